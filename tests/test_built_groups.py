"""Netlist lines pelcs simulates as groups of elements it builds (netlist.circuit.BuiltGroup):
a clamping B source's limiter and a resistor stepped in time in one deck. Each element names
its group, the circuit records each group once, and the deck written for ngspice holds the
original lines, which ngspice runs as it runs the netlist itself (side by side)."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.circuit import LIMITER, TIME_STEPPED_RESISTOR
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit

# a clamped amplifier (a limiter: it feeds a resistor) into an RC whose resistor doubles at
# 1 ms (a resistor stepped in time)
BOTH = """a limiter and a resistor stepped in time
V1 in 0 SIN(0 1 1k)
B1 out 0 V = max(-1, min(2, 3*v(in) + 0.5))
R1 out cap R = 'time < 1ms ? 1k : 2k'
C1 cap 0 100n
.tran 1u 3m uic
.end
"""
B1_LINE = "B1 out 0 V = max(-1.0, min(2.0, 3.0*v(in) + 0.5))"
R1_LINE = "R1 out cap R = 'time < 1m ? 1k : 2k'"


def test_each_group_is_recorded_once_and_named_by_its_elements():
    c = parse_string(BOTH)
    assert {k: (g.name, g.construct, g.line) for k, g in c.built_groups.items()} == {
        "b1": ("B1", LIMITER, B1_LINE), "r1": ("R1", TIME_STEPPED_RESISTOR, R1_LINE)}
    by_group: dict[str, list[str]] = {}
    for el in c.elements:
        group = c.built_group(el)
        if group is not None:
            by_group.setdefault(group.name, []).append(el.name)
    # each group keeps its line's name for one element (i(B1), i(R1) are the line's current)
    assert "B1" in by_group["B1"] and {"B1#r", "B1#dlo", "B1#dhi"} <= set(by_group["B1"])
    assert by_group["R1"] == ["R1", "R1#r2", "R1#s2", "R1#v2"]
    assert [el.name for el in c.elements if c.built_group(el) is None] == ["V1", "C1"]


def test_the_deck_holds_both_lines_and_reads_back_to_the_same_circuit():
    c = parse_string(BOTH)
    deck = write_circuit(c)
    body = deck.splitlines()[2:]
    # (the limiter's elements follow the netlist's, and its line with them)
    assert body[:4] == ["V1 in 0 DC 0 SIN(0 1 1k)", R1_LINE, "C1 cap 0 100n", B1_LINE]
    assert "#" not in deck.replace("* written by pelcs", "")  # (nor the bypasses' model)
    again = parse_string(deck)
    assert again.elements == c.elements
    assert again.built_groups == c.built_groups


def test_ngspice_runs_the_written_deck_as_the_netlist(tmp_path, ngspice):
    probes = ["v(out)", "v(cap)"]
    ng = ngspice_wrdata(BOTH, probes, tmp_path)
    written = ngspice_wrdata(write_circuit(parse_string(BOTH)), probes, tmp_path)
    # (the same time points and values, bit for bit: measured 0.0)
    assert written.shape == ng.shape
    assert np.abs(written - ng).max() <= 1e-9
    # and pelcs agrees with both, up to where ngspice lands the resistor's change: inside
    # its step past 1 ms, not at the instant (measured: v(out) 4.4e-4 V, v(cap) 4.0e-3 V at
    # 1.001 ms, 1.2e-3 V at the end)
    res = simulate_circuit(parse_string(BOTH), probes=probes)
    res.raise_if_error()
    t = ng[:, 0]
    for col, probe, tol in ((1, "v(out)", 1e-3), (3, "v(cap)", 5e-3)):
        assert np.interp(t, res.t, res[probe]) == pytest.approx(ng[:, col], abs=tol)


def test_a_changed_circuit_keeps_its_groups_true():
    from netlist.studies.param_sweep import _perturbed
    from netlist.time_value import frozen_at

    c = parse_string(BOTH)
    # a Monte Carlo draw of R1 at +50 %: its every value, and its line for ngspice
    drawn, _ = _perturbed(c, (("R1", True),), [0.5])
    line = "R1 out cap R = 'time < 1m ? 1.5k : 3k'"
    assert drawn.built_groups["r1"].line == line and c.built_groups["r1"].line == R1_LINE
    deck = write_circuit(drawn)
    assert line in deck.splitlines()
    assert parse_string(deck).elements == drawn.elements
    # R1 frozen at its value at 2 ms (a periodic steady state): a resistor of the netlist's
    # own, written as such; the limiter is still a group
    frozen, _ = frozen_at(c, 2e-3)
    assert list(frozen.built_groups) == ["b1"]
    lines = write_circuit(frozen).splitlines()
    assert "R1 out cap 2k" in lines and B1_LINE in lines
