"""Comparator B sources whose output drives more than switch controls (a load, a gate
resistor, a transistor's gate, another comparator): ``lo + (hi - lo) s``, ``s`` the state of an
ideal switch on exactly while the comparison is true (:func:`netlist.behavioural._driving`).
Each deck runs side by side with ngspice, and against its analytic mean where it has one."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.circuit import Resistor, Switch, Vcvs, VoltageSource
from netlist.errors import NetlistError
from netlist.parser import parse_string
from pelcs.api import simulate

# A comparator driving an RC load: g is 5 V while the ramp (0 to 1 V over 9.99 µs, held at
# 1 V, back to 0 at each 10 µs period start; ngspice's PW = 0 is TSTOP) is below 0.4 V, from
# each period start for 0.4 * 9.99 = 3.996 µs: the mean of v(o) in the periodic state is
# 5 * 0.3996 = 1.998 V (the capacitor carries no mean current).
RC = """comparator driving an RC load
Vref ref 0 DC 0.4
Vramp ramp 0 PULSE(0 1 0 9.99u 10n 0 10u)
B1 g 0 V = V(ref) > V(ramp) ? 5 : 0
R1 g o 1k
C1 o 0 10n
.tran 10n 200u 0 10n uic
.end
"""


def _mean(t, y, start):
    keep = t >= start
    return np.trapezoid(y[keep], t[keep]) / (t[-1] - start)


def test_the_expansion_is_a_unit_switch_and_a_linear_output():
    c = parse_string(RC)
    els = {el.name: el for el in c.elements}
    assert isinstance(els["B1#u"], VoltageSource) and els["B1#u"].dc == 1.0
    sw = els["B1#s"]
    assert isinstance(sw, Switch) and sw.nodes == ("b1#u", "b1#c") and sw.strict
    assert sw.control == ("ref", "ramp")
    assert isinstance(els["B1#r"], Resistor)
    # the output: 0 + 5 v(b1#c), an E source that keeps the B's name (i(B1) is its current)
    assert els["B1"] == Vcvs("B1", ("g", "0"), control=("b1#c", "0"), gain=5.0)
    assert any("drives more than switch controls: its output is 0 + 5*d(B1#s) V" in n
               for n in c.notes)


def test_a_comparator_driving_an_rc_load_against_ngspice(tmp_path, ngspice):
    res = simulate(RC, probes=["v(o)", "v(g)"])
    on = [t for t, m in res.events if m[0]]
    off = [t for t, m in res.events if not m[0]]
    # one on and one off per period (analytic instants: on at each period start, off 3.996
    # µs later; on at t = 0 already)
    assert len(off) == 20 and len(on) == 19
    assert np.allclose(off, np.arange(20) * 10e-6 + 3.996e-6, rtol=0, atol=1e-15)
    assert np.allclose(on, np.arange(1, 20) * 10e-6, rtol=0, atol=1e-15)
    half = 100e-6
    mean = _mean(res.t, res["v(o)"], half)
    # (the start from 0 V has decayed to exp(-10) of it by then)
    assert mean == pytest.approx(5 * 0.3996, rel=1e-4)
    ng = ngspice_wrdata(RC, ["v(o)", "v(g)"], tmp_path)
    t = ng[:, 0]
    # ngspice's B output changes at its time points (10 ns apart): its mean on-time is up
    # to a step longer, 0.1 % of the mean
    assert mean == pytest.approx(_mean(t, ng[:, 1], half), rel=2e-3)
    keep, mine = t >= half, res.t >= half
    ripple, ripple_ng = np.ptp(res["v(o)"][mine]), np.ptp(ng[keep, 1])
    assert ripple == pytest.approx(ripple_ng, rel=3e-3)
    # the switching instants: ngspice's v(g) crosses 2.5 V within a step of pelcs'
    g = ng[:, 3] > 2.5
    k = np.flatnonzero(g[1:] != g[:-1])
    cross = t[k] + (2.5 - ng[k, 3]) / (ng[k + 1, 3] - ng[k, 3]) * (t[k + 1] - t[k])
    mine_t = np.sort(np.concatenate([on, off]))
    cross = cross[cross < 200e-6 - 10e-9]  # (not the reset at the last time point)
    assert len(cross) == len(mine_t)
    assert np.max(np.abs(cross - mine_t)) < 10e-9


# A buck whose comparator drives a gate resistor, a pull-down and the switch's control: the
# switch reads v(gate) = 5 * 10k / 10.01k V while the comparison is true, 0 else (its control
# rows depend on the comparator's state: the planner's general path).
BUCK = """buck whose PWM comparator drives a gate resistor, a pull-down and the switch
Vin in 0 DC 12
Vramp ramp 0 PULSE(0 1 0 9.99u 10n 0 10u)
Vref ref 0 DC 0.4
B1 drv 0 V = V(ref) > V(ramp) ? 5 : 0
Rg drv gate 10
Rgs gate 0 10k
S1 in sw gate 0 sm
.model sm SW(VT=2.5 VH=0 RON=10m ROFF=1meg)
D1 0 sw dm
.model dm D(IS=1e-14 RS=10m)
L1 sw out 100u
C1 out 0 100u
R1 out 0 5
.tran 0.1u 2m 0 0.1u uic
.end
"""

# A boost whose comparator drives a MOSFET's gate through a resistor (no gate capacitance in
# the model: the gate follows the comparator's output): on while the ramp is below 0.5 V.
BOOST = """boost whose PWM comparator drives a MOSFET gate through a resistor
Vin in 0 DC 12
Vramp ramp 0 PULSE(0 1 0 9.99u 10n 0 10u)
Vref ref 0 DC 0.5
B1 drv 0 V = V(ramp) < V(ref) ? 10 : 0
Rg drv gate 100
M1 sw gate 0 0 NM
.model NM NMOS(VTO=2 KP=20)
L1 in sw 100u
D1 sw out dm
.model dm D(IS=1e-14 RS=10m)
C1 out 0 47u
R1 out 0 20
.tran 0.1u 2m 0 0.1u uic
.end
"""


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("deck, switch, duty, tol", [(BUCK, "S1", 0.3996, 3e-4),
                                                     (BOOST, "M1", 0.4995, 1e-3)])
def test_pwm_converters_whose_comparator_drives_a_gate_against_ngspice(deck, switch, duty,
                                                                       tol, tmp_path, ngspice):
    res = simulate(deck, probes=["v(out)"], devices="pwl")
    # the power switch (first in the modes) turns with the comparator's switch B1#s, twice a
    # period: on at each ramp reset, off at the crossing (analytic)
    for i, name in enumerate((switch, "B1#s")):
        events = list(res.events)
        turns = [(t, m[i]) for (t, m), (_, p) in zip(
            events, [(0.0, (True, True))] + events[:-1], strict=True) if m[i] != p[i]]
        t_on = np.array([t for t, on in turns if on])
        t_off = np.array([t for t, on in turns if not on])
        assert len(t_off) == 200 and len(t_on) == 199, name
        assert np.allclose(t_off - np.arange(200) * 10e-6, duty * 10e-6, rtol=0, atol=1e-15)
        assert np.allclose(t_on - np.arange(1, 200) * 10e-6, 0, rtol=0, atol=1e-15)
    ng = ngspice_wrdata(deck, ["v(out)"], tmp_path)
    want = _mean(ng[:, 0], ng[:, 1], 1e-3)
    assert _mean(res.t, res["v(out)"], 1e-3) == pytest.approx(want, rel=tol)


# Two comparators in a chain: B2 reads B1's output (on while the ramp is below 0.4 V) and
# drives an RC with 5 V while v(g1) > 0.5 V; an I= comparator drives 1 mA into 1k while the
# ramp is above 0.7 V.
CHAIN = """two comparators in a chain, and a current comparator
Vref ref 0 DC 0.4
Vramp ramp 0 PULSE(0 1 0 9.99u 10n 0 10u)
B1 g1 0 V = V(ref) > V(ramp) ? 1 : 0
R1 g1 0 1k
B2 g2 0 V = V(g1) > 0.5 ? 5 : 0
R2 g2 o 1k
C2 o 0 10n
B3 0 i I = V(ramp) > 0.7 ? 1m : 0
R3 i 0 1k
.tran 10n 200u 0 10n uic
.end
"""


def test_chained_and_current_comparators_against_ngspice(tmp_path, ngspice):
    res = simulate(CHAIN, probes=["v(o)", "v(i)"])
    # B2 turns with B1 at the same instants; B3 on from 0.7 * 9.99 µs to the period end
    mean_o = _mean(res.t, res["v(o)"], 100e-6)
    assert mean_o == pytest.approx(5 * 0.3996, rel=1e-4)
    mean_i = _mean(res.t, res["v(i)"], 100e-6)
    assert mean_i == pytest.approx(1.0 * (1 - 0.7 * 0.999), rel=1e-9)
    ng = ngspice_wrdata(CHAIN, ["v(o)", "v(i)"], tmp_path)
    # (ngspice's B outputs change at its time points, 10 ns apart: up to a step an edge, of
    # the 3 µs the current flows a period)
    assert mean_o == pytest.approx(_mean(ng[:, 0], ng[:, 1], 100e-6), rel=2e-3)
    assert mean_i == pytest.approx(_mean(ng[:, 0], ng[:, 3], 100e-6), rel=5e-3)


# Linear branches (ngspice's semantics: the B's value is whichever branch the comparison
# selects): a regulator stand-in whose output is v(in) - 5 above 7 V of input, v(in) - 2
# below, into an RC; and a chopper, 2 v(in) while a gate pulse is high, 0 else. The input
# rises to 12 V over 100 µs and is cut back to 0 every 200 µs.
BRANCHES = """linear branches selected by a comparison
Vin in 0 PULSE(0 12 0 100u 100u 0 200u)
B1 out 0 V = V(in) > 7 ? V(in) - 5 : V(in) - 2
R1 out o 1k
C1 o 0 10n
Vp p 0 PULSE(0 1 0 1u 1u 3u 10u)
B2 ch 0 V = V(p) > 0.5 ? 2*V(in) : 0
R2 ch 0 1k
.tran 0.1u 400u 0 0.1u uic
.end
"""


def test_linear_branches_against_the_formula_and_ngspice(tmp_path, ngspice):
    c = parse_string(BRANCHES)
    assert any("its output is v(in) - 5 V while v(in) - 7 > 0, v(in) - 2 V else" in n
               for n in c.notes)
    probes = ["v(in)", "v(out)", "v(p)", "v(ch)", "v(o)"]
    res = simulate(BRANCHES, probes=probes)
    vin, out, p, ch = (res[k] for k in probes[:4])
    # at every point off the switching instants themselves, the selected branch exactly
    off = np.abs(vin - 7) > 1e-9
    assert np.allclose(out[off], np.where(vin > 7, vin - 5, vin - 2)[off], rtol=0, atol=1e-9)
    off = np.abs(p - 0.5) > 1e-9
    assert np.allclose(ch[off], np.where(p > 0.5, 2 * vin, 0)[off], rtol=0, atol=1e-9)
    ng = ngspice_wrdata(BRANCHES, probes, tmp_path)
    for j, probe in enumerate(probes):
        # (ngspice's outputs change at its time points: 0.1 µs steps)
        want = _mean(ng[:, 0], ng[:, 2 * j + 1], 0.0)
        assert _mean(res.t, res[probe], 0.0) == pytest.approx(want, rel=2e-3), probe


def test_a_comparison_of_comparisons_is_still_refused():
    from netlist.errors import NetlistError

    with pytest.raises(NetlistError, match=r"B1: '\(v\(a\) > 0\)' is a comparison used as an "
                       r"operand of another comparison"):
        parse_string("t\nVa a 0 1\nB1 g 0 V = (v(a) > 0) > 0.5 ? v(a) : 0\nR1 g 0 1k\n.end\n")


# A closed-loop buck whose comparator (output voltage against a ramp: located, it reads the
# state) drives the switch's gate through a gate resistor and a pull-down: the gate reads no
# state, but jumps whenever the comparator switches, so S1 is a comparator of its own and turns
# at the comparator's instants (FOLDED: the same comparator driving S1 directly).
CLOSED_LOOP_GATE = """closed-loop buck, its comparator driving the gate through a resistor
V1 in 0 DC 24
Vramp r 0 PULSE(0 1 0 9.99u 10n 0 10u)
B1 gd 0 V = (0.5 - 0.1*v(out) + 0.2 > v(r)) ? 10 : 0
Rg gd g 10
Rgs g 0 10k
S1 in sw g 0 SMOD
.model SMOD SW(VT=5 VH=0 RON=10m ROFF=1e6)
D1 0 sw DMOD
.model DMOD D(IS=1e-14)
L1 sw out 100u
C1 out 0 100u
Rl out 0 5
.tran 0.1u 2m
.end
"""
FOLDED = (CLOSED_LOOP_GATE.replace("Rg gd g 10\n", "").replace("Rgs g 0 10k\n", "")
          .replace("S1 in sw g 0", "S1 in sw gd 0"))


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_a_closed_loop_comparator_driving_a_gate_divider(tmp_path, ngspice):
    res = simulate(CLOSED_LOOP_GATE, probes=["v(out)"], devices="pwl")
    folded = simulate(FOLDED, probes=["v(out)"], devices="pwl")
    # S1 turns at B1#s's instants, which are the folded comparator's (to round-off)
    events = [(0.0, (True, True))] + list(res.events)
    turns = {0: [], 1: []}
    for (t, m), (_, prev) in zip(events[1:], events[:-1], strict=True):
        for i in (0, 1):
            if m[i] != prev[i]:
                turns[i].append(t)
    s1 = np.array(sorted(set(turns[0])))
    assert np.array_equal(s1, np.array(sorted(set(turns[1]))))
    direct = np.array([t for t, _ in folded.events])
    assert len(s1) == len(direct) > 300
    # (two records an instant, B1#s then S1: no zero-time toggle of B1#s between them)
    assert len(res.events) == 2 * len(direct)
    assert np.allclose(s1, direct, rtol=0, atol=1e-15)
    assert np.allclose(res["v(out)"], folded["v(out)"], rtol=0, atol=1e-8)
    ng = ngspice_wrdata(CLOSED_LOOP_GATE, ["v(out)"], tmp_path)
    want = _mean(ng[:, 0], ng[:, 1], 1e-3)
    # (measured: 4.7572 V against ngspice's 4.7486 V, 0.18 %)
    assert _mean(res.t, res["v(out)"], 1e-3) == pytest.approx(want, rel=5e-3)


# A comparator whose output drives nothing, written only to be probed (an analog PWM deck's
# 'Bpwm pwm 0 V = (v(ramp) < v(ctrl)) ? 1 : 0'): kept as its value, so that v(pwm) can be
# probed; before, it was left out and v(pwm) was an unknown probe. Its duty over the second
# half: on while ramp < 0.4, 0.4 * 9.99 us of each 10 us period, 0.3996
PROBED = """comparator driving nothing, probed
Vref ref 0 DC 0.4
Vramp ramp 0 PULSE(0 1 0 9.99u 10n 0 10u)
Rr ramp 0 1k
Bpwm pwm 0 V = (v(ramp) < v(ref)) ? 1 : 0
.tran 10n 200u 0 10n
.end
"""


def test_a_comparator_driving_nothing_can_be_probed(tmp_path, ngspice):
    c = parse_string(PROBED)
    assert any("Bpwm" in n and "drives nothing (kept, so that it can be probed)" in n
               for n in c.notes)
    res = simulate(PROBED, probes=["v(pwm)"])
    half = 100e-6
    duty = _mean(res.t, res["v(pwm)"], half)
    assert duty == pytest.approx(0.3996, rel=1e-4)
    ng = ngspice_wrdata(PROBED, ["v(pwm)"], tmp_path)
    # (ngspice's B output changes at its time points, 10 ns apart: within one of them)
    assert duty == pytest.approx(_mean(ng[:, 0], ng[:, 1], half), abs=1.5e-3)


# A comparator that drives a switch alone is mapped onto it and its output node is gone
# (a KiCad PWM subcircuit's output, probed as ngspice decks plot it): the probe's error names
# the comparator and the switch, and the switch's state it offers instead is a probe that runs
MAPPED = """comparator mapped onto the switch it drives
Vref ref 0 DC 0.4
Vramp ramp 0 PULSE(0 1 0 9.99u 10n 0 10u)
Rr ramp 0 1k
Bpwm pwm 0 V = (v(ramp) < v(ref)) ? 5 : 0
S1 in out pwm 0 sw1
.model sw1 SW(VT=2.5 RON=1m ROFF=1meg)
Vin in 0 DC 10
Rl out 0 10
.tran 10n 100u
.end
"""


def test_a_probe_of_a_mapped_comparator_output_names_the_switch():
    with pytest.raises(NetlistError) as info:
        simulate(MAPPED, probes=["v(pwm)"])
    text = str(info.value)
    assert "node pwm was the output of comparator Bpwm, mapped onto the switch it drives " \
           "(S1)" in text and "probe d(S1)" in text
    res = simulate(MAPPED, probes=["d(S1)"])
    assert np.all(np.isfinite(res["d(S1)"]))
