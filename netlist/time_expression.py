"""A B source whose expression is a function of ``time`` alone (``V = 5*sin(2*pi*50*time)``,
``V = time/10u - floor(time/10u)``, ``V = sin(2*pi*50*time) > 0.5 ? 5 : 0``): the independent
source of that waveform (:class:`TimeExpression`).

ngspice evaluates a B source's expression at each of its time points; a function of time alone
is then an independent source of that waveform, which pelcs evaluates the same way, at its own
steps. The expression may read numbers, parameters, arithmetic (``+ - * /``, ``**`` and ``^``,
``pow``, ``pwr``), the smooth functions (``sin``, ``cos``, ``exp``, ``sqrt`` ...), and the
piecewise ones: ``floor``, ``ceil``, ``nint`` (jumps where the argument crosses an integer, a
half-integer), ``sgn``, ``u`` (jumps at 0), ``abs``, ``uramp``, ``u2``, ``min``, ``max`` (kinks),
comparisons, ``&&``, ``||``, ``!`` and ``? :``. The instants where the waveform jumps or kinks
are its breakpoints (:meth:`TimeExpression.breakpoints`), found where each piecewise node's
argument crosses its levels: in closed form where the argument is affine in time between the
breakpoints of the nodes under it (a sawtooth ``time/T - floor(time/T)`` compared with a
constant), by bisection to round-off between samples elsewhere (a sine compared with that
sawtooth). A run steps to each, and takes the waveform's one-sided limits there.

ngspice puts no breakpoint at those instants: a jump lands inside the step that straddles it,
and its step control shortens the steps around it. Both converge to the waveform's own
instants; pelcs lands on them. The arithmetic is that of ngspice's B sources
(:mod:`netlist.behavioural_expr`: ``a ** b`` is ``|a|^b``, ``pwr`` keeps the sign, ``pi`` and
``e`` are the constants even beside a ``.param`` of the name; ``u(0)`` is 0.5, ``nint``
rounds half to even, as C's ``nearbyint``). An expression that only steps between constants
(``V = time > 1m ? 5 : 0``) is the PWL source of :mod:`netlist.time_value`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from .behavioural_expr import BehaviouralError, Tree, spice_text
from .errors import Diagnostic, Location, NetlistError
from .expressions import CONSTANTS
from .units import format_number

__all__ = ["MAX_BREAKPOINTS", "TimeExpression", "time_expression"]


def _step(x):
    return np.where(x > 0, 1.0, np.where(x < 0, 0.0, 0.5))


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
# the piecewise functions: name -> (function, number of arguments, levels, jumps), the levels
# being those its argument (or the difference of its two) crosses at a breakpoint: "zero",
# "int" (the integers), "half" (the half-integers), "unit" (0 and 1)
_PIECEWISE = {
    "floor": (np.floor, 1, "int", True), "ceil": (np.ceil, 1, "int", True),
    "nint": (np.rint, 1, "half", True), "sgn": (np.sign, 1, "zero", True),
    "u": (_step, 1, "zero", True), "abs": (np.abs, 1, "zero", False),
    "uramp": (lambda x: np.maximum(x, 0.0), 1, "zero", False),
    "u2": (lambda x: np.clip(x, 0.0, 1.0), 1, "unit", False),
    "min": (np.minimum, 2, "zero", False), "max": (np.maximum, 2, "zero", False),
}
_ARITH = ("neg", "+", "-", "*", "/", "**")
_COMPARE = {"<": np.less, ">": np.greater, "<=": np.less_equal, ">=": np.greater_equal,
            "==": np.equal, "!=": np.not_equal}
_LOGIC = ("&&", "||", "not", "?")
_PERIODIC = ("sin", "cos")
_WHY = ("pelcs reads a B source of time alone as the source of its waveform: numbers, "
        "parameters, + - * / ** and " + ", ".join(sorted({*_SMOOTH, *_PIECEWISE}))
        + ", comparisons, &&, ||, ! and ? :")

#: the most breakpoints a waveform may have in a run (a 100 kHz sawtooth over 10 s)
MAX_BREAKPOINTS = 2_000_000


def _check(t: Tree, text: str, env: Mapping[str, float]) -> None:
    """Raise :class:`BehaviouralError` at the first part of ``t`` pelcs cannot evaluate as a
    function of time, or that names an unknown parameter."""
    if t.tag == "num":
        return
    if t.tag == "var":
        name = t.args[0]
        if name == "time" or name in CONSTANTS or name in env:
            return
        raise BehaviouralError(f"unknown parameter '{name}'", t.start,
                               "define it with .param NAME=VALUE")
    if t.tag == "call" and t.args[0] in (*_SMOOTH, *_PIECEWISE):
        want = (_SMOOTH[t.args[0]][1] if t.args[0] in _SMOOTH else _PIECEWISE[t.args[0]][1])
        if len(t.args) - 1 != want:
            raise BehaviouralError(f"{t.args[0]}() takes {want} argument(s)", t.start)
    elif t.tag == "call" and t.args[0] == "limit" and len(t.args) == 4:
        # (LTspice's clamp, common in decks written for LTspice; ngspice 39's B sources have
        # no such function, so a run there is not the waveform the author meant)
        raise BehaviouralError("LTspice's limit(x, lo, hi) is not a function of ngspice's B "
                               "sources", t.start, "write the clamp max(lo, min(hi, x)), "
                               "which pelcs evaluates as a function of time")
    elif t.tag not in (*_ARITH, *_COMPARE, *_LOGIC):
        part = text[t.start:t.end].strip()
        raise BehaviouralError(f"'{part}' in a B expression of time is not a function pelcs "
                               "evaluates", t.start, _WHY)
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
        fn = _SMOOTH[args[0]][0] if args[0] in _SMOOTH else _PIECEWISE[args[0]][0]
        return fn(*(_eval(a, time, env) for a in args[1:]))
    if tag == "neg":
        return -_eval(args[0], time, env)
    if tag == "not":
        return np.where(_eval(args[0], time, env) == 0, 1.0, 0.0)
    if tag == "?":
        return np.where(_eval(args[0], time, env) != 0, _eval(args[1], time, env),
                        _eval(args[2], time, env))
    a, b = _eval(args[0], time, env), _eval(args[1], time, env)
    if tag in _COMPARE:
        return np.where(_COMPARE[tag](a, b), 1.0, 0.0)
    if tag == "&&":
        return np.where((np.asarray(a) != 0) & (np.asarray(b) != 0), 1.0, 0.0)
    if tag == "||":
        return np.where((np.asarray(a) != 0) | (np.asarray(b) != 0), 1.0, 0.0)
    if tag == "+":
        return a + b
    if tag == "-":
        return a - b
    if tag == "*":
        return a * b
    if tag == "/":
        return a / b
    return np.abs(a) ** b


# ------------------------------------------------------------------------------ breakpoints

def _crossing_function(t: Tree) -> tuple[list[Tree], str] | None:
    """The sub-trees whose difference (or the one sub-tree) a piecewise node's breakpoints
    are the level crossings of, and the levels; None for a node that has none of its own."""
    if t.tag == "call" and t.args[0] in _PIECEWISE:
        return list(t.args[1:]), _PIECEWISE[t.args[0]][2]
    if t.tag in _COMPARE:
        return list(t.args), "zero"
    if t.tag == "?" and not _boolean(t.args[0]):
        return [t.args[0]], "zero"
    return None


def _boolean(t: Tree) -> bool:
    """A comparison or a logical operation: 0 or 1, turning only at its own breakpoints."""
    return t.tag in _COMPARE or t.tag in ("&&", "||", "not")


def _level_index(g: np.ndarray, levels: str) -> np.ndarray:
    """Which band between consecutive levels each value lies in (a level itself: a band of
    its own, so that touching it counts)."""
    if levels == "int":
        return 2 * np.floor(g) + (g != np.floor(g))
    if levels == "half":
        return 2 * np.floor(g + 0.5) + (g + 0.5 != np.floor(g + 0.5))
    if levels == "unit":
        return np.sign(g) + np.sign(g - 1.0)
    return np.sign(g)


def _affine_crossings(a: np.ndarray, d: np.ndarray, ga: np.ndarray, slope: np.ndarray,
                      levels: str) -> np.ndarray:
    """The instants where ``ga + slope (t - a)`` crosses its levels inside each interval
    ``(a, a + d)`` (vectorised over the intervals)."""
    gb = ga + slope * d
    lo, hi = np.minimum(ga, gb), np.maximum(ga, gb)
    if levels in ("zero", "unit"):
        cand = np.array([0.0] if levels == "zero" else [0.0, 1.0])
        idx = np.repeat(np.arange(a.size), cand.size)
        lv = np.tile(cand, a.size)
    else:
        shift = 0.5 if levels == "half" else 0.0
        with np.errstate(invalid="ignore"):
            first = np.floor(lo + shift) + 1
            count = np.maximum(0.0, np.ceil(hi + shift) - 1 - first + 1)
        if count.sum() > MAX_BREAKPOINTS:
            raise _TooMany
        count = count.astype(np.int64)
        idx = np.repeat(np.arange(a.size), count)
        offs = np.arange(idx.size) - np.repeat(np.cumsum(count) - count, count)
        lv = first[idx] + offs - shift
    keep = (lv > lo[idx]) & (lv < hi[idx]) & (slope[idx] != 0)
    idx, lv = idx[keep], lv[keep]
    tk = a[idx] + (lv - ga[idx]) / slope[idx]
    tol = 1e-7 * d[idx]
    return tk[(tk > a[idx] + tol) & (tk < a[idx] + d[idx] - tol)]


class _TooMany(Exception):
    """Over :data:`MAX_BREAKPOINTS` instants (or what the message says)."""


#: the most samples the instants of one piecewise node are looked for with
_MAX_SAMPLES = 64 * MAX_BREAKPOINTS


def _bisect(fn: Callable[[np.ndarray], np.ndarray], left: np.ndarray, right: np.ndarray,
            levels: str) -> np.ndarray:
    """The instants in each ``[left, right]`` where the level band of ``fn`` first changes
    from the one at ``left`` (vectorised bisection to round-off)."""
    band = _level_index(fn(left), levels)
    for _ in range(80):
        mid = 0.5 * (left + right)
        moved = (mid <= left) | (mid >= right)
        if moved.all():
            break
        same = _level_index(fn(mid), levels) == band
        left = np.where(same & ~moved, mid, left)
        right = np.where(~same & ~moved, mid, right)
    return 0.5 * (left + right)


#: the most samples :func:`_crossings` holds at once (its intervals are taken in batches)
_BATCH = 1_000_000


def _crossings(fn: Callable[[np.ndarray], np.ndarray], edges: np.ndarray, levels: str,
               top_frequency: float) -> np.ndarray:
    """The instants inside the intervals between consecutive ``edges`` (sorted) where ``fn``,
    smooth inside each, crosses its levels."""
    a, b = edges[:-1], edges[1:]
    d = b - a
    keep = d > 0
    a, b, d = a[keep], b[keep], d[keep]
    if a.size == 0:
        return np.empty(0)
    # an interval longer than 4096 samples of its sines' period: in pieces of that length,
    # each reaching a hair into the next (a crossing at a piece's end is its neighbour's,
    # found twice at most: breakpoints keeps it once)
    pieces = np.maximum(1.0, np.ceil(32 * d * top_frequency / 4096))
    if pieces.max() > 1:
        if 4096 * pieces.sum() > _MAX_SAMPLES:
            raise _TooMany(
                f"its sines' periods and floor/ceil/nint levels number "
                f"{top_frequency * d.sum():.3g}, over {MAX_BREAKPOINTS:,}, too many to look for "
                "the instants where it jumps or kinks")
        pieces = pieces.astype(np.int64)
        idx = np.repeat(np.arange(a.size), pieces)
        k = np.arange(idx.size) - np.repeat(np.cumsum(pieces) - pieces, pieces)
        length = d[idx] / pieces[idx]
        first, last = k == 0, k == pieces[idx] - 1
        a, b = (np.where(first, a[idx], a[idx] + k * length - 2e-7 * length),
                np.where(last, b[idx], a[idx] + (k + 1) * length + 2e-7 * length))
        d = b - a
    # samples inside each interval: enough to see every oscillation of its sines
    # (and at least 1024 over the run: a function with no sine may still turn several times)
    n = int(min(4096, max(4, math.ceil(1024 / a.size),
                          math.ceil(32 * float(d.max()) * top_frequency))))
    # (the intervals in batches: a long run's samples at once would fill memory; what is
    # bounded is the number of instants found)
    per = max(1, _BATCH // (n + 2))
    out, count = [], 0
    for i in range(0, a.size, per):
        found = _batch_crossings(fn, a[i:i + per], b[i:i + per], d[i:i + per], n, levels)
        count += found.size
        if count > MAX_BREAKPOINTS:
            raise _TooMany
        out.append(found)
    return np.concatenate(out)


def _excursions(fn: Callable[[np.ndarray], np.ndarray], ts: np.ndarray, g: np.ndarray,
                band: np.ndarray, levels: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Brackets of the crossings of a narrow excursion between samples (a sine's peak just
    over a level, 4.5 us of each 1 ms period for 0.9999): at each sampled extremum whose
    neighbours lie in its band, the extremum itself (golden-section search), and where it
    lies in another band, the two brackets either side of it: (rows, lefts, rights)."""
    dg = np.diff(g, axis=1)
    # (rising then not: a maximum at the middle sample or just past it, where two samples
    # either side of a peak are equal; falling then not, a minimum)
    turn = (((dg[:, :-1] > 0) & (dg[:, 1:] <= 0)) | ((dg[:, :-1] < 0) & (dg[:, 1:] >= 0))) & (
        band[:, 1:-1] == band[:, :-2]) & (band[:, 1:-1] == band[:, 2:])
    r, c = np.nonzero(turn)
    c = c + 1
    if r.size == 0:
        return r, np.empty(0), np.empty(0)
    lo, hi = ts[r, c - 1].copy(), ts[r, c + 1].copy()
    sign = np.where(dg[r, c - 1] > 0, 1.0, -1.0)  # (+1: a maximum)
    w = 0.5 * (math.sqrt(5.0) - 1.0)

    def f(x):
        return sign * np.broadcast_to(np.asarray(fn(x), dtype=float), x.shape)

    for _ in range(200):
        m1, m2 = hi - w * (hi - lo), lo + w * (hi - lo)
        live = (m1 > lo) & (m2 < hi) & (m1 < m2)
        if not live.any():
            break
        up = f(m1) < f(m2)  # (the extremum in [m1, hi])
        lo = np.where(live & up, m1, lo)
        hi = np.where(live & ~up, m2, hi)
    tx = 0.5 * (lo + hi)
    other = _level_index(np.broadcast_to(np.asarray(fn(tx), dtype=float), tx.shape),
                         levels) != band[r, c]
    r, c, tx = r[other], c[other], tx[other]
    return (np.concatenate([r, r]), np.concatenate([ts[r, c - 1], tx]),
            np.concatenate([tx, ts[r, c + 1]]))


def _batch_crossings(fn: Callable[[np.ndarray], np.ndarray], a: np.ndarray, b: np.ndarray,
                     d: np.ndarray, n: int, levels: str) -> np.ndarray:
    """:func:`_crossings` in the intervals ``(a, b)``, ``n`` samples inside each."""
    # (the first and last a hair inside: the one-sided limits at the ends)
    frac = np.concatenate(([1e-7], (np.arange(n) + 0.5) / n, [1 - 1e-7]))
    ts = a[:, None] + d[:, None] * frac[None, :]
    with np.errstate(all="ignore"):
        g = np.broadcast_to(np.asarray(fn(ts), dtype=float), ts.shape)
    # (a crossing nearer an end than this is that end's: a round-off echo of the jump there)
    tol = 1e-7 * d
    out = []
    # affine intervals: the crossings of each level in closed form
    # (every sample on the line through the first and the last: a sine over whole periods
    # has three on a line)
    line = g[:, :1] + (g[:, -1:] - g[:, :1]) * ((frac - frac[0]) / (frac[-1] - frac[0]))
    scale = np.maximum(np.abs(g[:, 0]), np.abs(g[:, -1])) + np.abs(g[:, -1] - g[:, 0])
    affine = np.isfinite(g).all(axis=1) & (np.abs(g - line).max(axis=1) <= 1e-9 * scale)
    rows = np.flatnonzero(affine)
    if rows.size:
        slope = (g[rows, -1] - g[rows, 0]) / (d[rows] * (frac[-1] - frac[0]))
        ga = g[rows, 0] - slope * frac[0] * d[rows]
        out.append(_affine_crossings(a[rows], d[rows], ga, slope, levels))
    # the others: where the band changes between consecutive samples, and where an
    # excursion between two samples reaches another band, refined by bisection
    rows = np.flatnonzero(~affine)
    if rows.size:
        band = _level_index(g[rows], levels)
        r, c = np.nonzero(band[:, 1:] != band[:, :-1])
        left, right = ts[rows[r], c], ts[rows[r], c + 1]
        with np.errstate(all="ignore"):
            er, el, en = _excursions(fn, ts[rows], g[rows], band, levels)
        r, left, right = (np.concatenate([r, er]), np.concatenate([left, el]),
                          np.concatenate([right, en]))
        # (a bracket crossing several levels: one at a time; a staircase of exp(time) crosses
        # hundreds between two samples)
        for _ in range(1024):
            if left.size == 0:
                break
            found = _bisect(fn, left.copy(), right.copy(), levels)
            inside = (found > a[rows[r]] + tol[rows[r]]) & (found < b[rows[r]] - tol[rows[r]])
            out.append(found[inside])
            # past the crossing: brackets whose far end is in yet another band
            after = np.minimum(right, found + 1e-12 * np.maximum(np.abs(found), d[rows[r]]))
            more = (_level_index(fn(after), levels) != _level_index(fn(right), levels)) & (
                after < right)
            left, right, r = after[more], right[more], r[more]
    return np.concatenate(out) if out else np.empty(0)


def _breakpoints(t: Tree, env: Mapping[str, float], t0: float, t1: float) -> np.ndarray:
    """Sorted breakpoints of the sub-tree ``t`` strictly inside ``(t0, t1)``."""
    subs = [a for a in t.args if isinstance(a, Tree)]
    under = {id(a): _breakpoints(a, env, t0, t1) for a in subs}
    pts = np.unique(np.concatenate(list(under.values()))) if under else np.empty(0)
    own = _crossing_function(t)
    if own is None:
        return pts
    args, levels = own
    if len(args) == 1:
        def fn(time, s=args[0]):
            return _eval(s, time, env)
    else:
        def fn(time, s=args):
            return _eval(s[0], time, env) - _eval(s[1], time, env)
    # the argument is smooth between its own breakpoints
    edges = np.unique(np.concatenate([[t0, t1], *(under[id(a)] for a in args)]))
    # (sampled as its own argument turns: the sines and levels under it, not the whole
    # expression's, whose 1 MHz sine would make u(time - 1m) a million samples a second)
    freq = max([_local_frequency(a, env, t0, t1) for a in args]
               + [f for a in args for n in a.walk() if (f := _frequency(n, env)) is not None])
    found = _crossings(fn, edges, levels, freq)
    return np.unique(np.concatenate([pts, found[(found > t0) & (found < t1)]]))


def _degree(t: Tree) -> int:
    """0: constant (or piecewise constant in time), 1: piecewise affine in time, 2: other."""
    tag, args = t.tag, t.args
    if tag == "num":
        return 0
    if tag == "var":
        return 1 if args[0] == "time" else 0
    subs = [_degree(a) for a in args if isinstance(a, Tree)]
    if tag in _COMPARE or tag in ("&&", "||", "not"):
        return 0
    if tag == "call":
        name = args[0]
        if name in ("floor", "ceil", "nint", "sgn", "u"):
            return 0
        if name in _PIECEWISE:
            return max(subs)
        return 0 if max(subs) == 0 else 2
    if tag == "?":
        return max(subs[1:])
    if tag in ("neg", "+", "-"):
        return max(subs)
    if tag == "*":
        return min(2, subs[0] + subs[1])
    if tag == "/":
        return subs[0] if subs[1] == 0 else 2
    return 0 if max(subs) == 0 else 2  # **


def _jumps(t: Tree) -> bool:
    return any(n.tag in _COMPARE or n.tag in ("&&", "||", "not", "?")
               or (n.tag == "call" and n.args[0] in _PIECEWISE and _PIECEWISE[n.args[0]][3])
               for n in t.walk())


def _spice(t: Tree, env: Mapping[str, float]) -> str:
    """The expression with the parameters' values written in (the writer's B line)."""

    def leaf(x: Tree) -> str:
        if x.tag == "num":
            return format_number(x.args[0])
        name = x.args[0]
        return name if name == "time" or name in CONSTANTS else format_number(env[name])

    return spice_text(t, leaf)


def _frequency(t: Tree, env: Mapping[str, float]) -> float | None:
    """The frequency (Hz) of a ``sin``/``cos`` of an affine function of time (its slope / 2π),
    or of a ``floor``/``ceil``/``nint`` of one (its slope: a level a period), else None."""
    if t.tag != "call" or t.args[0] not in (*_PERIODIC, "floor", "ceil", "nint"):
        return None
    # affine in time: its values at 0, 1, 2 s fall on a line
    with np.errstate(all="ignore"):
        y = np.broadcast_to(_eval(t.args[1], np.array([0.0, 1.0, 2.0]), env), 3)
    slope = y[1] - y[0]
    if not (np.all(np.isfinite(y)) and abs(y[2] - 2 * y[1] + y[0]) <= 1e-9 * abs(slope)):
        return None
    return abs(slope) / (2 * math.pi) if t.args[0] in _PERIODIC else abs(slope)


def _local_frequency(tree: Tree, env: Mapping[str, float], t0: float, t1: float,
                     kinds: tuple[str, ...] = (*_PERIODIC, "floor", "ceil", "nint")) -> float:
    """The highest rate (Hz) over ``[t0, t1]`` at which the argument of a ``sin``/``cos``
    turns (its slope / 2π) or that of a ``floor``/``ceil``/``nint`` crosses its levels (its
    slope), from its slopes at 4096 instants: what :func:`_frequency` does not see, an
    argument that is not affine (``sin(2*pi*100k*(time - floor(time/T)*T))``, a chirp). Each
    slope is the smaller of the two one-sided ones: a jump of the argument is not one."""
    nodes = [t for t in tree.walk() if t.tag == "call" and t.args[0] in kinds]
    if not nodes or not t1 > t0:
        return 0.0
    ts = t0 + (t1 - t0) * (np.arange(4096) + 0.5) / 4096
    eps = 1e-7 * (t1 - t0)
    best = 0.0
    for t in nodes:
        def arg(x, s=t.args[1]):
            return np.broadcast_to(np.asarray(_eval(s, x, env), dtype=float), x.shape)
        with np.errstate(all="ignore"):
            g = arg(ts)
            slope = np.minimum(np.abs(arg(ts + eps) - g), np.abs(g - arg(ts - eps))) / eps
        slope = slope[np.isfinite(slope)]
        if slope.size:
            best = max(best, float(slope.max()) / (
                2 * math.pi if t.args[0] in _PERIODIC else 1.0))
    return best


@dataclass(frozen=True)
class TimeExpression:
    """The waveform of a B source's expression of ``time`` (V or A).

    Attributes
    ----------
    text : str
        The expression as written (after ``V=`` or ``I=``).
    tree : Tree
        Its parse (:func:`netlist.behavioural_expr.parse_behavioural`, ``.func`` calls
        expanded).
    env : tuple of (str, float)
        The parameters it reads and their values (picklable, for the workers of a sweep).
    piecewise_linear : bool
        Affine in time between its breakpoints (a sawtooth, a PWM of constants): what the
        exact method needs, and what makes interpolation inside a step exact.
    jumps : bool
        It can jump at a breakpoint (``floor``, a comparison ...): evaluated there with its
        one-sided limits.
    """

    text: str
    tree: Tree
    env: tuple[tuple[str, float], ...]
    piecewise_linear: bool = False
    jumps: bool = False
    _memo: dict = field(default_factory=dict, compare=False, repr=False)
    location: Location | None = field(default=None, compare=False, repr=False)

    keyword = "B"  # (how a note names the source)

    def __call__(self, t, side: int = 0):
        """The value at the times ``t`` (s); ``side`` -1 or +1: the limit from before or after
        (at a jump)."""
        t = np.asarray(t, dtype=float)
        if side and self.jumps:
            # (a breakpoint's instant is exact to round-off: a relative 1e-12 past it is on
            # the piece beyond, and as near as a run can tell)
            t = t + side * 1e-12 * np.maximum(np.abs(t), 1e-300)
        with np.errstate(all="ignore"):
            value = _eval(self.tree, t, dict(self.env))
        return np.broadcast_to(np.asarray(value, dtype=float), t.shape).copy()

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """The instants strictly inside ``(t0, t1)`` where it jumps or kinks, sorted, s.

        Raises
        ------
        NetlistError
            Over :data:`MAX_BREAKPOINTS` of them.
        """
        key = (float(t0), float(t1))
        if key not in self._memo:
            try:
                pts = _breakpoints(self.tree, dict(self.env), key[0], key[1])
            except _TooMany as exc:
                why = str(exc) or (f"over {MAX_BREAKPOINTS:,} instants where it jumps or "
                                   "kinks")
                raise NetlistError(Diagnostic(
                    f"B source of time '{self.text.strip()}': {why} in {t1 - t0:g} s",
                    location=self.location,
                    hint="a shorter run (--tstop) or a slower waveform: a run steps to each "
                         "instant"), self.location.file if self.location else None) from None
            if pts.size > 1:  # (one instant found twice, apart by round-off)
                keep = np.concatenate(([True], np.diff(pts) > 1e-12 * np.maximum(
                    np.abs(pts[1:]), key[1] - key[0])))
                pts = pts[keep]
            self._memo.clear()
            self._memo[key] = pts
        return self._memo[key]

    def top_frequency(self) -> float | None:
        """The highest frequency (Hz) of its ``sin``/``cos`` of an affine function of time,
        and of its ``floor``/``ceil``/``nint`` of one (a sawtooth's), None when it has none."""
        env = dict(self.env)
        found = [f for t in self.tree.walk() if (f := _frequency(t, env)) is not None]
        return max(found) if found and max(found) > 0 else None

    def run_frequency(self, t0: float, t1: float) -> float:
        """:meth:`top_frequency`, and the slopes over ``[t0, t1]`` of its sines' arguments
        that are not affine (:func:`_local_frequency`), Hz (0 when it has none): what the
        step resolves (a staircase of ``floor`` needs no step of its own: its instants are
        steps' ends)."""
        return max(self.top_frequency() or 0.0,
                   _local_frequency(self.tree, dict(self.env), t0, t1, _PERIODIC))

    def spice(self) -> str:
        """The expression for a B line, with the parameters' values written in."""
        return _spice(self.tree, dict(self.env))

    def describe(self) -> str:
        """For ``pelcs info``."""
        return f"B source of time: {self.text.strip()}"


def time_expression(tree: Tree, text: str, env: Mapping[str, float],
                    location: Location | None = None) -> TimeExpression:
    """The waveform of a B expression of ``time`` alone.

    Raises
    ------
    BehaviouralError
        A part of it pelcs does not evaluate (a function outside the module's list), an
        unknown parameter, or a value at t = 0 that is not a finite number.
    """
    _check(tree, text, env)
    names = {t.args[0] for t in tree.walk() if t.tag == "var"} - {"time", *CONSTANTS}
    sig = TimeExpression(text, tree, tuple(sorted((n, float(env[n])) for n in names)),
                         piecewise_linear=_degree(tree) <= 1, jumps=_jumps(tree),
                         location=location)
    v0 = float(sig(0.0, side=1))
    if not math.isfinite(v0):
        raise BehaviouralError(f"'{text.strip()}' is {v0} at time 0", 0,
                               "a B source's value must be a finite number at every instant")
    return sig
