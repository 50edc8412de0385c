"""Source waveforms against hand values and against ngspice's own evaluation."""


import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from lcs.signals import Dc, Exp, Pulse, Pwl, Sin, resolve

TSTEP, TSTOP = 0.1e-6, 40e-6

WAVEFORMS = {
    "a": Pulse(0, 5, 1e-6, 2e-6, 3e-6, 4e-6, 20e-6),
    "b": Sin(1, 2, 50e3, 3e-6, 1e4, 30),
    "c": Exp(0, 4, 2e-6, 3e-6, 10e-6, 5e-6),
    "d": Pwl((0, 5e-6, 10e-6, 12e-6), (0, 3, 3, -1)),
    "e": Pulse(1, -2, 0, 0, 0, 5e-6, 10e-6),  # TR = TF = 0 become TSTEP, as in ngspice
}

NETLIST = """sources
V1 a 0 PULSE(0 5 1u 2u 3u 4u 20u)
V2 b 0 SIN(1 2 50k 3u 1e4 30)
V3 c 0 EXP(0 4 2u 3u 10u 5u)
V4 d 0 PWL(0 0 5u 3 10u 3 12u -1)
V5 e 0 PULSE(1 -2 0 0 0 5u 10u)
R1 a 0 1k
R2 b 0 1k
R3 c 0 1k
R4 d 0 1k
R5 e 0 1k
.tran 0.1u 40u 0 0.05u
.end
"""


def test_pulse_by_hand():
    p = resolve(Pulse(0, 5, 1e-6, 2e-6, 3e-6, 4e-6, 20e-6), TSTEP, TSTOP)
    t = np.array([0, 1e-6, 2e-6, 3e-6, 5e-6, 7e-6, 8.5e-6, 10e-6, 21e-6, 22e-6])
    expected = [0, 0, 2.5, 5, 5, 5, 2.5, 0, 0, 2.5]
    np.testing.assert_allclose(p(t), expected, atol=1e-12)
    np.testing.assert_allclose(p.breakpoints(0, 25e-6), [1e-6, 3e-6, 7e-6, 10e-6, 21e-6, 23e-6])


def test_pulse_defaults_come_from_tran():
    p = resolve(Pulse(0, 1), 1e-6, 1e-3)
    assert (p.tr, p.tf, p.pw, p.per) == (1e-6, 1e-6, 1e-3, 1e-3)


def test_pulse_count_limits_the_train():
    p = resolve(Pulse(0, 1, 0, 1e-9, 1e-9, 1e-6, 2e-6, 2), TSTEP, TSTOP)
    assert p(np.array([0.5e-6, 2.5e-6, 4.5e-6]))[2] == 0  # third pulse absent
    assert p(np.array([2.5e-6]))[0] == 1


def test_sin_exp_pwl_dc_by_hand():
    s = resolve(Sin(1, 2, 50e3, 3e-6, 0, 90), TSTEP, TSTOP)
    assert s(np.array([0.0]))[0] == pytest.approx(3.0)  # before TD: VO + VA sin(phase)
    assert s(np.array([3e-6 + 5e-6]))[0] == pytest.approx(1.0, abs=1e-12)  # quarter period
    e = resolve(Exp(0, 4, 2e-6, 3e-6, 10e-6, 5e-6), TSTEP, TSTOP)
    assert e(np.array([5e-6]))[0] == pytest.approx(4 * (1 - np.exp(-1)))
    w = Pwl((0, 5e-6, 10e-6), (0, 3, 1))
    np.testing.assert_allclose(w(np.array([-1, 2.5e-6, 7.5e-6, 1])), [0, 1.5, 2, 1])
    np.testing.assert_allclose(Dc(3.3)(np.zeros(3)), 3.3)


def test_unresolved_defaults_are_an_error():
    with pytest.raises(ValueError, match="resolve"):
        Pulse(0, 1)(np.zeros(1))


def test_waveforms_match_ngspice(tmp_path):
    data = ngspice_wrdata(NETLIST, [f"v({k})" for k in "abcde"], tmp_path, timeout=60)
    t = data[:, 0]
    for col, key in enumerate("abcde"):
        ours = resolve(WAVEFORMS[key], TSTEP, TSTOP)(t)
        np.testing.assert_allclose(ours, data[:, 2 * col + 1], atol=1e-9, err_msg=key)


def test_inputs_by_row_blocks_equal_each_source_on_its_own(monkeypatch):
    # evaluate_inputs and InputTable fill their (N, p) array a block of rows at a time; with
    # blocks of 7 rows (a last block short) every column is still the source itself on the
    # whole time array, bit for bit: tabulated PULSE/PWL/DC by np.interp, a SIN called, a PWL
    # with a jump by its one-sided limits.
    import lcs.simulation.inputs as inputs
    from lcs.signals import Dc, Pulse, Pwl, Sin

    sources = [Pulse(0.0, 5.0, 1e-6, 1e-7, 1e-7, 4e-6, 1e-5), Dc(3.3),
               Pwl((0.0, 2e-5, 4e-5), (0.0, 1.0, -2.0)), Sin(0.0, 2.0, 5e4),
               Pwl((0.0, 1e-5, 1e-5, 5e-5), (0.0, 1.0, 3.0, 3.0))]
    t = np.linspace(0.0, 5e-5, 100)
    full = inputs.evaluate_inputs(sources, t)
    monkeypatch.setattr(inputs, "ROW_BLOCK", 7)
    for side in (0, 1, -1):
        got = inputs.evaluate_inputs(sources, t, side)
        assert got.shape == (100, 5) and got.flags.c_contiguous
        for j, f in enumerate(sources):
            ref = (f(t, side) if side and getattr(f, "jumps", False)
                   else np.broadcast_to(f(t), t.shape))
            assert np.array_equal(got[:, j], ref), (side, j)
    table = inputs.InputTable(sources, 0.0, 5e-5)
    for side in (0, 1, -1):
        got = table(t, side)
        assert np.array_equal(got[:, [1, 3]], full[:, [1, 3]])
        assert np.allclose(got, inputs.evaluate_inputs(sources, t, side), rtol=0, atol=1e-12)
    assert inputs.evaluate_inputs(sources, np.empty(0)).shape == (0, 5)
    assert inputs.evaluate_inputs([], t).shape == (100, 0)


def _snapped_in_turn(tau, edges, tol):
    """The PULSE's edge snapping as written first: each edge in turn."""
    for edge in edges:
        tau = np.where(np.abs(tau - edge) <= tol, edge, tau)
    return tau


def test_edges_snapped_at_once_as_in_turn():
    # Edges more than four tolerances apart are snapped by one comparison of every instant
    # with every edge; closer ones (a 1e-30 s rise) in turn: both as the loop gives them.
    from lcs.signals import _snap_to_edges

    rng = np.random.default_rng(4)
    for edges in [(0.0, 1e-8, 8e-6, 8.01e-6, 2e-5), (0.0, 1e-30, 2e-30, 1e-6, 1e-6),
                  (0.0, 3e-6, 9e-6, 1.2e-5, 1e-5), (0.0, 1e-3, 1e-3 + 5e-17, 2e-3, 3e-3)]:
        e = np.array(edges)
        tau = np.concatenate([rng.uniform(-1e-6, 3e-3, 200), e, np.nextafter(e, 1.0),
                              np.nextafter(e, -1.0), e + 1e-19, e - 3e-20, [np.nan]])
        tol = 16 * np.finfo(float).eps * (np.abs(tau) + 2e-5)
        got = tau.copy()
        _snap_to_edges(got, edges, tol)
        want = _snapped_in_turn(tau, edges, tol)
        assert got.view(np.int64).tolist() == want.view(np.int64).tolist(), edges


def test_inputs_at_one_instant_are_the_sources_calls():
    # evaluate_inputs takes a PULSE at one instant without its array, a DC source as its
    # value: the bits of their calls, one-sided limits where a pulse jumps.
    from lcs.simulation.inputs import evaluate_inputs

    sources = [Pulse(0.0, 1.0, 0.0, 1e-8, 1e-8, 8e-6, 2e-5),
               Pulse(0.0, 5.0, 1e-6, 3e-6, 4e-6, 9e-6, 1e-5),  # edges past the period
               Pulse(1.0, 2.0, 0.0, 1e-6, 1e-6, 2e-6, 1e-5, 2.5), Dc(-0.0), Dc(3.3)]
    instants = [0.0, 1e-8, 8.01e-6, 1e-5, 1.9e-5, 2e-5, 2.5e-5, 4e-5, np.inf, np.nan]
    with np.errstate(invalid="ignore"):  # (at infinity: inf - inf, NaN as meant)
        for x, side in [(x, side) for x in instants for side in (-1, 0, 1)]:
            got = evaluate_inputs(sources, np.array([x]), side)[0]
            for j, f in enumerate(sources):
                ref = f(np.array([x]), side) if side and getattr(f, "jumps", False) \
                    else f(np.array([x]))
                assert got[j:j + 1].view(np.int64).tolist() == \
                    np.asarray(ref, dtype=float).view(np.int64).tolist(), (x, side, j)
