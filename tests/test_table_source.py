"""E and G sources with a TABLE (netlist.table_source): a steep two-point table read as the
comparator it approximates (the astable multivibrator of PySpice's examples, against its
analytic period and ngspice up to where ngspice stops), a gentle one as a clamp, others
refused where they are written."""

from __future__ import annotations

import math

import numpy as np
import pytest
from ngspice_helpers import ngspice_run

from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from netlist.table_source import read_table

# PySpice's astable: a comparator (the TABLE) with positive feedback through R2 (thresholds
# 10 V and 5 V) and the timing RC R1 C1 (100 µs). From v(comparator) = 0 the output is 15 V
# until v(comparator) reaches 10 V, at τ ln 3; then it swings between 5 V and 10 V, τ ln 2
# each way.
ASTABLE = """astable
Vcc vcc 0 15
R1 output comparator 1k
C1 comparator 0 100n
.IC V(comparator)=0
R2 output reference 100k
R3 Vcc reference 100k
R4 reference 0 100k
E1 output 0 TABLE {V(reference, comparator)} = (-1uV, 0V) (1uV, 15V)
.tran 1u 500u
.end
"""
TAU = 1e3 * 100e-9


def test_a_steep_table_is_the_comparator_it_approximates():
    table = read_table("E1 output 0 TABLE {V(reference, comparator)} = (-1uV, 0V) (1uV, 15V)",
                       "E")
    assert table.name == "E1" and table.nodes == ("output", "0")
    assert table.text == "((V(reference, comparator)) > 0.0) ? 15.0 : 0.0"
    assert "a gain of 7.5e+06" in table.note and "1 µV or more from 0 V" in table.note


def test_a_gentle_table_is_a_clamped_line():
    table = read_table("G1 a 0 TABLE {v(x)} = (0, 0) (2, 1m)", "G")
    assert table.text == "max(0.0, min(0.001, 0.0 + 0.0005 * ((v(x)) - 0.0)))"


def test_astable_period_and_thresholds_are_the_analytic_ones():
    c = parse_string(ASTABLE)
    assert any(n.startswith("E1: TABLE {V(reference, comparator)} from 0 V to 15 V") and
               "read as the comparator" in n for n in c.notes)
    res = simulate_circuit(c, probes=["v(output)", "v(comparator)"], step=1e-7)
    out, vc = res["v(output)"], res["v(comparator)"]
    edges = res.t[1:][np.diff(out > 7.5) != 0]
    want = TAU * math.log(3) + TAU * math.log(2) * np.arange(len(edges))
    assert len(edges) == 6
    assert np.max(np.abs(edges - want)) < 2e-7
    after = res.t > TAU * math.log(3) + 1e-6
    assert 5 - 1e-3 < vc[after].min() and vc[after].max() < 10 + 1e-3


def test_astable_side_by_side_with_ngspice_until_it_stops(tmp_path, ngspice):
    # ngspice steps into the table's 2 µV band at the first threshold and stops there
    # (timestep too small, at 112 µs): compared before it
    ng, log = ngspice_run(ASTABLE, ["v(comparator)"], tmp_path)
    assert ng is not None, log
    assert ng[-1, 0] < 200e-6 and "aborted" in log
    res = simulate_circuit(parse_string(ASTABLE), probes=["v(comparator)"], step=1e-7)
    keep = ng[:, 0] < 105e-6
    got = np.interp(ng[keep, 0], res.t, res["v(comparator)"])
    assert np.max(np.abs(got - ng[keep, 1])) < 5e-3


def test_a_gentle_table_driving_a_load_is_a_limiter_with_positive_feedback():
    """Gain 7.5 between 0 and 15 V with the divider's positive feedback: a Schmitt trigger.
    The output leaves 15 V when v(comparator) reaches 9 V (R1C1 ln(15/6) = 91.6 µs) and
    snaps to 0 V; it comes back at 6 V, so each half period is R1C1 ln(3/2) = 40.5 µs.
    ngspice stops at that first fold (89.7 µs, "timestep too small"). pelcs warns that the
    circuit is not passive: the clamp's output is not unique there, and the run keeps the
    saturated branch while it exists."""
    text = ASTABLE.replace("(-1uV, 0V) (1uV, 15V)", "(-1V, 0V) (1V, 15V)")
    with pytest.warns(UserWarning, match="not passive"):
        res = simulate_circuit(parse_string(text), probes=["v(output)"])
    res.raise_if_error()
    assert any("E1: clamp" in n and "built as an ideal limiter" in n for n in res.notes)
    high = res["v(output)"] > 7.5
    edges = res.t[1:][np.diff(high.astype(int)) != 0]
    rc = 1e3 * 100e-9
    assert len(edges) >= 8
    # the limiter's diodes turn on the step grid (1 µs): each instant within a step or so
    assert edges[0] == pytest.approx(rc * np.log(15 / 6), abs=2.5e-6)
    assert np.abs(np.diff(edges) - rc * np.log(1.5)).max() <= 1e-6


def test_a_table_of_three_points_is_refused_where_it_is():
    text = ASTABLE.replace("(1uV, 15V)", "(1uV, 15V) (2, 16)")
    with pytest.raises(NetlistError) as exc:
        parse_string(text)
    d = exc.value.diagnostics[0]
    assert d.location.line == 9 and "TABLE with 3 points" in d.message
    assert "two points" in d.hint


def test_a_control_block_after_end_is_read_as_ngspice_reads_it():
    # (PySpice's astable.cir: '.end', then the .control block with its tran)
    text = ASTABLE.replace(".tran 1u 500u\n.end\n", ".end\n.control\ntran 1u 500u\n.endc\n"
                           "R9 never 0 1\n")
    c = parse_string(text)
    assert c.tran is not None and c.tran.tstop == pytest.approx(500e-6)
    assert "never" in c.nodes  # (read too: tests/test_netlist_spellings.py, AFTER_END)


# ngspice's table interpolation takes its points in the order written, x increasing: points
# written x decreasing are not the line through them there. Measured (ngspice 39, V(in) a
# ramp from -1 V to 1 V): TABLE {V(in)} = (1u, 0) (-1u, 15) gives 0 V at V(in) = -0.81 V and
# 15 V at V(in) = +2.9 µV, where pelcs, reading the points sorted, gave 15 V and 0 V; equal x,
# (0, 0) (0, 15), ngspice cannot run (its operating point fails).
DESCENDING = """table written x decreasing
V1 in 0 PWL(0 -1 1m 1)
E1 o1 0 TABLE {V(in)} = (1u, 0) (-1u, 15)
R1 o1 0 1k
.tran 1u 1m
.end
"""


@pytest.mark.parametrize("points", ["(1u, 0) (-1u, 15)", "(0, 0) (0, 15)"])
def test_a_table_whose_x_does_not_increase_is_refused_where_it_is(points):
    with pytest.raises(NetlistError) as exc:
        parse_string(DESCENDING.replace("(1u, 0) (-1u, 15)", points))
    d = exc.value.diagnostics[0]
    assert d.location.line == 3 and "increasing" in d.message


def test_a_descending_table_is_not_what_ngspice_runs(tmp_path, ngspice):
    # the reference for the refusal: ngspice's output is not the table read sorted
    ng, log = ngspice_run(DESCENDING, ["v(o1)", "v(in)"], tmp_path)
    assert ng is not None, log
    early = np.argmin(np.abs(ng[:, 3] + 0.8))
    assert ng[early, 1] == pytest.approx(0.0, abs=1e-6)  # the sorted table: 15 V
