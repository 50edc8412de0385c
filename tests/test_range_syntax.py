"""One range syntax, ``NAME=START:STOP[:N]`` (N values from START to STOP), for every command
that sweeps a parameter or a state: continue, bifurcation, sweep, basins. The default N of
each, continue's deprecated ``--steps``, "did you mean" for a range written ``A..B`` and for
a misspelt option."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from netlist.errors import NetlistError
from netlist.studies.param_sweep import parse_sweep_param
from netlist.studies.sweep import ParamRange, parse_grid, split_params
from pelcs.cli import main
from pelcs.commands.continuation import continuation_steps
from pelcs.commands.options import RANGE_COUNTS

NETLISTS = Path(__file__).resolve().parents[1] / "converters" / "netlists"
VM_BUCK = str(NETLISTS / "vm_buck.cir")
BUCK = str(NETLISTS / "buck.cir")


class _Stop(Exception):
    """Raised by a stand-in analysis once it has seen what the command parsed."""


def _capture(monkeypatch, module: str, name: str, seen: dict):
    """Replace ``module.name`` by a function that records its arguments and stops."""
    import importlib

    mod = importlib.import_module(module)

    def fake(*args, **kwargs):
        seen["args"], seen["kwargs"] = args, kwargs
        raise _Stop

    monkeypatch.setattr(mod, name, fake)


# -- continue --------------------------------------------------------------------------------

def test_continue_count_is_values_and_steps_are_one_fewer(capsys):
    rc = main(["continue", VM_BUCK, "--param", "vin=20:21:3", "--json", "--no-progress"])
    out, err = capsys.readouterr()
    assert rc == 0 and "deprecated" not in err
    report = json.loads(out)
    assert report["steps"] == 2
    assert [round(b["param"], 9) for b in report["branch"]] == [20.0, 20.5, 21.0]


def test_continue_default_count_and_deprecated_steps(capsys):
    rng = ParamRange("vin", 20.0, 30.0)
    assert continuation_steps(None, rng) == RANGE_COUNTS["continue"] - 1 == 40
    assert continuation_steps(None, ParamRange("vin", 20.0, 30.0, 5)) == 4
    # the old form still works, with a note on stderr naming the new one
    assert continuation_steps("2", ParamRange("vin", 20.0, 21.0)) == 2
    err = capsys.readouterr().err
    assert "--steps 2 is deprecated" in err and "--param vin=20:21:3" in err
    # both, agreeing: taken (with the note); disagreeing: refused
    assert continuation_steps("2", ParamRange("vin", 20.0, 21.0, 3)) == 2
    with pytest.raises(NetlistError, match="disagrees"):
        continuation_steps("4", ParamRange("vin", 20.0, 21.0, 3))


def test_continue_with_deprecated_steps_runs(capsys):
    rc = main(["continue", VM_BUCK, "--param", "vin=20:21", "--steps", "2", "--json",
               "--no-progress"])
    out, err = capsys.readouterr()
    assert rc == 0 and json.loads(out)["steps"] == 2
    assert "pelcs continue: note: --steps 2 is deprecated" in err


# -- bifurcation -----------------------------------------------------------------------------

@pytest.mark.parametrize("spec, count", [("vin=20:21:7", 7), ("vin=20:21", 200)])
def test_bifurcation_range(monkeypatch, spec, count):
    seen: dict = {}
    _capture(monkeypatch, "lcs.analysis.bifurcation", "bifurcation_diagram", seen)
    with pytest.raises(_Stop):
        main(["bifurcation", VM_BUCK, "--param", spec, "--transient", "1", "--record", "1",
              "--no-progress"])
    values = np.asarray(seen["args"][1])
    assert values.size == count and values[0] == 20.0 and values[-1] == 21.0
    assert RANGE_COUNTS["bifurcation"] == 200


# -- sweep -----------------------------------------------------------------------------------

def test_sweep_range():
    name, values = parse_sweep_param("duty=0.2:0.8:7", default_count=11)
    assert name == "duty" and values.size == 7
    _, values = parse_sweep_param("duty=0.2:0.8", default_count=RANGE_COUNTS["sweep"])
    assert values.size == 11 and values[1] == pytest.approx(0.26)
    with pytest.raises(NetlistError, match="START:STOP"):
        parse_sweep_param("duty=0.2:0.8")  # (no default given: the count is needed)


def test_sweep_cli_default_count(monkeypatch):
    seen: dict = {}
    _capture(monkeypatch, "netlist.studies.param_sweep", "run_sweep", seen)
    with pytest.raises(_Stop):
        main(["sweep", BUCK, "--param", "duty=0.4:0.6", "--measure", "mean(v(out))"])
    assert np.asarray(seen["kwargs"]["params"]["duty"]).size == RANGE_COUNTS["sweep"]


# -- basins ----------------------------------------------------------------------------------

def test_basins_grid():
    assert parse_grid("v(C1)=10:14:20,i(L1)=0:1.2:30") == [("v(C1)", 10, 14, 20),
                                                          ("i(L1)", 0, 1.2, 30)]
    assert parse_grid("v(C1)=10:14,i(L1)=0:1.2:30", default_count=100)[0][3] == 100
    with pytest.raises(NetlistError, match="COUNT"):
        parse_grid("v(C1)=10:14,i(L1)=0:1.2:30")


def test_basins_cli_default_count(monkeypatch):
    seen: dict = {}
    _capture(monkeypatch, "lcs.analysis.basins", "cell_basins", seen)
    with pytest.raises(_Stop):
        main(["basins", VM_BUCK, "--grid", "v(C1)=10:14,i(L1)=0:1.2:3", "--no-progress"])
    axes = seen["args"][1]
    assert [a[3] for a in axes] == [RANGE_COUNTS["basins"], 3]


# -- did you mean ----------------------------------------------------------------------------

@pytest.mark.parametrize("argv", [
    ["continue", VM_BUCK, "--param", "vin=20..30"],
    ["bifurcation", VM_BUCK, "--param", "vin=20..30", "--transient", "1", "--record", "1"],
    ["sweep", BUCK, "--param", "vin=20..30", "--measure", "mean(v(out))"],
    ["basins", VM_BUCK, "--grid", "v(C1)=20..30,i(L1)=0:1:3"],
])
def test_range_written_with_dots_gets_did_you_mean(argv, capsys):
    assert main(argv) == 2
    err = capsys.readouterr().err
    good = "v(C1)=20:30" if argv[0] == "basins" else "vin=20:30"
    assert f"did you mean {good}?" in err and "Traceback" not in err


def test_dots_with_count_and_suffixes():
    with pytest.raises(NetlistError, match=r"did you mean vin=20k:30k:5\?"):
        split_params(["vin=20k..30k:5"])
    # a fixed value and an expression are not ranges
    assert split_params(["a=8.4", "b={2*3}"])[0] == []


@pytest.mark.parametrize("command, extra", [
    ("continue", []), ("bifurcation", ["--transient", "1", "--record", "1"]),
    ("sweep", ["--measure", "mean(v(out))"]), ("basins", ["--grid", "v(C1)=0:1,i(L1)=0:1"]),
])
def test_misspelt_option_gets_did_you_mean(command, extra, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, VM_BUCK, "--parm", "vin=20:30", *extra])
    assert exc.value.code == 2
    assert "unrecognized option '--parm'; did you mean '--param'?" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["continue", "bifurcation", "sweep", "basins"])
def test_help_gives_the_range_syntax(command, capsys):
    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "START:STOP[:N] is N" in text
    assert f"(default N = {RANGE_COUNTS[command]})" in text
