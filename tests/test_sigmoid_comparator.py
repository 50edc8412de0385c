"""B sources written as smooth comparators (``tanh``, a logistic, ``atan`` of an affine form),
read as the ideal comparator they approximate (:mod:`netlist.sigmoid`): the comparator each
form gives, the runs against ngspice running the sigmoid itself, and the check after the run
that refuses a sigmoid whose input sits in its transition band (an amplifier)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.behavioural_expr import Affine, parse_behavioural
from netlist.errors import NetlistError
from netlist.knee import knees_for_run
from netlist.parser import parse_string
from netlist.sigmoid import ATAN_BAND, TANH_BAND, SigmoidBand, SoftStep, sigmoid_step
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit


def step(text: str, env: dict | None = None):
    return sigmoid_step(parse_behavioural(text), text, env or {})


def v(node: str) -> tuple[str, str]:
    return ("v", node)


# ------------------------------------------------------------------------------ the forms


def test_the_bands_are_where_the_sigmoid_is_1_percent_of_its_swing_from_both_values():
    assert math.tanh(TANH_BAND) == pytest.approx(0.98, rel=1e-12)
    assert math.atan(ATAN_BAND) / (math.pi / 2) == pytest.approx(0.98, rel=1e-12)


@pytest.mark.parametrize("text, env, terms, const, hi, lo, band", [
    # A (1 + tanh(k x))/2: the comparator x > 0 ? A : 0, z = k x
    ("5*(1+tanh(1000*(v(ctl)-v(tri))))/2", {}, {v("ctl"): 1e3, v("tri"): -1e3}, 0.0,
     5.0, 0.0, TANH_BAND),
    # ... plus B, with parameters
    ("{a}*(1 + tanh(k*(v(a) - 2.5)))/2 + b", {"a": 12, "k": 100, "b": -1},
     {v("a"): 100.0}, -250.0, 11.0, -1.0, TANH_BAND),
    # A tanh(k x): +-A
    ("a*tanh(k*v(p,n))", {"a": 15, "k": 10}, {v("p"): 10.0, v("n"): -10.0}, 0.0, 15.0,
     -15.0, TANH_BAND),
    # a negative A: the comparator's input flips, so that hi is the upper limit
    ("-3*tanh(50*v(x))", {}, {v("x"): -50.0}, 0.0, 3.0, -3.0, TANH_BAND),
    # 0.5 A (1 + tanh(x/w))
    ("0.5*5*(1+tanh((v(x)-2.5)/w))", {"w": 1e-3}, {v("x"): 1e3}, -2500.0, 5.0, 0.0,
     TANH_BAND),
    # A/(1 + exp(-k x)) = A (1 + tanh(k x/2))/2
    ("5/(1+exp(-k*(v(a)-v(b))))", {"k": 100}, {v("a"): 50.0, v("b"): -50.0}, 0.0, 5.0, 0.0,
     TANH_BAND),
    # a current, and a logistic of other constants: K/(c0 + c1 e^u) crosses its mid value
    # at u = -ln(c1/c0) (here i(vs) = ln(3)/3), 0 below it and -2.5 above
    ("-5/(2+6*exp(-3*i(vs)))", {}, {("i", "vs"): -1.5}, 0.5 * math.log(3), 0.0, -2.5,
     TANH_BAND),
    # atan: +-pi/2 times its factor
    ("2*atan(100*v(a)) + 1", {}, {v("a"): 100.0}, 0.0, 1 + math.pi, 1 - math.pi, ATAN_BAND),
])
def test_each_form_gives_its_ideal_comparator(text, env, terms, const, hi, lo, band):
    s = step(text, env)
    assert isinstance(s, SoftStep) and s.strict
    assert dict(s.diff.terms) == pytest.approx(terms, rel=1e-12)
    assert s.diff.const == pytest.approx(const, abs=1e-12)
    assert (s.hi, s.lo, s.band) == pytest.approx((hi, lo, band), rel=1e-12)


@pytest.mark.parametrize("text", [
    "5*(1+tanh(v(a)*v(b)))/2",  # not affine
    "tanh(v(a)) + tanh(v(b))",  # two sigmoids
    "v(b)*tanh(v(a))",  # a sigmoid times a circuit quantity
    "tanh(tanh(v(a)))",  # a sigmoid of a sigmoid
    "exp(v(a))",  # an exponential alone
    "1/(1-exp(v(a)))",  # a pole, not a logistic
    "1/tanh(v(a))",
    "sinh(v(a))",
])
def test_other_expressions_are_no_sigmoid(text):
    assert step(text) is None


def test_a_sigmoid_of_zero_swing_is_its_constant():
    assert step("0*tanh(v(a)) + 2") == Affine((), 2.0)


def _error(text: str) -> str:
    with pytest.raises(NetlistError) as err:
        parse_string(text, file="n.cir")
    return str(err.value)


def test_a_sigmoid_of_a_nonlinear_input_keeps_the_refusal_with_the_forms_read():
    msg = _error("t\nVa a 0 1\nVb b 0 1\nB1 g 0 V = 5*(1+tanh(v(a)*v(b)))/2\nR1 g 0 1\n.end\n")
    assert "n.cir:4:22: error: B1: 'v(a)*v(b)' is a product of node voltages" in msg
    assert "A*(1+tanh(k*x))/2 + B, A/(1+exp(-k*x))" in msg


# ------------------------------------------------------------------------------ in circuits

# a synchronous buck whose PWM is a tanh comparator (k = 1000/V) of a DC control voltage
# against a triangle: S1 on while the sigmoid's output is above 2.5 V, S2 while below
SYNC_BUCK = """sync buck, PWM by a tanh comparator
.param vc=0.4 k=1000
Vin in 0 12
Vctl ctl 0 {vc}
Vtri tri 0 PULSE(0 1 0 5u 5u 1n 10u)
B1 g 0 V = 5*(1+tanh(k*(v(ctl)-v(tri))))/2
S1 in sw g 0 swm
S2 sw 0 0 g swl
L1 sw out 100u
C1 out 0 100u
R1 out 0 2
.model swm SW(VT=2.5 RON=1m)
.model swl SW(VT=-2.5 RON=1m)
.tran 0.1u 3m
.end
"""


def _mean(t, y, start):
    keep = t >= start
    return np.trapezoid(y[keep], t[keep]) / (t[-1] - start)


def test_the_sigmoid_maps_onto_the_switches_it_drives():
    c = parse_string(SYNC_BUCK)
    assert c.element("S1").control == ("ctl", "tri") and c.element("S1").strict
    assert c.element("S2").control == ("tri", "ctl") and not c.element("S2").strict
    assert "B1" not in {el.name for el in c.elements}
    # (the switches turn where the sigmoid crosses their VT, 2.5 V and -2.5 V of the
    # opposite: its mid value; its output acts through them alone, so no band to check)
    assert not [k for k in c.knees if isinstance(k, SigmoidBand)]
    for sw in ("S1", "S2"):
        model = c.models[c.element(sw).model.lower()].params
        assert (model["vt"], model["vh"]) == pytest.approx((0.0, 0.0), abs=1e-15)
    assert any("drives only switches, read as turning where it crosses their VT ± VH" in n
               for n in c.notes)
    # ngspice is given the sigmoid and the switches as written (not their rewiring)
    deck = write_circuit(c)
    assert "B1 g 0 V=((5.0 * (1.0 + tanh((1000.0 * (v(ctl) - v(tri)))))) / 2.0)" in deck
    assert "S1 in sw g 0 swm\n" in deck and "S2 sw 0 0 g swl\n" in deck
    assert "pelcs_sw" not in deck


def test_a_switch_turns_where_the_sigmoid_crosses_its_threshold():
    # S1 turns where the sigmoid crosses 10 mV, at tanh(z) = -0.996 (z = -3.106, v(ctl) -
    # v(tri) = -3.106 mV), as in ngspice, not at its mid value; with a hysteresis VH, on
    # where it crosses VT + VH and off where it crosses VT - VH
    c = parse_string(SYNC_BUCK.replace("SW(VT=2.5", "SW(VT=10m"))
    s1 = c.models[c.element("S1").model.lower()].params
    assert c.element("S1").control == ("ctl", "tri")
    assert (s1["vt"], s1["vh"]) == pytest.approx((math.atanh(-0.996) / 1e3, 0.0), rel=1e-12)
    assert not [k for k in c.knees if isinstance(k, SigmoidBand)]
    c = parse_string(SYNC_BUCK.replace("SW(VT=2.5", "SW(VT=4 VH=0.5"))
    s1 = c.models[c.element("S1").model.lower()].params
    on, off = math.atanh(2 * 4.5 / 5 - 1) / 1e3, math.atanh(2 * 3.5 / 5 - 1) / 1e3
    assert (s1["vt"], s1["vh"]) == pytest.approx(((on + off) / 2, (on - off) / 2), rel=1e-12)


def test_the_band_reaches_the_level_where_a_switch_turns():
    # a negative VH (no band of the argument read): S1 turns where the sigmoid crosses
    # 9 mV or 11 mV, at z = -3.16 and -3.06, not at its mid value: the time in between is
    # counted too
    c = parse_string(SYNC_BUCK.replace("SW(VT=2.5", "SW(VT=10m VH=-1m"))
    (knee,) = [k for k in c.knees if isinstance(k, SigmoidBand)]
    band = -math.atanh(2 * 9e-3 / 5 - 1)
    assert knee.band == pytest.approx(band, rel=1e-12) and knee.widened
    assert any(f"|v(ctl) - v(tri)| < {band:.4g} mV (where it is more than 1 % of its swing "
               "from both of its values, or between its mid value and the level where a switch "
               "it drives turns)" in n for n in c.notes)


def test_a_long_run_written_as_it_goes_leaves_the_check_out_and_says_so():
    # (the output drives a load too: the ideal comparator's value, checked)
    c = parse_string(SYNC_BUCK.replace("R1 out 0 2", "R1 out 0 2\nRg g 0 1k"))
    kept, note = knees_for_run(c.knees, 2e6, streaming=True)
    assert kept == () and note.startswith(
        "B1: not checked for its input inside the sigmoid's transition band in this run of "
        "2e+06 steps written as it goes")
    assert knees_for_run(c.knees, 2e6, streaming=False)[0] == tuple(c.knees)


@pytest.mark.slow
def test_a_tanh_pwm_buck_against_ngspice(tmp_path, ngspice):
    """The mean output over the last 2 ms: pelcs's ideal comparator against ngspice running
    the tanh (and the deck pelcs writes, which gives it the same): 4.7913 V and 4.7900 V."""
    res = simulate_circuit(parse_string(SYNC_BUCK), probes=["v(out)"])
    res.raise_if_error()
    assert any("drives only switches" in n for n in res.notes)
    got = _mean(res.t, res["v(out)"], 1e-3)
    ng = ngspice_wrdata(SYNC_BUCK, ["v(out)"], tmp_path)
    want = _mean(ng[:, 0], ng[:, 1], 1e-3)
    assert got == pytest.approx(want, rel=0.01)
    assert got == pytest.approx(0.4 * 12, rel=0.01)  # (the duty cycle's: 4.8 V)
    (tmp_path / "w").mkdir()
    written = ngspice_wrdata(write_circuit(parse_string(SYNC_BUCK)), ["v(out)"],
                             tmp_path / "w")
    assert _mean(written[:, 0], written[:, 1], 1e-3) == pytest.approx(want, rel=1e-6)


# the same buck in closed loop: the sigmoid compares 2 (5 - v(out)) + 0.4 with a sawtooth
CLOSED = """voltage-mode buck, the PWM a logistic of the output's error
Vin in 0 12
Vramp ramp 0 PULSE(0 1 0 9.9u 0.1u 0 10u)
B1 g 0 V = 5/(1+exp(-2000*(2*(5 - v(out)) + 0.4 - v(ramp))))
S1 in sw g 0 swm
S2 sw 0 0 g swl
L1 sw out 100u
C1 out 0 100u
R1 out 0 5
.model swm SW(VT=2.5 RON=1m)
.model swl SW(VT=-2.5 RON=1m)
.tran 0.1u 4m uic
.end
"""


@pytest.mark.slow
def test_a_closed_loop_logistic_pwm_against_ngspice(tmp_path, ngspice):
    c = parse_string(CLOSED)
    assert c.element("S1").control == ("s1#c2", "0")  # (built on inner nodes: E sources)
    res = simulate_circuit(c, probes=["v(out)"])
    res.raise_if_error()
    # (the mean over the last 2 ms, past the start-up's ringing: 4.993 V in pelcs, 4.999 V
    # in ngspice; the loop's duty d = 2 (5 - v) + 0.4 and v = 12 d give 124.8/25 = 4.992 V)
    got = _mean(res.t, res["v(out)"], 2e-3)
    ng = ngspice_wrdata(CLOSED, ["v(out)"], tmp_path)
    assert got == pytest.approx(_mean(ng[:, 0], ng[:, 1], 2e-3), rel=0.01)
    assert got == pytest.approx(124.8 / 25, rel=0.005)


# a gentle sigmoid (k = 1/V) of an input swinging +-1 V: an amplifier, inside its band
# (|x| < 2.3 V) all the time
GENTLE = """a gentle sigmoid driving an RC through a switch
Vin in 0 5
Vtri tri 0 PULSE(-1 1 0 0.5m 0.5m 1n 1m)
B1 g 0 V = 5*(1+tanh(1*(0 - v(tri))))/2
S1 in o g 0 swm
R1 o out 1k
C1 out 0 1u
R2 out 0 10k
.model swm SW(VT=2.5)
.tran 1u 3m
.end
"""


def test_a_gentle_sigmoid_driving_a_switch_alone_turns_it_where_ngspice_does():
    # (the switch turns where the sigmoid crosses its VT, 2.5 V, at v(tri) = 0: however
    # gentle the sigmoid, its output acts through the switch alone. ngspice: mean v(out)
    # 4.33379 V over the run, measured)
    c = parse_string(GENTLE)
    assert not [k for k in c.knees if isinstance(k, SigmoidBand)]
    res = simulate_circuit(c, probes=["v(out)"])
    res.raise_if_error()
    assert _mean(res.t, res["v(out)"], 0.0) == pytest.approx(4.33379, rel=2e-4)


def test_a_gentle_sigmoid_is_refused_by_the_band_check():
    # (its output drives a load too: there the ideal comparator's value is not the sigmoid's)
    with pytest.raises(NetlistError) as err:
        simulate_circuit(parse_string(GENTLE.replace(".model", "Rg g 0 10k\n.model"),
                                      file="g.cir"), probes=["v(out)"])
    msg = str(err.value)
    assert "g.cir:4:1: error: B1: the sigmoid '5*(1+tanh(1*(0 - v(tri))))/2', read as the " \
           "ideal comparator -v(tri) > 0 ? 5 : 0, held its input inside its transition band " \
           "|-v(tri)| < 2.298 V" in msg
    assert "for 0.003 s of the run, more than 10% of it, from t = 0 s" in msg
    assert "there it is an amplifier, not a comparator" in msg
    assert "hint: write the comparator ideal (x > 0 ? hi : lo" in msg
    assert "or make the sigmoid steeper (a larger gain k)" in msg


def test_a_sigmoid_driving_a_load_is_its_value_and_written_as_the_sigmoid():
    deck = ("t\n.subckt cmp a b o\n.param k=500\nB1 o 0 V = 3*tanh(k*(v(a)-v(b)))\n.ends\n"
            "Va a 0 SIN(0 1 1k)\nX1 a 0 g cmp\nR1 g 0 1k\n.tran 1u 2m\n.end\n")
    c = parse_string(deck)
    assert c.element("X1.B1#s").control == ("a", "0")
    out = write_circuit(c)
    assert "B.X1.B1 g 0 V=(3.0 * tanh((500.0 * (v(a) - v(0)))))" in out
    assert "X1.B1#" not in out and "pelcs_sw" not in out
    res = simulate_circuit(c, probes=["v(g)"])
    res.raise_if_error()
    # +-3 V on the sine's sign; the sine crosses the band (|v(a)| < 4.6 mV) in 1.5 us
    mid = (res.t > 0.1e-3) & (res.t < 0.4e-3)
    assert np.allclose(res["v(g)"][mid], 3.0, rtol=1e-6)
    assert "X1.B1: the sigmoid '3*tanh(k*(v(a)-v(b)))' read as the ideal comparator v(a) > 0 " \
           "? 3 : -3: its input (-1 V to 1 V over the run) never stayed inside the sigmoid's " \
           "transition band |v(a)| < 4.595 mV from one step to the next" in res.notes


def test_a_clamp_a_sigmoid_reads_stays_a_limiter_so_that_ngspice_reads_it_too():
    c = parse_string("t\nVa a 0 SIN(0.5 1 100)\nVtri tri 0 PULSE(0.1 0.9 0 5u 5u 1n 10u)\n"
                     "Bc c 0 V = max(0, min(1, v(a)))\n"
                     "B1 g 0 V = 5*(1+tanh(1000*(v(c)-v(tri))))/2\nVin in 0 10\n"
                     "S1 in o g 0 swm\nR1 o 0 10\n.model swm SW(VT=2.5)\n.tran 0.1u 10m\n.end\n")
    assert c.element("S1").control == ("c", "tri")
    assert any(n.startswith("Bc: clamp") and "it feeds B1" in n for n in c.notes)
    deck = write_circuit(c)
    assert "Bc c 0 V = max(0.0, min(1.0, 1.0*v(a) + 0.0))" in deck
    assert "B1 g 0 V=((5.0 * (1.0 + tanh((1000.0 * (v(c) - v(tri)))))) / 2.0)" in deck


def test_an_e_value_sigmoid_of_a_current_in_a_subcircuit_inside_its_band_is_refused():
    # (E VALUE={...} is a B source; the knee probes the flattened source's current; its
    # output drives a load as well as the switch: the ideal comparator's value, checked)
    c = parse_string("t\nVin in 0 10\n.subckt sense a b\nVs a m 0\nR1 m b 1k\n.ends\n"
                     "X1 in c sense\nC1 c 0 1u\n"
                     "E1 g 0 VALUE={5/(1+exp(-1e4*(i(X1.Vs) - 5m)))}\nRg g 0 1k\n"
                     "S1 c d g 0 swm\nRd d 0 1k\n.model swm SW(VT=2.5)\n.tran 1u 5m uic\n.end\n")
    (knee,) = [k for k in c.knees if isinstance(k, SigmoidBand)]
    assert knee.probes == ("i(X1.Vs)",) and knee.comparator == "i(X1.Vs) - 0.005 > 0 ? 5 : 0"
    assert (knee.band, knee.scale) == pytest.approx((TANH_BAND, 5000.0), rel=1e-12)
    assert "B.E1 g 0 V=(5.0 / (1.0 + exp(((-10000.0) * (i(V.X1.Vs) - 0.005)))))" in \
        write_circuit(c)
    # from 0 V the current (10 mA) is above 5 mA: S1 on, Rd loading the capacitor, which
    # settles at 5 V (tau 0.5 ms), where the current is exactly 5 mA: the input (10 mA -
    # v(c)/1k - 5 mA) is inside the band (459.5 uA) from 0.5 ms ln(5/0.4595) = 1.19 ms on,
    # most of the run: refused
    with pytest.raises(NetlistError) as err:
        simulate_circuit(c, probes=["v(c)"])
    msg = str(err.value)
    assert "E1: the sigmoid '{5/(1+exp(-1e4*(i(X1.Vs) - 5m)))}', read as the ideal " \
           "comparator i(X1.Vs) - 0.005 > 0 ? 5 : 0, held its input inside its transition " \
           "band |i(X1.Vs) - 0.005| < 459.5 µA" in msg
    assert "more than 10% of it, from t = 0.0011" in msg


def test_a_switch_with_hysteresis_off_the_mid_value_against_the_sine_crossings():
    # the switch turns on where the sigmoid crosses VT + VH = 4.8 V (v(a) = 1 + atanh(0.92)/50)
    # and off where it falls through 4.2 V (1 + atanh(0.68)/50), not where it crosses 2.5 V:
    # its duty over each period of the sine is then known. ngspice (its 0.01 ohm RON, a
    # 20 ns step): 4.95669 V, 10/10.01 of this; read at the mid value pelcs gave 5.0017 V
    deck = ("sigmoid into a switch\nV1 a 0 SIN(1 2 1k)\n"
            "B1 g 0 V=5*(1+tanh(50*(v(a)-1)))/2\nS1 in x g 0 swm\n"
            ".model swm sw vt=4.5 vh=0.3 ron=0.01 roff=1e6\nV2 in 0 10\nR1 x 0 10\n"
            ".tran 1u 3m\n.end\n")
    res = simulate_circuit(parse_string(deck), probes=["v(x)"], every=1)
    on = math.asin(math.atanh(0.92) / 100)
    off = math.asin(math.atanh(0.68) / 100)
    duty = (math.pi - on - off) / (2 * math.pi)
    assert _mean(res.t, res["v(x)"], 0.0) == pytest.approx(10 * duty, rel=2e-4)
    assert 10 * duty * 10 / 10.01 == pytest.approx(4.95669, rel=1e-4)


def test_a_sigmoid_driven_switch_turns_at_both_ends_of_its_hysteresis(tmp_path):
    # 1 + 2 tanh(3 (v(a) - 1)) of a 1 kHz sine 1 + 2 sin into a switch at VT 2 V, VH 0.5 V:
    # on where the sigmoid rises through 2.5 V, off where it falls through 1.5 V (ngspice
    # 39: 25.78 us and 492.78 us); the comparison's strictness must not make the switch an
    # idealised one turning at VT alone (16.5 us and 484.5 us)
    from pelcs.cli import main

    deck = tmp_path / "band.cir"
    deck.write_text("""sigmoid into a switch with hysteresis
Va a 0 SIN(1 2 1k)
B1 c 0 V=1+2*tanh(3*(v(a)-1))
Vin in 0 5
S1 in y c 0 SW1
R1 y 0 1k
.model SW1 SW(RON=0.01 ROFF=1e9 VT=2 VH=0.5)
.tran 1u 1m
.end
""")
    out = tmp_path / "y.csv"
    assert main(["simulate", str(deck), "--no-progress", "--probe", "v(y)", "-o",
                 str(out)]) == 0
    t, y = np.genfromtxt(out, delimiter=",", skip_header=1).T
    w = 2 * np.pi * 1e3
    t_on = np.arcsin(np.arctanh(0.75) / 6) / w
    t_off = (np.pi - np.arcsin(np.arctanh(0.25) / 6)) / w
    on = t[y > 2.5]
    assert on[0] == pytest.approx(t_on, abs=1.1e-6)
    assert on[-1] == pytest.approx(t_off, abs=1.1e-6)
