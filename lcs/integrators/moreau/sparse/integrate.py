"""The sparse KKT kernel inside the Moreau integrator: which runs it takes, its mode store
and factorisation cache across runs, and the calls of its grid loop.

:class:`lcs.integrators.moreau.integrator.MoreauIntegrator` asks :func:`choose` in ``prepare``; a
:class:`SparseRun` then advances the chunks, and the integrator hands single grid steps to
the dense kernel when it returns ``STEP_FALLBACK``.
"""

from __future__ import annotations

import weakref

import numpy as np

from lcs.bits import to_words, words
from lcs.simulation.codes import SW_LOCATED, SW_SAMPLED, SWF_LATCH

from ..dense.layout import IV_NMODES
from .grid import run_kkt
from .layout import C_FACTOR, KKTCache
from .stack import NetStackBuilder, NoNetwork, cache_for
from .step import KKTWork, lookup

__all__ = ["SparseRun", "choose", "dense_cost", "kept", "sparse_cost"]

#: the sparse kernel is considered ("auto") from this many states plus pairs, and pairs
AUTO_MIN_SIZE = 48
AUTO_MIN_PAIRS = 8
#: cost of the sparse step per entry of its factors and vectors over the dense step's per
#: matrix entry (indirect, dependent updates against contiguous, vectorised products, and
#: the pivoting steps' further solves), from the voltage multipliers, interleaved bucks and
#: MMC arms of ``converters/scaling.py`` (``benchmarks/bench_scale.py``: both kernels timed)
SPARSE_ENTRY_COST = 10.0
#: room for each factor (L, U) of a cached factorisation, in entries of the largest KKT
#: matrix (grown by STEP_GROW when a factorisation needs more)
CAP_FACTOR = 4
#: step lengths within this fraction of h share factorisations (as the dense kernel's
#: stored shortened steps)
LENGTH_RTOL = 1e-9

_BUILDERS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
STORES_PER_SYSTEM = 8


def dense_cost(A, C, m: int) -> float:
    """Estimated entries the dense kernel reads a step: ``Phi x`` and ``C x`` over their
    non-zeros, then ``M_ia λ_a``, ``K λ_a`` and ``λ_a = G q_a`` with half the pairs active."""
    n = A.shape[0]
    return float(np.count_nonzero(A) + n + np.count_nonzero(C) + (n + m) * m / 2
                 + m * m / 4)


def sparse_cost(lu_entries: int, N: int, n: int, m: int) -> float:
    """Estimated cost of a sparse step in dense-entry units: the KKT solve (its factors'
    entries and its N unknowns), the new state, the pairs' checks."""
    return SPARSE_ENTRY_COST * (lu_entries + N + n + 3 * m)


class SparseRun:
    """The sparse kernel's part of one run: the mode store (kept per system for later runs
    with the same configuration), the factorisation cache and the work arrays."""

    def __init__(self, builder: NetStackBuilder, cache: KKTCache, h: float, opts):
        self.builder = builder
        self.cache = cache
        self.h = h
        self.opts = opts
        self.dense_steps = 0
        self.handed_at = -1  # steps taken when the run went on with the dense kernel
        self.f0 = int(cache.counters[C_FACTOR])
        self.f_done = 0  # factorisations in caches replaced by grow()
        self._work = None

    @property
    def count(self) -> int:
        return self.builder.count

    def add(self, key: int) -> bool:
        """Build the mode of ``key``; False when it has no usable network."""
        try:
            self.builder.add(key)
        except NoNetwork:
            return False
        if self.builder.nmax + 1 > self.cache.Lp.shape[1]:
            self.grow(cap=self.cache.Li.shape[1])
        return True

    def grow(self, cap: int | None = None) -> None:
        """A new cache with room for the largest mode and twice the entries (its
        factorisations are made again as they are needed)."""
        b = self.builder
        cap = cap or 2 * self.cache.Li.shape[1]
        self.f_done += int(self.cache.counters[C_FACTOR]) - self.f0
        self.cache = _new_cache(b, self.opts, cap)
        self.f0 = 0
        _remember(b.prob.system, b, self.cache)
        self._work = None

    def work(self) -> KKTWork:
        b = self.builder
        N = b.nmax
        if self._work is None or self._work.x.shape[0] < N:
            m = b.m
            self._work = KKTWork(np.zeros(N + 1, np.int64), np.zeros(b.tpl_nnz + m, np.int64),
                                 np.zeros(b.tpl_nnz + m), np.zeros(N),
                                 np.zeros(2 * N, np.int64), np.zeros(N, np.int64), np.zeros(N),
                                 np.zeros(N), np.zeros(N), np.zeros(N), np.zeros(b.nzmax),
                                 np.zeros(b.p), np.zeros(m), np.zeros(m), np.zeros(m),
                                 np.zeros(m), np.full(1, -1, np.int64), np.zeros(1, np.int64),
                                 np.zeros(m, np.int64), np.zeros(words(m), np.int64),
                                 np.zeros(m, np.int64), np.zeros(words(m), np.int64))
        return self._work

    def run(self, chunk, sched, state, limits, store) -> int:
        state.ivars[IV_NMODES] = self.builder.count
        return run_kkt(self.builder.arrays(), self.cache, chunk, sched, state, limits, store,
                       self.work(), LENGTH_RTOL * self.h)

    def stats(self, steps: int) -> dict:
        """This run's counters (``steps``: the run's steps so far, of both kernels)."""
        c = self.cache.counters
        handed = steps - self.handed_at if self.handed_at >= 0 else 0
        return dict(factorisations=self.f_done + int(c[C_FACTOR]) - self.f0,
                    dense_steps=self.dense_steps + handed)

    def factor_entries(self, j: int, active: int) -> int:
        """Entries of the factors of mode ``j``'s KKT matrix for a regular step and the active
        set ``active`` (a bitmask), factorised now if not cached; -1 for a singular set."""
        b = self.builder
        mask = to_words(active, words(b.m))
        slot = -1
        for _ in range(4):
            slot = lookup(b.arrays(), self.cache, j, self.h, LENGTH_RTOL * self.h, mask,
                          self.work())
            if slot >= 0:
                break
            self.grow()
        if slot < 0 or self.cache.state[slot] != 0:
            return -1
        N = int(b.arrays().dims[j, 1])
        return int(self.cache.Lp[slot, N] + self.cache.Up[slot, N])


def kept(system) -> list[SparseRun]:
    """The sparse kernel's stores and caches kept for ``system`` (one per configuration run),
    as :class:`SparseRun` objects."""
    try:
        found = list(_BUILDERS.get(system, {}).values())
    except TypeError:
        return []
    return [SparseRun(b, cache, b.h, b.opts) for b, cache in found]


def _remember(system, b: NetStackBuilder, cache: KKTCache) -> None:
    """Keep the store and cache of this configuration for the system's next runs (at most
    :data:`STORES_PER_SYSTEM` configurations per system)."""
    try:
        per_system = _BUILDERS.setdefault(system, {})
    except TypeError:  # not weak-referenceable: no keeping
        return
    if b.cache_key not in per_system and len(per_system) >= STORES_PER_SYSTEM:
        per_system.pop(next(iter(per_system)))
    per_system[b.cache_key] = (b, cache)


def _new_cache(b: NetStackBuilder, opts, cap: int) -> KKTCache:
    nmax = b.nmax + b.k + 8  # (closed switches add branch unknowns in other modes)
    per_slot = 8 * (5 * nmax + 4) + 16 * 2 * cap
    slots = int(min(1024, max(16, int(getattr(opts, "kkt_bytes", 64 << 20)) // per_slot)))
    return cache_for(slots, nmax, cap, words(b.m))


def _builder(run, h: float, theta: float, opts):
    """The mode store and cache of this configuration from an earlier run of the system, or
    new ones."""
    problem, plan, sched = run.problem, run.plan, run.schedule
    system = problem.system
    names = run.recorder.names
    key = (float(h), float(theta), tuple(names), tuple(plan.kind.tolist()),
           tuple(plan.source), int(getattr(opts, "kkt_bytes", 64 << 20)), tuple(run.base))
    try:
        found = _BUILDERS.get(system, {}).get(key)
    except TypeError:  # not weak-referenceable
        found = None
    if found is not None and found[0].prob.probes is problem.probes:
        b, cache = found
        b.src_maps = sched.src_maps
        b.plan = plan
        return b, cache
    n, m, p = len(system.states), len(system.diodes), len(system.inputs)
    b = NetStackBuilder(problem, plan, theta, n, m, p, len(names), sched.src_maps, run.base)
    b.cache_key = key
    b.h, b.opts = float(h), opts
    return b, None


def choose(run, h: float, theta: float, opts) -> SparseRun | None:
    """The sparse kernel's part of this run, or None when the dense kernel takes it: asked
    for (``opts.kernel == "dense"``), or a run the sparse kernel cannot take (comparators,
    latches, no pairs, an initial mode without a network), or ("auto") a small circuit or
    one whose estimated sparse step is dearer (:func:`dense_cost`, :func:`sparse_cost`)."""
    kind = getattr(opts, "kernel", "auto")
    if kind not in ("auto", "dense", "sparse"):
        raise ValueError(f"kernel must be 'auto', 'dense' or 'sparse', got {kind!r}")
    problem, plan = run.problem, run.plan
    system = problem.system
    n, m = len(system.states), len(system.diodes)
    if kind == "dense" or m == 0:
        return None
    if np.any((plan.kind == SW_LOCATED) | (plan.kind == SW_SAMPLED)):
        return None
    if np.any((np.asarray(plan.flags) & SWF_LATCH) != 0):
        return None
    if kind == "auto" and (n + m < AUTO_MIN_SIZE or m < AUTO_MIN_PAIRS):
        return None
    init = run.initial
    net = problem.network(init.mode)
    if net is None:
        return None
    if kind == "auto":
        A, _B, C = problem.mode_arrays(init.mode)[:3]
        dense = dense_cost(A, C, m)
        # (the factors hold at least the network matrix: when even that costs more, no
        # store is built and no kernel loaded)
        if sparse_cost(len(net.Y[0]), net.nz + m, n, m) >= dense:
            return None
    b, cache = _builder(run, h, theta, opts)
    try:
        j = b.add(init.key)
    except NoNetwork:
        return None
    if cache is None or b.nmax + 1 > cache.Lp.shape[1]:
        cache = _new_cache(b, opts, CAP_FACTOR * b.tpl_nnz + 64)
        _remember(system, b, cache)
    sr = SparseRun(b, cache, h, opts)
    if kind == "sparse":
        return sr
    lu = sr.factor_entries(j, init.active)
    if lu >= 0 and sparse_cost(lu, int(b.arrays().dims[j, 1]), n, m) < dense:
        return sr
    return None

