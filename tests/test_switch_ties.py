"""ngspice's SW rule at the threshold and inside the band (``swload.c``), for S switches and
idealised transistors: hand-derived instants, and ngspice run side by side.

ngspice decides a switch at every time point: on above ``VT + |VH|``, off below ``VT - |VH|``;
inside the band, with ``VH > 0`` it keeps its state, with ``VH <= 0`` (the default ``VH = 0``
included) it turns on when the control enters the band from below and off when from above. So
a gate ``PULSE(0 1 ...)`` falling to exactly ``VT = 0`` turns the switch off every period.
"""


import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from lcs.model import IDEALISED_OPTION, OPERATING_POINT_OPTION, SwitchControl
from lcs.signals import Pulse, Sin, resolve
from lcs.simulation.inputs import collect_breakpoints
from lcs.simulation.source_switching import source_switch_events
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit

GATE = Pulse(0, 1, 1e-3, 0.1e-3, 0.1e-3, 1e-3, 2e-3)
OP = {OPERATING_POINT_OPTION: True}


class _Gated:
    """One switch whose control is the one input (a source-driven gate)."""

    inputs = ["Vg"]

    class _Map:
        Cy, Dy, Fy = np.zeros((1, 1)), np.zeros((1, 0)), np.ones((1, 1))

    def __init__(self, sw):
        self.switches = [sw]

    def outputs(self, mode, names):
        return self._Map()

    def describe_mode(self, mode):
        return str(mode)


def _events(sig, vt, vh, options, t1=5e-3):
    sig = resolve(sig, 10e-6, t1)
    system = _Gated(SwitchControl("S1", "v(g,0)", vt, vh, options))
    mode0, ev = source_switch_events(system, [sig], 0.0, t1,
                                     collect_breakpoints([sig], 0.0, t1), 1e-6)
    return mode0[0], [(round(t * 1e3, 6), m[0]) for t, m in ev]


# (case, gate, VT, VH, options, initial state, switching instants in ms and new states): the
# instants ngspice shows (test_resistor_decks_match_ngspice runs the same decks)
CASES = [
    ("VH=0, gate low at VT, from the operating point", GATE, 0, 0, OP, True,
     [(2.2, False), (3.0, True), (4.2, False)]),
    ("VH=0, gate low at VT, UIC", GATE, 0, 0, {}, False,
     [(1.0, True), (2.2, False), (3.0, True), (4.2, False)]),
    ("VH=0, gate rising to VT and staying", Pulse(-1, 0, 1e-3, 0.1e-3, 0.1e-3, 1e-3, 2e-3),
     0, 0, OP, False, [(1.1, True), (2.1, False), (3.1, True), (4.1, False)]),
    ("VH=0, gate falling to VT and staying", Pulse(1, 0, 1e-3, 0.1e-3, 0.1e-3, 1e-3, 2e-3),
     0, 0, OP, True, [(1.1, False), (2.1, True), (3.1, False), (4.1, True)]),
    ("VH<0 band [-0.1, 0.3], from the operating point", GATE, 0.1, -0.2, OP, True,
     [(2.17, False), (3.03, True), (4.17, False)]),
    ("VH<0 band [-0.1, 0.3], UIC", GATE, 0.1, -0.2, {}, False,
     [(1.03, True), (2.17, False), (3.03, True), (4.17, False)]),
    ("VH>0 band [-0.1, 0.3]: keeps its state", GATE, 0.1, 0.2, OP, False, [(1.03, True)]),
    ("VH>0, ON", GATE, 0.1, 0.2, {"initial": True}, True, []),
    ("idealised transistor: on only above VT", GATE, 0, 0, {IDEALISED_OPTION: True, **OP},
     False, [(1.0, True), (2.2, False), (3.0, True), (4.2, False)]),
    # a sine (the generic path): zero before its delay, crossings at asin(0.1) and 5/12 ms
    ("SIN, VH=0, from the operating point", Sin(0, 1, 1e3, 1e-3), 0, 0, OP, True,
     [(1.5, False), (2.0, True), (2.5, False), (3.0, True), (3.5, False), (4.0, True),
      (4.5, False)]),
    ("SIN, VH<0 band [0.1, 0.5], UIC", Sin(0, 1, 1e3, 1e-3), 0.3, -0.2, {}, False,
     [(1.015942, True), (1.416667, False), (2.015942, True), (2.416667, False),
      (3.015942, True), (3.416667, False), (4.015942, True), (4.416667, False)]),
]


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_switching_instants_by_hand(case):
    _, gate, vt, vh, options, on0, expected = case
    assert _events(gate, vt, vh, options) == (on0, expected)


DECK = """ties
Vs a 0 DC 1
R1 a b 1k
S1 b 0 g 0 SWM {flag}
Vg g 0 {gate}
.model SWM SW(VT={vt} VH={vh} RON=1m ROFF=1e9)
.tran 10u 5m {uic}
"""

DECKS = [  # (gate, VT, VH, switch flag, UIC)
    ("PULSE(0 1 1m 0.1m 0.1m 1m 2m)", 0, 0, "", ""),
    ("PULSE(0 1 1m 0.1m 0.1m 1m 2m)", 0, 0, "", "UIC"),
    ("PULSE(0 1 1m 0.1m 0.1m 1m 2m)", 0, 0, "OFF", ""),
    ("PULSE(-1 0 1m 0.1m 0.1m 1m 2m)", 0, 0, "", ""),
    ("PULSE(1 0 1m 0.1m 0.1m 1m 2m)", 0, 0, "", "UIC"),
    ("PULSE(0 1 1m 0.1m 0.1m 1m 2m)", 0.1, -0.2, "", ""),
    ("PULSE(0 1 1m 0.1m 0.1m 1m 2m)", 0.1, -0.2, "ON", "UIC"),
    ("PULSE(0 1 1m 0.1m 0.1m 1m 2m)", 0.1, 0.2, "", "UIC"),
    ("SIN(0 1 1k 1m)", 0, 0, "", ""),
    ("SIN(0 1 1k 1m)", 0.3, -0.2, "", "UIC"),
]


def _ngspice(tmp_path, deck: str, vectors: str) -> np.ndarray:
    return ngspice_wrdata(deck + ".end\n", vectors.split(), tmp_path, timeout=60)


def _off_by_ngspice(t, data, col, level=0.5, near=20e-6):
    """The switch states ngspice shows (True = off) at its time points, and a mask of the
    points more than ``near`` (s: two of pelcs's steps, over which its output is
    interpolated) away from its transitions."""
    off = data[:, col] > level
    change = np.flatnonzero(np.diff(off.astype(int))) + 1
    far = np.ones(t.size, bool)
    for i in change:
        far &= np.abs(t - t[i]) > near
    return off, far


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("deck", DECKS, ids=[f"{g.split('(')[0]}-vt{vt}-vh{vh}-{f}-{u}"
                                             for g, vt, vh, f, u in DECKS])
def test_resistor_decks_match_ngspice(ngspice, tmp_path, deck):
    gate, vt, vh, flag, uic = deck
    text = DECK.format(gate=gate, vt=vt, vh=vh, flag=flag, uic=uic)
    data = _ngspice(tmp_path, text, "v(b)")
    t = data[:, 0]
    off, far = _off_by_ngspice(t, data, 1)
    res = simulate_circuit(parse_string(text + ".end\n"), probes=["v(b)"])
    ours = np.interp(t, res.t, res["v(b)"]) > 0.5
    assert far.sum() > 0.8 * t.size
    assert np.array_equal(ours[far], off[far])
    # ngspice switches at every transition pelcs does, within one of its steps
    assert np.count_nonzero(np.diff(ours.astype(int))) == np.count_nonzero(
        np.diff(off.astype(int)))


BOOST = """boost, gate low level exactly at VT = 0
Vin in 0 DC 12
L1 in sw 100u
S1 sw 0 g 0 SWM
D1 sw out DM
C1 out 0 100u
R1 out 0 20
Vg g 0 PULSE(0 1 0 10n 10n 5u 10u)
.model SWM SW(RON=0.001)
.model DM D(IS=1e-12 N=0.05)
.tran 0.1u 10m 0 0.1u UIC
"""


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_boost_gate_at_threshold_switches_every_period(ngspice, tmp_path):
    # Before: the switch turned on at the first rise and stayed on (the gate's low level is
    # VT: "inside the band", kept): 0 switching events, i(L1) climbed without bound. ngspice
    # turns it off at the end of each fall: a boost at duty 0.5, 24 V in steady state.
    data = _ngspice(tmp_path, BOOST, "i(L1) v(out)")
    t, il, vout = data[:, 0], data[:, 1], data[:, 3]
    res = simulate_circuit(parse_string(BOOST + ".end\n"), probes=["i(L1)", "v(out)"])
    assert res.error is None
    assert res["i(L1)"].max() == pytest.approx(il.max(), rel=0.01)  # 24.9 A, the start-up
    # the mean output over the last 2 ms (a time average: ngspice's points are not uniform)
    late, ng_late = res.t > 8e-3, t > 8e-3
    ours = np.trapezoid(res["v(out)"][late], res.t[late]) / np.ptp(res.t[late])
    theirs = np.trapezoid(vout[ng_late], t[ng_late]) / np.ptp(t[ng_late])
    assert ours == pytest.approx(theirs, rel=0.002)  # 24.073 V and 24.079 V


MOS = """nmos at its threshold
Vs a 0 DC 1
R1 a b 1k
M1 b g 0 0 NM
Vg g 0 PULSE(0 5 1m 0.1m 0.1m 1m 2m)
.model NM NMOS(VTO=0 KP=10)
.tran 10u 5m
"""


def test_idealised_mosfet_is_off_at_its_threshold(ngspice, tmp_path):
    # An NMOS with VTO = 0 and its gate at 0 V conducts nothing (cutoff), in ngspice's real
    # model as in the idealised switch: off whenever the gate is low, from t = 0.
    data = _ngspice(tmp_path, MOS, "v(b)")
    t = data[:, 0]
    off, far = _off_by_ngspice(t, data, 1)
    res = simulate_circuit(parse_string(MOS + ".end\n"), probes=["v(b)"])
    ours = np.interp(t, res.t, res["v(b)"]) > 0.5
    assert off[0] and ours[0]
    assert np.array_equal(ours[far], off[far])
