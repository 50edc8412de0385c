"""ngspice's B sources: the expression grammar, linear B sources as E/G/H/F elements (against
analytic answers), comparators mapped onto the switches they drive, and the refusals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from ngspice_helpers import ngspice_print, ngspice_wrdata

from netlist.behavioural_expr import (
    Affine,
    BehaviouralError,
    Clamp,
    Select,
    Step,
    linearise,
    parse_behavioural,
)
from netlist.circuit import Ccvs, CurrentSource, Vccs, Vcvs, VoltageSource
from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit


def form(text: str, env: dict | None = None):
    return linearise(parse_behavioural(text), text, env or {})


def v(node: str) -> tuple[str, str]:
    return ("v", node)


# ------------------------------------------------------------------------------ grammar


def test_precedence_and_constants():
    assert form("1 + 2*3 - 4/2").const == 5
    assert form("-2**2").const == -4  # ** binds tighter than a unary minus
    assert form("2^3^2").const == 64  # left-associative (ngspice 39: 64)
    assert form("{k}*2 + pi", {"k": 3}).const == pytest.approx(6 + math.pi)
    assert form("1 < 2 && 3 > 4 || 1").const == 1  # && before ||, comparisons before &&
    assert form("0 ? 1 : 2 ? 3 : 4").const == 3  # ?: right-associative
    assert form("!(2 > 1)").const == 0
    assert form("max(1, 3) + abs(-1) + u(0)").const == pytest.approx(4.5)  # u(0) = 1/2
    # (a B source's min and max take two arguments: ngspice 39 parses no B line of max(3)
    # and stops at max(1, 2, 3) with "Internal Error: bad node type")
    for bad in ("max(3)", "max(1, 2, 3)", "min(v(a), 1, 2)"):
        with pytest.raises(BehaviouralError, match="takes 2 argument"):
            form(bad)


@pytest.mark.parametrize("text, value", [
    # (ngspice 39's B sources, measured with .op)
    ("2^-1^2", 0.5),  # a sign in an exponent takes the powers after it: 2^-(1^2)
    ("2**-1**2", 0.5),
    ("2^!0^2", 2.0),  # 2^!(0^2)
    ("-2^-2", -0.25),
    ("2^-2*3", 0.75),
    ("2 == 1 < 2", 0.0),  # == and != looser than < and >: 2 == (1 < 2)
    ("2 != 1 < 2", 1.0),
    ("1 < 2 == 1", 1.0),
    ("0 != 2 == 1", 1.0),
    ("3 >= 2 == 1", 1.0),
])
def test_precedence_as_ngspice_b_sources(text, value):
    assert form(text).const == pytest.approx(value)
    # (the same in a B source of time: netlist.time_expression evaluates the parsed tree)
    c = parse_string(f"t\nB1 a 0 V=({text}) + 0*sin(time)\nR1 a 0 1\n.tran 1u 10u\n.end\n")
    assert float(c.element("B1").waveform(0.0)) == pytest.approx(value)


@pytest.mark.slow
def test_precedence_in_ngspice(tmp_path, ngspice):
    cases = {"2^-1^2": 0.5, "2 == 1 < 2": 0.0, "2^!0^2": 2.0}
    lines = "".join(f"B{k} n{k} 0 V={e}\nR{k} n{k} 0 1\n" for k, e in enumerate(cases))
    got = ngspice_print(f"t\n{lines}.tran 1u 10u\n.end\n",
                        [f"v(n{k})[0]" for k in range(len(cases))], tmp_path)
    assert list(got.values()) == pytest.approx(list(cases.values()))


def test_affine_forms():
    f = form("-(1)*i(vs1)*{n} + 2*v(a,b) - v(c)/4 + 3", {"n": 10})
    assert dict(f.terms) == {("i", "vs1"): -10.0, v("a"): 2.0, v("b"): -2.0, v("c"): -0.25}
    assert f.const == 3
    # node names as written, with characters that are operators elsewhere
    assert dict(form("V(Net-_V2-Pad1_)").terms) == {v("net-_v2-pad1_"): 1.0}
    assert form("v(a) - v(a)").terms == ()
    assert form("v(0)").terms == () and form("v(gnd)").terms == ()


def test_comparator_forms():
    s = form("( V(nPin) > V(nPtri) ) ? 1.0 : 0.0")
    assert isinstance(s, Step) and s.strict and (s.hi, s.lo) == (1, 0)
    assert dict(s.diff.terms) == {v("npin"): 1, v("nptri"): -1}
    s = form("v(a) <= 2 ? 5 : -5")  # a <= 2 is 2 - a >= 0
    assert not s.strict and dict(s.diff.terms) == {v("a"): -1} and s.diff.const == 2
    assert (s.hi, s.lo) == (5, -5)
    s = form("3*u(v(x) - 1) + 1")
    assert s.strict and (s.hi, s.lo) == (4, 1) and s.diff.const == -1
    s = form("5*(v(x) > v(y))")
    assert (s.hi, s.lo) == (5, 0)
    s = form("!(v(x) > 1) ? 2 : 7")
    assert (s.hi, s.lo) == (7, 2)
    assert form("v(x) > 1 ? 3 : 3") == Affine((), 3.0)  # both values equal: a constant
    # linear branches, as the whole expression
    s = form("v(a) > 1 ? v(b) : 0")
    assert isinstance(s, Select) and s.strict and dict(s.diff.terms) == {v("a"): 1}
    assert s.hi == Affine(((v("b"), 1.0),), 0.0) and s.lo == Affine((), 0.0)
    s = form("!(v(a) >= 1) ? v(b) - 5 : v(b) - 2")  # false first: the branches swap
    assert not s.strict and s.hi.const == -2 and s.lo.const == -5
    assert form("v(a) > 1 ? v(b) : v(b)") == Affine(((v("b"), 1.0),), 0.0)


@pytest.mark.parametrize("text, offset, words", [
    ("v(a)*v(b)", 0, "product"),
    ("max(0, min(5, v(ref,x)*10k))", 7, "min()"),  # the innermost nonlinear operation
    ("2 + 1/v(a)", 4, "division"),
    ("2*(v(a) > 1 ? v(b) : 0)", 14, "not a constant"),  # linear branches: the whole B only
    ("v(a) > 1 && v(b) > 2", 0, "two comparisons"),
    ("v(a) == 1 ? 1 : 0", 0, "equality"),
    ("time < 1m ? 1 : 0", 0, "time-varying"),
    ("sqrt(v(a))", 0, "sqrt()"),
    ("foo(1)", 0, "unknown function"),
    ("1 +", 3, "incomplete expression"),
    ("(1 + 2", 6, "expected ')'"),
    ("v(a b)", 0, "malformed"),
    ("2 # 3", 2, "unexpected character"),
    ("v(a) ?", 6, "incomplete expression"),
    ("1e400", 0, "too large"),
    ("1e308*10", 0, "overflows"),
    ("(" * 3000 + "1" + ")" * 3000, 0, "nested too deeply"),
    ("-" * 5000 + "v(a)", 0, "nested too deeply"),
])
def test_refusals_say_where_and_what(text, offset, words):
    with pytest.raises(BehaviouralError) as err:
        form(text)
    assert err.value.offset == offset and words in err.value.message


# ------------------------------------------------------------------------------ linear sources


def test_linear_v_source_is_an_e_chain_with_its_constant():
    c = parse_string("t\nV1 in 0 3\nR1 in 0 1k\nB1 out 0 V = 2*v(in) + 1\nR2 out 0 1k\n.end\n")
    b = [el for el in c.elements if el.name.startswith("B1")]
    assert b == [Vcvs("B1", ("out", "b1#n1"), control=("in", "0"), gain=2.0),
                 VoltageSource("B1#2", ("b1#n1", "0"), dc=1.0)]


def test_linear_i_source_is_a_g_f_set():
    c = parse_string("t\nV1 in 0 3\nR1 in 0 1k\nB1 0 out I = v(in)/1k - 0.5*i(V1)\n"
                     "R2 out 0 1k\n.end\n")
    b = [el for el in c.elements if el.name.startswith("B1")]
    assert [type(el).__name__ for el in b] == ["Vccs", "Cccs"]
    assert b[0] == Vccs("B1", ("0", "out"), control=("in", "0"), gain=1e-3)
    assert (b[1].source, b[1].gain) == ("V1", -0.5)


GYRATOR = """gyrator from two B sources: Zin = N^2 / RL
.param N=2
Vin s 0 10
Rs s a 1
Vs1 a a1 0
B1 a1 0 V = {N}*i(Vs2)
Vs2 b b1 0
B2 b1 0 V = -{N}*i(Vs1)
L1 b c 1m
RL c 0 4
.tran 1u 3m
.end
"""


def test_gyrator_input_impedance_is_n2_over_rl():
    c = parse_string(GYRATOR)
    assert c.element("B1") == Ccvs("B1", ("a1", "0"), source="Vs2", gain=2.0)
    res = simulate_circuit(c, probes=["v(a)", "v(b)", "i(Vs1)"])
    res.raise_if_error()
    # i1 = 10 / (1 + 2^2/4) = 5 A, v(a) = N i2 = 5 V, v(b) = -N i1 = -10 V once L1's
    # current has settled (time constant L1 / (RL + N^2/Rs) = 125 us)
    assert res["i(Vs1)"][-1] == pytest.approx(5.0, rel=1e-6)
    assert res["v(a)"][-1] == pytest.approx(5.0, rel=1e-6)
    assert res["v(b)"][-1] == pytest.approx(-10.0, rel=1e-6)


@pytest.mark.parametrize("deck", [GYRATOR, "written"])
def test_gyrator_in_ngspice(deck, tmp_path, ngspice):
    """ngspice gives the same answer from the B sources and from pelcs' written E/H form."""
    text = GYRATOR if deck == GYRATOR else write_circuit(parse_string(GYRATOR))
    if deck == "written":
        assert "H.B1 a1 0 Vs2 2" in text
    last = [f"{p}[length(time)-1]" for p in ("i(Vs1)", "v(a)", "v(b)")]
    got = ngspice_print(text, last, tmp_path)
    assert [got[k] for k in last] == pytest.approx([5.0, 5.0, -10.0], rel=1e-6)


def test_linear_b_inside_a_subcircuit_names_its_own_sources():
    c = parse_string("t\n.subckt amp in out k=1\nVs in m 0\nRm m 0 1\n"
                     "B1 out 0 V = {k}*i(Vs)\n.ends\nV1 x 0 2\nX1 x y amp k=3\nR1 y 0 1\n.end\n")
    assert c.element("X1.B1") == Ccvs("X1.B1", ("y", "0"), source="X1.Vs", gain=3.0)


# ------------------------------------------------------------------------------ comparators

PWM = """PWM from a B comparator, as in the pess converters' edt01.sub
.subckt pwmtri nPin nPout fs=10000
Vtri nPtri 0 PULSE(-1 1 0 {0.5/fs} {0.5/fs} 0 {1/fs})
Bout nPout 0 V = ( V(nPin) > V(nPtri) ) ? 1.0 : 0.0
.ends
Vd d 0 {duty}
X1 d g pwmtri fs=10k
Vin in 0 10
S1 in out g 0 sw1
R1 out 0 10
.model sw1 SW(RON=1m)
.param duty=0.5
.tran 1u 200u uic
.end
"""


def test_pwm_comparator_becomes_the_switch_control():
    c = parse_string(PWM)
    sw = c.element("S1")
    assert sw.control == ("d", "x1.nptri") and sw.strict
    assert c.models[sw.model.lower()].params == {"vt": 0.0, "vh": 0.0, "ron": 1e-3}
    assert not any(el.name.lower().startswith("x1.bout") for el in c.elements)
    assert any("on while v(d) - v(x1.nptri) > 0" in n for n in c.notes)


def test_pwm_instants_are_the_triangle_crossings():
    # ngspice reads PULSE's PW = 0 as its default, TSTOP: the carrier rises from -1 to 1 in
    # 50 us, stays at 1 and falls back to -1 at the period's end, so 0.5 > carrier from the
    # period's start to 37.5 us (and ngspice agrees: the pess buck, tests/test_corpus.py)
    res = simulate_circuit(parse_string(PWM), probes=["v(out)"])
    res.raise_if_error()
    assert res.switching == {"S1": "source"}
    assert [k for _, k in res.events] == [(False,), (True,), (False,)]
    assert np.allclose([t for t, _ in res.events], [37.5e-6, 100e-6, 137.5e-6], rtol=0,
                       atol=1e-15)


@pytest.mark.parametrize("expr, model, control, vt, strict", [
    # values on either side of VT: on while the comparison holds (2 - v(a) > 0: v(0,a) > -2)
    ("v(a) < 2 ? 1 : 0", "", ("0", "a"), -2.0, True),
    ("u(v(a) - 2)", "", ("a", "0"), 2.0, True),
    ("v(a) >= 2 ? 1 : 0", "", ("a", "0"), 2.0, False),
    # the false value turns it on: on while not v(a) > 2, i.e. 2 - v(a) >= 0
    ("v(a) > 2 ? 0 : 5", "", ("0", "a"), -2.0, False),
    # both values above VT: always on; both below: always off
    ("v(a) > 2 ? 3 : 2", "VT=1", ("0", "0"), -1.0, True),
    ("5*(v(a,b) > 0)", "VT=6", ("0", "0"), 1.0, True),
    # the model's VT and VH apply to the B's output, not to the comparison
    ("v(a) > v(b) ? 10 : 0", "VT=5 VH=1", ("a", "b"), 0.0, True),
    # the control across the output the other way round: -output > VT
    ("v(a) > v(b) ? -1 : 0", "VT=0.5", ("a", "b"), 0.0, True),
])
def test_switch_state_follows_values_and_threshold(expr, model, control, vt, strict):
    nodes = "0 g" if "-1" in expr else "g 0"
    c = parse_string(f"t\nVa a 0 1\nVb b 0 0\nB1 g 0 V = {expr}\nVin in 0 1\n"
                     f"S1 in out {nodes} m\nR1 out 0 1\n.model m SW({model})\n.end\n")
    sw = c.element("S1")
    params = c.models[sw.model.lower()].params
    assert (sw.control, params["vt"], params["vh"], sw.strict) == (control, vt, 0.0, strict)


def test_start_inside_the_band_is_noted_where_ngspice_differs():
    # ngspice (checked by hand: duty -2, no UIC) keeps S1 on throughout: its operating point
    # takes the B output 0 = VT as entering the band from below; under UIC it is off
    no_uic = parse_string(PWM.replace(" uic", ""))
    assert any("if the comparison of X1.Bout is false at t = 0, ngspice holds the switch on"
               in n for n in no_uic.notes)
    assert not any("ngspice holds" in n for n in parse_string(PWM).notes)


def test_a_longer_difference_is_built_on_inner_nodes():
    c = parse_string("t\nVa a 0 1\nVb b 0 0\nB1 g 0 V = 2*v(a) + i(Va) > 3 ? 1 : 0\n"
                     "Vin in 0 1\nS1 in out g 0 m\nR1 out 0 1\n.model m SW()\n.end\n")
    sw = c.element("S1")
    assert sw.control == ("s1#c2", "0")
    assert c.models[sw.model.lower()].params["vt"] == 3.0
    chain = [el for el in c.elements if el.name.startswith("S1#")]
    assert chain == [Vcvs("S1#c1", ("s1#c1", "0"), control=("a", "0"), gain=2.0),
                     Ccvs("S1#c2", ("s1#c2", "s1#c1"), source="Va", gain=1.0)]


RELAY = """a comparator on a state: C charges through S1 until v(out) reaches 5 V
Vin in 0 10
S1 in mid g 0 m
R1 mid out 1k
C1 out 0 1u
Bc g 0 V = v(out) < 5 ? 1 : 0
.model m SW()
.tran 1u 2m uic
.end
"""


def test_comparator_on_a_state_is_located():
    res = simulate_circuit(parse_string(RELAY), probes=["v(out)"])
    res.raise_if_error()
    assert res.switching["S1"] == "implicit"
    # v = 10 (1 - exp(-t/RC)) reaches 5 V at RC ln 2; the switch then holds it there (the
    # comparator slides, as the B source's output chatters in ngspice)
    t_off, key = res.events[0]
    assert key == (False,) and t_off == pytest.approx(1e-3 * math.log(2), rel=1e-6)
    assert res.sliding[0][0] == "S1"
    assert res["v(out)"][-1] == pytest.approx(5.0, rel=1e-9)


VM_BUCK = """voltage-mode buck: the PWM comparator is a B source on the output voltage
Vin in 0 12
Vramp ramp 0 PULSE(0 1 0 9.9u 0.1u 0 10u)
S1 in sw g 0 swm
D1 0 sw dm
L1 sw out 100u
C1 out 0 100u
R1 out 0 5
B1 g 0 V = (2*(5 - v(out)) + 0.4 > v(ramp)) ? 1 : 0
.model swm SW(RON=1m)
.model dm D
.tran 0.1u 2m uic
.end
"""


def test_comparator_on_the_output_against_ngspice(tmp_path, ngspice):
    """A closed loop: the comparison reads a state, built on inner nodes (E sources), and
    its crossings are located; ngspice runs the B source itself. Mean v(out) over the
    second millisecond: 4.971 V in ngspice (its exponential diode), 4.991 V in pelcs."""
    c = parse_string(VM_BUCK)
    assert c.element("S1").control == ("s1#c2", "0")
    res = simulate_circuit(c, probes=["v(out)"])
    res.raise_if_error()
    assert res.switching == {"S1": "implicit"}
    ng = ngspice_wrdata(VM_BUCK, ["v(out)"], tmp_path)
    keep, mine = ng[:, 0] >= 1e-3, res.t >= 1e-3
    want = np.trapezoid(ng[keep, 1], ng[keep, 0]) / (ng[-1, 0] - 1e-3)
    got = np.trapezoid(res["v(out)"][mine], res.t[mine]) / (res.t[-1] - 1e-3)
    assert got == pytest.approx(want, rel=0.01)


GY = (Path(__file__).parent / "corpus/pess/simulations/converters/Flyback_Conv/edt01.sub")


@pytest.mark.parametrize("load", ["10", "1e6"])
def test_pess_gyrator_two_port_against_ngspice(load, tmp_path, ngspice):
    """The pess transformer's gyrator subcircuit (four linear B sources: two H, two G) as a
    two-port between a source and a load: the same operating point as ngspice's."""
    sub = GY.read_text()
    gy = sub[sub.index(".SUBCKT gy "):]
    gy = gy[:gy.index(".ENDS") + 5]
    deck = (f"gyrator two-port\n{gy}\nVin s 0 10\nRs s p 1\nX1 p 0 q 0 gy N=10\n"
            f"L1 q r 1m\nRL r 0 {load}\n.tran 1u 2m\n.end\n")
    res = simulate_circuit(parse_string(deck), probes=["v(p)", "v(q)", "i(Vin)"])
    res.raise_if_error()
    last = [f"{p}[length(time)-1]" for p in ("v(p)", "v(q)", "i(Vin)")]
    got = ngspice_print(deck, last, tmp_path)
    for probe, key in zip(("v(p)", "v(q)", "i(Vin)"), last, strict=True):
        assert res[probe][-1] == pytest.approx(got[key], rel=1e-5)


# ------------------------------------------------------------------------------ refusals


def _error(text: str) -> str:
    with pytest.raises(NetlistError) as err:
        parse_string(text, file="n.cir")
    return str(err.value)


def test_nonlinear_b_names_file_line_column_and_the_accepted_forms():
    msg = _error("t\nV1 ref 0 1\nR1 ref x 1k\nC2 err x 50n\n"
                 "B1 err 0 V = max(0,min(5,V(ref,x)*V(x)))\n.end\n")
    assert "n.cir:5:26: error: B1: 'V(ref,x)*V(x)' is a product of node voltages" in msg


def test_comparator_output_feeding_a_load_is_its_value():
    # (its output is set by an ideal switch on the comparison: tests/test_comparator_loads.py)
    c = parse_string("t\nVa a 0 1\nB1 g 0 V = v(a) > 0 ? 1 : 0\nR1 g 0 1k\n.end\n")
    names = {el.name for el in c.elements}
    assert {"B1", "B1#s", "B1#u", "B1#r", "R1"} <= names
    assert c.element("B1#s").control == ("a", "0")


def test_comparator_feeding_another_comparator_reads_its_value():
    c = parse_string("t\nVa a 0 1\nB1 g 0 V = v(a) > 0 ? 1 : 0\nB2 h 0 V = v(g) > 0.5 ? 1 : 0\n"
                     "Vin in 0 1\nS1 in o h 0 m\nRo o 0 1\n.model m SW()\n.end\n")
    # B1 drives B2's comparison: its output is its value; B2 only drives S1's control
    assert c.element("B1#s").control == ("a", "0")
    assert c.element("S1").control == ("g", "0")
    assert "B2#s" not in {el.name for el in c.elements}


def test_comparator_values_inside_a_hysteresis_band_are_refused():
    msg = _error("t\nVa a 0 1\nB1 g 0 V = v(a) > 0 ? 1 : 0\nVin in 0 1\nS1 in o g 0 m\n"
                 "R1 o 0 1\n.model m SW(VT=0.5 VH=1)\n.end\n")
    assert "sit in the band 0.5 ± 1 V of switch S1's control" in msg


def test_b_syntax_errors_point_into_the_expression():
    assert "n.cir:2:21: error: expected ')'" in _error("t\nB1 a 0 V = (v(a) + 1\nR1 a 0 1\n"
                                                       ".end\n")
    assert "n.cir:2:8: error: behavioural source 'B1' needs two nodes" in _error(
        "t\nB1 a 0 X=1\nR1 a 0 1\n.end\n")


def test_b_in_an_unused_subcircuit_is_not_an_error():
    # (ngspice skips a definition nothing instantiates; its nonlinear B is never evaluated)
    c = parse_string("t\n.subckt u a b\nB1 a b V = v(a)*v(b)\n.ends\nV1 1 0 1\nR1 1 0 1\n.end\n")
    assert [el.name for el in c.elements] == ["V1", "R1"]


# ------------------------------------------------------------------------------ clamps


def clamp_form(text: str):
    return linearise(parse_behavioural(text), text, {}, clamps=True)


@pytest.mark.parametrize("text, terms, const, lo, hi", [
    ("max(0, min(1.5, 2*(5 - v(out)) + 0.4))", ((v("out"), -2.0),), 10.4, 0.0, 1.5),
    ("min(5, v(ref,x)*10k)", ((v("ref"), 1e4), (v("x"), -1e4)), 0.0, -math.inf, 5.0),
    ("min(2, max(-1, v(a)))", ((v("a"), 1.0),), 0.0, -1.0, 2.0),
    ("2*max(0, min(1, v(a))) + 1", ((v("a"), 2.0),), 1.0, 1.0, 3.0),
    ("-min(1, v(a))", ((v("a"), -1.0),), 0.0, -1.0, math.inf),
    ("min(min(v(a), 2), 3)", ((v("a"), 1.0),), 0.0, -math.inf, 2.0),
])
def test_clamp_forms(text, terms, const, lo, hi):
    c = clamp_form(text)
    assert isinstance(c, Clamp)
    assert c.form == Affine(terms, const) or (c.form.terms == terms and c.form.const == 0)
    assert (c.lo, c.hi) == (lo, hi)
    if len(terms) == 1:
        # and the clamp is the expression: max(lo, min(hi, e)) at a few values of the node
        for x in (-3.0, 0.2, 0.7, 4.0):
            e = terms[0][1] * x + const
            want = eval(text.replace("v(a)", "x").replace("v(out)", "x"),
                        {"max": max, "min": min, "x": x})
            assert max(lo, min(hi, e)) == pytest.approx(want)


def test_clamp_folds_to_a_constant_and_refuses_the_rest():
    assert clamp_form("max(1, min(0, v(a)))") == Affine((), 1.0)
    for text in ("min(v(a), v(b))", "min(5, v(a)) > v(b)", "u(min(1, v(a)))",
                 "min(1, v(a)) * v(b)"):
        with pytest.raises(BehaviouralError):
            clamp_form(text)
    with pytest.raises(BehaviouralError, match="min\\(\\) of a node voltage"):
        form("min(5, v(a))")  # a clamp only where the B source is read whole


CLAMP_BUCK = Path(__file__).parent / "netlists/closed_loop/clamped_error_amp_buck.cir"


def test_clamp_folds_into_the_comparator():
    c = parse_string(CLAMP_BUCK.read_text())
    assert not any(el.kind == "B" for el in c.elements)
    assert any("Bea: clamp" in n and "folded into comparator Bpwm" in n for n in c.notes)
    # on while the unclamped error 2*(5 - v(out)) + 0.4 is above the ramp
    assert any("on while -v(ramp) - 2*v(out) + 10.4 > 0" in n for n in c.notes)


def test_clamped_error_amplifier_against_ngspice(tmp_path, ngspice):
    """The closed-loop buck whose error amplifier saturates at 1.5 V during start-up (ngspice's
    v(ea) is 1.5 V until 92 us): v(out) during the saturation, and its mean over the second
    millisecond (ngspice 4.971 V, its exponential diode; pelcs 4.991 V)."""
    text = CLAMP_BUCK.read_text()
    res = simulate_circuit(parse_string(text), probes=["v(out)"])
    res.raise_if_error()
    assert res.switching == {"S1": "implicit"}
    ng = ngspice_wrdata(text, ["v(out)", "v(ea)"], tmp_path)
    t_ng, out_ng, ea_ng = ng[:, 0], ng[:, 1], ng[:, 3]
    saturated = t_ng[np.argmax(ea_ng < 1.5 - 1e-9)]
    assert 50e-6 < saturated < 150e-6 and ea_ng[t_ng < 50e-6].min() == pytest.approx(1.5)
    for t in (30e-6, 60e-6, saturated):
        assert np.interp(t, res.t, res["v(out)"]) == pytest.approx(
            np.interp(t, t_ng, out_ng), rel=0.01)
    keep, mine = t_ng >= 1e-3, res.t >= 1e-3
    want = np.trapezoid(out_ng[keep], t_ng[keep]) / (t_ng[-1] - 1e-3)
    got = np.trapezoid(res["v(out)"][mine], res.t[mine]) / (res.t[-1] - 1e-3)
    assert got == pytest.approx(want, rel=0.01)


@pytest.mark.parametrize("change, words", [
    # a maximum-duty clamp: the ramp passes the clamp's top, where the clamp decides
    ("min(1.5,", "spans 0 to 1 V, beyond the clamp's range 0 to 0.8 V"),
    # a strict comparison against a ramp that reaches the clamp's top
    ("min(1.5,", "spans 0 to 1 V, beyond the clamp's range 0 to 1 V"),
    ("Bpwm g 0 V = (v(ea) > v(ramp))", "reads v(out), which is not a DC, PULSE or PWL"),
    ("R1 out 0 5", "it feeds R2"),
])
def test_clamp_outside_the_control_path_is_a_limiter(change, words):
    text = CLAMP_BUCK.read_text()
    if words.startswith("spans") and "0.8" in words:
        text = text.replace(change, "min(0.8,")
    elif words.startswith("spans"):
        text = text.replace(change, "min(1,")
    elif change.startswith("Bpwm"):
        text = text.replace(change, "Bpwm g 0 V = (v(ea) > v(ramp) + 0.1*v(out))")
    else:
        text = text.replace(change, change + "\nR2 ea 0 1k")
    c = parse_string(text)
    assert any("Bea: clamp" in n and "built as an ideal limiter" in n and words in n
               for n in c.notes)
    assert {el.name for el in c.elements if el.kind == "D"} >= {"Bea#dlo", "Bea#dhi"}


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("compare", ["v(ea) > v(ramp)", "v(ea) >= v(ramp)", "v(ea) < v(ramp)",
                                     "v(ea) <= v(ramp)", "v(ramp) - 2*v(ea) > -1",
                                     "v(ramp) - 2*v(ea) >= -1"])
@pytest.mark.parametrize("ramp", [(0, 1), (0.2, 0.8), (0, 0.5), (0.5, 1), (-0.1, 0.5),
                                  (0.5, 1.1)])
def test_clamp_is_folded_exactly_where_it_does_not_decide(compare, ramp):
    """The fold is accepted exactly where comparing the clamp max(0, min(1, e)) is comparing
    e for every e and every level the ramp takes (brute force over a grid that holds the
    bounds and the ramp's ends)."""
    text = (f"t\nVr ramp 0 PULSE({ramp[0]} {ramp[1]} 0 9u 1u 0 10u)\nVx x 0 0.3\n"
            "Bea ea 0 V = max(0, min(1, v(x)))\n"
            f"Bc g 0 V = ({compare}) ? 1 : 0\nS1 a 0 g 0 sw\nR1 a 0 1\n.model sw SW\n"
            ".tran 1u 20u\n.end\n")
    py = compare.replace("v(ea)", "c").replace("v(ramp)", "r")
    es = np.unique(np.r_[np.linspace(-2, 3, 51), 0.0, 1.0])
    rs = np.linspace(*ramp, 61)
    agree = all(eval(py, {"c": max(0.0, min(1.0, e)), "r": r}) == eval(py, {"c": e, "r": r})
                for e in es for r in rs)
    c = parse_string(text)
    assert not any(el.kind == "B" for el in c.elements)
    limiter = [n for n in c.notes if "built as an ideal limiter" in n]
    if agree:
        assert not limiter
    else:
        assert len(limiter) == 1 and "where the clamp decides the comparison" in limiter[0]


TIME_STEPS = """B sources of time alone, stepping between constants
.subckt stepper g
Bg g 0 V = (time > 0.5m) ? 1 : 0
.ends
V1 in 0 DC 5
R1 in a 1k
C1 a 0 1u
X1 g stepper
S1 a c g 0 SWM
Rc c 0 100
.model SWM SW(VT=0.5 RON=1m ROFF=1G)
Bl 0 a I = time >= 1.2m && time < 1.6m ? 2m : 0
Bv y 0 v={u(time - 0.3m)*2 + (time > 1.5m)}
Ry y 0 1k
.tran 1u 2m
.end
"""


def test_b_source_of_time_alone_is_the_stepping_source_it_is(tmp_path, ngspice):
    # ngspice evaluates the expression at each of its steps: the same waveform, its steps
    # landing on or just past the instants
    c = parse_string(TIME_STEPS)
    bg = c.element("X1.Bg")
    assert isinstance(bg, VoltageSource) and bg.dc == 0.0
    assert bg.waveform.times == (0.0, 0.5e-3, 0.5e-3) and bg.waveform.values == (0, 0, 1)
    bl = c.element("Bl")
    assert isinstance(bl, CurrentSource) and bl.nodes == ("0", "a")
    assert bl.waveform.values == (0, 0, 2e-3, 2e-3, 0)
    assert c.element("Bv").waveform.values == (0, 0, 2, 2, 3)
    run = simulate_circuit(c, probes=["v(a)", "v(y)"])
    data = ngspice_wrdata(TIME_STEPS, ["v(a)", "v(y)"], tmp_path)
    t = data[:, 0]
    away = np.min(np.abs(t[:, None] - np.array([0.3e-3, 0.5e-3, 1.2e-3, 1.5e-3, 1.6e-3])),
                  axis=1) > 5e-6
    # (measured: 10 mV on v(a)'s 5 V, ngspice turning S1 at its first step past 0.5 ms;
    # v(y) exact)
    for k, atol in ((0, 0.02), (1, 1e-9)):
        ours = np.interp(t[away], run.t, run.y[:, k])
        np.testing.assert_allclose(ours, data[away, 2 * k + 1], atol=atol)


# 'e' beside a .param and a subcircuit parameter of that name: ngspice 39's B sources read
# Euler's number all the same (measured: v(a) = v(c) = 2.718282 V, v(b) = 2.718282*2 V)
E_DECK = """e in B sources
.param e=5
.subckt half o params: e=7
B1 o 0 V=e*(1+time)
.ends
B1 a 0 V=e*(1+time*1k)
R1 a 0 1
V2 d 0 DC 2
B2 b 0 V=e*v(d)
R2 b 0 1
X1 c half e=3
R3 c 0 1
.tran 10u 1m
.end
"""


def test_e_is_eulers_number_in_a_b_source_whatever_the_params():
    res = simulate_circuit(parse_string(E_DECK), probes=["v(a)", "v(b)", "v(c)"])
    assert res.y[0] == pytest.approx([math.e, 2 * math.e, math.e], rel=1e-12)
    assert res.y[-1, 0] == pytest.approx(2 * math.e, rel=1e-9)


@pytest.mark.slow
def test_e_in_a_b_source_as_ngspice(tmp_path, ngspice):
    got = ngspice_print(E_DECK, ["v(a)[0]", "v(b)[0]", "v(c)[0]"], tmp_path)
    assert list(got.values()) == pytest.approx([math.e, 2 * math.e, math.e], rel=1e-6)


def test_a_comparator_value_inside_a_hysteresis_band_is_named_alone():
    # 5 is above VT + VH = 0.5 V; only 0 is inside the band 0.2 ± 0.3 V
    msg = _error("t\nVa a 0 1\nB1 g 0 V = v(a) > 0 ? 5 : 0\nVin in 0 1\nS1 in o g 0 m\n"
                 "R1 o 0 1\n.model m SW(VT=0.2 VH=0.3)\n.end\n")
    assert "its value 0 sits in the band 0.2 ± 0.3 V of switch S1's control" in msg
    assert "5 and 0" not in msg


def test_a_refused_comparator_leaves_no_floating_control_error():
    # the refused B source's output node is not a floating control node of S1
    msg = _error("t\nVa a 0 1\nB1 g 0 V = v(a) > 0 ? 5 : 0\nVin in 0 1\nS1 in o g 0 m\n"
                 "R1 o 0 1\n.model m SW(VT=0.2 VH=0.3)\n.end\n")
    assert "sits in the band" in msg and "not connected to any element" not in msg
