"""Moreau θ time-stepping of (switched) linear complementarity systems.

The scheme is Siconos's ``EulerMoreauOSI(θ)`` for first-order linear systems (θ in [1/2, 1],
default 1/2; the relation is fully implicit, Siconos's γ is not used)::

    W        = (I - h θ A)^-1
    x_free   = W [(I + h(1-θ) A) x_k + h((1-θ) E u(t_k) + θ E u(t_k+1))]
    w_k+1    = (D + h C W B) λ_k+1 + C x_free + F u(t_k+1),     0 <= w ⊥ λ >= 0
    x_k+1    = x_free + h W B λ_k+1

Layers:

* :mod:`lcs.simulation` -- the driver, common to every integrator: how each switch is driven,
  breakpoints and source-driven switching instants, the initial state, windows between the
  sampling instants of Python controllers (:mod:`lcs.controllers`), outputs, errors.
* this module -- the Moreau integrator (:class:`MoreauIntegrator`, plugged into the driver):
  the time grid of each window, its chunks and their inputs, the mode stack
  (:mod:`lcs.integrators.moreau.dense.modes`, a mode is built the first time the kernel asks for
  it), and the kernel's return codes turned into errors.
* :mod:`lcs.integrators.moreau.dense` -- the numba kernel: the whole grid of a chunk in one call,
mode changes
  from the schedule or from comparators evaluated after each step (instants located inside
  the step, the step split there), the Filippov relay for sliding modes; the step's LCP by
  :mod:`lcs.lcp.compiled` (cached active sets, Lemke, enumeration).

See ``docs/switching.md`` for the switching rules and methods.

Accuracy: as in Siconos (γ unused), the complementarity impulse ``h W B λ_k+1`` is implicit
Euler. θ = 1/2 is therefore second order only while no pair carries a nonzero λ (m = 0, all
diodes blocking with λ = 0, or λ = 0 pairs such as a freewheeling diode in series with an
inductor); on intervals where a pair is active with ``D`` ≠ 0 the scheme is first order for
every θ (tests/test_moreau.py checks both). Comparator switching instants are the roots of
the switching function along the numerical solution (each trial a θ step of the trial length),
so they are as accurate as the states: O(h²) with θ = 1/2 (tests/test_closed_loop.py). In
sliding mode (Filippov relay) the scheme is first order.

Grid: every source breakpoint, user breakpoint, source-driven switching instant, latch period
start, controller command and ``save_at`` instant is a step boundary; each segment between
boundaries starts its own uniform grid ``sa + j h`` and ends with one shortened step (merged
into the previous step when shorter than 1 % of h). A comparator switching splits the step
that contains it; the grid is not shifted.

Errors: a step whose LCP has no solution (or whose solutions give different next states, or
that produces NaN/inf), or a comparator that chatters, stops the run. :func:`simulate` does
not raise then: it returns the result computed so far with ``result.error`` set to a
:class:`~lcs.results.SimulationError` naming the time, the mode and the diodes or switch;
``result.raise_if_error()`` raises it (the exception carries the partial result as
``.result``).
"""

from __future__ import annotations

import time
import weakref
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ... import interrupt
from ...arrays import unique_sorted
from ...bits import from_words, to_words, words
from ...lcp import LcpOptions
from ...model import LCS, ModeModel, OutputMap, SwitchedLCS
from ...results import SimulationError, SimulationResult
from ...simulation import driver, failures
from ...simulation.initial import InconsistentHandler
from ...simulation.inputs import MERGE_FRACTION, InputFunction, merge_close
from ...simulation.integrator import Integrator, Run, Snapshot, Window
from ...simulation.problem import Problem, mode_tuple, state_outputs
from ...simulation.switches import SWITCHING_METHODS
from .dense import run_grid
from .dense.gridplan import grid_chunks, plan_grid
from .dense.layout import (
    FV_DUTY,
    FV_FAIL_T0,
    FV_FAIL_T1,
    FV_FEAS_TOL,
    FV_H,
    FV_LASTT,
    FV_LEN,
    FV_LEX_TOL,
    FV_PIVOT_TOL,
    FV_ROOT_TOL,
    FV_RTOL,
    FV_TCUR,
    FV_THETA,
    FV_UNIQ_TOL,
    IV_EVPOS,
    IV_FAILMODE,
    IV_FAILSW,
    IV_FALLBACKS,
    IV_INIT,
    IV_K,
    IV_LASTSW,
    IV_LEN,
    IV_LOCATED,
    IV_MISSES,
    IV_NMODES,
    IV_ODD,
    IV_ODDHIT,
    IV_ODDMISS,
    IV_OUTPOS,
    IV_PIVOTS,
    IV_ROOTEVALS,
    IV_SCHED,
    IV_SLIDE,
    IV_SLIDESTEPS,
    IV_STEPS,
    IV_UNIQ,
    IV_UPDATES,
    IV_WARM,
    STEP_CHATTER,
    STEP_FULL,
    STEP_LCP_FAILED,
    STEP_NEED_MODE,
    STEP_NONFINITE,
    STEP_NONUNIQUE,
    STEP_OK,
    STEP_SLIDING,
    Chunk,
    Limits,
    Schedule,
    State,
    Store,
    SwitchArrays,
)
from .dense.modes import cached_stack
from .sparse import integrate as sparse_kernel
from .sparse.layout import STEP_FALLBACK, STEP_GROW

__all__ = [
    "MoreauIntegrator",
    "MoreauOptions",
    "SWITCHING_METHODS",
    "SimulationError",
    "SimulationResult",
    "simulate",
    "simulate_lcs",
]

# Rough cost model for deciding whether a progress bar is worth showing.
_EST_STEP_S = 0.2e-6
_EST_SEGMENT_S = 0.5e-6


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
        freewheeling overlap) is accepted. Modes whose steps are proven to have one next state
        whatever λ they take (a passive mode: the system's ``storage`` verified, and θ = 1 or
        steps short enough, :mod:`lcs.theory.step_uniqueness`) are not enumerated: any solution
        will do.
    uniqueness_tol : float
        Relative state difference regarded as a different solution.
    chunk_steps : int
        Grid steps per kernel call (bounds the memory of the input arrays).
    switching : str
        How comparator-driven switches are simulated (``docs/switching.md``): ``"auto"``
        (per switch: ``EXPLICIT=1`` on its model → explicit, ``VH > 0`` → hysteresis,
        ``VH = 0`` → implicit), ``"implicit"`` (instants located inside the step; on an
        attractive switching surface the Filippov relay, chattering-free; VH ignored),
        ``"hysteresis"`` (instants of the VH band edges located inside the step; no sliding
        mode: a switch that toggles without progress stops the run), ``"explicit"`` (the
        comparator sampled at the end of each step, the new state from that instant).
    max_switchings : int
        Comparator switchings allowed inside one grid step before the run stops as
        chattering.
    root_tol : float
        Comparator instants are located to this fraction of h (or to round-off of the
        switching function, whichever comes first).
    warm_iter : int
        When a regular step's cached active set is not accepted, at most this many iterations
        of block principal pivoting from it (:func:`lcs.lcp.compiled.solve_warm`) before
        Lemke; 0 goes to Lemke directly.
    odd_slots : int
        Discretisations of shortened steps kept per mode (fewer for large circuits: 4 MiB a
        mode, :func:`lcs.integrators.moreau.dense.modes.odd_slots`); 0 discretises every shortened
        step afresh.
    keep_odd_steps : bool
        Start a run with the shortened steps stored by earlier runs of the same system
        (default: repeated runs, as a shooting method's, discretise each length once). A
        stored length serves every length within 1e-9 h of it, so the result then depends
        on what ran before at round-off; False starts with none, and the run gives bit for
        bit the result of a newly formulated system (the dense kernel's runs).
    kernel : str
        How the steps are solved: ``"dense"``, each mode's θ-discretised matrices stored
        (:mod:`lcs.integrators.moreau.dense`: fastest while they are small or sparse); ``"sparse"``,
        factorised KKT systems of the circuit's network (:mod:`lcs.integrators.moreau.sparse`: a
        step costs the non-zeros of its factors, linear in the circuit's size where the LCS's
        matrices are dense, as on a voltage multiplier); ``"auto"`` (default), the sparse kernel
        where it can take the run and its estimated cost per step is lower. The sparse kernel
        takes runs of circuits (modes with a :class:`~lcs.network.NetworkRealisation`)
        whose switches are driven by sources or controllers; a step whose block pivoting
        finds no solution goes to the dense kernel (Lemke) and back.
    kkt_bytes : int
        Memory for the sparse kernel's cached factorisations (bytes, shared by every mode).
    """

    lcp: LcpOptions = field(default_factory=LcpOptions)
    fast_path: bool = True
    accept_rtol: float = 1e-11
    cache_slots: int = 64
    uniqueness_max_m: int = 6
    uniqueness_tol: float = 1e-6
    chunk_steps: int = 32768
    switching: str = "auto"
    max_switchings: int = 16
    root_tol: float = 1e-12
    warm_iter: int = 32
    odd_slots: int = 8
    keep_odd_steps: bool = True
    kernel: str = "auto"
    kkt_bytes: int = 64 << 20


class MoreauIntegrator(Integrator):
    """The Moreau θ time-stepping as an :class:`~lcs.simulation.integrator.Integrator`.

    Parameters
    ----------
    h : float
        Regular step, s.
    theta : float
        θ in [1/2, 1].
    options : MoreauOptions
    """

    name = "moreau"

    def __init__(self, h: float, theta: float, options: MoreauOptions):
        self.h = float(h)
        self.theta = float(theta)
        self.opts = options
        self._done = 0
        self._kernel_time = 0.0  # s inside the compiled kernels (SimulationStats.kernel_time)

    def prepare(self, run: Run) -> None:
        self.run = run
        opts, h = self.opts, self.h
        problem, plan, sched, init = run.problem, run.plan, run.schedule, run.initial
        system = problem.system
        k = problem.k
        n, m, p = len(system.states), len(system.diodes), len(system.inputs)
        self.k, self.m, self.p = k, m, p
        names = run.recorder.names
        self._stack_args = (problem, plan, h, self.theta, opts, n, m, p, names,
                            sched.src_maps, run.base)
        self.stack = None
        self.sparse = sparse_kernel.choose(run, h, self.theta, opts)
        self._sparse_used = self.sparse  # (kept when a mode without a network ends it)
        if not self.sparse:
            self._dense()
        Wk, Wm = words(k), words(m)
        ivars = np.zeros(IV_LEN, np.int64)
        fvars = np.zeros(FV_LEN)
        fvars[FV_RTOL] = opts.accept_rtol
        fvars[FV_PIVOT_TOL] = opts.lcp.pivot_tol
        fvars[FV_LEX_TOL] = opts.lcp.lex_tol
        fvars[FV_UNIQ_TOL] = opts.uniqueness_tol
        fvars[FV_FEAS_TOL] = opts.lcp.feas_tol
        fvars[FV_H] = h
        fvars[FV_THETA] = self.theta
        fvars[FV_ROOT_TOL] = opts.root_tol
        fvars[FV_TCUR] = run.t_start
        fvars[FV_LASTT] = -np.inf
        ivars[IV_SLIDE] = -1
        ivars[IV_LASTSW] = -1
        act = np.zeros((2, Wm), np.int64)
        act[0] = to_words(init.active, Wm)
        self.state = State(np.array(init.x, dtype=float), np.array(init.lam, dtype=float),
                           np.zeros(m), to_words(init.key, Wk), act, np.zeros(Wm, np.int64),
                           np.zeros(Wk, np.int64), ivars, fvars)
        self.ivars, self.fvars = ivars, fvars
        max_piv = opts.lcp.pivots_for(m)
        enum_max_m = int(opts.lcp.enum_max_m) if opts.lcp.method == "auto" else -1
        self.max_sw = max(1, int(opts.max_switchings))
        self.limits = Limits(max_piv, enum_max_m, run.every, self.max_sw,
                             max(0, int(opts.warm_iter)))
        known = sched.known
        self.est_steps = int((run.t_stop - run.t_start) / h) + sched.expected_breakpoints + 2
        run.recorder.reserve(self.est_steps // run.every + len(sched.save_at) + 63,
                             min(sched.expected_known, len(known) + (1 << 16))
                             + 4 * self.max_sw + 2 * k + 256)
        kind = np.ascontiguousarray(plan.kind)
        self.sw_arrays = SwitchArrays(kind, np.ascontiguousarray(plan.flags),
                                      np.ascontiguousarray(plan.vt),
                                      np.ascontiguousarray(plan.vh))

    def _dense(self):
        """The dense kernel's mode stack (built when first needed: a sparse run builds it
        only for the grid steps it hands over)."""
        if self.stack is not None:
            return self.stack
        problem, plan, h, theta, opts, n, m, p, names, src_maps, base = self._stack_args
        self.stack = cached_stack(problem, plan, h, theta, opts, n, m, p, names, src_maps,
                                  base)
        sched = self.run.schedule
        if len(sched.known) and problem.k:
            # The source-driven switchings say how many modes the run will build at least:
            # room for them at once, not by copies of every cache as they come.
            # (distinct rows by their bytes: np.unique(axis=0) imports numpy.ma, 7 ms)
            distinct = len(set(map(bytes, np.ascontiguousarray(sched.known.b))))
            self.stack.reserve(min(distinct + 2, 4096))
        # Evictions of stored shortened steps are weighed against this run's hits (the store
        # itself is kept for the next run of this system, unless the run must not depend on
        # earlier ones).
        odd = self.stack.odd
        odd.counters[0] = 0
        if not opts.keep_odd_steps:
            odd.s.fill(-1.0)
            odd.next.fill(0)
            odd.sets.na.fill(-2)
            odd.counters.fill(0)
        self.stack.add(self.run.initial.key)
        return self.stack

    def expected_cost(self, run: Run) -> tuple[int, float]:
        n_known = run.schedule.expected_known
        return self.est_steps, self.est_steps * _EST_STEP_S + n_known * _EST_SEGMENT_S

    def progress(self) -> int:
        done, self._done = self._done, 0
        return done

    def advance(self, window: Window) -> SimulationError | None:
        run, h, opts = self.run, self.h, self.opts
        ws, we = window.t0, window.t1
        tol = run.tol
        known = window.known
        e_t, e_op, e_a, e_b = known.t, known.op, known.a, known.b
        save_at = run.schedule.save_at
        table = run.table
        p = self.p
        bounds = unique_sorted(np.concatenate(([ws, we], window.breakpoints,
                                           e_t[(e_t > ws) & (e_t < we)])))
        bounds = merge_close(bounds, MERGE_FRACTION * h)
        bounds[0], bounds[-1] = ws, we
        if save_at.size:
            # A save_at instant merged with a breakpoint an ulp away is stored at its own
            # value.
            sv = save_at[(save_at > ws) & (save_at < we)]
            near = np.clip(np.searchsorted(bounds, sv), 1, len(bounds) - 1)
            near = np.where(np.abs(bounds[near - 1] - sv) < np.abs(bounds[near] - sv),
                            near - 1, near)
            close = np.abs(bounds[near] - sv) <= tol
            bounds[near[close]] = sv[close]
        plan = plan_grid(bounds, h)
        ivars, rec = self.ivars, run.recorder
        # (an interrupt is answered between kernel calls: a call of chunk_steps grid steps
        # lasts 20 ms on the boost, 1.4 s on a 200-stage multiplier; a shorter call would
        # change the sparse kernel's results at round-off, its refinement restarting)
        for tg, odd, _seg in grid_chunks(plan, opts.chunk_steps):
            signum = interrupt.requested()
            if signum is not None:
                snap = self.snapshot()
                return failures.interrupted(
                    snap.t, run.problem.describe(mode_tuple(snap.key, run.problem.k)), signum)
            if table.jumps:
                U0 = np.ascontiguousarray(table(tg[:-1], +1))
                U1 = np.ascontiguousarray(table(tg[1:], -1))
            else:
                U = table(tg)
                U0, U1 = U[:-1], U[1:]
            if table.piecewise_linear:
                Um = np.zeros((0, p))
            else:
                Um = np.ascontiguousarray(table(0.5 * (tg[:-1] + tg[1:])))
            N = len(odd)
            # (the known switchings are sorted by time: a slice, not a mask over the whole
            # window at every chunk, quadratic in the run's length)
            sel = slice(int(np.searchsorted(e_t, tg[0] - tol, side="left")),
                        int(np.searchsorted(e_t, tg[-1] - tol, side="left")))
            idx = np.searchsorted(tg, e_t[sel] - tol, side="left")
            if idx.size and np.any(np.abs(tg[idx] - e_t[sel]) > max(tol, 1e-15 * we)):
                raise AssertionError("a scheduled switching instant is not a grid point")
            sched = Schedule(np.ascontiguousarray(idx, dtype=np.int64),
                             np.ascontiguousarray(e_op[sel]), np.ascontiguousarray(e_a[sel]),
                             np.ascontiguousarray(e_b[sel]))
            force = np.zeros(N, np.bool_)
            if save_at.size:
                pos_s = np.searchsorted(tg[1:], save_at - tol, side="left")
                ok = pos_s < N
                hit = ok & (np.abs(tg[1:][np.minimum(pos_s, N - 1)] - save_at) <= tol)
                force[pos_s[hit]] = True
            chunk = Chunk(tg, odd, U0, U1, Um, force)
            # (a recorder resampling as the run goes makes room for the chunk's rows)
            rec.room(N // run.every + 1 + int(np.count_nonzero(force)) + self.max_sw + 3)
            ivars[IV_K] = 0
            ivars[IV_SCHED] = 0
            ivars[IV_INIT] = -1
            while True:
                if self.sparse:
                    status = self._kernel_call(lambda store, c=chunk, s=sched: self.sparse.run(
                        c, s, self.state, self.limits, store))
                else:
                    status = self._dense_call(chunk, sched)
                if status == STEP_OK:
                    break
                if status == STEP_NEED_MODE:
                    if not self.sparse:
                        self.stack.add(from_words(self.state.need))
                    elif not self.sparse.add(from_words(self.state.need)):
                        self._hand_over()
                    continue
                if status == STEP_FULL:
                    rec.reserve(self.max_sw + 3, 2 * self.max_sw + self.k + 6 + len(sched.k))
                    continue
                if status == STEP_FALLBACK:
                    err = self._dense_step(chunk)
                    if err is not None:
                        return err
                    continue
                if status == STEP_GROW:
                    self.sparse.grow()
                    continue
                return self._error(status)
            self._done += N
        return None

    def _kernel_call(self, call) -> int:
        """``call(store)``, a kernel's call with the recorder's buffers; the rows and events it
        wrote are taken back. Returns its status."""
        ivars, rec = self.ivars, self.run.recorder
        ivars[IV_OUTPOS] = rec.pos
        ivars[IV_EVPOS] = rec.evpos
        store = Store(rec.T, rec.Y, rec.duty, rec.ev_t, rec.ev_key, rec.ev_info)
        t0 = time.perf_counter()
        status = call(store)
        self._kernel_time += time.perf_counter() - t0
        rec.pos = int(ivars[IV_OUTPOS])
        rec.evpos = int(ivars[IV_EVPOS])
        return status

    def _dense_call(self, chunk: Chunk, sched: Schedule) -> int:
        """The dense kernel over ``chunk``."""
        self.ivars[IV_NMODES] = self.stack.count
        return self._kernel_call(lambda store: run_grid(
            self.stack.arrays(), self.sw_arrays, chunk, sched, self.state, self.limits, store))

    def _dense_step(self, chunk: Chunk) -> SimulationError | None:
        """The dense kernel takes grid step ``ivars[IV_K]`` of ``chunk`` (its schedule already
        applied), then the sparse kernel goes on from the next."""
        ivars, rec = self.ivars, self.run.recorder
        stack = self._dense()
        kk = int(ivars[IV_K])
        um = chunk.Um[kk:kk + 1] if chunk.Um.shape[0] else chunk.Um
        sub = Chunk(chunk.t[kk:kk + 2], chunk.odd[kk:kk + 1], chunk.U0[kk:kk + 1],
                    chunk.U1[kk:kk + 1], um, chunk.force_out[kk:kk + 1])
        Wk = self.state.key.shape[0]
        none = Schedule(np.zeros(0, np.int64), np.zeros(0, np.int64),
                        np.zeros((0, Wk), np.int64), np.zeros((0, Wk), np.int64))
        sp = ivars[IV_SCHED]
        ivars[IV_K] = 0
        ivars[IV_SCHED] = 0
        ivars[IV_INIT] = -1
        while True:
            status = self._dense_call(sub, none)
            if status == STEP_OK:
                break
            if status == STEP_NEED_MODE:
                stack.add(from_words(self.state.need))
                continue
            if status == STEP_FULL:
                rec.reserve(self.max_sw + 3, 2 * self.max_sw + self.k + 6)
                continue
            return self._error(status, dense=True)
        ivars[IV_K] = kk + 1
        ivars[IV_SCHED] = sp
        self.sparse.dense_steps += 1
        return None

    def _hand_over(self) -> None:
        """A mode without a network: the dense kernel takes the rest of the run from this
        grid step, whose schedule has been applied; a note says so."""
        self.run.notes.append(
            "the sparse kernel handed the run to the dense one at "
            f"t = {float(self.fvars[FV_TCUR]):.6g} s (a switch mode without a regular "
            "network matrix)")
        self.sparse.handed_at = int(self.ivars[IV_STEPS])
        self.sparse = None
        self._dense()
        self.ivars[IV_INIT] = -1

    can_set_state = True
    writes_until_full = True  # (the kernels return STEP_FULL)

    def set_state(self, x: np.ndarray) -> None:
        self.state.x[:] = x

    def snapshot(self) -> Snapshot:
        st = self.state
        return Snapshot(float(self.fvars[FV_TCUR]), from_words(st.key), st.x, st.lam,
                        int(self.ivars[IV_SLIDE]), float(self.fvars[FV_DUTY]))

    def stats(self) -> dict:
        iv = self.ivars
        sparse = self._sparse_used
        extra = sparse.stats(int(iv[IV_STEPS])) if sparse else {}
        modes = max(sparse.count if sparse else 0, self.stack.count if self.stack else 0)
        return dict(
            steps=int(iv[IV_STEPS]),
            odd_steps=int(iv[IV_ODD]),
            fallbacks=int(iv[IV_FALLBACKS]),
            warm_solves=int(iv[IV_WARM]),
            lcp_pivots=int(iv[IV_PIVOTS]),
            factorisations=int(iv[IV_MISSES]) + extra.get("factorisations", 0),
            factor_updates=int(iv[IV_UPDATES]),
            uniqueness_checks=int(iv[IV_UNIQ]),
            odd_stored=int(iv[IV_ODDHIT]),
            odd_discretised=int(iv[IV_ODDMISS]),
            located=int(iv[IV_LOCATED]),
            root_evaluations=int(iv[IV_ROOTEVALS]),
            sliding_steps=int(iv[IV_SLIDESTEPS]),
            modes_built=modes,
            kernel="sparse" if sparse else "dense",
            dense_steps=extra.get("dense_steps", 0),
            kernel_time=self._kernel_time,
        )

    def _theta_cause(self, lcs: LCS, s: float) -> str | None:
        """Why the LCP of a step of length ``s`` (s) failed when the mode is passive (the
        system's storage verified) and only θ < 1 at that step makes it ill-posed; else
        None."""
        storage = getattr(self.run.problem.system, "storage", None)
        if storage is None or self.theta >= 1.0:
            return None
        from ...theory.step_uniqueness import longest_unique_step

        longest = longest_unique_step(lcs, storage, self.theta)
        if not 0.0 < longest < s:
            return None
        return failures.theta_cause(self.theta, s, longest)

    def _error(self, status: int, dense: bool = False) -> SimulationError:
        """The :class:`SimulationError` of a kernel failure (``dense``: of the dense kernel,
        in a grid step a sparse run handed to it: its mode ids are the dense stack's)."""
        ivars, fvars, stack, opts = self.ivars, self.fvars, self.stack, self.opts
        problem, plan = self.run.problem, self.run.plan
        t0, t1 = float(fvars[FV_FAIL_T0]), float(fvars[FV_FAIL_T1])
        if self.sparse and not dense:
            stack = self.sparse.builder
        if status in (STEP_LCP_FAILED, STEP_NONUNIQUE, STEP_NONFINITE):
            jf = int(ivars[IV_FAILMODE])
        else:
            jf = stack.index.get(from_words(self.state.key), 0)
        mode = stack.mode_tuple(stack.keys[jf]) if stack.keys else ()
        desc = problem.describe(mode)
        lcs = problem.lcs(mode)
        if status == STEP_LCP_FAILED:
            enum = opts.lcp.method == "auto" and lcs.m <= opts.lcp.enum_max_m
            how = ("Lemke ray termination, confirmed by enumeration" if enum
                   else "Lemke: ray termination or pivot budget exhausted")
            return failures.no_solution(t0, t1, desc, lcs, from_words(self.state.fail), how,
                                        self._theta_cause(lcs, t1 - t0))
        if status == STEP_NONUNIQUE:
            return failures.non_unique(t0, t1, desc, lcs, from_words(self.state.fail),
                                       self._theta_cause(lcs, t1 - t0))
        if status == STEP_NONFINITE:
            # (an input that is not a number there: named, rather than blamed on the mode)
            names = problem.system.inputs
            with np.errstate(all="ignore"):
                u = np.vstack([self.run.table(np.array([t]), side)[0]
                               for t, side in ((t0, 1), (t1, -1))])
            bad = [names[j] for j in np.flatnonzero(~np.isfinite(u).all(axis=0))]
            return failures.non_finite(t0, t1, desc, bad)
        i = int(ivars[IV_FAILSW])
        name = plan.names[i] if 0 <= i < len(plan.names) else "?"
        if status == STEP_CHATTER:
            return failures.chattering(t0, t1, desc, name, opts.max_switchings)
        if status == STEP_SLIDING:
            other = int(ivars[IV_SLIDE])
            return failures.sliding(t0, desc, name, plan.method[i],
                                    plan.names[other] if 0 <= other != i else None)
        raise AssertionError(f"unknown kernel status {status}")  # pragma: no cover


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
    switching: str | None = None,
    save_at: Sequence[float] = (),
    controllers: Sequence = (),
    output_step: float | None = None,
    output_from: float = -np.inf,
    keep_events: int | None = None,
    rows_to=None,
    operating_point: bool = False,
) -> SimulationResult:
    """Simulate a switched LCS with the Moreau θ scheme.

    Parameters
    ----------
    system : SwitchedLCS
        One LCS per switch mode. A switch is driven by independent sources (its control's
        output map has ``Cy = Dy = 0``: instants computed from the waveforms and hit
        exactly), by its comparator (a control that depends on the state: instants located
        inside the steps, see ``switching``), or by a controller (``controllers``).
    signals : sequence of Signal (or vectorised callables ``f(t) -> array``)
        ``signals[j]`` drives input j, already resolved (:func:`lcs.signals.resolve`). A
        callable is evaluated pointwise, on slices of the time grid
        (:mod:`lcs.simulation.inputs`).
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
        know, e.g. ``"v(out)"``, ``"i(D1)"``; ``"d(S1)"`` is the state of switch S1, 1 on and
        0 off, its equivalent duty in [0, 1] while it slides). Default: all states.
    every : int
        Store every ``every``-th grid step (the first and last points are always stored;
        with ``every = 1`` the comparator switching instants too).
    breakpoints : sequence of float
        Extra instants (s) to land on exactly.
    progress : bool
        Show a tqdm progress bar (only when stderr is a terminal and the run is expected to
        last more than about a second).
    on_inconsistent : callable, optional
        ``on_inconsistent(lcs, x, u) -> x_plus`` (or ``(x_plus, note)``, the note then
        replacing the generic one in ``result.notes``) applied once to an inconsistent initial
        state (one whose instantaneous LCP ``w = C x + D λ + F u`` has no solution), e.g.
        built on ``lcs.theory.wellposed.state_jump``. Without it, the first step absorbs the jump.
    options : MoreauOptions, optional
    switching : str, optional
        Overrides ``options.switching``: ``"auto"``, ``"implicit"``, ``"hysteresis"`` or
        ``"explicit"`` (``docs/switching.md``).
    save_at : sequence of float
        Instants (s) at which the probes are stored whatever ``every`` says (they become step
        boundaries), e.g. ``k T`` for a stroboscopic map.
    controllers : sequence of controller objects
        Python controllers (:mod:`lcs.controllers`) driving named switches.
    output_step : float, optional
        Return the stored points at or after ``output_from`` resampled onto the instants
        ``k output_step`` (s): :func:`lcs.results.resample`'s numbers, computed as the run
        goes, so that the run holds its output grid and not every step
        (:mod:`lcs.simulation.regrid`).
    output_from : float
        The first time kept with ``output_step`` (``.tran`` TSTART), s.
    keep_events : int, optional
        Keep only the last ``keep_events`` switchings in ``result.events`` and count the
        earlier ones (:attr:`lcs.results.Events.count`), so that with ``output_step`` the
        run's memory does not grow with its length; None keeps them all.
    rows_to : lcs.simulation.driver.RowStream, optional
        Where the output rows go as the run makes them (a file written as it goes): the
        result then holds the last one (:func:`lcs.simulation.driver.run`).
    operating_point : bool
        Start from the DC operating point of the initial mode (capacitors open, inductors
        shorted: :mod:`lcs.theory.operating_point`), as ngspice's ``.tran`` without ``UIC``;
        ``x0`` then only gives the states that no DC equation sets. Where there is none, the
        run starts from ``x0`` and a note says why.

    Returns
    -------
    SimulationResult
        With ``error`` set if the run stopped early (the result then ends at the last
        completed step); see the module docstring.

    Raises
    ------
    ValueError
        Invalid arguments (θ outside [1/2, 1], h <= 0, wrong shapes, unknown switching
        method).
    NotImplementedError
        A switch that is source-driven in one mode and state-driven in another.
    """
    t_wall = time.perf_counter()
    opts = options or MoreauOptions()
    _check_args(system, signals, x0, t_start, t_stop, h, theta, every)
    return driver.run(_problem(system, probes), list(signals), np.asarray(x0, dtype=float),
                      float(t_start), float(t_stop),
                      MoreauIntegrator(float(h), float(theta), opts), every=int(every),
                      breakpoints=breakpoints, save_at=save_at, progress=progress,
                      on_inconsistent=on_inconsistent,
                      switching=switching or opts.switching, controllers=list(controllers),
                      lcp=opts.lcp, t_wall=t_wall, output_step=output_step,
                      output_from=output_from, keep_events=keep_events, rows_to=rows_to,
                      operating_point=operating_point)


_PROBLEMS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _problem(system: SwitchedLCS, probes) -> Problem:
    """The :class:`Problem` of ``system`` with these probe names, kept with the system (its
    per-mode outputs and arrays are built once for repeated runs); an explicit output map
    gets a new one."""
    if isinstance(probes, OutputMap):
        return Problem(system, probes)
    names = None if probes is None else tuple(probes)
    try:
        per_system = _PROBLEMS.setdefault(system, {})
    except TypeError:  # not weak-referenceable: not kept
        return Problem(system, names)
    problem = per_system.get(names)
    if problem is None:
        if len(per_system) >= 8:
            per_system.pop(next(iter(per_system)))
        problem = per_system[names] = Problem(system, names)
    return problem


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
    save_at: Sequence[float] = (),
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
        return ModeModel(lcs, lambda names: state_outputs(lcs, names))

    system = SwitchedLCS([], lcs.states, lcs.inputs, [pr.name for pr in lcs.pairs], builder)
    _check_args(system, inputs, x0, t_start, t_stop, h, theta, every)
    return driver.run(Problem(system, probes), list(inputs), np.asarray(x0, dtype=float),
                      float(t_start), float(t_stop),
                      MoreauIntegrator(float(h), float(theta), opts), every=int(every),
                      breakpoints=breakpoints, save_at=save_at, progress=progress,
                      on_inconsistent=on_inconsistent, switching=opts.switching,
                      lcp=opts.lcp, t_wall=t_wall)


def _check_args(system, signals, x0, t_start, t_stop, h, theta, every) -> None:
    if not 0.5 <= theta <= 1.0:
        raise ValueError(f"theta must be in [1/2, 1], got {theta}")
    if not (h > 0 and np.isfinite(h)):
        raise ValueError(f"step h must be positive, got {h}")
    driver.check_args(system, signals, x0, t_start, t_stop, every)
