"""One θ step of one mode by its sparse KKT system.

For a step of length ``s`` from ``x_k`` (inputs ``u0`` to ``u1``, ``u_θ = (1-θ) u0 + θ u1``),
Moreau's step (:mod:`lcs.integrators.moreau.dense.discretise`) in the network's unknowns ``z``
(:mod:`lcs.network`), with ``v = θ x_k+1 + (1-θ) x_k`` (so that ``A v`` carries the θ
weighting and no solve of ``x_k``'s own network is needed)::

    (Y - s θ S_x Rx) z - S_λ λ = S_x x_k + S_u u_θ       (the companion network: z at v)
    θ w = Rw z + (θ - 1) D λ - F u_θ + θ F u1 - (1-θ) C x_k
    x_k+1 = x_k + s Rx z

(``Rx z = A v + B λ + E u_θ`` and ``v - x_k = s θ (A v + B λ + E u_θ)`` give the state
equation; ``Rw z = C v + D λ + F u_θ`` the pairs'). ``c = C x_k`` is carried from step to
step (``c_k+1 = w - D λ - F u1``) and computed afresh with Y's factors at a mode change, on
entry and every :data:`SYNC_STEPS` steps (with θ = 1/2 its round-off neither grows nor decays:
the fresh computation bounds it).

For an active set ``a`` (the pairs with λ basic) the rows ``w_a = 0`` and ``λ_i = 0`` off
``a`` close the system: one sparse LU per mode, length and active set (:func:`lookup`, cached
in :class:`~lcs.integrators.moreau.sparse.layout.KKTCache`), one solve per step; the set is accepted
when ``λ_a >= -rtol max|λ_a|`` and ``w_i >= -rtol Σ|terms|`` off ``a``, else block principal
pivoting goes on from it (:func:`kkt_step`), each basis a factorisation of its own. No dense
matrix of the LCS is touched: a step costs the non-zeros of its factors.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from lcs.bits import bit
from lcs.jit import inline, kernel

from ..dense.layout import FV_RTOL, FV_THETA, IV_WARM
from .layout import (
    C_FACTOR,
    C_NEXT,
    C_REFINE,
    C_SINGULAR,
    C_TRIALS,
    K_BOTH_ACTIVE,
    K_COL_ACTIVE,
    K_COL_INACTIVE,
    K_ROW_ACTIVE,
    ST_D,
    ST_F,
    ST_RW,
    ST_RX,
    ST_SU,
    ST_SX,
    ST_TEMPLATE,
    ST_YL,
    ST_YU,
    VF_YCOL,
    VF_YROW,
    VI_ORDER,
    VI_YORDER,
    VI_YPINV,
)
from .lu import FACTOR_FULL, FACTOR_OK, Factors, factor, solve_into

KKTWork = namedtuple("KKTWork", ["Ap", "Ai", "Ax", "x", "xi", "mark", "rhs", "rhs0", "sol",
                                 "y", "zy", "v", "fd", "fu", "c", "wt", "csync", "marginal",
                                 "viol", "prev", "viol0", "first"])
KKTWork.__doc__ = """Scratch and carried values of the KKT steps: the assembled matrix
``Ap (Nmax + 1,)``, ``Ai, Ax (capA,)``; the factorisation's ``x (Nmax,)``, ``xi (2 Nmax,)``,
``mark (Nmax,)``; the system's right-hand side (as built: ``rhs0``) and solution ``rhs,
rhs0, sol, y (Nmax,)``;
``zy (nzmax,)`` for Y's solve; ``v (p,)`` = u_θ; ``fd (m,)`` = F u_θ - θ F u1, ``fu (m,)`` =
F u1; ``c (m,)`` = C x carried, ``csync (1,)`` its age in steps (-1: not valid); ``wt (m,)``
= θ w; ``marginal (1,)`` (:func:`evaluate`); ``viol (m,)`` the infeasible pairs; ``prev
(Wm,)`` an active set; ``viol0 (m,)``, ``first (Wm,)``: a step's first set and its infeasible
pairs, while a remembered set is tried (:func:`kkt_step`)."""

#: the diagonal row is the pivot when its entry is at least this fraction of the column's
#: largest (KLU's rule; the column order was chosen for diagonal pivots)
PIVOT_TOL = 0.1
#: a pivot below this (on the matrix scaled to entries of about 1) is a singular basis
PIVOT_MIN = 1e-13
#: positions of the slot table probed per lookup
PROBES = 8
#: infeasibilities within this fraction of their scale get one step of iterative refinement
#: before they count
REFINE_RTOL = 1e-6


@inline
def _present(kind, r, c, nz, mask, cact):
    """Whether a template entry of kind ``kind`` at row ``r``, column ``c`` is part of the
    matrix of the active set ``mask`` (``cact``: column c is an active pair's)."""
    if kind == K_ROW_ACTIVE:
        return bit(mask, r - nz) == 1
    if kind == K_COL_ACTIVE:
        return cact
    if kind == K_BOTH_ACTIVE:
        return cact and bit(mask, r - nz) == 1
    if kind == K_COL_INACTIVE:
        return c >= nz and not cact
    return True


@kernel
def assemble(net, j, s, mask, Ap, Ai, Ax, rs, cs):
    """The KKT matrix of mode ``j``, step ``s`` and active set ``mask`` into ``Ap, Ai, Ax``
    (CSC), scaled by powers of two (rows ``rs``, columns ``cs``) to unit maxima. Returns its
    size N, or -1 when ``Ai`` is too short."""
    nz = net.dims[j, 0]
    N = net.dims[j, 1]
    base = net.tab[j, ST_TEMPLATE]
    ptr = net.ptr
    cap = Ai.shape[0]
    cnt = 0
    for c in range(N):
        Ap[c] = cnt
        cact = c >= nz and bit(mask, c - nz) == 1
        for t in range(ptr[base + c], ptr[base + c + 1]):
            r = net.idx[t]
            if _present(net.kind[t], r, c, nz, mask, cact):
                if cnt >= cap:
                    return -1
                Ai[cnt] = r
                Ax[cnt] = net.val[t] + s * net.val2[t]
                cnt += 1
    Ap[N] = cnt
    for r in range(N):
        rs[r] = 0.0
    for t in range(cnt):
        a = abs(Ax[t])
        if a > rs[Ai[t]]:
            rs[Ai[t]] = a
    for r in range(N):
        rs[r] = _pow2_inverse(rs[r])
    for c in range(N):
        big = 0.0
        for t in range(Ap[c], Ap[c + 1]):
            a = abs(Ax[t]) * rs[Ai[t]]
            if a > big:
                big = a
        sc = _pow2_inverse(big)
        cs[c] = sc
        for t in range(Ap[c], Ap[c + 1]):
            Ax[t] *= rs[Ai[t]] * sc
    return N


@kernel
def _pow2_inverse(a):
    """The power of two nearest ``1/a`` (1 for 0 or non-finite ``a``): scaling by it is
    exact."""
    if not (a > 0.0) or not np.isfinite(a):
        return 1.0
    m, e = math.frexp(a)
    return math.ldexp(1.0, -e + (1 if m < 0.7071067811865476 else 0))


@inline
def _hash(j, s, stol, mask):
    """A hash of (mode, length to within ``stol``, active set), non-negative."""
    h = np.uint64(j) * np.uint64(0x9E3779B97F4A7C15) + np.uint64(int(s / stol))
    for w in range(mask.shape[0]):
        h = (h ^ np.uint64(mask[w])) * np.uint64(0xBF58476D1CE4E5B9)
        h ^= h >> np.uint64(31)
    return np.int64(h >> np.uint64(1))


@inline
def _matches(cache, t, j, s, stol, mask):
    if cache.mode[t] != j or cache.state[t] == -2 or abs(cache.s[t] - s) > stol:
        return False
    for w in range(mask.shape[0]):
        if cache.sets[t, w] != mask[w]:
            return False
    return True


@kernel
def lookup(net, cache, j, s, stol, mask, W):
    """The cache slot of mode ``j``, length ``s`` (within ``stol``) and active set ``mask``,
    factorised now on a miss (the next slot round robin). Returns the slot (its ``state``
    -1 for a singular set), or -1 when the slot's storage is too small.

    Slots are found through an open-addressing table (``cache.table``: :data:`PROBES`
    positions from the key's hash; an entry whose slot was reused for another key is stale
    and may be overwritten), so that a lookup costs the same with a thousand slots as with
    one."""
    H = cache.table.shape[0]
    hk = _hash(j, s, stol, mask)
    free = -1
    for p in range(PROBES):
        pos = (hk + p) & (H - 1)
        t = cache.table[pos]
        if t >= 0 and cache.hkey[t] == hk and _matches(cache, t, j, s, stol, mask):
            return t
        if free < 0 and (t < 0 or cache.hkey[t] != cache.thash[pos]):
            free = pos
    T = cache.mode.shape[0]
    t = cache.counters[C_NEXT]
    cache.counters[C_NEXT] = (t + 1) % T
    cache.table[hk & (H - 1) if free < 0 else free] = t
    cache.thash[hk & (H - 1) if free < 0 else free] = hk
    cache.hkey[t] = hk
    cache.succ[t] = -1
    cache.mode[t] = j
    cache.s[t] = s
    for w in range(mask.shape[0]):
        cache.sets[t, w] = mask[w]
    cache.state[t] = -2
    N = assemble(net, j, s, mask, W.Ap, W.Ai, W.Ax, cache.rs[t], cache.cs[t])
    if N < 0:
        return -1
    q = net.ivec[net.vtab[j, VI_ORDER]:net.vtab[j, VI_ORDER] + N]
    st = factor(N, W.Ap, W.Ai, W.Ax, q, PIVOT_TOL, PIVOT_MIN,
                Factors(cache.Lp[t], cache.Li[t], cache.Lx[t], cache.Up[t], cache.Ui[t],
                        cache.Ux[t], cache.pinv[t]), W.x, W.xi, W.mark)
    cache.counters[C_FACTOR] += 1
    if st == FACTOR_FULL:
        return -1
    if st == FACTOR_OK:
        cache.state[t] = 0
    else:
        cache.state[t] = -1
        cache.counters[C_SINGULAR] += 1
    return t


@inline
def _network_rhs(net, j, x, N, rhs):
    """``rhs[:N] = S_x x`` (zero beyond the rows of mode ``j``'s network equations)."""
    for r in range(N):
        rhs[r] = 0.0
    sx = net.tab[j, ST_SX]
    ptr, idx, val = net.ptr, net.idx, net.val
    for c in range(x.shape[0]):
        xc = x[c]
        if xc != 0.0:
            for t in range(ptr[sx + c], ptr[sx + c + 1]):
                rhs[idx[t]] += val[t] * xc


#: steps after which ``c = C x`` is computed afresh from Y's factors
SYNC_STEPS = 32


@kernel
def sync_c(net, j, x, W):
    """``W.c = C x = Rw Y⁻¹ S_x x`` with mode ``j``'s factors of Y. False when not finite."""
    m = W.c.shape[0]
    nz = net.dims[j, 0]
    ptr, idx, val = net.ptr, net.idx, net.val
    rhs = W.rhs
    _network_rhs(net, j, x, nz, rhs)
    yrow = net.vtab[j, VF_YROW]
    ycol = net.vtab[j, VF_YCOL]
    for r in range(nz):
        rhs[r] *= net.fvec[yrow + r]
    # (the factors' pointers in the store are absolute: they index idx and val as they are)
    yl = net.tab[j, ST_YL]
    yu = net.tab[j, ST_YU]
    yq = net.vtab[j, VI_YORDER]
    yp = net.vtab[j, VI_YPINV]
    solve_into(nz, net.ivec[yq:yq + nz], ptr[yl:yl + nz + 1], idx, val, ptr[yu:yu + nz + 1],
               idx, val, net.ivec[yp:yp + nz], rhs, W.y, W.zy)
    for r in range(nz):
        W.zy[r] *= net.fvec[ycol + r]
    rw = net.tab[j, ST_RW]
    chk = 0.0
    for i in range(m):
        acc = 0.0
        for t in range(ptr[rw + i], ptr[rw + i + 1]):
            acc += val[t] * W.zy[idx[t]]
        W.c[i] = acc
        chk += acc
    return chk - chk == 0.0


@inline
def inputs_part(net, j, theta, u0, u1, W):
    """``W.v = u_θ = (1-θ) u0 + θ u1``, ``W.fd = F u_θ - θ F u1`` and ``W.fu = F u1`` over
    the mode's inputs."""
    nu = net.inp[j, 0]
    for t in range(nu):
        i = net.inp[j, 1 + t]
        W.v[i] = (1.0 - theta) * u0[i] + theta * u1[i]
    m = W.fd.shape[0]
    fo = net.tab[j, ST_F]
    ptr, idx, val = net.ptr, net.idx, net.val
    for i in range(m):
        a = 0.0
        b = 0.0
        for t in range(ptr[fo + i], ptr[fo + i + 1]):
            a += val[t] * W.v[idx[t]]
            b += val[t] * u1[idx[t]]
        W.fd[i] = a - theta * b
        W.fu[i] = b


@inline
def residual(net, j, s, mask, sol, r):
    """``r -= K sol`` for the KKT matrix of mode ``j``, length ``s`` and active set ``mask``
    (unscaled, from the template as :func:`assemble` takes it)."""
    nz = net.dims[j, 0]
    N = net.dims[j, 1]
    base = net.tab[j, ST_TEMPLATE]
    ptr = net.ptr
    for c in range(N):
        xc = sol[c]
        if xc == 0.0:
            continue
        cact = c >= nz and bit(mask, c - nz) == 1
        for t in range(ptr[base + c], ptr[base + c + 1]):
            rr = net.idx[t]
            if _present(net.kind[t], rr, c, nz, mask, cact):
                r[rr] -= (net.val[t] + s * net.val2[t]) * xc


@inline
def _scaled_solve(net, cache, t, j, rhs, W, out):
    """``out = K⁻¹ rhs`` with the scaled factors of cache slot ``t`` (``rhs`` is scaled in
    place); returns the largest entry of the scaled solution (the scale of its round-off)."""
    N = net.dims[j, 1]
    rs = cache.rs[t]
    cs = cache.cs[t]
    for r in range(N):
        rhs[r] *= rs[r]
    q = net.ivec[net.vtab[j, VI_ORDER]:net.vtab[j, VI_ORDER] + N]
    solve_into(N, q, cache.Lp[t], cache.Li[t], cache.Lx[t], cache.Up[t], cache.Ui[t],
               cache.Ux[t], cache.pinv[t], rhs, W.y, out)
    big = 0.0
    for r in range(N):
        a = abs(out[r])
        if a > big:
            big = a
        out[r] *= cs[r]
    return big


@inline
def trial(net, cache, t, j, s, theta, x, mask, rtol, W, xn, lamn):
    """Solve the KKT system of cache slot ``t`` (mode ``j``, length ``s``, active set
    ``mask``) from ``x`` with the inputs of :func:`inputs_part` and ``W.c = C x``; the new
    state into ``xn``, λ into ``lamn``, ``θ w`` into ``W.wt``, the infeasible pairs into
    ``W.viol``. Returns their number, or -1 when the result is not finite.

    When every infeasibility is within :data:`REFINE_RTOL` of its scale (a pair at its
    switching point, where the solve's round-off, that of the whole network's system, can
    decide the sign), the solution gets one step of iterative refinement first: the set is
    judged on the pairs' values, not on the round-off (on a 100-stage multiplier, 1,900 fewer
    pivoting steps and 6,700 fewer factorisations in 40,000 steps)."""
    nz = net.dims[j, 0]
    N = net.dims[j, 1]
    m = lamn.shape[0]
    ptr, idx, val = net.ptr, net.idx, net.val
    rhs = W.rhs
    _network_rhs(net, j, x, N, rhs)
    su = net.tab[j, ST_SU]
    nu = net.inp[j, 0]
    for tt in range(nu):
        c = net.inp[j, 1 + tt]
        vc = W.v[c]
        if vc != 0.0:
            for p in range(ptr[su + c], ptr[su + c + 1]):
                rhs[idx[p]] += val[p] * vc
    g = 1.0 - theta
    for i in range(m):
        if bit(mask, i) == 1:
            rhs[nz + i] = W.fd[i] + g * W.c[i]
    rhs0 = W.rhs0
    for r in range(N):
        rhs0[r] = rhs[r]
    sol = W.sol
    big = _scaled_solve(net, cache, t, j, rhs, W, sol)
    nv = evaluate(net, cache.cs[t], big, j, s, theta, x, mask, rtol, W, xn, lamn)
    if nv <= 0 or W.marginal[0] == 0:
        return nv
    for r in range(N):
        rhs[r] = rhs0[r]
    residual(net, j, s, mask, sol, rhs)
    _scaled_solve(net, cache, t, j, rhs, W, W.x)
    for r in range(N):
        sol[r] += W.x[r]
    cache.counters[C_REFINE] += 1
    return evaluate(net, cache.cs[t], big, j, s, theta, x, mask, rtol, W, xn, lamn)


@inline
def evaluate(net, cs, big, j, s, theta, x, mask, rtol, W, xn, lamn):
    """The new state, λ and θ w from the KKT solution ``W.sol`` (see :func:`trial`), the
    infeasible pairs into ``W.viol``; ``W.marginal[0]`` is 1 when every infeasibility is
    within :data:`REFINE_RTOL` of its scale. Returns their number, -1 when not finite.

    A λ's scale is the largest |λ| of the set, or where larger the round-off scale of the
    solve (``big``, the largest entry of the solution scaled by the columns ``cs``: a λ
    that vanishes in exact arithmetic comes out at ``±eps cond big`` in its column's units,
    however small the set's other λ)."""
    nz = net.dims[j, 0]
    n = xn.shape[0]
    m = lamn.shape[0]
    ptr, idx, val = net.ptr, net.idx, net.val
    sol = W.sol
    g = 1.0 - theta
    rx = net.tab[j, ST_RX]
    chk = 0.0
    for i in range(n):
        acc = 0.0
        for p in range(ptr[rx + i], ptr[rx + i + 1]):
            acc += val[p] * sol[idx[p]]
        v = x[i] + s * acc
        xn[i] = v
        chk += v
    lmax = 0.0
    for i in range(m):
        if bit(mask, i) == 1:
            v = sol[nz + i]
            lamn[i] = v
            chk += v
            if abs(v) > lmax:
                lmax = abs(v)
        else:
            lamn[i] = 0.0
    if not chk - chk == 0.0:
        return -1
    marginal = 1
    nv = 0
    for i in range(m):
        if bit(mask, i) == 1:
            sc = max(lmax, cs[nz + i] * big)
            if lamn[i] < -rtol * sc:
                W.viol[nv] = i
                nv += 1
                if lamn[i] < -REFINE_RTOL * sc:
                    marginal = 0
    # θ w of every pair (the active ones' is their row's residual), the inactive ones checked
    # against the scale of their terms (summed for them only)
    rw = net.tab[j, ST_RW]
    dm = net.tab[j, ST_D]
    h = theta - 1.0
    for i in range(m):
        checked = bit(mask, i) == 0 and net.zw[j, i] == 0
        w = -W.fd[i] - g * W.c[i]
        sc = 0.0
        if checked:
            sc = abs(W.fd[i]) + abs(g * W.c[i])
        for p in range(ptr[rw + i], ptr[rw + i + 1]):
            term = val[p] * sol[idx[p]]
            w += term
            if checked:
                sc += abs(term)
        if h != 0.0:
            for p in range(ptr[dm + i], ptr[dm + i + 1]):
                term = h * val[p] * lamn[idx[p]]
                w += term
                if checked:
                    sc += abs(term)
        W.wt[i] = w
        if checked and w < -rtol * sc:
            W.viol[nv] = i
            nv += 1
            if w < -REFINE_RTOL * sc:
                marginal = 0
    W.marginal[0] = marginal
    return nv


@inline
def carry_c(net, j, theta, lamn, W):
    """``W.c = C x_k+1 = w - D λ - F u1`` after an accepted step."""
    m = lamn.shape[0]
    ptr, idx, val = net.ptr, net.idx, net.val
    dm = net.tab[j, ST_D]
    for i in range(m):
        acc = W.wt[i] / theta - W.fu[i]
        for p in range(ptr[dm + i], ptr[dm + i + 1]):
            acc -= val[p] * lamn[idx[p]]
        W.c[i] = acc


@inline
def _alternative(prev, viol, nv, a, m, mask):
    """Alternative ``a`` to a flip from ``prev`` that gave a singular set: ``prev`` with one
    infeasible pair ``viol[e]`` flipped (``a < nv``), then with an infeasible pair added and
    an active one removed (a diode taking over another's current: two conducting at once
    would short a source). Sets ``mask``; False when there is no alternative ``a``."""
    for w in range(mask.shape[0]):
        mask[w] = prev[w]
    if a < nv:
        f = viol[a]
        mask[f >> 6] ^= np.int64(1) << (f & 63)
        return True
    a -= nv
    for e in range(nv):
        f = viol[e]
        if bit(prev, f) == 1:
            continue
        for r in range(m):
            if bit(prev, r) == 1:
                if a == 0:
                    mask[f >> 6] ^= np.int64(1) << (f & 63)
                    mask[r >> 6] ^= np.int64(1) << (r & 63)
                    return True
                a -= 1
    return False


@inline
def step_body(net, cache, j, s, stol, x, u0, u1, acts, W, xn, lamn, led):
    """One θ step of length ``s`` of mode ``j`` from ``x`` into ``xn``, ``lamn``, from the
    active set ``mask = acts.act[0]`` (cache slot ``slot[0]``, ``slot = acts.slots``, -1:
    unknown; :class:`~lcs.integrators.moreau.dense.layout.Actives`), by block principal pivoting
    (Júdice–Pires, Murty's single flip once the infeasibilities stop decreasing, as
    :func:`lcs.lcp.compiled.solve_warm`) when it is not accepted, and around a flip that
    makes the set singular the single flips and swaps of :func:`_alternative`
    (``max_iter = led.lim.warm_iter`` bases at most; 0: the previous set only; θ and the
    acceptance tolerance ``rtol`` from ``led.fvars``,
    :class:`~lcs.integrators.moreau.dense.layout.Ledger`). When the first set fails, the
    set its steps last ended in after pivoting (``cache.succ``) is tried next, and when that
    fails too, pivoting goes on from the first set: on a 100-stage multiplier the
    half-period commutations took up to 26 bases a step, and the remembered sets save 11 %
    of the run's KKT solves. ``mask`` and ``slot[0]`` are
    updated; a step taken after pivoting counts in ``led.ivars[IV_WARM]``; ``W.c`` must hold
    ``C x`` (``W.csync[0]`` steps old, -1: not valid) and is carried to ``C xn``. Step lengths
    within ``stol`` (s) of each other share factorisations, and the step taken is one of the
    factorised length (as the dense kernel's stored shortened steps: the matrix and the state
    update of one length). Returns 0 (taken), 1 (no accepted set, or a basis whose solution
    is not finite: the caller takes the step otherwise) or 3 (a factorisation needs more
    room)."""
    mask = acts.act[0]
    slot = acts.slots
    ivars = led.ivars
    theta = led.fvars[FV_THETA]
    rtol = led.fvars[FV_RTOL]
    max_iter = led.lim.warm_iter
    if theta < 1.0 and (W.csync[0] < 0 or W.csync[0] >= SYNC_STEPS):
        if not sync_c(net, j, x, W):
            return 1
        W.csync[0] = 0
    inputs_part(net, j, theta, u0, u1, W)
    m = lamn.shape[0]
    # pairs whose w vanishes identically stay inactive
    for i in range(m):
        if net.zw[j, i] != 0 and bit(mask, i) == 1:
            mask[i >> 6] ^= np.int64(1) << (i & 63)
            slot[0] = -1
    best = m + 1
    tries = 0
    prev = W.prev
    nvp = 0  # infeasible pairs of prev (still in W.viol while alternatives are tried)
    alt = -1  # the alternative around prev being tried after a singular set
    first = -1  # the slot of the step's first solved set
    hinted = False
    nv0 = 0  # infeasible pairs of the first set, kept while the remembered set is tried
    for it in range(max(1, max_iter)):
        t = slot[0]
        if t < 0:
            t = lookup(net, cache, j, s, stol, mask, W)
            if t < 0:
                return 3
            slot[0] = t
        if cache.state[t] < 0:
            slot[0] = -1
            if it == 0:
                # (the previous step's set is singular here: start from every λ = 0)
                for w in range(mask.shape[0]):
                    mask[w] = 0
                continue
            alt += 1
            if not _alternative(prev, W.viol, nvp, alt, m, mask):
                return 1
            continue
        alt = -1
        nv = trial(net, cache, t, j, cache.s[t], theta, x, mask, rtol, W, xn, lamn)
        cache.counters[C_TRIALS] += 1
        if nv < 0:
            return 1
        if first < 0:
            first = t
        if nv == 0:
            if t != first:
                cache.succ[first] = t
                cache.succ_key[first] = cache.hkey[t]
            if theta < 1.0:
                carry_c(net, j, theta, lamn, W)
                W.csync[0] += 1
            if it > 0:
                ivars[IV_WARM] += 1
            return 0
        if t == first and not hinted:
            # The set this one's steps last pivoted to, when it is still cached: a periodic
            # commutation (a voltage multiplier's ladder each half period) ends where it did
            # a period before, where block pivoting would uncover it a pair or two per basis.
            hinted = True
            tn = cache.succ[t]
            if (tn >= 0 and tn != t and cache.hkey[tn] == cache.succ_key[t]
                    and cache.state[tn] == 0 and cache.mode[tn] == j
                    and abs(cache.s[tn] - s) <= stol):
                for w in range(mask.shape[0]):
                    W.first[w] = mask[w]
                    mask[w] = cache.sets[tn, w]
                for e in range(nv):
                    W.viol0[e] = W.viol[e]
                nv0 = nv
                slot[0] = tn
                continue
        elif nv0 > 0:
            # The remembered set is not the answer this time: pivoting goes on from the first
            # set, as without it (its bases are those of the earlier steps, mostly cached).
            for w in range(mask.shape[0]):
                mask[w] = W.first[w]
            for e in range(nv0):
                W.viol[e] = W.viol0[e]
            nv = nv0
            nv0 = 0
        for w in range(mask.shape[0]):
            prev[w] = mask[w]
        nvp = nv
        if nv < best or tries < 3:
            for e in range(nv):
                f = W.viol[e]
                mask[f >> 6] ^= np.int64(1) << (f & 63)
        else:
            low = W.viol[0]
            for e in range(1, nv):
                if W.viol[e] < low:
                    low = W.viol[e]
            mask[low >> 6] ^= np.int64(1) << (low & 63)
        slot[0] = -1
        if nv < best:
            best = nv
            tries = 0
        elif tries < 3:
            tries += 1
    return 1


@kernel
def kkt_step(net, cache, j, s, stol, x, u0, u1, acts, W, xn, lamn, led):
    """:func:`step_body` as a kernel of its own, for one step called from Python.

    The grid loop (:func:`lcs.integrators.moreau.sparse.grid.run_kkt`) inlines :func:`step_body`
    instead: a compiled call that takes the mode store, the cache and the work space (108 arrays)
    increfs each of them on entry and decrefs them on return, which was 10-14 % of a
    50-stage multiplier's stepping in a perf profile."""
    return step_body(net, cache, j, s, stol, x, u0, u1, acts, W, xn, lamn, led)
