"""The error catalogue: malformed netlists, each with its message, line and column.

Every case is a whole netlist (title first). ``line``/``col`` are where the caret must point;
``None`` for problems that belong to no single line, which must name the elements instead.
"""

import os

import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import simulate_circuit

OK = "V1 a 0 1\nR1 a 0 1k\n"  # a valid body to put next to a mistake

# (id, netlist text, message substring, line, column, hint substring)
CATALOGUE = [
    ("jfet", "t\nV1 a 0 1\nJ1 a g 0 NJF\n",
     "unknown element type 'J' (JFET)", 3, 1, "S switch driven by the gate"),
    ("mosfet-model", "t\nV1 a 0 1\nM1 a g 0 0 NMOS\n",
     "M1: unknown model 'NMOS'", 3, 12, ".model NMOS NMOS/PMOS/VDMOS"),
    ("bjt-model", "t\nV1 a 0 1\nQ1 a b 0 NPN\n", "Q1: unknown model 'NPN'", 3, 10,
     ".model NPN NPN/PNP"),
    ("b-source", "t\nV1 a 0 1\nB1 b 0 V={v(a)**2}\n", "is a power of a node voltage", 3, 10,
     "linear in v() and i()"),
    ("t-line", "t\nV1 a 0 1\nT1 a 0 b 0 Z0=50 TD=1n\n", "(transmission line)", 3, 1,
     "L and C"),
    ("w-switch", "t\nV1 a 0 1\nW1 a 0 V1\n", "current-controlled switch 'W1' needs", 3, 10,
     "Vcontrol model"),
    ("w-model", "t\nV1 a 0 1\nW1 a 0 V1 nope\n", "W1: unknown model 'nope'", 3, 11, "CSW("),
    ("unknown-letter", "t\nV1 a 0 1\n9R a 0 1\n", "unknown element type '9' in '9R'", 3, 1,
     "R L C V I D S W E F G H K X"),
    ("unknown-dot", "t\n" + OK + ".foo bar\n", "unknown dot command '.foo'", 4, 1,
     "supported: .param"),
    ("func", "t\n" + OK + ".func f(x {x*2}\n", "malformed .func", 4, 7, "syntax"),
    ("poly", "t\n" + OK + "E1 b 0 POLY(1) a 0 0 1 3\n",
     "E source with a nonlinear POLY(1): coefficient '3'", 4, 24, "affine"),
    ("g-table", "t\n" + OK + "G1 b 0 TABLE {v(a)} = (0,0) (1,1) (2,3)\n",
     "G source TABLE with 3 points", 4, 23, "two points"),
    ("bad-number", "t\nV1 a 0 1\nR1 a 0 1k2\n", "invalid number '1k2'", 3, 8, "suffix"),
    # (a bare parameter name is its value, as in ngspice: tests/test_netlist_spellings.py)
    ("bare-unknown", "t\nV1 a 0 1\nR1 a 0 rval\n", "unknown parameter 'rval'", 3, 8,
     ".param"),
    ("incomplete-r", "t\nV1 a 0 1\nR1 a 0\n", "incomplete resistor 'R1'", 3, 7,
     "Rname n+ n- value"),
    ("extra-field", "t\nV1 a 0 1\nR1 a 0 1k 2k\n", "unexpected '2k' in resistor 'R1'", 3, 11,
     "syntax"),
    ("unknown-param", "t\nV1 a 0 1\nR1 a 0 {2*rr}\n", "unknown parameter 'rr'", 3, 11,
     ".param"),
    ("param-typo", "t\n.param rload=10\nV1 a 0 1\nR1 a 0 {rlaod}\n",
     "unknown parameter 'rlaod'", 4, 9, "did you mean rload"),
    ("param-cycle", "t\n" + OK + ".param a={b+1} b={c} c={2*a}\n",
     "parameter cycle: a -> b -> c -> a", 4, 8, "depend on themselves"),
    ("self-cycle", "t\n" + OK + ".param x={x+1}\n", "parameter cycle: x -> x", 4, 8, ""),
    ("div-zero", "t\n.param z=0\nV1 a 0 1\nR1 a 0 {1/z}\n", "division by zero", 4, 11, ""),
    ("math-domain", "t\nV1 a 0 1\nR1 a 0 {sqrt(-4)}\n", "cannot evaluate sqrt(-4)", 3, 9, ""),
    ("bad-expression", "t\nV1 a 0 1\nR1 a 0 {2*(1+}\n", "incomplete expression", 3, 14, ""),
    ("unknown-function", "t\nV1 a 0 1\nR1 a 0 {foo(2)}\n", "unknown function 'foo'", 3, 9,
     "sqrt"),
    ("unclosed-brace", "t\nV1 a 0 1\nR1 a 0 {1+2\n", "unexpected character '{'", 3, 8,
     "closed"),
    ("unclosed-quote", "t\nV1 a 0 1\nR1 a 0 '1+2\n", "unexpected quote", 3, 8, "closed"),
    ("unknown-model", "t\n" + OK + "D1 a 0 NOPE\n", "unknown model 'NOPE' for diode D1", 4, 8,
     ".model NOPE D"),
    ("wrong-model-type", "t\n" + OK + "D1 a 0 SWM\n.model SWM SW(VT=1)\n",
     "a diode needs a D model", 4, 8, "D(...)"),
    ("switch-model-type", "t\n" + OK + "S1 a 0 a 0 DM\n.model DM D\n",
     "a switch needs a SW model", 4, 12, "SW(...)"),
    ("unsupported-model", "t\n" + OK + ".model J2N NJF(BETA=1m)\nD1 a 0 J2N\n",
     "model type 'NJF' (JFET) is not supported", 4, 12, "S element"),
    ("duplicate-model", "t\n" + OK + ".model DM D\n.model dm D(IS=1n)\n",
     "model 'dm' is defined twice (first at line 4)", 5, 1, "rename"),
    ("negative-l", "t\nV1 a 0 1\nL1 a 0 -1u\n", "L1: inductance must be positive", 3, 8, ""),
    ("zero-c", "t\nV1 a 0 1\nR1 a b 1\nC1 b 0 0\n", "C1: capacitance must be positive", 4, 8,
     ""),
    ("zero-r", "t\nV1 a 0 1\nR1 a 0 0\n", "R1: resistance is zero", 3, 8, "0 V source"),
    ("k-too-big", "t\n" + OK + "L1 a 0 1u\nL2 a 0 1u\nK1 L1 L2 1.5\n", "|k| <= 1", 6, 10, ""),
    ("k-unknown", "t\n" + OK + "L1 a 0 1u\nK1 L1 L9 0.5\n", "unknown inductor 'L9'", 5, 7,
     "two inductors"),
    ("k-not-l", "t\n" + OK + "L1 a 0 1u\nK1 L1 R1 0.5\n", "'R1', which is not an inductor",
     5, 7, ""),
    ("f-unknown-source", "t\n" + OK + "F1 b 0 Vx 2\nR2 b 0 1\n",
     "unknown controlling source 'Vx' for F1", 4, 8, "V source"),
    ("h-not-v", "t\n" + OK + "H1 b 0 R1 2\nR2 b 0 1\n",
     "controlling element 'R1' of H1 is not a voltage source", 4, 8, "0 V source"),
    ("switch-no-control", "t\n" + OK + "S1 a 0 SWM\n.model SWM SW\n",
     "incomplete switch 'S1'", 4, 11, "nc+ nc-"),
    ("switch-control-typo", "t\n" + OK + "S1 a 0 gat 0 SWM\n.model SWM SW\n",
     "control node 'gat' of S1 is not connected", 4, 1, "spelling"),
    ("unknown-subckt", "t\n" + OK + "X1 a 0 nope\n", "unknown subcircuit 'nope'", 4, 8,
     ".subckt nope"),
    ("port-count", "t\n" + OK + ".subckt s p q\nR1 p q 1\n.ends\nX1 a s\n",
     "instance X1 connects 1 node but subcircuit 's' has 2 ports (p q)", 7, 1, ""),
    ("unknown-instance-param", "t\n" + OK + ".subckt s p params: r=1\nR1 p 0 {r}\n.ends\n"
     "X1 a s params: zz=2\n", "subcircuit 's' has no parameter 'zz'", 7, 16, "r"),
    ("missing-ends", "t\n" + OK + ".subckt s p\nR1 p 0 1\n", "subcircuit 's' has no .ends", 4, 1,
     ".ends"),
    ("stray-ends", "t\n" + OK + ".ends\n", ".ends without .subckt", 4, 1, ""),
    ("nested-unclosed", "t\n" + OK + ".subckt a p\n.subckt b q\n.ends\n", "subcircuit 'a' has "
     "no .ends", 4, 1, ".ends"),
    ("recursive-subckt", "t\n" + OK + ".subckt s p\nX1 p s\n.ends\nX1 a s\n",
     "subcircuit 's' instantiates itself (s -> s)", 5, 6, ""),
    ("duplicate-subckt", "t\n" + OK + ".subckt s p\n.ends\n.subckt S q\n.ends\n",
     "subcircuit 'S' is defined twice (first at line 4)", 6, 9, ""),
    ("duplicate-element", "t\nV1 a 0 1\nR1 a 0 1\nr1 a 0 2\n",
     "duplicate element name 'r1' (first at line 3)", 4, 1, "unique"),
    ("duplicate-param", "t\n" + OK + ".param a=1\n.param A=2\n",
     "parameter 'a' is defined twice (first at line 4)", 5, 8, ""),
    ("stray-continuation", "t\n+ 1k\n" + OK, "continuation line '+' with no statement", 2, 1,
     "previous statement"),
    ("pulse-args", "t\nV1 a 0 PULSE(0)\nR1 a 0 1\n",
     "PULSE takes 2 to 8 values, got 1", 2, 8, "PULSE(V1 V2"),
    ("pwl-odd", "t\nV1 a 0 PWL(0 0 1u)\nR1 a 0 1\n", "PWL needs time-value pairs, got 3", 2, 8,
     ""),
    ("pwl-order", "t\nV1 a 0 PWL(0 0 2u 1 1u 2)\nR1 a 0 1\n",
     "PWL time 1e-06 s comes before the previous time 2e-06 s", 2, 21, "increasing"),
    ("pulse-negative", "t\nV1 a 0 PULSE(0 1 0 -1n)\nR1 a 0 1\n",
     "PULSE TR must not be negative", 2, 20, ""),
    ("sin-no-args", "t\nV1 a 0 SIN()\nR1 a 0 1\n", "SIN takes 2 to 6 values, got 0", 2, 8, ""),
    ("tran-negative-step", "t\n" + OK + ".tran -1u 1m\n", ".tran TSTEP must be positive", 4,
     7, ""),
    ("tran-start", "t\n" + OK + ".tran 1u 1m 2m\n", ".tran TSTART (0.002) must be before",
     4, 13, ""),
    ("second-tran", "t\n" + OK + ".tran 1u 1m\n.tran 1u 2m\n", "second .tran (first at line 4)",
     5, 1, "keep one"),
    ("tran-incomplete", "t\n" + OK + ".tran\n", "incomplete .tran", 4, 6, "TSTOP"),
    ("ic-unknown-node", "t\n" + OK + ".ic v(zz)=1\n", ".ic names node 'zz'", 4, 7, ""),
    ("ic-current", "t\n" + OK + ".ic i(a)=1\n", ".ic sets node voltages", 4, 5, "IC="),
    ("ic-twice", "t\n" + OK + ".ic v(a)=1\n.ic v(a)=2\n", ".ic sets node 'a' twice", 5, 7, ""),
    ("r-scale", "t\nV1 a 0 1\nR1 a 0 1k scale=2\n", "unsupported parameter 'scale'", 3, 11,
     "scale factor"),
    ("r-multiplier", "t\nV1 a 0 1\nR1 a 0 1k m=-2\n", "R1: m must be positive, got -2", 3,
     11, "positive"),
    ("bad-start", "t\n" + OK + "(R5 a 0 1)\n", "unexpected '(' at the start", 4, 1, ""),
    ("control-open", "t\n" + OK + ".control\nrun\n", ".control block without .endc", 4, 1,
     ".endc"),
    ("lib-one-file-missing", "t\n" + OK + ".lib nowhere/models.lib\n",
     "file not found: 'nowhere/models.lib'", 4, 6, "relative"),
    ("include-missing", "t\n" + OK + ".include nowhere/missing.inc\n",
     "file not found: 'nowhere/missing.inc'", 4, 10, "relative"),
    ("instance-no-subckt", "t\n" + OK + "X1\n", "incomplete subcircuit instance 'X1'", 4, 3, ""),
    ("model-bad-value", "t\n" + OK + ".model DM D(IS=abc)\n", "unknown parameter 'abc'", 4, 16,
     ""),
    # LTspice's clamp, no function of ngspice's B sources: the clamp pelcs reads instead
    ("b-limit", "t\n" + OK + "B2 b 0 V = limit(v(a)*0.5, -1, 3)\n",
     "LTspice's limit(x, lo, hi) is not a function of ngspice's B sources", 4, 12,
     "max(lo, min(hi, x))"),
    # a capacitor stepped in time is a capacitor's problem, not a B source's
    ("capacitor-time", "t\n" + OK + "C1 a 0 C='time > 1m ? 1u : 2u'\n",
     "capacitor 'C1' has a value that depends on time: a time-varying capacitor", 4, 11,
     "read for a resistor only"),
]


@pytest.mark.parametrize("text, message, line, col, hint", [c[1:] for c in CATALOGUE],
                         ids=[c[0] for c in CATALOGUE])
def test_error_catalogue(text, message, line, col, hint):
    with pytest.raises(NetlistError) as info:
        parse_string(text, file="bad.cir")
    diags = info.value.diagnostics
    found = [d for d in diags if message in d.message]
    assert found, f"no diagnostic with {message!r} in:\n{info.value.format()}"
    d = found[0]
    assert d.location is not None
    assert (d.location.file, d.location.line, d.location.column) == ("bad.cir", line, col)
    assert d.location.text == text.split("\n")[line - 1]
    assert hint in d.hint
    # the gcc-style text names the place and shows the caret under the column
    text_out = d.format()
    assert text_out.startswith(f"bad.cir:{line}:{col}: error: ")
    caret_line = text_out.split("\n")[2]
    assert caret_line == "    " + " " * (col - 1) + "^"


# (id, netlist, message substring, elements that must be named)
TOPOLOGY = [
    ("no-ground", "t\nV1 a b 1\nR1 a b 1\n", "no ground node", ()),
    ("voltage-loop", "t\nV1 a 0 1\nV2 a b 2\nE1 b 0 a 0 1\nR1 a 0 1\n",
     "loop of voltage sources: V2, V1, E1", ("V2", "V1", "E1")),
    ("voltage-loop-h", "t\nV1 a 0 1\nR1 a 0 1\nH1 a 0 V1 2\n",
     "loop of voltage sources: V1, H1", ("V1", "H1")),
    ("shorted-source", "t\nV1 a a 1\nR1 a 0 1\n", "voltage source V1 is short-circuited",
     ("V1",)),
    ("floating", "t\nV1 a 0 1\nR1 a 0 1\nR2 x y 1\nC1 y x 1u\n",
     "nodes x, y have no connection to ground", ("R2", "C1")),
    ("floating-through-control-only", "t\nV1 a 0 1\nR1 a 0 1\nE1 x y a 0 2\nR2 x y 1\n",
     "nodes x, y have no connection to ground", ("E1", "R2")),
    ("no-elements", "just a title\n* and a comment\n", "the netlist has no elements", ()),
]


@pytest.mark.parametrize("text, message, elements", [c[1:] for c in TOPOLOGY],
                         ids=[c[0] for c in TOPOLOGY])
def test_topology_errors_name_the_elements(text, message, elements):
    with pytest.raises(NetlistError) as info:
        parse_string(text)
    found = [d for d in info.value.diagnostics if message in d.message]
    assert found, info.value.format()
    assert found[0].location is None
    assert found[0].elements == elements
    assert found[0].hint


def test_all_independent_problems_are_reported_in_file_order():
    text = (
        "t\n"
        "V1 a 0 1\n"
        "R1 a 0 {nope}\n"  # 3: unknown parameter
        "J1 a b 0 NJF\n"  # 4: unsupported element
        "L1 a 0 -1u\n"  # 5: negative inductance
        "D1 a 0 NOMODEL\n"  # 6: unknown model
        "R1 a 0 5\n"  # 7: duplicate
        "R3 q 0 1k3\n"  # 8: bad number
    )
    with pytest.raises(NetlistError) as info:
        parse_string(text)
    # with syntax errors (lines 4, 8), the problems that the unreadable lines cannot cause
    # are reported too (5: value, 7: duplicate); unknown names wait (a missing line could
    # define them)
    assert [d.location.line for d in info.value.diagnostics] == [4, 5, 7, 8]
    fixed = text.replace("J1 a b 0 NJF", "* no J").replace("1k3", "1k")
    with pytest.raises(NetlistError) as info:
        parse_string(fixed)
    lines = [d.location.line for d in info.value.diagnostics]
    assert lines == [3, 5, 6, 7]


def test_one_definition_used_twice_is_reported_once():
    text = "t\nV1 a 0 1\n.subckt s p\nR1 p 0 {nope}\n.ends\nX1 a s\nX2 a s\n"
    with pytest.raises(NetlistError) as info:
        parse_string(text)
    assert len(info.value.diagnostics) == 1
    assert info.value.diagnostics[0].location.line == 4


def test_failed_parameter_does_not_cascade():
    text = "t\n.param a={1/0} b={2*a}\nV1 x 0 {b}\nR1 x 0 {a}\n"
    with pytest.raises(NetlistError) as info:
        parse_string(text)
    assert [d.message for d in info.value.diagnostics] == ["division by zero"]


# -------------------------------------------------------------------------- file problems


def _only(info):
    assert len(info.value.diagnostics) == 1
    return info.value.diagnostics[0]


def test_missing_file(tmp_path):
    with pytest.raises(NetlistError) as info:
        parse_file(tmp_path / "nope.cir")
    assert "file not found" in _only(info).message


def test_directory(tmp_path):
    with pytest.raises(NetlistError) as info:
        parse_file(tmp_path)
    assert "is a directory" in _only(info).message


def test_empty_file(tmp_path):
    p = tmp_path / "empty.cir"
    p.write_text("")
    with pytest.raises(NetlistError) as info:
        parse_file(p)
    assert _only(info).message == "empty netlist"
    assert _only(info).location.line == 1


def test_binary_file(tmp_path):
    p = tmp_path / "bin.cir"
    p.write_bytes(b"title\nR1 a 0 1\n\x00\x01\x02\xff")
    with pytest.raises(NetlistError) as info:
        parse_file(p)
    d = _only(info)
    assert "NUL bytes" in d.message and (d.location.line, d.location.column) == (3, 1)


def test_a_latin1_or_utf16_file_is_read_as_ngspice_reads_its_bytes(tmp_path):
    # an LTspice export's µ (byte 0xB5 in Latin-1): ngspice 39 reads C1 1µ as 1 uF
    p = tmp_path / "latin1.cir"
    p.write_bytes("title \u00e4\nV1 a 0 1\nR1 a b 1k ; 1 k\u00b5\nC1 b 0 1\u00b5\n"
                  .encode("latin-1"))
    assert parse_file(p).element("C1").value == pytest.approx(1e-6)
    p.write_bytes("title\nV1 a 0 1\nR1 a b 1k\nC1 b 0 2\u00b5\n".encode("utf-16"))
    assert parse_file(p).element("C1").value == pytest.approx(2e-6)


def test_a_file_of_two_encodings_is_refused(tmp_path):
    # UTF-8's µ (bytes C2 B5) beside Latin-1's (B5): read as Latin-1, '1Âµ' would not be
    # 1e-6
    p = tmp_path / "mixed.cir"
    p.write_bytes(b"title\nV1 a 0 1\nR1 a b 1k\nC1 b 0 1\xc2\xb5\nC2 b 0 1\xb5\n")
    with pytest.raises(NetlistError, match="not UTF-8"):
        parse_file(p)


def test_non_utf8_binary_file(tmp_path):
    p = tmp_path / "binary.cir"
    p.write_bytes(b"title\nV1 a 0 1\n" + bytes(range(0x80, 0xC0)))
    with pytest.raises(NetlistError) as info:
        parse_file(p)
    d = _only(info)
    assert "not UTF-8" in d.message and "0x80" in d.message
    assert (d.location.line, d.location.column) == (3, 1)


def test_nul_in_string():
    with pytest.raises(NetlistError, match="NUL bytes"):
        parse_string("t\nR1 a 0 1\x00\n")


def test_include_cycle(tmp_path):
    (tmp_path / "a.cir").write_text("top\nV1 x 0 1\nR1 x 0 1\n.include b.inc\n")
    (tmp_path / "b.inc").write_text("* b\n.include c.inc\n")
    (tmp_path / "c.inc").write_text(".include b.inc\n")
    with pytest.raises(NetlistError) as info:
        parse_file(tmp_path / "a.cir")
    d = _only(info)
    assert d.message == "include cycle: a.cir -> b.inc -> c.inc -> b.inc"
    assert d.location.file == os.path.join(str(tmp_path), "c.inc")
    assert (d.location.line, d.location.column) == (1, 10)


def test_error_inside_include_points_into_it(tmp_path):
    (tmp_path / "m.inc").write_text("* models\n.model DM D(IS=1n)\nR2 a 0 xyz\n")
    (tmp_path / "top.cir").write_text("top\nV1 a 0 1\n.include m.inc\n")
    with pytest.raises(NetlistError) as info:
        parse_file(tmp_path / "top.cir")
    d = _only(info)
    assert d.location.file.endswith("m.inc") and d.location.line == 3
    assert d.location.column == 8


def test_missing_library_section(tmp_path):
    (tmp_path / "x.lib").write_text(".lib fast\nR9 a 0 1\n.endl\n")
    (tmp_path / "top.cir").write_text("top\nV1 a 0 1\nR1 a 0 1\n.lib x.lib slow\n")
    with pytest.raises(NetlistError) as info:
        parse_file(tmp_path / "top.cir")
    assert "library section 'slow' not found" in _only(info).message


# -------------------------------------------------------------------------- limits


def test_deeply_nested_expression_is_an_input_error():
    with pytest.raises(NetlistError, match="expression is nested too deeply"):
        parse_string("t\nV1 a 0 1\nR1 a 0 {" + "-" * 3000 + "1}\n")


def test_deeply_nested_subcircuits_are_an_input_error():
    n = 150
    subs = "".join(f".subckt s{i} a\nX1 a s{i + 1}\n.ends\n" for i in range(n))
    text = f"t\n{subs}.subckt s{n} a\nR1 a 0 1\n.ends\nV1 x 0 1\nX1 x s0\n"
    with pytest.raises(NetlistError, match="subcircuits nested more than 100 levels deep"):
        parse_string(text)


@pytest.mark.parametrize("driver", [
    "Bg g 0 V = ddt(1k*time)",
    "asq g sq\n.model sq square(freq_array=[1k 1k] cntl_array=[0 1])",
])
def test_refused_driver_leaves_no_follow_on_connectivity_error(driver):
    # the refused B source or A element is the problem; its output node, left without an
    # element, is not a second one ('control node g of S1 is not connected')
    with pytest.raises(NetlistError) as info:
        parse_string(f"t\nV1 a 0 1\nR1 a b 1\n{driver}\nS1 b 0 g 0 SW1\n.model SW1 SW(VT=0.5)\n"
                     ".tran 1u 1m\n")
    assert len(info.value.diagnostics) == 1
    assert info.value.diagnostics[0].location.line == 4


def test_control_node_of_no_element_is_still_reported():
    with pytest.raises(NetlistError) as info:
        parse_string("t\nV1 a 0 1\nR1 a b 1\nS1 b 0 g 0 SW1\n.model SW1 SW(VT=0.5)\n"
                     ".tran 1u 1m\n")
    assert "control node 'g' of S1 is not connected" in info.value.message


FLOATING_BASE = ("npn, base joined to nothing else\nV1 vcc 0 5\nR1 vcc c 1k\nQ1 c nb 0 qn\n"
                 ".model qn npn(bf=100)\n.tran 1u 10u\n.end\n")


def test_a_transistor_base_joined_to_nothing_else_says_it_only_senses():
    # (a 555's RESET pin left open in a transistor-level model: the idealised transistor's
    # base is a switch's control, so the hint says what to connect, not "check its spelling")
    with pytest.raises(NetlistError) as info:
        parse_string(FLOATING_BASE)
    text = str(info.value)
    assert "<string>:4:1: error: control node 'nb' of Q1 is not connected" in text, text
    assert "Q1 is an NPN transistor pelcs idealised into a switch, whose base only senses " \
           "the voltage at 'nb'" in text, text
    assert "spelling" not in text, text


def test_ngspice_runs_the_floating_base_pelcs_refuses(tmp_path, ngspice):
    # the other side of the hint's claim: ngspice settles the open base and runs the deck
    data = ngspice_wrdata(FLOATING_BASE, ["v(c)"], tmp_path)
    assert len(data) > 2


def test_a_network_reached_only_through_transistor_bases_says_so():
    # a timing capacitor between two bases (eSim's transistor-level UC1525 oscillator): the
    # idealised transistors read their bases and load neither, so only pelcs sees it floating
    with pytest.raises(NetlistError) as info:
        parse_string("t\nV1 vcc 0 5\nQ1 vcc b1 e1 QN\nQ2 vcc b2 e2 QN\nR1 e1 0 1k\n"
                     "R2 e2 0 1k\nR9 b1 m 1k\nC2 m b2 1n\n.model QN NPN\n.tran 1u 1m\n")
    text = str(info.value)
    assert "reach the rest of the circuit only through the base or gate of Q1, Q2" in text
    assert "write the controller behaviourally" in text


def test_a_mode_with_no_explicit_lcs_is_refused_at_an_element_line():
    # E1 copies its own output (gain 1 from b to b): v(b), so the capacitor's current, is
    # left free; the refusal points at C1's line (it named the file alone)
    c = parse_string("t\nV1 a 0 1\nR1 a b 1\nE1 b 0 b 0 1\nC1 b c 1n\nR2 c 0 1\n.tran 1u 10u\n")
    with pytest.raises(NetlistError) as info:
        simulate_circuit(c, probes=["v(c)"])
    text = str(info.value)
    assert "<string>:5:1: error: no explicit LCS: i(C1) is not determined" in text, text
