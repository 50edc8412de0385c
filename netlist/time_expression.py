"""A B source whose expression is a smooth function of ``time`` alone (``V = 5*sin(2*pi*50*time)``,
``I = 1k*time``): the independent source of that waveform (:class:`TimeExpression`).

ngspice evaluates a B source's expression at each of its time points; a function of time alone
is then an independent source of that waveform, which pelcs evaluates the same way, at its own
steps. Smooth means arithmetic (``+ - * /``, ``**`` and ``^``, ``pow``, ``pwr``) and the smooth
functions (``sin``, ``cos``, ``exp``, ``sqrt`` ...) of time, parameters and numbers: a comparison,
``u()``, ``abs``, ``min``, ``max`` or a condition has instants where the waveform jumps or
kinks, which no step would land on (an expression that steps between constants is the PWL
source of :mod:`netlist.time_value`). The arithmetic is that of ngspice's B sources
(:mod:`netlist.behavioural_expr`: ``a ** b`` is ``|a|^b``, ``pwr`` keeps the sign, ``pi`` is
the constant even beside a ``.param pi``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from .behavioural_expr import BehaviouralError, Tree
from .expressions import CONSTANTS
from .units import format_number

__all__ = ["TimeExpression", "time_expression"]

# the smooth functions of a B source, as numpy's: name -> (function, number of arguments)
_SMOOTH = {
    "sin": (np.sin, 1), "cos": (np.cos, 1), "tan": (np.tan, 1), "exp": (np.exp, 1),
    "sqrt": (np.sqrt, 1), "ln": (np.log, 1), "log": (np.log, 1), "log10": (np.log10, 1),
    "sinh": (np.sinh, 1), "cosh": (np.cosh, 1), "tanh": (np.tanh, 1), "atan": (np.arctan, 1),
    "asin": (np.arcsin, 1), "acos": (np.arccos, 1), "asinh": (np.arcsinh, 1),
    "acosh": (np.arccosh, 1), "atanh": (np.arctanh, 1),
    "pow": (lambda a, b: np.abs(a) ** b, 2),
    "pwr": (lambda a, b: np.sign(a) * np.abs(a) ** b, 2),
}
_ARITH = ("neg", "+", "-", "*", "/", "**")
_PERIODIC = ("sin", "cos")
_WHY = ("pelcs reads a B source of time alone as the source of its waveform when the "
        "expression is smooth in time: numbers, parameters, + - * / ** and "
        + ", ".join(sorted(_SMOOTH)) + "; one that steps between constants (V = time > 1m ? "
        "5 : 0) is read as a PWL source")


def _check(t: Tree, text: str, env: Mapping[str, float]) -> None:
    """Raise :class:`BehaviouralError` at the first part of ``t`` that is not smooth in time
    or names an unknown parameter."""
    if t.tag == "num":
        return
    if t.tag == "var":
        name = t.args[0]
        if name == "time" or name in CONSTANTS or name in env:
            return
        raise BehaviouralError(f"unknown parameter '{name}'", t.start,
                               "define it with .param NAME=VALUE")
    if t.tag == "call" and t.args[0] in _SMOOTH:
        if len(t.args) - 1 != _SMOOTH[t.args[0]][1]:
            raise BehaviouralError(f"{t.args[0]}() takes {_SMOOTH[t.args[0]][1]} argument(s)",
                                   t.start)
    elif t.tag not in _ARITH:
        part = text[t.start:t.end].strip()
        raise BehaviouralError(f"'{part}' in a B expression of time is not smooth in time: "
                               "its instants of jump or kink are not known to a run", t.start,
                               _WHY)
    for a in t.args:
        if isinstance(a, Tree):
            _check(a, text, env)


def _eval(t: Tree, time: np.ndarray, env: Mapping[str, float]):
    tag, args = t.tag, t.args
    if tag == "num":
        return args[0]
    if tag == "var":
        name = args[0]
        if name == "time":
            return time
        return CONSTANTS[name] if name in CONSTANTS else env[name]
    if tag == "call":
        fn = _SMOOTH[args[0]][0]
        return fn(*(_eval(a, time, env) for a in args[1:]))
    if tag == "neg":
        return -_eval(args[0], time, env)
    a, b = _eval(args[0], time, env), _eval(args[1], time, env)
    if tag == "+":
        return a + b
    if tag == "-":
        return a - b
    if tag == "*":
        return a * b
    if tag == "/":
        return a / b
    return np.abs(a) ** b


def _spice(t: Tree, env: Mapping[str, float]) -> str:
    """The expression with the parameters' values written in (the writer's B line)."""
    tag, args = t.tag, t.args
    if tag == "num":
        return format_number(args[0])
    if tag == "var":
        return args[0] if args[0] == "time" or args[0] in CONSTANTS else format_number(
            env[args[0]])
    if tag == "call":
        return f"{args[0]}({', '.join(_spice(a, env) for a in args[1:])})"
    if tag == "neg":
        return f"(-{_spice(args[0], env)})"
    return f"({_spice(args[0], env)} {tag} {_spice(args[1], env)})"


@dataclass(frozen=True)
class TimeExpression:
    """The waveform of a B source's smooth expression of ``time`` (V or A).

    Attributes
    ----------
    text : str
        The expression as written (after ``V=`` or ``I=``).
    tree : Tree
        Its parse (:func:`netlist.behavioural_expr.parse_behavioural`, ``.func`` calls
        expanded).
    env : tuple of (str, float)
        The parameters it reads and their values (picklable, for the workers of a sweep).
    """

    text: str
    tree: Tree
    env: tuple[tuple[str, float], ...]

    piecewise_linear = False
    keyword = "B"  # (how a note names the source)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        with np.errstate(all="ignore"):
            value = _eval(self.tree, t, dict(self.env))
        return np.broadcast_to(np.asarray(value, dtype=float), t.shape).copy()

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        return np.empty(0)

    def top_frequency(self) -> float | None:
        """The highest frequency of its ``sin``/``cos`` of an affine function of time, Hz
        (None when it has none)."""
        env, top = dict(self.env), None
        stack = [self.tree]
        while stack:
            t = stack.pop()
            stack.extend(a for a in t.args if isinstance(a, Tree))
            if t.tag == "call" and t.args[0] in _PERIODIC:
                # affine in time: its values at 0, 1, 2 s fall on a line (slope: 2π f)
                with np.errstate(all="ignore"):
                    y = np.broadcast_to(_eval(t.args[1], np.array([0.0, 1.0, 2.0]), env), 3)
                slope = y[1] - y[0]
                if np.all(np.isfinite(y)) and abs(y[2] - 2 * y[1] + y[0]) <= 1e-9 * abs(slope):
                    f = abs(slope) / (2 * math.pi)
                    top = f if top is None else max(top, f)
        return top or None

    def spice(self) -> str:
        """The expression for a B line, with the parameters' values written in."""
        return _spice(self.tree, dict(self.env))

    def describe(self) -> str:
        """For ``pelcs info``."""
        return f"B source of time: {self.text.strip()}"


def time_expression(tree: Tree, text: str, env: Mapping[str, float]) -> TimeExpression:
    """The waveform of a B expression of ``time`` alone.

    Raises
    ------
    BehaviouralError
        A part of it that is not smooth in time (a comparison, ``u()``, ``abs``, a
        condition...), an unknown parameter, or a value at t = 0 that is not a finite number.
    """
    _check(tree, text, env)
    names = {t.args[0] for t in tree.walk() if t.tag == "var"} - {"time", *CONSTANTS}
    sig = TimeExpression(text, tree, tuple(sorted((n, float(env[n])) for n in names)))
    v0 = float(sig(0.0))
    if not math.isfinite(v0):
        raise BehaviouralError(f"'{text.strip()}' is {v0} at time 0", 0,
                               "a B source's value must be a finite number at every instant")
    return sig
