"""Monte Carlo tolerances on the element groups pelcs builds for a netlist line: a clamping
B source's limiter keeps the B source's name on its output buffer, a gain of 1 that is no
value of the netlist's (drawing it scaled the clamp's rails: v(out) 1.79..2.10 V about a
nominal 1.92 V); a resistor stepped in time varies as a whole."""

from __future__ import annotations

import pytest

from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.param_sweep import match_tolerances, parse_tolerance

DECK = """a limiter and a resistor stepped in time
V1 in 0 SIN(0 1 1k)
B1 o 0 V = max(-1, min(2, 3*v(in) + 0.5))
R1 o a R = 'time < 1ms ? 10 : 20'
D1 a out DM
C1 out 0 10u
RL out 0 1k
.model DM D(IS=1e-12 RS=0.5)
.tran 1u 4m
.end
"""


def test_a_pattern_varies_the_netlists_values_not_the_limiters_buffer():
    c = parse_string(DECK)
    got = [name for name, _ in match_tolerances(c, [parse_tolerance("*=10%")])]
    assert got == ["R1", "C1", "RL"]


def test_the_b_source_named_has_no_value_to_vary():
    c = parse_string(DECK)
    with pytest.raises(NetlistError, match="B1 has no value to vary"):
        match_tolerances(c, [parse_tolerance("B1=10%")])
