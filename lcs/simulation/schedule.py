"""What a run knows before integrating: the instants to land on and the switchings at known
instants.

* Breakpoints: source breakpoints (PULSE edges, PWL corners), user breakpoints, ``save_at``
  instants and the clock period starts of latched switches.
* Known switchings (:class:`KnownSwitchings`), as operations on the switch key at an instant:
  ``OP_SET`` (source-driven switches, :mod:`.source_switching`, and Python controllers'
  commands) and ``OP_REARM`` (a latched switch re-armed at its clock period start).
* Python controllers (:class:`Controllers`): sampled at their instants between windows of the
  integration, their commands become ``OP_SET`` entries.
"""

from __future__ import annotations

import weakref
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..arrays import unique_sorted
from ..bits import from_words, to_words, words
from ..model import ModeKey, SwitchedLCS
from .codes import OP_REARM, OP_SET  # noqa: F401  (operations of known switchings)
from .inputs import MERGE_FRACTION, InputFunction, collect_breakpoints, evaluate_inputs, merge_close
from .problem import Problem, mode_tuple
from .source_general import check_start
from .source_switching import _ControlMaps, source_switch_events
from .switches import SwitchPlan


def periodic(period: float, phase: float, t0: float, t1: float) -> np.ndarray:
    """``phase + j period`` strictly inside (t0, t1)."""
    j0 = int(np.floor((t0 - phase) / period))
    j1 = int(np.ceil((t1 - phase) / period))
    t = phase + period * np.arange(j0, j1 + 1)
    return t[(t > t0) & (t < t1)]


@dataclass
class KnownSwitchings:
    """Switchings at known instants: ``t (L,)`` in s, ``op (L,)`` (``OP_*``), arguments
    ``a (L, Wk)``, ``b (L, Wk)`` (bitsets of the switches, :mod:`lcs.bits`: ``OP_SET`` sets the
    key to ``(key & ~a) | b``; ``OP_REARM`` re-arms switch ``a[:, 0]``), sorted by time then
    operation."""

    t: np.ndarray
    op: np.ndarray
    a: np.ndarray
    b: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    def window(self, ws: float, we: float, tol: float, pending=()) -> KnownSwitchings:
        """The entries in ``[ws, we)`` (to ``tol``), with the controller commands of
        ``pending`` (``(time, op, a, b)``, those before ``we``) merged in."""
        lo = np.searchsorted(self.t, ws - tol, side="left")
        hi = np.searchsorted(self.t, we - tol, side="left")
        e_t, e_op, e_a, e_b = self.t[lo:hi], self.op[lo:hi], self.a[lo:hi], self.b[lo:hi]
        if pending:
            Wk = self.a.shape[1]
            e_t = np.concatenate([e_t, [max(e[0], ws) for e in pending]])
            e_op = np.concatenate([e_op, np.array([e[1] for e in pending], np.int64)])
            e_a = np.concatenate([e_a, np.array([to_words(e[2], Wk) for e in pending])])
            e_b = np.concatenate([e_b, np.array([to_words(e[3], Wk) for e in pending])])
            order = np.lexsort((e_op, e_t))
            e_t, e_op, e_a, e_b = e_t[order], e_op[order], e_a[order], e_b[order]
        return KnownSwitchings(e_t, e_op, e_a, e_b)


# A run longer than this many grid steps is planned a stretch at a time (its breakpoints,
# source-driven instants and input table held for one stretch only), so that its memory does
# not grow with its length; a shorter one in one piece. (2^18: the buck of bench_memory at
# 1e7 steps peaks at 57 MB against 75 MB with 2^21, for the same CPU time within 3 %.)
STRETCH_STEPS = 1 << 18
# Breakpoints near a stretch's end that are tried as its boundary before the stretch is made
# longer.
_CUT_TRIES = 64
# ... and the distance (in steps) a boundary keeps from every known switching: far beyond the
# distances at which instants are merged (lcs.simulation.inputs.MERGE_FRACTION).
_CUT_GUARD = 1e-6


@dataclass
class RunPlan:
    """The breakpoints, the known switchings and the initial switch states of a stretch
    ``[t0, t1)`` of a run (the whole run unless it is longer than :data:`STRETCH_STEPS`).

    Attributes
    ----------
    t0, t1 : float
        The stretch, s (``t1`` is the run's stop for the last one).
    breakpoints : ndarray
        Sorted instants strictly inside the stretch (merged to round-off), s.
    save_at : ndarray
        The ``save_at`` instants inside ``(t_start, t_stop]`` (the whole run's), s.
    known : KnownSwitchings
        The known switchings in ``[t0, t1)``.
    mode_src : ModeKey
        The mode at ``t0`` with the source-driven switches set from their controls (the others
        as guessed).
    src_maps : dict
        Per mode, the source-driven switches' control rows (see
        :func:`~lcs.simulation.source_switching.source_switch_events`), shared by the stretches.
    expected_breakpoints, expected_known : int
        The whole run's breakpoints and known switchings, estimated from this stretch (exact
        for a run in one piece): what an integrator reserves room for.
    """

    t0: float
    t1: float
    breakpoints: np.ndarray
    save_at: np.ndarray
    known: KnownSwitchings
    mode_src: ModeKey
    src_maps: dict
    expected_breakpoints: int
    expected_known: int


def plan_run(system: SwitchedLCS, inputs: Sequence[InputFunction], plan: SwitchPlan,
             t_start: float, t_stop: float, h: float, merge: float, user_bps, save_at,
             guess: ModeKey):
    """The run's plan a stretch at a time: yields :class:`RunPlan` of consecutive stretches
    ``[t_start, b1), [b1, b2), ..., [bj, t_stop)``, each computed when the previous one has
    been integrated.

    ``h`` is the integrator's time step (the source-driven instants' search resolution) and
    ``merge`` the distance under which two instants are one (s).

    The stretches give the whole run's plan, entry for entry: each boundary is one of the
    run's breakpoints, away from every known switching, where every
    source-driven switch's state is what its control there says on its own (the state a
    stretch starts from is the one the previous stretch ended with), and breakpoints are
    merged across it as in one piece.
    """
    save_at = unique_sorted(np.asarray(save_at, dtype=float).ravel())
    save_at = save_at[(save_at > t_start) & (save_at <= t_stop)]
    user_bps = unique_sorted(np.asarray(user_bps, dtype=float).ravel())
    src_maps = _control_maps(system, plan.source)
    span = STRETCH_STEPS * h
    a = t_start
    while True:
        c = t_stop if t_stop - a <= 1.5 * span else a + span
        while True:
            part = _plan_part(system, inputs, plan, a, c, a == t_start, h, merge, user_bps,
                              save_at, guess, src_maps)
            cut = t_stop if c >= t_stop else _boundary(system, inputs, plan, part, h, guess,
                                                        src_maps)
            if cut is not None:
                break
            c = t_stop if t_stop - c <= span else c + span
        bps, known, mode_src = part
        if cut < t_stop:
            bps = bps[bps < cut]
            keep = known.t < cut
            known = KnownSwitchings(known.t[keep], known.op[keep], known.a[keep], known.b[keep])
        scale = (t_stop - t_start) / (cut - a)
        yield RunPlan(a, cut, bps, save_at, known, mode_src, src_maps,
                      int(np.ceil(len(bps) * scale)), int(np.ceil(len(known) * scale)))
        if cut >= t_stop:
            return
        a = cut


def _plan_part(system, inputs, plan, a, c, first, h, merge, user_bps, save_at, guess,
               src_maps):
    """Breakpoints, known switchings and the source-driven mode at ``a`` of ``[a, c)``."""
    k = len(system.switches)
    # Schedule entries (time, op, a, b) as arrays: latch re-arms, then source events.
    lt, li = [np.empty(0)], [np.empty(0, np.int64)]
    for i, (per, ph) in plan.latch.items():
        tt = periodic(per, ph, a, c)
        lt.append(tt)
        li.append(np.full(len(tt), i, np.int64))
    latch_t, latch_i = np.concatenate(lt), np.concatenate(li)
    extra = np.concatenate([v[(v > a) & (v < c)] for v in (user_bps, save_at)] + [latch_t])
    raw = collect_breakpoints(inputs, a, c, extra)
    # (an instant is merged into the one before it: a later stretch starts from its first
    # instant, the previous stretch's boundary, which the whole run keeps)
    bps = merge_close(raw, merge) if first else merge_close(
        np.concatenate(([a], raw)), merge)[1:]
    if k:
        mode_src, (src_t, src_k) = source_switch_events(system, inputs, a, c, bps, h,
                                                        which=plan.source, base=guess,
                                                        maps_out=src_maps, as_arrays=True)
        if plan.source:
            _check_start(system, inputs, plan, a, h, tuple(mode_src), src_maps)
    else:
        mode_src, src_t, src_k = (), np.empty(0), np.empty((0, 1), np.int64)
    Wk = words(k)
    smask = to_words(plan.source_mask, Wk)
    latch_a = np.zeros((len(latch_i), Wk), np.int64)
    latch_a[:, 0] = latch_i
    st_t = np.concatenate([src_t, latch_t])
    st_op = np.concatenate([np.full(len(src_t), OP_SET, np.int64),
                            np.full(len(latch_t), OP_REARM, np.int64)])
    st_a = np.concatenate([np.tile(smask, (len(src_t), 1)), latch_a])
    st_b = np.concatenate([src_k.reshape(len(src_t), Wk) & smask,
                           np.zeros((len(latch_t), Wk), np.int64)])
    order = np.lexsort((st_op, st_t))
    known = KnownSwitchings(st_t[order], st_op[order], st_a[order], st_b[order])
    return bps, known, tuple(mode_src)


def _check_start(system, inputs, plan, a: float, h: float, mode: tuple, src_maps) -> None:
    """The source-driven switches' states at ``a`` agree with their controls there
    (:func:`~lcs.simulation.source_general.check_start`)."""
    rows = _ControlMaps(system, src_maps, frozenset(plan.source)).rows(mode)
    u = evaluate_inputs(inputs, np.array([a, a + MERGE_FRACTION * h]), +1)
    check_start(system.switches, plan.source, rows, u[0], u[1], mode, a)


def _boundary(system, inputs, plan, part, h, guess, src_maps) -> float | None:
    """A breakpoint in the second half of ``part`` (the plan of ``[a, c)``) where the run can
    be cut (see :func:`plan_run`), the latest; None when none of the last few can."""
    bps, known, mode_src = part
    if not len(bps):
        return None
    half = 0.5 * (bps[0] + bps[-1])
    src_t = known.t[known.op == OP_SET]
    src_b = known.b[known.op == OP_SET]
    k = len(system.switches)
    smask = plan.source_mask
    guard = _CUT_GUARD * h
    for b in bps[::-1][:_CUT_TRIES]:
        if b <= half:
            break
        j = int(np.searchsorted(known.t, b - guard, side="left"))
        if j < len(known.t) and known.t[j] <= b + guard:
            continue  # (a known switching that could be merged with b)
        if not k or not smask:
            return float(b)
        # The source-driven mode at b: the last source switching's, or the stretch's first.
        e = int(np.searchsorted(src_t, b, side="left")) - 1
        if e >= 0:
            from_bits = from_words(src_b[e])
            mode_b = tuple(bool((from_bits >> i) & 1) if (smask >> i) & 1 else guess[i]
                           for i in range(k))
        else:
            mode_b = tuple(mode_src)
        # What the next stretch would start from: the same, or b is not a boundary.
        start, _ = source_switch_events(system, inputs, float(b), float(b) + h, np.empty(0),
                                        h, which=plan.source, base=guess, maps_out=src_maps)
        if tuple(start) == mode_b:
            return float(b)
    return None


_CONTROL_MAPS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _control_maps(system: SwitchedLCS, source) -> dict:
    """The dict of the source-driven switches' control rows per mode (filled by
    :func:`source_switch_events` as modes are met), kept with the system for its next runs:
    the rows are the system's, whatever its sources do."""
    try:
        per_system = _CONTROL_MAPS.setdefault(system, {})
    except TypeError:  # not weak-referenceable: not kept
        return {}
    return per_system.setdefault(tuple(source), {})


class _Measure:
    """Probe values for a controller at a sampling instant."""

    def __init__(self, system: SwitchedLCS, names: Sequence[str]):
        self.names = tuple(names)
        self.prob = Problem(system, self.names)

    def __call__(self, key: int, x, lam, u, slide: int, duty: float) -> dict:
        if not self.names:
            return {}
        out = self.prob.output(mode_tuple(key, self.prob.k))
        y = out.row(key, slide, duty, x, lam, u)
        return dict(zip(self.names, (float(v) for v in y), strict=True))


class Controllers:
    """The run's Python schedule controllers: their sampling instants and their commands.

    Parameters
    ----------
    system : SwitchedLCS
    plan : SwitchPlan
        Says which controller drives which switch.
    t_start, t_stop : float
        The run, s.
    tol : float
        Instants closer than this are one, s.
    """

    def __init__(self, system: SwitchedLCS, plan: SwitchPlan, t_start: float, t_stop: float,
                 tol: float):
        self.plan = plan
        self.tol = tol
        self.ctrls = list({id(c): c for c in plan.scheduled_by.values()}.values())
        self.measures = {id(c): _Measure(system, getattr(c, "probes", ())) for c in self.ctrls}
        for ctrl in self.ctrls:
            if hasattr(ctrl, "reset"):
                ctrl.reset(t_start, t_stop)
        # Sampling instants of each controller (decisions also at t_start).
        self.samples = {}
        for ctrl in self.ctrls:
            ts = np.asarray(ctrl.sample_times(t_start, t_stop) if hasattr(ctrl, "sample_times")
                            else (), dtype=float).ravel()
            self.samples[id(ctrl)] = unique_sorted(ts[(ts > t_start + tol) & (ts < t_stop - tol)])
        self.pending: list[tuple[float, int, int, int]] = []

    def __bool__(self) -> bool:
        return bool(self.ctrls)

    def windows(self, t_start: float, t_stop: float) -> np.ndarray:
        """Window boundaries: the start, every sampling instant, the stop (s)."""
        tol = self.tol
        samples = list(self.samples.values())
        samp = unique_sorted(np.concatenate(samples)) if samples else np.empty(0)
        samp = merge_close(samp[(samp > t_start + tol) & (samp < t_stop - tol)], tol)
        return np.concatenate(([t_start], samp, [t_stop]))

    def due(self, t: float) -> list:
        """The controllers sampled at ``t``."""
        out = []
        for c in self.ctrls:
            cs_ = self.samples[id(c)]
            i_ = np.searchsorted(cs_, t - self.tol)
            if i_ < len(cs_) and abs(cs_[i_] - t) <= self.tol:
                out.append(c)
        return out

    def commands(self, ctrls, t: float, key: int, x, lam, u, slide: int, duty: float,
                 apply: bool = True) -> int:
        """Ask the controllers ``ctrls`` sampled at ``t`` for their commands. Commands at ``t``
        itself are applied to ``key`` when ``apply`` (the initial instant), the others
        become pending schedule entries ``(time, OP_SET, mask, bits)``; returns the key."""
        plan = self.plan
        lower = {nm.lower(): i for i, nm in enumerate(plan.names)}
        pending = list(self.pending)
        for ctrl in ctrls:
            values = self.measures[id(ctrl)](key, x, lam, u, slide, duty)
            for tc, states in ctrl.decide(t, values):
                mask = bits = 0
                for nm, on in states.items():
                    i = lower[nm.lower()]
                    if plan.scheduled_by.get(i) is not ctrl:
                        raise ValueError(f"controller {type(ctrl).__name__} commands switch "
                                         f"{nm}, which it does not drive")
                    mask |= 1 << i
                    bits |= (1 << i) if on else 0
                if apply and tc <= t + self.tol:
                    key = (key & ~mask) | bits
                else:
                    pending.append((max(float(tc), t), OP_SET, mask, bits))
        pending.sort(key=lambda e: e[0])
        self.pending = pending
        return key

    def take_pending(self, we: float) -> list:
        """The pending commands before ``we`` (removed from the pending list)."""
        now = [e for e in self.pending if e[0] < we - self.tol]
        self.pending = [e for e in self.pending if e[0] >= we - self.tol]
        return now
