"""numparam's and the B sources' operators and functions, each value compared with ngspice 39's
on the same deck (a source of the expression's value across 1 ohm, ``print v(n)`` after ``op``).

numparam (``.param`` and ``{...}``): ``%`` is ``a - b*trunc(a/b)``, ``**`` and ``^`` are
``|a|^b`` and left-associative, ``pwr(a, b)`` is ``|a|^b``, hexadecimal numbers are read. B
sources: ``pwr(a, b)`` is ``sign(a)|a|^b``, ``pow`` and ``^`` are ``|a|^b``; no ``%``, no
hexadecimal.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from netlist.behavioural_expr import BehaviouralError, linearise, parse_behavioural
from netlist.expressions import ExpressionError, parse_expression
from netlist.parser import parse_string
from tests.netlist_asserts import refused_at

# expression -> the value ngspice 39 prints for {expression} (measured)
NUMPARAM = {
    "10 % 3": 1.0, "-10 % 3": -1.0, "10 % -3": 1.0, "7.5 % 2": 1.5, "-7.5 % 2": -1.5,
    "20 % 3 * 2": 4.0, "2+10%3": 3.0, "2**3%5": 3.0, "10%3**2": 1.0, "-7%2.5": -2.0,
    "0x10": 16.0, "0x10+1": 17.0, "0x1F": 31.0, "0X1f": 31.0, "0x1.8": 1.5, "0x10k": 16e3,
    "pwr(-2,3)": 8.0, "pwr(-2,0.5)": 2**0.5, "pwr(-2,-1)": 0.5, "pwr(-8,1/3)": 2.0,
    "pow(-2,3)": -8.0, "(-2)**3": 8.0, "(-2)^3": 8.0, "(-2)**0.5": 2**0.5,
    "2^3^2": 64.0, "2**3**2": 64.0, "-2^2": -4.0, "2^-1": 0.5, "2^-2^2": 0.0625,
    "(-2^2)": -4.0, "2*(-3^2)": -18.0, "-3^2*2": -18.0, "-(2)^2": -4.0, "1-2^2": -3.0,
    "max(-3^2,-20)": -9.0, "sqr(-3)": 9.0, "int(-2.7)": -2.0, "nint(2.5)": 2.0,
    "sgn(-3)": -1.0, "arctan(1)": 0.7853981633974483, "asinh(1)": 0.881373587019543,
    "ternary_fcn(1,2,3)": 2.0,
    # numparam's min and max take their first and last argument, 1 for a missing first
    "min(3)": 1.0, "max(0.5)": 1.0, "min(4,2,3)": 3.0, "max(1,9,2)": 2.0, "min(1,5,3)": 1.0,
    "max(5,1,2)": 5.0, "min(4,2)": 2.0,
    # and every function: one argument's takes the last, two arguments' the first and last
    "pow(3)": 1.0, "pwr(2)": 1.0, "pow(2,3,4)": 16.0, "sqrt(4,9)": 3.0, "abs(-2,-3)": 3.0,
    "sin(0,1)": 0.8414709848078965,
}
# B-source expression -> ngspice 39's value (measured)
BSOURCE = {
    "pwr(-2,3)": -8.0, "pwr(-2,0.5)": -(2**0.5), "pwr(-2,-1)": -0.5, "pwr(-8,1/3)": -2.0,
    "pow(-2,3)": 8.0, "pow(-2,0.5)": 2**0.5, "(-2)^3": 8.0, "(-2)**3": 8.0,
    "(-2)^0.5": 2**0.5, "2^3^2": 64.0, "-2^2": -4.0, "2*-3^2": -18.0, "2^-2^2": 0.0625,
    "nint(2.5)": 2.0, "sgn(-3)": -1.0, "ternary_fcn(1,2,3)": 2.0,
}


def _ngspice_values(tmp_path, lines: list[str]) -> list[float | None]:
    """ngspice's v(nK) of a deck of the element lines ``lines`` (each drives node nK)."""
    deck = ["operators"]
    for k, line in enumerate(lines, 1):
        deck += [line.format(n=f"n{k}", k=k), f"R{k} n{k} 0 1"]
    deck += [".control", "set numdgt=12", "op",
             *(f"print v(n{k})" for k in range(1, len(lines) + 1)), ".endc", ".end"]
    (tmp_path / "deck.cir").write_text("\n".join(deck) + "\n")
    r = subprocess.run(["ngspice", "-b", "deck.cir"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=60, env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"})
    got = {int(m.group(1)): float(m.group(2))
           for m in re.finditer(r"v\(n(\d+)\) = (\S+)", r.stdout)}
    return [got.get(k) for k in range(1, len(lines) + 1)]


def test_numparam_values():
    for text, want in NUMPARAM.items():
        assert parse_expression(text).evaluate({}) == pytest.approx(want, rel=1e-12), text


def test_numparam_values_in_a_deck():
    deck = ("operators\n.param a=10%3 b=0x10 c=pwr(-2,3) d={(-2)**3}\nV1 n1 0 {a+b+c+d}\n"
            "R1 n1 0 1\nV2 n2 0 {2^3^2 % 10}\nR2 n2 0 1\n.tran 1u 2u\n.end\n")
    c = parse_string(deck)
    assert (c.element("V1").dc, c.element("V2").dc) == (33.0, 4.0)


def test_numparam_values_against_ngspice(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    texts = list(NUMPARAM)
    got = _ngspice_values(tmp_path, [f"V{{k}} {{n}} 0 {{{{{t}}}}}" for t in texts])
    for text, value in zip(texts, got, strict=True):
        assert value == pytest.approx(NUMPARAM[text], rel=1e-6), text


def test_bsource_values():
    for text, want in BSOURCE.items():
        assert linearise(parse_behavioural(text), text, {}).const == pytest.approx(
            want, rel=1e-12), text


def test_bsource_values_against_ngspice(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    texts = list(BSOURCE)
    got = _ngspice_values(tmp_path, [f"B{{k}} {{n}} 0 V={t}" for t in texts])
    for text, value in zip(texts, got, strict=True):
        assert value == pytest.approx(BSOURCE[text], rel=1e-6), text


@pytest.mark.parametrize("text", ["2*-3^2", "2+-3^2", "--3^2", "2*-(3)^2", "1?-3^2:0"])
def test_a_minus_after_an_operator_before_a_power_is_refused(text):
    # ngspice 39: 2*-3^2 = 18, 2+-3^2 = 11, --3^2 = -9, 2*-(3)^2 = 0.2222, 1?-3^2:0 = 9
    with pytest.raises(ExpressionError, match="after an operator"):
        parse_expression(text)


@pytest.mark.parametrize("text", ["5.5%0", "pwr(0,-1)", "pow(-2,0.5)", "0x"])
def test_numparam_errors(text):
    # ngspice 39 stops on each (nan, inf, "Number format error")
    with pytest.raises(ExpressionError):
        parse_expression(text).evaluate({})


@pytest.mark.parametrize(("text", "words"), [
    ("10%3", ["'%'", "no remainder operator"]), ("0x10", ["hexadecimal"]),
    ("sqr(3)", ["no function 'sqr'"]), ("int(2.7)", ["no function 'int'"]),
    ("arctan(1)", ["no function 'arctan'"])])
def test_bsource_refusals(text, words):
    # ngspice 39: "unknown parameter (%)", "unknown parameter", "no such function"
    with pytest.raises(BehaviouralError) as exc:
        linearise(parse_behavioural(text), text, {})
    msg = exc.value.message + " " + exc.value.hint
    for w in words:
        assert w in msg, msg


def test_bare_hexadecimal_value_is_refused():
    # ngspice 39 reads V1 n1 0 0x10 as 0 V: hexadecimal only inside braces
    refused_at("hex\nV1 n1 0 0x10\nR1 n1 0 1\n.tran 1u 2u\n.end\n", (2, 9),
               ["ngspice reads '0x10' here as 0", "{0x10}"])


def test_numparam_min_of_four_arguments_is_refused():
    # (ngspice 39 stops: "Syntax error: letter [,]")
    with pytest.raises(ExpressionError, match=r"min\(\) takes 1 to 3 arguments .*, got 4"):
        parse_expression("min(9,1,8,7)")
