"""Switching patterns: the sequence of switch and diode configurations over an orbit.

:class:`SwitchingPattern` describes one orbit (k periods) as segments of constant switch
modes and conducting diodes; :func:`switching_pattern` extracts it from a run stored every
step. Continuation compares patterns to detect border collisions.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..results import SimulationResult

__all__ = ["PatternSegment", "SwitchingPattern", "conducting", "switching_pattern"]

# A diode conducts when its current exceeds this fraction of the largest current seen in the
# run (plus an absolute floor, A): the Moreau λ of a blocking diode is exactly 0, up to
# round-off.
_DIODE_RTOL = 1e-9
_DIODE_ATOL = 1e-12


@dataclass(frozen=True)
class PatternSegment:
    """An interval of constant switch and diode states within a period.

    Attributes
    ----------
    start, duration : float
        Start (relative to the first sampling instant) and length, s.
    switches : tuple[bool, ...]
        Switch states (True = on) in :attr:`SwitchingPattern.switch_names` order.
    diodes : tuple[bool, ...]
        Diode states (True = conducting) in :attr:`SwitchingPattern.diode_names` order.
    """

    start: float
    duration: float
    switches: tuple[bool, ...]
    diodes: tuple[bool, ...]

    @property
    def state(self) -> tuple[tuple[bool, ...], tuple[bool, ...]]:
        return (self.switches, self.diodes)


@dataclass(frozen=True)
class SwitchingPattern:
    """The sequence of switch/diode configurations over one orbit (k periods).

    Attributes
    ----------
    switch_names, diode_names : tuple[str, ...]
    segments : tuple[PatternSegment, ...]
        In time order from the first sampling instant; consecutive segments differ.
    period : float
        Total duration, s (k T for a period-k orbit).
    """

    switch_names: tuple[str, ...]
    diode_names: tuple[str, ...]
    segments: tuple[PatternSegment, ...]
    period: float

    @property
    def signature(self) -> tuple:
        """The configuration sequence without durations, for comparing orbits.

        The sampling instant is not an event: when the first and last segments have the same
        configuration they are one interval that wraps around, and are counted once.
        """
        states = [s.state for s in self.segments]
        if len(states) > 1 and states[0] == states[-1]:
            states = states[:-1]
        return tuple(states)

    def label(self, seg: PatternSegment) -> str:
        parts = [f"{n} {'on' if on else 'off'}" for n, on in zip(self.switch_names,
                                                                   seg.switches, strict=True)]
        parts += [f"{n} {'on' if on else 'off'}" for n, on in zip(self.diode_names,
                                                                   seg.diodes, strict=True)]
        return ", ".join(parts) if parts else "single mode"

    def __str__(self) -> str:
        if not self.segments:
            return "(empty)"
        return " -> ".join(f"[{self.label(s)}] {s.duration / self.period:.4g}"
                           for s in self.segments) + f" (fractions of {self.period:.6g} s)"

    def to_list(self) -> list[dict]:
        """JSON-ready segments: ``{"start", "duration", "switches": {...}, "diodes": {...}}``."""
        return [{
            "start": float(s.start), "duration": float(s.duration),
            "switches": {n: ("on" if on else "off")
                         for n, on in zip(self.switch_names, s.switches, strict=True)},
            "diodes": {n: ("on" if on else "off")
                       for n, on in zip(self.diode_names, s.diodes, strict=True)},
        } for s in self.segments]



def conducting(currents: np.ndarray) -> np.ndarray:
    """Which diode currents mean conduction: above ``1e-9`` of the largest |current| of the
    run (at least 1 A) plus 1e-12 A.

    Parameters
    ----------
    currents : ndarray, shape (N,) or (N, d)
        Diode currents, A (the Moreau λ of a blocking diode is 0 up to round-off).

    Returns
    -------
    ndarray of bool, same shape
    """
    cur = np.asarray(currents, dtype=float)
    thr = _DIODE_RTOL * max(float(np.max(np.abs(cur))) if cur.size else 0.0, 1.0) + _DIODE_ATOL
    return cur > thr


def switching_pattern(
    res: SimulationResult,
    t_start: float,
    t_end: float,
    *,
    switch_names: Sequence[str],
    diode_names: Sequence[str],
    diode_probes: Sequence[str],
    time_tol: float,
) -> SwitchingPattern:
    """Segments of constant (switch mode, conducting diodes) of a run stored every step.

    Parameters
    ----------
    res : SimulationResult
        A run from ``t_start`` to ``t_end`` stored at every step, with the diode probes.
    t_start, t_end : float
        The span, s.
    switch_names, diode_names : sequence of str
    diode_probes : sequence of str
        One probe per diode, positive while it conducts (``i(D1)``); empty: no diode states.
    time_tol : float
        An event within this time of a step boundary belongs to the next step, s.
    """
    sw_names = tuple(switch_names)
    d_names = tuple(diode_names)
    t = res.t
    nstep = len(t) - 1
    # Switch mode during step j (from t[j] to t[j+1]): the last event strictly before
    # t[j+1] (an event at a step boundary belongs to the next step).
    mode0 = tuple(res.modes_visited[0]) if res.modes_visited else ()
    ev_t = np.array([e[0] for e in res.events], dtype=float)
    ev_modes = [tuple(e[1]) for e in res.events]
    idx = np.searchsorted(ev_t, t[1:] - time_tol, side="left") - 1
    modes = [mode0 if i < 0 else ev_modes[i] for i in idx.tolist()]
    if diode_probes:
        dio = conducting(np.stack([res[p] for p in diode_probes], axis=1)[1:])
    else:
        dio = np.zeros((nstep, 0), dtype=bool)
    segs: list[PatternSegment] = []
    cur_state = None
    seg_start = t_start
    for j in range(nstep):
        state = (modes[j], tuple(bool(v) for v in dio[j]))
        if state != cur_state:
            if cur_state is not None:
                segs.append(PatternSegment(seg_start - t_start, float(t[j]) - seg_start,
                                           *cur_state))
            cur_state = state
            seg_start = float(t[j])
    if cur_state is not None:
        segs.append(PatternSegment(seg_start - t_start, t_end - seg_start, *cur_state))
    return SwitchingPattern(sw_names, d_names, tuple(segs), t_end - t_start)
