"""The expressions of ngspice's B sources: their grammar, and their linear or comparator form.

:func:`parse_behavioural` reads the text after ``V=``/``I=`` into a :class:`Tree`;
:func:`linearise` evaluates the parameters in it and gives an :class:`Affine` form (a linear
source), a :class:`Step` (a comparator whose values are constants) or, when asked, a
:class:`Clamp` (``min``/``max`` of one affine form and constants), or refuses the expression
at the operation that makes it none of these. What these become in a circuit is
:mod:`netlist.behavioural`.

Precedence (loosest first, as in ngspice): ``? :``, ``||``, ``&&``, ``== !=``, ``< > <= >=``,
``+ -``, ``* /``, unary ``- + !``, ``** ^`` (a sign in an exponent takes the powers after it:
``2^-1^2`` is ``2^-(1^2)``). ``u(0)`` is 0.5 in ngspice: a tie, as a comparison at
equality, lasts an instant and decides nothing here.

The arithmetic of constants is that of ngspice 39's B sources (measured), not numparam's
(:mod:`netlist.expressions`): ``a ** b``, ``a ^ b`` and ``pow(a, b)`` are ``|a|^b``,
left-associative (``2^3^2 = 64``), ``pwr(a, b)`` is ``sign(a)|a|^b`` (``pwr(-2, 3) = -8``); a B
source has no ``%``, no hexadecimal numbers and no ``sqr``, ``arctan`` or ``int``.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from .circuit import GROUND
from .dialect import node_name
from .expressions import CONSTANTS, FUNCTIONS
from .units import parse_number

__all__ = ["ACCEPTED", "Affine", "BehaviouralError", "Clamp", "ClampInSum", "Select", "Step",
           "Tree", "circuit_quantity", "linearise", "parse_behavioural", "spice_text"]

#: the forms pelcs reads, for the hints of every refusal
ACCEPTED = ("pelcs reads B sources whose expression is linear in v() and i() (constants and "
            "parameters allowed; it becomes E/G/H/F sources), and comparators 'x > y ? A : B', "
            "'u(x - y)' or 'A*(x > y)' with linear x, y and constant A, B, or 'x > y ? A : B' "
            "with linear A, B as the whole expression (an ideal switch on the comparison sets "
            "the output), clamps max(lo, min(hi, x)) of a linear x with constant lo, hi "
            "(ideal diodes hold it within the bounds), alone or added to linear terms, and "
            "sigmoids of a linear x, A*tanh(k*x), A*(1+tanh(k*x))/2 + B, A/(1+exp(-k*x)), "
            "A*atan(k*x) (read as the ideal comparator x > 0 ? hi : lo at their limits, if x "
            "crosses their transition band quickly: checked after the run)")


class BehaviouralError(Exception):
    """A problem in a B expression, at ``offset`` (0-based) in its text."""

    def __init__(self, message: str, offset: int = 0, hint: str = ""):
        super().__init__(message)
        self.message = message
        self.offset = offset
        self.hint = hint


class ClampInSum(BehaviouralError):
    """A clamp (``min``/``max`` of an affine form) added to a non-constant term: no one form,
    though :mod:`netlist.behavioural` builds the clamp on a node of its own."""


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


def _b_pow(a: float, b: float) -> float:
    """A B source's power, pow() and ``**``: ``|a|^b`` (``(-2)^3 = 8`` in ngspice 39)."""
    return float(abs(a) ** b)


def _b_pwr(a: float, b: float) -> float:
    """A B source's pwr(): ``sign(a)|a|^b`` (``pwr(-2, 3) = -8``, numparam's is 8)."""
    return math.copysign(abs(a) ** b, a) if a != 0.0 else float(0.0 ** b)


# the functions whose B-source value differs from numparam's, and numparam's functions that
# ngspice 39's B sources do not know
_B_CONSTANT = {"pow": (_b_pow, 2, 2), "pwr": (_b_pwr, 2, 2)}
_NOT_IN_B = {"sqr", "arctan", "int"}


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

    def walk(self) -> list[Tree]:
        """This node and every node under it (depth first)."""
        out, stack = [], [self]
        while stack:
            t = stack.pop()
            out.append(t)
            stack.extend(a for a in t.args if isinstance(a, Tree))
        return out


class _Parser:
    def __init__(self, text: str):
        self.text = text
        self.toks: list[tuple[str, str, int]] = []
        pos = 0
        while pos < len(text):
            m = _TOKEN.match(text, pos)
            if m is None:
                raise BehaviouralError(f"unexpected character {text[pos]!r} in expression "
                                       f"'{text.strip()}'", pos,
                                       "ngspice's B sources have no remainder operator %: "
                                       "numparam's a % b is a - b*int(a/b), in a .param"
                                       if text[pos] == "%" else "")
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

    # binary levels, loosest first, as ngspice's B sources (== and != looser than < and >:
    # 2 == 1 < 2 is 2 == (1 < 2) = 0 there, measured); ** is handled in power()
    _LEVELS = (("||",), ("&&",), ("==", "!="), ("<", ">", "<=", ">="), ("+", "-"), ("*", "/"))

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
        # left-associative, as ngspice's B sources (2^3^2 = 64); an exponent may carry signs
        base = self.atom()
        while self.peek()[1] in ("**", "^"):
            self.take()
            exp = self.exponent()
            base = Tree("**", (base, exp), base.start, exp.end)
        return base

    def exponent(self) -> Tree:
        kind, value, pos = self.peek()
        if kind == "op" and value in "-+!":
            self.take()
            sub = self.exponent()
            # (a sign in an exponent takes the powers after it, as ngspice's B sources:
            # 2^-1^2 is 2^-(1^2) = 0.5 there, measured, where 2^3^2 is (2^3)^2)
            while self.peek()[1] in ("**", "^"):
                self.take()
                exp = self.exponent()
                sub = Tree("**", (sub, exp), sub.start, exp.end)
            if value == "+":
                return sub
            return Tree("neg" if value == "-" else "not", (sub,), pos, sub.end)
        return self.atom()

    def atom(self) -> Tree:
        kind, value, pos = self.take()
        if kind == "num":
            if value[:2].lower() == "0x":
                raise BehaviouralError(f"ngspice's B sources read no hexadecimal number "
                                       f"('{self.text.strip()}' is an error there)", pos,
                                       "write the number in decimal, or in a .param "
                                       "(numparam reads 0x10 as 16)")
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
            if low == "if" and len(args) == 3:  # LTspice's if(c, a, b): c ? a : b
                return Tree("?", tuple(args), pos, self.end_of())
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


def spice_text(t: Tree, leaf: Callable[[Tree], str]) -> str:
    """A parsed B expression written back for a B line, fully parenthesised; ``leaf`` writes
    its numbers, names, ``v()`` and ``i()`` (the parameters' values, the flattened nodes)."""
    tag, args = t.tag, t.args
    if tag == "call":
        return f"{args[0]}({', '.join(spice_text(a, leaf) for a in args[1:])})"
    if tag == "neg":
        return f"(-{spice_text(args[0], leaf)})"
    if tag == "not":
        return f"(!{spice_text(args[0], leaf)})"
    if tag == "?":
        c, a, b = (spice_text(x, leaf) for x in args)
        return f"({c} ? {a} : {b})"
    if tag in ("num", "var", "v", "i"):
        return leaf(t)
    a, b = (spice_text(x, leaf) for x in args)
    return f"({a} {tag} {b})"


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


@dataclass(frozen=True)
class Select:
    """``hi`` while ``diff > 0`` (``strict``) or ``diff >= 0``, else ``lo``: a comparator whose
    branches are affine forms, not both constants (read as a whole B expression only:
    ``v(in) > 7 ? v(in) - 5 : v(in) - 2``)."""

    diff: Affine
    strict: bool
    hi: Affine
    lo: Affine


@dataclass(frozen=True)
class Clamp:
    """``max(lo, min(hi, form))``: an affine form clamped between constants (``lo`` may be
    ``-inf``, ``hi`` ``+inf``; ``lo < hi``), as ``min``/``max`` of an affine form and
    constants give: folded into what compares it, or an ideal limiter
    (:func:`netlist.behavioural.fold_clamps`)."""

    form: Affine
    lo: float
    hi: float

    def scaled(self, k: float) -> Affine | Clamp:
        if k == 0:
            return Affine((), 0.0)
        lo, hi = self.lo * k, self.hi * k
        return Clamp(self.form.scaled(k), min(lo, hi), max(lo, hi))

    def shifted(self, c: float) -> Clamp:
        return Clamp(self.form.plus(Affine((), c)), self.lo + c, self.hi + c)

    def bounded(self, name: str, k: float) -> Affine | Clamp:
        """``min(k, self)`` or ``max(k, self)``: min distributes over max (and max over min),
        so the bounds move and the form stays."""
        fn = min if name == "min" else max
        lo, hi = fn(self.lo, k), fn(self.hi, k)
        return Affine((), lo) if lo == hi else Clamp(self.form, lo, hi)


def _const(x: float) -> Affine:
    return Affine((), float(x))


class _Lineariser:
    def __init__(self, text: str, env: Mapping[str, float], mapnode: Callable[[str], str],
                 source: Callable[[str], str], clamps: bool = False):
        self.clamps = clamps
        self.memo: dict[int, Affine | Step | Clamp] = {}
        self.text = text
        self.env = env
        self.mapnode = mapnode
        self.source = source

    def nonlinear(self, t: Tree, why: str, kind: type[BehaviouralError] = BehaviouralError
                  ) -> BehaviouralError:
        part = self.text[t.start:t.end].strip()
        return kind(f"'{part}' is {why}", t.start, ACCEPTED)

    def constant_of(self, t: Tree, x: Affine | Step) -> float | None:
        return x.const if isinstance(x, Affine) and x.constant else None

    def form(self, t: Tree) -> Affine | Step | Clamp:
        # memoised: the clamp checks below read a node's operands before its own rules do
        key = id(t)
        if key not in self.memo:
            self.memo[key] = self._form(t)
        return self.memo[key]

    def _clamp_op(self, t: Tree, tag: str, a, b) -> Affine | Clamp:
        """A clamp in ``neg``, ``+ - * /`` with a constant: the clamp moved or scaled."""
        if tag == "neg":
            return a.scaled(-1.0)
        ka = a.const if isinstance(a, Affine) and a.constant else None
        kb = b.const if isinstance(b, Affine) and b.constant else None
        if tag in ("+", "-"):
            if tag == "-":
                b = b.scaled(-1.0) if kb is None else _const(-kb)
                kb = None if kb is None else -kb
            if isinstance(a, Clamp) and kb is not None:
                return a.shifted(kb)
            if isinstance(b, Clamp) and ka is not None:
                return b.shifted(ka)
            raise self.nonlinear(t, "a sum of a clamp (min/max) and a non-constant term",
                                 ClampInSum)
        if tag == "/":
            if kb is None:
                raise self.nonlinear(t, "a division by a clamp or node voltage: nonlinear")
            if kb == 0:
                raise BehaviouralError("division by zero", t.args[1].start)
            return a.scaled(1.0 / kb)
        if isinstance(a, Clamp) and kb is not None:
            return a.scaled(kb)
        if isinstance(b, Clamp) and ka is not None:
            return b.scaled(ka)
        raise self.nonlinear(t, "a product of a clamp (min/max) and a circuit quantity: "
                                "nonlinear")

    def _form(self, t: Tree) -> Affine | Step | Clamp:
        tag, args = t.tag, t.args
        if tag in ("neg", "+", "-", "*", "/"):
            subs = [self.form(a) for a in args]
            if any(isinstance(x, Clamp) for x in subs):
                return self._clamp_op(t, tag, *subs, *([None] if tag == "neg" else []))
        for sub in args:
            if tag != "call" and isinstance(sub, Tree) and isinstance(self.form(sub), Clamp):
                raise self.nonlinear(sub, "a clamp (min/max) of a circuit quantity inside "
                                          "a comparison or condition: pelcs reads a clamp "
                                          "only as a whole B source")
        if tag in ("num", "var", "v", "i"):
            return self._leaf(t)
        if tag in ("neg", "+", "-", "*", "/", "**"):
            return self._arith(t)
        if tag == "call":
            return self.call(t)
        return self._logic(t)

    def _leaf(self, t: Tree) -> Affine:
        """A number, a parameter, a node voltage or a source's current."""
        tag, args = t.tag, t.args
        if tag == "num":
            return _const(args[0])
        if tag == "var":
            name = args[0]
            if name in CONSTANTS:  # (before a .param of the name: ngspice 39, measured)
                return _const(CONSTANTS[name])
            if name in self.env:
                return _const(self.env[name])
            if name in ("time", "temper", "hertz"):
                raise BehaviouralError(
                    f"'{name}' in a B expression makes a time-varying source", t.start,
                    "a known waveform is an independent V or I source with PULSE, SIN, PWL or "
                    "EXP; a B source of time alone (V = time > 1m ? 5 : 0, a sawtooth "
                    "time/T - floor(time/T), 5*sin(2*pi*50*time)) is read as the source of "
                    "its waveform, but not one that also reads v() or i(); " + ACCEPTED)
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
        raise AssertionError(tag)

    def _arith(self, t: Tree) -> Affine | Step:
        """A negation, sum, difference, product, quotient or power (no clamp in them)."""
        tag, args = t.tag, t.args
        if tag == "neg":
            x = self.form(args[0])
            return x.scaled(-1.0) if isinstance(x, Affine) else x.mapped(lambda v: -v)
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
                value = _b_pow(ka, kb)
            except (ZeroDivisionError, OverflowError):
                raise BehaviouralError(f"cannot evaluate {ka:g} ** {kb:g}", t.start) from None
            return _const(value)
        raise AssertionError(tag)

    def _logic(self, t: Tree) -> Affine | Step:
        """A negation, comparison, conjunction, disjunction or condition."""
        tag, args = t.tag, t.args
        if tag == "not":
            x = self.form(args[0])
            return self.truth(args[0], x, negate=True)
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
        raise AssertionError(tag)

    def truth(self, t: Tree, x: Affine | Step, negate: bool) -> Affine | Step:
        """``x != 0`` (or ``x == 0`` with ``negate``) as 1 or 0."""
        if isinstance(x, Affine):
            if not x.constant:
                raise self.nonlinear(t, "a node voltage or current used as a truth value")
            return _const(float((x.const != 0) != negate))
        return x.mapped(lambda v: float((v != 0) != negate))

    def call(self, t: Tree) -> Affine | Step | Clamp:
        name, subs = t.args[0], t.args[1:]
        forms = [self.form(s) for s in subs]
        consts = [self.constant_of(s, f) for s, f in zip(subs, forms, strict=True)]
        if self.clamps and name in ("min", "max") and len(subs) == 2:
            moving = [f for f, k in zip(forms, consts, strict=True) if k is None]
            if len(moving) == 1 and isinstance(moving[0], Affine | Clamp):
                x = moving[0]
                bound = (min if name == "min" else max)(k for k in consts if k is not None)
                if isinstance(x, Affine):
                    x = Clamp(x, -math.inf, math.inf)
                return x.bounded(name, bound)
        for s, f in zip(subs, forms, strict=True):
            if isinstance(f, Clamp):
                raise self.nonlinear(s, f"a clamp (min/max) of a circuit quantity inside "
                                        f"{name}(): pelcs reads min()/max() of one linear "
                                        "expression and constants")
        if name == "u" and len(subs) == 1:
            x = forms[0]
            if consts[0] is not None:
                k = consts[0]
                return _const(1.0 if k > 0 else 0.0 if k < 0 else 0.5)
            if isinstance(x, Affine):
                return Step(x, True, 1.0, 0.0)
            raise self.nonlinear(t, "u() of a comparison")
        if name in _NOT_IN_B:
            raise BehaviouralError(f"no function '{name}' in ngspice's B sources (ngspice 39: "
                                   f"\"no such function '{name}'\")", t.start,
                                   f"{name}() is numparam's: compute it in a .param")
        if name in FUNCTIONS:
            fn, lo, hi = _B_CONSTANT.get(name) or FUNCTIONS[name]
            if len(subs) < lo or (hi is not None and len(subs) > hi):
                raise BehaviouralError(f"{name}() takes {lo if lo == hi else f'at least {lo}'}"
                                       f" argument(s), got {len(subs)}", t.start)
            if all(k is not None for k in consts):
                try:
                    return _const(float(fn(*consts)))
                except (ValueError, OverflowError, ZeroDivisionError) as exc:
                    raise BehaviouralError(f"cannot evaluate {name}(): {exc}", t.start) from None
            raise self.nonlinear(t, f"{name}() of a node voltage or current: nonlinear")
        if name in _B_FUNCTIONS:
            raise self.nonlinear(t, f"{name}() of the circuit's quantities: not a linear or "
                                    "comparator form")
        known = ", ".join(sorted(set(FUNCTIONS) | {"u", "v", "i"}))
        if name == "limit" and len(t.args) == 4:
            # (LTspice's clamp; ngspice 39 has no such B function and gives the source 0 V)
            raise BehaviouralError("unknown function 'limit': LTspice's limit(x, lo, hi) is "
                                   "not a function of ngspice's B sources", t.start,
                                   "write the clamp max(lo, min(hi, x)), which pelcs reads "
                                   "as an exact ideal-diode limiter; known: " + known)
        raise BehaviouralError(f"unknown function '{name}'", t.start, f"known: {known}")


def linearise(tree: Tree, text: str, env: Mapping[str, float],
              mapnode: Callable[[str], str] = lambda n: n,
              source: Callable[[str], str] = lambda s: s, clamps: bool = False
              ) -> Affine | Step | Select | Clamp:
    """The linear, comparator or clamp form of a parsed B expression.

    Parameters
    ----------
    tree, text : Tree, str
        From :func:`parse_behavioural`, and the text it was parsed from (for messages).
    env : mapping of str to float
        Parameter values (lower-case names).
    mapnode, source : callable
        Node names and source names as written -> the flattened circuit's names.
    clamps : bool
        Read ``min``/``max`` of one affine form and constants as a :class:`Clamp` (else they
        are refused as nonlinear).

    Returns
    -------
    Affine, Step, Select or Clamp
        An :class:`Affine` form (a linear source), a :class:`Step` (a comparator whose
        values are constants), a :class:`Select` (a comparator whose branches are linear, as
        the whole expression), or (with ``clamps``) a :class:`Clamp`.

    Raises
    ------
    BehaviouralError
        A nonlinear expression, an unknown parameter or function, at its offset.
    """
    try:
        out = _Lineariser(text, env, mapnode, source, clamps).form(tree)
    except RecursionError:
        raise BehaviouralError(_TOO_DEEP, 0) from None
    except BehaviouralError:
        # a comparator whose branches are linear forms, as the whole expression
        out = _select(tree, _Lineariser(text, env, mapnode, source, clamps))
        if out is None:
            raise
    if isinstance(out, Clamp):
        numbers = [c for _, c in out.form.terms] + [out.form.const]
    elif isinstance(out, Affine):
        numbers = [c for _, c in out.terms] + [out.const]
    elif isinstance(out, Select):
        numbers = [c for f in (out.diff, out.hi, out.lo) for c in (*dict(f.terms).values(),
                                                                    f.const)]
    else:
        numbers = [*(c for _, c in out.diff.terms), out.diff.const, out.hi, out.lo]
    if not all(math.isfinite(c) for c in numbers):
        raise BehaviouralError(f"expression '{text.strip()}' overflows: a coefficient or "
                               "value is not a finite double", 0)
    if isinstance(out, Step) and out.hi == out.lo:
        return _const(out.hi)
    if isinstance(out, Select) and out.hi == out.lo:
        return out.hi
    return out


def _select(tree: Tree, lin: _Lineariser) -> Select | None:
    """``cond ? a : b`` with a comparison ``cond`` and affine ``a``, ``b`` as a
    :class:`Select`, or such a comparator (or one of constants) plus or minus an affine form
    (a floating gate drive: ``V(sw) + if(V(pwm) > 6, 11.5, 0)``), the form added to both
    branches; None for any other expression (or a part that is no such form)."""
    if tree.tag in ("+", "-"):
        parts = []
        for x in tree.args:
            part = _select(x, lin)
            if part is None:
                try:
                    part = lin.form(x)
                except (BehaviouralError, RecursionError):
                    return None
            if isinstance(part, Step):
                part = Select(part.diff, part.strict, _const(part.hi), _const(part.lo))
            parts.append(part)
        a, b = parts
        if tree.tag == "-":
            b = b.scaled(-1.0) if isinstance(b, Affine) else Select(
                b.diff, b.strict, b.hi.scaled(-1.0), b.lo.scaled(-1.0)) \
                if isinstance(b, Select) else None
        if isinstance(a, Select) and isinstance(b, Affine):
            a, b = b, a
        if not (isinstance(a, Affine) and isinstance(b, Select)):
            return None
        return Select(b.diff, b.strict, b.hi.plus(a), b.lo.plus(a))
    if tree.tag != "?":
        return None
    try:
        c, a, b = (lin.form(x) for x in tree.args)
    except (BehaviouralError, RecursionError):
        return None
    if not (isinstance(c, Step) and isinstance(a, Affine) and isinstance(b, Affine)):
        return None
    return Select(c.diff, c.strict, a if c.hi != 0 else b, a if c.lo != 0 else b)
