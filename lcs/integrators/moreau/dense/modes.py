"""The Moreau integrator's mode stack: per switch mode, the LCS, its θ discretisation, the
probe and control rows and an active-set cache, stacked by mode id as the kernel takes them
(:class:`~lcs.integrators.moreau.dense.layout.ModeStack`), built the first time the kernel asks for
a mode.

Stacks are kept per system for the next run with the same configuration: parameter sweeps
and maps re-run one system many times, and reuse the matrices, the discretisations and the
active-set factorisations.
"""

from __future__ import annotations

import contextlib
import weakref

import numpy as np

from lcs.bits import to_words, words
from lcs.lcp import is_p_matrix
from lcs.lcp.compiled import ActiveSets
from lcs.model import LCS, ModeKey, OutputMap
from lcs.simulation.inputs import SNAP_FRACTION
from lcs.simulation.problem import Problem, mode_tuple
from lcs.simulation.switches import SwitchPlan

from .discretise import discretise
from .layout import (
    IV_LEN,
    MF_FAST,
    MF_IMAGE,
    MF_LEN,
    MF_OUTSTATE,
    MF_UNIQ,
    ODD_SETS,
    ModeArrays,
    ModeStack,
    OddSteps,
    mode_shapes,
)


class ModeStackBuilder:
    """Per-mode matrices stacked by mode id; grows on demand.

    Parameters
    ----------
    problem : Problem
    plan : SwitchPlan
    h, theta : float
        The regular step (s) and θ.
    opts : MoreauOptions
    n, m, p, r : int
        States, pairs, inputs, stored probes.
    src_maps : dict
        Source-driven switches' control rows per mode (for the checks of
        :meth:`Problem.control_rows`).
    base : ModeKey
        The guessed initial switch states.
    """

    def __init__(self, problem: Problem, plan: SwitchPlan, h: float, theta: float, opts,
                 n: int, m: int, p: int, r: int, src_maps: dict, base: ModeKey):
        self.prob, self.plan, self.h, self.theta, self.opts = problem, plan, h, theta, opts
        self.n, self.m, self.p, self.r = n, m, p, r
        k = len(plan.names)
        self.k = k
        self.shapes = mode_shapes(n, m, p, r, k)
        self.S = cache_slots(int(opts.cache_slots), m, k)
        self.Wk, self.Wm = words(k), words(m)
        self.src_maps = src_maps
        self.base = base
        self.keys: list[int] = []
        self.index: dict[int, int] = {}
        self.lcs: list[LCS] = []
        self.cap = 0
        self.mats = ModeArrays(*(np.zeros((0, *s)) for s in self.shapes))
        self.mkey = np.zeros((0, self.Wk), np.int64)
        self.mflags = np.zeros((0, MF_LEN), np.int64)
        self.minp = np.zeros((0, p + 1), np.int64)
        self.mspan = np.zeros((0, 2, n, 2), np.int64)
        self.ckeys = np.zeros((0, self.S, self.Wm), np.int64)
        self.cna = np.zeros((0, self.S), np.int64)
        self.cidx = np.zeros((0, self.S, m), np.int64)
        self.cG = np.zeros((0, self.S, m, m))
        self.OS = odd_slots(n, m, p, int(getattr(opts, "odd_slots", ODD_SLOTS)))
        OS = self.OS
        self.odd = OddSteps(
            np.zeros((0, OS)), np.zeros((0, n, n)), np.zeros((0, n, p)), np.zeros((0, n, p)),
            np.zeros((0, m, n)), np.zeros((0, m, m)), np.zeros(0, np.int64),
            ActiveSets(np.zeros((0, ODD_SETS, self.Wm), np.int64),
                       np.zeros((0, ODD_SETS), np.int64), np.zeros((0, ODD_SETS, m), np.int64),
                       np.zeros((0, ODD_SETS, m, m))),
            np.zeros(IV_LEN, np.int64))
        self._grow(4)

    def _grow(self, cap: int) -> None:
        with _small_pages():
            self._grow_arrays(cap)

    def _grow_arrays(self, cap: int) -> None:
        c = self.count

        def grown(a, fill=0, per=1):
            # (``per`` rows a mode: the stored shortened steps hold OS slots a mode.)
            # np.zeros maps zeroed pages lazily: the active-set caches (2 MiB a mode) cost
            # nothing until used, where np.full wrote them all on every doubling.
            shape = (cap * per, *a.shape[1:])
            new = np.zeros(shape, a.dtype) if fill == 0 else np.full(shape, fill, a.dtype)
            new[:c * per] = a[:c * per]
            return new

        self.mats = ModeArrays(*(grown(a) for a in self.mats))
        self.mkey = grown(self.mkey)
        self.mflags = grown(self.mflags)
        self.minp = grown(self.minp)
        self.mspan = grown(self.mspan)
        self.ckeys = grown(self.ckeys)
        self.cna = grown(self.cna, -2)  # (-2: an empty cache slot)
        self.cidx = grown(self.cidx)
        self.cG = grown(self.cG)
        OS = self.OS
        o = self.odd
        self.odd = OddSteps(
            grown(o.s, -1.0), *(grown(a, per=OS) for a in (o.Phi, o.G0, o.G1, o.KT, o.M)),
            grown(o.next),
            ActiveSets(grown(o.sets.keys, per=OS), grown(o.sets.na, -2, OS),
                       grown(o.sets.idx, per=OS), grown(o.sets.G, per=OS)),
            o.counters)
        self.cap = cap

    def reserve(self, cap: int) -> None:
        """Room for ``cap`` modes (zeroed lazily: memory is touched as modes are built)."""
        if cap > self.cap:
            self._grow(int(cap))

    @property
    def count(self) -> int:
        return len(self.keys)

    def mode_tuple(self, key: int) -> ModeKey:
        return mode_tuple(key, self.k)

    def arrays(self) -> ModeStack:
        """The stack as the kernel takes it."""
        return ModeStack(self.mats, ActiveSets(self.ckeys, self.cna, self.cidx, self.cG),
                         self.mkey, self.mflags, self.odd, self.minp, self.mspan)

    def add(self, key: int) -> int:
        """Build the mode of ``key`` (switch i on when bit i is set) and append it; returns its
        id."""
        if key in self.index:
            return self.index[key]
        mode = self.mode_tuple(key)
        prob, n, m = self.prob, self.n, self.m
        A, B, C, D, E, F = prob.mode_arrays(mode)
        E = np.asarray(E, dtype=float)
        used = np.flatnonzero(np.any(E != 0, axis=0) | np.any(np.asarray(F) != 0, axis=0))
        # (the inputs outside the dynamics, gate drives, have zero columns of G0, G1: the
        # elimination runs over the others only; 129 -> 1 right-hand sides on a 64-cell MMC)
        disc = discretise(A, B, C, D, E[:, used], self.h, self.theta)
        p = E.shape[1]
        for name in ("G0", "G1"):
            full = np.zeros((n, p))
            full[:, used] = getattr(disc, name)
            setattr(disc, name, full)
        out = prob.output(mode)
        Cc, Dc, Fc = prob.control_rows(mode, self.plan, self.src_maps, self.base)
        if self.count == self.cap:
            self._grow(4 * self.cap)  # (fewer copies of the caches as modes accrue)
        j = self.count
        for stacked, arr in zip(self.mats, (A, B, C, D, E, F, disc.Phi, disc.G0, disc.G1,
                                            disc.K, disc.M, out.Cy, out.Dy, out.Fy, Cc, Dc,
                                            Fc, disc.Phi.T, np.asarray(C).T, disc.K.T,
                                            disc.M.T),
                                strict=True):
            stacked[j] = arr
        fast = bool(self.opts.fast_path)
        # Enumeration-based uniqueness checks only for small m, and not for P-matrices
        # (unique λ for every q).
        check = 0 < m <= self.opts.uniqueness_max_m and not is_p_matrix(disc.M)
        out_is_state = bool(
            out.Cy.shape == (n, n) and np.array_equal(out.Cy, np.eye(n))
            and not out.Dy.any() and not out.Fy.any() and not (out.duty >= 0).any()
        )
        self.mflags[j, MF_FAST] = int(fast)
        self.mflags[j, MF_UNIQ] = int(m) if check else -1
        self.mflags[j, MF_IMAGE] = int(check and self._image_unique(mode))
        self.mflags[j, MF_OUTSTATE] = int(out_is_state)
        self.minp[j, 0] = used.size
        self.minp[j, 1:1 + used.size] = used
        self.mspan[j, 0] = column_spans(disc.Phi)
        self.mspan[j, 1] = column_spans(C)
        self.mkey[j] = to_words(key, self.Wk)
        self.keys.append(key)
        self.index[key] = j
        self.lcs.append(prob.lcs(mode))
        return j

    def _image_unique(self, mode: ModeKey) -> bool:
        """Whether every step of ``mode`` has a unique next state whatever its λ
        (:func:`lcs.theory.step_uniqueness.unique_next_state` with the system's storage): its
        solutions then need no enumeration for another next state. Steps are at most
        ``(1 + SNAP_FRACTION) h`` long (a remainder below ``SNAP_FRACTION h`` joins the last
        regular step: :mod:`lcs.integrators.moreau.dense.gridplan`); the bound is taken with that
        margin twice."""
        storage = getattr(self.prob.system, "storage", None)
        if storage is None:
            return False
        from lcs.theory.step_uniqueness import unique_next_state

        s_max = (1.0 + 2.0 * SNAP_FRACTION) * self.h
        return unique_next_state(self.prob.lcs(mode), storage, s_max, self.theta)


def column_spans(a) -> np.ndarray:
    """Per column of ``a`` (r, c): the row of its first non-zero entry and the row past its
    last, (c, 2) int64; (0, 0) for a zero column."""
    nz = np.asarray(a) != 0
    r = nz.shape[0]
    spans = np.zeros((nz.shape[1], 2), np.int64)
    if r == 0:
        return spans
    any_ = nz.any(axis=0)
    spans[:, 0] = np.where(any_, nz.argmax(axis=0), 0)
    spans[:, 1] = np.where(any_, r - nz[::-1].argmax(axis=0), 0)
    return spans


@contextlib.contextmanager
def _small_pages():
    """Allocate without numpy's transparent-huge-page advice (numpy asks for 2 MiB pages on
    arrays of 4 MiB and more). The stacks are reserved large and written sparsely (a mode's
    row, a factorised cache slot): with huge pages every first write zeroes and maps 2 MiB,
    which on a 64-phase interleaved buck made the run touch 930 MB and spend 1.5 s in the
    kernel's page faults, against 590 MB and 0.5 s with 4 KiB pages."""
    core = getattr(np, "_core", None) or getattr(np, "core", None)  # (numpy 2 / 1.x)
    setter = getattr(getattr(core, "multiarray", None), "_set_madvise_hugepage", None)
    if setter is None:
        yield
        return
    previous = setter(False)
    try:
        yield
    finally:
        setter(previous)


# Memory for the stored discretisations of shortened steps of one mode, and their number.
ODD_BYTES_PER_MODE = 4 << 20
ODD_SLOTS = 8


def odd_slots(n: int, m: int, p: int, wanted: int = ODD_SLOTS) -> int:
    """Stored shortened-step discretisations per mode: ``wanted``, fewer when they (with their
    :data:`~lcs.integrators.moreau.dense.layout.ODD_SETS` active-set factorisations) would take more
    than
    :data:`ODD_BYTES_PER_MODE` (0 when one slot alone would, or when ``wanted`` is 0)."""
    if wanted <= 0:
        return 0
    size = 8 * (n * n + 2 * n * p + n * m + (1 + ODD_SETS) * m * m)
    # (none when one slot alone is over the budget: a very large circuit discretises its
    # shortened steps afresh rather than keep 10 MiB a mode)
    return min(wanted, ODD_BYTES_PER_MODE // max(1, size))


# Memory for the active-set factorisations of one mode: fewer cache slots for large m. With
# few switches (few modes) the modes share CACHE_BYTES_TOTAL instead: a diode network's
# active sets cycle through dozens of sets a period (a 100-stage Cockcroft-Walton multiplier,
# 200 pairs: 6 slots refactorised 13,000 sets in 200 periods, 64 slots 2,750).
CACHE_BYTES_PER_MODE = 2 << 20
CACHE_BYTES_TOTAL = 64 << 20


def cache_slots(wanted: int, m: int, switches: int = 64) -> int:
    """Active-set cache slots per mode: ``wanted``, fewer when ``m x m`` factorisations would
    take more than :data:`CACHE_BYTES_PER_MODE` a mode, or :data:`CACHE_BYTES_TOTAL` over
    the ``2**switches`` modes when that is more (at least 4). (The slots are zeroed pages:
    memory is used as sets are factorised.)"""
    budget = max(CACHE_BYTES_PER_MODE, CACHE_BYTES_TOTAL >> min(int(switches), 40))
    fit = budget // max(1, 8 * m * m)
    return max(1, min(int(wanted), max(4, fit)))


_STACK_CACHE: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_STACKS_PER_SYSTEM = 8


def cached_stack(problem: Problem, plan: SwitchPlan, h, theta, opts, n, m, p, names, src_maps,
                 guess) -> ModeStackBuilder:
    """The stack of this configuration kept from an earlier run of the same system, or a new
    one (at most ``_STACKS_PER_SYSTEM`` configurations per system are kept)."""
    if isinstance(problem.probes, OutputMap):
        probe_key = ("outputmap", id(problem.probes))
    else:
        probe_key = tuple(names)
    surf = tuple(sorted((i, tuple(sorted(dict(c.terms).items())))
                        for i, c in plan.surface.items()))
    key = (float(h), float(theta), probe_key, tuple(plan.kind.tolist()), surf,
           tuple(plan.source), bool(opts.fast_path), int(opts.cache_slots),
           int(getattr(opts, "odd_slots", ODD_SLOTS)),
           int(opts.uniqueness_max_m), tuple(guess))
    try:
        per_system = _STACK_CACHE.setdefault(problem.system, {})
    except TypeError:  # not weak-referenceable: no caching
        per_system = {}
    stack = per_system.get(key)
    if stack is not None and (isinstance(problem.probes, OutputMap)
                              and stack.prob.probes is not problem.probes):
        stack = None
    if stack is None:
        stack = ModeStackBuilder(problem, plan, h, theta, opts, n, m, p, len(names), src_maps,
                                 guess)
        if len(per_system) >= _STACKS_PER_SYSTEM:
            per_system.pop(next(iter(per_system)))
        per_system[key] = stack
    else:
        stack.src_maps = src_maps
        stack.plan = plan
    return stack
