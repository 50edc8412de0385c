"""The exact event-driven integrator: an :class:`~lcs.simulation.integrator.Integrator` that
plugs into the simulation driver like the Moreau one, but follows the run mode by mode with
exact flows (:class:`~.events.Follower`) instead of taking steps.

Output (dense): the probes at every multiple of the output step ``h`` from the start, at the
``save_at`` instants, and just after every event (a switch or a diode changing state, a clock
of a latched switch, a source corner), each computed from the exact flow of its segment.
Every event is also listed in ``result.event_log`` (:class:`ExactEvent`: time, element,
kind, mode after).

Sources: DC, PULSE, PWL and SIN (an oscillator in the augmented system). The switches
follow their netlist comparators (with hysteresis) and latches; Python controllers are
refused with a named error (use the Moreau integrator); a comparator without hysteresis
slides (:mod:`.sliding`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from ... import interrupt
from ...bits import to_words
from ...results import SimulationError
from ...simulation import failures
from ...simulation.integrator import Integrator, Run, Snapshot, Window
from ...simulation.problem import key_of
from ...simulation.recorder import EV_SLIDE_END, EV_SLIDE_START, EV_SWITCH
from .events import Event, ExactError, Follower, FollowStopped, Segment, one_blas_thread
from .flow import flow_matrix
from .sliding import SlidingSegment

__all__ = ["ExactEvent", "ExactIntegrator"]


@dataclass(frozen=True)
class ExactEvent:
    """One event of an exact run.

    Attributes
    ----------
    t : float
        s.
    element : str
        The switch or diode (``""`` for a source corner).
    kind : str
        ``"switch"`` (a comparator), ``"diode"`` (a diode's w or λ reached zero: it starts
        or stops conducting), ``"clock"`` (a latched switch re-armed) or ``"breakpoint"``.
    mode : dict
        After the event: switch states ``{"S1": "on"}`` and ``"held"``, the diodes held at
        ``w = 0`` (conducting or at the conduction boundary).
    """

    t: float
    element: str
    kind: str
    mode: dict


class ExactIntegrator(Integrator):
    """Exact integration between events; ``h`` is the output step (s), not a time step.

    Parameters
    ----------
    h : float
        Output spacing, s (the probes are stored at every multiple of it).
    save_at : sequence of float
        Further output instants, s.
    log_breakpoints : bool
        List source corners in ``event_log`` too (they change no mode).
    """

    name = "exact"

    def __init__(self, h: float, save_at=(), log_breakpoints: bool = False, jump=None):
        self.h = float(h)
        self.jump = jump
        self.save_at = np.sort(np.asarray(save_at, dtype=float))
        self.log_breakpoints = log_breakpoints
        self.event_log: list[ExactEvent] = []
        self._segments = 0
        self._events = 0
        self._flows = 0

    # --- Integrator interface ------------------------------------------------------------
    def prepare(self, run: Run) -> None:
        plan = run.plan
        unsupported = [(nm, md) for nm, md in zip(plan.names, plan.method, strict=True)
                       if md in ("controller",)]
        if unsupported or plan.surface or plan.scheduled_by:
            names = ", ".join(nm for nm, _ in unsupported) or "a Python controller"
            raise ExactError(f"the exact method follows the netlist's comparators, not Python "
                             f"controllers ({names}): use the Moreau method")
        self.run = run
        init = run.initial
        self.t = float(run.t_start)
        self.mode = tuple(init.mode)
        self.x = np.asarray(init.x, dtype=float).copy()
        self.lam = np.asarray(init.lam, dtype=float).copy()
        self.held: tuple[int, ...] = tuple(int(i) for i in np.flatnonzero(self.lam > 0))
        self._next_out = 1  # index of the next multiple of h to store
        self.slide, self.duty = -1, 0.0

    def advance(self, window: Window) -> SimulationError | None:
        with one_blas_thread():  # tiny matrices (see Follower.follow)
            return self._advance(window)

    def _advance(self, window: Window) -> SimulationError | None:
        run = self.run
        system = run.problem.system
        span = window.t1 - self.t
        if span <= 0:
            return None
        try:
            follower = Follower(system, run.inputs, self.t, span, jump=self.jump,
                                stop=lambda: interrupt.requested() is not None)
        except ExactError as exc:
            return self._error(str(exc), self.t)
        stopped = False
        try:
            follower.follow(self.x, self.mode, self.held)
            error = None
        except FollowStopped:
            error, stopped = None, True
        except ExactError as exc:
            error = str(exc)
        segs, events = follower.segments, follower.events
        self._store(segs, events, window.t1 if error is None and not stopped else None)
        self._flows += len(follower._flows)
        if segs:
            last = segs[-1]
            self.t = last.t_end
            self.mode = tuple(last.key)
            self.x = np.asarray(follower.x, dtype=float).copy()
            if isinstance(last, SlidingSegment):
                self.held = tuple(last.flows[1].held)
                self.lam, _ = self._sliding_values(last, self.x, last.t_end)
                self.slide = last.switch
                self.duty = last.duty(last.t_end, self.x)
            else:
                self.held = tuple(last.flow.held)
                self.lam = self._multipliers(last, self.x, last.duration)
                self.slide, self.duty = -1, 0.0
        if error is not None:
            return self._error(error, self.t)
        if stopped:  # (an interrupt: the segments done are kept, the run ends there)
            signum = interrupt.requested()
            return failures.interrupted(self.t, run.problem.describe(self.mode),
                                        signum if signum is not None else 2)
        self.t = float(window.t1)
        return None

    can_set_state = True

    def set_state(self, x: np.ndarray) -> None:
        self.x = np.array(x, dtype=float)

    def snapshot(self) -> Snapshot:
        return Snapshot(self.t, key_of(self.mode), self.x.copy(), self.lam.copy(), self.slide,
                        self.duty)

    def stats(self) -> dict:
        return dict(steps=self._segments, located=self._events, modes_built=self._flows)

    # --- output --------------------------------------------------------------------------
    def _multipliers(self, seg: Segment, x: np.ndarray, s: float) -> np.ndarray:
        f = seg.flow
        lam = f.Lx @ x + f.Lu @ seg.piece.u(s) + f.Ld @ seg.piece.du(s)
        free = np.ones(lam.size, dtype=bool)
        free[list(f.held)] = False
        lam[free] = 0.0
        return lam

    def _row(self, seg: Segment, x: np.ndarray, s: float) -> np.ndarray:
        u = seg.piece.u(s)
        key = seg.key
        return self.run.problem.output(key).row(key_of(key), -1, 0.0, x, self._multipliers(
            seg, x, s), u)

    def _store(self, segs: list[Segment], events: list[Event], t_end: float | None) -> None:
        """Probe rows at the output instants inside each segment, and after each event."""
        run = self.run
        rec = run.recorder
        n = len(run.problem.system.states)
        t0 = run.t_start
        h = self.h
        names = run.problem.system.diodes
        switches = [s.name for s in run.problem.system.switches]
        for k, seg in enumerate(segs):
            last = k == len(segs) - 1
            if isinstance(seg, SlidingSegment):
                self._store_sliding(seg, last, t_end)
                self._segments += 1
                if k < len(events) and k + 1 < len(segs):
                    ev = events[k]
                    if ev.kind != "breakpoint" or self.log_breakpoints:
                        self._log(ev, segs[k + 1], names, switches)
                continue
            # output instants in (t_start, t_end] of the segment (its start belongs to the
            # segment before, or is the run's first row)
            hi = seg.t_end
            j0 = self._next_out
            j1 = int(np.floor((hi - t0) / h * (1 + 1e-15) + 1e-9))
            grid = t0 + h * np.arange(j0, j1 + 1)
            grid = grid[(grid > seg.t_start) & (grid <= hi + 1e-12 * h)]
            extra = self.save_at[(self.save_at > seg.t_start) & (self.save_at <= hi)]
            times = np.unique(np.concatenate([grid, extra, [hi] if last and t_end is not None
                                                            and abs(hi - t_end) < 1e-12 * h
                                                            else []]))
            self._next_out = max(self._next_out, j1 + 1)
            if times.size:
                G = flow_matrix(seg.flow, seg.piece)
                z0 = np.concatenate([seg.x_start, seg.piece.z0])
                rec.reserve(times.size, 0)
                # one exponential for the first instant and one for the output step; the
                # uniform grid then costs a matrix-vector product per point
                step = expm(G * h) if grid.size > 2 else None
                z, s_prev = None, None
                for tt in times:
                    s = min(float(tt) - seg.t_start, seg.duration)
                    if (step is not None and z is not None
                            and abs(s - s_prev - h) <= 1e-9 * h):
                        z = step @ z
                    else:
                        z = expm(G * s) @ z0
                    s_prev = s
                    rec.append(float(tt), self._row(seg, z[:n], s))
            self._segments += 1
            if k < len(events):
                ev = events[k]
                nxt = segs[k + 1] if k + 1 < len(segs) else None
                if nxt is None:
                    continue
                if ev.kind != "breakpoint" or self.log_breakpoints:
                    self._log(ev, nxt, names, switches)
                if isinstance(nxt, SlidingSegment):
                    self._event_record(ev.t, seg.key, EV_SLIDE_START + nxt.switch)
                    continue
                if nxt.key != seg.key:
                    self._event_record(ev.t, nxt.key, EV_SWITCH)
                if ev.kind != "breakpoint" and (rec.pos == 0 or rec.last_time() < ev.t):
                    rec.append(float(ev.t), self._row(nxt, nxt.x_start, 0.0))

    def _log(self, ev: Event, nxt, diodes, switches) -> None:
        self._events += 1
        kind = "diode" if ev.kind == "pair" else ev.kind
        mode = {nm: ("on" if on else "off") for nm, on in zip(switches, nxt.key, strict=True)}
        if isinstance(nxt, SlidingSegment):
            mode[switches[nxt.switch]] = "sliding"
            held = nxt.flows[1].held
        else:
            held = nxt.flow.held
        mode["held"] = tuple(diodes[i] for i in held)
        self.event_log.append(ExactEvent(float(ev.t), ev.name, kind, mode))
        if getattr(ev, "jump", False):
            self.event_log.append(ExactEvent(float(ev.t), ev.name, "jump", dict(mode)))

    def _event_record(self, t: float, key, info: int) -> None:
        rec = self.run.recorder
        rec.reserve(0, 1)
        e = rec.evpos
        rec.ev_t[e] = t
        rec.ev_key[e] = to_words(key_of(key), rec.ev_key.shape[1])
        rec.ev_info[e] = info
        rec.evpos += 1

    def _sliding_values(self, seg: SlidingSegment, x: np.ndarray, t: float):
        """Multipliers and probes of the Filippov motion at (t, x): the modes' values
        weighted by the equivalent duty."""
        d = seg.duty(t, x)
        s = t - seg.t_piece
        u = seg.piece.u(s)
        lams, rows = [], []
        for m, on in ((0, False), (1, True)):
            key = tuple(on if i == seg.switch else v for i, v in enumerate(seg.key))
            f = seg.flows[m]
            lam = f.Lx @ x + f.Lu @ u + f.Ld @ seg.piece.du(s)
            free = np.ones(lam.size, dtype=bool)
            free[list(f.held)] = False
            lam[free] = 0.0
            lams.append(lam)
            rows.append(self.run.problem.output(key).row(key_of(key), seg.switch, d, x, lam, u))
        return (1 - d) * lams[0] + d * lams[1], (1 - d) * rows[0] + d * rows[1]

    def _store_sliding(self, seg: SlidingSegment, last: bool, t_end: float | None) -> None:
        rec = self.run.recorder
        t0, h = self.run.t_start, self.h
        j1 = int(np.floor((seg.t_end - t0) / h * (1 + 1e-15) + 1e-9))
        grid = t0 + h * np.arange(self._next_out, j1 + 1)
        grid = grid[(grid > seg.t_start) & (grid <= seg.t_end + 1e-12 * h)]
        extra = self.save_at[(self.save_at > seg.t_start) & (self.save_at <= seg.t_end)]
        times = np.unique(np.concatenate([grid, extra]))
        self._next_out = max(self._next_out, j1 + 1)
        rec.reserve(times.size + 1, 1)
        for tt in times:
            tt = min(float(tt), seg.t_end)
            x = np.asarray(seg.sol(tt), dtype=float)
            rec.append(tt, self._sliding_values(seg, x, tt)[1])
        if not (last and t_end is not None and seg.t_end >= t_end - 1e-12 * h):
            self._event_record(seg.t_end, seg.key, EV_SLIDE_END + seg.switch)

    def _error(self, message: str, t: float) -> SimulationError:
        mode = self.run.problem.describe(self.mode)
        return SimulationError(f"exact method: {message}", kind="exact", time=t, t_prev=t,
                               mode=mode)
