"""ngspice spellings met in third-party netlists (tests/corpus), each read as ngspice reads it.

Where ngspice gives a number the test compares pelcs's reading with it (ngspice in pipe mode
on a small deck); the LTspice-only forms have notes that say what pelcs does instead.
"""

from __future__ import annotations

import math

import pytest
from ngspice_helpers import ngspice_print

from lcs.signals import Pulse, Sin
from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.studies.realistic import simulate_devices

pytestmark = pytest.mark.filterwarnings("ignore::UserWarning")


SINE_DECK = """sine source as eSim writes it, and KiCad's DC/SIN/AC order
v1 a 0 sine(0 5 50 0 0)
V2 b 0 DC 0 SIN( 0 3 100 0 0 0 ) AC 1
r1 a 0 1k
R2 b 0 1k
.tran 0.1m 20m
.end
"""


def test_sine_and_kicad_order(tmp_path, ngspice):
    c = parse_string(SINE_DECK)
    a, b = c.element("v1").waveform, c.element("V2").waveform
    assert isinstance(a, Sin) and (a.vo, a.va, a.freq) == (0, 5, 50)
    assert isinstance(b, Sin) and (b.vo, b.va, b.freq) == (0, 3, 100)
    got = ngspice_print(SINE_DECK, ["v(a)[26]", "time[26]", "v(b)[26]"], tmp_path)
    t = got["time[26]"]
    assert got["v(a)[26]"] == pytest.approx(5 * math.sin(2 * math.pi * 50 * t), abs=1e-6)
    assert got["v(b)[26]"] == pytest.approx(3 * math.sin(2 * math.pi * 100 * t), abs=1e-6)


@pytest.mark.parametrize("order", ["AC 1 DC 2 SIN(2 1 50)", "SIN(2 1 50) AC 1 DC 2",
                                   "DC 2 AC 1 0 SIN 2 1 50", "2 SIN(2 1 50) AC 1"])
def test_source_parts_in_any_order(order):
    c = parse_string(f"t\nV1 a 0 {order}\nR1 a 0 1\n.tran 1m 10m\n")
    el = c.element("V1")
    assert el.dc == 2 and isinstance(el.waveform, Sin) and el.waveform.va == 1


DC_EQUALS_DECK = """DC= and AC= (ngspice's lexer reads the '=' as a blank)
V1 a 0 DC=2 AC=1
Ra a 0 1k
I1 0 b dc = 3m AC= 1 0 PULSE(0 1m 1m 1u 1u 1m 2m)
Rb b 0 1k
.tran 10u 0.5m
.end
"""


def test_dc_and_ac_written_with_equals(tmp_path, ngspice):
    c = parse_string(DC_EQUALS_DECK)
    assert c.element("V1").dc == 2 and c.element("I1").dc == pytest.approx(3e-3)
    got = ngspice_print(DC_EQUALS_DECK, ["v(a)[1]", "v(b)[1]"], tmp_path)
    assert got["v(a)[1]"] == pytest.approx(2)
    # the PULSE's first value, as in pelcs's transient (the DC value is the operating point's)
    assert got["v(b)[1]"] == pytest.approx(0, abs=1e-9)
    wave = c.element("I1").waveform
    assert isinstance(wave, Pulse) and (wave.v1, wave.v2) == (0, pytest.approx(1e-3))


# DC(48) and AC(1 0): ngspice's lexer reads parentheses as blanks too (eduardobehr/power-
# electronics' buck netlists write 'V1 /Vin GND dc(48)'); pelcs stopped at the '('
DC_PAREN_DECK = """DC(value) and AC(mag phase) in parentheses
V1 a 0 dc(48)
Ra a 0 1k
I1 0 b DC(2m) AC(1 0)
Rb b 0 1k
V2 c 0 DC (5) AC(1)
Rc c 0 1
.tran 1u 10u
.end
"""


def test_dc_and_ac_values_in_parentheses(tmp_path, ngspice):
    c = parse_string(DC_PAREN_DECK)
    assert c.element("V1").dc == 48 and c.element("I1").dc == pytest.approx(2e-3)
    assert c.element("V2").dc == 5
    got = ngspice_print(DC_PAREN_DECK, ["v(a)[1]", "v(b)[1]", "v(c)[1]"], tmp_path)
    assert got == {"v(a)[1]": pytest.approx(48), "v(b)[1]": pytest.approx(2),
                   "v(c)[1]": pytest.approx(5)}


# (SFFM and AM are read: tests/test_modulated_sources.py)
@pytest.mark.parametrize("fn", ["TRNOISE(1m 1n 0 0)", "TRRANDOM(1 1n 0 1)"])
def test_unsupported_source_functions_named(fn):
    with pytest.raises(NetlistError) as info:
        parse_string(f"t\nV1 a 0 {fn}\nR1 a 0 1\n.tran 1m 10m\n")
    word = fn.split("(")[0]
    assert f"{word} sources are not supported" in str(info.value)


def test_pwl_repeat_and_delay_are_read_and_a_repeat_off_the_points_is_refused():
    # ngspice's PWL(...) r=T td=T (repeat from the point at T, delay): read as ngspice does
    # (their waveforms are checked against ngspice in tests/test_source_corners.py); r must be
    # one of the points' times, as ngspice requires.
    parse_string("t\nV1 a 0 PWL(0 0 1m 1) r=0 td=1m\nR1 a 0 1\n.tran 1u 5m\n")
    with pytest.raises(NetlistError) as info:
        parse_string("t\nV1 a 0 PWL(0 0 1m 1) r=0.5m\nR1 a 0 1\n.tran 1u 5m\n")
    assert ":2:" in str(info.value) and "r=" in str(info.value)


R_MODEL_DECK = """resistor with a model name
V1 a 0 1
R1 a 0 600k MDR
.model MDR R TC1=0 TC2=0
.tran 1u 10u
.end
"""


def test_resistor_model_name(tmp_path, ngspice):
    c = parse_string(R_MODEL_DECK)
    assert c.element("R1").value == 600e3
    assert not any("R1:" in n for n in c.notes)  # (TC1 = TC2 = 0: nothing scaled)
    got = ngspice_print(R_MODEL_DECK, ["i(V1)[1]"], tmp_path)
    # ngspice prints 6 digits
    assert -got["i(V1)[1]"] == pytest.approx(1 / c.element("R1").value, rel=1e-5)
    with pytest.raises(NetlistError, match="unexpected '2k'"):
        parse_string("t\nV1 a 0 1\nR1 a 0 1k 2k\n")


TEMPERATURE_DECK = """temperature coefficients of R, L, C away from their nominal temperature
.options temp=60
.subckt half in out
R1 in out 1k RLOC
.model RLOC R(tc1=2m tnom=40)
.ends
V1 in 0 10
X1 in a half
R2 a 0 1k MDR tc1=-1m
R3 a b 500 temp=100 tc2=1e-5
R4 b 0 2k dtemp=10 tc1=1m
C1 a 0 1u tc1=5m dtemp=10
L1 b c 10m tc1=3m
R5 c 0 1
.model MDR R TC1=0.01 TC2=1e-4 TNOM=30
.temp 77
.tran 1u 10u
.end
"""


def test_temperature_coefficients_scale_values_as_ngspice(tmp_path, ngspice):
    # ngspice's 1 + TC1 dT + TC2 dT^2 (restemp.c, captemp.c, indtemp.c): .temp over
    # .options temp, the instance's tc1/tc2 over its model's, temp= over dtemp=, the model's
    # TNOM (a model local to a subcircuit too)
    c = parse_string(TEMPERATURE_DECK)
    value = {n: c.element(n).value for n in ("X1.R1", "R2", "R3", "R4", "C1", "L1")}
    assert value["X1.R1"] == pytest.approx(1e3 * (1 + 2e-3 * 37))
    assert value["R2"] == pytest.approx(1e3 * (1 - 1e-3 * 47 + 1e-4 * 47**2))
    assert value["R3"] == pytest.approx(500 * (1 + 1e-5 * 73**2))
    assert value["R4"] == pytest.approx(2e3 * (1 + 1e-3 * 60))
    assert value["C1"] == pytest.approx(1e-6 * (1 + 5e-3 * 60))
    assert value["L1"] == pytest.approx(10e-3 * (1 + 3e-3 * 50))
    assert any("R2: value scaled by 1.1739" in n and "30 °C to its 77 °C" in n
               for n in c.notes)
    got = ngspice_print(TEMPERATURE_DECK, ["v(a)[1]", "v(b)[1]"], tmp_path)
    r2, r3, r4, r5 = value["R2"], value["R3"], value["R4"], 1.0  # (L1 a short at DC)
    below = 1 / (1 / r2 + 1 / (r3 + 1 / (1 / r4 + 1 / r5)))
    va = 10 * below / (value["X1.R1"] + below)
    assert got["v(a)[1]"] == pytest.approx(va, rel=1e-5)


MODEL_THEN_R_DECK = """a resistor written with its model first and its value as r=
V1 a 0 1
R2 a 0 mdr2 r=300k
.model mdr2 R(tc1=0.01)
.temp 37
.tran 1u 10u
.end
"""


def test_resistor_model_first_and_value_as_r(tmp_path, ngspice):
    # ngspice's semiconductor-resistor order: the model's TC1 still applies (300k * 1.1)
    c = parse_string(MODEL_THEN_R_DECK)
    assert c.element("R2").value == pytest.approx(330e3)
    got = ngspice_print(MODEL_THEN_R_DECK, ["i(V1)[1]"], tmp_path)
    assert -got["i(V1)[1]"] == pytest.approx(1 / 330e3, rel=1e-5)


SW_DECK = """switch model with spaces instead of '=', and a multi-line model closed by ')'
V1 a 0 1
Vc c 0 1
S1 a b c 0 swm
R1 b 0 1
.model swm SW( RON 0.25 ROFF 1e6 VT 0.5 )
D1 a d dm
R2 d 0 1k
.model dm D (
+ IS=1e-14
+ N=1
)
.tran 1u 10u
.end
"""


def test_model_name_value_pairs_and_bare_paren(tmp_path, ngspice):
    c = parse_string(SW_DECK)
    assert c.models["swm"].params == {"ron": 0.25, "roff": 1e6, "vt": 0.5, "vh": 0.0}
    assert c.models["dm"].params["is"] == 1e-14 and c.models["dm"].params["n"] == 1
    got = ngspice_print(SW_DECK, ["v(b)[1]", "v(d)[1]"], tmp_path)
    # ngspice reads RON 0.25: 1 V over 0.25 + 1 Ohm
    assert got["v(b)[1]"] == pytest.approx(1 / 1.25, rel=1e-6)
    # and the diode's IS and N: 1 V = vd + 1k * IS (exp(vd / Vt) - 1)
    vd = 1 - got["v(d)[1]"]
    vt = 1.380649e-23 * 300.15 / 1.602176634e-19
    assert got["v(d)[1]"] / 1e3 == pytest.approx(1e-14 * math.expm1(vd / vt), rel=1e-3)


def test_vdmos_channel_flags():
    body = "t\nV1 d 0 10\nR1 d x 1\nVg g 0 {}\nM1 x g 0 MM\n.tran 1u 10u\n"
    n = parse_string(body.format(5) + ".model MM VDMOS nchan Vto=3 Kp=1\n")
    p = parse_string(body.format(-5) + ".model MM VDMOS(pchan Vto=-3 Kp=1)\n")
    assert n.models["mm"].params.get("pchan") is None
    assert p.models["mm"].params["pchan"] == 1.0
    with pytest.raises(NetlistError, match="VDMOS flag"):
        parse_string("t\nV1 a 0 1\nD1 a 0 DM\n.model DM D(pchan IS=1n)\n")


def test_ltspice_tran_modifiers():
    body = "t\nV1 a 0 1\nR1 a b 1\nC1 b 0 1u\n"
    c = parse_string(body + ".tran 0 1m startup\n")
    assert c.tran.tstop == 1e-3
    assert any("startup (LTspice) ignored" in n for n in c.notes)
    c = parse_string(body + ".tran 1u 1m 0 1u steady nodiscard uic\n")
    assert c.tran.uic and c.tran.tmax == 1e-6
    assert any("steady (LTspice) ignored" in n for n in c.notes)
    # LTspice's .tran TSTOP: .tran 0 TSTOP, with a note (ngspice refuses the line)
    c = parse_string(body + ".tran 1m\n")
    assert c.tran.tstop == 1e-3 and c.tran.no_tstep
    assert any(".tran TSTOP (LTspice; ngspice needs .tran TSTEP TSTOP)" in n for n in c.notes)


INNER = """.title inner schematic netlist
V1 a 0 1
R1 a b 1k
C1 b 0 1u
.tran 1u 1m
"""
WRAPPER = """* wrapper
.tran 10u 5m
.include inner.net
.end
"""


def test_wrapper_tran_wins(tmp_path, ngspice):
    (tmp_path / "inner.net").write_text(INNER)
    (tmp_path / "top.cir").write_text(WRAPPER)
    c = parse_file(tmp_path / "top.cir")
    assert c.tran.tstop == 5e-3 and c.tran.tstep == 10e-6
    assert any("inner.net:5: .tran ignored" in n for n in c.notes)
    # ngspice runs both; the plot it leaves current (the one plotted and written) is the
    # wrapper's
    got = ngspice_print(WRAPPER, ["time[length(time)-1]"], tmp_path, {"inner.net": INNER})
    assert got["time[length(time)-1]"] == pytest.approx(5e-3)
    # two .tran lines in the top-level file are still an error
    with pytest.raises(NetlistError, match="second .tran"):
        parse_string(INNER + ".tran 1u 2m\n")


UNUSED = """unused subcircuit and model that pelcs cannot read
V1 a 0 1
R1 a 0 1k
.subckt opamp in out
E1 out 0 poly(1) in 0 0 1e5 1
B1 x 0 V = V(in) * * 2
.ends
.model JX NJF(BETA=1m)
.tran 1u 10u
.end
"""


def test_unused_definitions_skipped(tmp_path, ngspice):
    c = parse_string(UNUSED)
    assert [e.name for e in c.elements] == ["V1", "R1"]
    assert any("subcircuit 'opamp'" in n and "not used" in n for n in c.notes)
    assert any("model 'jx'" in n and "not used" in n for n in c.notes)
    got = ngspice_print(UNUSED, ["i(V1)[1]"], tmp_path)  # ngspice runs it as well
    assert got["i(V1)[1]"] == pytest.approx(-1e-3)
    used = UNUSED.replace("R1 a 0 1k", "R1 a 0 1k\nX1 a o opamp\nRo o 0 1k")
    with pytest.raises(NetlistError) as info:
        parse_string(used)
    assert "poly" in str(info.value) and "unexpected '*'" in str(info.value)


def test_control_block_tran(tmp_path, ngspice):
    deck = ("control tran\nV1 a 0 PULSE(0 1 0 1u 1u 5u 10u)\nR1 a b 1k\nC1 b 0 1n\n"
            ".control\ntran 0.1u 50u\nplot v(b)\n.endc\n.end\n")
    c = parse_string(deck)
    assert (c.tran.tstep, c.tran.tstop) == (0.1e-6, 50e-6)
    assert any("`tran` command read as the .tran line" in n for n in c.notes)
    # a .tran line wins over the block's command
    c = parse_string(deck.replace(".control", ".tran 1u 20u\n.control"))
    assert c.tran.tstop == 20e-6
    # ngspice runs the block's tran when it reads the file
    got = ngspice_print(deck, ["time[length(time)-1]"], tmp_path)
    assert got["time[length(time)-1]"] == pytest.approx(50e-6)


AFTER_END = """elements after .end (engineer-e's form2: a .control block, .end, then the netlist)
.control
tran 1u 1m
.endc
.end
V1 a 0 1
R1 a 0 1k
.END
R2 a 0 1k
"""


def test_lines_after_end_are_still_the_netlist(tmp_path, ngspice):
    """ngspice turns a ``.end`` line into a comment and reads on (inpcom.c): the elements
    after it, even after a second one, are in the circuit (R1 || R2: 2 mA)."""
    c = parse_string(AFTER_END)
    assert [e.name for e in c.elements] == ["V1", "R1", "R2"]
    assert c.tran.tstop == 1e-3
    got = ngspice_print(AFTER_END, ["i(V1)[1]"], tmp_path)
    assert got["i(V1)[1]"] == pytest.approx(-2e-3)


# forms met in public ngspice netlists (ngspice's own examples, course labs), each deck's
# v(o) in pelcs against ngspice's
FORMS = {
    # an unbraced value: a number first, all of it (spaces too); a name or '(' first, up to
    # a space outside parentheses (ngspice's inp_fix_param_values)
    "param call": ".param a = sqrt(4)\n.param b = 1 * (1 + 0.5) * a\n.param c=max(1, 2)\n"
                  ".param d = (a * 2) e=a*(1+1)\nV1 o 0 {b*c*d*e}\nR1 o 0 1k\n",
    "param comment": ".param raiz_2 = sqrt(2);\nV1 o 0 {raiz_2}\nR1 o 0 1k\n",
    # Sue/ngspice keyword forms of a source's DC and AC values, quoted
    "dc= ac=": "V1 o 0 dc='12' ac='0'\nR1 o 0 1k\n",
    # E with its node pairs in parentheses (PySpice's small-signal amplifier)
    "E pairs": "V1 a 0 1\nE1 (o 0) (a 0) -10\nR1 o 0 1k\n",
    "E pair comma": "V1 a 0 2\nE1 (o,0) a 0 3\nR1 o 0 1k\n",
    # a parameter's bare name as a value (ngspice substitutes it: lopesivan's periodo.sp)
    "bare param": ".param rval=2k vv=3\nV1 a 0 DC vv\nR1 a o 1k\nR2 o 0 rval\n",
    # a parameter named pi is the value ngspice's numparam takes for pi (it was the constant)
    "param pi": ".param pi=2\nV1 a 0 3\nR1 a o {pi}\nR2 o 0 1\n",
    "param pi bare": ".param pi=2\nV1 a 0 3\nR1 a o pi\nR2 o 0 1\n",
    # a resistor's TC (ngspice's TransImpedanceAmp example): nothing at 27 C
    "R TC": "V1 a 0 1\nR1 a o 1E3 TC=7E-6\nR2 o 0 1k\n",
    # a .model whose ')' comes before its continuation (ngspice's 555 timer example):
    # ngspice reads parentheses as separators
    "model paren": "V1 a 0 1\nR1 a o 1k\nD1 o 0 DA\n.MODEL DA D (RS=40 IS=1.0E-14)\n"
                   "+ N=2)\n",
}


@pytest.mark.parametrize("form", sorted(FORMS))
def test_ngspice_forms(form, tmp_path, ngspice):
    deck = f"t\n{FORMS[form]}.tran 1u 10u\n.end\n"
    res = simulate_devices(parse_string(deck), devices="pwl", probes=["v(o)"])
    res.raise_if_error()
    got = float(res["v(o)"][-1])
    want = ngspice_print(deck, ["v(o)[5]"], tmp_path)["v(o)[5]"]
    # (ngspice prints 7 digits; the diode's pwl fit within 10 mV of its exponential)
    assert got == pytest.approx(want, rel=1e-6, abs=1e-2 if form == "model paren" else 0)


@pytest.mark.parametrize("line, where", [(".param b = a * 1.5", 12), (".param b = sqrt(a) * 2", 18),
                                         (".param b = a + 1, c=1", 12),
                                         (".param b = 1 + a, c=1", 12)])
def test_an_unbraced_value_ngspice_stops_in_is_refused(line, where, tmp_path, ngspice):
    deck = f"t\n.param a = 2\n{line}\nV1 o 0 {{b}}\nR1 o 0 1k\n.tran 1u 10u\n.end\n"
    with pytest.raises(NetlistError) as exc:
        parse_string(deck)
    text = str(exc.value)
    assert f"<string>:3:{where + 1}: error: ngspice reads" in text and "write b={" in text
    # (what ngspice does with them: stops, or for the last, sets b to 1)
    if "1 + a" in line:
        got = ngspice_print(deck, ["v(o)[3]"], tmp_path)["v(o)[3]"]
        assert got == 1.0


@pytest.mark.parametrize("deck, want", [
    # in a subcircuit a value that starts with a number is cut at its first space too: pelcs
    # read rv = 3 (v(o) 0.25 V) where ngspice's rv is 1 (0.5 V)
    ("t\n.subckt rr a b\n.param rv = 1 + 2\nR1 a b {rv}\n.ends\nV1 1 0 1\nX1 1 o rr\n"
     "R2 o 0 1\n.tran 1u 10u\n.end\n", 0.5),
    # beside a braced value as well: pelcs read b = 5 where ngspice's b is 2
    ("t\n.param a={1} b = 2 + 3\nV1 o 0 {b}\nR1 o 0 1k\n.tran 1u 10u\n.end\n", 2.0),
])
def test_an_unbraced_value_ngspice_cuts_in_a_subcircuit_is_refused(deck, want, tmp_path,
                                                                    ngspice):
    with pytest.raises(NetlistError, match=r":[23]:\d+: error: ngspice reads '\w' as the value"):
        parse_string(deck)
    assert ngspice_print(deck, ["v(o)[3]"], tmp_path)["v(o)[3]"] == want


def test_control_characters_are_blanks(tmp_path, ngspice):
    # a schematic tool's export (Sue, tests/corpus-like lab files) leaves DC3 after values:
    # ngspice reads '1nf\x13' as 1 nF and 'ic=0\x13' as 0
    deck = "t\nV1 a 0 DC 1\nR1 a b 1k\x13\nC1 b 0 1nf\x13 ic=0\x13\n.tran 1u 10u\n.end\n"
    path = tmp_path / "cc.cir"
    path.write_bytes(deck.encode())
    res = simulate_devices(parse_file(path), devices="pwl", probes=["v(b)"])
    want = ngspice_print(deck, ["v(b)[5]"], tmp_path)["v(b)[5]"]
    assert float(res["v(b)"][-1]) == pytest.approx(want, rel=1e-6)


def test_a_control_character_starting_a_line_is_refused(tmp_path, ngspice):
    # ngspice 39 does not read a line that starts with one (a form feed comments it out,
    # with a warning; DC3 is an 'unknown device type' error): blanked, pelcs read R1 and
    # printed v(b) 0.5 V where ngspice's run, without R1, gives 0 V
    deck = "t\nV1 a 0 1\n\x0cR1 a b 1k\nR2 b 0 1k\n.tran 1u 10u\n.end\n"
    assert ngspice_print(deck, ["v(b)[2]"], tmp_path)["v(b)[2]"] == 0.0
    for text in (deck, deck.replace("\x0c", " \x13")):
        path = tmp_path / "ff.cir"
        path.write_bytes(text.encode())
        for read, arg in ((parse_file, path), (parse_string, text)):
            with pytest.raises(NetlistError, match=r":3:\d: error: control character 0x"):
                read(arg)
    # a page break alone on its line, before a comment, or in the title is nothing
    fine = "\x0ct\x13\n\x0c\n\x0c* page 2\nV1 a 0 1\nR1 a b 1k\x13\nR2 b 0 1k\n.tran 1u 10u\n.end\n"
    assert [e.name for e in parse_string(fine).elements] == ["V1", "R1", "R2"]
    # and the API's text reads '1nf\x13' as the file does
    assert parse_string("t\nV1 a 0 1\nC1 a 0 1nf\x13\n.end\n").element("C1").value == 1e-9
