"""Moreau θ time-stepping of (switched) linear complementarity systems.

The scheme is Siconos's ``EulerMoreauOSI(θ)`` for first-order linear systems (θ in [1/2, 1],
default 1/2; the relation is fully implicit, Siconos's γ is not used)::

    W        = (I - h θ A)^-1
    x_free   = W [(I + h(1-θ) A) x_k + h((1-θ) E u(t_k) + θ E u(t_k+1))]
    w_k+1    = (D + h C W B) λ_k+1 + C x_free + F u(t_k+1),     0 <= w ⊥ λ >= 0
    x_k+1    = x_free + h W B λ_k+1

Layers:

* :mod:`lcs.stepping` -- the numba kernel: per-mode matrices stacked by mode id, the whole
  grid of a chunk in one call, mode changes from a schedule (source- and controller-driven
  switches) or from comparators evaluated after each step (instants located inside the step,
  the step split there), the Filippov relay for sliding modes; active-set fast path with
  cached factorisations, numba Lemke and enumeration fallbacks.
* this module -- the driver: breakpoints of the sources, switching instants of source-driven
  switches (:mod:`lcs.events`), the switching method of each comparator, windows between the
  sampling instants of Python controllers (:mod:`lcs.controllers`), chunks of the grid, the
  mode stack (a mode is built the first time the kernel asks for it), outputs, errors. See
  ``docs/switching.md`` for the switching rules and methods.

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

import sys
import time
import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .events import (
    MERGE_FRACTION,
    InputFunction,
    InputTable,
    collect_breakpoints,
    evaluate_inputs,
    grid_chunks,
    has_jumps,
    merge_close,
    plan_grid,
    source_switch_events,
)
from .lcp import LcpOptions, is_p_matrix, solve_lcp
from .lcp.compiled import MAX_MASK_M, ActiveSets
from .model import LCS, ModeKey, ModeModel, OutputMap, SwitchedLCS
from .results import SimulationError, SimulationResult, SimulationStats
from .stepping import discretise, run_grid
from .stepping.layout import (
    EV_SLIDE_END,
    EV_SLIDE_START,
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
    IV_FAILMASK,
    IV_FAILMODE,
    IV_FAILSW,
    IV_FALLBACKS,
    IV_INIT,
    IV_K,
    IV_KEY,
    IV_LASTSW,
    IV_LEN,
    IV_LOCATED,
    IV_MASK,
    IV_MISSES,
    IV_NEED,
    IV_NMODES,
    IV_ODD,
    IV_OUTPOS,
    IV_PIVOTS,
    IV_ROOTEVALS,
    IV_SCHED,
    IV_SLIDE,
    IV_SLIDESTEPS,
    IV_STEPS,
    IV_UNIQ,
    MF_FAST,
    MF_LEN,
    MF_OUTSTATE,
    MF_UNIQ,
    OP_REARM,
    OP_SET,
    PLAIN_MIN,
    STEP_CHATTER,
    STEP_FULL,
    STEP_LCP_FAILED,
    STEP_NEED_MODE,
    STEP_NONFINITE,
    STEP_NONUNIQUE,
    STEP_OK,
    STEP_SLIDING,
    SW_LOCATED,
    SW_SAMPLED,
    SW_SCHEDULED,
    SWF_LATCH,
    SWF_RELAY,
    Chunk,
    Limits,
    ModeArrays,
    ModeStack,
    Schedule,
    Store,
    SwitchArrays,
    mode_shapes,
)

__all__ = [
    "MoreauOptions",
    "SWITCHING_METHODS",
    "SimulationError",
    "SimulationResult",
    "simulate",
    "simulate_lcs",
]

InconsistentHandler = Callable[[LCS, np.ndarray, np.ndarray], object]

# Rough cost model for deciding whether a progress bar is worth showing.
_EST_STEP_S = 0.2e-6
_EST_SEGMENT_S = 0.5e-6

SWITCHING_METHODS = ("auto", "implicit", "hysteresis", "explicit")


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


def _c(a, shape=None) -> np.ndarray:
    arr = np.ascontiguousarray(a, dtype=float)
    return arr.reshape(shape) if shape is not None else arr


@dataclass
class _Output:
    names: tuple[str, ...]
    Cy: np.ndarray
    Dy: np.ndarray
    Fy: np.ndarray
    duty: np.ndarray  # int64 (r,): switch index for "d(S)" probes, -1 otherwise


def _duty_switch(name: str, switches: Sequence[str]) -> int:
    """Index of the switch ``S`` of a probe ``d(S)`` (its on-fraction), or -1."""
    nm = name.strip().lower()
    if nm.startswith("d(") and nm.endswith(")"):
        inner = nm[2:-1].strip()
        for i, s in enumerate(switches):
            if s.lower() == inner:
                return i
    return -1


class _Problem:
    """A switched LCS seen by the driver: LCS and output map per mode, mode names."""

    def __init__(self, system: SwitchedLCS, probes: Sequence[str] | OutputMap | None):
        self.system = system
        self.probes = probes
        self._outputs: dict[ModeKey, _Output] = {}
        self.switch_names = [s.name for s in system.switches]

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
            q = len(om.names)
            Cy, Dy, Fy = _c(om.Cy, (q, n)), _c(om.Dy, (q, m)), _c(om.Fy, (q, p))
            out = _Output(tuple(om.names), Cy, Dy, Fy, np.full(Cy.shape[0], -1, np.int64))
        else:
            names = tuple(self.probes) if self.probes is not None else tuple(lcs.states)
            k = len(names)
            Cy, Dy, Fy = np.zeros((k, n)), np.zeros((k, m)), np.zeros((k, p))
            duty = np.array([_duty_switch(nm, self.switch_names) for nm in names], np.int64)
            lower_states = [s.lower() for s in lcs.states]
            others = [(i, nm) for i, nm in enumerate(names)
                      if nm.lower() not in lower_states and duty[i] < 0]
            for i, nm in enumerate(names):
                if nm.lower() in lower_states:
                    Cy[i, lower_states.index(nm.lower())] = 1.0
            if others:
                om = self.system.outputs(mode, [nm for _, nm in others])
                q = len(others)
                oCy, oDy, oFy = _c(om.Cy, (q, n)), _c(om.Dy, (q, m)), _c(om.Fy, (q, p))
                for r, (i, _) in enumerate(others):
                    Cy[i], Dy[i], Fy[i] = oCy[r], oDy[r], oFy[r]
            out = _Output(names, Cy, Dy, Fy, duty)
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


# ---------------------------------------------------------------------------------------------
# Switches: how each one is driven
# ---------------------------------------------------------------------------------------------


def _opt(options, name: str, default=None):
    if not isinstance(options, dict):
        return default
    for key, val in options.items():
        if str(key).lower() == name:
            return val
    return default


@dataclass
class _Switches:
    """How each switch of a run is driven (see ``docs/switching.md``)."""

    names: tuple[str, ...]
    kind: np.ndarray  # int64 (k,): SW_*
    flags: np.ndarray  # int64 (k,): SWF_*
    vt: np.ndarray  # (k,)
    vh: np.ndarray  # (k,)
    method: list[str]  # per switch: source, controller, implicit, hysteresis, explicit, latched
    source: list[int] = field(default_factory=list)
    scheduled_by: dict = field(default_factory=dict)  # switch index -> schedule controller
    surface: dict = field(default_factory=dict)  # switch index -> surface controller
    latch: dict = field(default_factory=dict)  # switch index -> (period, phase)

    @property
    def source_mask(self) -> int:
        return sum(1 << i for i in self.source)


def _classify_switches(system: SwitchedLCS, controllers, method: str, guess: ModeKey,
                       notes: list[str]) -> _Switches:
    """Kind, flags, thresholds and method of every switch."""
    if method not in SWITCHING_METHODS:
        raise ValueError(f"switching must be one of {', '.join(SWITCHING_METHODS)}, got "
                         f"{method!r}")
    sw = system.switches
    k = len(sw)
    if k > 62:
        raise ValueError(f"{k} switches: at most 62 are supported (mode keys are bitmasks)")
    lower = {s.name.lower(): i for i, s in enumerate(sw)}
    out = _Switches(tuple(s.name for s in sw), np.zeros(k, np.int64), np.zeros(k, np.int64),
                    np.array([float(s.vt) for s in sw]),
                    np.array([abs(float(s.vh)) for s in sw]), [""] * k)
    for ctrl in controllers:
        names = [ctrl.switch] if getattr(ctrl, "kind", "schedule") == "surface" \
            else list(ctrl.switches)
        for nm in names:
            if nm.lower() not in lower:
                raise KeyError(f"controller {type(ctrl).__name__}: no switch {nm!r} (switches: "
                               f"{', '.join(s.name for s in sw) or 'none'})")
            i = lower[nm.lower()]
            if i in out.scheduled_by or i in out.surface:
                raise ValueError(f"switch {sw[i].name} is driven by two controllers")
            if getattr(ctrl, "kind", "schedule") == "surface":
                out.surface[i] = ctrl
            else:
                out.scheduled_by[i] = ctrl
    for i, s in enumerate(sw):
        if i in out.scheduled_by:
            out.kind[i] = SW_SCHEDULED
            out.method[i] = "controller"
            continue
        if i in out.surface:
            ctrl = out.surface[i]
            out.vt[i] = -float(getattr(ctrl, "constant", 0.0))
            out.vh[i] = abs(float(getattr(ctrl, "vh", 0.0)))
            sw_method = getattr(ctrl, "method", None) or method
            explicit_flag = sw_method == "explicit"
            latch = None
        else:
            om = system.outputs(guess, [s.control])
            if not (np.any(np.asarray(om.Cy) != 0) or np.any(np.asarray(om.Dy) != 0)):
                out.kind[i] = SW_SCHEDULED
                out.method[i] = "source"
                out.source.append(i)
                continue
            sw_method = method
            explicit_flag = bool(_opt(s.options, "explicit", 0))
            latch = _opt(s.options, "latch", 0)
        if latch:
            period = float(_opt(s.options, "period", 0.0) or 0.0)
            if not period > 0:
                raise ValueError(f"switch {s.name}: LATCH=1 needs PERIOD=<the clock period> "
                                 "on its .model line")
            phase = float(_opt(s.options, "phase", 0.0) or 0.0)
            out.latch[i] = (period, phase)
            out.kind[i] = SW_LOCATED
            out.flags[i] = SWF_LATCH
            out.method[i] = "latched"
            continue
        if sw_method == "auto":
            if explicit_flag:
                sw_method = "explicit"
            elif out.vh[i] > 0:
                sw_method = "hysteresis"
            else:
                sw_method = "implicit"
        if sw_method == "explicit":
            out.kind[i] = SW_SAMPLED
        elif sw_method == "hysteresis":
            out.kind[i] = SW_LOCATED
        else:  # implicit
            out.kind[i] = SW_LOCATED
            out.flags[i] = SWF_RELAY
            if out.vh[i] > 0:
                notes.append(f"switch {s.name}: switching='implicit' ignores its hysteresis "
                             f"(VH = {out.vh[i]:g})")
                out.vh[i] = 0.0
        out.method[i] = sw_method
    return out


# ---------------------------------------------------------------------------------------------
# The mode stack
# ---------------------------------------------------------------------------------------------


class _Stack:
    """Per-mode matrices stacked by mode id, as the kernel wants them; grows on demand."""

    def __init__(self, prob: _Problem, sws: _Switches, h: float, theta: float,
                 opts: MoreauOptions, n: int, m: int, p: int, r: int, src_maps: dict,
                 base: ModeKey):
        self.prob, self.sws, self.h, self.theta, self.opts = prob, sws, h, theta, opts
        self.n, self.m, self.p, self.r = n, m, p, r
        k = len(sws.names)
        self.k = k
        self.shapes = mode_shapes(n, m, p, r, k)
        self.S = max(1, int(opts.cache_slots))
        self.src_maps = src_maps
        self.base = base
        self.keys: list[int] = []
        self.index: dict[int, int] = {}
        self.lcs: list[LCS] = []
        self.cap = 0
        self.mats = ModeArrays(*(np.zeros((0, *s)) for s in self.shapes))
        self.mkey = np.zeros(0, np.int64)
        self.mflags = np.zeros((0, MF_LEN), np.int64)
        self.ckeys = np.zeros((0, self.S), np.int64)
        self.cna = np.zeros((0, self.S), np.int64)
        self.cidx = np.zeros((0, self.S, m), np.int64)
        self.cG = np.zeros((0, self.S, m, m))
        self._grow(4)

    def _grow(self, cap: int) -> None:
        c = self.count

        def grown(a, fill=0):
            new = np.full((cap, *a.shape[1:]), fill, dtype=a.dtype)
            new[:c] = a[:c]
            return new

        self.mats = ModeArrays(*(grown(a) for a in self.mats))
        self.mkey = grown(self.mkey, -1)
        self.mflags = grown(self.mflags)
        self.ckeys = grown(self.ckeys, -1)
        self.cna = grown(self.cna)
        self.cidx = grown(self.cidx)
        self.cG = grown(self.cG)
        self.cap = cap

    @property
    def count(self) -> int:
        return len(self.keys)

    def mode_tuple(self, key: int) -> ModeKey:
        return tuple(bool((key >> i) & 1) for i in range(self.k))

    def key_of(self, mode: ModeKey) -> int:
        return sum(1 << i for i, on in enumerate(mode) if on)

    def arrays(self) -> ModeStack:
        """The stack as the kernel takes it."""
        return ModeStack(self.mats, ActiveSets(self.ckeys, self.cna, self.cidx, self.cG),
                         self.mkey, self.mflags)

    def add(self, key: int) -> int:
        """Build the mode of ``key`` (switch i on when bit i is set) and append it."""
        if key in self.index:
            return self.index[key]
        mode = self.mode_tuple(key)
        prob, n, m, p = self.prob, self.n, self.m, self.p
        lcs = prob.lcs(mode)
        if lcs.n != n or lcs.m != m or lcs.p != p:
            raise ValueError("all modes must have the same numbers of states, pairs and inputs")
        A, B, C = _c(lcs.A, (n, n)), _c(lcs.B, (n, m)), _c(lcs.C, (m, n))
        D, E, F = _c(lcs.D, (m, m)), _c(lcs.E, (n, p)), _c(lcs.F, (m, p))
        disc = discretise(A, B, C, D, E, self.h, self.theta)
        out = prob.output(mode)
        Cc, Dc, Fc = self._control_rows(mode)
        if self.count == self.cap:
            self._grow(2 * self.cap)
        j = self.count
        for stacked, arr in zip(self.mats, (A, B, C, D, E, F, disc.Phi, disc.G0, disc.G1,
                                            disc.K, disc.M, out.Cy, out.Dy, out.Fy, Cc, Dc,
                                            Fc), strict=True):
            stacked[j] = arr
        fast = bool(self.opts.fast_path and m <= MAX_MASK_M)
        # Enumeration-based uniqueness checks only for small m, and not for P-matrices
        # (unique λ for every q).
        check = 0 < m <= self.opts.uniqueness_max_m and not is_p_matrix(disc.M)
        out_is_state = bool(
            out.Cy.shape == (n, n) and np.array_equal(out.Cy, np.eye(n))
            and not out.Dy.any() and not out.Fy.any() and not (out.duty >= 0).any()
        )
        self.mflags[j, MF_FAST] = int(fast)
        self.mflags[j, MF_UNIQ] = int(m) if check else -1
        self.mflags[j, MF_OUTSTATE] = int(out_is_state)
        self.mkey[j] = key
        self.keys.append(key)
        self.index[key] = j
        self.lcs.append(lcs)
        return j

    def _control_rows(self, mode: ModeKey):
        n, m, p, k = self.n, self.m, self.p, self.k
        Cc, Dc, Fc = np.zeros((k, n)), np.zeros((k, m)), np.zeros((k, p))
        system = self.prob.system
        sws = self.sws
        for i, s in enumerate(system.switches):
            if i in sws.surface:
                ctrl = sws.surface[i]
                terms = dict(ctrl.terms)
                om = system.outputs(mode, list(terms))
                coef = np.array([terms[nm] for nm in terms], dtype=float)
                q = len(coef)
                Cc[i] = coef @ _c(om.Cy, (q, n))
                Dc[i] = coef @ _c(om.Dy, (q, m))
                Fc[i] = coef @ _c(om.Fy, (q, p))
                continue
            if sws.kind[i] == SW_SCHEDULED:
                if i in sws.source:
                    self._check_source_control(i, s, mode)
                continue
            om = system.outputs(mode, [s.control])
            Cc[i] = _c(om.Cy, (1, n))[0]
            Dc[i] = _c(om.Dy, (1, m))[0]
            Fc[i] = _c(om.Fy, (1, p))[0]
        return Cc, Dc, Fc

    def _check_source_control(self, i, s, mode: ModeKey) -> None:
        om = self.prob.system.outputs(mode, [s.control])
        if np.any(np.asarray(om.Cy) != 0) or np.any(np.asarray(om.Dy) != 0):
            raise NotImplementedError(
                f"switch {s.name}: its control {s.control!r} is driven by sources alone in the "
                f"initial mode but depends on the circuit state in mode "
                f"{_fmt_mode(self.prob.describe(mode))}; switches whose kind (source-driven or "
                "comparator) changes with the mode are not supported"
            )
        src = set(self.sws.source)
        ref_mode = tuple(on if j in src else self.base[j] for j, on in enumerate(mode))
        rows = self.src_maps.get(ref_mode)
        if rows is not None and not np.allclose(rows[i], np.asarray(om.Fy).ravel(),
                                                rtol=1e-12, atol=0.0):
            raise NotImplementedError(
                f"switch {s.name}: its gate {s.control!r} depends on the state of a "
                "comparator-driven switch; source-driven instants are computed with the "
                "comparators in their initial states, so this is not supported"
            )


# Mode stacks kept per system for the next run with the same configuration (parameter sweeps
# re-run one system many times: the per-mode matrices, discretisations and active-set
# factorisations are reused). At most _STACKS_PER_SYSTEM configurations per system.
_STACK_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_STACKS_PER_SYSTEM = 8


def _cached_stack(prob: _Problem, sws: _Switches, h, theta, opts: MoreauOptions, n, m, p,
                  names, src_maps, guess) -> _Stack:
    if isinstance(prob.probes, OutputMap):
        probe_key = ("outputmap", id(prob.probes))
    else:
        probe_key = tuple(names)
    surf = tuple(sorted((i, tuple(sorted(dict(c.terms).items())))
                        for i, c in sws.surface.items()))
    key = (float(h), float(theta), probe_key, tuple(sws.kind.tolist()), surf,
           tuple(sws.source), bool(opts.fast_path), int(opts.cache_slots),
           int(opts.uniqueness_max_m), tuple(guess))
    try:
        per_system = _STACK_CACHE.setdefault(prob.system, {})
    except TypeError:  # not weak-referenceable: no caching
        per_system = {}
    stack = per_system.get(key)
    if stack is not None and (isinstance(prob.probes, OutputMap)
                              and stack.prob.probes is not prob.probes):
        stack = None
    if stack is None:
        stack = _Stack(prob, sws, h, theta, opts, n, m, p, len(names), src_maps, guess)
        if len(per_system) >= _STACKS_PER_SYSTEM:
            per_system.pop(next(iter(per_system)))
        per_system[key] = stack
    else:
        stack.src_maps = src_maps
        stack.sws = sws
    return stack


def _outputs_now(stack: _Stack, j: int, x, lam, u, names_rows=None) -> np.ndarray:
    M = stack.mats
    y = M.Cy[j] @ x + M.Dy[j] @ lam + M.Fy[j] @ u
    return y


# ---------------------------------------------------------------------------------------------
# Entry points
# ---------------------------------------------------------------------------------------------


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
        built on ``lcs.wellposed.state_jump``. Without it, the first step absorbs the jump.
    options : MoreauOptions, optional
    switching : str, optional
        Overrides ``options.switching``: ``"auto"``, ``"implicit"``, ``"hysteresis"`` or
        ``"explicit"`` (``docs/switching.md``).
    save_at : sequence of float
        Instants (s) at which the probes are stored whatever ``every`` says (they become step
        boundaries), e.g. ``k T`` for a stroboscopic map.
    controllers : sequence of controller objects
        Python controllers (:mod:`lcs.controllers`) driving named switches.

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
    return _run(_Problem(system, probes), list(signals), np.asarray(x0, dtype=float),
                float(t_start), float(t_stop), float(h), float(theta), int(every),
                breakpoints, save_at, progress, on_inconsistent, opts,
                switching or opts.switching, list(controllers), t_wall)


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
        return ModeModel(lcs, lambda names: _state_outputs(lcs, names))

    system = SwitchedLCS([], lcs.states, lcs.inputs, [pr.name for pr in lcs.pairs], builder)
    _check_args(system, inputs, x0, t_start, t_stop, h, theta, every)
    return _run(_Problem(system, probes), list(inputs), np.asarray(x0, dtype=float),
                float(t_start), float(t_stop), float(h), float(theta), int(every),
                breakpoints, save_at, progress, on_inconsistent, opts, opts.switching, [],
                t_wall)


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


# ---------------------------------------------------------------------------------------------
# The run
# ---------------------------------------------------------------------------------------------


def _initially_on(options) -> bool:
    """A switch's netlist ``ON``/``OFF`` (``options["initial"]`` or ``options["on"]``)."""
    val = _opt(options, "initial", _opt(options, "on"))
    return bool(val) if val is not None else False


def _periodic(period: float, phase: float, t0: float, t1: float) -> np.ndarray:
    """``phase + j period`` strictly inside (t0, t1)."""
    j0 = int(np.floor((t0 - phase) / period))
    j1 = int(np.ceil((t1 - phase) / period))
    t = phase + period * np.arange(j0, j1 + 1)
    return t[(t > t0) & (t < t1)]


class _Measure:
    """Probe values for a controller at a sampling instant."""

    def __init__(self, system: SwitchedLCS, names: Sequence[str]):
        self.names = tuple(names)
        self.prob = _Problem(system, self.names)

    def __call__(self, stack: _Stack, key: int, x, lam, u, slide: int, duty: float) -> dict:
        if not self.names:
            return {}
        out = self.prob.output(stack.mode_tuple(key))
        y = out.Cy @ x + out.Dy @ lam + out.Fy @ u
        for r, i in enumerate(out.duty):
            if i >= 0:
                y[r] = duty if i == slide else float((key >> int(i)) & 1)
        return dict(zip(self.names, (float(v) for v in y), strict=True))


def _row(stack: _Stack, j: int, key: int, slide: int, duty: float, x, lam, u) -> np.ndarray:
    M = stack.mats
    y = M.Cy[j] @ x + M.Dy[j] @ lam + M.Fy[j] @ u
    out = stack.prob.output(stack.mode_tuple(key))
    for r, i in enumerate(out.duty):
        if i >= 0:
            y[r] = duty if i == slide else float((key >> int(i)) & 1)
    return y


def _run(prob: _Problem, inputs, x0, t_start, t_stop, h, theta, every, user_bps, save_at,
         progress, on_inconsistent, opts: MoreauOptions, method: str, controllers,
         t_wall) -> SimulationResult:
    notes: list[str] = []
    system = prob.system
    k = len(system.switches)
    guess = tuple(_initially_on(s.options) for s in system.switches)
    sws = _classify_switches(system, controllers, method, guess, notes)
    tol = 2 * MERGE_FRACTION * h

    # --- breakpoints, source-driven instants, latch period starts --------------------------
    save_at = np.unique(np.asarray(save_at, dtype=float).ravel())
    save_at = save_at[(save_at > t_start) & (save_at <= t_stop)]
    # Schedule entries (time, op, a, b) as arrays: latch re-arms, then source events.
    lt, li = [np.empty(0)], [np.empty(0, np.int64)]
    for i, (per, ph) in sws.latch.items():
        tt = _periodic(per, ph, t_start, t_stop)
        lt.append(tt)
        li.append(np.full(len(tt), i, np.int64))
    latch_t, latch_i = np.concatenate(lt), np.concatenate(li)
    extra = np.concatenate([np.asarray(user_bps, dtype=float).ravel(), save_at, latch_t])
    bps = merge_close(collect_breakpoints(inputs, t_start, t_stop, extra), MERGE_FRACTION * h)
    src_maps: dict = {}
    if k:
        mode_src, (src_t, src_k) = source_switch_events(system, inputs, t_start, t_stop, bps,
                                                        h, which=sws.source, base=guess,
                                                        maps_out=src_maps, as_arrays=True)
    else:
        mode_src, src_t, src_k = (), np.empty(0), np.empty(0, np.int64)
    smask = sws.source_mask
    st_t = np.concatenate([src_t, latch_t])
    st_op = np.concatenate([np.full(len(src_t), OP_SET, np.int64),
                            np.full(len(latch_t), OP_REARM, np.int64)])
    st_a = np.concatenate([np.full(len(src_t), smask, np.int64), latch_i])
    st_b = np.concatenate([src_k & smask, np.zeros(len(latch_t), np.int64)])
    order = np.lexsort((st_op, st_t))
    st_t, st_op, st_a, st_b = st_t[order], st_op[order], st_a[order], st_b[order]

    # --- the mode stack and the initial mode -------------------------------------------------
    key = sum(1 << i for i, on in enumerate(mode_src) if on)
    lcs0 = prob.lcs(tuple(mode_src) if k else ())
    n, m, p = lcs0.n, lcs0.m, lcs0.p
    out0 = prob.output(tuple(mode_src) if k else ())
    names = out0.names
    stack = _cached_stack(prob, sws, h, theta, opts, n, m, p, names, src_maps, guess)
    x = np.array(x0, dtype=float)
    u0 = evaluate_inputs(inputs, np.array([t_start]), +1)[0]

    def initial_lcp(j):
        if not m:
            return None
        Dm, Cm, Fm = stack.mats.D[j], stack.mats.C[j], stack.mats.F[j]
        return solve_lcp(Dm, Cm @ x + Fm @ u0, opts.lcp)

    comparators = [i for i in range(k) if sws.kind[i] != SW_SCHEDULED]
    pending: list[tuple[float, int, int, int]] = []
    sched_ctrls = list({id(c): c for c in sws.scheduled_by.values()}.values())
    measures = {id(c): _Measure(system, getattr(c, "probes", ())) for c in sched_ctrls}
    for ctrl in sched_ctrls:
        if hasattr(ctrl, "reset"):
            ctrl.reset(t_start, t_stop)
    # Sampling instants of each controller (decisions also at t_start).
    ctrl_samples = {}
    for ctrl in sched_ctrls:
        ts = np.asarray(ctrl.sample_times(t_start, t_stop) if hasattr(ctrl, "sample_times")
                        else (), dtype=float).ravel()
        ctrl_samples[id(ctrl)] = np.unique(ts[(ts > t_start + tol) & (ts < t_stop - tol)])
    for _ in range(k + 2):
        j = stack.add(key)
        res0 = initial_lcp(j)
        lam = res0.z.copy() if (res0 is not None and res0.ok) else np.zeros(m)
        if not comparators:
            break
        c = stack.mats.Cc[j] @ x + stack.mats.Dc[j] @ lam + stack.mats.Fc[j] @ u0
        new = key
        for i in comparators:
            on = bool((key >> i) & 1)
            if sws.flags[i] & SWF_LATCH:
                on = c[i] >= sws.vt[i] - sws.vh[i]
            elif c[i] > sws.vt[i] + sws.vh[i]:
                on = True
            elif c[i] < sws.vt[i] - sws.vh[i]:
                on = False
            new = (new | (1 << i)) if on else (new & ~(1 << i))
        if new == key:
            break
        key = new
    if sched_ctrls:
        key, pending = _controller_commands(sched_ctrls, [t_start], t_start, stack, key, x,
                                            lam, u0, -1, 0.0, measures, sws, tol, pending)
        j = stack.add(key)
        res0 = initial_lcp(j)
        lam = res0.z.copy() if (res0 is not None and res0.ok) else np.zeros(m)
    mode0 = stack.mode_tuple(key)
    lcs_j = stack.lcs[j]
    if res0 is not None and not res0.ok:
        if on_inconsistent is not None:
            handled = on_inconsistent(lcs_j, x.copy(), u0.copy())
            note = None
            if isinstance(handled, tuple):  # (x_plus, note): the handler explains itself
                handled, note = handled
            x_new = np.asarray(handled, dtype=float)
            if x_new.shape != x.shape or not np.all(np.isfinite(x_new)):
                raise ValueError(
                    f"on_inconsistent returned {x_new!r}; expected a finite state of shape "
                    f"{x.shape}"
                )
            notes.append(note or (
                f"initial state {np.array2string(x, precision=6)} is inconsistent (the LCP "
                f"w = C x + D λ + F u at t = {t_start:g} s has no solution); replaced by "
                f"{np.array2string(x_new, precision=6)} (on_inconsistent)"
            ))
            x = x_new
            res0 = initial_lcp(j)
        if not res0.ok:
            notes.append(
                f"initial state is inconsistent (the LCP w = C x + D λ + F u at "
                f"t = {t_start:g} s has no solution): λ(t0) is reported as 0 and the first "
                "step absorbs the state jump"
            )
    lam = res0.z.copy() if (res0 is not None and res0.ok) else np.zeros(m)
    lama = np.zeros(m)

    # --- kernel state and buffers ------------------------------------------------------------
    ivars = np.zeros(IV_LEN, np.int64)
    fvars = np.zeros(FV_LEN)
    fvars[FV_RTOL] = opts.accept_rtol
    fvars[FV_PIVOT_TOL] = opts.lcp.pivot_tol
    fvars[FV_LEX_TOL] = opts.lcp.lex_tol
    fvars[FV_UNIQ_TOL] = opts.uniqueness_tol
    fvars[FV_FEAS_TOL] = opts.lcp.feas_tol
    fvars[FV_H] = h
    fvars[FV_THETA] = theta
    fvars[FV_ROOT_TOL] = opts.root_tol
    fvars[FV_TCUR] = t_start
    fvars[FV_LASTT] = -np.inf
    ivars[IV_KEY] = key
    ivars[IV_SLIDE] = -1
    ivars[IV_LASTSW] = -1
    if res0 is not None and res0.ok and res0.basis is not None and m <= 62:
        ivars[IV_MASK] = int(sum(1 << i for i in np.flatnonzero(res0.basis)))
    max_piv = opts.lcp.pivots_for(m)
    enum_max_m = int(opts.lcp.enum_max_m) if opts.lcp.method == "auto" else -1
    max_sw = max(1, int(opts.max_switchings))
    est_steps = int((t_stop - t_start) / h) + len(bps) + 2
    cap = est_steps // every + len(save_at) + 64
    T_out = np.empty(cap)
    Y_out = np.empty((cap, len(names)))
    ev_cap = len(st_t) + 4 * max_sw + 2 * k + 256
    ev_t = np.empty(ev_cap)
    ev_key = np.empty(ev_cap, np.int64)
    ev_info = np.empty(ev_cap, np.int64)
    duty_sw = np.ascontiguousarray(out0.duty, dtype=np.int64)
    T_out[0] = t_start
    Y_out[0] = _row(stack, j, key, -1, 0.0, x, lam, u0)
    ivars[IV_OUTPOS] = 1
    jumps = has_jumps(inputs)
    table = InputTable(inputs, t_start, t_stop)
    sw_kind = np.ascontiguousarray(sws.kind)
    sw_arrays = SwitchArrays(sw_kind, np.ascontiguousarray(sws.flags),
                             np.ascontiguousarray(sws.vt), np.ascontiguousarray(sws.vh))
    limits = Limits(max_piv, enum_max_m, every, max_sw)
    # The kernel's plain loop only for runs with no comparator (None: compiled without it).
    # (and only when the schedule leaves long runs of steps between its entries: the branch
    # slows the steps it does not take).
    plain_mode = (None if (np.any((sw_kind == SW_LOCATED) | (sw_kind == SW_SAMPLED))
                           or est_steps < 2 * PLAIN_MIN * (len(st_t) + 1))
                  else True)

    # --- windows between controller sampling instants ---------------------------------------
    samples = list(ctrl_samples.values())
    samp = np.unique(np.concatenate(samples)) if samples else np.empty(0)
    samp = merge_close(samp[(samp > t_start + tol) & (samp < t_stop - tol)], tol)
    wins = np.concatenate(([t_start], samp, [t_stop]))
    error: SimulationError | None = None
    bar = _progress_bar(bool(progress) and sys.stderr.isatty()
                        and est_steps * _EST_STEP_S + len(st_t) * _EST_SEGMENT_S > 1.0,
                        est_steps)
    try:
        for w in range(len(wins) - 1):
            ws, we = float(wins[w]), float(wins[w + 1])
            if w > 0 and sched_ctrls:
                u_ws = table(np.array([ws]), +1)[0]
                key_now = int(ivars[IV_KEY])
                due = []
                for c in sched_ctrls:
                    cs_ = ctrl_samples[id(c)]
                    i_ = np.searchsorted(cs_, ws - tol)
                    if i_ < len(cs_) and abs(cs_[i_] - ws) <= tol:
                        due.append(c)
                _, pending = _controller_commands(due, [ws], ws, stack, key_now, x, lam, u_ws,
                                                  int(ivars[IV_SLIDE]), float(fvars[FV_DUTY]),
                                                  measures, sws, tol, pending, apply=False)
            lo = np.searchsorted(st_t, ws - tol, side="left")
            hi = np.searchsorted(st_t, we - tol, side="left")
            e_t, e_op, e_a, e_b = st_t[lo:hi], st_op[lo:hi], st_a[lo:hi], st_b[lo:hi]
            if pending:
                now = [e for e in pending if e[0] < we - tol]
                pending = [e for e in pending if e[0] >= we - tol]
                if now:
                    e_t = np.concatenate([e_t, [max(e[0], ws) for e in now]])
                    e_op = np.concatenate([e_op, np.array([e[1] for e in now], np.int64)])
                    e_a = np.concatenate([e_a, np.array([e[2] for e in now], np.int64)])
                    e_b = np.concatenate([e_b, np.array([e[3] for e in now], np.int64)])
                    order = np.lexsort((e_op, e_t))
                    e_t, e_op, e_a, e_b = e_t[order], e_op[order], e_a[order], e_b[order]
            inner_bps = bps[(bps > ws) & (bps < we)]
            bounds = np.unique(np.concatenate(([ws, we], inner_bps,
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
            for tg, odd, _seg in grid_chunks(plan, opts.chunk_steps):
                if jumps:
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
                sel = (e_t >= tg[0] - tol) & (e_t < tg[-1] - tol)
                idx = np.searchsorted(tg, e_t[sel] - tol, side="left")
                if idx.size and np.any(np.abs(tg[idx] - e_t[sel]) > max(tol, 1e-15 * we)):
                    raise AssertionError("a scheduled switching instant is not a grid point")
                sched_k = np.ascontiguousarray(idx, dtype=np.int64)
                sched_op = np.ascontiguousarray(e_op[sel])
                sched_a = np.ascontiguousarray(e_a[sel])
                sched_b = np.ascontiguousarray(e_b[sel])
                force = np.zeros(N, np.bool_)
                if save_at.size:
                    pos_s = np.searchsorted(tg[1:], save_at - tol, side="left")
                    ok = pos_s < N
                    hit = ok & (np.abs(tg[1:][np.minimum(pos_s, N - 1)] - save_at) <= tol)
                    force[pos_s[hit]] = True
                ivars[IV_K] = 0
                ivars[IV_SCHED] = 0
                ivars[IV_INIT] = -1
                while True:
                    ivars[IV_NMODES] = stack.count
                    status = run_grid(
                        stack.arrays(), sw_arrays, Chunk(tg, odd, U0, U1, Um, force),
                        Schedule(sched_k, sched_op, sched_a, sched_b), x, lam, lama, ivars,
                        fvars, limits, Store(T_out, Y_out, duty_sw, ev_t, ev_key, ev_info),
                        plain_mode,
                    )
                    if status == STEP_OK:
                        break
                    if status == STEP_NEED_MODE:
                        stack.add(int(ivars[IV_NEED]))
                        continue
                    if status == STEP_FULL:
                        if ivars[IV_OUTPOS] + max_sw + 3 > len(T_out):
                            T_out = _grow(T_out, 2 * len(T_out) + max_sw)
                            Y_out = _grow(Y_out, len(T_out))
                        need = int(ivars[IV_EVPOS]) + 2 * max_sw + k + 6 + len(sched_k)
                        if need > len(ev_t):
                            new = 2 * len(ev_t) + need
                            ev_t, ev_key, ev_info = (_grow(a, new) for a in (ev_t, ev_key,
                                                                              ev_info))
                        continue
                    error = _kernel_error(status, stack, prob, sws, ivars, fvars, opts)
                    break
                if error is not None:
                    break
                if bar is not None:
                    bar.update(N)
            if error is not None:
                break
    finally:
        if bar is not None:
            bar.close()

    t_last = float(fvars[FV_TCUR])
    key = int(ivars[IV_KEY])
    slide = int(ivars[IV_SLIDE])
    pos = int(ivars[IV_OUTPOS])
    if T_out[pos - 1] != t_last:
        # Always keep the last completed step.
        j = stack.index.get(key, None)
        if j is None:
            j = stack.add(key)
        u_last = evaluate_inputs(inputs, np.array([t_last]), -1)[0]
        if pos >= len(T_out):
            T_out = _grow(T_out, pos + 1)
            Y_out = _grow(Y_out, pos + 1)
        T_out[pos] = t_last
        Y_out[pos] = _row(stack, j, key, slide, float(fvars[FV_DUTY]), x, lam, u_last)
        pos += 1
    events, sliding, visited = _collect_events(stack, sws, ev_t, ev_key, ev_info,
                                               int(ivars[IV_EVPOS]), mode0, t_last)
    stats = SimulationStats(
        steps=int(ivars[IV_STEPS]),
        odd_steps=int(ivars[IV_ODD]),
        fallbacks=int(ivars[IV_FALLBACKS]),
        lcp_pivots=int(ivars[IV_PIVOTS]),
        factorisations=int(ivars[IV_MISSES]),
        uniqueness_checks=int(ivars[IV_UNIQ]),
        intervals=len(events) + 1,
        located=int(ivars[IV_LOCATED]),
        root_evaluations=int(ivars[IV_ROOTEVALS]),
        sliding_steps=int(ivars[IV_SLIDESTEPS]),
        modes_built=stack.count,
        wall_time=time.perf_counter() - t_wall,
    )
    # The buffers were sized for the whole run: slice them (a copy of a large run costs as
    # much as the stepping), unless the run stopped early and most of them is unused.
    t_res, y_res = T_out[:pos], Y_out[:pos]
    if 2 * pos < len(T_out):
        t_res, y_res = t_res.copy(), y_res.copy()
    result = SimulationResult(
        t=t_res,
        names=tuple(names),
        y=y_res,
        x_final=x.copy(),
        lambda_final=lam.copy(),
        modes_visited=visited,
        events=events,
        stats=stats,
        notes=notes,
        error=error,
        sliding=sliding,
        switching={nm: md for nm, md in zip(sws.names, sws.method, strict=True)},
    )
    if error is not None:
        error.result = result
    return result


def _grow(a: np.ndarray, n: int) -> np.ndarray:
    new = np.empty((n, *a.shape[1:]), dtype=a.dtype)
    new[: len(a)] = a
    return new


def _controller_commands(ctrls, times, t, stack: _Stack, key: int, x, lam, u, slide, duty,
                         measures, sws: _Switches, tol, pending, apply: bool = True):
    """Ask the controllers sampled at ``t`` for their commands. Commands at ``t`` itself are
    applied to ``key`` when ``apply`` (the initial instant), the others become schedule
    entries ``(time, OP_SET, mask, bits)`` in ``pending``."""
    lower = {nm.lower(): i for i, nm in enumerate(sws.names)}
    pending = list(pending)
    for ctrl in ctrls:
        values = measures[id(ctrl)](stack, key, x, lam, u, slide, duty)
        for tc, states in ctrl.decide(t, values):
            mask = bits = 0
            for nm, on in states.items():
                i = lower[nm.lower()]
                if sws.scheduled_by.get(i) is not ctrl:
                    raise ValueError(f"controller {type(ctrl).__name__} commands switch {nm}, "
                                     "which it does not drive")
                mask |= 1 << i
                bits |= (1 << i) if on else 0
            if apply and tc <= t + tol:
                key = (key & ~mask) | bits
            else:
                pending.append((max(float(tc), t), OP_SET, mask, bits))
    pending.sort(key=lambda e: e[0])
    return key, pending


def _collect_events(stack: _Stack, sws: _Switches, ev_t, ev_key, ev_info, count, mode0,
                    t_last):
    """Mode changes ``[(t, mode)]``, sliding intervals ``[(switch, t_start, t_end)]`` and the
    modes in order of first use, from the kernel's event records."""
    t = ev_t[:count]
    keys = ev_key[:count]
    info = ev_info[:count]
    keep = t <= t_last
    t, keys, info = t[keep], keys[keep], info[keep]
    k0 = stack.key_of(mode0)
    prev = np.concatenate(([k0], keys[:-1]))
    change = keys != prev
    tuples: dict[int, ModeKey] = {}
    ct = t[change].tolist()
    ck = keys[change].tolist()
    events = []
    for tt, kk in zip(ct, ck, strict=True):
        md = tuples.get(kk)
        if md is None:
            md = tuples[kk] = stack.mode_tuple(kk)
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
            sliding.append((sws.names[sw], open_slide.pop(sw, tt), tt))
        else:
            open_slide[i - EV_SLIDE_START] = tt
    for i, t0 in open_slide.items():
        sliding.append((sws.names[i], t0, None))
    return events, sliding, visited


def _kernel_error(status, stack: _Stack, prob: _Problem, sws: _Switches, ivars, fvars,
                  opts: MoreauOptions) -> SimulationError:
    """The :class:`SimulationError` of a kernel failure."""
    t0, t1 = float(fvars[FV_FAIL_T0]), float(fvars[FV_FAIL_T1])
    if status in (STEP_LCP_FAILED, STEP_NONUNIQUE, STEP_NONFINITE):
        jf = int(ivars[IV_FAILMODE])
    else:
        jf = stack.index.get(int(ivars[IV_KEY]), 0)
    mode = stack.mode_tuple(stack.keys[jf]) if stack.keys else ()
    desc = prob.describe(mode)
    lcs = stack.lcs[jf]
    where = f"t = {t1:.9g} s (step from {t0:.9g} s), mode: {_fmt_mode(desc)}"
    if status == STEP_LCP_FAILED:
        pairs = _pair_names(lcs, int(ivars[IV_FAILMASK]))
        m = lcs.m
        enum = opts.lcp.method == "auto" and m <= opts.lcp.enum_max_m
        how = ("Lemke ray termination, confirmed by enumeration" if enum
               else "Lemke: ray termination or pivot budget exhausted")
        msg = (
            f"{where}: the complementarity problem of the time step has no solution ({how}). "
            f"Diodes involved: {', '.join(pairs) or '(none with negative w at λ = 0)'} "
            "(with every diode off they would be forward-biased, or carry a reverse current, "
            "and no combination of conducting diodes satisfies the circuit). The circuit is "
            "probably ill-posed in this mode: not passive (a negative resistance, an active "
            "controlled source), or a loop of diodes and voltage sources, or a cut-set of "
            "diodes and current sources."
        )
        return SimulationError(msg, kind="no_solution", time=t1, t_prev=t0, mode=desc,
                               pairs=pairs)
    if status == STEP_NONUNIQUE:
        pairs = _pair_names(lcs, int(ivars[IV_FAILMASK]))
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
    i = int(ivars[IV_FAILSW])
    name = sws.names[i] if 0 <= i < len(sws.names) else "?"
    if status == STEP_CHATTER:
        msg = (
            f"switch {name} at t = {t0:.9g} s (mode: {_fmt_mode(desc)}): more than "
            f"{opts.max_switchings} comparator switchings inside one step of the grid "
            f"(up to {t1:.9g} s): the comparator chatters. Check its control and threshold, "
            "add hysteresis (VH > 0) or raise MoreauOptions.max_switchings."
        )
        return SimulationError(msg, kind="chattering", time=t1, t_prev=t0, mode=desc,
                               switch=name)
    if status == STEP_SLIDING:
        other = int(ivars[IV_SLIDE])
        if other >= 0 and other != i:
            why = (f"switch {sws.names[other]} is already sliding; pelcs handles one sliding "
                   "switch at a time")
        else:
            why = (f"its method is {sws.method[i]!r}, which has no sliding mode; use "
                   "switching='implicit' (the Filippov solution), a hysteresis band VH > 0, or "
                   "switching='explicit'")
        msg = (
            f"switch {name} toggles without progress at t = {t0:.9g} s (mode: "
            f"{_fmt_mode(desc)}): the trajectory is on an attractive switching surface of its "
            f"comparator (a sliding mode); {why}."
        )
        return SimulationError(msg, kind="sliding", time=t0, t_prev=t0, mode=desc,
                               switch=name)
    raise AssertionError(f"unknown kernel status {status}")  # pragma: no cover
