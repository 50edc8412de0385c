"""The command line takes no abbreviations and names the closest option or probe of a typo."""

from __future__ import annotations

import argparse

import pytest

from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import check_probes
from netlist.suggest import close_matches, did_you_mean
from pelcs.cli import COMMANDS, build_parser, main

BUCK = """buck
Vin in 0 DC 12
S1 in sw ctl 0 SW1
Vg ctl 0 PULSE(0 1 0 1n 1n 5u 10u)
D1 0 sw DI
L1 sw out 100u
C1 out 0 10u
R1 out 0 5
.model SW1 SW(VT=0.5 RON=1m ROFF=1e9)
.model DI D
.tran 0.1u 100u
.end
"""


def _error(capsys, argv: list[str]) -> str:
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    out, err = capsys.readouterr()
    assert "Traceback" not in err + out
    return err


def test_every_parser_refuses_abbreviations():
    parser = build_parser([], commands=COMMANDS)
    assert not parser.allow_abbrev
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert set(sub.choices) == set(COMMANDS)
    assert all(not p.allow_abbrev for p in sub.choices.values())


def test_a_prefix_of_an_option_is_refused(capsys):
    err = _error(capsys, ["simulate", "x.cir", "--tst", "1m"])
    assert "error: unrecognized option '--tst'; did you mean '--tstop'?" in err
    assert "usage: pelcs simulate" in err


@pytest.mark.parametrize("command, typo, meant", [
    ("simulate", "--tsop", "--tstop"),
    ("orbit", "--perod", "--period"),
    ("sweep", "--mesure", "--measure"),
    ("ac", "--freqs", "--freq"),
    ("check", "--prob=v(out)", "--probe"),
])
def test_a_misspelt_option_gets_a_did_you_mean(capsys, command, typo, meant):
    err = _error(capsys, [command, "x.cir", typo, "1"])
    name = typo.split("=")[0]
    assert f"error: unrecognized option '{name}'; did you mean '{meant}'?" in err
    assert f"pelcs {command}: error" in err


def test_an_option_far_from_any_and_a_stray_argument(capsys):
    err = _error(capsys, ["simulate", "x.cir", "--zzzzzzzz"])
    assert "unrecognized option '--zzzzzzzz'; `pelcs simulate --help` lists" in err
    err = _error(capsys, ["simulate", "x.cir", "y.cir"])
    assert "unrecognized arguments: y.cir" in err
    err = _error(capsys, ["--verison"])
    assert "did you mean '--version'?" in err


def test_close_matches_ignore_case_and_blanks():
    assert close_matches("V( OT )", ["v(out)", "i(L1)"]) == ["v(out)"]
    assert did_you_mean("i(l)", ["v(out)", "i(L1)"]) == "did you mean i(L1)?"
    assert did_you_mean("qqqq", ["v(out)", "i(L1)"]) == ""


def test_a_misspelt_probe_gets_a_did_you_mean():
    circuit = parse_string(BUCK)
    for typo, meant in (("v(ot)", "v(out)"), ("i(L)", "i(L1)"), ("d(S)", "d(S1)")):
        with pytest.raises(NetlistError) as exc:
            check_probes(circuit, [typo])
        text = exc.value.format()
        assert f"unknown probe '{typo}'" in text and f"did you mean {meant}?" in text, text
    with pytest.raises(NetlistError) as exc:
        check_probes(circuit, ["v(qqqqqq)"])
    assert "did you mean" not in exc.value.format()


def test_the_formulation_names_the_closest_probe_too():
    from netlist.formulation import _Formulator

    f = _Formulator(parse_string(BUCK))
    with pytest.raises(NetlistError) as exc:
        f._resolve_probe("v(ot)")
    assert "did you mean v(out)?" in exc.value.format()


def test_the_cli_prints_the_probe_guess(tmp_path, capsys):
    path = tmp_path / "buck.cir"
    path.write_text(BUCK)
    code = main(["simulate", str(path), "--probe", "v(ot)", "--tstop", "10u"])
    err = capsys.readouterr().err
    assert code == 2 and "unknown probe 'v(ot)'" in err and "did you mean v(out)?" in err


SHARED = ("--param", "--probe", "--step", "--theta", "--method", "--period", "--json",
          "--scheduler", "--tol", "-o")


def test_the_shared_options_are_declared_once():
    """Only pelcs/commands/options.py calls add_argument with a shared option's name."""
    import ast
    from pathlib import Path

    import pelcs.commands

    root = Path(pelcs.commands.__file__).parent
    offenders = []
    for path in [*root.glob("*.py"), root.parent / "cli.py"]:
        if path.name == "options.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr == "add_argument"):
                names = {a.value for a in node.args if isinstance(a, ast.Constant)}
                if names & set(SHARED):
                    offenders.append(f"{path.name}:{node.lineno}")
    assert offenders == []


def test_a_shared_option_means_the_same_in_every_command():
    """Same kind of value, repetition and metavar wherever a shared option appears."""
    parser = build_parser([], commands=COMMANDS)
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    seen: dict[str, tuple] = {}
    for name, p in sub.choices.items():
        for action in p._actions:
            for opt in set(action.option_strings) & set(SHARED):
                kind = (type(action).__name__, action.dest, action.required,
                        action.metavar if opt not in ("--param", "-o") else None)
                assert seen.setdefault(opt, kind) == kind, (name, opt)
    assert set(seen) == set(SHARED)


def test_a_misspelt_required_option_is_named_not_reported_missing(capsys):
    err = _error(capsys, ["bifurcation", "x.cir", "--param", "a=1:2:3", "--trasient", "3",
                          "--record", "2"])
    assert "unrecognized option '--trasient'; did you mean '--transient'?" in err
    assert "required" not in err
    # Missing for real (no misspelling): argparse's own message.
    err = _error(capsys, ["bifurcation", "x.cir", "--param", "a=1:2:3", "--record", "2"])
    assert "the following arguments are required: --transient" in err
