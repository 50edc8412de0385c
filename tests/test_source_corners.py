"""Every source function at its corner cases, as a run evaluates it (the tabulation of
``lcs.simulation.inputs.InputTable``, one-sided limits at jumps), against ngspice's ``.tran``
of the same sources across resistors, sampled at ngspice's own time points (TMAX small so
that ngspice lands near every corner)."""


import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from lcs.signals import Pulse, resolve
from lcs.simulation.inputs import InputTable, has_jumps
from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import transient_setup

# name -> (waveform, what is special about it)
SOURCES = {
    "zero_edges": ("PULSE(0 1 1u 0 0 2u 5u)", "TR = TF = 0 are TSTEP"),
    "pw_zero": ("PULSE(0 1 0 2u 2u 0 4u)",
                "PW = 0 is TSTOP in ngspice: not a triangle but a ramp up, then high, and a "
                "jump back to 0 at every period start"),
    "delay": ("PULSE(0 1 3u 1u 1u 2u 6u)", "TD > 0"),
    "cut_fall": ("PULSE(0 1 0 1u 2u 3u 5u)", "PER < TR + PW + TF: the fall is cut at 0.5"),
    "duty_one": ("PULSE(0 1 0 10n 10n 1.99u 2u)", "TR + PW = PER: high until the period end"),
    "count": ("PULSE(0 1 0 1u 1u 1u 4u 2)", "NP = 2: two pulses, then V1"),
    "count_cut": ("PULSE(0 1 0 1u 2u 1.5u 3u 2)", "NP = 2 of a cut pulse"),
    "sin": ("SIN(1 2 100k 3u 2e4 30)", "delay, damping and phase"),
    "exp": ("EXP(0 4 2u 3u 10u 5u)", "rise and fall"),
    "pwl": ("PWL(0 0 5u 3 10u 3 12u -1)", "corners, constant after the last point"),
    "pwl_jump": ("PWL(0 0 5u 1 5u 3 12u -1)", "a jump"),
    "pwl_repeat": ("PWL(0 0 1u 1 2.5u 0) r=0", "a triangle repeated for ever"),
    "pwl_repeat_from": ("PWL(0 0 1u 1 3u 0.5) r=1u td=2u",
                        "delayed, the part from 1 us repeated: a sawtooth from 1 to 0.5"),
}


def _deck(tstep="0.1u", tstop="20u", tmax="0.02u") -> str:
    lines = ["sources"]
    for i, (name, (wave, _)) in enumerate(SOURCES.items()):
        lines += [f"V{i} {name} 0 {wave}", f"R{i} {name} 0 1k"]
    lines.append(f".tran {tstep} {tstop} 0 {tmax}")
    return "\n".join(lines) + "\n"


def test_pulse_edges_outlasting_the_period_jump_at_period_starts():
    p = resolve(Pulse(0, 1, 0, 1e-6, 2e-6, 3e-6, 5e-6), 1e-7, 20e-6)
    assert p.jumps
    t = np.array([4.9e-6, 5e-6, 5.5e-6, 10e-6])
    np.testing.assert_allclose(p(t, -1), [0.55, 0.5, 0.5, 0.5], atol=1e-12)
    np.testing.assert_allclose(p(t, +1), [0.55, 0.0, 0.5, 0.0], atol=1e-12)
    # the breakpoints: period starts and the edges before the period's end, no later edge
    np.testing.assert_allclose(p.breakpoints(0, 10e-6), [0, 1e-6, 4e-6, 5e-6, 6e-6, 9e-6, 10e-6])
    # duty 1 (the buck's --param duty=1.0): high until each period's end, not a ramp down
    g = resolve(Pulse(0, 1, 0, 10e-9, 10e-9, 20e-6 - 10e-9, 20e-6), 0.2e-6, 5e-3)
    table = InputTable([g], 0.0, 100e-6)
    tt = np.linspace(0, 100e-6, 10001)
    vals = table(tt)[:, 0]
    assert has_jumps([g]) and np.mean(vals) > 0.999
    # period starts within round-off: 9.8e-4 / 2e-5 exceeds 49 by an ulp; the left limit
    # there is the end of period 48 (high), the right limit the start of period 49
    ends = np.arange(1, 250) * 20e-6
    assert np.all(g(ends, -1) == 1.0) and np.all(g(ends, +1) == 0.0)
    # PW = 0 is replaced by TSTOP (ngspice), not kept as a zero-width top
    assert resolve(Pulse(0, 1, 0, 2e-6, 2e-6, 0, 4e-6), 1e-7, 20e-6).pw == 20e-6


def test_sources_match_ngspice_at_its_time_points(ngspice, tmp_path):
    deck = _deck()
    names = list(SOURCES)
    data = ngspice_wrdata(deck + ".end\n", [f"v({n})" for n in names], tmp_path, timeout=60)
    t = data[:, 0]
    setup = transient_setup(parse_string(deck + ".end\n"))
    order = [setup.system.inputs.index(f"V{i}") for i in range(len(names))]
    sig = [setup.signals[j] for j in order]
    table = InputTable(sig, 0.0, 20e-6)
    ours, left, right = table(t), table(t, -1), table(t, +1)
    for k, name in enumerate(names):
        theirs = data[:, 2 * k + 1]
        # at a jump instant ngspice takes one side or the other (its period wrap is
        # `time > PER`); everywhere else the values are the same
        tol = 1e-8 * np.maximum(1.0, np.abs(theirs))  # wrdata prints 9 digits
        ok = ((np.abs(ours[:, k] - theirs) < tol) | (np.abs(left[:, k] - theirs) < tol)
              | (np.abs(right[:, k] - theirs) < tol))
        assert ok.all(), (name, t[~ok][:5], ours[~ok, k][:5], theirs[~ok][:5])


@pytest.mark.parametrize("name", ["pw_zero", "cut_fall", "duty_one", "count_cut",
                                  "pwl_repeat_from"])
def test_jumping_pulses_are_evaluated_by_limits(name):
    setup = transient_setup(parse_string(_deck() + ".end\n"))
    i = list(SOURCES).index(name)
    sig = setup.signals[setup.system.inputs.index(f"V{i}")]
    assert sig.jumps


def test_pwl_repeat_by_hand_and_its_errors():
    setup = transient_setup(parse_string(_deck() + ".end\n"))
    i = list(SOURCES).index("pwl_repeat_from")
    w = setup.signals[setup.system.inputs.index(f"V{i}")]
    # 1 at 3 us, down to 0.5 at 5 us, where the part from 1 us starts again: 1 at 5 us
    t = np.array([0.0, 2e-6, 3e-6, 5e-6, 6e-6, 7e-6, 8e-6])
    np.testing.assert_allclose(w(t), [0, 0, 1, 1, 0.75, 1.0, 0.75], atol=1e-12)
    np.testing.assert_allclose(w(np.array([7e-6]), -1), [0.5], atol=1e-12)
    np.testing.assert_allclose(w.breakpoints(0, 10e-6), [2e-6, 3e-6, 5e-6, 7e-6, 9e-6])
    with pytest.raises(NetlistError, match="not one of its times") as exc:
        parse_string("p\nV1 a 0 PWL(0 0 1u 1 2u 0) r=0.5u\nR1 a 0 1\n.tran 1n 5u\n.end\n")
    assert "r=" in exc.value.format()
    with pytest.raises(NetlistError, match="unsupported parameter 'q'"):
        parse_string("p\nV1 a 0 PWL(0 0 1u 1 2u 0) q=0\nR1 a 0 1\n.tran 1n 5u\n.end\n")


BUCK = "converters/netlists/buck.cir"


def _mean_late(t, v, after=4e-3):
    late = t > after
    return np.trapezoid(v[late], t[late]) / np.ptp(t[late])


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_buck_at_duty_one_holds_the_switch_on(ngspice, tmp_path):
    # PW = duty * ts - 10 ns with 10 ns edges: at duty >= 1 the fall never starts within the
    # period, and the gate dips to 0 for the first 10 ns of each (the switch off for 5 ns).
    # Before: the tabulation ramped the gate down over every period, mean v(out) 14.5 V, and
    # duty 0.5, 1 and 2 gave 12.0, 14.5 and 14.5 V. ngspice: 24.01 V (TMAX 20 ns; its 23.9 V
    # at the netlist's TMAX of 0.2 us samples the 10 ns dip coarsely).
    from pelcs.api import simulate

    means = {d: _mean_late(*(lambda r: (r.t, r["v(out)"]))(
        simulate(BUCK, params={"duty": d}, probes=["v(out)"]))) for d in (0.5, 1.0, 2.0)}
    assert means[0.5] == pytest.approx(12.0, rel=0.01)
    assert means[1.0] == means[2.0]
    deck = open(BUCK).read().replace("duty=0.5", "duty=1.0").replace(
        ".tran 0.2u 5m 0 0.2u UIC", ".tran 0.2u 5m 0 0.02u UIC").replace(".end\n", "")
    data = ngspice_wrdata(deck + ".end\n", ["v(out)"], tmp_path)
    assert means[1.0] == pytest.approx(_mean_late(data[:, 0], data[:, 1]), rel=1e-3)
