"""``.step param`` in the netlist: parsed into ``circuit.steps``, run by
``pelcs sweep`` (and ``run_sweep``) as swept parameters, errors with file, line and column."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.param_sweep import run_sweep
from pelcs.cli import main

STEP = Path(__file__).parent / "netlists" / "step" / "buck_step.cir"

BASE = """t
.param a=1 b=2
{step}
R1 in 0 {{a}}
V1 in 0 DC 1
.end
"""


def parse(step: str):
    return parse_string(BASE.format(step=step), file="s.cir")


@pytest.mark.parametrize("line, expected", [
    (".step param a 1 2 0.25", [("a", (1.0, 1.25, 1.5, 1.75, 2.0))]),
    (".step param a 0.2 0.6 0.2", [("a", (0.2, 0.4, 0.6))]),  # no 0.6000000000000001
    (".step param a 3 1 -1", [("a", (3.0, 2.0, 1.0))]),
    (".step param a list 1k 2.2k {2*b}", [("a", (1000.0, 2200.0, 4.0))]),
    (".step a list 5 6", [("a", (5.0, 6.0))]),  # LTspice spelling without 'param'
    (".step lin param A 1 2 1", [("a", (1.0, 2.0))]),
])
def test_step_forms(line, expected):
    assert parse(line).steps == expected


def test_two_axes():
    c = parse(".step param a list 1 2\n.step param b 1 3 1")
    assert c.steps == [("a", (1.0, 2.0)), ("b", (1.0, 2.0, 3.0))]


@pytest.mark.parametrize("line, message, column", [
    (".step param z 1 2 1", "'z' is not a .param", 13),
    (".step param a 1 2 -1", "INCR -1 does not lead from 1 to 2", 19),
    (".step param a 1 2 0", "INCR 0", 19),
    (".step param a 1 2", "expected START STOP INCR", 15),
    (".step dec param a 1 100 10", ".step dec is not supported", 7),
    (".step param a list", "list needs values", 19),
])
def test_step_errors_name_the_place(line, message, column):
    with pytest.raises(NetlistError) as info:
        parse(line)
    d = info.value.diagnostics[0]
    assert message in d.message
    assert d.location.file == "s.cir" and d.location.line == 3
    assert d.location.column == column


def test_stepped_twice():
    with pytest.raises(NetlistError, match="stepped twice"):
        parse(".step param a list 1 2\n.step param a list 3")


def test_sweep_runs_the_netlist_steps():
    table = run_sweep(str(STEP), ["mean(v(out))"], workers=1)
    assert tuple(table.swept) == ("duty",)
    assert np.allclose(table.column("duty"), [0.2, 0.4, 0.6])
    assert any(".step" in n for n in table.notes)
    # the same runs as the grid given on the command line
    ref = run_sweep(str(STEP), ["mean(v(out))"], params={"duty": [0.2, 0.4, 0.6]}, workers=1)
    assert np.array_equal(table.column("mean(v(out))"), ref.column("mean(v(out))"))
    # a value given for a stepped parameter wins over its .step
    one = run_sweep(str(STEP), ["mean(v(out))"], params={"duty": 0.5}, workers=1)
    assert len(one) == 1


def test_simulate_runs_the_nominal_values_and_says_so(capsys):
    assert main(["simulate", str(STEP), "--tstop", "0.1m"]) == 0
    out = capsys.readouterr().out
    assert "is run by `pelcs sweep`" in out


def test_writer_leaves_step_out():
    from netlist.parser import parse_file
    from netlist.writer import write_circuit

    text = write_circuit(parse_file(str(STEP)))
    assert not any(line.lower().startswith(".step") for line in text.splitlines())


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_sweep_plots_the_netlist_steps(capsys, tmp_path):
    """--plot was refused ("needs a swept --param") before the .step lines were read."""
    png = tmp_path / "p.png"
    code = main(["sweep", str(STEP), "--measure", "mean(v(out))", "--plot", str(png),
                 "--tstop", "0.2m", "--workers", "1", "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "duty 0.2..0.6 (3 values): 3 run(s), 3 ok" in out
    assert png.stat().st_size > 5000


def test_sweep_says_a_given_value_replaces_the_step(capsys):
    code = main(["sweep", str(STEP), "--measure", "mean(v(out))", "--param", "duty=0.5",
                 "--tstop", "0.2m", "--workers", "1", "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "note: duty = 0.5 replaces the netlist's .step of duty (3 values)" in out
    assert "one run: 1 run(s)" in out


def test_simulate_names_the_step_values_it_uses(capsys):
    assert main(["simulate", str(STEP), "--tstop", "0.1m", "--param", "duty=0.3"]) == 0
    out = capsys.readouterr().out
    assert ("note: the netlist's .step (duty) is run by `pelcs sweep`; this run uses "
            "duty = 0.3 (--param)") in out
    assert "nominal .param values" not in out
    # Another parameter given: the stepped one is at its nominal value, and the note says so.
    assert main(["simulate", str(STEP), "--tstop", "0.1m", "--param", "vin=10"]) == 0
    out = capsys.readouterr().out
    assert "this run uses the nominal .param values" in out


def test_grid_values_like_step_values():
    from netlist.studies.param_sweep import parse_sweep_param

    from_step = parse(".step param a 0.2 0.8 0.2").steps[0][1]
    assert tuple(parse_sweep_param("a=0.2:0.8:4")[1]) == from_step == (0.2, 0.4, 0.6, 0.8)
