"""The sources of a run: evaluation on time arrays, tabulation, breakpoints.

Every integrator evaluates the inputs ``u(t)`` (one callable per independent source, a
:mod:`lcs.signals` waveform or any vectorised function) through these functions, and lands on
their breakpoints (PULSE edges, PWL corners), where a waveform is not smooth. A callable is
evaluated pointwise: it is called on consecutive slices of a time array
(:data:`ROW_BLOCK` instants at a time), and its value at an instant must not depend on the
other instants of the array.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from ..arrays import unique_sorted
from ..signals import Dc, Pulse

InputFunction = Callable[[np.ndarray], np.ndarray]

# Two boundaries closer than this fraction of h are merged (they differ by round-off).
MERGE_FRACTION = 1e-9
# A remainder step shorter than this fraction of h is merged into the previous step.
SNAP_FRACTION = 0.01


def _jumps(f) -> bool:
    """Whether a waveform can jump (a PWL with two points at one time, a PULSE whose edges
    outlast its period): it is then evaluated with one-sided limits at the step ends."""
    return bool(getattr(f, "jumps", False))


def evaluate_inputs(inputs: Sequence[InputFunction], t: np.ndarray, side: int = 0) -> np.ndarray:
    """Inputs on a time array.

    Parameters
    ----------
    inputs : sequence of callables
        ``inputs[j](t)`` evaluates input j on an array of times (a :mod:`lcs.signals` waveform
        or any vectorised function).
    t : ndarray, shape (N,)
        Times, s.
    side : int
        0: plain evaluation; +1 / -1: right / left limits (differs only at the jumps of PWL
        waveforms and of PULSE waveforms whose edges outlast their period; the other
        waveforms are continuous once resolved).

    Returns
    -------
    ndarray, shape (N, p)
    """
    t = np.asarray(t, dtype=float)

    def column(j: int, tb: np.ndarray):
        f = inputs[j]
        if type(f) is Dc:
            return f.value  # (broadcast: what its call gives, without the array)
        if type(f) is Pulse and tb.shape == (1,) and math.isfinite(tb[0]):
            return f.value_at(float(tb[0]), side if side != 0 and f.jumps else 0)
        if side != 0 and _jumps(f):
            return f(tb, side)
        return f(tb)  # (a value or the block's values: _by_row_blocks broadcasts it)

    return _by_row_blocks(t, len(inputs), column)


#: breakpoints of a source past which it is called, not tabulated (:class:`InputTable`)
MAX_TABLE = 4_000_000

#: rows of an (N, p) array of inputs computed at a time (see :func:`_by_row_blocks`)
ROW_BLOCK = 4096


def _by_row_blocks(t: np.ndarray, p: int, column: Callable[[int, np.ndarray], np.ndarray]
                   ) -> np.ndarray:
    """The (N, p) array whose column j is ``column(j, t)`` (broadcast: a constant input may
    give one value), computed :data:`ROW_BLOCK` rows at
    a time: each input's values go into a row of a (p, block) buffer, and the block is
    transposed into place. Writing a column of the C-ordered result directly strides p
    entries per value (a cache line each): 130 inputs over 46,081 instants took 0.10-0.17 s
    that way, 0.06-0.08 s by blocks. An array of at most :data:`ROW_BLOCK` values is written
    by columns (a run's few instants, evaluated several times each run)."""
    out = np.empty((t.size, p))
    if p == 0 or t.size == 0:
        return out
    if t.size * p <= ROW_BLOCK:
        for j in range(p):
            out[:, j] = column(j, t)
        return out
    buf = np.empty((p, min(ROW_BLOCK, t.size)))
    for a in range(0, t.size, ROW_BLOCK):
        tb = t[a:a + ROW_BLOCK]
        n = tb.size
        for j in range(p):
            buf[j, :n] = column(j, tb)
        out[a:a + n] = buf[:, :n].T
    return out


class InputTable:
    """Fast evaluation of the inputs over one run: a piecewise-linear source without jumps (DC,
    PULSE, PWL) is tabulated at its breakpoints (its corners, and a PULSE's period starts) in
    ``[t0, t1]`` once and evaluated by linear interpolation (exact: it is linear between
    breakpoints); other sources are called.

    Parameters
    ----------
    inputs : sequence of callables
    t0, t1 : float
        Run interval, s.
    """

    def __init__(self, inputs: Sequence[InputFunction], t0: float, t1: float):
        self.inputs = list(inputs)
        self.tables: list = []
        for f in self.inputs:
            table = None
            bp = getattr(f, "breakpoints", None)
            if type(f) is Dc and t0 < t1:
                # (what the general case gives a DC source: its value at both ends)
                table = (np.array([t0, t1], dtype=float),
                         np.array([f.value, f.value], dtype=float))
            elif type(f) is Pulse and t0 < t1 and not f.jumps:
                # (its breakpoints are sorted and distinct already: those inside, and the
                # ends)
                pts = f.breakpoints(t0, t1)
                pts = np.concatenate((
                    [t0], pts[pts.searchsorted(t0, "right"):pts.searchsorted(t1, "left")],
                    [t1]))
                if len(pts) <= MAX_TABLE:
                    table = (pts, np.asarray(f(pts), dtype=float).ravel())
            elif getattr(f, "piecewise_linear", False) and bp is not None and not _jumps(f):
                pts = np.asarray(bp(t0, t1), dtype=float).ravel()
                pts = unique_sorted(np.concatenate(([t0, t1], pts[(pts > t0) & (pts < t1)])))
                if len(pts) <= MAX_TABLE:
                    table = (pts, np.asarray(f(pts), dtype=float).ravel())
            self.tables.append(table)
        self.jumps = has_jumps(self.inputs)
        # Every input linear between breakpoints (DC, PULSE, PWL): linear interpolation
        # inside a step is exact.
        self.piecewise_linear = all(getattr(f, "piecewise_linear", False) for f in self.inputs)

    def __call__(self, t: np.ndarray, side: int = 0) -> np.ndarray:
        """Inputs at the times ``t`` (s), shape (N, p); ``side`` as in
        :func:`evaluate_inputs`."""
        t = np.asarray(t, dtype=float)

        def column(j: int, tb: np.ndarray):
            table = self.tables[j]
            if table is not None:
                if len(table[0]) == 2 and table[1][0] == table[1][1]:
                    return table[1][0]
                return np.interp(tb, table[0], table[1])
            f = self.inputs[j]
            if side != 0 and _jumps(f):
                return f(tb, side)
            return np.broadcast_to(np.asarray(f(tb), dtype=float), tb.shape)

        return _by_row_blocks(t, len(self.inputs), column)


def has_jumps(inputs: Sequence[InputFunction]) -> bool:
    """Whether some input can jump (a PWL with two points at the same time, a PULSE whose
    edges outlast its period)."""
    return any(_jumps(f) for f in inputs)


def collect_breakpoints(inputs: Sequence[InputFunction], t0: float, t1: float,
                        extra: Sequence[float] = ()) -> np.ndarray:
    """Sorted source breakpoints (and ``extra`` instants) strictly inside ``(t0, t1)``, s."""
    pts = [np.asarray(extra, dtype=float).ravel()]
    for f in inputs:
        bp = getattr(f, "breakpoints", None)
        if bp is not None and type(f) is not Dc:  # (a DC source has none)
            pts.append(np.asarray(bp(t0, t1), dtype=float).ravel())
    allp = unique_sorted(np.concatenate(pts))
    # (sorted, NaN last: the instants strictly inside are a slice)
    return allp[allp.searchsorted(t0, "right"):allp.searchsorted(t1, "left")]


def merge_close(times: np.ndarray, tol: float) -> np.ndarray:
    """Drop entries closer than ``tol`` to their predecessor (times sorted)."""
    if times.size < 2:
        return times
    keep = np.empty(times.size, dtype=bool)
    keep[0] = True
    np.greater(times[1:] - times[:-1], tol, out=keep[1:])
    return times[keep]

