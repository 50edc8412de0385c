"""What a run saves: the probe rows and the event records, in buffers that integrators write
(compiled kernels write them directly) and that grow on demand.

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

    Attributes
    ----------
    T, Y : ndarray, shapes (cap,), (cap, r)
        Times (s) and probes; rows ``< pos`` are valid.
    ev_t, ev_info : ndarray, shape (cap_e,)
    ev_key : ndarray, shape (cap_e, key_words)
        Event records (the switch keys as bitsets, :mod:`lcs.bits`); entries ``< evpos`` are
        valid.
    """

    def __init__(self, names: tuple[str, ...], rows: int, events: int, duty: np.ndarray,
                 key_words: int = 1):
        self.names = tuple(names)
        self.T = np.empty(rows)
        self.Y = np.empty((rows, len(self.names)))
        self.ev_t = np.empty(events)
        self.ev_key = np.empty((events, key_words), np.int64)
        self.ev_info = np.empty(events, np.int64)
        self.duty = np.ascontiguousarray(duty, dtype=np.int64)
        self.pos = 0
        self.evpos = 0

    def reserve(self, rows: int, events: int) -> None:
        """Room for ``rows`` more probe rows and ``events`` more event records."""
        if self.pos + rows > len(self.T):
            self.T = grown(self.T, 2 * len(self.T) + rows)
            self.Y = grown(self.Y, len(self.T))
        need = self.evpos + events
        if need > len(self.ev_t):
            new = 2 * len(self.ev_t) + need
            self.ev_t, self.ev_key, self.ev_info = (grown(a, new) for a in (
                self.ev_t, self.ev_key, self.ev_info))

    def append(self, t: float, y: np.ndarray) -> None:
        """One probe row."""
        if self.pos >= len(self.T):
            self.T = grown(self.T, self.pos + 1)
            self.Y = grown(self.Y, self.pos + 1)
        self.T[self.pos] = t
        self.Y[self.pos] = y
        self.pos += 1

    def last_time(self) -> float:
        return float(self.T[self.pos - 1])

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """The saved times and probes. The buffers were sized for the whole run: they are
        sliced (a copy of a large run costs as much as the stepping) unless the run stopped
        early and most of them is unused."""
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
        keep = t <= t_last
        t, rows, info = t[keep], rows[keep], info[keep]
        if k <= 63:
            keys = rows[:, 0]  # (one word, no sign bit: the integers themselves)
        else:
            keys = np.array([from_words(r) for r in rows], dtype=object)
        k0 = key_of(mode0)
        prev = np.concatenate(([k0], keys[:-1])) if len(keys) else keys
        change = keys != prev
        tuples: dict[int, ModeKey] = {}
        ct = t[change].tolist()
        ck = keys[change].tolist()
        events = []
        for tt, kk in zip(ct, ck, strict=True):
            md = tuples.get(kk)
            if md is None:
                md = tuples[kk] = mode_tuple(kk, k)
            events.append((tt, md))
        visited = [tuple(mode0)]
        for kk in dict.fromkeys(ck):
            md = tuples[kk]
            if md not in visited:
                visited.append(md)
        sliding = []
        open_slide: dict[int, float] = {}
        for e in np.flatnonzero(info >= EV_SLIDE_START).tolist():
            i, tt = int(info[e]), float(t[e])
            if i >= EV_SLIDE_END:
                sw = i - EV_SLIDE_END
                sliding.append((switch_names[sw], open_slide.pop(sw, tt), tt))
            else:
                open_slide[i - EV_SLIDE_START] = tt
        for i, t0 in open_slide.items():
            sliding.append((switch_names[i], t0, None))
        return events, sliding, visited
