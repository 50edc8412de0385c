"""lark's stand-alone parser of grammar.lark (netlist.lark_standalone) gives the trees and the
errors lark itself gives, and a start with its code cached does not import lark."""

from __future__ import annotations

import os
import random
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import netlist.expressions as expressions
import netlist.reader as reader
from netlist import lark_standalone
from netlist.errors import NetlistError
from netlist.parser import parse_file

ROOT = Path(__file__).resolve().parents[1]
DECKS = sorted(p for d in ("tests/netlists", "tests/corpus", "converters/netlists", "examples")
               for p in (ROOT / d).rglob("*") if p.suffix.lower() in (".cir", ".sp", ".net"))

# Statements with syntax errors of each kind (an early end, an unexpected token, a character
# no terminal matches) and calls with and without arguments, with the rules they are parsed with.
EXTRA = [("f()", "expression"), ("max(1, 2, x)", "expression"), ("R1 a", "passive"),
         ("R1 a b (", "passive"), ("V1 a 0 PULSE(0 1", "source"), ("V1 a 0 DC", "source"),
         ("D1 a b", "diode"), ("S1 a b c d", "switch"), (".tran 1u", "tran_cmd"),
         (".model m d (is=", "model_cmd"), ("1 +", "expression"), ("2 * (3", "expression"),
         ("a b", "expression"), ("3 ** ** 2", "expression"), ("max(1,", "expression"),
         ("1 $ 2", "expression"), (".param a=", "param_cmd"), (".ic v(a)=", "ic_cmd"),
         ("X1 a b", "instance"), ("K1 L1 L2", "coupling")]


def _canonical(node) -> tuple:
    """A tree or token as plain tuples: what the reader reads of it, positions included."""
    if hasattr(node, "children"):
        return ("tree", str(node.data), tuple(_canonical(c) for c in node.children))
    return ("token", node.type, str(node), node.start_pos, node.line, node.column,
            node.end_line, node.end_column, node.end_pos)


def _outcome(parser, text: str, rule: str) -> tuple:
    try:
        return _canonical(parser.parse(text, start=rule))
    except Exception as exc:  # noqa: BLE001 - the error itself is what is compared
        token = getattr(exc, "token", None)
        return (type(exc).__name__, getattr(exc, "line", None), getattr(exc, "column", None),
                getattr(exc, "pos_in_stream", None), getattr(exc, "char", None),
                None if token is None else (token.type, str(token)),
                tuple(sorted(getattr(exc, "expected", None) or ())),
                tuple(sorted(getattr(exc, "allowed", None) or ())))


class _Recorder:
    """A parser that records what it is asked to parse."""

    def __init__(self, parser, seen: list[tuple[str, str]]):
        self.parser, self.seen = parser, seen

    def parse(self, text: str, start: str):
        self.seen.append((text, start))
        return self.parser.parse(text, start=start)


@pytest.fixture(scope="module")
def statements() -> list[tuple[str, str]]:
    """Every statement the reader parses in the bundled and test netlists, with its rule,
    and mutations of them (characters dropped, doubled or inserted: mostly syntax errors)."""
    seen: list[tuple[str, str]] = []
    recorder = _Recorder(expressions.lark_parser(), seen)
    mp = pytest.MonkeyPatch()
    mp.setattr(reader, "lark_parser", lambda: recorder)
    mp.setattr(expressions, "lark_parser", lambda: recorder)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # (idealised devices, non-passive circuits)
            for deck in DECKS:
                try:
                    parse_file(deck)
                except (NetlistError, OSError, ValueError):
                    pass  # (decks of error tests: their statements count all the same)
    finally:
        mp.undo()
    unique = sorted(set(seen))
    rng = random.Random(1)
    mutated = []
    for text, rule in rng.sample(unique, min(400, len(unique))):
        i = rng.randrange(len(text) + 1)
        mutated += [(text[:i] + text[i + 1:], rule), (text[:i] + text[i:i + 1] + text[i:], rule),
                    (text[:i] + rng.choice("(){}=,'\" +*x1") + text[i:], rule)]
    return unique + EXTRA + mutated


def test_the_stand_alone_parser_is_used():
    if os.environ.get("PELCS_LARK_STANDALONE") == "0":
        pytest.skip("PELCS_LARK_STANDALONE=0: lark itself parses")
    assert lark_standalone.AVAILABLE
    assert isinstance(expressions.lark_parser(), lark_standalone.Lark)
    assert expressions.Token is lark_standalone.Token


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_same_trees_and_errors_as_lark(statements):
    from lark import Lark

    assert len(statements) > 1000
    ours = lark_standalone.Lark_StandAlone() if lark_standalone.AVAILABLE else None
    if ours is None:
        pytest.skip("the stand-alone parser is not available here")
    theirs = Lark(lark_standalone.GRAMMAR_FILE.read_text(encoding="utf-8"), parser="lalr",
                  lexer="contextual", start=lark_standalone.START_RULES,
                  maybe_placeholders=False)
    errors = 0
    for text, rule in statements:
        a, b = _outcome(ours, text, rule), _outcome(theirs, text, rule)
        assert a == b, (text, rule)
        errors += a[0] != "tree"
    assert errors > 300  # the mutations reached the errors


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_a_start_with_the_code_cached_imports_no_lark(tmp_path):
    code = ("import sys; from netlist.parser import parse_string; "
            "c = parse_string('t\\nR1 a 0 {2*5k}\\nV1 a 0 PULSE(0 1 0 1u 1u 1m 2m)\\n.end\\n'); "
            "print('LARK', sorted(m for m in sys.modules if m.split('.')[0] == 'lark'))")
    env = {**os.environ, "PELCS_CACHE_DIR": str(tmp_path)}
    env.pop("PELCS_LARK_STANDALONE", None)
    runs = [subprocess.run([sys.executable, "-c", code], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=120) for _ in range(2)]
    for p in runs:
        assert p.returncode == 0 and p.stderr == "", p.stderr[-2000:]
    # The first start generated the code (with lark); the second loaded it.
    assert "LARK ['lark'" in runs[0].stdout
    assert "LARK []" in runs[1].stdout
