"""User-defined functions: ``.func name(a, b) {expression}``, as ngspice's numparam reads them.

ngspice expands a call of a ``.func`` in place, its arguments taking the place of the
parameters in the body (the body may use ``.param`` names and call other functions), in
parameter expressions and B-source expressions alike. pelcs does the same to the text of an
expression before parsing it (:func:`expand`), so what follows sees ordinary expressions. The
definitions are collected from a file's statements before the file is read, so that a call
may come before its ``.func`` line, as in ngspice.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .dialect import split_top_level

if TYPE_CHECKING:
    from .rawdeck import Statement

__all__ = ["Func", "FuncError", "FuncReading", "expand", "read_func"]

# .func name(args) {body} | = {body} | 'body' | body
_LINE = re.compile(r"(?is)\.func\s+([A-Za-z_][\w.]*)\s*\(([^()]*)\)\s*=?\s*(.*?)\s*$")
_NAME = re.compile(r"[A-Za-z_][\w.]*")
# a name standing alone (not the suffix of a number such as 1e3 or 2meg)
_WORD = re.compile(r"(?<![\w.])[A-Za-z_][\w.]*")
# calls nested deeper than this are a cycle (a function calling itself)
_MAX_DEPTH = 32


@dataclass(frozen=True)
class Func:
    """A ``.func``: its parameters (lower case) and its body (without braces or quotes)."""

    name: str
    params: tuple[str, ...]
    body: str


class FuncError(Exception):
    """A malformed ``.func`` line or call: message, offset in the text, hint."""

    def __init__(self, message: str, offset: int = 0, hint: str = ""):
        super().__init__(message)
        self.message = message
        self.offset = offset
        self.hint = hint


def read_func(text: str) -> Func:
    """The function a ``.func`` statement defines.

    Raises
    ------
    FuncError
        Not ``.func name(params) {body}``, or a parameter that is not a name.
    """
    m = _LINE.match(text)
    if m is None or not m.group(3):
        raise FuncError("malformed .func", len(text.split()[0]) + 1 if text.split() else 0,
                        "syntax: .func name(a, b) {expression}")
    params = tuple(p.strip().lower() for p in m.group(2).split(",") if p.strip())
    for p in params:
        if not _NAME.fullmatch(p):
            raise FuncError(f".func {m.group(1)}: parameter '{p}' is not a name", m.start(2),
                            "syntax: .func name(a, b) {expression}")
    body = m.group(3)
    if len(body) >= 2 and (body[0], body[-1]) in (("{", "}"), ("'", "'"), ('"', '"')):
        body = body[1:-1]
    return Func(m.group(1).lower(), params, body.strip())


def _call_end(text: str, open_at: int) -> int:
    """Index of the parenthesis closing the one at ``open_at``; -1 if none."""
    depth = 0
    for i in range(open_at, len(text)):
        if text[i] == "(":
            depth += 1
        elif text[i] == ")":
            depth -= 1
            if depth == 0:
                return i
    return -1


def _bind(body: str, bound: dict[str, str]) -> str:
    """``body`` with each parameter of ``bound`` replaced by its argument in parentheses."""
    def arg(w: re.Match) -> str:
        a = bound.get(w.group(0).lower())
        return w.group(0) if a is None else f"({a})"

    return _WORD.sub(arg, body)


def expand(text: str, funcs: dict[str, Func], depth: int = 0) -> str:
    """``text`` with every call of a function of ``funcs`` replaced by its body, each
    parameter by its argument in parentheses, the whole in parentheses.

    Raises
    ------
    FuncError
        A call with the wrong number of arguments or unclosed, or calls nested past
        :data:`_MAX_DEPTH` (a function that calls itself).
    """
    if not funcs:
        return text
    if depth > _MAX_DEPTH:
        raise FuncError(f"functions nested more than {_MAX_DEPTH} deep (a .func calling "
                        "itself?)", 0, "a .func must not call itself")
    out, i = [], 0
    for m in _WORD.finditer(text):
        f = funcs.get(m.group(0).lower())
        if f is None or m.start() < i:
            continue
        j = m.end()
        while j < len(text) and text[j] in " \t":
            j += 1
        if j >= len(text) or text[j] != "(":
            continue
        end = _call_end(text, j)
        if end < 0:
            raise FuncError(f"call of .func '{f.name}' is not closed", m.start(),
                            "close its argument list with ')'")
        args = [expand(a, funcs, depth + 1)
                for a in split_top_level(text[j + 1:end], keep_empty=True)]
        if len(args) != len(f.params):
            raise FuncError(f".func '{f.name}' takes {len(f.params)} argument"
                            f"{'s' if len(f.params) != 1 else ''}, got {len(args)}", m.start(),
                            f"call it as {f.name}({', '.join(f.params)})")
        body = _bind(f.body, dict(zip(f.params, args, strict=True)))
        out.append(text[i:m.start()])
        out.append(f"({expand(body, funcs, depth + 1)})")
        i = end + 1
    out.append(text[i:])
    return "".join(out)


class FuncReading:
    """The ``.func`` handling of :class:`netlist.reader._Reader` (its ``funcs``,
    ``func_defs`` and ``error``)."""

    def define_func(self, st: Statement) -> None:
        """Register a ``.func`` (netlist.funcs); its statement is then passed over."""
        try:
            f = read_func(st.text)
        except FuncError as exc:
            self.error(exc.message, st, exc.offset, exc.hint)
            return
        prev = self.func_defs.get(f.name)
        if prev is not None and prev.text != st.text:
            self.error(f".func '{f.name}' is defined twice (first at line {prev.loc(0).line})",
                       st, 0, "rename one of the functions")
            return
        self.funcs[f.name] = f
        self.func_defs[f.name] = st

    def expand_funcs(self, text: str, st: Statement, offset: int) -> str | None:
        """``text`` with its ``.func`` calls expanded (netlist.funcs); None (and a
        diagnostic) for a malformed call."""
        if not self.funcs:
            return text
        try:
            return expand(text, self.funcs)
        except FuncError as exc:
            self.error(exc.message, st, offset + exc.offset, exc.hint)
            return None
