"""The CLI builds only the parser of the command it runs (start-up), without
changing what help, errors and the commands themselves say."""

from __future__ import annotations

import pytest

from pelcs.cli import COMMANDS, _wanted, build_parser, main


def test_only_the_named_command_is_imported():
    assert _wanted(["simulate", "x.cir", "--tstop", "1m"]) == ["simulate"]
    assert _wanted(["--strict", "orbit", "x.cir"]) == ["orbit"]
    # Help before the command, no command, or a typo: every command (for the listing).
    assert _wanted(["--help", "simulate"]) == COMMANDS
    assert _wanted([]) == COMMANDS
    assert _wanted(["simulat", "x.cir"]) == COMMANDS


def test_help_lists_every_command(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    out = capsys.readouterr().out
    for name in COMMANDS:
        assert name in out


def test_a_mistyped_command_is_named_with_the_choices(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["simulat", "x.cir"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'simulat'" in err and "'simulate'" in err


def test_one_command_parser_equals_the_full_one():
    argv = ["simulate", "f.cir", "--tstop", "5m", "--strict", "--output-step", "1u"]
    one = vars(build_parser(argv).parse_args(argv))
    full = vars(build_parser(argv, commands=COMMANDS).parse_args(argv))
    assert one.keys() == full.keys()
    assert all(one[k] == full[k] for k in one if k != "func")


@pytest.mark.slow  # (a few seconds: outside the fast subset)
@pytest.mark.parametrize("cache, standalone", [("grammar.lark-standalone", "1"),
                                               ("grammar.lark-tables", "0")])
def test_grammar_caches_survive_a_corrupt_file(tmp_path, cache, standalone):
    # The stand-alone parser's code (netlist.lark_standalone) and, where lark itself parses
    # (PELCS_LARK_STANDALONE=0), lark's tables.
    import os
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    code = ("from netlist.parser import parse_string; "
            "c = parse_string('t\\nR1 a 0 1k\\nV1 a 0 DC 1\\n.end\\n'); "
            "print('OK', [e.name for e in c.elements])")
    env = {**os.environ, "PELCS_CACHE_DIR": str(tmp_path), "PELCS_LARK_STANDALONE": standalone}
    for garbage in (None, b"not a pickle", None, b"", None):
        if garbage is not None:
            (tmp_path / cache).write_bytes(garbage)
        p = subprocess.run([sys.executable, "-c", code], cwd=root, env=env,
                           capture_output=True, text=True, timeout=120)
        assert p.returncode == 0 and "OK ['R1', 'V1']" in p.stdout, p.stderr[-2000:]
        assert p.stderr == ""
        # Written (again) after each run: the next start loads it.
        assert (tmp_path / cache).stat().st_size > 10000
    assert [f.name for f in tmp_path.iterdir()] == [cache]  # no temporary file left
