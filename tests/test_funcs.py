""".func user-defined functions, expanded in place as ngspice's numparam does, in parameter
expressions and B-source expressions alike (netlist.funcs); a buck whose period, on-time and
PWM comparator are written with functions runs side by side with ngspice."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.errors import NetlistError
from netlist.expressions import parse_expression
from netlist.funcs import Func, expand, read_func
from netlist.parser import parse_string
from pelcs.api import simulate

# the functions are used before they are defined, one calls another, and the comparator is
# a function of two node voltages
BUCK = """buck written with .func
.param fs=100k d=0.4
Vin in 0 DC 12
Vramp ramp 0 PULSE(0 1 0 {ton(1, fs) - 10n} 10n 0 {per(fs)})
Vref ref 0 DC {d}
B1 g 0 V={above(V(ref), V(ramp))}
S1 in sw g 0 sm
.model sm SW(VT=2.5 VH=0 RON=10m ROFF=1meg)
D1 0 sw dm
.model dm D(IS=1e-14 RS=10m)
L1 sw out 100u
C1 out 0 100u
R1 out 0 5
.func per(f) {1/f}
.func ton(duty, f) = {duty*per(f)}
.func above(a, b) {a > b ? 5 : 0}
.tran 0.1u 2m
.end
"""


def test_expand():
    funcs = {f.name: f for f in (read_func(".func per(f) {1/f}"),
                                 read_func(".func sq(x) 'x*x'"))}
    assert funcs["per"] == Func("per", ("f",), "1/f")
    text = expand("2*PER(fs) + sq(per(2))", funcs)
    assert "per" not in text.lower() and "sq" not in text
    assert parse_expression(text).evaluate({"fs": 4.0}) == 2 / 4 + 0.25
    # a function named like the suffix of a number leaves the number alone
    text = expand("sq(1e3)", {"e3": Func("e3", (), "7"), **funcs})
    assert parse_expression(text).evaluate({}) == 1e6


def test_values():
    c = parse_string(BUCK)
    assert c.element("Vramp").waveform.per == pytest.approx(1e-5)
    assert c.element("Vramp").waveform.tr == pytest.approx(1e-5 - 1e-8)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_buck_agrees_with_ngspice(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    ng = ngspice_wrdata(BUCK, ["v(out)"], tmp_path)
    t0 = ng[-1, 0] / 2
    keep = ng[:, 0] >= t0
    want = np.trapezoid(ng[keep, 1], ng[keep, 0]) / (ng[-1, 0] - t0)
    res = simulate(BUCK, probes=["v(out)"], devices="pwl")
    keep = res.t >= t0
    got = np.trapezoid(res.y[keep, 0], res.t[keep]) / (res.t[-1] - t0)
    assert abs(got - want) <= 0.02 * want, (got, want)


@pytest.mark.parametrize("old, new, message", [
    ("{ton(1, fs) - 10n}", "{ton(1) - 10n}", ".func 'ton' takes 2 arguments, got 1"),
    ("{per(fs)})", "{per(fs})", "call of .func 'per' is not closed"),
])
def test_bad_calls_are_refused_at_the_call(old, new, message):
    deck = BUCK.replace(old, new)
    with pytest.raises(NetlistError) as info:
        parse_string(deck)
    (d,) = info.value.diagnostics
    assert d.message == message
    line = deck.splitlines()[3]
    assert (d.location.line, d.location.column) == (4, line.index(new[1:]) + 1)


def test_a_function_calling_itself_is_refused():
    with pytest.raises(NetlistError, match="functions nested more than 32 deep"):
        parse_string(BUCK.replace(".func per(f) {1/f}", ".func per(f) {per(f)}"))
