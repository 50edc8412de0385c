"""Compiled kernel of the Moreau θ time-stepping (one LCS, a given time grid, given inputs).

The kernel knows nothing of switch modes, events or signals: the driver in
:mod:`lcs.moreau` cuts the run into intervals of constant mode, builds the time grid (uniform
steps ``h`` plus shortened "odd" steps that land on breakpoints), evaluates the inputs on it and
calls :func:`run_chunk` once per chunk. A future event-locating driver (state-dependent
switches) can reuse the same kernel, stopping it where a step must be redone.

Scheme (Siconos ``EulerMoreauOSI(θ)`` for first-order linear systems, ``γ`` unused)::

    W      = (I - h θ A)^-1
    x_free = W [(I + h(1-θ) A) x_k + h((1-θ) E u_k + θ E u_{k+1})]
    w      = (D + h C W B) λ + C x_free + F u_{k+1},      0 <= w ⊥ λ >= 0
    x_k+1  = x_free + h W B λ

written as ``x_free = Phi x_k + G0 u_k + G1 u_k+1``, ``M = D + C K``, ``K = h W B``.

Fast path: the previous step's active set ``a`` (pairs whose λ is basic) is tried first with the
cached ``-(M_aa)^-1``; the step is accepted when ``λ_a >= 0`` and ``w >= 0`` off ``a`` within a
relative tolerance. Otherwise the numba Lemke solves the LCP and its final basis becomes the new
active set (Lemke's basis matrices are nonsingular, so ``M_aa`` is invertible). Factorisations
are cached per active set (bitmask) in a small pool with round-robin replacement.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit


def _refresh_cache_stamp() -> None:
    """Numba's on-disk cache keys a function on the mtime of its own source file only, so a
    change to ``lemke_nb`` in lcp.py would leave a stale compiled kernel here. Make this file
    at least as new as lcp.py before the decorators below read its stamp."""
    here = Path(__file__)
    try:
        dep = here.with_name("lcp.py").stat().st_mtime
        if dep > here.stat().st_mtime:
            os.utime(here, (dep, dep))
    except OSError:  # read-only install: nothing is edited there anyway
        pass


_refresh_cache_stamp()

from .lcp import LEMKE_SOLVED, LEMKE_TRIVIAL, lemke_nb  # noqa: E402

# Kernel return codes.
STEP_OK = 0
STEP_LCP_FAILED = 1  # Lemke ray termination or pivot budget: the driver decides
STEP_NONFINITE = 2
STEP_NONUNIQUE = 3

# Layout of the int64 "ivars" array shared between the driver and the kernel.
IV_MASK = 0  # active set (bitmask of pairs with basic λ) of the last step
IV_NEXT_SLOT = 1  # next cache slot to (re)use
IV_FALLBACKS = 2  # Lemke calls
IV_PIVOTS = 3  # Lemke pivots in total
IV_GSTEP = 4  # global step counter (for ``every``)
IV_OUTPOS = 5  # rows written to the output buffers
IV_ODD = 6  # shortened steps
IV_FAILMASK = 7  # pairs involved in a failure (bitmask, valid when the kernel fails)
IV_UNIQ = 8  # uniqueness checks done
IV_MISSES = 9  # active-set cache misses (factorisations)
IV_LEN = 10

# Layout of the float64 "fvars" options array.
FV_RTOL = 0  # fast-path acceptance tolerance (relative)
FV_PIVOT_TOL = 1
FV_LEX_TOL = 2
FV_UNIQ_TOL = 3  # relative state difference that makes two LCP solutions "different"
FV_LEN = 4

MAX_MASK_M = 62  # the fast path indexes active sets by int64 bitmasks


@dataclass
class Discretisation:
    """Matrices of one θ step of length ``h`` (s) for one LCS.

    Shapes: ``Phi (n, n)``, ``G0, G1 (n, p)``, ``K (n, m)``, ``M (m, m)``.
    """

    h: float
    theta: float
    Phi: np.ndarray
    G0: np.ndarray
    G1: np.ndarray
    K: np.ndarray
    M: np.ndarray


@njit(cache=True)
def discretise_nb(A, B, C, D, E, h, theta, Phi, G0, G1, K, M):
    """Fill ``Phi, G0, G1, K, M`` for a step ``h`` (see the module docstring)."""
    n = A.shape[0]
    Wden = np.eye(n) - h * theta * A
    rhs_phi = np.eye(n) + h * (1.0 - theta) * A
    Phi[:, :] = np.linalg.solve(Wden, rhs_phi) if n > 0 else Phi
    if E.shape[1] > 0 and n > 0:
        WE = np.linalg.solve(Wden, np.ascontiguousarray(E))
        G0[:, :] = h * (1.0 - theta) * WE
        G1[:, :] = h * theta * WE
    if B.shape[1] > 0 and n > 0:
        K[:, :] = h * np.linalg.solve(Wden, np.ascontiguousarray(B))
    m = D.shape[0]
    for i in range(m):
        for j in range(m):
            s = D[i, j]
            for k in range(n):
                s += C[i, k] * K[k, j]
            M[i, j] = s


def discretise(A, B, C, D, E, h: float, theta: float) -> Discretisation:
    """Python entry to :func:`discretise_nb` (allocates the matrices)."""
    A, B, C, D, E = (np.ascontiguousarray(a, dtype=float) for a in (A, B, C, D, E))
    n, m, p = A.shape[0], B.shape[1], E.shape[1]
    Phi = np.zeros((n, n))
    G0 = np.zeros((n, p))
    G1 = np.zeros((n, p))
    K = np.zeros((n, m))
    M = np.zeros((m, m))
    discretise_nb(A, B, C, D, E, float(h), float(theta), Phi, G0, G1, K, M)
    return Discretisation(float(h), float(theta), Phi, G0, G1, K, M)


@njit(cache=True)
def _factor_active(M, mask, slot, cna, cidx, cG):
    """Store ``-(M_aa)^-1`` and the index split of active set ``mask`` in cache ``slot``.

    ``cna[slot] = -1`` marks a singular ``M_aa`` (no fast path for that set).
    """
    m = M.shape[0]
    na = 0
    for i in range(m):
        if (mask >> i) & 1:
            cidx[slot, na] = i
            na += 1
    ni = na
    for i in range(m):
        if not (mask >> i) & 1:
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
            cG[slot, i, j] = -aug[i, na + j]
    cna[slot] = na


@njit(cache=True)
def _lookup(M, mask, ckeys, cna, cidx, cG, ivars):
    """Cache slot of active set ``mask``, factorising it on a miss."""
    S = ckeys.shape[0]
    for s in range(S):
        if ckeys[s] == mask:
            return s
    s = ivars[IV_NEXT_SLOT]
    ivars[IV_NEXT_SLOT] = (s + 1) % S
    ivars[IV_MISSES] += 1
    ckeys[s] = mask
    _factor_active(M, mask, s, cna, cidx, cG)
    return s


@njit(cache=True)
def _mask_of(active):
    mask = 0
    for i in range(active.shape[0]):
        if active[i]:
            mask |= 1 << i
    return mask


@njit(cache=True)
def _basis_solution(M, q, mask, z, aug):
    """Solve the complementary basis ``mask`` (``w_a = 0``, ``z_n = 0``) into ``z``.

    Returns False for a (numerically) singular basis.
    """
    m = q.shape[0]
    na = 0
    idx = np.empty(m, np.int64)
    for i in range(m):
        z[i] = 0.0
        if (mask >> i) & 1:
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


@njit(cache=True)
def _unique_state(M, q, K, xf, lam, uniq_tol, feas_tol, zalt, aug):
    """Enumerate every complementary basis; return the bitmask of pairs whose λ differs in a
    solution that moves the state by more than ``uniq_tol`` (relative), or 0 if the state is
    unique."""
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
        if not _basis_solution(M, q, mask, zalt, aug):
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
                diff = 0
                for j in range(m):
                    if abs(zalt[j] - lam[j]) > uniq_tol * max(abs(zalt[j]), abs(lam[j])):
                        diff |= 1 << j
                return diff if diff != 0 else (1 << m) - 1
    return 0


@njit(cache=True)
def run_chunk(
    Phi, G0, G1, C, F, M, K,
    A, B, D, E, theta, h,
    Cy, Dy, Fy,
    tgrid, odd, U0, U1,
    x, lam,
    ckeys, cna, cidx, cG,
    ivars, fvars, max_pivots, every, uniq_max_m, fast_enabled,
    T_out, Y_out, out_is_state,
    xf, q, z, w, act, tab, basis, za, aug,
    Phi_o, G0_o, G1_o, K_o, M_o,
):
    """Advance ``x`` over ``tgrid`` in one mode.

    Parameters
    ----------
    Phi, G0, G1, C, F, M, K : float64 arrays
        Discretisation for the regular step ``h`` and the relation matrices ``C (m, n)``,
        ``F (m, p)``.
    A, B, D, E : float64 arrays
        Continuous-time matrices (used to discretise shortened steps).
    theta, h : float
        θ and the regular step, s.
    Cy, Dy, Fy : float64 arrays, shapes (r, n), (r, m), (r, p)
        Output map of the stored probes.
    tgrid : float64[:], shape (N + 1,)
        Step boundaries, s. ``tgrid[0]`` is the time of the current ``x``.
    odd : bool[:], shape (N,)
        True for shortened steps (length ``tgrid[k+1] - tgrid[k]`` instead of ``h``).
    U0, U1 : float64 arrays, shape (N, p)
        Inputs at the start (right limit) and end (left limit) of each step.
    x, lam : float64[:]
        State (n,) and multipliers (m,), updated in place.
    ckeys, cna, cidx, cG : arrays
        Active-set cache of this mode (see ``_factor_active``); persists across calls.
    ivars, fvars : int64[:], float64[:]
        Counters and options (``IV_*``, ``FV_*`` layouts).
    max_pivots, every, uniq_max_m : int
        Lemke budget; store every ``every``-th step; check state uniqueness at Lemke calls when
        ``m <= uniq_max_m``.
    fast_enabled : bool
        Use the active-set fast path.
    T_out, Y_out : float64 arrays, shapes (cap,), (cap, r)
        Output buffers, written from row ``ivars[IV_OUTPOS]``.
    out_is_state : bool
        The output map is ``y = x`` (then the matrix products are skipped).
    xf, q, z, w, act, tab, basis, za, aug, Phi_o, G0_o, G1_o, K_o, M_o : arrays
        Work arrays. On failure ``xf`` and ``q`` hold the failing step's free state and LCP
        vector, ``M_o``/``K_o`` its matrices if the step was shortened.

    Returns
    -------
    status : int
        ``STEP_OK`` or a failure code; ``x``/``lam`` then hold the last good step.
    k : int
        Index of the failing step (``N`` on success).
    """
    n = x.shape[0]
    m = lam.shape[0]
    p = U0.shape[1]
    r_out = Cy.shape[0]
    N = tgrid.shape[0] - 1
    rtol = fvars[FV_RTOL]
    pivot_tol = fvars[FV_PIVOT_TOL]
    lex_tol = fvars[FV_LEX_TOL]
    uniq_tol = fvars[FV_UNIQ_TOL]
    # Steps left until the next stored one (the global counter is a multiple of ``every``
    # at stored steps).
    countdown = every - ivars[IV_GSTEP] % every
    slot = -1
    if fast_enabled and m > 0:
        slot = _lookup(M, ivars[IV_MASK], ckeys, cna, cidx, cG, ivars)
    for k in range(N):
        is_odd = odd[k]
        if is_odd:
            hk = tgrid[k + 1] - tgrid[k]
            discretise_nb(A, B, C, D, E, hk, theta, Phi_o, G0_o, G1_o, K_o, M_o)
            Pk, G0k, G1k, Kk, Mk = Phi_o, G0_o, G1_o, K_o, M_o
            ivars[IV_ODD] += 1
        else:
            Pk, G0k, G1k, Kk, Mk = Phi, G0, G1, K, M
        # Free state and LCP vector.
        for i in range(n):
            s = 0.0
            for j in range(n):
                s += Pk[i, j] * x[j]
            for j in range(p):
                s += G0k[i, j] * U0[k, j] + G1k[i, j] * U1[k, j]
            xf[i] = s
        for i in range(m):
            s = 0.0
            for j in range(n):
                s += C[i, j] * xf[j]
            for j in range(p):
                s += F[i, j] * U1[k, j]
            q[i] = s
        # Never a silent NaN: inf - inf and NaN both give NaN. Checked before x is
        # overwritten so that the driver keeps the last good state.
        s = 0.0
        for i in range(n):
            s += xf[i]
        for i in range(m):
            s += q[i]
        if s - s != 0.0:
            return STEP_NONFINITE, k
        accepted = False
        na = 0
        if m == 0:
            accepted = True
            for i in range(n):
                x[i] = xf[i]
        elif slot >= 0 and not is_odd and cna[slot] >= 0:
            # Fast path: previous active set, cached -(M_aa)^-1.
            na = cna[slot]
            accepted = True
            zmax = 0.0
            for ii in range(na):
                s = 0.0
                for jj in range(na):
                    s += cG[slot, ii, jj] * q[cidx[slot, jj]]
                za[ii] = s
                if abs(s) > zmax:
                    zmax = abs(s)
            for ii in range(na):
                if za[ii] < -rtol * zmax:
                    accepted = False
                    break
            if accepted:
                for ii in range(na, m):
                    i = cidx[slot, ii]
                    s = q[i]
                    sc = abs(s)
                    for jj in range(na):
                        t = Mk[i, cidx[slot, jj]] * za[jj]
                        s += t
                        sc += abs(t)
                    if s < -rtol * sc:
                        accepted = False
                        break
            if accepted:
                for i in range(n):
                    s = xf[i]
                    for jj in range(na):
                        s += Kk[i, cidx[slot, jj]] * za[jj]
                    x[i] = s
                for i in range(m):
                    lam[i] = 0.0
                for jj in range(na):
                    lam[cidx[slot, jj]] = za[jj]
        if not accepted:
            status, piv = lemke_nb(Mk, q, max_pivots, pivot_tol, lex_tol, tab, basis, z, w, act)
            ivars[IV_FALLBACKS] += 1
            ivars[IV_PIVOTS] += piv
            if status != LEMKE_SOLVED and status != LEMKE_TRIVIAL:
                fm = 0
                for i in range(m):
                    if q[i] < 0.0:
                        fm |= 1 << i
                ivars[IV_FAILMASK] = fm
                if is_odd:
                    # Leave the shortened step's matrices where the driver expects them.
                    pass
                return STEP_LCP_FAILED, k
            if m <= uniq_max_m:
                ivars[IV_UNIQ] += 1
                diff = _unique_state(Mk, q, Kk, xf, z, uniq_tol, 1e-9, w, aug)
                if diff != 0:
                    ivars[IV_FAILMASK] = diff
                    return STEP_NONUNIQUE, k
            for i in range(n):
                s = xf[i]
                for j in range(m):
                    s += Kk[i, j] * z[j]
                x[i] = s
            for i in range(m):
                lam[i] = z[i]
            mask = _mask_of(act)
            ivars[IV_MASK] = mask
            if fast_enabled:
                slot = _lookup(M, mask, ckeys, cna, cidx, cG, ivars)
        # Overflow in x_free + K λ (λ itself comes from a finite LCP solve).
        s = 0.0
        for i in range(n):
            s += x[i]
        for i in range(m):
            s += lam[i]
        if s - s != 0.0:
            return STEP_NONFINITE, k
        g = ivars[IV_GSTEP] + 1
        ivars[IV_GSTEP] = g
        countdown -= 1
        if countdown == 0:
            countdown = every
            pos = ivars[IV_OUTPOS]
            T_out[pos] = tgrid[k + 1]
            if out_is_state:
                for j in range(n):
                    Y_out[pos, j] = x[j]
                ivars[IV_OUTPOS] = pos + 1
                continue
            for r in range(r_out):
                s = 0.0
                for j in range(n):
                    s += Cy[r, j] * x[j]
                for j in range(m):
                    s += Dy[r, j] * lam[j]
                for j in range(p):
                    s += Fy[r, j] * U1[k, j]
                Y_out[pos, r] = s
            ivars[IV_OUTPOS] = pos + 1
    return STEP_OK, N
