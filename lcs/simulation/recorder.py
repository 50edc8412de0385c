"""What a run saves: the probe rows and the event records, in buffers that integrators write
(compiled kernels write them directly) and that grow on demand.

A run written on a regular output grid hands its rows to a :class:`~.regrid.Regrid` whenever
the buffer is full, instead of growing it: the buffer then holds a block of rows, and the
run's memory is its output grid's, whatever the number of steps. The event records are
compacted block by block as the buffer fills: only those that change the switch key (or
start or end a sliding mode) are kept, and the result's events take 12 bytes each
(:class:`~lcs.results.Events`). With ``keep_events`` only the last switchings are kept, and
the earlier ones counted: a run's memory is then independent of its length.

Event records are ``(t, switch key after it, info)``; ``info`` is the switch index of a
comparator switching (-1 for a known switching), plus ``EV_SLIDE_START`` or ``EV_SLIDE_END``
for the start and end of a sliding mode.
"""

from __future__ import annotations

import numpy as np

from ..bits import from_words
from ..model import ModeKey
from ..results import Events
from .codes import EV_SLIDE_END, EV_SLIDE_START, EV_SWITCH  # noqa: F401  (kernel codes)
from .problem import key_of, mode_tuple
from .regrid import Regrid

# Event records the buffer holds before they are compacted (24 bytes and a key word each).
EVENT_BLOCK = 1 << 16


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
    keep_events : int, optional
        Keep only the last ``keep_events`` switchings (at least; up to twice as many are held
        between compactions) and count the earlier ones; None keeps them all.

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
                 key_words: int = 1, sink: Regrid | None = None, block: int = 1 << 14,
                 keep_events: int | None = None):
        if keep_events is not None and keep_events < 1:
            raise ValueError(f"keep_events must be at least 1, got {keep_events!r}")
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
        # (the times of the first row whose probes are not all finite numbers, and of the
        # row before it, once one is seen)
        self.non_finite: tuple[float, float] | None = None
        self._t_before = np.nan
        # Event records drained from the buffer (those that change the key, and sliding
        # records), and the key of the last record drained.
        self._ev_t, self._ev_ix, self._ev_n = np.empty(0), np.empty(0, np.int32), 0
        self._slide_parts: list[tuple[np.ndarray, np.ndarray]] = []
        self._slide_records = 0
        # (with keep_events: the sliding records paired as they come, the last intervals
        # kept: [(switch, t_start, t_end)], and those still open by switch)
        self._slides: list[tuple[int, float, float]] = []
        self._slide_open: dict[int, float] = {}
        self._key_ids: dict[int, int] = {}
        self._last_key: np.ndarray | None = None
        self.keep_events = keep_events
        # Switchings dropped from the front (keep_events), the key ids they entered, and the
        # key id of the very first record (which may only enter the initial mode).
        self._dropped = 0
        self._dropped_ids: set[int] = set()
        self._first_id: int | None = None

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
        ok = self._watch(n)
        self.sink.take(self.T[:ok], self.Y[:ok])
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
        if need > len(self.ev_t) and self.evpos >= EVENT_BLOCK:
            self._drain_events()
            need = events
        if need > len(self.ev_t):
            new = 2 * len(self.ev_t) + need
            self.ev_t, self.ev_key, self.ev_info = (grown(a, new) for a in (
                self.ev_t, self.ev_key, self.ev_info))

    def _drain_events(self) -> None:
        """The buffer's event records compacted: of each, whether it changes the switch key
        from the previous record (the first record ever is compared with the initial mode in
        :meth:`events`), kept as its time and the index of its key among the keys met; the
        records that start or end a sliding mode whole."""
        n = self.evpos
        if n == 0:
            return
        t, key, info = self.ev_t[:n], self.ev_key[:n], self.ev_info[:n]
        change = np.empty(n, np.bool_)
        if key.shape[1] == 1:
            keys = key[:, 0]
            change[0] = self._last_key is None or keys[0] != self._last_key[0]
            np.not_equal(keys[1:], keys[:-1], out=change[1:])
            changed = keys[change]
            if len(changed) <= 256:
                index = np.fromiter(map(self._key_id, changed.tolist()), np.int32,
                                    len(changed))
            else:
                # (a few distinct keys: each looked up once)
                uniq, inverse = np.unique(changed, return_inverse=True)
                ids = np.array([self._key_id(u) for u in uniq.tolist()], np.int32)
                index = ids[inverse]
        else:
            change[0] = self._last_key is None or bool(np.any(key[0] != self._last_key))
            change[1:] = np.any(key[1:] != key[:-1], axis=1)
            index = np.array([self._key_id(from_words(r)) for r in key[change]], np.int32)
        m = len(index)
        if self._first_id is None and m:
            self._first_id = int(index[0])
        if not self._ev_n:
            self._ev_t, self._ev_ix = t[change], index
        else:
            if self._ev_n + m > len(self._ev_t):
                size = max(self._ev_n + m, len(self._ev_t) + len(self._ev_t) // 2)
                self._ev_t, self._ev_ix = grown(self._ev_t, size), grown(self._ev_ix, size)
            self._ev_t[self._ev_n:self._ev_n + m] = t[change]
            self._ev_ix[self._ev_n:self._ev_n + m] = index
        self._ev_n += m
        if self.keep_events is not None and self._ev_n > 2 * self.keep_events:
            self._drop_front(self._ev_n - self.keep_events)
        slide = info >= EV_SLIDE_START
        if slide.any():
            self._slide_parts.append((t[slide].copy(), info[slide].copy()))
            self._slide_records += int(slide.sum())
            if self.keep_events is not None and self._slide_records > 2 * self.keep_events:
                self._pair_slides()
        self._last_key = key[n - 1].copy()
        self.evpos = 0

    def _pair_slides(self) -> None:
        """The sliding records held paired into intervals, of which the last
        ``keep_events`` are kept (a run that keeps its last switchings keeps its last
        sliding intervals)."""
        _pair(self._slide_parts, self._slide_open, self._slides)
        del self._slides[:-self.keep_events]
        self._slide_parts, self._slide_records = [], 0

    def _drop_front(self, n: int) -> None:
        """The first ``n`` compacted switchings dropped (counted, their modes remembered)."""
        self._dropped += n
        self._dropped_ids.update(np.unique(self._ev_ix[:n]).tolist())
        rest = self._ev_n - n
        self._ev_t[:rest] = self._ev_t[n:self._ev_n]
        self._ev_ix[:rest] = self._ev_ix[n:self._ev_n]
        self._ev_n = rest

    def _key_id(self, key: int) -> int:
        """The index of switch key ``key`` among those met (added when new)."""
        j = self._key_ids.get(key)
        if j is None:
            j = self._key_ids[key] = len(self._key_ids)
        return j

    def append(self, t: float, y: np.ndarray) -> None:
        """One probe row."""
        if self.pos >= len(self.T):
            if self.sink is not None:
                self._drain()
            self._grow(1, 0)
        self.T[self.pos] = t
        self.Y[self.pos] = y
        self.pos += 1

    def _watch(self, n: int) -> int:
        """Note the first of the buffer's first ``n`` rows whose probes are not finite;
        returns how many of them come before it (all ``n`` while none is seen, none after
        one was: the run's error stops its results there, streamed ones too)."""
        if self.non_finite is not None:
            return 0
        if n <= 0:
            return n
        bad = ~np.isfinite(self.Y[:n]).all(axis=1)
        if not bad.any():
            self._t_before = float(self.T[n - 1])
            return n
        i = int(np.argmax(bad))
        self.non_finite = (float(self.T[i - 1]) if i else self._t_before, float(self.T[i]))
        return i

    def last_time(self) -> float:
        return float(self.T[self.pos - 1])

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The saved times and probes (with a sink: its output grid, the rest of the rows
        handed to it). The buffers were sized for the whole run: they are sliced (a copy of a
        large run costs as much as the stepping) unless the run stopped early and most of
        them is unused."""
        ok = self._watch(self.pos)
        if self.sink is not None:
            self.sink.take(self.T[:ok], self.Y[:ok])
            self.peak_rows = max(self.peak_rows, len(self.T) + self.sink.held())
            self.handed += self.pos
            self.pos = 0
            return self.sink.finish()
        t_res, y_res = self.T[:self.pos], self.Y[:self.pos]
        if 2 * self.pos < len(self.T):
            t_res, y_res = t_res.copy(), y_res.copy()
        return t_res, y_res

    def events(self, switch_names, mode0: ModeKey, t_last: float):
        """Mode changes (:class:`~lcs.results.Events`), sliding intervals
        ``[(switch, t_start, t_end)]`` and the modes in order of first use, up to ``t_last``
        (the end of the run: the records are drained, the buffer is not written again)."""
        k = len(switch_names)
        self._drain_events()
        t, index = self._ev_t[:self._ev_n], self._ev_ix[:self._ev_n]
        keys = list(self._key_ids)  # (in order of their ids: of first use)
        # (the first record enters the initial mode: not a switching)
        enters_initial = self._first_id is not None and keys[self._first_id] == key_of(mode0)
        earlier = self._dropped
        if self._dropped:
            earlier -= enters_initial
        elif enters_initial:
            t, index = t[1:], index[1:]
        n = int(np.searchsorted(t, t_last, side="right"))
        modes = tuple(mode_tuple(kk, k) for kk in keys)
        if n < len(t):
            # (cut short: the modes of the switchings kept, in order of first use; those of
            # dropped switchings first)
            t, index = t[:n].copy(), index[:n].copy()
            ids, first = np.unique(index, return_index=True)
            order = ids[np.argsort(first, kind="stable")].tolist()
            if self._dropped:
                order = sorted(self._dropped_ids.difference(order)) + order
            used = [modes[j] for j in order]
        else:
            used = list(modes)
        if self.keep_events is not None and len(t) > self.keep_events:
            earlier += len(t) - self.keep_events
            t, index = t[-self.keep_events:].copy(), index[-self.keep_events:].copy()
        events = Events(t, index, modes, earlier)
        visited = [tuple(mode0)]
        for md in used:
            if md not in visited:
                visited.append(md)
        # (intervals paired as they came: those that end after t_last, the end of a run cut
        # short, are still open there, and starts after it did not happen)
        sliding, open_slide = [], {}
        for sw, t0, t1 in self._slides:
            if t1 <= t_last:
                sliding.append((switch_names[sw], t0, t1))
            elif t0 <= t_last:
                open_slide[sw] = t0
        open_slide.update((sw, t0) for sw, t0 in self._slide_open.items() if t0 <= t_last)
        intervals: list[tuple[int, float, float]] = []
        _pair(self._slide_parts, open_slide, intervals, t_last)
        sliding.extend((switch_names[sw], t0, t1) for sw, t0, t1 in intervals)
        for i, t0 in open_slide.items():
            sliding.append((switch_names[i], t0, None))
        if self.keep_events is not None:
            sliding = sliding[-self.keep_events:]
        return events, sliding, visited


def _pair(parts, open_slide: dict[int, float], intervals: list,
          t_last: float = np.inf) -> None:
    """Sliding records ``[(times, infos)]`` up to ``t_last`` (s) paired into ``intervals``
    ``(switch, t_start, t_end)``; the starts not yet ended are left in ``open_slide`` (by
    switch). An end with no start begins where it ends."""
    for st, si in parts:
        for tt, i in zip(st.tolist(), si.tolist(), strict=True):
            if tt > t_last:
                return
            if i >= EV_SLIDE_END:
                sw = i - EV_SLIDE_END
                intervals.append((sw, open_slide.pop(sw, tt), tt))
            else:
                open_slide[i - EV_SLIDE_START] = tt
