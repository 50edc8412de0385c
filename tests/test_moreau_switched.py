"""Moreau stepping of switched LCS driven by independent gate sources: a hand-built buck
converter (SwitchedLCS with a builder), exact switching instants, continuity, agreement with
the independent reference, DCM, hysteresis, smooth and discontinuous gates."""

from __future__ import annotations

import numpy as np
import pytest
from test_moreau_reference import moreau_reference

from lcs.integrators.moreau.integrator import simulate
from lcs.model import LCS, ComplementarityPair, ModeModel, OutputMap, SwitchControl, SwitchedLCS
from lcs.signals import Dc, Pulse, Pwl, Sin

VIN, L, C = 12.0, 100e-6, 100e-6
TD, TR, TF, PW, PER = 10e-6, 1e-6, 1e-6, 48e-6, 100e-6


def buck(R: float, vt: float = 2.5, vh: float = 0.0, control: str = "v(g)") -> SwitchedLCS:
    """Vin -- S1 -- node a; D1 from ground (anode) to a; L1 from a to out; C1 || R from out
    to ground. Inputs (Vin, Vg): Vg only drives the gate. States (i(L1), v(C1)).

    On: v(a) = Vin, the diode is reverse biased by Vin: λ = i(D1), w = v(a) = Vin.
    Off: i(D1) = i(L1): λ = reverse voltage v(a), w = i(D1) = i(L1) (DCM when λ > 0).
    """
    A = np.array([[0.0, -1 / L], [1 / C, -1 / (R * C)]])

    def build(key):
        (on,) = key
        if on:
            lcs = LCS(A, np.zeros((2, 1)), np.zeros((1, 2)), np.zeros((1, 1)),
                      np.array([[1 / L, 0.0], [0.0, 0.0]]), np.array([[1.0, 0.0]]),
                      ("i(L1)", "v(C1)"), (ComplementarityPair("D1", "current"),),
                      ("Vin", "Vg"))
            rows = {"v(a)": ([0, 0], [0], [1, 0]), "i(d1)": ([0, 0], [1], [0, 0])}
        else:
            lcs = LCS(A, np.array([[1 / L], [0.0]]), np.array([[1.0, 0.0]]), np.zeros((1, 1)),
                      np.zeros((2, 2)), np.zeros((1, 2)), ("i(L1)", "v(C1)"),
                      (ComplementarityPair("D1", "voltage"),), ("Vin", "Vg"))
            rows = {"v(a)": ([0, 0], [1], [0, 0]), "i(d1)": ([1, 0], [0], [0, 0])}
        rows["v(g)"] = ([0, 0], [0], [0, 1])
        rows["v(c1)"] = ([0, 1], [0], [0, 0])
        rows["v(g,c1)"] = ([0, -1], [0], [0, 1])

        def output(names):
            sel = [rows[nm.lower()] for nm in names]
            return OutputMap(tuple(names), np.array([r[0] for r in sel], float),
                             np.array([r[1] for r in sel], float),
                             np.array([r[2] for r in sel], float))

        return ModeModel(lcs, output)

    return SwitchedLCS([SwitchControl("S1", control, vt=vt, vh=vh)], ("i(L1)", "v(C1)"),
                       ("Vin", "Vg"), ("D1",), build)


def gate():
    return Pulse(0.0, 5.0, TD, TR, TF, PW, PER)


def expected_instants(t_stop, frac_on=0.5, frac_off=0.5):
    k = np.arange(0, int(t_stop / PER) + 1)
    on = TD + k * PER + frac_on * TR
    off = TD + k * PER + TR + PW + frac_off * TF
    return on[on < t_stop], off[off < t_stop]


def test_switching_instants_exact_and_on_grid():
    t_stop = 0.5e-3
    res = simulate(buck(2.0), [Dc(VIN), gate()], [0.0, 0.0], t_stop, 0.3e-6,
                   probes=["i(L1)", "v(C1)", "v(a)", "i(D1)"])
    assert res.ok
    on, off = expected_instants(t_stop)
    t_ev = np.array([t for t, _ in res.events])
    modes = [md for _, md in res.events]
    np.testing.assert_allclose(t_ev[0::2], on, rtol=1e-14)
    np.testing.assert_allclose(t_ev[1::2], off, rtol=1e-14)
    assert modes[0::2] == [(True,)] * len(on) and modes[1::2] == [(False,)] * len(off)
    assert res.modes_visited == [(False,), (True,)]
    # Every switching instant is a step boundary (the step crossing it was shortened).
    for t in t_ev:
        assert np.min(np.abs(res.t - t)) <= 1e-15 * t
    assert res.stats.odd_steps > 0
    # v(a) = Vin while on, 0 while freewheeling (CCM).
    mid = 0.5 * (on[-1] + off[-1])
    j = np.argmin(np.abs(res.t - mid))
    assert res["v(a)"][j] == pytest.approx(VIN)
    j = np.argmin(np.abs(res.t - (off[-1] + 10e-6)))
    assert res["v(a)"][j] == pytest.approx(0.0, abs=1e-9)
    assert res["i(D1)"][j] == pytest.approx(res["i(L1)"][j])


def test_state_continuous_across_switching_and_matches_reference():
    t_stop = 0.3e-3
    h = 0.25e-6
    res = simulate(buck(2.0), [Dc(VIN), gate()], [0.0, 0.0], t_stop, h)
    on, off = expected_instants(t_stop)

    def mode_at(t):
        return bool(np.any((t >= on) & (t < off[: len(on)] if len(off) >= len(on)
                                         else np.append(off, np.inf)[: len(on)])))

    sys_ = buck(2.0)
    mats = {}
    for key in ((False,), (True,)):
        lcs = sys_.mode(key)
        mats[key] = (lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, lcs.F)

    def per_step(k):
        return mats[(mode_at(0.5 * (res.t[k] + res.t[k + 1])),)]

    u = lambda t: np.array([VIN, float(gate()(t))])  # noqa: E731
    xs, _ = moreau_reference(*mats[(False,)], u, [0.0, 0.0], res.t, 0.5, per_step)
    np.testing.assert_allclose(res.y / np.abs(xs).max(axis=0), xs / np.abs(xs).max(axis=0),
                               rtol=0, atol=1e-10)
    # Continuity: the inductor current never moves faster than Vin / L allows.
    di = np.abs(np.diff(res["i(L1)"]))
    assert np.all(di <= VIN / L * np.diff(res.t) * 1.001)


def test_ccm_average_and_dcm_blocking():
    h = 0.2e-6
    duty = (PW + 0.5 * TR + 0.5 * TF) / PER
    res = simulate(buck(2.0), [Dc(VIN), gate()], [0.0, 0.0], 6e-3, h, every=5)
    last = res.t > res.t[-1] - PER
    v_avg = np.trapezoid(res["v(C1)"][last], res.t[last]) / (res.t[last][-1] - res.t[last][0])
    assert v_avg == pytest.approx(duty * VIN, rel=0.03)
    assert res["i(L1)"][last].min() > 0  # CCM
    # Light load: DCM, the diode blocks (λ = v(a) > 0) and keeps i(L1) = 0.
    res = simulate(buck(40.0), [Dc(VIN), gate()], [0.0, 0.0], 2e-3, h)
    i = res["i(L1)"]
    assert i.min() >= -1e-12
    assert (i[res.t > 1e-3] == 0.0).sum() > 100


def test_finite_rise_time_and_hysteresis():
    # Threshold 2.5 V ± 1 V: on above 3.5 V (70 % of the rise), off below 1.5 V (70 % of
    # the fall).
    t_stop = 0.25e-3
    res = simulate(buck(2.0, vt=2.5, vh=1.0), [Dc(VIN), gate()], [0.0, 0.0], t_stop, 0.3e-6)
    on, off = expected_instants(t_stop, 0.7, 0.7)
    t_ev = np.array([t for t, _ in res.events])
    np.testing.assert_allclose(t_ev[0::2], on, rtol=1e-14)
    np.testing.assert_allclose(t_ev[1::2], off, rtol=1e-14)


def test_sine_gate_root_finding():
    f = 10e3
    t_stop = 150e-6
    res = simulate(buck(2.0), [Dc(VIN), Sin(0.0, 5.0, f)], [0.0, 0.0], t_stop, 0.3e-6)
    w = 2 * np.pi * f
    # 5 sin(wt) > 2.5: on at wt = π/6 (+2πk), off at 5π/6.
    expected = np.sort(np.concatenate([(np.pi / 6 + 2 * np.pi * np.arange(2)) / w,
                                       (5 * np.pi / 6 + 2 * np.pi * np.arange(2)) / w]))
    t_ev = np.array([t for t, _ in res.events])
    np.testing.assert_allclose(t_ev, expected, rtol=1e-12)


def test_pwl_gate_with_jumps():
    g = Pwl((0.0, 20e-6, 20e-6, 50e-6, 50e-6), (0.0, 0.0, 5.0, 5.0, 0.0))
    res = simulate(buck(2.0), [Dc(VIN), g], [0.0, 0.0], 80e-6, 0.3e-6,
                   probes=["i(L1)", "v(g)"])
    assert [(t, md) for t, md in res.events] == [(20e-6, (True,)), (50e-6, (False,))]
    # i(L1) rises only while on: the slope changes exactly at the jumps.
    i = res["i(L1)"]
    assert np.all(i[res.t <= 20e-6] == 0.0)
    # (v(C1) stays small over 30 µs: the ramp is Vin / L to within a few per cent.)
    assert i[np.searchsorted(res.t, 50e-6)] == pytest.approx(VIN / L * 30e-6, rel=0.05)


def test_initially_on_and_gate_in_band():
    # A gate at the threshold (in the hysteresis band) keeps the initial state: off by
    # default, on with options={"on": True}.
    sys_ = buck(2.0, vt=2.5, vh=1.0)
    res = simulate(sys_, [Dc(VIN), Dc(2.5)], [0.0, 0.0], 20e-6, 1e-6)
    assert res.modes_visited == [(False,)] and res["i(L1)"][-1] == 0.0
    sys_.switches[0].options["on"] = True
    res = simulate(sys_, [Dc(VIN), Dc(2.5)], [0.0, 0.0], 20e-6, 1e-6)
    assert res.modes_visited == [(True,)] and res["i(L1)"][-1] > 0.0


def test_state_dependent_switch_is_a_located_comparator():
    # Gate v(g) - v(C1) with a 2.5 V gate source: a bang-bang regulator, on while
    # v(C1) < 2.5 V (with hysteresis: the band edges are crossed exactly by the numerical
    # solution at the recorded instants).
    sys_ = buck(2.0, vt=0.0, vh=0.1, control="v(g,c1)")
    res = simulate(sys_, [Dc(VIN), Dc(2.5)], [0.0, 0.0], 2e-3, 0.5e-6,
                   probes=["i(L1)", "v(C1)"])
    assert res.ok and res.switching == {"S1": "hysteresis"}
    assert res.stats.located == len(res.events) > 10
    t_ev = np.array([t for t, _ in res.events])
    v_at = np.interp(t_ev, res.t, res["v(C1)"])
    # Turn-off where v(C1) rises to 2.6 V, turn-on where it falls to 2.4 V.
    on = np.array([md[0] for _, md in res.events])
    np.testing.assert_allclose(v_at[~on], 2.6, atol=1e-9)
    np.testing.assert_allclose(v_at[on][1:], 2.4, atol=1e-9)


def test_initial_option_from_netlist():
    sys_ = buck(2.0, vt=2.5, vh=1.0)
    sys_.switches[0].options["initial"] = True
    res = simulate(sys_, [Dc(VIN), Dc(2.5)], [0.0, 0.0], 20e-6, 1e-6)
    assert res.modes_visited == [(True,)]
