"""What a run saves: the probe rows and the event records, in buffers that integrators write
(compiled kernels write them directly) and that grow on demand.

A run written on a regular output grid hands its rows to a :class:`~.regrid.Regrid` whenever
the buffer is full, instead of growing it: the buffer then holds a block of rows, and the
run's memory is its output grid's, whatever the number of steps. The event records are kept
whole (24 bytes and a key word or more each).

Event records are ``(t, switch key after it, info)``; ``info`` is the switch index of a
comparator switching (-1 for a known switching), plus ``EV_SLIDE_START`` or ``EV_SLIDE_END``
for the start and end of a sliding mode.
"""

from __future__ import annotations

import numpy as np

from ..bits import from_words
from ..model import ModeKey
from .codes import EV_SLIDE_END, EV_SLIDE_START, EV_SWITCH  # noqa: F401  (kernel codes)
from .problem import key_of, mode_tuple
from .regrid import Regrid


def grown(a: np.ndarray, n: int) -> np.ndarray:
    """``a`` copied into a new array of ``n`` rows."""
    new = np.empty((n, *a.shape[1:]), dtype=a.dtype)
    new[: len(a)] = a
    return new


class Recorder:
    """Output and event buffers of one run.

    Parameters
    ----------
    names : tuple of str
        Probe names (columns of ``Y``).
    rows, events : int
        Initial capacities.
    duty : ndarray of int64, shape (r,)
        Per probe, the switch of a ``d(S)`` probe, -1 otherwise.
    sink : Regrid, optional
        Where the rows go when the buffer is full (all but the last one, which stays); the
        buffer then holds at most about ``block`` rows beyond what one kernel call asks for
        (:meth:`room`).
    block : int
        Rows of the buffer with a sink.

    Attributes
    ----------
    T, Y : ndarray, shapes (cap,), (cap, r)
        Times (s) and probes; rows ``< pos`` are valid.
    ev_t, ev_info : ndarray, shape (cap_e,)
    ev_key : ndarray, shape (cap_e, key_words)
        Event records (the switch keys as bitsets, :mod:`lcs.bits`); entries ``< evpos`` are
        valid.
    stored : int
        Rows stored in all (those handed to the sink included).
    peak_rows : int
        The most rows held at once: the buffer's capacity, plus the rows the sink held.
    """

    def __init__(self, names: tuple[str, ...], rows: int, events: int, duty: np.ndarray,
                 key_words: int = 1, sink: Regrid | None = None, block: int = 1 << 14):
        self.names = tuple(names)
        self.T = np.empty(rows)
        self.Y = np.empty((rows, len(self.names)))
        self.ev_t = np.empty(events)
        self.ev_key = np.empty((events, key_words), np.int64)
        self.ev_info = np.empty(events, np.int64)
        self.duty = np.ascontiguousarray(duty, dtype=np.int64)
        self.pos = 0
        self.evpos = 0
        self.sink = sink
        self.block = int(block)
        self.handed = 0  # rows handed to the sink
        self.peak_rows = rows

    @property
    def stored(self) -> int:
        return self.handed + self.pos

    def reserve(self, rows: int, events: int) -> None:
        """Room for ``rows`` more probe rows and ``events`` more event records (with a sink,
        for at most ``block`` rows: an integrator writes until the buffer is full and asks
        again)."""
        if self.sink is not None:
            rows = min(rows, self.block)
            if self.pos + rows > len(self.T):
                self._drain()
        self._grow(rows, events)

    def room(self, rows: int) -> None:
        """With a sink, room for ``rows`` more probe rows (those one kernel call may write,
        so that it is not cut short: a call resumed after ``STEP_FULL`` may differ at
        round-off, the sparse kernel's carried products being computed afresh); without one,
        nothing (the buffer was reserved for the whole run)."""
        if self.sink is not None:
            if self.pos + rows > len(self.T):
                self._drain()
            self._grow(rows, 0)

    def _drain(self) -> None:
        """The rows but the last handed to the sink; the last one stays (the run's last
        time, and the row the next ones follow)."""
        n = self.pos - 1
        if n <= 0:
            return
        self.sink.take(self.T[:n], self.Y[:n])
        self.peak_rows = max(self.peak_rows, len(self.T) + self.sink.held())
        self.T[0] = self.T[n]
        self.Y[0] = self.Y[n]
        self.pos = 1
        self.handed += n

    def _grow(self, rows: int, events: int) -> None:
        if self.pos + rows > len(self.T):
            # (doubled for a run that keeps its rows; with a sink, what is asked)
            self.T = grown(self.T, self.pos + rows if self.sink is not None
                           else 2 * len(self.T) + rows)
            self.Y = grown(self.Y, len(self.T))
            self.peak_rows = max(self.peak_rows, len(self.T))
        need = self.evpos + events
        if need > len(self.ev_t):
            new = 2 * len(self.ev_t) + need
            self.ev_t, self.ev_key, self.ev_info = (grown(a, new) for a in (
                self.ev_t, self.ev_key, self.ev_info))

    def append(self, t: float, y: np.ndarray) -> None:
        """One probe row."""
        if self.pos >= len(self.T):
            if self.sink is not None:
                self._drain()
            self._grow(1, 0)
        self.T[self.pos] = t
        self.Y[self.pos] = y
        self.pos += 1

    def last_time(self) -> float:
        return float(self.T[self.pos - 1])

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The saved times and probes (with a sink: its output grid, the rest of the rows
        handed to it). The buffers were sized for the whole run: they are sliced (a copy of a
        large run costs as much as the stepping) unless the run stopped early and most of
        them is unused."""
        if self.sink is not None:
            self.sink.take(self.T[:self.pos], self.Y[:self.pos])
            self.peak_rows = max(self.peak_rows, len(self.T) + self.sink.held())
            self.handed += self.pos
            self.pos = 0
            return self.sink.finish()
        t_res, y_res = self.T[:self.pos], self.Y[:self.pos]
        if 2 * self.pos < len(self.T):
            t_res, y_res = t_res.copy(), y_res.copy()
        return t_res, y_res

    def events(self, switch_names, mode0: ModeKey, t_last: float):
        """Mode changes ``[(t, mode)]``, sliding intervals ``[(switch, t_start, t_end)]`` and
        the modes in order of first use, up to ``t_last``."""
        k = len(switch_names)
        count = self.evpos
        t = self.ev_t[:count]
        rows = self.ev_key[:count]
        info = self.ev_info[:count]
        if count and not t.max() <= t_last:  # (a run that stopped early; or a NaN)
            keep = t <= t_last
            t, rows, info = t[keep], rows[keep], info[keep]
        if k <= 63:
            keys = rows[:, 0]  # (one word, no sign bit: the integers themselves)
        else:
            keys = np.array([from_words(r) for r in rows], dtype=object)
        # (the events that change the key: the first against the initial mode's)
        change = np.empty(len(keys), dtype=bool)
        if len(keys):
            change[0] = keys[0] != key_of(mode0)
            np.not_equal(keys[1:], keys[:-1], out=change[1:])
        ct = t[change].tolist()
        ck = keys[change].tolist()
        # (one tuple per mode, shared by its events; ct and ck are of one length)
        tuples: dict[int, ModeKey] = {kk: mode_tuple(kk, k) for kk in dict.fromkeys(ck)}
        events = list(zip(ct, map(tuples.__getitem__, ck), strict=False))
        visited = [tuple(mode0)]
        for md in tuples.values():
            if md not in visited:
                visited.append(md)
        sliding = []
        open_slide: dict[int, float] = {}
        slides = (info >= EV_SLIDE_START).nonzero()[0].tolist() if info.size and \
            info.max() >= EV_SLIDE_START else ()
        for e in slides:
            i, tt = int(info[e]), float(t[e])
            if i >= EV_SLIDE_END:
                sw = i - EV_SLIDE_END
                sliding.append((switch_names[sw], open_slide.pop(sw, tt), tt))
            else:
                open_slide[i - EV_SLIDE_START] = tt
        for i, t0 in open_slide.items():
            sliding.append((switch_names[i], t0, None))
        return events, sliding, visited
