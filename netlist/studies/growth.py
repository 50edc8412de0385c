"""A note when a run's recorded signals grew without bound: the ideal model of a non-passive
or unstable circuit is followed as it is (its growth is its true solution), and the result
says so. Read from the held rows (:func:`state_growth`) or, for a run written to its file as
it went, from what :class:`GrowthWatch` kept of the rows on their way.
"""

from __future__ import annotations

import math

import numpy as np

from lcs.results import SimulationResult

__all__ = ["GROWTH_LIMIT", "GrowthWatch", "state_growth"]

#: growth of the recorded signals over a run beyond which the summary says so
GROWTH_LIMIT = 1e6


def state_growth(result: SimulationResult) -> str | None:
    """A note when the recorded signals grew by more than :data:`GROWTH_LIMIT` over the run.

    The reference is the largest magnitude in the first tenth of the run (the start alone
    is often zero); the end is the last point. None when the growth is below the limit.
    """
    y = np.asarray(result.y, dtype=float)
    t = np.asarray(result.t, dtype=float)
    if y.ndim != 2 or y.shape[0] < 3 or not y.shape[1]:
        return None
    first = _first_tenth(t, float(t[0]), float(t[-1]))
    return _growth_note(float(np.abs(y[:first]).max()), y[-1], result.names)


def _first_tenth(t: np.ndarray, t0: float, t_last: float) -> int:
    """How many of the increasing instants ``t`` (s) lie in the first tenth of
    ``[t0, t_last]``: the first one at least."""
    return max(1, int(t.searchsorted(t0 + 0.1 * (t_last - t0), side="right")))


class GrowthWatch:
    """A row stream (:class:`lcs.simulation.driver.RowStream`) passed through, keeping what
    :func:`state_growth` reads of the rows that are not held: the largest magnitude up to
    each row of the first tenth of the run, and the number of rows.

    The first tenth is that of the rows the run made (up to its last row), as
    :func:`state_growth` reads it: a run that fails or is interrupted ends before
    ``t_stop``, and its reference is then over an earlier stretch. So the running largest
    magnitude is kept where it grows (a staircase of instants and values) over the rows
    within the first tenth of ``[t0, t_stop]`` (the longest the reference can span), and
    read at the end at the run's own first tenth.
    """

    def __init__(self, stream, t_stop: float):
        self.stream = stream
        self.t_stop = float(t_stop)
        self.rows = 0
        self.t0 = np.nan
        self._peak = -np.inf  # (the largest magnitude so far, over the rows kept below)
        self._t: list[np.ndarray] = []  # (where it grew: the row's instant, s)
        self._m: list[np.ndarray] = []  # (and its value then)

    def open(self, names: tuple[str, ...]) -> None:
        self.stream.open(names)

    def write(self, t: np.ndarray, y: np.ndarray) -> None:
        if not self.rows and t.size:
            self.t0 = float(t[0])
        if t.size and y.shape[1]:
            # (the rows up to the end of the first tenth of the asked run, with a margin
            # for round-off on the last instant)
            end = self.t0 + 0.1 * (self.t_stop - self.t0) * (1 + 1e-6)
            n = int(t.searchsorted(end, side="right"))
            if not self.rows:
                n = max(1, n)
            if n:
                m = np.maximum.accumulate(
                    np.concatenate(([self._peak], np.abs(y[:n]).max(axis=1))))
                grew = np.flatnonzero(m[1:] != m[:-1])  # (NaN included: it propagates)
                if not self.rows:
                    # (the first row is the reference at least; np.union1d would import
                    # numpy.ma, which the smallest command does without)
                    grew = np.concatenate(([0], grew[grew > 0]))
                if grew.size:
                    self._t.append(np.array(t[:n][grew], dtype=float))
                    self._m.append(m[1:][grew])
                self._peak = m[-1]
        self.rows += t.size
        self.stream.write(t, y)

    def reference(self, t_last: float) -> float:
        """The largest magnitude over the rows in the first tenth of ``[t0, t_last]`` (the
        first row at least), as :func:`state_growth` takes it."""
        if not self._t:
            return 0.0
        t = np.concatenate(self._t)
        m = np.concatenate(self._m)
        return float(m[_first_tenth(t, self.t0, t_last) - 1])

    def note(self, result: SimulationResult) -> str | None:
        """:func:`state_growth` of the streamed run (its last row is ``result``'s)."""
        y = np.asarray(result.y, dtype=float)
        if self.rows < 3 or y.ndim != 2 or not len(y) or not y.shape[1]:
            return None
        return _growth_note(self.reference(float(result.t[-1])), y[-1], result.names)


def _growth_note(ref: float, last: np.ndarray, names) -> str | None:
    """The note of :func:`state_growth`: ``ref`` the reference magnitude, ``last`` the last
    row (shape (q,))."""
    y_last = np.asarray(last, dtype=float)
    end = float(np.abs(y_last).max())
    if not math.isfinite(end):
        return "the recorded signals became non-finite during the run"
    if ref <= 0.0 or end <= GROWTH_LIMIT * ref:
        return None
    k = int(np.argmax(np.abs(y_last)))
    return (f"the state grew by a factor of {end / ref:.3g} over the run ({names[k]} "
            f"= {y_last[k]:.4g} at the end, largest magnitude {ref:.4g} in the first tenth): "
            "an unstable or non-passive circuit?")
