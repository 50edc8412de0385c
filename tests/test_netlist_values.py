"""SPICE numbers and parameter expressions against hand-computed values."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from netlist.expressions import ExpressionError, parse_expression
from netlist.units import format_eng, format_number, parse_number


@pytest.mark.parametrize(
    "text, value",
    [
        ("1e-3", 1e-3),
        ("1E3", 1e3),
        ("10uF", 10e-6),
        ("1kOhm", 1e3),
        ("5V", 5.0),
        ("1Meg", 1e6),
        ("1MEG", 1e6),
        ("2.2megohm", 2.2e6),
        ("1M", 1e-3),  # SPICE: M is milli
        ("3m", 3e-3),
        ("1mil", 25.4e-6),
        ("10F", 10e-15),  # SPICE: F is femto, not farad
        ("4p", 4e-12),
        ("7n", 7e-9),
        ("2g", 2e9),
        ("1t", 1e12),
        ("3a", 3e-18),
        ("-2.5k", -2500.0),
        ("+.5", 0.5),
        ("1.", 1.0),
        ("1e-3k", 1.0),
        ("100u", 1e-4),  # exactly float("1e-4"), not 100 * 1e-6
        ("1Hz", 1.0),
        ("47uH", 47e-6),
    ],
)
def test_parse_number(text, value):
    assert parse_number(text) == value


@pytest.mark.parametrize("text", ["abc", "1k2", "", "-", "e5", "nan", "inf", "1..2"])
def test_parse_number_rejects(text):
    assert parse_number(text) is None


@pytest.mark.parametrize(
    "value, text",
    [(1e-4, "100u"), (5e4, "50k"), (0.5, "0.5"), (12.0, "12"), (0.0, "0"), (1e6, "1Meg"),
     (-3.3e-9, "-3.3n"), (25.4e-6, "25.4u"), (1e-3, "1m"), (1e-20, "1e-20")],
)
def test_format_number(value, text):
    assert format_number(value) == text
    assert parse_number(text) == value


@settings(max_examples=300, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False))
def test_format_number_reads_back_exactly(value):
    assert parse_number(format_number(value)) == value


def test_format_eng_for_people():
    assert format_eng(1e-4, "F") == "100 µF"
    assert format_eng(47e3, "Ω") == "47 kΩ"
    assert format_eng(2e6, "Hz") == "2 MHz"
    assert format_eng(0.0, "V") == "0 V"
    assert format_eng(None, "s") == "default"


@pytest.mark.parametrize(
    "text, env, value",
    [
        ("1+2*3", {}, 7.0),
        ("(1+2)*3", {}, 9.0),
        ("2**3", {}, 8.0),
        ("2^3", {}, 8.0),
        ("2^3^2", {}, 64.0),  # left-associative, as numparam (ngspice 39: 64)
        ("-2**2", {}, -4.0),  # power binds tighter than unary minus
        ("--3", {}, 3.0),
        ("1/(2*pi*fs)", {"fs": 1e3, "pi": math.pi}, 1 / (2 * math.pi * 1e3)),
        ("duty*ts-10n", {"duty": 0.5, "ts": 1e-5}, 0.5e-5 - 10e-9),
        ("2*10k", {}, 2e4),
        ("sqrt(16)+exp(0)+log(1)+ln(1)", {}, 5.0),
        ("sin(0)+cos(0)+tan(0)+abs(-2)", {}, 3.0),
        # (numparam: min(3,1,2) is min(3,2), its first and last arguments, as in ngspice 39)
        ("min(3,1,2)+max(1,5)+pow(2,10)", {}, 2 + 5 + 1024.0),
        ("FS*2", {"fs": 2.0}, 4.0),  # names are case-insensitive
        ("PI", {"pi": math.pi}, math.pi),
        ("log10(1k)", {}, 3.0),
    ],
)
def test_expressions(text, env, value):
    assert parse_expression(text).evaluate(env) == pytest.approx(value, rel=1e-15)


def test_expression_names():
    # (pi too: a parameter of that name is its value, as in ngspice, and numparam has no
    # constant pi: ngspice 39 stops at "Undefined parameter [pi]")
    assert parse_expression("a*b+sqrt(c)-pi").names == frozenset({"a", "b", "c", "pi"})
    with pytest.raises(ExpressionError, match="no constant pi"):
        parse_expression("pi").evaluate({})
    assert parse_expression("pi").evaluate({"pi": 2.0}) == 2.0
    assert parse_expression("3*4").constant


@pytest.mark.parametrize(
    "text, env, message, offset",
    [
        ("(1+2", {}, "incomplete expression", 4),
        ("1+", {}, "incomplete expression", 2),
        ("2 3", {}, "unexpected '3'", 2),
        ("foo(1)", {}, "unknown function 'foo'", 0),
        ("v(out)*2", {}, "unknown function 'v'", 0),
        # (pow(2) is pow(1, 2) = 1 in numparam, as in ngspice 39; a fourth argument stops it)
        ("pow(1,2,3,4)", {}, "pow() takes 1 to 3 arguments", 0),
        ("1/x", {"x": 0.0}, "division by zero", 2),
        ("sqrt(-1)", {}, "cannot evaluate sqrt(-1)", 0),
        ("a+b", {"a": 1.0}, "unknown parameter 'b'", 2),
        ("10**400", {}, "overflow", 2),
        ("1 $ 2", {}, "unexpected '$'", 2),
        ("", {}, "empty expression", 0),
    ],
)
def test_expression_errors(text, env, message, offset):
    with pytest.raises(ExpressionError) as info:
        parse_expression(text).evaluate(env)
    assert message in info.value.message
    assert info.value.offset == offset
