"""Moreau θ time-stepping of (switched) linear complementarity systems.

The scheme is Siconos's ``EulerMoreauOSI(θ)`` for first-order linear systems (θ in [1/2, 1],
default 1/2; the relation is fully implicit, Siconos's γ is not used)::

    W        = (I - h θ A)^-1
    x_free   = W [(I + h(1-θ) A) x_k + h((1-θ) E u(t_k) + θ E u(t_k+1))]
    w_k+1    = (D + h C W B) λ_k+1 + C x_free + F u(t_k+1),     0 <= w ⊥ λ >= 0
    x_k+1    = x_free + h W B λ_k+1

Layers:

* :mod:`lcs.stepping` -- the numba kernel: one LCS, a time grid, inputs on the grid; active-set
  fast path with cached factorisations, numba Lemke fallback.
* this module -- the driver: breakpoints of the sources, switching instants of source-driven
  switches (:mod:`lcs.events`), intervals of constant mode, chunks of the grid, outputs,
  errors. Every breakpoint and switching instant is a step boundary (the step that would cross
  it is shortened).

Accuracy: as in Siconos (γ unused), the complementarity impulse ``h W B λ_k+1`` is implicit
Euler. θ = 1/2 is therefore second order only while no pair carries a nonzero λ (m = 0, all
diodes blocking with λ = 0, or λ = 0 pairs such as a freewheeling diode in series with an
inductor); on intervals where a pair is active with ``D`` ≠ 0 the scheme is first order for
every θ (tests/test_moreau.py checks both).

Grid: every source breakpoint, user breakpoint and switching instant is a step boundary; each
segment between boundaries starts its own uniform grid ``sa + j h`` and ends with one
shortened step (merged into the previous step when shorter than 1 % of h).

Errors: a step whose LCP has no solution (or whose solutions give different next states, or
that produces NaN/inf) stops the run. :func:`simulate` does not raise then: it returns the
result computed so far with ``result.error`` set to a :class:`~lcs.results.SimulationError`
naming the time, the mode and the diodes; ``result.raise_if_error()`` raises it (the exception
carries the partial result as ``.result``).
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .events import (
    MERGE_FRACTION,
    InputFunction,
    collect_breakpoints,
    evaluate_inputs,
    grid_chunks,
    has_jumps,
    merge_close,
    plan_grid,
    source_switch_events,
)
from .lcp import LcpOptions, is_p_matrix, solve_lcp
from .model import LCS, ModeKey, ModeModel, OutputMap, SwitchedLCS
from .results import SimulationError, SimulationResult, SimulationStats
from .stepping import (
    FV_LEN,
    FV_LEX_TOL,
    FV_PIVOT_TOL,
    FV_RTOL,
    FV_UNIQ_TOL,
    IV_FAILMASK,
    IV_FALLBACKS,
    IV_GSTEP,
    IV_LEN,
    IV_MASK,
    IV_MISSES,
    IV_ODD,
    IV_OUTPOS,
    IV_PIVOTS,
    IV_UNIQ,
    MAX_MASK_M,
    STEP_LCP_FAILED,
    STEP_NONFINITE,
    STEP_NONUNIQUE,
    STEP_OK,
    Discretisation,
    discretise,
    run_chunk,
)

__all__ = [
    "MoreauOptions",
    "SimulationError",
    "SimulationResult",
    "simulate",
    "simulate_lcs",
]

InconsistentHandler = Callable[[LCS, np.ndarray, np.ndarray], np.ndarray]

# Rough cost model for deciding whether a progress bar is worth showing.
_EST_STEP_S = 0.5e-6
_EST_SEGMENT_S = 5e-6


@dataclass(frozen=True)
class MoreauOptions:
    """Numerical options of the time stepper.

    Parameters
    ----------
    lcp : LcpOptions
        Options of the LCP solvers (Lemke tolerances, pivot budget, enumeration size).
    fast_path : bool
        Try the previous step's active set before Lemke.
    accept_rtol : float
        Relative tolerance of the fast-path acceptance test (``λ_a >= -rtol·|λ_a|``,
        ``w_i >= -rtol·(|q_i| + Σ|M_ij λ_j|)``): round-off, not modelling, accuracy.
    cache_slots : int
        Active-set factorisations kept per mode.
    uniqueness_max_m : int
        When the step's LCP matrix is not a P-matrix and ``m`` is at most this, every Lemke
        solution is checked by enumerating all complementary bases: another solution that
        moves the state stops the run (``"non_unique"``). Non-unique λ with a unique state (a
        freewheeling overlap) is accepted.
    uniqueness_tol : float
        Relative state difference regarded as a different solution.
    chunk_steps : int
        Steps per kernel call (bounds the memory of the input arrays).
    """

    lcp: LcpOptions = field(default_factory=LcpOptions)
    fast_path: bool = True
    accept_rtol: float = 1e-11
    cache_slots: int = 64
    uniqueness_max_m: int = 6
    uniqueness_tol: float = 1e-6
    chunk_steps: int = 32768


def _c(a, shape=None) -> np.ndarray:
    arr = np.ascontiguousarray(a, dtype=float)
    return arr.reshape(shape) if shape is not None else arr


@dataclass
class _Output:
    names: tuple[str, ...]
    Cy: np.ndarray
    Dy: np.ndarray
    Fy: np.ndarray


class _ModeData:
    """Everything the kernel needs for one mode: matrices, active-set cache, work arrays."""

    def __init__(self, lcs: LCS, out: _Output, h: float, theta: float, opts: MoreauOptions):
        n, m, p = lcs.n, lcs.m, lcs.p
        self.lcs = lcs
        self.A, self.B, self.C = _c(lcs.A, (n, n)), _c(lcs.B, (n, m)), _c(lcs.C, (m, n))
        self.D, self.E, self.F = _c(lcs.D, (m, m)), _c(lcs.E, (n, p)), _c(lcs.F, (m, p))
        self.disc: Discretisation = discretise(self.A, self.B, self.C, self.D, self.E, h, theta)
        self.out = out
        self.Cy, self.Dy, self.Fy = _c(out.Cy), _c(out.Dy), _c(out.Fy)
        self.out_is_state = bool(
            self.Cy.shape == (n, n) and np.array_equal(self.Cy, np.eye(n))
            and not self.Dy.any() and not self.Fy.any()
        )
        S = max(1, int(opts.cache_slots))
        self.ckeys = np.full(S, -1, np.int64)
        self.cna = np.zeros(S, np.int64)
        self.cidx = np.zeros((S, m), np.int64)
        self.cG = np.zeros((S, m, m))
        self.fast = bool(opts.fast_path and m <= MAX_MASK_M)
        # Enumeration-based uniqueness checks only for small m, and not for P-matrices
        # (unique λ for every q).
        check = 0 < m <= opts.uniqueness_max_m and not is_p_matrix(self.disc.M)
        self.uniq_max_m = int(m) if check else -1
        self.work = (
            np.zeros(n), np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(m, np.bool_),
            np.zeros((m, 2 * m + 2)), np.zeros(m, np.int64), np.zeros(m), np.zeros((m, m + 1)),
            np.zeros((n, n)), np.zeros((n, p)), np.zeros((n, p)), np.zeros((n, m)),
            np.zeros((m, m)),
        )

    @property
    def xf(self) -> np.ndarray:
        return self.work[0]

    @property
    def q(self) -> np.ndarray:
        return self.work[1]


class _Problem:
    """A switched LCS seen by the driver: LCS and output map per mode, mode names."""

    def __init__(self, system: SwitchedLCS, probes: Sequence[str] | OutputMap | None):
        self.system = system
        self.probes = probes
        self._outputs: dict[ModeKey, _Output] = {}

    def lcs(self, mode: ModeKey) -> LCS:
        return self.system.mode(mode)

    def describe(self, mode: ModeKey) -> dict[str, str]:
        return self.system.describe_mode(mode) if self.system.switches else {}

    def output(self, mode: ModeKey) -> _Output:
        if mode in self._outputs:
            return self._outputs[mode]
        lcs = self.lcs(mode)
        n, m, p = lcs.n, lcs.m, lcs.p
        if isinstance(self.probes, OutputMap):
            om = self.probes
            out = _Output(tuple(om.names), _c(om.Cy, (-1, n)), _c(om.Dy, (-1, m)),
                          _c(om.Fy, (-1, p)))
        else:
            names = tuple(self.probes) if self.probes is not None else tuple(lcs.states)
            k = len(names)
            Cy, Dy, Fy = np.zeros((k, n)), np.zeros((k, m)), np.zeros((k, p))
            lower_states = [s.lower() for s in lcs.states]
            others = [(i, nm) for i, nm in enumerate(names) if nm.lower() not in lower_states]
            for i, nm in enumerate(names):
                if nm.lower() in lower_states:
                    Cy[i, lower_states.index(nm.lower())] = 1.0
            if others:
                om = self.system.outputs(mode, [nm for _, nm in others])
                oCy, oDy, oFy = _c(om.Cy, (-1, n)), _c(om.Dy, (-1, m)), _c(om.Fy, (-1, p))
                for r, (i, _) in enumerate(others):
                    Cy[i], Dy[i], Fy[i] = oCy[r], oDy[r], oFy[r]
            out = _Output(names, Cy, Dy, Fy)
        self._outputs[mode] = out
        return out


def _pair_names(lcs: LCS, mask: int) -> tuple[str, ...]:
    return tuple(pr.name for i, pr in enumerate(lcs.pairs) if (mask >> i) & 1)


def _fmt_mode(desc: dict[str, str]) -> str:
    return ", ".join(f"{k} {v}" for k, v in desc.items()) if desc else "single LCS"


def _progress_bar(show: bool, total: int):
    if not show:
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None
    return tqdm(total=total, unit="step", unit_scale=True, desc="moreau", leave=False)


def simulate(
    system: SwitchedLCS,
    signals: Sequence[InputFunction],
    x0,
    t_stop: float,
    h: float,
    *,
    theta: float = 0.5,
    t_start: float = 0.0,
    probes: Sequence[str] | None = None,
    every: int = 1,
    breakpoints: Sequence[float] = (),
    progress: bool = False,
    on_inconsistent: InconsistentHandler | None = None,
    options: MoreauOptions | None = None,
) -> SimulationResult:
    """Simulate a switched LCS with the Moreau θ scheme.

    Parameters
    ----------
    system : SwitchedLCS
        One LCS per switch mode. Switches must be driven by independent sources (the control's
        output map has ``Cy = Dy = 0``); their instants are computed from the waveforms and
        hit exactly.
    signals : sequence of Signal (or vectorised callables ``f(t) -> array``)
        ``signals[j]`` drives input j, already resolved (:func:`lcs.signals.resolve`).
    x0 : array_like, shape (n,)
        Initial state (A for inductor currents, V for capacitor voltages).
    t_stop, h : float
        Stop time and step, s.
    theta : float
        θ in [1/2, 1]: 1/2 is the trapezoidal (second-order) Moreau scheme, 1 backward Euler.
    t_start : float
        Start time, s.
    probes : sequence of str, optional
        Names of the stored outputs (state names and any probe the system's output maps
        know, e.g. ``"v(out)"``, ``"i(D1)"``). Default: all states.
    every : int
        Store every ``every``-th step (the first and last points are always stored).
    breakpoints : sequence of float
        Extra instants (s) to land on exactly.
    progress : bool
        Show a tqdm progress bar (only when stderr is a terminal and the run is expected to
        last more than about a second).
    on_inconsistent : callable, optional
        ``on_inconsistent(lcs, x, u) -> x_plus`` applied once to an inconsistent initial state
        (one whose instantaneous LCP ``w = C x + D λ + F u`` has no solution), e.g.
        ``lcs.wellposed.state_jump``. Without it, the first step absorbs the jump.
    options : MoreauOptions, optional

    Returns
    -------
    SimulationResult
        With ``error`` set if the run stopped early (the result then ends at the last
        completed step); see the module docstring.

    Raises
    ------
    NotImplementedError
        A switch is driven by the circuit state (comparator).
    ValueError
        Invalid arguments (θ outside [1/2, 1], h <= 0, wrong shapes).
    """
    t_wall = time.perf_counter()
    opts = options or MoreauOptions()
    _check_args(system, signals, x0, t_start, t_stop, h, theta, every)
    signals = list(signals)
    bps = collect_breakpoints(signals, t_start, t_stop, breakpoints)
    bps = merge_close(bps, MERGE_FRACTION * h)
    mode0, events = source_switch_events(system, signals, t_start, t_stop, bps, h)
    return _run(_Problem(system, probes), signals, np.asarray(x0, dtype=float), t_start,
                t_stop, h, theta, every, bps, mode0, events, progress, on_inconsistent, opts,
                t_wall)


def simulate_lcs(
    lcs: LCS,
    inputs: Sequence[InputFunction],
    x0,
    t_stop: float,
    h: float,
    *,
    theta: float = 0.5,
    t_start: float = 0.0,
    probes: Sequence[str] | OutputMap | None = None,
    every: int = 1,
    breakpoints: Sequence[float] = (),
    progress: bool = False,
    on_inconsistent: InconsistentHandler | None = None,
    options: MoreauOptions | None = None,
) -> SimulationResult:
    """Simulate a single LCS (no switches) with the Moreau θ scheme.

    Same as :func:`simulate`, with ``inputs[j](t)`` any vectorised function of time (a
    :mod:`lcs.signals` waveform or e.g. ``lambda t: np.sin(t)``; its ``breakpoints(t0, t1)``
    method, if any, is honoured) and ``probes`` state names or an explicit
    :class:`~lcs.model.OutputMap` (``y = Cy x + Dy λ + Fy u``).
    """
    t_wall = time.perf_counter()
    opts = options or MoreauOptions()

    def builder(key):
        return ModeModel(lcs, lambda names: _state_outputs(lcs, names))

    system = SwitchedLCS([], lcs.states, lcs.inputs, [pr.name for pr in lcs.pairs], builder)
    _check_args(system, inputs, x0, t_start, t_stop, h, theta, every)
    inputs = list(inputs)
    bps = merge_close(collect_breakpoints(inputs, t_start, t_stop, breakpoints),
                      MERGE_FRACTION * h)
    return _run(_Problem(system, probes), inputs, np.asarray(x0, dtype=float), t_start, t_stop,
                h, theta, every, bps, (), [], progress, on_inconsistent, opts, t_wall)


def _state_outputs(lcs: LCS, names: Sequence[str]) -> OutputMap:
    unknown = [nm for nm in names if nm.lower() not in [s.lower() for s in lcs.states]]
    raise KeyError(
        f"unknown probe(s) {', '.join(unknown)}: a bare LCS knows only its states "
        f"({', '.join(lcs.states)}); pass an OutputMap for other outputs"
    )


def _check_args(system, signals, x0, t_start, t_stop, h, theta, every) -> None:
    if not 0.5 <= theta <= 1.0:
        raise ValueError(f"theta must be in [1/2, 1], got {theta}")
    if not (h > 0 and np.isfinite(h)):
        raise ValueError(f"step h must be positive, got {h}")
    if not t_stop > t_start:
        raise ValueError(f"t_stop ({t_stop}) must exceed t_start ({t_start})")
    if int(every) != every or every < 1:
        raise ValueError(f"every must be a positive integer, got {every}")
    if len(signals) != len(system.inputs):
        raise ValueError(
            f"{len(system.inputs)} input(s) ({', '.join(system.inputs)}) but "
            f"{len(signals)} signal(s) given"
        )
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (len(system.states),):
        raise ValueError(f"x0 must have shape ({len(system.states)},), got {x0.shape}")
    if not np.all(np.isfinite(x0)):
        raise ValueError("x0 contains NaN or infinity")


def _segments(t_start, t_stop, bps, events, h):
    """Step-grid boundaries and the mode of each segment between them."""
    ev_t = np.array([t for t, _ in events], dtype=float)
    bounds = np.unique(np.concatenate(([t_start, t_stop], bps, ev_t)))
    bounds = merge_close(bounds, MERGE_FRACTION * h)
    if bounds[-1] != t_stop:
        bounds[-1] = t_stop
    return bounds, ev_t


def _run(prob: _Problem, inputs, x0, t_start, t_stop, h, theta, every, bps, mode0, events,
         progress, on_inconsistent, opts: MoreauOptions, t_wall) -> SimulationResult:
    notes: list[str] = []
    bounds, ev_t = _segments(t_start, t_stop, bps, events, h)
    ev_modes = [md for _, md in events]
    # Mode of segment i: the last event at or before its start (events are merged into
    # bounds, so an event time is a segment start up to MERGE_FRACTION * h).
    last_event = np.searchsorted(ev_t, bounds[:-1] + MERGE_FRACTION * h, side="right") - 1
    seg_modes = [tuple(mode0) if j < 0 else ev_modes[j] for j in last_event.tolist()]
    plan = plan_grid(bounds, h)
    total_steps = plan.total
    cap = total_steps // every + 3
    jumps = has_jumps(inputs)

    modes: dict[ModeKey, _ModeData] = {}

    def mode_data(mode) -> _ModeData:
        if mode not in modes:
            modes[mode] = _ModeData(prob.lcs(mode), prob.output(mode), h, theta, opts)
        return modes[mode]

    md0 = mode_data(tuple(mode0))
    lcs0 = md0.lcs
    n, m = lcs0.n, lcs0.m
    names = md0.out.names
    T_out = np.empty(cap)
    Y_out = np.empty((cap, len(names)))
    ivars = np.zeros(IV_LEN, np.int64)
    fvars = np.zeros(FV_LEN)
    fvars[FV_RTOL] = opts.accept_rtol
    fvars[FV_PIVOT_TOL] = opts.lcp.pivot_tol
    fvars[FV_LEX_TOL] = opts.lcp.lex_tol
    fvars[FV_UNIQ_TOL] = opts.uniqueness_tol
    max_piv = opts.lcp.pivots_for(m)

    # Initial state and multipliers: the instantaneous LCP w = C x + D λ + F u.
    x = np.array(x0, dtype=float)
    u0 = evaluate_inputs(inputs, np.array([t_start]), +1)[0]
    res0 = solve_lcp(md0.D, md0.C @ x + md0.F @ u0, opts.lcp) if m else None
    if res0 is not None and not res0.ok:
        if on_inconsistent is not None:
            x_new = np.asarray(on_inconsistent(lcs0, x.copy(), u0.copy()), dtype=float)
            if x_new.shape != x.shape or not np.all(np.isfinite(x_new)):
                raise ValueError(
                    f"on_inconsistent returned {x_new!r}; expected a finite state of shape "
                    f"{x.shape}"
                )
            notes.append(
                f"initial state {np.array2string(x, precision=6)} is inconsistent (the LCP "
                f"w = C x + D λ + F u at t = {t_start:g} s has no solution); replaced by "
                f"{np.array2string(x_new, precision=6)} (on_inconsistent)"
            )
            x = x_new
            res0 = solve_lcp(md0.D, md0.C @ x + md0.F @ u0, opts.lcp)
        if not res0.ok:
            notes.append(
                f"initial state is inconsistent (the LCP w = C x + D λ + F u at "
                f"t = {t_start:g} s has no solution): λ(t0) is reported as 0 and the first "
                "step absorbs the state jump"
            )
    lam = res0.z.copy() if (res0 is not None and res0.ok) else np.zeros(m)
    if res0 is not None and res0.ok and res0.basis is not None:
        ivars[IV_MASK] = int(sum(1 << i for i in np.flatnonzero(res0.basis))) if m <= 62 else 0
    T_out[0] = t_start
    Y_out[0] = md0.Cy @ x + md0.Dy @ lam + md0.Fy @ u0
    ivars[IV_OUTPOS] = 1

    visited = [tuple(mode0)]
    error: SimulationError | None = None
    est = total_steps * _EST_STEP_S + len(bounds) * _EST_SEGMENT_S
    bar = _progress_bar(bool(progress) and sys.stderr.isatty() and est > 1.0, total_steps)
    t_last = t_start  # time of the current x
    cur_mode = tuple(mode0)
    # Modes by integer id so that a chunk of the grid can be split into runs of one mode.
    mode_list: list[ModeKey] = []
    for md_key in seg_modes:
        if md_key not in mode_list:
            mode_list.append(md_key)
    seg_mode_id = np.array([mode_list.index(k_) for k_ in seg_modes], dtype=np.int64)
    n_intervals = 1 + int(np.count_nonzero(np.diff(seg_mode_id)))
    try:
        for tg, odd, seg in grid_chunks(plan, opts.chunk_steps):
            # Inputs for the whole chunk at once (one vectorised evaluation per chunk).
            if jumps:
                U0 = np.ascontiguousarray(evaluate_inputs(inputs, tg[:-1], +1))
                U1 = np.ascontiguousarray(evaluate_inputs(inputs, tg[1:], -1))
            else:
                U = evaluate_inputs(inputs, tg)
                U0, U1 = U[:-1], U[1:]
            mid = seg_mode_id[seg]
            cuts = np.concatenate(([0], np.flatnonzero(mid[1:] != mid[:-1]) + 1, [len(mid)]))
            for r0, r1 in zip(cuts[:-1], cuts[1:], strict=True):
                mode = mode_list[int(mid[r0])]
                md = mode_data(mode)
                if mode not in visited:
                    visited.append(mode)
                if md.lcs.n != n or md.lcs.m != m:
                    raise ValueError("all modes must have the same numbers of states and pairs")
                cur_mode = mode
                k0 = int(r0)
                while True:
                    status, k = _call_kernel(md, theta, h, tg[k0:r1 + 1], odd[k0:r1],
                                             U0[k0:r1], U1[k0:r1], x, lam, ivars, fvars,
                                             max_piv, every, T_out, Y_out)
                    if status == STEP_OK:
                        break
                    kk = k0 + k
                    error = _handle_failure(status, md, prob, mode, tg, odd, U1, kk, x, lam,
                                            ivars, every, T_out, Y_out, theta, opts)
                    if error is not None:
                        t_last = float(tg[kk])
                        break
                    k0 = kk + 1
                    if k0 >= r1:
                        break
                if error is not None:
                    break
                t_last = float(tg[r1])
            if error is not None:
                break
            if bar is not None:
                bar.update(len(odd))
    finally:
        if bar is not None:
            bar.close()

    pos = int(ivars[IV_OUTPOS])
    if T_out[pos - 1] != t_last:
        # Always keep the last completed step.
        md = modes[cur_mode]
        u_last = evaluate_inputs(inputs, np.array([t_last]), -1)[0]
        T_out[pos] = t_last
        Y_out[pos] = md.Cy @ x + md.Dy @ lam + md.Fy @ u_last
        pos += 1
    stats = SimulationStats(
        steps=int(ivars[IV_GSTEP]),
        odd_steps=int(ivars[IV_ODD]),
        fallbacks=int(ivars[IV_FALLBACKS]),
        lcp_pivots=int(ivars[IV_PIVOTS]),
        factorisations=int(ivars[IV_MISSES]),
        uniqueness_checks=int(ivars[IV_UNIQ]),
        intervals=n_intervals,
        wall_time=time.perf_counter() - t_wall,
    )
    # The buffers were sized for the whole run: slice them (a copy of a large run costs as
    # much as the stepping), unless the run stopped early and most of them is unused.
    t_res, y_res = T_out[:pos], Y_out[:pos]
    if 2 * pos < cap:
        t_res, y_res = t_res.copy(), y_res.copy()
    result = SimulationResult(
        t=t_res,
        names=tuple(names),
        y=y_res,
        x_final=x.copy(),
        lambda_final=lam.copy(),
        modes_visited=visited,
        events=[(float(t), md_) for t, md_ in events if t <= t_last],
        stats=stats,
        notes=notes,
        error=error,
    )
    if error is not None:
        error.result = result
    return result


def _call_kernel(md: _ModeData, theta, h, tg, odd, U0, U1, x, lam, ivars, fvars, max_piv,
                 every, T_out, Y_out):
    d = md.disc
    return run_chunk(
        d.Phi, d.G0, d.G1, md.C, md.F, d.M, d.K,
        md.A, md.B, md.D, md.E, float(theta), float(h),
        md.Cy, md.Dy, md.Fy,
        tg, odd, U0, U1,
        x, lam,
        md.ckeys, md.cna, md.cidx, md.cG,
        ivars, fvars, int(max_piv), int(every), int(md.uniq_max_m), md.fast,
        T_out, Y_out, md.out_is_state,
        *md.work,
    )


def _handle_failure(status, md: _ModeData, prob: _Problem, mode, tg, odd, U1, k, x, lam, ivars,
                    every, T_out, Y_out, theta, opts: MoreauOptions) -> SimulationError | None:
    """Deal with a step the kernel could not complete: retry its LCP with the full driver
    (enumeration confirms Lemke's verdict for small m), or build the error."""
    t0, t1 = float(tg[k]), float(tg[k + 1])
    desc = prob.describe(mode)
    where = f"t = {t1:.9g} s (step from {t0:.9g} s), mode: {_fmt_mode(desc)}"
    if status == STEP_LCP_FAILED:
        if odd[k]:
            d = discretise(md.A, md.B, md.C, md.D, md.E, t1 - t0, theta)
        else:
            d = md.disc
        q = md.q.copy()
        res = solve_lcp(d.M, q, opts.lcp)
        if res.ok:
            # Enumeration found what Lemke could not (M not copositive-plus): take the step.
            x[:] = md.xf + d.K @ res.z
            lam[:] = res.z
            ivars[IV_MASK] = int(sum(1 << i for i in np.flatnonzero(res.basis))) \
                if md.lcs.m <= 62 else 0
            g = int(ivars[IV_GSTEP]) + 1
            ivars[IV_GSTEP] = g
            if g % every == 0:
                pos = int(ivars[IV_OUTPOS])
                T_out[pos] = t1
                Y_out[pos] = md.Cy @ x + md.Dy @ lam + md.Fy @ U1[k]
                ivars[IV_OUTPOS] = pos + 1
            return None
        pairs = _pair_names(md.lcs, int(ivars[IV_FAILMASK]))
        how = ("Lemke ray termination, confirmed by enumeration" if res.status == "no_solution"
               else f"Lemke: {res.status}")
        kind = "max_pivots" if res.status == "max_pivots" else "no_solution"
        msg = (
            f"{where}: the complementarity problem of the time step has no solution ({how}). "
            f"Diodes involved: {', '.join(pairs) or '(none with negative w at λ = 0)'} "
            "(they would be reverse-biased beyond zero with every diode off, and no "
            "combination of conducting diodes satisfies the circuit). The circuit is "
            "probably ill-posed in this mode (e.g. a loop of diodes and voltage sources or a "
            "cut-set of diodes and current sources)."
        )
        return SimulationError(msg, kind=kind, time=t1, t_prev=t0, mode=desc, pairs=pairs)
    if status == STEP_NONUNIQUE:
        pairs = _pair_names(md.lcs, int(ivars[IV_FAILMASK]))
        msg = (
            f"{where}: the complementarity problem of the time step has several solutions "
            f"giving different next states; diodes involved: {', '.join(pairs)}. The circuit "
            "is not well posed in this mode (check passivity / the diode orientation)."
        )
        return SimulationError(msg, kind="non_unique", time=t1, t_prev=t0, mode=desc,
                               pairs=pairs)
    if status == STEP_NONFINITE:
        msg = (
            f"{where}: the state became NaN or infinite (overflow: an unstable mode, or "
            "non-finite inputs)."
        )
        return SimulationError(msg, kind="non_finite", time=t1, t_prev=t0, mode=desc)
    raise AssertionError(f"unknown kernel status {status}")  # pragma: no cover
