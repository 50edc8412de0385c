"""Parameter expressions: the text in ``{...}``, ``'...'`` and bare ``.param`` values.

Grammar (in ``grammar.lark``, start rule ``expression``): numbers with engineering suffixes
(``2*10k``) or hexadecimal (``0x10``), parameter names, ``+ - * /``, ``%``, ``**`` or ``^`` for
powers, unary minus, parentheses, the functions in :data:`FUNCTIONS`;
comparisons (``== != < > <= >=``), ``&&``, ``||`` and ``c ? a : b``, which ngspice's numparam
reads in ``.param`` expressions (a comparison is 1 or 0; ``c`` is true when not 0). Names are
case-insensitive.

The arithmetic is numparam's, measured in ngspice 39: ``a % b`` is ``a - b*trunc(a/b)`` (the
sign of ``a``: ``-10 % 3 = -1``), at the level of ``*`` and ``/``; ``a ** b`` and ``a ^ b`` are
``|a|^b`` (``(-2)**3 = 8``), left-associative (``2^3^2 = 64``); ``pwr(a, b)`` is ``|a|^b``
too and ``pow(a, b)`` C's ``pow`` (``pow(-2, 3) = -8``). numparam reads a minus written just
after an operator as part of the number it precedes (``2*-3^2 = 2*9``) but a minus at the start
of an expression or a parenthesis as applied to the power (``-3^2 = -9``), and ``2*-(3)^2`` as
``2/9``: pelcs refuses a minus after an operator applied to a power, and asks for parentheses.

An expression is parsed once into a small tree of tuples (:class:`Expression`) that lists the
parameter names it uses, so that parameters can be evaluated in dependency order and cycles
found before anything is evaluated.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING

from . import lark_standalone
from .lark_standalone import GRAMMAR_FILE, START_RULES
from .units import parse_number, suffix_scale

if TYPE_CHECKING:
    from lark import Lark

# The parser's token, tree and error classes: the stand-alone parser's, else lark's.
if lark_standalone.AVAILABLE:
    Token, Tree = lark_standalone.Token, lark_standalone.Tree
    UnexpectedCharacters = lark_standalone.UnexpectedCharacters
    UnexpectedEOF = lark_standalone.UnexpectedEOF
    UnexpectedInput = lark_standalone.UnexpectedInput
    UnexpectedToken = lark_standalone.UnexpectedToken
else:
    from lark import Token, Tree
    from lark.exceptions import (
        UnexpectedCharacters,
        UnexpectedEOF,
        UnexpectedInput,
        UnexpectedToken,
    )



def _grammar_cache() -> str | bool:
    """Where lark caches the parser tables (when it parses, see :func:`lark_parser`):
    ``grammar.lark-tables`` in :func:`netlist.lark_standalone.cache_dir`; False when that is
    not writable (the tables are then built on every start)."""
    root = lark_standalone.cache_dir()
    return str(root / "grammar.lark-tables") if root is not None else False


@lru_cache(maxsize=1)
def lark_parser() -> Lark:
    """The LALR parser of ``grammar.lark`` for all start rules, built once: lark's
    stand-alone parser (:mod:`netlist.lark_standalone`, about 5 ms), else lark's."""
    if lark_standalone.AVAILABLE:
        return lark_standalone.Lark_StandAlone()
    from lark import Lark

    return Lark(
        GRAMMAR_FILE.read_text(encoding="utf-8"),
        parser="lalr",
        # The LALR tables, built in ~0.15 s, are cached on disk (keyed by lark on the
        # grammar's hash and these options; rebuilt when either changes).
        cache=_grammar_cache(),
        lexer="contextual",
        start=START_RULES,
        maybe_placeholders=False,
    )


def numparam_arguments(fname: str, args: Sequence[float]) -> tuple[float, ...]:
    """The arguments numparam hands a function of :data:`FUNCTIONS` from a call's one to three
    (ngspice's xpressn.c reads them as first, middle and last, 1 and 0 standing for a
    missing first and middle): a function of one argument takes the last, of two the first
    and the last, of three all three. So, in ngspice 39, ``max(0.5)`` is ``max(1, 0.5)`` = 1,
    ``min(4, 2, 3)`` is 3, ``sqrt(4, 9)`` is 3 and ``pow(3)`` is 1."""
    first = args[0] if len(args) >= 2 else 1.0
    middle = args[1] if len(args) == 3 else 0.0
    taken = {1: (args[-1],), 2: (first, args[-1]), 3: (first, middle, args[-1])}
    return taken[FUNCTIONS[fname][1]]  # (each function's one number of arguments)


def _pwr(a: float, b: float) -> float:
    return _power(a, b)


def _power(a: float, b: float) -> float:
    """numparam's power, ``|a|^b`` (``(-2)**3 = 8``, ``(-2)**0.5 = 1.414``)."""
    return float(abs(a) ** b)


def _sgn(a: float) -> float:
    return float((a > 0.0) - (a < 0.0))


# name -> (function, minimum and maximum number of arguments; None = any number): as a B
# source takes them; numparam takes one to three for each (numparam_arguments)
FUNCTIONS: dict[str, tuple[Callable[..., float], int, int | None]] = {
    "sqrt": (math.sqrt, 1, 1),
    "exp": (math.exp, 1, 1),
    "log": (math.log, 1, 1),  # natural logarithm, as in ngspice
    "ln": (math.log, 1, 1),
    "log10": (math.log10, 1, 1),
    "sin": (math.sin, 1, 1),
    "cos": (math.cos, 1, 1),
    "tan": (math.tan, 1, 1),
    "asin": (math.asin, 1, 1),
    "acos": (math.acos, 1, 1),
    "atan": (math.atan, 1, 1),
    "sinh": (math.sinh, 1, 1),
    "cosh": (math.cosh, 1, 1),
    "tanh": (math.tanh, 1, 1),
    "abs": (abs, 1, 1),
    "floor": (math.floor, 1, 1),
    "ceil": (math.ceil, 1, 1),
    "min": (min, 2, 2),
    "max": (max, 2, 2),
    "pow": (math.pow, 2, 2),
    # numparam's pwr is |a|^b (pwr(-2, 3) = 8 in ngspice 39); a B source's is sign(a)|a|^b
    "pwr": (_pwr, 2, 2),
    "sqr": (lambda a: a * a, 1, 1),
    "arctan": (math.atan, 1, 1),
    "int": (math.trunc, 1, 1),
    # nearest integer, halves to even (nint(2.5) = 2 in ngspice 39), as Python's round
    "nint": (round, 1, 1),
    "sgn": (_sgn, 1, 1),
    "asinh": (math.asinh, 1, 1),
    "acosh": (math.acosh, 1, 1),
    "atanh": (math.atanh, 1, 1),
    "ternary_fcn": (lambda c, a, b: a if c != 0.0 else b, 3, 3),
}
# the constants of B-source expressions, pi and Euler's number e, which a B source reads even
# beside a .param or subcircuit parameter of the name (ngspice 39, measured); numparam has
# none (ngspice 39: "Undefined parameter [pi]"), so a .param or {...} expression refuses them
# unless a .param defines them
CONSTANTS = {"pi": math.pi, "e": math.e}

# Functions that mean the user wants a behavioural (nonlinear) source.
_BEHAVIOURAL = {"v", "i", "time", "temper", "ddt", "idt", "u", "uramp", "table", "if"}


class ExpressionError(Exception):
    """A problem in one expression.

    Attributes
    ----------
    message, hint : str
        One-line message and advice.
    offset : int
        0-based character offset in the expression text where the problem is.
    """

    def __init__(self, message: str, offset: int = 0, hint: str = ""):
        super().__init__(message)
        self.message = message
        self.offset = offset
        self.hint = hint


@dataclass(frozen=True)
class Expression:
    """A parsed expression.

    Attributes
    ----------
    text : str
        The expression as written (without braces or quotes).
    tree : tuple
        ``("num", value)``, ``("var", name, offset)``, ``("neg", a)``,
        ``(op, a, b, offset)`` with op in ``+ - * / % ** && || == != < > <= >=``,
        ``("?", c, a, b, offset)`` or ``("call", name, args, offset)``.
    names : frozenset of str
        Lower-case parameter names used.
    """

    text: str
    tree: tuple
    names: frozenset[str]

    @property
    def constant(self) -> bool:
        return not self.names

    def evaluate(self, env: Mapping[str, float]) -> float:
        """The value with parameters taken from ``env`` (lower-case names).

        Raises
        ------
        ExpressionError
            Unknown parameter, division by zero, math domain error, overflow.
        """
        try:
            value = _eval(self.tree, env)
        except RecursionError:
            raise ExpressionError(_TOO_DEEP, 0) from None
        if not math.isfinite(value):
            raise ExpressionError(f"expression '{self.text}' evaluates to {value}", 0)
        return value


def _eval(node: tuple, env: Mapping[str, float]) -> float:
    tag = node[0]
    if tag == "num":
        return node[1]
    if tag == "var":
        name = node[1]
        if name in env:
            return env[name]
        if name in CONSTANTS:  # (B sources know pi and e; numparam does not)
            raise ExpressionError(
                f"unknown parameter '{name}': ngspice 39's .param and {{...}} expressions have "
                f"no constant {name} (there: \"Undefined parameter [{name}]\")", node[2],
                f"define it, .param {name}={CONSTANTS[name]!r}; a B source knows {name}")
        raise ExpressionError(f"unknown parameter '{name}'", node[2],
                              "define it with .param NAME=VALUE")
    if tag == "neg":
        return -_eval(node[1], env)
    if tag == "?":
        return _eval(node[2] if _eval(node[1], env) != 0.0 else node[3], env)
    if tag in _LOGIC:
        a = _eval(node[1], env) != 0.0
        if tag == "&&":
            return float(a and _eval(node[2], env) != 0.0)
        return float(a or _eval(node[2], env) != 0.0)
    if tag in _COMPARE:
        return float(_COMPARE[tag](_eval(node[1], env), _eval(node[2], env)))
    if tag == "call":
        fn, _, _ = FUNCTIONS[node[1]]
        args = numparam_arguments(node[1], [_eval(a, env) for a in node[2]])
        try:
            return float(fn(*args))
        except (ValueError, OverflowError, ZeroDivisionError) as exc:
            shown = ", ".join(f"{a:g}" for a in args)
            raise ExpressionError(f"cannot evaluate {node[1]}({shown}): {exc}", node[3]) from None
    a = _eval(node[1], env)
    b = _eval(node[2], env)
    try:
        if tag == "+":
            return a + b
        if tag == "-":
            return a - b
        if tag == "*":
            return a * b
        if tag == "/":
            return a / b
        if tag == "%":
            # numparam's remainder: a - b*trunc(a/b), the sign of a
            return a - b * math.trunc(a / b)
        return _power(a, b)
    except ZeroDivisionError:
        if tag == "/":
            msg = "division by zero"
        elif tag == "%":
            msg = f"{a:g} % 0: the remainder of a division by zero"
        else:
            msg = f"cannot raise 0 to the negative power {b:g}"
        raise ExpressionError(msg, node[3]) from None
    except OverflowError:
        raise ExpressionError(f"overflow in {a:g} {tag} {b:g}", node[3]) from None


_TOO_DEEP = "expression is nested too deeply"

_BINARY = {"add": "+", "sub": "-", "mul": "*", "div": "/", "mod": "%", "pow": "**"}
_LOGIC = {"&&", "||"}
_COMPARE: dict[str, Callable[[float, float], bool]] = {
    "==": lambda a, b: a == b, "!=": lambda a, b: a != b, "<": lambda a, b: a < b,
    ">": lambda a, b: a > b, "<=": lambda a, b: a <= b, ">=": lambda a, b: a >= b}


def _number(tok: Token) -> float | None:
    """A NUMBER token's value: a SPICE number, or a hexadecimal one (``0x10``, ``0x1.8``,
    then a suffix: ``0x10k``), as numparam reads it with C's strtod."""
    if tok[:2] not in ("0x", "0X"):
        return parse_number(tok)
    end = 2
    while end < len(tok) and (tok[end] in "0123456789abcdefABCDEF."):
        end += 1
    try:
        return float.fromhex(tok[:end]) * suffix_scale(tok[end:])[1]
    except ValueError:  # 0x without digits: ngspice stops, "Number format error"
        return None


def _build(t: Tree | Token, names: set[str], leading: bool = True) -> tuple:
    """The tuple tree of ``t``. ``leading``: ``t`` starts an expression, a parenthesis or a
    function's argument (not right after an operator), where numparam reads a minus before
    a power as applied to the power."""
    if isinstance(t, Token):  # a parenthesised sub-expression collapses to its token
        raise AssertionError(t)
    data = t.data
    if data == "paren":
        return _build(t.children[0], names)
    if data == "number":
        tok = t.children[0]
        value = _number(tok)
        if value is None:  # letters then digits, e.g. 1k2
            raise ExpressionError(f"invalid number '{tok}'", tok.start_pos,
                                  "a number is digits, an optional exponent, then letters")
        return ("num", value)
    if data == "var":
        tok = t.children[0]
        name = tok.lower()
        # (pi too: numparam has no such constant, a .param pi=... defines it, measured;
        # B sources know the constants pi and e, CONSTANTS)
        names.add(name)
        return ("var", name, tok.start_pos)
    if data == "neg":
        child = t.children[0]
        if isinstance(child, Tree) and child.data == "pow" and not leading:
            at = _first_offset(t)
            raise ExpressionError(
                "ngspice reads a minus written after an operator as the sign of the number "
                "it precedes, before the power (2*-3^2 is 2*9 = 18 there, -3^2 alone is -9)",
                at, "write the parentheses you mean: 2*(-3^2) or 2*(-3)^2")
        sub = _build(child, names, leading=False)
        if sub[0] == "num":
            return ("num", -sub[1])
        return ("neg", sub)
    if data == "call":
        tok = t.children[0]
        fname = tok.lower()
        args = [_build(c, names) for c in t.children[1:]]
        if fname not in FUNCTIONS:
            if fname in _BEHAVIOURAL:
                hint = ("node voltages, currents and time in expressions make a behavioural "
                        "source: pelcs needs linear E/G/F/H sources and ideal switches")
            else:
                hint = "known functions: " + ", ".join(sorted(FUNCTIONS))
            raise ExpressionError(f"unknown function '{tok}'", tok.start_pos, hint)
        if not 1 <= len(args) <= 3:
            # (ngspice 39 stops at a fourth: "Syntax error: letter [,]")
            raise ExpressionError(
                f"{fname}() takes 1 to 3 arguments in a parameter expression, got {len(args)}",
                tok.start_pos, "numparam reads a call's first, middle and last arguments")
        return ("call", fname, tuple(args), tok.start_pos)
    if data == "ternary":
        c, a, b = t.children
        return ("?", _build(c, names, leading), _build(a, names, False),
                _build(b, names, False), _first_offset(c))
    if data in ("logic_or", "logic_and"):
        left, right = t.children
        return ("||" if data == "logic_or" else "&&", _build(left, names, leading),
                _build(right, names, False), _first_offset(right))
    if data == "compare":
        left, op, right = t.children
        return (str(op), _build(left, names, leading), _build(right, names, False),
                op.start_pos)
    if data in _BINARY:
        if data == "pow":
            left, op, right = t.children
            offset = op.start_pos
        else:
            left, right = t.children
            offset = _first_offset(right)
        return (_BINARY[data], _build(left, names, leading), _build(right, names, False),
                offset)
    # the "+" unary rule is inlined by lark and leaves only its operand
    raise AssertionError(f"unexpected expression node {data}")


def _first_offset(t: Tree | Token) -> int:
    while isinstance(t, Tree):
        t = t.children[0]
    return t.start_pos


def _syntax_error(text: str, exc: UnexpectedInput) -> ExpressionError:
    if isinstance(exc, UnexpectedEOF) or (
        isinstance(exc, UnexpectedToken) and exc.token.type == "$END"
    ):
        return ExpressionError(f"incomplete expression '{text}'", len(text),
                               "an operand or a closing parenthesis is missing")
    if isinstance(exc, UnexpectedToken):
        return ExpressionError(f"unexpected '{exc.token}' in expression '{text}'",
                               exc.token.start_pos)
    if isinstance(exc, UnexpectedCharacters):
        return ExpressionError(f"unexpected character {text[exc.pos_in_stream]!r} in "
                               f"expression '{text}'", exc.pos_in_stream)
    return ExpressionError(f"cannot parse expression '{text}'", 0)


@lru_cache(maxsize=4096)
def parse_expression(text: str) -> Expression:
    """Parse an expression (without its braces or quotes).

    Parameters
    ----------
    text : str
        E.g. ``"1/(2*pi*fs)"`` or ``"duty*ts-10n"``.

    Raises
    ------
    ExpressionError
        With the offset of the problem in ``text``.
    """
    if not text.strip():
        raise ExpressionError("empty expression", 0, "write a value or a parameter name")
    try:
        tree = lark_parser().parse(text, start="expression")
    except UnexpectedInput as exc:
        raise _syntax_error(text, exc) from None
    names: set[str] = set()
    if isinstance(tree, Token):  # never: the expression rule always wraps tokens
        raise AssertionError(tree)
    try:
        built = _build(tree, names)
    except RecursionError:
        raise ExpressionError(_TOO_DEEP, 0, "split it into several .param lines") from None
    return Expression(text, built, frozenset(names))
