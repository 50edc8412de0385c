"""Capacitors constant below a knee of their own voltage (netlist.knee), and the solve of a
network held only by a very large resistor (netlist.mna_solve)."""

from __future__ import annotations

import contextlib
import io
import math

import numpy as np
import pytest

from netlist.errors import NetlistError
from netlist.knee import KneeCapacitor
from netlist.mna_solve import Solution
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from pelcs.cli import main

RC = """knee rc
V1 in 0 DC {vin}
R1 in a 1k
C1 a 0 c = 'v(a) < 5 ? 1u : 0.99u*exp(-10*v(a)) + 0.01u'
.param vin=4
.tran 1u 5m uic
.end
"""


def test_below_the_knee_is_the_constant_capacitor():
    c = parse_string(RC)
    cap = c.element("C1")
    assert isinstance(cap, KneeCapacitor) and cap.value == 1e-6 and cap.region == "v(C1) < 5 V"
    res = simulate_circuit(c, probes=["v(a)"])
    res.raise_if_error()
    # the RC charge to 4 V, tau 1 ms (backward Euler or trapezoidal: within 1e-3)
    t = res.t
    assert np.allclose(res["v(a)"], 4 * (1 - np.exp(-t / 1e-3)), atol=4e-3)
    assert res.names == ("v(a)",)  # the capacitor's voltage, checked, is not kept
    assert any("C1: capacitor value" in n and "the run stayed there (0 V to 3.97" in n
               for n in res.notes)


def test_past_the_knee_is_refused_with_the_instant():
    with pytest.raises(NetlistError) as exc:
        simulate_circuit(parse_string(RC.replace("vin=4", "vin=6")), probes=["v(a)"])
    text = str(exc.value)
    assert "<string>:4:1: error: capacitor 'C1'" in text
    t = float(text.split("at t = ")[1].split(" s")[0])
    # 6 (1 - exp(-t/tau)) = 5 at t = tau ln 6
    assert t == pytest.approx(1e-3 * math.log(6), abs=2e-6)


def test_the_knee_is_checked_at_every_step_of_a_run_written_on_a_grid():
    # A run written on a coarse grid (output_step) is otherwise interpolated as it goes; with
    # a knee it keeps every step, so that the crossing between two grid points is found at
    # its step, not at the next grid point.
    with pytest.raises(NetlistError) as exc:
        simulate_circuit(parse_string(RC.replace("vin=4", "vin=6")), probes=["v(a)"],
                         output_step=1e-3)
    t = float(str(exc.value).split("at t = ")[1].split(" s")[0])
    assert t == pytest.approx(1e-3 * math.log(6), abs=2e-6)
    res = simulate_circuit(parse_string(RC), probes=["v(a)"], output_step=1e-3)
    assert np.allclose(res.t, np.arange(6) * 1e-3)
    assert np.allclose(res["v(a)"], 4 * (1 - np.exp(-res.t / 1e-3)), atol=4e-3)


def test_the_knee_is_checked_at_every_step_of_a_run_of_every_state(tmp_path):
    # Without probes every state is stored, the knee's voltage among them: such a run
    # written on a grid, or streamed to a file by the command line, still keeps every step
    # for the check (it once saw only the grid's points, or the last row)
    with pytest.raises(NetlistError) as exc:
        simulate_circuit(parse_string(RC.replace("vin=4", "vin=6")), output_step=1e-3)
    t = float(str(exc.value).split("at t = ")[1].split(" s")[0])
    assert t == pytest.approx(1e-3 * math.log(6), abs=2e-6)
    deck = tmp_path / "knee.cir"
    deck.write_text(RC.replace("vin=4", "vin=6"))
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        code = main(["simulate", str(deck), "-o", str(tmp_path / "out.csv"), "--no-progress"])
    assert code != 0 and "past the knee" in out.getvalue(), out.getvalue()


@pytest.mark.parametrize("value, words", [
    ("v(in) < 5 ? 1u : 2u", "other than the capacitor's own voltage"),
    ("v(a) < 5 ? v(a)*1u : 2u", "depends on v(a)"),
])
def test_other_forms_are_refused(value, words):
    with pytest.raises(NetlistError) as exc:
        parse_string(RC.replace("v(a) < 5 ? 1u : 0.99u*exp(-10*v(a)) + 0.01u", value))
    assert words in str(exc.value)


@pytest.mark.parametrize("g, regular", [(1e-11, True), (1e-15, False), (0.0, False)])
def test_a_part_held_by_a_tiny_conductance(g, regular):
    """A node joined to the rest by g (S) only, against 1 S: regular at double precision
    above 1e-13 of the largest singular value, solved whole; below, or exactly singular,
    the right-hand side that would need it is inconsistent."""
    M = np.array([[1.0 + g, -1.0], [-1.0, 1.0]])
    K = np.array([[1.0], [0.0]])
    sol = Solution(M, K)
    if regular:
        assert not sol.inconsistent and sol.null.shape[1] == 0
        assert np.allclose(sol.Z, np.linalg.solve(M, K), rtol=1e-4)
    else:
        assert sol.inconsistent == [0]


# An RC of 1 Ohm from 1 V, with UIC: ngspice cuts an unquoted value at its first blank
# outside parentheses (netlist.element_lines.ngspice_value_token)
UNQUOTED = "unquoted\nV1 in 0 DC 1\nR1 in a 1\nC1 a 0 c = {value}\n.tran 0.1u 2u uic\n.end\n"


@pytest.mark.parametrize("value, farads", [
    ("(v(a) < {5}) ? {1u} : {2u}", 1.0),  # the comparison alone: 1 F while it holds
    ("(v(a)<{5})?{1u}:{2u}", 1e-6),  # one token: the conditional as written
])
def test_an_unquoted_value_is_read_as_ngspice_reads_it(value, farads, tmp_path, ngspice):
    from ngspice_helpers import ngspice_print

    deck = UNQUOTED.format(value=value)
    c = parse_string(deck)
    assert c.element("C1").value == farads
    res = simulate_circuit(c, probes=["v(a)"])
    got = float(res["v(a)"][-1])
    assert got == pytest.approx(1 - math.exp(-2e-6 / farads), rel=1e-3)
    ng = ngspice_print(deck, ["v(a)[length(v(a))-1]"], tmp_path)
    assert got == pytest.approx(ng["v(a)[length(v(a))-1]"], rel=2e-3)
    cut = [n for n in c.notes if n.startswith("C1: value written unquoted")]
    assert bool(cut) == (farads == 1.0)
    if cut:
        assert "c = (v(a) < {5}), the rest ('? {1u} : {2u}') dropped" in cut[0]
        assert "1 F while it holds (0 F else)" in cut[0]


def test_an_unquoted_value_ngspice_cuts_to_a_nonlinear_one_is_refused():
    with pytest.raises(NetlistError) as exc:
        parse_string(UNQUOTED.format(value="(v(a)*{2}) ? {1u} : {2u}"))
    text = str(exc.value)
    assert "<string>:4:12: error: capacitor 'C1': its value is written unquoted" in text
    assert "c = (v(a)*{2}), the rest ('? {1u} : {2u}') dropped" in text
