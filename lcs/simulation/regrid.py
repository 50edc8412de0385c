"""A run's output grid built as the run goes: the stored rows interpolated onto the instants
``k dt`` block by block, so that a run written on a regular grid holds that grid and not
every step.

:func:`lcs.results.resample` interpolates a whole run at its end; :class:`Regrid` gives the
same numbers, bit for bit, from the rows handed to it in blocks (the recorder's buffer each
time it is full, :class:`~lcs.simulation.recorder.Recorder`), keeping across blocks only the
rows the next output instants lie between:

* an output instant's value depends only on the stored rows around it (the last one at or
  before it and the next, :func:`lcs.results.interpolate`): an instant is interpolated as
  soon as a later row has been stored, on the slice of rows that holds both;
* the last output instant is the run's last time when that is within ``1e-9 dt`` of a
  multiple of ``dt`` (:func:`lcs.results.output_times`): an instant within ``1e-9 dt`` of
  the last row so far waits for the next rows or the end of the run;
* while every stored row so far is an output instant (the step grid is the output grid), the
  rows are kept as they are, since :func:`lcs.results.resample` then returns them unchanged:
  they are as many as the output instants.

Memory: the output rows, a block of rows while it is interpolated, and between blocks the
last row or two. With ``emit`` (a file written as the run goes), the output rows are handed
on as they are made and not held either: the run's memory is then independent of its length
and of its number of output points. :class:`Passthrough` hands on the stored rows themselves
(a run without an output grid: every step, or every N-th).

Streamed rows are those of the held run, bit for bit, with one exception: while every row so
far is an output instant, the rows are handed on as they are (their values are the steps'),
and if a later row then leaves the grid (a comparator's located instant stored between two
steps), the held run interpolates all of its rows onto the instants instead, which moves the
values handed on by at most the change over ``1e-9 dt``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..results import interpolate, output_times, resample_arrays, rows_at

#: Where streamed rows go: ``emit(t, y)`` with times (s, shape (N,)) and rows (shape (N, q)),
#: in order; the arrays may be reused after the call.
Emit = Callable[[np.ndarray, np.ndarray], None]

#: the closeness (in output spacings) at which an instant and a stored time are one
#: (:func:`lcs.results.output_times`)
_CLOSE = 1e-9


def _kept(t: np.ndarray, y: np.ndarray, t_from: float) -> tuple[np.ndarray, np.ndarray]:
    """The rows at or after ``t_from`` (s; ``.tran`` TSTART)."""
    if t_from > -np.inf and t.size and t[0] < t_from:
        keep = t >= t_from
        t, y = t[keep], y[keep]
    return t, y


class Regrid:
    """Stored rows interpolated onto the instants ``k dt`` as they come.

    Parameters
    ----------
    dt : float
        Output spacing, s.
    q : int
        Probes per row.
    t_from : float
        Rows before this time are not kept (``.tran`` TSTART): the grid starts at the first
        kept row, s.
    emit : callable, optional
        Where the output rows go as they are made (:data:`Emit`); :meth:`finish` then
        returns the last one only.

    Attributes
    ----------
    kept : int
        Rows kept (at or after ``t_from``): the points of the run's every step.
    written : int
        Output rows handed to ``emit``.
    """

    def __init__(self, dt: float, q: int, t_from: float = -np.inf, emit: Emit | None = None):
        if not dt > 0:
            raise ValueError(f"output step must be positive, got {dt!r}")
        self.dt = float(dt)
        self.q = int(q)
        self.t_from = float(t_from)
        self.kept = 0
        self.t_first = np.nan
        self.k0 = 0
        self.next_k = 0  # the next instant to interpolate (k of k dt)
        # While the rows are the output grid: every row (as many as the instants); then only
        # the rows from the one at or before the next instant on.
        self.on_grid = True
        self.rows_t: list[np.ndarray] = []
        self.rows_y: list[np.ndarray] = []
        self.out_t: list[np.ndarray] = []
        self.out_y: list[np.ndarray] = []
        self.emit = emit
        self.written = 0
        self._last: tuple[np.ndarray, np.ndarray] | None = None

    def held(self) -> int:
        """Rows held between blocks (not yet past every instant they serve)."""
        return sum(len(a) for a in self.rows_t)

    def take(self, t: np.ndarray, y: np.ndarray) -> None:
        """The next stored rows, in order: times ``t`` (s, shape (N,)), probes ``y`` (shape
        (N, q)). They are copied where kept: the caller may reuse its buffers."""
        t, y = _kept(t, y, self.t_from)
        if t.size == 0:
            return
        if self.kept == 0:
            self.t_first = float(t[0])
            self.k0 = self.next_k = int(np.ceil(self.t_first / self.dt - _CLOSE))
        before = self.kept
        self.kept += t.size
        self.rows_t.append(np.array(t, dtype=float))
        self.rows_y.append(np.array(y, dtype=float))
        if self.on_grid:
            self.on_grid = self._on_grid(before, t)
            if self.on_grid and self.emit is not None:
                self._emit_on_grid()
        if not self.on_grid:
            self._interpolate_ready()

    def _held_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """The rows held, joined."""
        if len(self.rows_t) == 1:
            return self.rows_t[0], self.rows_y[0]
        return np.concatenate(self.rows_t), np.concatenate(self.rows_y)

    def _out(self, tout: np.ndarray, yout: np.ndarray) -> None:
        """Output rows made: held, or handed on (the last one kept for :meth:`finish`)."""
        if self.emit is None:
            self.out_t.append(tout)
            self.out_y.append(yout)
            return
        if tout.size:
            self.emit(tout, yout)
            self.written += tout.size
            self._last = (tout[-1:].copy(), yout[-1:].copy())

    def _emit_on_grid(self) -> None:
        """The rows held but the last, handed on as the output instants they are (the first
        at its own time); the last stays (it may be the run's end, off the grid)."""
        t, y = self._held_rows()
        n = t.size - 1
        if n <= 0:
            return
        tout = np.arange(self.next_k, self.next_k + n, dtype=float) * self.dt
        if self.next_k == self.k0:
            tout[0] = self.t_first
        self._out(tout, y[:n])
        self.next_k += n
        self.rows_t, self.rows_y = [t[n:].copy()], [y[n:].copy()]

    def _on_grid(self, before: int, t: np.ndarray) -> bool:
        """Whether the rows stay within ``1e-9 dt`` of their instants ``(k0 + i) dt``: the
        rows ``before - 1`` (the last of the previous block, now followed by others) to the
        one before the last (the last one may be the run's end, off the grid)."""
        i0 = max(0, before - 1)
        prev = self.rows_t[-2][-1:] if before else np.zeros(0)
        times = np.concatenate((prev, t[:-1]))
        grid = np.arange(self.k0 + i0, self.k0 + i0 + times.size, dtype=float) * self.dt
        return bool(np.all(np.abs(grid - times) <= _CLOSE * self.dt))

    def _interpolate_ready(self) -> None:
        """The instants more than ``1e-9 dt`` before the last row so far, interpolated; the
        rows before the one at or before the next instant dropped."""
        t, y = self._held_rows()
        tl = float(t[-1])
        dt = self.dt
        # An instant more than 1e-9 dt before this row is one the run's last time (this or
        # later) cannot replace (lcs.results.output_times), and a row after it is stored.
        k_end = int(np.floor(tl / dt)) + 1
        ks = np.arange(self.next_k, max(self.next_k, k_end), dtype=float)
        tout = ks * dt
        tout = tout[tl - tout > _CLOSE * dt]
        if tout.size:
            if self.next_k == self.k0 and abs(tout[0] - self.t_first) <= _CLOSE * dt:
                tout[0] = self.t_first
            self._out(tout, interpolate(t, y, tout))
            self.next_k += tout.size
        # the rows from the last one at or before the next instant (its left neighbour)
        t_next = self.next_k * dt
        j = max(0, int(np.searchsorted(t, t_next, side="right")) - 1)
        if self.next_k == self.k0:
            j = 0  # (the first instant may be t_first itself)
        self.rows_t, self.rows_y = [t[j:].copy() if j else t], [y[j:].copy() if j else y]

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        """The output instants (s, shape (N',)) and rows (shape (N', q)) of the whole run,
        the rows taken being all of it; as :func:`lcs.results.resample_arrays` of them. With
        ``emit``, the rest is handed on and the last output row returned."""
        if self.kept == 0:
            return np.zeros(0), np.zeros((0, self.q))
        t, y = self._held_rows()
        self.rows_t, self.rows_y = [], []
        if self.emit is not None:
            rest = output_times(self.t_first, float(t[-1]), self.dt, self.next_k)
            self._out(rest, rows_at(t, y, rest, self.dt) if self.on_grid
                      else interpolate(t, y, rest))
            return self._last
        if self.on_grid:
            return resample_arrays(t, y, self.dt)
        tout = output_times(self.t_first, float(t[-1]), self.dt)
        done = self.next_k - self.k0
        rest = tout[done:]
        self.out_t.append(rest)
        self.out_y.append(interpolate(t, y, rest))
        t_all = np.concatenate(self.out_t)
        y_all = np.concatenate(self.out_y) if len(self.out_y) > 1 else self.out_y[0]
        self.out_t, self.out_y = [], []
        return t_all, y_all


class Passthrough:
    """The stored rows themselves handed on as they come (a run streamed without an output
    grid: every step, or every N-th), those before ``t_from`` (s) dropped; the interface of
    :class:`Regrid`.

    Attributes
    ----------
    kept, written : int
        Rows handed on.
    """

    def __init__(self, emit: Emit, q: int, t_from: float = -np.inf):
        self.emit = emit
        self.q = int(q)
        self.t_from = float(t_from)
        self.kept = self.written = 0
        self._last = (np.zeros(0), np.zeros((0, self.q)))

    def held(self) -> int:
        return 0

    def take(self, t: np.ndarray, y: np.ndarray) -> None:
        t, y = _kept(t, y, self.t_from)
        if t.size:
            self.emit(t, y)
            self.kept += t.size
            self.written += t.size
            self._last = (t[-1:].copy(), y[-1:].copy())

    def finish(self) -> tuple[np.ndarray, np.ndarray]:
        """The last row handed on (shapes (1,), (1, q)), or none."""
        return self._last
