"""Time grid, input evaluation and switching instants for the Moreau driver.

Switches driven by independent sources (the control's output map has ``Cy = 0`` and ``Dy = 0``)
have a control that is a known function of time, ``c(t) = Fy u(t)``. Their switching instants
are computed before stepping: exactly on piecewise-linear segments (DC, PULSE, PWL between
breakpoints), by sampling and ``brentq`` otherwise. State-dependent controls (comparators) need
event location inside a step and are left to the next issue.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from .model import SwitchedLCS
from .signals import Pwl

InputFunction = Callable[[np.ndarray], np.ndarray]

# Two boundaries closer than this fraction of h are merged (they differ by round-off).
MERGE_FRACTION = 1e-9
# A remainder step shorter than this fraction of h is merged into the previous step.
SNAP_FRACTION = 0.01


# ---------------------------------------------------------------------------------------------
# Inputs
# ---------------------------------------------------------------------------------------------


def _pwl_limit(sig: Pwl, t: np.ndarray, side: int) -> np.ndarray:
    """One-sided limit of a PWL waveform (which may jump where two points share a time)."""
    times = np.asarray(sig.times, dtype=float)
    values = np.asarray(sig.values, dtype=float)
    idx = np.searchsorted(times, t, side="right" if side > 0 else "left")
    lo = np.clip(idx - 1, 0, len(times) - 1)
    hi = np.clip(idx, 0, len(times) - 1)
    t_lo, t_hi = times[lo], times[hi]
    span = np.where(t_hi > t_lo, t_hi - t_lo, 1.0)
    frac = np.clip((t - t_lo) / span, 0.0, 1.0)
    out = values[lo] + (values[hi] - values[lo]) * np.where(t_hi > t_lo, frac, 0.0)
    out = np.where(idx == 0, values[0], out)
    return np.where(idx >= len(times), values[-1], out)


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
        0: plain evaluation; +1 / -1: right / left limits (differs only at jumps of PWL
        waveforms; the other waveforms are continuous once resolved).

    Returns
    -------
    ndarray, shape (N, p)
    """
    t = np.asarray(t, dtype=float)
    out = np.empty((t.size, len(inputs)))
    for j, f in enumerate(inputs):
        if side != 0 and isinstance(f, Pwl):
            out[:, j] = _pwl_limit(f, t, side)
        else:
            out[:, j] = np.broadcast_to(np.asarray(f(t), dtype=float), t.shape)
    return out


def has_jumps(inputs: Sequence[InputFunction]) -> bool:
    """Whether some input can jump (a PWL with two points at the same time)."""
    for f in inputs:
        if isinstance(f, Pwl) and np.any(np.diff(np.asarray(f.times, dtype=float)) == 0):
            return True
    return False


def collect_breakpoints(inputs: Sequence[InputFunction], t0: float, t1: float,
                        extra: Sequence[float] = ()) -> np.ndarray:
    """Sorted source breakpoints (and ``extra`` instants) strictly inside ``(t0, t1)``, s."""
    pts = [np.asarray(extra, dtype=float).ravel()]
    for f in inputs:
        bp = getattr(f, "breakpoints", None)
        if bp is not None:
            pts.append(np.asarray(bp(t0, t1), dtype=float).ravel())
    allp = np.unique(np.concatenate(pts)) if pts else np.empty(0)
    return allp[(allp > t0) & (allp < t1)]


def merge_close(times: np.ndarray, tol: float) -> np.ndarray:
    """Drop entries closer than ``tol`` to their predecessor (times sorted)."""
    if times.size < 2:
        return times
    keep = np.concatenate(([True], np.diff(times) > tol))
    return times[keep]


# ---------------------------------------------------------------------------------------------
# Source-driven switching instants
# ---------------------------------------------------------------------------------------------


@dataclass
class _ControlMaps:
    """Per mode, the rows ``Fy`` (k, p) of the switch controls as functions of the inputs."""

    system: SwitchedLCS
    cache: dict

    def rows(self, mode) -> np.ndarray:
        if mode not in self.cache:
            sw = self.system.switches
            Fy = np.zeros((len(sw), len(self.system.inputs)))
            for i, s in enumerate(sw):
                om = self.system.outputs(mode, [s.control])
                Cy = np.asarray(om.Cy, dtype=float)
                Dy = np.asarray(om.Dy, dtype=float)
                if np.any(Cy != 0) or np.any(Dy != 0):
                    raise NotImplementedError(
                        f"switch {s.name}: its control {s.control!r} depends on the circuit "
                        "state (a comparator-driven switch); only switches driven by "
                        "independent sources are supported so far (state-dependent switching "
                        "with event location comes next)"
                    )
                Fy[i] = np.asarray(om.Fy, dtype=float).reshape(-1)
            self.cache[mode] = Fy
        return self.cache[mode]


def _initially_on(options) -> bool:
    """State of a switch whose control starts inside the hysteresis band: the netlist's
    ``ON``/``OFF`` (``options["initial"]``, or ``options["on"]``), off by default as in
    ngspice."""
    if not isinstance(options, dict):
        return False
    val = options.get("initial", options.get("on"))
    return bool(val) if val is not None else False


def _switch_state(c: float, on: bool, vt: float, vh: float) -> bool:
    if c > vt + vh:
        return True
    if c < vt - vh:
        return False
    return on


def _first_crossing(fun, sa: float, sb: float, ca: float, cb: float, thr: float, up: bool,
                    linear: bool, h: float, skip_start: bool = False) -> float | None:
    """First t in [sa, sb] where c(t) > thr (``up``) or c(t) < thr (not ``up``).

    ``ca``/``cb`` are the right/left limits of c at sa/sb; ``fun`` evaluates c on arrays.
    ``skip_start`` is set for a switch that flipped at ``sa``: its control sits on the other
    threshold there (up to round-off), which must not count as a new crossing.
    """
    def beyond(v):
        return v > thr if up else v < thr

    if beyond(ca) and not skip_start:
        return sa
    if linear:
        if not beyond(cb) or cb == ca:
            return None
        # c is linear on [sa, sb]: exact crossing of the threshold.
        t = sa + (thr - ca) / (cb - ca) * (sb - sa)
        if skip_start and t <= sa:
            return None
        return min(max(t, sa), sb)
    # Smooth but not linear: sample (at most h apart, so no crossing longer than a step is
    # missed) and refine the first sign change with brentq.
    nseg = int(max(8, min(1e6, np.ceil((sb - sa) / h))))
    ts = np.linspace(sa, sb, nseg + 1)
    cs = fun(ts)
    cs[0], cs[-1] = ca, cb
    hit = np.flatnonzero(cs > thr if up else cs < thr)
    if skip_start:
        hit = hit[hit > 0]
    if hit.size == 0:
        return None
    i = int(hit[0])
    if i == 0:
        return sa

    def g(tt):
        return float(fun(np.array([tt]))[0]) - thr

    if g(ts[i - 1]) == 0.0:
        lo = ts[i - 1]
    else:
        lo = brentq(g, ts[i - 1], ts[i], xtol=1e-300, rtol=1e-15)
    # brentq returns a root; the switch acts just after it.
    return float(lo)


def source_switch_events(system: SwitchedLCS, inputs: Sequence[InputFunction], t0: float,
                         t1: float, breakpoints: np.ndarray, h: float):
    """Switch states at ``t0`` and switching instants in ``(t0, t1)`` for source-driven gates.

    Parameters
    ----------
    system : SwitchedLCS
    inputs : sequence of callables
        The resolved source waveforms, one per input of ``system``.
    t0, t1 : float
        Run interval, s.
    breakpoints : ndarray
        Sorted source breakpoints inside (t0, t1), s (the controls are smooth between them).
    h : float
        Step, s (sampling resolution for non-linear controls).

    Returns
    -------
    mode0 : tuple[bool, ...]
        Switch states at ``t0`` (on while control > vt + vh, off while < vt - vh; inside the
        band, the switch's ``options["initial"]`` (or ``"on"``), default off).
    events : list of (float, tuple[bool, ...])
        Switching instants (s) and the mode after them, increasing.

    Raises
    ------
    NotImplementedError
        If a switch's control depends on the state (``Cy`` or ``Dy`` nonzero in some mode).
    """
    sw = system.switches
    if not sw:
        return (), []
    maps = _ControlMaps(system, {})
    linear_inputs = all(getattr(f, "piecewise_linear", False) for f in inputs)

    def controls(mode, t, side):
        return evaluate_inputs(inputs, np.atleast_1d(t), side) @ maps.rows(mode).T

    vt = np.array([s.vt for s in sw], dtype=float)
    vh = np.array([abs(s.vh) for s in sw], dtype=float)
    initial = [_initially_on(s.options) for s in sw]
    mode = tuple(initial)
    # Mode-dependent control maps: iterate to a fixed point (at most a few passes).
    for _ in range(len(sw) + 1):
        c0 = controls(mode, t0, +1)[0]
        new = tuple(_switch_state(c0[i], mode[i], vt[i], vh[i]) for i in range(len(sw)))
        if new == mode:
            break
        mode = new
    mode0 = mode
    events: list[tuple[float, tuple[bool, ...]]] = []
    bounds = np.concatenate(([t0], breakpoints, [t1]))
    tol = MERGE_FRACTION * h
    # Inputs at every segment end, once (vectorised): right limits at the starts, left
    # limits at the ends. Controls are then small matrix products per segment.
    u_start = evaluate_inputs(inputs, bounds[:-1], +1)
    u_end = evaluate_inputs(inputs, bounds[1:], -1)
    lin_cache: dict = {}

    def linear_rows(mode) -> list[bool]:
        if mode not in lin_cache:
            rows = maps.rows(mode)
            lin_cache[mode] = [
                linear_inputs or all(getattr(inputs[j], "piecewise_linear", False)
                                     for j in np.flatnonzero(rows[i]))
                for i in range(len(sw))
            ]
        return lin_cache[mode]

    for s_idx in range(len(bounds) - 1):
        sa0 = sa = float(bounds[s_idx])
        sb = float(bounds[s_idx + 1])
        just_flipped: list[int] = []
        while sa < sb:
            rows = maps.rows(mode)
            lin = linear_rows(mode)
            ca0 = rows @ u_start[s_idx]
            cb = rows @ u_end[s_idx]
            if sa > sa0:
                # After an event inside the segment: the control there, by interpolation
                # where it is linear, by evaluation otherwise.
                frac = (sa - sa0) / (sb - sa0)
                c_at = controls(mode, sa, 0)[0] if not all(lin) else None
                ca = np.array([ca0[i] + (cb[i] - ca0[i]) * frac if lin[i] else c_at[i]
                               for i in range(len(sw))])
            else:
                ca = ca0
            best = None
            flips = []
            for i in range(len(sw)):
                if not rows[i].any():
                    continue
                up = not mode[i]
                thr = vt[i] + vh[i] if up else vt[i] - vh[i]

                def fun(tt, i=i, mode=mode):
                    return controls(mode, tt, 0)[:, i]

                tc = _first_crossing(fun, sa, sb, ca[i], cb[i], thr, up, lin[i], h,
                                     skip_start=i in just_flipped)
                if tc is None:
                    continue
                if best is None or tc < best - tol:
                    best, flips = tc, [i]
                elif abs(tc - best) <= tol:
                    flips.append(i)
            if best is None:
                break
            mode = tuple((not on) if i in flips else on for i, on in enumerate(mode))
            if events and abs(events[-1][0] - best) <= tol:
                events[-1] = (events[-1][0], mode)
            elif best <= t0 + tol:
                mode0 = mode
            else:
                events.append((best, mode))
            if best >= sb:
                break
            sa = best
            just_flipped = flips
            if len(events) > 10_000_000:
                raise RuntimeError("more than 1e7 switching events: chattering gate?")
    # Drop events that do not change the mode (e.g. a flip and flip-back at the same instant).
    out = []
    prev = mode0
    for t, md in events:
        if md != prev:
            out.append((t, md))
            prev = md
    return mode0, out


# ---------------------------------------------------------------------------------------------
# Time grid
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class GridPlan:
    """The step sequence over consecutive segments ``bounds[i] .. bounds[i+1]``.

    Each segment starts its own uniform grid ``sa + j h`` (j = 1..n_regular) and ends with
    one shortened ("odd") step of length ``last`` onto ``sb`` when the segment is not a whole
    number of steps. A remainder shorter than ``SNAP_FRACTION * h`` is merged into the last
    regular step (one slightly longer odd step) so that no needlessly tiny step is taken.

    Attributes
    ----------
    bounds : ndarray, shape (S + 1,)
        Segment boundaries, s.
    n_regular : ndarray of int64, shape (S,)
    last : ndarray, shape (S,)
        Length of the final odd step, s (0: none, the grid lands on ``sb``).
    start : ndarray of int64, shape (S + 1,)
        Global index of each segment's first step (``start[-1]`` = total steps).
    """

    bounds: np.ndarray
    h: float
    n_regular: np.ndarray
    last: np.ndarray
    start: np.ndarray

    @property
    def total(self) -> int:
        return int(self.start[-1])


def plan_grid(bounds: np.ndarray, h: float) -> GridPlan:
    """Step counts of every segment (vectorised)."""
    bounds = np.asarray(bounds, dtype=float)
    sa, sb = bounds[:-1], bounds[1:]
    L = sb - sa
    r = L / h
    N = np.rint(r)
    aligned = (N >= 1) & (np.abs(L - N * h) <= MERGE_FRACTION * h * np.maximum(1.0, r))
    Nf = np.floor(r)
    rem = L - Nf * h
    fix = rem <= 0.0  # floor round-off
    Nf = np.where(fix, Nf - 1, Nf)
    rem = np.where(fix, L - Nf * h, rem)
    snap = (Nf >= 1) & (rem < SNAP_FRACTION * h)
    n_reg = np.where(aligned, N, np.where(snap, Nf - 1, Nf)).astype(np.int64)
    last = np.where(aligned, 0.0, np.where(snap, h + rem, rem))
    nsteps = n_reg + (last > 0)
    start = np.concatenate(([0], np.cumsum(nsteps))).astype(np.int64)
    return GridPlan(bounds, float(h), n_reg, last, start)


def grid_chunks(plan: GridPlan, chunk: int):
    """Yield ``(t, odd, seg)`` for consecutive pieces of at most ``chunk`` steps.

    ``t`` (k + 1,) are step boundaries (the first is the end of the previous piece), ``odd``
    (k,) flags shortened steps and ``seg`` (k,) gives each step's segment index.
    """
    total = plan.total
    t_prev = float(plan.bounds[0])
    for g0 in range(0, total, chunk):
        g = np.arange(g0, min(total, g0 + chunk), dtype=np.int64)
        seg = np.searchsorted(plan.start, g, side="right") - 1
        j = g - plan.start[seg]
        sa = plan.bounds[seg]
        sb = plan.bounds[seg + 1]
        nreg = plan.n_regular[seg]
        odd = j >= nreg
        t_end = np.where(odd, sb, sa + (j + 1) * plan.h)
        # A segment that is a whole number of steps ends exactly on its boundary.
        exact_end = (j == nreg - 1) & (plan.last[seg] == 0.0)
        t_end = np.where(exact_end, sb, t_end)
        t = np.concatenate(([t_prev], t_end))
        t_prev = float(t[-1])
        yield t, odd, seg
