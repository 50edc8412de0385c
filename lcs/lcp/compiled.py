"""The LCP of a time step, compiled: one interface over the active-set fast path, Lemke and
enumeration, for use inside numba integration loops (no allocation, no Python).

A step's LCP ``w = M λ + q, 0 <= w ⊥ λ >= 0`` usually has the same active set ``a`` (the pairs
whose λ is basic) as the step before. The integrators therefore try, in order:

1. :func:`solve_cached` -- the previous active set with a cached ``-(M_aa)^-1`` (regular steps:
   ``M`` is fixed per mode, so its factorisations are kept per active set in an
   :class:`ActiveSets` cache);
2. :func:`solve_warm` -- when it is not accepted (regular steps), block principal pivoting
   from it: the few pairs that changed are flipped and the new bases factorised through the
   same cache;
3. :func:`solve_basis` -- the previous active set by a direct solve of the basis (steps of
   another length, whose ``M`` is new);
4. :func:`solve_pivoting` -- Lemke with lexicographic tie-breaking, then every complementary
   basis when Lemke fails and ``m`` is small (:func:`enumerate_nb`).

An active set is accepted when ``λ_a >= -rtol |λ_a|_max`` and ``w_i >= -rtol Σ|terms|`` off
``a``: round-off, not modelling, accuracy. Active sets are bitsets of any size: int64 arrays
of :func:`words` words (bit ``i & 63`` of word ``i >> 6``: pair i active).

:func:`distinct_images` enumerates every solution to tell whether they map to different
states ``x = x_free + K λ`` (non-uniqueness that matters).
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..bits import bit as bit
from ..bits import clear_bits, from_int, set_bit, words
from ..jit import inline, kernel
from .lemke import LEMKE_SOLVED, LEMKE_TRIVIAL, lemke_nb

MAX_ENUM_M = 62  # enumeration runs over int64 bitmasks (and 2^m bases: tiny m only)
# Active sets of at least UPDATE_MIN_NA pairs, within UPDATE_MAX_FLIPS flips of a cached set,
# are factorised by rank-one updates of its inverse.
UPDATE_MIN_NA = 16
UPDATE_MAX_FLIPS = 6

# Entries of the integer counters array the cache updates (the integrators' counters arrays
# keep these two indices for it).
AS_NEXT_SLOT = 1  # next cache slot to (re)use, round robin over every mode's cache
AS_MISSES = 9  # cache misses (factorisations)
AS_UPDATES = 26  # of which by rank-one updates of a cached neighbour

ActiveSets = namedtuple("ActiveSets", ["keys", "na", "idx", "G"])
ActiveSets.__doc__ = """Cached factorisations of Q LCP matrices (stacked ``M (Q, m, m)``, one per
switch mode), ``S`` active sets each.

For matrix ``j``: ``keys[j] (S, W)`` the active-set bitset of each slot; ``na[j] (S,)`` its size
(-1: the principal submatrix is singular, no fast path; -2: an empty slot); ``idx[j] (S, m)`` the
active indices first, then the others; ``G[j] (S, m, m)`` the transpose of ``-(M_aa)^-1`` in
its top-left ``na x na`` block (stored transposed so that ``λ_a = -(M_aa)^-1 q_a`` is summed a
column at a time over contiguous memory: the same sums, in the same order, as row by row; the
loops vectorise). (Indexing the stacks with ``j`` inside the loops, rather than taking views
per matrix, keeps reference counting out of the steps.)
"""

LcpWork = namedtuple("LcpWork", ["z", "w", "active", "tableau", "basis", "aug", "mask",
                                 "prev", "za", "wv", "ws"])
LcpWork.__doc__ = """Work arrays of the LCP solvers, for ``m`` pairs: of the pivoting and basis
solvers ``z, w (m,)``, ``active (m,) bool``, ``tableau (m, 2m + 2)``, ``basis (m,) int64``,
``aug (m, m + 1)``, two bitsets ``mask, prev (W,)``; of the cached path (:func:`solve_cached`,
:func:`solve_warm`) ``λ_a`` into ``za (m,)``, the inactive pairs' ``w`` into ``wv (m,)`` and
its scale into ``ws (m,)``."""


def lcp_work(m: int) -> LcpWork:
    """Allocate the work arrays of :class:`LcpWork` for ``m`` pairs."""
    return LcpWork(np.zeros(m), np.zeros(m), np.zeros(m, np.bool_), np.zeros((m, 2 * m + 2)),
                   np.zeros(m, np.int64), np.zeros((m, m + 1)), np.zeros(words(m), np.int64),
                   np.zeros(words(m), np.int64), np.zeros(m), np.zeros(m), np.zeros(m))


@kernel
def factor_active(M, j, mask, slot, sets):
    """Store ``-(M_aa)^-1`` of matrix ``M[j]`` and the index split of active set ``mask`` in
    cache slot ``slot`` of matrix ``j``.

    ``sets.na[j, slot] = -1`` marks a singular ``M_aa`` (no fast path for that set).
    """
    cna, cidx, cG = sets.na[j], sets.idx[j], sets.G[j]
    M = M[j]
    m = M.shape[0]
    na = 0
    for i in range(m):
        if bit(mask, i):
            cidx[slot, na] = i
            na += 1
    ni = na
    for i in range(m):
        if not bit(mask, i):
            cidx[slot, ni] = i
            ni += 1
    if na == 0:
        cna[slot] = 0
        return
    # Gauss-Jordan with partial pivoting on [M_aa | I].
    aug = np.zeros((na, 2 * na))
    amax = 0.0
    for i in range(na):
        for j in range(na):
            v = M[cidx[slot, i], cidx[slot, j]]
            aug[i, j] = v
            if abs(v) > amax:
                amax = abs(v)
        aug[i, na + i] = 1.0
    for c in range(na):
        p = c
        for r in range(c + 1, na):
            if abs(aug[r, c]) > abs(aug[p, c]):
                p = r
        if abs(aug[p, c]) <= 1e-13 * amax:
            cna[slot] = -1
            return
        if p != c:
            for j in range(2 * na):
                tmp = aug[c, j]
                aug[c, j] = aug[p, j]
                aug[p, j] = tmp
        piv = aug[c, c]
        for j in range(2 * na):
            aug[c, j] /= piv
        for r in range(na):
            if r != c:
                f = aug[r, c]
                if f != 0.0:
                    for j in range(2 * na):
                        aug[r, j] -= f * aug[c, j]
    for i in range(na):
        for j in range(na):
            cG[slot, j, i] = -aug[i, na + j]
    cna[slot] = na


@kernel
def lookup(M, j, mask, sets, counters):
    """Cache slot of active set ``mask`` of matrix ``M[j]``, factorising it on a miss
    (``counters``: see :data:`AS_NEXT_SLOT`, :data:`AS_MISSES`)."""
    S = sets.keys.shape[1]
    W = sets.keys.shape[2]
    for s in range(S):
        if sets.na[j, s] == -2:
            continue
        same = True
        for w in range(W):
            if sets.keys[j, s, w] != mask[w]:
                same = False
                break
        if same:
            return s
    s = counters[AS_NEXT_SLOT]
    counters[AS_NEXT_SLOT] = (s + 1) % S
    counters[AS_MISSES] += 1
    # A large set a few flips away from a cached one: rank-one updates of its inverse
    # (O(k na²) instead of O(na³)).
    src = -1
    nbits = 0
    for w in range(W):
        nbits += _popcount_word(mask[w])
    if nbits >= UPDATE_MIN_NA:
        best = UPDATE_MAX_FLIPS + 1
        for r in range(S):
            if r == s or sets.na[j, r] < 0:
                continue
            dist = 0
            for w in range(W):
                dist += _popcount_word(sets.keys[j, r, w] ^ mask[w])
            if dist < best:
                best = dist
                src = r
    for w in range(W):
        sets.keys[j, s, w] = mask[w]
    if src >= 0 and factor_update(M, j, mask, s, src, sets):
        counters[AS_UPDATES] += 1
        return s
    factor_active(M, j, mask, s, sets)
    return s


@kernel
def _popcount_word(v):
    c = 0
    while v != 0:
        v &= v - 1
        c += 1
    return c


@kernel
def factor_update(M, j, mask, slot, src, sets):
    """Factorise active set ``mask`` of ``M[j]`` into cache ``slot`` from the cached set of
    slot ``src`` by rank-one updates of the inverse: a removed index deletes its row and
    column (``H - H[:, r] H[r, :] / H[r, r]``, in place after swapping it to the last
    position), an added one borders the matrix with its Schur complement. Returns False
    (nothing trusted) when a pivot is small or the result fails a residual check; the caller
    then factorises from scratch."""
    m = M.shape[1]
    Mj = M[j]
    na0 = sets.na[j, src]
    cidx = sets.idx
    nbits = 0
    for w in range(mask.shape[0]):
        nbits += _popcount_word(mask[w])
    cap = max(na0, nbits, 1)
    H = np.empty((cap, cap))
    lst = np.empty(m, np.int64)
    na = na0
    for a in range(na0):
        lst[a] = cidx[j, src, a]
    for b in range(na0):
        for a in range(na0):
            H[a, b] = -sets.G[j, src, b, a]
    u = np.empty(cap)
    v = np.empty(cap)
    mcol = np.empty(cap)
    # Removals: the index to remove is swapped to the last position, and the leading block
    # updated in place (row by row, contiguous).
    r = 0
    while r < na:
        e = lst[r]
        if bit(mask, e):
            r += 1
            continue
        last = na - 1
        if r != last:
            for b in range(na):
                t = H[r, b]
                H[r, b] = H[last, b]
                H[last, b] = t
            for a in range(na):
                t = H[a, r]
                H[a, r] = H[a, last]
                H[a, last] = t
            lst[r] = lst[last]
            lst[last] = e
        piv = H[last, last]
        # (the pivot against its own row and column, as they are now: earlier removals may
        # have grown the entries)
        scale = 0.0
        for b in range(na):
            scale = max(scale, abs(H[last, b]), abs(H[b, last]))
        if not abs(piv) > 1e-10 * scale:
            return False
        for a in range(last):
            f = H[a, last] / piv
            if f != 0.0:
                for b in range(last):
                    H[a, b] -= f * H[last, b]
        na = last
    # Additions.
    for e in range(m):
        if not bit(mask, e):
            continue
        present = False
        for a in range(na):
            if lst[a] == e:
                present = True
                break
        if present:
            continue
        for b in range(na):
            mcol[b] = Mj[lst[b], e]
        for a in range(na):
            s_ = 0.0
            for b in range(na):
                s_ += H[a, b] * mcol[b]
            u[a] = s_
            v[a] = 0.0
        for b in range(na):
            coef = Mj[e, lst[b]]
            if coef != 0.0:
                for a in range(na):
                    v[a] += coef * H[b, a]
        sch = Mj[e, e]
        scale = abs(Mj[e, e])
        for a in range(na):
            sch -= Mj[e, lst[a]] * u[a]
            scale += abs(Mj[e, lst[a]] * u[a])
        if not abs(sch) > 1e-10 * scale:
            return False
        for a in range(na):
            ua = u[a] / sch
            if ua != 0.0:
                for b in range(na):
                    H[a, b] += ua * v[b]
            H[a, na] = -u[a] / sch
            H[na, a] = -v[a] / sch
        H[na, na] = 1.0 / sch
        lst[na] = e
        na += 1
    # Residual check on one column: M_aa H e_0 = e_0.
    if na > 0:
        res = 0.0
        ref = 0.0
        for a in range(na):
            acc = 0.0
            for b in range(na):
                t = Mj[lst[a], lst[b]] * H[b, 0]
                acc += t
                ref += abs(t)
            res = max(res, abs(acc - (1.0 if a == 0 else 0.0)))
        if not res <= 1e-9 * max(1.0, ref):
            return False
    k = na
    for i in range(m):
        if not bit(mask, i):
            cidx[j, slot, k] = i
            k += 1
    for a in range(na):
        cidx[j, slot, a] = lst[a]
    for b in range(na):
        for a in range(na):
            sets.G[j, slot, b, a] = -H[a, b]
    sets.na[j, slot] = na
    return True


@kernel
def mask_of(active, mask):
    """The bitset ``mask`` of a boolean active-set vector."""
    clear_bits(mask)
    for i in range(active.shape[0]):
        if active[i]:
            set_bit(mask, i)


@inline
def active_lambda(sets, j, slot, na, q, za):
    """``λ_a = -(M_aa)^-1 q_a`` of cache ``slot`` of matrix ``j`` into ``za[:na]``, a column
    of the stored transpose at a time (each entry sums its terms in the order of a row-by-row
    product); returns ``max |λ_a|``."""
    cidx = sets.idx
    GT = sets.G
    for ii in range(na):
        za[ii] = 0.0
    for jj in range(na):
        qj = q[cidx[j, slot, jj]]
        for ii in range(na):
            za[ii] += GT[j, slot, jj, ii] * qj
    zmax = 0.0
    for ii in range(na):
        if abs(za[ii]) > zmax:
            zmax = abs(za[ii])
    return zmax


@inline
def _inactive_w(M, MT, columns, j, cidx, slot, na, q, za, wv, ws):
    """``wv = q + M[j][:, a] λ_a`` and its scale ``ws = |q| + Σ |M[j][:, a] λ_a|`` at the
    inactive pairs of cache ``slot``: with ``columns`` for every pair, a column of the
    transpose ``MT[j]`` at a time (the terms in the order of a row-by-row sum, so the same
    numbers; one dependent dot product per pair does not vectorise), else row by row from
    ``M[j]``."""
    m = q.shape[0]
    if columns:
        for i in range(m):
            wv[i] = q[i]
            ws[i] = abs(q[i])
        for jj in range(na):
            c = cidx[j, slot, jj]
            z = za[jj]
            for i in range(m):
                t = MT[j, c, i] * z
                wv[i] += t
                ws[i] += abs(t)
        return
    for ii in range(na, m):
        i = cidx[j, slot, ii]
        v = q[i]
        sc = abs(v)
        for jj in range(na):
            t = M[j, i, cidx[j, slot, jj]] * za[jj]
            v += t
            sc += abs(t)
        wv[i] = v
        ws[i] = sc


@inline
def solve_cached(M, MT, columns, j, q, sets, slot, za, rtol, wv, ws):
    """The active set of cache ``slot`` of matrix ``j`` (see :class:`ActiveSets`) for
    ``w = M[j] λ + q``.

    Returns its size ``na`` with ``λ_a`` in ``za[:na]`` (in the order
    ``sets.idx[j, slot, :na]``), or -1 when the set is singular or not accepted. The inactive
    pairs' ``w`` and its scale go to ``wv``, ``ws`` (m,) (:func:`_inactive_w`; ``columns``:
    from the transpose ``MT``).
    """
    m = q.shape[0]
    na = sets.na[j, slot]
    if na < 0:
        return -1
    cidx = sets.idx
    zmax = active_lambda(sets, j, slot, na, q, za)
    for ii in range(na):
        if za[ii] < -rtol * zmax:
            return -1
    _inactive_w(M, MT, columns, j, cidx, slot, na, q, za, wv, ws)
    for ii in range(na, m):
        i = cidx[j, slot, ii]
        if wv[i] < -rtol * ws[i]:
            return -1
    return na


@kernel
def solve_warm(M, MT, columns, j, q, mask, sets, counters, rtol, max_iter, work):
    """Block principal pivoting from the active set ``mask`` (Júdice–Pires, with Murty's
    single-index rule when the number of infeasibilities stops decreasing) for
    ``w = M[j] λ + q``, each basis factorised through the cache of matrix ``j``.

    A step's active set is usually a few flips away from the previous step's: each iteration
    flips the infeasible pairs (``λ_a < 0`` in the set, ``w < 0`` out of it) and solves the
    new basis, a cached factorisation when the set was seen before; a flip that makes the
    basis singular is undone and the pivoting goes on one index at a time. Finite for
    P-matrices; stops after ``max_iter`` iterations otherwise. Returns ``(slot, na)`` of the
    solution's cache slot (``λ_a`` in ``work.za[:na]``, ``mask`` its active set), or
    ``(-1, 0)``. ``work`` (:class:`LcpWork`): ``basis`` and the bitset ``prev`` are work space;
    with ``columns`` the inactive pairs' ``w`` is summed from the transpose ``MT`` into
    ``wv``, ``ws`` as in :func:`solve_cached`.
    """
    za = work.za
    viol = work.basis
    prev = work.prev
    wv = work.wv
    ws = work.ws
    m = q.shape[0]
    best = m + 1
    tries = 0
    for it in range(max_iter):
        slot = lookup(M, j, mask, sets, counters)
        na = sets.na[j, slot]
        if na < 0:
            if tries > 3:
                return -1, 0
            if it == 0:
                # (the previous step's set is singular here, e.g. a pair's λ changed meaning
                # with the mode: start from every λ = 0)
                for w in range(mask.shape[0]):
                    mask[w] = 0
                continue
            # A singular basis: back to the last one, one index at a time from there.
            for w in range(mask.shape[0]):
                mask[w] = prev[w]
            tries = 4
            continue
        cidx = sets.idx
        zmax = active_lambda(sets, j, slot, na, q, za)
        nv = 0
        for ii in range(na):
            if za[ii] < -rtol * zmax:
                viol[nv] = cidx[j, slot, ii]
                nv += 1
        _inactive_w(M, MT, columns, j, cidx, slot, na, q, za, wv, ws)
        for ii in range(na, m):
            i = cidx[j, slot, ii]
            if wv[i] < -rtol * ws[i]:
                viol[nv] = i
                nv += 1
        if nv == 0:
            return slot, na
        _pivot(mask, prev, viol, nv, best, tries)
        if nv < best:
            best = nv
            tries = 0
        elif tries < 3:
            tries += 1
    return -1, 0


@inline
def _pivot(mask, prev, viol, nv, best, tries):
    """Flip the ``nv`` infeasible indices ``viol`` in ``mask`` (the block rule while the count
    decreases, or for three more tries), else only the smallest (Murty's rule); the set before
    is kept in ``prev``."""
    for w in range(mask.shape[0]):
        prev[w] = mask[w]
    if nv < best or tries < 3:
        for e in range(nv):
            flip = viol[e]
            mask[flip >> 6] ^= np.int64(1) << (flip & 63)
    else:
        low = viol[0]
        for e in range(1, nv):
            if viol[e] < low:
                low = viol[e]
        mask[low >> 6] ^= np.int64(1) << (low & 63)


@kernel
def basis_solution(M, q, mask, z, aug):
    """Solve the complementary basis ``mask`` (``w_a = 0``, ``z_n = 0``) into ``z``.

    Returns False for a (numerically) singular basis.
    """
    m = q.shape[0]
    na = 0
    idx = np.empty(m, np.int64)
    for i in range(m):
        z[i] = 0.0
        if bit(mask, i):
            idx[na] = i
            na += 1
    if na == 0:
        return True
    amax = 0.0
    for i in range(na):
        for j in range(na):
            v = M[idx[i], idx[j]]
            aug[i, j] = v
            if abs(v) > amax:
                amax = abs(v)
        aug[i, na] = -q[idx[i]]
    for c in range(na):
        p = c
        for r in range(c + 1, na):
            if abs(aug[r, c]) > abs(aug[p, c]):
                p = r
        if abs(aug[p, c]) <= 1e-11 * amax:
            return False
        if p != c:
            for j in range(na + 1):
                tmp = aug[c, j]
                aug[c, j] = aug[p, j]
                aug[p, j] = tmp
        for r in range(c + 1, na):
            f = aug[r, c] / aug[c, c]
            if f != 0.0:
                for j in range(c, na + 1):
                    aug[r, j] -= f * aug[c, j]
    for i in range(na - 1, -1, -1):
        s = aug[i, na]
        for j in range(i + 1, na):
            s -= aug[i, j] * z[idx[j]]
        z[idx[i]] = s / aug[i, i]
    return True


@inline
def solve_basis(M, q, mask, work, lam, rtol):
    """The active set ``mask`` for ``w = M λ + q`` by a direct solve of its basis.

    Returns True with ``λ`` in ``lam`` (negative round-off clipped to 0) when the basis is
    regular and accepted.
    """
    m = q.shape[0]
    z = work.z
    if not basis_solution(M, q, mask, z, work.aug):
        return False
    zmax = 0.0
    for i in range(m):
        if abs(z[i]) > zmax:
            zmax = abs(z[i])
    for i in range(m):
        if z[i] < -rtol * zmax:
            return False
    for i in range(m):
        if bit(mask, i):
            continue
        v = q[i]
        sc = abs(v)
        for jj in range(m):
            t = M[i, jj] * z[jj]
            v += t
            sc += abs(t)
        if v < -rtol * sc:
            return False
    for i in range(m):
        lam[i] = z[i] if z[i] > 0.0 else 0.0
    return True


@kernel
def solve_warm_direct(M, q, mask, work, lam, rtol, max_iter, viol):
    """:func:`solve_warm` for a matrix without a cache (a step of another length): the same
    pivoting, each basis solved directly (:func:`basis_solution`). Returns True with λ in
    ``lam`` (negative round-off clipped to 0) and the active set in ``mask``."""
    m = q.shape[0]
    z = work.z
    prev = work.prev
    best = m + 1
    tries = 0
    for it in range(max_iter):
        if not basis_solution(M, q, mask, z, work.aug):
            if tries > 3:
                return False
            if it == 0:
                for w in range(mask.shape[0]):
                    mask[w] = 0
                continue
            for w in range(mask.shape[0]):
                mask[w] = prev[w]
            tries = 4
            continue
        zmax = 0.0
        for i in range(m):
            if abs(z[i]) > zmax:
                zmax = abs(z[i])
        nv = 0
        for i in range(m):
            if bit(mask, i):
                if z[i] < -rtol * zmax:
                    viol[nv] = i
                    nv += 1
                continue
            v = q[i]
            sc = abs(v)
            for jj in range(m):
                t = M[i, jj] * z[jj]
                v += t
                sc += abs(t)
            if v < -rtol * sc:
                viol[nv] = i
                nv += 1
        if nv == 0:
            for i in range(m):
                lam[i] = z[i] if z[i] > 0.0 else 0.0
            return True
        _pivot(mask, prev, viol, nv, best, tries)
        if nv < best:
            best = nv
            tries = 0
        elif tries < 3:
            tries += 1
    return False


@kernel
def _popcount(v):
    c = 0
    while v:
        v &= v - 1
        c += 1
    return c


@kernel
def enumerate_nb(M, q, feas_tol, z, w, aug, bits):
    """Try every complementary basis, fewest active pairs first (the compiled twin of
    :func:`lcs.lcp.enumerate_lcp`; ``m <= MAX_ENUM_M``). Returns True with the solution in
    ``z`` and its basis in the bitset ``bits``, or False when there is none."""
    m = q.shape[0]
    for cnt in range(m + 1):
        for mask in range(1 << m):
            if _popcount(mask) != cnt:
                continue
            from_int(mask, bits)
            if not basis_solution(M, q, bits, z, aug):
                continue
            zs = 0.0
            for i in range(m):
                if abs(z[i]) > zs:
                    zs = abs(z[i])
            ok = True
            for i in range(m):
                if z[i] < -feas_tol * zs:
                    ok = False
                    break
                wi = q[i]
                sc = abs(q[i])
                for j in range(m):
                    t = M[i, j] * z[j]
                    wi += t
                    sc += abs(t)
                w[i] = wi
                if wi < -feas_tol * sc:
                    ok = False
                    break
            if ok:
                for i in range(m):
                    if z[i] < 0.0:
                        z[i] = 0.0
                return True
    return False


@kernel
def solve_pivoting(M, q, work, max_piv, pivot_tol, lex_tol, feas_tol, enum_max_m, lam, mask):
    """Lemke, then enumeration (``m <= enum_max_m``) when Lemke fails.

    Returns ``(ok, pivots, lemke_status)``: with ``ok``, the active set of the solution in the
    bitset ``mask`` and its λ in ``lam`` (negative round-off clipped to 0); ``lemke_status``
    is Lemke's ``LEMKE_*`` code.
    """
    m = q.shape[0]
    z = work.z
    status, piv = lemke_nb(M, q, max_piv, pivot_tol, lex_tol, work.tableau, work.basis, z,
                           work.w, work.active)
    if status == LEMKE_SOLVED or status == LEMKE_TRIVIAL:
        mask_of(work.active, mask)
    elif not (m <= enum_max_m and m <= MAX_ENUM_M
              and enumerate_nb(M, q, feas_tol, z, work.w, work.aug, mask)):
        return False, piv, status
    for i in range(m):
        lam[i] = z[i] if z[i] > 0.0 else 0.0
    return True, piv, status


@kernel
def negative_q_mask(q, mask):
    """The bitset of the pairs with ``q_i < 0`` (forward-biased / reverse current with every
    λ = 0): the pairs to name when an LCP has no solution."""
    clear_bits(mask)
    for i in range(q.shape[0]):
        if q[i] < 0.0:
            set_bit(mask, i)


@kernel
def distinct_images(M, q, K, xf, lam, uniq_tol, feas_tol, zalt, aug, bits, diff):
    """Enumerate every complementary basis (``m <= MAX_ENUM_M``); return True, with the pairs
    whose λ differs in the bitset ``diff``, when a solution's image ``x_free + K λ`` differs
    from that of ``lam`` by more than ``uniq_tol`` (relative); False when every solution gives
    the same image. ``bits`` is work space (a bitset)."""
    m = q.shape[0]
    n = K.shape[0]
    xscale = 0.0
    for i in range(n):
        s = abs(xf[i])
        for j in range(m):
            s += abs(K[i, j] * lam[j])
        if s > xscale:
            xscale = s
    for mask in range(1 << m):
        from_int(mask, bits)
        if not basis_solution(M, q, bits, zalt, aug):
            continue
        zs = 0.0
        for i in range(m):
            if abs(zalt[i]) > zs:
                zs = abs(zalt[i])
        feasible = True
        for i in range(m):
            if zalt[i] < -feas_tol * zs:
                feasible = False
                break
            wi = q[i]
            sc = abs(q[i])
            for j in range(m):
                t = M[i, j] * zalt[j]
                wi += t
                sc += abs(t)
            if wi < -feas_tol * sc:
                feasible = False
                break
        if not feasible:
            continue
        for i in range(n):
            dx = 0.0
            for j in range(m):
                dx += K[i, j] * (zalt[j] - lam[j])
            # The absolute floor ignores differences among subnormal numbers (a state that
            # decayed to ~1e-310 has lost its relative precision; it is zero in practice).
            if abs(dx) > uniq_tol * xscale and abs(dx) > 1e-250:
                clear_bits(diff)
                count = 0
                for j in range(m):
                    if abs(zalt[j] - lam[j]) > uniq_tol * max(abs(zalt[j]), abs(lam[j])):
                        set_bit(diff, j)
                        count += 1
                if count == 0:
                    for j in range(m):
                        set_bit(diff, j)
                return True
    return False
