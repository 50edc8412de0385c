"""Time grid, input evaluation and switching instants for the Moreau driver.

Switches driven by independent sources (the control's output map has ``Cy = 0`` and ``Dy = 0``)
have a control that is a known function of time, ``c(t) = Fy u(t)``. Their switching instants
are computed before stepping: exactly on piecewise-linear segments (DC, PULSE, PWL between
breakpoints), by sampling and ``brentq`` otherwise. State-dependent controls (comparators) are
located inside the steps by the kernel (:mod:`lcs.stepping`); here they only keep their
initial state while the source-driven instants are computed.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit
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


class InputTable:
    """Fast evaluation of the inputs over one run: a piecewise-linear source without jumps (DC,
    PULSE, PWL) is tabulated at its breakpoints in ``[t0, t1]`` once and evaluated by linear
    interpolation (exact: it is linear between breakpoints); other sources are called.

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
            if (getattr(f, "piecewise_linear", False) and bp is not None
                    and not (isinstance(f, Pwl)
                             and np.any(np.diff(np.asarray(f.times, float)) == 0))):
                pts = np.asarray(bp(t0, t1), dtype=float).ravel()
                pts = np.unique(np.concatenate(([t0, t1], pts[(pts > t0) & (pts < t1)])))
                if len(pts) <= 4_000_000:
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
        out = np.empty((t.size, len(self.inputs)))
        for j, f in enumerate(self.inputs):
            table = self.tables[j]
            if table is not None:
                if len(table[0]) == 2 and table[1][0] == table[1][1]:
                    out[:, j] = table[1][0]
                else:
                    out[:, j] = np.interp(t, table[0], table[1])
            elif side != 0 and isinstance(f, Pwl):
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
    """Per mode, the rows ``Fy`` (k, p) of the switch controls as functions of the inputs
    (zero rows for the switches not in ``which``)."""

    system: SwitchedLCS
    cache: dict
    which: frozenset | None = None

    def rows(self, mode) -> np.ndarray:
        if mode not in self.cache:
            sw = self.system.switches
            Fy = np.zeros((len(sw), len(self.system.inputs)))
            for i, s in enumerate(sw):
                if self.which is not None and i not in self.which:
                    continue
                om = self.system.outputs(mode, [s.control])
                Cy = np.asarray(om.Cy, dtype=float)
                Dy = np.asarray(om.Dy, dtype=float)
                if np.any(Cy != 0) or np.any(Dy != 0):
                    raise NotImplementedError(
                        f"switch {s.name}: its control {s.control!r} depends on the circuit "
                        f"state in mode {self.system.describe_mode(mode)} although it is driven by "
                        "sources alone in the initial mode; switches whose kind (source-driven "
                        "or comparator) changes with the mode are not supported"
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


@njit(cache=True)
def _linear_switch_events(sa, sb, ca, cb, on0, up, down, out_t, out_on):
    """Switching instants of one switch whose control is linear on every segment
    ``[sa[s], sb[s]]`` (from ``ca[s]`` to ``cb[s]``): on above ``up``, off below ``down``.
    Writes instants and new states into ``out_t``/``out_on``; returns how many."""
    on = on0
    ne = 0
    for s in range(sa.shape[0]):
        t0 = sa[s]
        c0 = ca[s]
        b = cb[s]
        just = False
        for _ in range(4):
            thr = down if on else up
            beyond0 = (c0 < thr) if on else (c0 > thr)
            beyond1 = (b < thr) if on else (b > thr)
            if beyond0 and not just:
                tf = t0
            elif beyond1 and b != c0:
                # c is linear on [t0, sb]: exact crossing of the threshold.
                tf = t0 + (thr - c0) / (b - c0) * (sb[s] - t0)
                if just and tf <= t0:
                    break
                tf = min(max(tf, t0), sb[s])
            else:
                break
            on = not on
            out_t[ne] = tf
            out_on[ne] = on
            ne += 1
            c0 = thr
            t0 = tf
            just = True
            if tf >= sb[s]:
                break
    return ne


def _linear_events(maps, mode0, active, vt, vh, bounds, u_start, u_end, linear_inputs, inputs,
                   tol, t0):
    """Compiled path of :func:`source_switch_events` for piecewise-linear gates whose control
    rows do not depend on the mode (the usual case): per switch, a linear control crosses each
    threshold at most once per segment. Returns ``(mode0, events)`` or None when the
    conditions do not hold (then the generic path runs)."""
    rows = maps.rows(mode0)
    idx = sorted(active)
    for i in idx:
        if not (linear_inputs or all(getattr(inputs[j], "piecewise_linear", False)
                                     for j in np.flatnonzero(rows[i]))):
            return None
    ca_all = u_start @ rows.T
    cb_all = u_end @ rows.T
    sa = np.ascontiguousarray(bounds[:-1])
    sb = np.ascontiguousarray(bounds[1:])
    cap = 4 * len(sa) + 4
    times, sw_idx, states = [], [], []
    for i in idx:
        if not rows[i].any():
            continue
        out_t = np.empty(cap)
        out_on = np.empty(cap, np.bool_)
        ne = _linear_switch_events(sa, sb, np.ascontiguousarray(ca_all[:, i]),
                                   np.ascontiguousarray(cb_all[:, i]), bool(mode0[i]),
                                   float(vt[i] + vh[i]), float(vt[i] - vh[i]), out_t, out_on)
        times.append(out_t[:ne])
        sw_idx.append(np.full(ne, i))
        states.append(out_on[:ne])
    if not times:
        return tuple(mode0), (np.empty(0), np.empty(0, np.int64))
    t_all = np.concatenate(times)
    i_all = np.concatenate(sw_idx).astype(np.int64)
    on_all = np.concatenate(states)
    order = np.argsort(t_all, kind="stable")
    t_all, i_all, on_all = t_all[order], i_all[order], on_all[order]
    key0 = sum(1 << i for i, on in enumerate(mode0) if on)
    out_t = np.empty(len(t_all))
    out_k = np.empty(len(t_all), np.int64)
    key0, ne = _merge_keys(np.ascontiguousarray(t_all), np.ascontiguousarray(i_all),
                           np.ascontiguousarray(on_all), key0, float(t0), float(tol), out_t,
                           out_k)
    k = len(mode0)

    def mode_of(key):
        return tuple(bool((key >> i) & 1) for i in range(k))

    # The rows must be the same in every mode reached (else the generic path decides).
    scale = np.abs(rows[idx]).max() if idx else 0.0
    for key in set(out_k[:ne].tolist()) | {key0}:
        if not np.allclose(maps.rows(mode_of(key))[idx], rows[idx], rtol=0.0,
                           atol=1e-13 * scale):
            return None
    return mode_of(key0), (out_t[:ne].copy(), out_k[:ne].copy())


@njit(cache=True)
def _merge_keys(t_all, i_all, on_all, key0, t0, tol, out_t, out_k):
    """Switch keys after each instant: simultaneous instants (within ``tol``) merged, instants
    at ``t0`` folded into the initial key, instants that change nothing dropped."""
    key = key0
    ne = 0
    for e in range(t_all.shape[0]):
        i = i_all[e]
        if on_all[e]:
            key |= 1 << i
        else:
            key &= ~(1 << i)
        t = t_all[e]
        if ne > 0 and abs(out_t[ne - 1] - t) <= tol:
            out_k[ne - 1] = key
        elif t <= t0 + tol:
            key0 = key
        else:
            out_t[ne] = t
            out_k[ne] = key
            ne += 1
    # Drop the instants that do not change the key.
    m = 0
    prev = key0
    for e in range(ne):
        if out_k[e] != prev:
            out_t[m] = out_t[e]
            out_k[m] = out_k[e]
            prev = out_k[e]
            m += 1
    return key0, m


def source_switch_events(system: SwitchedLCS, inputs: Sequence[InputFunction], t0: float,
                         t1: float, breakpoints: np.ndarray, h: float,
                         which: Sequence[int] | None = None, base=None, maps_out=None,
                         as_arrays: bool = False):
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
    which : sequence of int, optional
        Indices of the source-driven switches (default: all). The others keep their state in
        ``base`` (default: off) throughout.
    base : tuple of bool, optional
        States of the switches not in ``which``.
    maps_out : dict, optional
        Receives ``{mode: Fy rows (k, p)}`` of the controls used (for later consistency
        checks).
    as_arrays : bool
        Return the events as two arrays ``(times, keys)`` (keys: bit i set when switch i is
        on) instead of a list of ``(t, mode)``.

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
        If a switch of ``which`` has a control that depends on the state (``Cy`` or ``Dy``
        nonzero) in some mode.
    """
    sw = system.switches
    if not sw:
        return (), []
    active = frozenset(range(len(sw)) if which is None else which)
    maps = _ControlMaps(system, {} if maps_out is None else maps_out, frozenset(active))
    if not active:
        m0 = tuple(bool(b) for b in base) if base is not None else tuple(False for _ in sw)
        return m0, ((np.empty(0), np.empty(0, np.int64)) if as_arrays else [])
    linear_inputs = all(getattr(f, "piecewise_linear", False) for f in inputs)

    def controls(mode, t, side):
        return evaluate_inputs(inputs, np.atleast_1d(t), side) @ maps.rows(mode).T

    vt = np.array([s.vt for s in sw], dtype=float)
    vh = np.array([abs(s.vh) for s in sw], dtype=float)
    initial = [_initially_on(s.options) for s in sw]
    if base is not None:
        initial = [initial[i] if i in active else bool(base[i]) for i in range(len(sw))]
    mode = tuple(initial)
    # Mode-dependent control maps: iterate to a fixed point (at most a few passes).
    for _ in range(len(sw) + 1):
        c0 = controls(mode, t0, +1)[0]
        new = tuple(_switch_state(c0[i], mode[i], vt[i], vh[i]) if i in active else mode[i]
                    for i in range(len(sw)))
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
    fast = _linear_events(maps, mode0, active, vt, vh, bounds, u_start, u_end, linear_inputs,
                          inputs, tol, t0)
    if fast is not None:
        m0, (ft, fk) = fast
        if as_arrays:
            return m0, (ft, fk)
        k = len(sw)
        return m0, [(t, tuple(bool((key >> i) & 1) for i in range(k)))
                    for t, key in zip(ft.tolist(), fk.tolist(), strict=True)]
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
                if i not in active or not rows[i].any():
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
    if as_arrays:
        return mode0, (np.array([t for t, _ in out], dtype=float),
                       np.array([sum(1 << i for i, on in enumerate(md) if on) for _, md in out],
                                dtype=np.int64))
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


@njit(cache=True)
def _plan_nb(bounds, h, merge, snap_frac, n_reg, last, start):
    nseg = bounds.shape[0] - 1
    start[0] = 0
    for i in range(nseg):
        L = bounds[i + 1] - bounds[i]
        r = L / h
        N = np.rint(r)
        aligned = N >= 1 and abs(L - N * h) <= merge * h * max(1.0, r)
        if aligned:
            n_reg[i] = int(N)
            last[i] = 0.0
        else:
            Nf = np.floor(r)
            rem = L - Nf * h
            if rem <= 0.0:  # floor round-off
                Nf -= 1
                rem = L - Nf * h
            if Nf >= 1 and rem < snap_frac * h:
                n_reg[i] = int(Nf) - 1
                last[i] = h + rem
            else:
                n_reg[i] = int(Nf)
                last[i] = rem
        start[i + 1] = start[i] + n_reg[i] + (1 if last[i] > 0 else 0)


def plan_grid(bounds: np.ndarray, h: float) -> GridPlan:
    """Step counts of every segment (compiled loop over the segments)."""
    bounds = np.ascontiguousarray(bounds, dtype=float)
    nseg = len(bounds) - 1
    n_reg = np.empty(nseg, np.int64)
    last = np.empty(nseg)
    start = np.empty(nseg + 1, np.int64)
    _plan_nb(bounds, float(h), MERGE_FRACTION, SNAP_FRACTION, n_reg, last, start)
    return GridPlan(bounds, float(h), n_reg, last, start)


@njit(cache=True)
def _fill_grid(bounds, n_regular, last, start, h, g0, g1, t_prev, t, odd, seg_out):
    """Step ends ``t[1:]``, odd flags and segment indices of global steps ``g0 .. g1-1``."""
    t[0] = t_prev
    seg = 0
    while start[seg + 1] <= g0:
        seg += 1
    for g in range(g0, g1):
        while g >= start[seg + 1]:
            seg += 1
        jj = g - start[seg]
        nreg = n_regular[seg]
        sa = bounds[seg]
        sb = bounds[seg + 1]
        o = jj >= nreg
        if o:
            te = sb
        elif jj == nreg - 1 and last[seg] == 0.0:
            # A segment that is a whole number of steps ends exactly on its boundary.
            te = sb
        else:
            te = sa + (jj + 1) * h
        t[g - g0 + 1] = te
        odd[g - g0] = o
        seg_out[g - g0] = seg


def grid_chunks(plan: GridPlan, chunk: int):
    """Yield ``(t, odd, seg)`` for consecutive pieces of at most ``chunk`` steps.

    ``t`` (k + 1,) are step boundaries (the first is the end of the previous piece), ``odd``
    (k,) flags shortened steps and ``seg`` (k,) gives each step's segment index.
    """
    total = plan.total
    t_prev = float(plan.bounds[0])
    bounds = np.ascontiguousarray(plan.bounds, dtype=float)
    n_reg = np.ascontiguousarray(plan.n_regular, dtype=np.int64)
    last = np.ascontiguousarray(plan.last, dtype=float)
    start = np.ascontiguousarray(plan.start, dtype=np.int64)
    for g0 in range(0, total, chunk):
        g1 = min(total, g0 + chunk)
        t = np.empty(g1 - g0 + 1)
        odd = np.empty(g1 - g0, np.bool_)
        seg = np.empty(g1 - g0, np.int64)
        _fill_grid(bounds, n_reg, last, start, float(plan.h), g0, g1, t_prev, t, odd, seg)
        t_prev = float(t[-1])
        yield t, odd, seg
