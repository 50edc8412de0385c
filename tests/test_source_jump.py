"""A source-driven switch whose control jumps over its threshold and crosses back inside the
same segment, on the planner's general path (control rows that depend on the switch states,
:mod:`lcs.simulation.source_general`): both switchings, from the control's value just after the
jump (hand-derived instants); and switches that switch each other in zero time: refused by
name, never a hang."""

from __future__ import annotations

import numpy as np
import pytest

from lcs.model import (
    IDEALISED_OPTION,
    LCS,
    ComplementarityPair,
    ModeModel,
    OutputMap,
    SwitchControl,
    SwitchedLCS,
)
from lcs.signals import Pwl, resolve
from lcs.simulation.inputs import collect_breakpoints
from lcs.simulation.source_switching import source_switch_events


def _system(controls, switches) -> SwitchedLCS:
    """A system whose switch controls are ``controls(mode)`` (rows over the inputs ``en`` and
    ``saw``); its LCS is a placeholder (the planner reads only the controls)."""

    def builder(mode):
        one = np.ones((1, 1))
        lcs = LCS(A=-one, B=one, C=-one, D=one, E=np.zeros((1, 2)), F=np.zeros((1, 2)),
                  states=("x",), pairs=(ComplementarityPair("D"),), inputs=("en", "saw"))

        def outputs(names):
            rows = controls(mode)
            fy = np.array([rows[int(n[1:]) - 1] for n in names], dtype=float)
            return OutputMap(tuple(names), np.zeros((len(names), 1)),
                             np.zeros((len(names), 1)), fy)

        return ModeModel(lcs, outputs)

    return SwitchedLCS(switches, ("x",), ("en", "saw"), ("D",), builder)


# S1 is the enable (its control the input en); S2 is an idealised transistor whose gate is the
# sawtooth while S1 is on, and held at 0 otherwise (a gate through an enable switch, a
# resistor to ground): its control rows depend on S1's state.
def _gated(mode):
    return [[1.0, 0.0], [0.0, 1.0 if mode[0] else 0.0]]


SWITCHES = [SwitchControl("S1", "c1", vt=0.5, vh=0.0),
            SwitchControl("S2", "c2", vt=2.0, vh=0.0, options={IDEALISED_OPTION: True})]


def _plan(system, en, saw, t1=5e-3):
    inputs = [resolve(en, 1e-6, t1), resolve(saw, 1e-6, t1)]
    mode0, ev = source_switch_events(system, inputs, 0.0, t1,
                                     collect_breakpoints(inputs, 0.0, t1), 1e-6)
    return mode0, [(round(t * 1e3, 9), m) for t, m in ev]


def test_a_jump_at_a_breakpoint_and_the_crossing_back_both_switch():
    # en steps to 1 at 1 ms; the sawtooth jumps from 0 to 5 V at 2 ms and falls back to 0 at
    # 3 ms: over VT = 2 V at 2 ms (S2 on), back through it at 2 + (5 - 2)/5 = 2.6 ms (off)
    en = Pwl([0.0, 1e-3, 1e-3, 5e-3], [0.0, 0.0, 1.0, 1.0])
    saw = Pwl([0.0, 2e-3, 2e-3, 3e-3, 5e-3], [0.0, 0.0, 5.0, 0.0, 0.0])
    mode0, ev = _plan(_system(_gated, SWITCHES), en, saw)
    assert mode0 == (False, False)
    assert ev == [(1.0, (True, False)), (2.0, (True, True)), (2.6, (True, False))]


def test_a_jump_by_a_mode_change_and_the_crossing_back_both_switch():
    # the sawtooth already falls from 5 V (2 ms) when en steps to 1 at 2.2 ms: S2's gate
    # jumps from 0 to 4 V as S1 turns on, and falls through 2 V at 2.6 ms
    en = Pwl([0.0, 2.2e-3, 2.2e-3, 5e-3], [0.0, 0.0, 1.0, 1.0])
    saw = Pwl([0.0, 2e-3, 2e-3, 3e-3, 5e-3], [0.0, 0.0, 5.0, 0.0, 0.0])
    _, ev = _plan(_system(_gated, SWITCHES), en, saw)
    assert ev == [(2.2, (True, True)), (2.6, (True, False))]


def test_a_jump_down_with_hysteresis_and_the_crossing_back_up():
    # S2 with VH = 0.5 (band [1.5, 2.5], keeps its state inside): the sawtooth rises from 0 to
    # 5 V over [1, 3] ms, jumps to 0 at 3 ms (off: below the band, not into it), and rises
    # again from 0 at 3 ms to 5 V at 5 ms: on again above 2.5 V at 3 + 2.5/5 * 2 = 4 ms
    sw = [SWITCHES[0], SwitchControl("S2", "c2", vt=2.0, vh=0.5)]
    en = Pwl([0.0, 0.5e-3, 0.5e-3, 6e-3], [0.0, 0.0, 1.0, 1.0])
    saw = Pwl([0.0, 1e-3, 3e-3, 3e-3, 5e-3, 6e-3], [0.0, 0.0, 5.0, 0.0, 5.0, 5.0])
    _, ev = _plan(_system(_gated, sw), en, saw, t1=6e-3)
    # on above 2.5 V at 1 + 2.5/5 * 2 = 2 ms; off at the jump (3 ms); on at 4 ms
    assert ev == [(0.5, (True, False)), (2.0, (True, True)), (3.0, (True, False)),
                  (4.0, (True, True))]


def test_switches_that_switch_each_other_in_zero_time_are_refused_by_name():
    # S2 on turns S1's control negative, S2 off turns it positive, and S1 drives S2: from
    # 1 ms, when en steps to 1, no state of the pair is consistent
    def loop(mode):
        return [[-1.0 if mode[1] else 1.0, 0.0], [4.0 if mode[0] else 0.0, 0.0]]

    en = Pwl([0.0, 1e-3, 1e-3, 5e-3], [0.0, 0.0, 1.0, 1.0])
    saw = Pwl([0.0, 5e-3], [0.0, 0.0])
    with pytest.raises(NotImplementedError, match=r"switches S1, S2 switch each other at "
                       r"t = 0\.001 s without settling"):
        _plan(_system(loop, SWITCHES), en, saw)


def test_a_gate_held_at_zero_when_its_enable_turns_off_turns_its_switch_off():
    # S2 on at the sawtooth's jump (2 ms); S1 off at 2.4 ms, when the sawtooth is still at
    # 3 V: S2's gate falls to 0 with it (a row of zeros in that mode), and S2 turns off
    en = Pwl([0.0, 0.5e-3, 0.5e-3, 2.4e-3, 2.4e-3, 5e-3], [0.0, 0.0, 1.0, 1.0, 0.0, 0.0])
    saw = Pwl([0.0, 2e-3, 2e-3, 3e-3, 5e-3], [0.0, 0.0, 5.0, 0.0, 0.0])
    _, ev = _plan(_system(_gated, SWITCHES), en, saw)
    assert ev == [(0.5, (True, False)), (2.0, (True, True)), (2.4, (False, False))]


# S1's gate is a falling sawtooth (5 V to 0 over each 10 µs period; TR = PER, so it jumps
# back to 5 V at each period start, as ngspice cuts it) through the enable switch S2, and held
# at 0 by Rg while S2 is off: S1's control rows depend on S2's state. S1 (band [1.5, 2.5] V,
# VH > 0) turns on at each jump and off when the sawtooth falls through 1.5 V, 7 µs later;
# the enable (on over 0.5 ns .. 43.0015 µs of each 100 µs) switches the gate in while it is
# high (S1 on with S2) and out while S1 is on (S1 off with S2).
ENABLED = """a sawtooth gate through an enable switch, jumping over the threshold at each period
Vin in 0 DC 12
Vp p 0 PULSE(5 0 0 10u 10n 0 10u)
Ven en 0 PULSE(0 1 0 1n 1n 43u 100u)
S2 p gate en 0 SWE
.model SWE SW(VT=0.5 VH=0 RON=1m ROFF=1e12)
Rg gate 0 1k
S1 in out gate 0 SWH
.model SWH SW(VT=2 VH=0.5 RON=1m ROFF=1e12)
R1 out 0 10
.tran 10n 200u 0 10n
.end
"""


def _enabled_instants() -> np.ndarray:
    """S1's switching instants (s), by hand: per 100 µs enable period, on at 0.5 ns, off 7 µs
    into each sawtooth period, on at its next start, off with the enable at 43.0015 µs."""
    one = [0.5e-9, 7e-6, 10e-6, 17e-6, 20e-6, 27e-6, 30e-6, 37e-6, 40e-6, 43.0015e-6]
    return np.array(one + [t + 100e-6 for t in one])


def test_a_sawtooth_gate_through_an_enable_switch_against_ngspice(tmp_path, ngspice):
    from ngspice_helpers import ngspice_wrdata

    from pelcs.api import simulate

    res = simulate(ENABLED, probes=["v(out)"])
    # (modes in the netlist's order: S2, S1)
    events = list(res.events)
    s1 = [t for (t, m), (_, prev) in zip(events, [(0.0, (False, False))] + events[:-1],
                                         strict=True) if m[1] != prev[1]]
    want = _enabled_instants()
    # two switchings per sawtooth period while enabled (analytic)
    assert len(s1) == len(want) == 20
    assert np.max(np.abs(np.array(s1) - want)) < 1e-15, np.array(s1) - want
    # ngspice: v(out) is 12 V while S1 is on; its crossings of 6 V, within its 10 ns step
    ng = ngspice_wrdata(ENABLED, ["v(out)"], tmp_path)
    t, v = ng[:, 0], ng[:, 1]
    on = v > 6.0
    k = np.flatnonzero(on[1:] != on[:-1])
    cross = t[k] + (6.0 - v[k]) / (v[k + 1] - v[k]) * (t[k + 1] - t[k])
    assert len(cross) == 20
    assert np.max(np.abs(cross - want)) < 10e-9, np.abs(cross - want)
    # and pelcs' output itself at ngspice's points away from the switchings
    got = np.interp(t, res.t, res.y[:, 0])
    away = np.min(np.abs(t[:, None] - want[None, :]), axis=1) > 20e-9
    assert np.max(np.abs(got[away] - v[away])) < 12 * 1e-3, np.max(np.abs(got[away] - v[away]))


# S1 closes while v(en) - v(b) > 0.5, S2 while v(a) > 0.5; each pulls the other's control:
# when en rises, S1 on -> a = 1 -> S2 on -> b = 1 -> S1 off -> a = 0 -> S2 off -> S1 on ...
RING = """two switches that switch each other with no delay
Vu u 0 1
Ven en 0 PULSE(0 1 1u 1n 1n 5u 10u)
S1 u a en b SWA
Ra a 0 1k
S2 u b a 0 SWA
Rb b 0 1k
.model SWA SW(VT=0.5 VH=0)
.tran 10n 20u
.end
"""


def test_a_zero_time_loop_is_a_clear_error_of_the_command(tmp_path):
    import contextlib
    import io

    from pelcs.cli import main

    path = tmp_path / "ring.cir"
    path.write_text(RING)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        code = main(["simulate", str(path), "--no-progress"])
    out = buf.getvalue()
    assert code == 2, out
    assert ("not supported: switches S1, S2 switch each other at t = 1.0005e-06 s without "
            "settling") in out
    assert "Traceback" not in out


def test_a_gated_sine_jumps_over_the_threshold_and_crosses_back_by_root_finding():
    # (a sine: the general path samples and refines with brentq) S2's gate is 5 sin(2π 1k t)
    # while S1 is on, from 1.1 ms: it jumps to 5 sin(0.2π) = 2.94 V > 2 V there, falls through
    # 2 V at (π - asin 0.4)/(2π 1k) past the period start, rises through it at asin(0.4)/(...)
    from lcs.signals import Sin

    en = Pwl([0.0, 1.1e-3, 1.1e-3, 2.5e-3], [0.0, 0.0, 1.0, 1.0])
    mode0, ev = _plan(_system(_gated, SWITCHES), en, Sin(0.0, 5.0, 1e3), t1=2.5e-3)
    down = (np.pi - np.arcsin(0.4)) / (2 * np.pi)  # ms into a period
    up = np.arcsin(0.4) / (2 * np.pi)
    assert mode0 == (False, False)
    assert [m for _, m in ev] == [(True, True), (True, False), (True, True), (True, False)]
    assert np.allclose([t for t, _ in ev], [1.1, 1 + down, 2 + up, 2 + down], rtol=0,
                       atol=1e-9)


def _cli(tmp_path, deck: str, *args: str) -> tuple[int, str]:
    import contextlib
    import io

    from pelcs.cli import main

    path = tmp_path / "deck.cir"
    path.write_text(deck)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        code = main(["simulate", str(path), "--no-progress", *args])
    return code, buf.getvalue()


# Loops with no consistent state from the start. Both ran with exit 0 and values that
# contradict their own switches: the planner's fixed point of the initial states did not
# settle, and its last pass was run as it was (B1#s on with v(b) = 0 V; S2 on with v(a) = 0 V).
B_RING = """two comparators in an inverting loop with no delay
B1 a 0 V = V(b) > 0.5 ? 0 : 1
B2 b 0 V = V(a) > 0.5 ? 1 : 0
R1 a 0 1k
R2 b 0 1k
.tran 10n 10u
.end
"""


@pytest.mark.parametrize(("deck", "name"), [(B_RING, "switch B1#s"),
                                            (RING.replace("PULSE(0 1 1u 1n 1n 5u 10u)", "DC 1"),
                                             "switch S2")])
def test_a_loop_with_no_consistent_start_is_refused_by_name(tmp_path, deck, name):
    code, out = _cli(tmp_path, deck)
    assert code == 2, out
    assert f"not supported: {name}: the start does not settle (t = 0 s)" in out
    assert "final values" not in out and "Traceback" not in out


# A comparator reading its own output through a divider with the input: for 0 < v(in) < 1
# no state is consistent (off: v(m) = (1 + v(in))/2 > 0.5 turns it on; on: v(m) = v(in)/2
# < 0.5 turns it off). With a PWL input the run went on with the switch off while v(m) rose
# to 0.86 V (v(a) = 1 V where the B says 0); with a sine, brentq's "f(a) and f(b) must have
# different signs" came out as "cannot simulate", hinting at extreme element values.
SELF = """comparator reading its own output with no delay
Vin in 0 {wave}
B1 a 0 V = V(m) > 0.5 ? 0 : 1
R1 a m 1k
R2 m in 1k
.tran 10n 20u
.end
"""


@pytest.mark.parametrize("wave", ["SIN(0 1 100k)",
                                  "PWL(0 0 2.5u 1 7.5u -1 10u 0 12.5u 1 17.5u -1 20u 0)"])
def test_a_comparator_that_switches_itself_is_refused_by_name(tmp_path, wave):
    code, out = _cli(tmp_path, SELF.format(wave=wave))
    assert code == 2, out
    assert ("not supported: switch B1#s switches itself at t = 0 s without settling") in out
    assert "f(a) and f(b)" not in out and "Traceback" not in out


# A latch of two comparators, set by a pulse through a summing E: consistent states exist
# (both off, both on), and the start from the netlist's states (off) is one: it runs, and
# sets at the pulse's crossing of 0.5 V (2 us + 0.5 ns), as ngspice does
LATCH = """two comparators in a latch with no delay, set by a pulse
Vset s 0 PULSE(0 1 2u 1n 1n 1u 20u)
B1 a 0 V = V(x) > 0.5 ? 1 : 0
E1 x 0 VALUE = {V(b) + V(s)}
B2 b 0 V = V(a) > 0.5 ? 1 : 0
R1 a 0 1k
R2 b 0 1k
.tran 10n 10u 0 10n
.end
"""


def test_a_latch_of_comparators_still_runs_against_ngspice(tmp_path, ngspice):
    from ngspice_helpers import ngspice_wrdata

    from pelcs.api import simulate

    res = simulate(LATCH, probes=["v(a)", "v(b)"])
    assert res.error is None
    assert [(pytest.approx(t, abs=1e-15), m) for t, m in res.events] == [(2.0005e-6,
                                                                          (True, True))]
    ng = ngspice_wrdata(LATCH, ["v(a)", "v(b)"], tmp_path)
    t = ng[:, 0]
    away = np.abs(t - 2.0005e-6) > 20e-9
    for j, p in enumerate(["v(a)", "v(b)"]):
        mine = np.interp(t, res.t, res[p])
        assert np.max(np.abs(mine[away] - ng[away, 1 + 2 * j])) < 1e-6


def test_a_latch_started_against_itself_is_refused_without_a_false_claim(tmp_path):
    # S1 ON and S2 OFF in the netlist: each contradicts the other's control. Consistent states
    # exist (both off: ngspice's, both on), which the switches moving together do not reach:
    # the refusal must not say there are none (it said "have no consistent state there")
    deck = RING.replace("Ven en 0 PULSE(0 1 1u 1n 1n 5u 10u)", "").replace(
        "S1 u a en b SWA", "S1 u a b 0 SWA ON").replace("S2 u b a 0 SWA", "S2 u b a 0 SWA OFF")
    code, out = _cli(tmp_path, deck)
    assert code == 2, out
    assert "switches S1, S2 switch each other at t = 0 s without settling" in out
    assert "whose consistent states the switches moving together do not reach" in out
    assert "have no consistent state" not in out
