"""ngspice's B sources (``Bname n+ n- V=expr`` or ``I=expr``) as ideal linear elements.

An ngspice B source computes its value from an arbitrary expression of node voltages
``v(a)``, ``v(a,b)``, source currents ``i(Vx)``, ``time`` and parameters. pelcs simulates
linear complementarity systems, so it reads the two forms that have an exact ideal
equivalent, and refuses the others with the expression's place and the accepted forms:

- **linear**: the expression is affine in ``v()`` and ``i()`` (constants, ``.param`` values
  and ``{...}`` allowed). A ``V=`` source becomes a series chain of E (voltage terms) and H
  (current terms) sources and, for a constant term, a DC source; an ``I=`` source the same
  terms in parallel as G, F and a DC current source. The first element keeps the B's name,
  so that ``i(Bname)`` of a ``V=`` source is still its current. A gyrator ``V=-N*i(Vs)``
  becomes one H source.
- **comparator**: ``cond ? A : B``, ``u(x)`` or ``A*(x > y)`` (and sums and constant
  multiples of these) where ``cond`` compares two affine expressions (``>``, ``<``, ``>=``,
  ``<=``, ``!``) and the values ``A``, ``B`` are constants. Its output switches between two
  constants, so the S switches it controls are on exactly while the comparison is true (or
  false, depending on the values and the switch's ``VT``/``VH``): :func:`resolve_comparators`
  gives those switches the comparison itself as their control and removes the B source.
  Whether the run then computes the switching instants from the sources before stepping or
  locates them as comparator crossings follows from that control, as for any S switch
  (``docs/switching.md``).

Precedence (loosest first, as in ngspice): ``? :``, ``||``, ``&&``, comparisons, ``+ -``,
``* /``, unary ``- + !``, ``** ^``. ``u(0)`` is 0.5 in ngspice: a tie, as a comparison at
equality, lasts an instant and decides nothing here.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import ClassVar

from .circuit import (
    GROUND,
    Cccs,
    Ccvs,
    Circuit,
    CurrentSource,
    Element,
    Model,
    Switch,
    Vccs,
    Vcvs,
    VoltageSource,
)
from .dialect import hierarchical_name, node_name
from .errors import Diagnostic, Location
from .expressions import CONSTANTS, FUNCTIONS
from .rawdeck import RawElement
from .units import parse_number

__all__ = ["ACCEPTED", "Affine", "BehaviouralError", "Comparator", "Step", "linear_elements",
           "linearise", "parse_behavioural", "resolve_comparators"]

#: the forms pelcs reads, for the hints of every refusal
ACCEPTED = ("pelcs reads B sources whose expression is linear in v() and i() (constants and "
            "parameters allowed; it becomes E/G/H/F sources), and comparators 'x > y ? A : B', "
            "'u(x - y)' or 'A*(x > y)' with linear x, y and constant A, B, which must drive only "
            "the controls of S switches")


class BehaviouralError(Exception):
    """A problem in a B expression, at ``offset`` (0-based) in its text."""

    def __init__(self, message: str, offset: int = 0, hint: str = ""):
        super().__init__(message)
        self.message = message
        self.offset = offset
        self.hint = hint


# ------------------------------------------------------------------------------ parsing

_TOKEN = re.compile(r"""
    (?P<ws>\s+)
  | (?P<num>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?[a-zA-Z]*)
  | (?P<name>[a-zA-Z_][a-zA-Z0-9_.$]*)
  | (?P<op>\*\*|<=|>=|==|!=|&&|\|\||[-+*/^<>!?:(),{}])
""", re.VERBOSE)

# extra functions of B expressions (besides netlist.expressions.FUNCTIONS): those that act on
# v()/i() as comparators are handled in _Lineariser.call; the others are nonlinear
_B_FUNCTIONS = {"u", "uramp", "sgn", "ddt", "idt", "table", "tablef", "pwl", "nint", "int",
                "u2", "pwr"}


@dataclass(frozen=True)
class Tree:
    """A node of a parsed B expression: ``tag``, its ``args`` and where it stands
    (``start``, ``end``: offsets in the expression's text).

    Tags: ``num`` (args: value), ``var`` (name), ``v`` (node, node or None), ``i`` (source),
    ``call`` (name, sub-trees...), ``neg``, ``not``, ``+ - * / **``, ``< > <= >= == !=``,
    ``&&``, ``||``, ``?`` (condition, if true, if false).
    """

    tag: str
    args: tuple
    start: int
    end: int


class _Parser:
    def __init__(self, text: str):
        self.text = text
        self.toks: list[tuple[str, str, int]] = []
        pos = 0
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if m is None:
                raise BehaviouralError(f"unexpected character {text[pos]!r} in expression "
                                       f"'{text.strip()}'", pos)
            if m.lastgroup != "ws":
                self.toks.append((m.lastgroup, m.group(), m.start()))
            pos = m.end()
        self.k = 0

    def peek(self) -> tuple[str, str, int]:
        return self.toks[self.k] if self.k < len(self.toks) else ("end", "", len(self.text))

    def take(self, value: str | None = None) -> tuple[str, str, int]:
        tok = self.peek()
        if value is not None and tok[1] != value:
            what = f"'{tok[1]}'" if tok[0] != "end" else "the end of the expression"
            raise BehaviouralError(f"expected '{value}', found {what} in expression "
                                   f"'{self.text.strip()}'", tok[2])
        self.k += 1
        return tok

    def end_of(self) -> int:
        prev = self.toks[self.k - 1]
        return prev[2] + len(prev[1])

    def parse(self) -> Tree:
        if not self.toks:
            raise BehaviouralError("empty expression", 0, "write V=expression or I=expression")
        tree = self.ternary()
        tok = self.peek()
        if tok[0] != "end":
            raise BehaviouralError(f"unexpected '{tok[1]}' in expression "
                                   f"'{self.text.strip()}'", tok[2])
        return tree

    def ternary(self) -> Tree:
        cond = self.binary(0)
        if self.peek()[1] != "?":
            return cond
        self.take("?")
        a = self.ternary()
        self.take(":")
        b = self.ternary()
        return Tree("?", (cond, a, b), cond.start, b.end)

    # binary levels, loosest first; ** is handled in power()
    _LEVELS = (("||",), ("&&",), ("<", ">", "<=", ">=", "==", "!="), ("+", "-"), ("*", "/"))

    def binary(self, level: int) -> Tree:
        if level == len(self._LEVELS):
            return self.unary()
        left = self.binary(level + 1)
        ops = self._LEVELS[level]
        while self.peek()[0] == "op" and self.peek()[1] in ops:
            op = self.take()[1]
            right = self.binary(level + 1)
            left = Tree(op, (left, right), left.start, right.end)
        return left

    def unary(self) -> Tree:
        kind, value, pos = self.peek()
        if kind == "op" and value in "-+!":
            self.take()
            sub = self.unary()
            if value == "+":
                return sub
            return Tree("neg" if value == "-" else "not", (sub,), pos, sub.end)
        return self.power()

    def power(self) -> Tree:
        base = self.atom()
        if self.peek()[1] in ("**", "^"):
            self.take()
            exp = self.unary()
            return Tree("**", (base, exp), base.start, exp.end)
        return base

    def atom(self) -> Tree:
        kind, value, pos = self.take()
        if kind == "num":
            number = parse_number(value)
            if number is None:
                raise BehaviouralError(f"invalid number '{value}'", pos)
            if not math.isfinite(number):
                raise BehaviouralError(f"number '{value}' is too large: it is not a finite "
                                       "double", pos)
            return Tree("num", (float(number),), pos, pos + len(value))
        if kind == "op" and value in "({":
            inner = self.ternary()
            self.take(")" if value == "(" else "}")
            return Tree(inner.tag, inner.args, pos, self.end_of())
        if kind == "name":
            low = value.lower()
            if self.peek()[1] != "(":
                return Tree("var", (low,), pos, pos + len(value))
            if low in ("v", "i"):
                return self.probe(low, pos)
            self.take("(")
            args = []
            if self.peek()[1] != ")":
                args.append(self.ternary())
                while self.peek()[1] == ",":
                    self.take()
                    args.append(self.ternary())
            self.take(")")
            return Tree("call", (low, *args), pos, self.end_of())
        if kind == "end":
            raise BehaviouralError(f"incomplete expression '{self.text.strip()}'", pos,
                                   "an operand is missing")
        raise BehaviouralError(f"unexpected '{value}' in expression '{self.text.strip()}'", pos)

    def probe(self, kind: str, pos: int) -> Tree:
        """``v(a)``, ``v(a,b)``, ``i(Vx)``: the arguments are names as written (a node name
        may hold characters that are operators elsewhere, ``v(net-_1)``)."""
        self.take("(")
        open_at = self.toks[self.k - 1][2]
        close = self.text.find(")", open_at)
        if close < 0:
            raise BehaviouralError(f"{kind}( is not closed", open_at)
        names = [a.strip() for a in self.text[open_at + 1:close].split(",")]
        if any(not a or re.search(r"\s", a) for a in names) or len(names) > (
                2 if kind == "v" else 1):
            usage = "v(node) or v(node1,node2)" if kind == "v" else "i(Vname)"
            raise BehaviouralError(f"malformed {kind}({self.text[open_at + 1:close]})", pos,
                                   f"write {usage}")
        while self.k < len(self.toks) and self.toks[self.k][2] < close:
            self.k += 1
        self.take(")")
        args = tuple(names) + ((None,) if kind == "v" and len(names) == 1 else ())
        return Tree(kind, args, pos, close + 1)


def parse_behavioural(text: str) -> Tree:
    """Parse a B expression (the text after ``V=`` or ``I=``).

    Raises
    ------
    BehaviouralError
        With the offset of the problem in ``text``.
    """
    try:
        return _Parser(text).parse()
    except RecursionError:
        raise BehaviouralError(_TOO_DEEP, 0) from None


_TOO_DEEP = "expression is nested too deeply"


def circuit_quantity(tree: Tree) -> str | None:
    """The first circuit quantity an expression reads (``v(a,b)``, ``i(V1)``, ``time``), as
    written, or None."""
    stack = [tree]
    while stack:
        t = stack.pop(0)
        if t.tag == "v":
            return f"v({t.args[0]})" if t.args[1] is None else f"v({t.args[0]},{t.args[1]})"
        if t.tag == "i":
            return f"i({t.args[0]})"
        if t.tag == "var" and t.args[0] in ("time", "temper", "hertz"):
            return t.args[0]
        stack.extend(a for a in t.args if isinstance(a, Tree))
    return None


# ------------------------------------------------------------------------------ linear forms


@dataclass(frozen=True)
class Affine:
    """``Σ coeff · quantity + const``; quantities ``("v", node)`` (V) and ``("i", source)``
    (A), nodes already mapped to the flattened circuit's names."""

    terms: tuple[tuple[tuple[str, str], float], ...] = ()
    const: float = 0.0

    @property
    def constant(self) -> bool:
        return not self.terms

    def scaled(self, k: float) -> Affine:
        if k == 0:
            return Affine((), 0.0)
        return Affine(tuple((q, c * k) for q, c in self.terms), self.const * k)

    def plus(self, other: Affine) -> Affine:
        acc: dict[tuple[str, str], float] = dict(self.terms)
        for q, c in other.terms:
            acc[q] = acc.get(q, 0.0) + c
        return Affine(tuple((q, c) for q, c in acc.items() if c != 0.0),
                      self.const + other.const)


@dataclass(frozen=True)
class Step:
    """``hi`` while ``diff > 0`` (``strict``) or ``diff >= 0``, else ``lo``: a comparator
    whose values are constants."""

    diff: Affine
    strict: bool
    hi: float
    lo: float

    def mapped(self, fn: Callable[[float], float]) -> Step:
        return Step(self.diff, self.strict, fn(self.hi), fn(self.lo))


def _const(x: float) -> Affine:
    return Affine((), float(x))


class _Lineariser:
    def __init__(self, text: str, env: Mapping[str, float], mapnode: Callable[[str], str],
                 source: Callable[[str], str]):
        self.text = text
        self.env = env
        self.mapnode = mapnode
        self.source = source

    def nonlinear(self, t: Tree, why: str) -> BehaviouralError:
        part = self.text[t.start:t.end].strip()
        return BehaviouralError(f"'{part}' is {why}", t.start, ACCEPTED)

    def constant_of(self, t: Tree, x: Affine | Step) -> float | None:
        return x.const if isinstance(x, Affine) and x.constant else None

    def form(self, t: Tree) -> Affine | Step:
        tag, args = t.tag, t.args
        if tag == "num":
            return _const(args[0])
        if tag == "var":
            name = args[0]
            if name in self.env:
                return _const(self.env[name])
            if name in CONSTANTS:
                return _const(CONSTANTS[name])
            if name in ("time", "temper", "hertz"):
                raise BehaviouralError(
                    f"'{name}' in a B expression makes a time-varying source", t.start,
                    "a known waveform is an independent V or I source with PULSE, SIN, PWL or "
                    "EXP; " + ACCEPTED)
            raise BehaviouralError(f"unknown parameter '{name}'", t.start,
                                   "define it with .param NAME=VALUE, or write v(node) for a "
                                   "node voltage")
        if tag == "v":
            a, b = (None if n is None else self.mapnode(node_name(n)) for n in args)
            terms = [] if a == GROUND else [(("v", a), 1.0)]
            if b is not None and b != GROUND and b != a:
                terms.append((("v", b), -1.0))
            elif b == a:
                terms = []
            return Affine(tuple(terms), 0.0)
        if tag == "i":
            return Affine(((("i", self.source(args[0])), 1.0),), 0.0)
        if tag == "neg":
            x = self.form(args[0])
            return x.scaled(-1.0) if isinstance(x, Affine) else x.mapped(lambda v: -v)
        if tag == "not":
            x = self.form(args[0])
            return self.truth(args[0], x, negate=True)
        if tag in ("+", "-"):
            a, b = self.form(args[0]), self.form(args[1])
            if tag == "-":
                b = b.scaled(-1.0) if isinstance(b, Affine) else b.mapped(lambda v: -v)
            if isinstance(a, Affine) and isinstance(b, Affine):
                return a.plus(b)
            ka, kb = self.constant_of(args[0], a), self.constant_of(args[1], b)
            if isinstance(a, Step) and kb is not None:
                return a.mapped(lambda v: v + kb)
            if isinstance(b, Step) and ka is not None:
                return b.mapped(lambda v: v + ka)
            raise self.nonlinear(t, "a sum of a comparison and a non-constant term")
        if tag in ("*", "/"):
            a, b = self.form(args[0]), self.form(args[1])
            ka, kb = self.constant_of(args[0], a), self.constant_of(args[1], b)
            if tag == "/":
                if kb is None:
                    raise self.nonlinear(t, "a division by a node voltage or current: "
                                            "nonlinear")
                if kb == 0:
                    raise BehaviouralError("division by zero", args[1].start)
                return a.scaled(1.0 / kb) if isinstance(a, Affine) else a.mapped(
                    lambda v: v / kb)
            if kb is not None:
                return a.scaled(kb) if isinstance(a, Affine) else a.mapped(lambda v: v * kb)
            if ka is not None:
                return b.scaled(ka) if isinstance(b, Affine) else b.mapped(lambda v: v * ka)
            raise self.nonlinear(t, "a product of node voltages or currents: nonlinear")
        if tag == "**":
            a, b = self.form(args[0]), self.form(args[1])
            ka, kb = self.constant_of(args[0], a), self.constant_of(args[1], b)
            if ka is None or kb is None:
                raise self.nonlinear(t, "a power of a node voltage or current: nonlinear")
            try:
                value = float(ka ** kb)
            except (ZeroDivisionError, OverflowError, TypeError):
                raise BehaviouralError(f"cannot evaluate {ka:g} ** {kb:g}", t.start) from None
            return _const(value)
        if tag in ("<", ">", "<=", ">=", "==", "!="):
            a, b = self.form(args[0]), self.form(args[1])
            for side, x in zip(args, (a, b), strict=True):
                if isinstance(x, Step):
                    raise self.nonlinear(side, "a comparison used as an operand of another "
                                               "comparison")
            diff = a.plus(b.scaled(-1.0)) if tag in (">", ">=", "==", "!=") else b.plus(
                a.scaled(-1.0))
            if diff.constant:
                d = diff.const
                truth = {">": d > 0, "<": d > 0, ">=": d >= 0, "<=": d >= 0, "==": d == 0,
                         "!=": d != 0}[tag]
                return _const(1.0 if truth else 0.0)
            if tag in ("==", "!="):
                raise self.nonlinear(t, "an equality of node voltages or currents (true for "
                                        "an instant only)")
            return Step(diff, tag in ("<", ">"), 1.0, 0.0)
        if tag in ("&&", "||"):
            a, b = self.form(args[0]), self.form(args[1])
            ka, kb = self.constant_of(args[0], a), self.constant_of(args[1], b)
            if ka is None and kb is None:
                raise self.nonlinear(t, "two comparisons combined: one comparison per B "
                                        "source")
            known, other, other_t = (ka, b, args[1]) if ka is not None else (kb, a, args[0])
            if tag == "&&" and known == 0:
                return _const(0.0)
            if tag == "||" and known != 0:
                return _const(1.0)
            return self.truth(other_t, other, negate=False)
        if tag == "?":
            c = self.form(args[0])
            a, b = self.form(args[1]), self.form(args[2])
            kc = self.constant_of(args[0], c)
            if kc is not None:
                return a if kc != 0 else b
            ka, kb = self.constant_of(args[1], a), self.constant_of(args[2], b)
            if ka is None or kb is None:
                bad = args[1] if ka is None else args[2]
                raise self.nonlinear(bad, "a branch of a comparator that is not a constant")
            assert isinstance(c, Step)
            return Step(c.diff, c.strict, ka if c.hi != 0 else kb, ka if c.lo != 0 else kb)
        if tag == "call":
            return self.call(t)
        raise AssertionError(tag)

    def truth(self, t: Tree, x: Affine | Step, negate: bool) -> Affine | Step:
        """``x != 0`` (or ``x == 0`` with ``negate``) as 1 or 0."""
        if isinstance(x, Affine):
            if not x.constant:
                raise self.nonlinear(t, "a node voltage or current used as a truth value")
            return _const(float((x.const != 0) != negate))
        return x.mapped(lambda v: float((v != 0) != negate))

    def call(self, t: Tree) -> Affine | Step:
        name, subs = t.args[0], t.args[1:]
        forms = [self.form(s) for s in subs]
        consts = [self.constant_of(s, f) for s, f in zip(subs, forms, strict=True)]
        if name == "u" and len(subs) == 1:
            x = forms[0]
            if consts[0] is not None:
                k = consts[0]
                return _const(1.0 if k > 0 else 0.0 if k < 0 else 0.5)
            if isinstance(x, Affine):
                return Step(x, True, 1.0, 0.0)
            raise self.nonlinear(t, "u() of a comparison")
        if name in FUNCTIONS:
            fn, lo, hi = FUNCTIONS[name]
            if len(subs) < lo or (hi is not None and len(subs) > hi):
                raise BehaviouralError(f"{name}() takes {lo if lo == hi else f'at least {lo}'}"
                                       f" argument(s), got {len(subs)}", t.start)
            if all(k is not None for k in consts):
                try:
                    return _const(float(fn(*consts)))
                except (ValueError, OverflowError) as exc:
                    raise BehaviouralError(f"cannot evaluate {name}(): {exc}", t.start) from None
            raise self.nonlinear(t, f"{name}() of a node voltage or current: nonlinear")
        if name in _B_FUNCTIONS:
            raise self.nonlinear(t, f"{name}() of the circuit's quantities: not a linear or "
                                    "comparator form")
        known = ", ".join(sorted(set(FUNCTIONS) | {"u", "v", "i"}))
        raise BehaviouralError(f"unknown function '{name}'", t.start, f"known: {known}")


def linearise(tree: Tree, text: str, env: Mapping[str, float],
              mapnode: Callable[[str], str] = lambda n: n,
              source: Callable[[str], str] = lambda s: s) -> Affine | Step:
    """The linear or comparator form of a parsed B expression.

    Parameters
    ----------
    tree, text : Tree, str
        From :func:`parse_behavioural`, and the text it was parsed from (for messages).
    env : mapping of str to float
        Parameter values (lower-case names).
    mapnode, source : callable
        Node names and source names as written -> the flattened circuit's names.

    Returns
    -------
    Affine or Step
        An :class:`Affine` form (a linear source), or a :class:`Step` (a comparator whose
        values are constants).

    Raises
    ------
    BehaviouralError
        A nonlinear expression, an unknown parameter or function, at its offset.
    """
    try:
        out = _Lineariser(text, env, mapnode, source).form(tree)
    except RecursionError:
        raise BehaviouralError(_TOO_DEEP, 0) from None
    numbers = [c for _, c in out.terms] + [out.const] if isinstance(out, Affine) else [
        *(c for _, c in out.diff.terms), out.diff.const, out.hi, out.lo]
    if not all(math.isfinite(c) for c in numbers):
        raise BehaviouralError(f"expression '{text.strip()}' overflows: a coefficient or "
                               "value is not a finite double", 0)
    if isinstance(out, Step) and out.hi == out.lo:
        return _const(out.hi)
    return out


# ------------------------------------------------------------------------------ elements


@dataclass
class Comparator(Element):
    """A B source whose value switches between two constants (before
    :func:`resolve_comparators` maps it onto the switches it drives; never formulated).
    ``kind_out`` is ``"V"`` or ``"I"``; ``step`` the comparison and the two values; ``text``
    the expression as written."""

    kind_out: str = "V"
    step: Step | None = None
    text: str = ""
    kind: ClassVar[str] = "B"


def _pairs(terms: tuple) -> list[tuple[str, tuple, float]]:
    """The terms of an affine form as controlled-source pieces: ``("v", (a, b), gain)`` for a
    voltage (two opposite node terms make one pair) and ``("i", source, gain)``."""
    volts = [(q[1], c) for q, c in terms if q[0] == "v"]
    out: list[tuple[str, tuple, float]] = []
    if len(volts) == 2 and volts[0][1] == -volts[1][1]:
        out.append(("v", (volts[0][0], volts[1][0]), volts[0][1]))
    else:
        out.extend(("v", (n, GROUND), c) for n, c in volts)
    out.extend(("i", q[1], c) for q, c in terms if q[0] == "i")
    return out


def linear_elements(name: str, kind_out: str, nodes: tuple[str, str], form: Affine,
                    loc: Location | None) -> list[Element]:
    """The E/H/V chain (``V=``) or the G/F/I parallel set (``I=``) equal to a linear B.

    The first element is named ``name``; the others ``name#2``, ``name#3``... and the chain's
    inner nodes ``name#n1``, ``name#n2``... (lower case).
    """
    pieces = _pairs(form.terms)
    p, n = nodes
    names = [name] + [f"{name}#{k}" for k in range(2, len(pieces) + 2)]
    out: list[Element] = []
    if kind_out == "V":
        count = len(pieces) + (1 if form.const != 0 or not pieces else 0)
        ends = [p] + [f"{name.lower()}#n{k}" for k in range(1, count)] + [n]
        for k, (what, ref, gain) in enumerate(pieces):
            a, b = ends[k], ends[k + 1]
            if what == "v":
                out.append(Vcvs(names[k], (a, b), loc, ref, gain))
            else:
                out.append(Ccvs(names[k], (a, b), loc, ref, gain))
        if len(out) < count:
            out.append(VoltageSource(names[len(out)], (ends[-2], n), loc, form.const))
        return out
    for k, (what, ref, gain) in enumerate(pieces):
        if what == "v":
            out.append(Vccs(names[k], (p, n), loc, ref, gain))
        else:
            out.append(Cccs(names[k], (p, n), loc, ref, gain))
    if form.const != 0 or not pieces:
        out.append(CurrentSource(names[len(out)], (p, n), loc, form.const))
    return out


def source_name(prefix: str) -> Callable[[str], str]:
    """``i(Vx)`` inside a subcircuit instance names the instance's ``Vx``."""
    return lambda s: prefix + hierarchical_name(s)


def elaborate(el: RawElement, prefix: str, mapnode: Callable[[str], str],
              env: Mapping[str, float], failed: set[str], error: Callable[..., None]
              ) -> list[Element]:
    """A B source of the raw deck in its instance: its linear equivalent, or a
    :class:`Comparator` that :func:`resolve_comparators` maps onto the switches it drives;
    nothing after reporting a problem with ``error(message, location, hint, elements,
    dependent=...)`` (``dependent``: an unknown parameter, which a statement the reader could
    not read may define)."""
    name = prefix + el.name if prefix else el.name
    out_kind, tree, text, offset = el.behaviour
    loc = el.st.loc(0)
    nodes = tuple(map(mapnode, el.nodes))
    try:
        form = linearise(tree, text, env, mapnode, source_name(prefix))
    except BehaviouralError as exc:
        unknown = exc.message.startswith("unknown parameter")
        if not (unknown and exc.message.split("'")[1] in failed):  # (else reported already)
            error(f"{name}: {exc.message}", el.st.loc(offset + exc.offset), exc.hint, (name,),
                  dependent=unknown)
        return []
    if isinstance(form, Step):
        return [Comparator(name, nodes, loc, out_kind, form, text)]
    return linear_elements(name, out_kind, nodes, form, loc)


# ------------------------------------------------------------------------------ comparators


@dataclass
class _Use:
    switch: Switch
    sign: float  # the switch's control is sign * (the B's output)


def _state(x: float, vt: float, vh: float) -> str | None:
    """``"on"``/``"off"`` for a control held at ``x``, ``None`` inside the band."""
    if x > vt + abs(vh):
        return "on"
    if x < vt - abs(vh):
        return "off"
    return None


def _describe(step: Step) -> str:
    parts = []
    for (kind, ref), c in step.diff.terms:
        q = f"v({ref})" if kind == "v" else f"i({ref})"
        parts.append(f"{'-' if c < 0 else '+'} {'' if abs(c) == 1 else f'{abs(c):g}*'}{q}")
    if step.diff.const:
        parts.append(f"{'-' if step.diff.const < 0 else '+'} {abs(step.diff.const):g}")
    text = " ".join(parts).lstrip("+ ")
    if text.startswith("- "):
        text = "-" + text[2:]
    return f"{text} {'>' if step.strict else '>='} 0"


def resolve_comparators(circuit: Circuit) -> list[Diagnostic]:
    """Map every :class:`Comparator` onto the S switches its output controls, and remove it.

    A switch whose control is ``±`` the B's output is on while its control is above its
    band ``VT ± |VH|`` and off below it (ngspice's SW). The B's two values decide, per
    switch, whether it is on while the comparison is true or while it is false (or always):
    the switch then gets the comparison's difference as its control, threshold 0, and no
    hysteresis (a model ``pelcs_sw_<switch>`` with the original's other parameters). A
    strict comparison (``>``) keeps the switch off at equality, as the B source does. A
    difference of two node voltages is the control pair itself; a longer one is built on
    inner nodes by E and H sources (``<B>#c1``...), each free of load.

    Returns
    -------
    list of Diagnostic
        A B output that feeds anything but switch controls, a switch whose control is not
        across the output, a value inside a switch's band, an ``I=`` comparator.
    """
    diags: list[Diagnostic] = []
    comps = [el for el in circuit.elements if isinstance(el, Comparator)]
    if not comps:
        return diags
    keep = [el for el in circuit.elements if not isinstance(el, Comparator)]
    op_start = circuit.tran is not None and not circuit.tran.uic
    added: list[Element] = []
    for b in comps:
        p, n = b.nodes
        label = f"comparator B source {b.name} ({b.text.strip()})"
        if b.kind_out != "V":
            diags.append(Diagnostic(
                f"{label} is a current source switching between constants", b.location,
                "pelcs maps comparator B sources of the V= form onto the S switches they "
                "control; " + ACCEPTED, (b.name,)))
            continue
        uses: list[_Use] = []
        bad: list[str] = []
        for el in keep:
            if p in el.nodes or (n != GROUND and n in el.nodes):
                bad.append(el.name)
                continue
            ctl = tuple(getattr(el, "control", ()))
            if not ({p, n} - {GROUND}) & set(ctl):
                continue
            if isinstance(el, Switch) and el.device is None and ctl in ((p, n), (n, p)):
                uses.append(_Use(el, 1.0 if ctl == (p, n) else -1.0))
            else:
                bad.append(el.name)
        if bad:
            diags.append(Diagnostic(
                f"the output of {label} feeds {', '.join(bad)}", b.location,
                "pelcs maps a comparator B source onto the S switches whose control "
                f"(nc+ nc-) is its output ({p} {n}); the output must drive nothing else. "
                + ACCEPTED, (b.name, *bad)))
            continue
        step = b.step
        for use in uses:
            sw = use.switch
            model = circuit.models.get(sw.model.lower())
            params = dict(model.params) if model is not None else {}
            vt, vh = float(params.get("vt", 0.0)), float(params.get("vh", 0.0))
            hi = _state(use.sign * step.hi, vt, vh)
            lo = _state(use.sign * step.lo, vt, vh)
            if hi is None and lo is None or (vh > 0 and (hi is None or lo is None)):
                diags.append(Diagnostic(
                    f"{label}: its values {step.hi:g} and {step.lo:g} sit in the band "
                    f"{vt:g} ± {abs(vh):g} V of switch {sw.name}'s control, where the switch's "
                    "state depends on its history", b.location,
                    "give the B source values on either side of the switch's VT ± VH",
                    (b.name, sw.name)))
                continue
            # a value inside a VH <= 0 band is entered from the other value's side: the
            # switch takes the state of that side's opposite (ngspice's swload)
            banded = [(v, "off" if o == "on" else "on") for v, x, o in (
                (step.hi, hi, lo), (step.lo, lo, hi)) if x is None]
            if hi is None:
                hi = "off" if lo == "on" else "on"
            if lo is None:
                lo = "off" if hi == "on" else "on"
            if banded:
                # ... except at the start: ngspice's operating point (no UIC) takes a control
                # inside the band as entered from below (on), UIC the netlist's ON/OFF
                value, state = banded[0]
                start = "on" if op_start else ("on" if sw.initial else "off")
                if start != state:
                    truth = "true" if value == step.hi else "false"
                    how = "its operating point" if op_start else "UIC"
                    circuit.notes.append(
                        f"{sw.name}: if the comparison of {b.name} is {truth} at t = 0, "
                        f"ngspice holds the switch {start} until the comparison changes (the "
                        f"output {value:g} starts inside the switch's band {vt:g} ± "
                        f"{abs(vh):g} V, from {how}); pelcs follows the comparison from t = 0")
            diff, strict = step.diff, step.strict
            if hi == lo:
                diff, strict = Affine((), 1.0 if hi == "on" else -1.0), True
            elif hi == "off":
                # on while the comparison is false: the opposite difference, and the
                # opposite strictness (not (d > 0) is -d >= 0)
                diff, strict = diff.scaled(-1.0), not strict
            control, vt_new, more = _control(sw.name, diff, sw.location)
            added.extend(more)
            key = f"pelcs_sw_{sw.name.lower().replace('.', '_')}"
            params.update({"vt": vt_new, "vh": 0.0})
            circuit.models[key] = Model(key, "SW", params, sw.location)
            sw.control = control
            sw.model = key
            sw.strict = strict
            on_while = _describe(Step(diff, strict, 1.0, 0.0))
            circuit.notes.append(f"{b.name}: comparator B source ({b.text.strip()}) mapped "
                                 f"onto switch {sw.name}: on while {on_while} (its output "
                                 f"node {p} is gone; d({sw.name}) is the switch's state)")
        if not uses:
            circuit.notes.append(f"{b.name}: comparator B source ({b.text.strip()}) controls "
                                 "no switch: left out")
    circuit.elements[:] = keep + added
    return diags


def _control(name: str, diff: Affine, loc: Location | None
             ) -> tuple[tuple[str, str], float, list[Element]]:
    """A control pair and threshold whose ``v(pair) > threshold`` is ``diff > 0``, and the
    elements that build it (none for a difference of two node voltages)."""
    volts = {q[1]: c for q, c in diff.terms if q[0] == "v"}
    currents = [(q[1], c) for q, c in diff.terms if q[0] == "i"]
    if not currents and len(volts) <= 2:
        items = list(volts.items())
        if not items:
            return (GROUND, GROUND), 0.0 - diff.const, []
        if len(items) == 1:
            (a, c), = items
            pair = (a, GROUND) if c > 0 else (GROUND, a)
            return pair, 0.0 - diff.const / abs(c), []
        if len(items) == 2 and items[0][1] == -items[1][1]:
            (a, c), (b, _) = items
            if c < 0:
                a, b, c = b, a, -c
            return (a, b), 0.0 - diff.const / c, []
    # the difference on an inner node: a chain of E (voltages) and H (currents) sources
    pieces = _pairs(diff.terms)
    base = f"{name.lower()}#c"
    ends = [GROUND] + [f"{base}{k}" for k in range(1, len(pieces) + 1)]
    out: list[Element] = []
    for k, (what, ref, gain) in enumerate(pieces):
        el_name = f"{name}#c{k + 1}"
        a, b = ends[k + 1], ends[k]
        if what == "v":
            out.append(Vcvs(el_name, (a, b), loc, ref, gain))
        else:
            out.append(Ccvs(el_name, (a, b), loc, ref, gain))
    return (ends[-1], GROUND), 0.0 - diff.const, out

