"""Compiled kernel of the Moreau θ time-stepping of a switched LCS (numba).

One call of :func:`run_grid` advances the state over a chunk of the time grid, through any
number of switch-mode changes, without returning to Python except when it needs a mode whose
matrices are not built yet (:data:`STEP_NEED_MODE`), when an output buffer is full
(:data:`STEP_FULL`), or on failure. The driver (:mod:`lcs.moreau`) builds the grid, the
inputs on it, the schedule of known switching instants, and the per-mode matrices, stacked in
arrays indexed by mode id.

Scheme (Siconos ``EulerMoreauOSI(θ)`` for first-order linear systems, ``γ`` unused), for one
step of length ``s`` in one mode::

    W      = (I - s θ A)^-1
    x_free = W [(I + s(1-θ) A) x_k + s((1-θ) E u_k + θ E u_{k+1})]
    w      = (D + s C W B) λ + C x_free + F u_{k+1},      0 <= w ⊥ λ >= 0
    x_k+1  = x_free + s W B λ

written as ``x_free = Phi x_k + G0 u_k + G1 u_k+1``, ``M = D + C K``, ``K = s W B``. Regular
steps (``s = h``) use the stored ``Phi, G0, G1, K, M`` of the mode; other steps (shortened
steps onto breakpoints, the two parts of a step split at a switching instant, the trial steps
of the instant search) are discretised on the fly by a small Gaussian elimination.

LCP: the previous step's active set ``a`` (pairs whose λ is basic) is tried first, with the
cached ``-(M_aa)^-1`` on regular steps and a direct solve of the basis on other steps; it is
accepted when ``λ_a >= 0`` and ``w >= 0`` off ``a`` within a relative tolerance. Otherwise the
numba Lemke solves the LCP; if Lemke fails and ``m`` is small, every complementary basis is
tried (enumeration, fewest active pairs first) before the step is declared failed.

Switches (``sw_kind``):

* :data:`SW_SCHEDULED` -- driven by independent sources or by a Python controller: their
  instants are known in advance and come as a schedule of grid indices (the grid lands on
  them).
* :data:`SW_LOCATED` -- comparators ``c = Cc x + Dc λ + Fc u`` evaluated after each step; a
  crossing of the threshold (``vt + vh`` upwards for an off switch, ``vt - vh`` downwards for
  an on switch) inside the step is located by root finding on the step length (cubic Hermite
  first guess, then secant / bisection steps, each a θ step of the trial length from the start
  of the step), the step is split there, the mode changes and the rest of the step is taken
  in the new mode. With :data:`SWF_LATCH` an off switch does not turn on (only the schedule's
  period starts re-arm it). With :data:`SWF_RELAY`, a switch that toggles without progress
  (the trajectory is on an attractive switching surface) enters sliding mode: the Filippov
  relay (:func:`_relay_fraction`), solved at every step together with the two modes' LCPs,
  until the on-fraction saturates at 0 or 1 with the surface left.
* :data:`SW_SAMPLED` -- comparators sampled at the end of each grid step (explicit method);
  the new state applies from that instant.
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
STEP_LCP_FAILED = 1  # Lemke and enumeration found no solution (or the pivot budget ran out)
STEP_NONFINITE = 2
STEP_NONUNIQUE = 3
STEP_NEED_MODE = 4  # build the mode of key ivars[IV_NEED], append it, call again
STEP_FULL = 5  # grow the output / event buffers, call again
STEP_CHATTER = 6  # more than max_switchings switchings in one grid step
STEP_SLIDING = 7  # a comparator toggles without progress and may not slide

# Layout of the int64 "ivars" array shared between the driver and the kernel.
IV_MASK = 0  # active set (bitmask of pairs with basic λ) of the last step
IV_NEXT_SLOT = 1  # next active-set cache slot to (re)use
IV_FALLBACKS = 2  # Lemke calls
IV_PIVOTS = 3  # Lemke pivots in total
IV_GSTEP = 4  # grid steps completed (for ``every``)
IV_OUTPOS = 5  # rows written to the output buffers
IV_ODD = 6  # steps not of the regular length h (shortened, split, sliding-mode partial)
IV_FAILMASK = 7  # pairs involved in a failure (bitmask, valid when the kernel fails)
IV_UNIQ = 8  # uniqueness checks done
IV_MISSES = 9  # active-set cache misses (factorisations)
IV_KEY = 10  # switch states, bit i = switch i on
IV_NMODES = 11  # modes in the stacks
IV_NEED = 12  # key of the mode the kernel needs (STEP_NEED_MODE)
IV_EVPOS = 13  # event records written
IV_K = 14  # grid step (index within the chunk) to resume at / where the kernel stopped
IV_SCHED = 15  # next schedule entry of the chunk
IV_INIT = 16  # grid step whose start (schedule, counters) has been processed
IV_NSW = 17  # switchings in the current grid step
IV_LASTSW = 18  # switch flipped last by its comparator (-1: none)
IV_SLIDE = 19  # switch in sliding mode (-1: none)
IV_FAILSW = 20  # switch involved in a chattering / sliding failure
IV_FAILMODE = 21  # mode id of a failing step
IV_STEPS = 22  # steps taken (grid steps and the extra parts of split steps)
IV_LOCATED = 23  # comparator switchings located inside a step
IV_ROOTEVALS = 24  # trial steps of the instant search
IV_SLIDESTEPS = 25  # steps taken in sliding mode
IV_MASK_ALT = 26  # active set of the other mode of the sliding switch
IV_LEMKE = 27  # Lemke status of a failed LCP
IV_LEN = 28

# Layout of the float64 "fvars" array.
FV_RTOL = 0  # fast-path acceptance tolerance (relative)
FV_PIVOT_TOL = 1
FV_LEX_TOL = 2
FV_UNIQ_TOL = 3  # relative state difference that makes two LCP solutions "different"
FV_TCUR = 4  # time of x, s (may lie inside grid step IV_K after a switching)
FV_H = 5  # regular step, s
FV_THETA = 6
FV_FEAS_TOL = 7  # feasibility tolerance of the enumeration fallback (relative)
FV_LASTT = 8  # time of the last comparator switching, s
FV_FAIL_T0 = 9  # failing step: start and end, s
FV_FAIL_T1 = 10
FV_DUTY = 11  # on-fraction of the sliding switch over the last step
FV_ROOT_TOL = 12  # instants are located to this fraction of h
FV_LEN = 13

# Per-mode flags (columns of ``mflags``).
MF_FAST = 0  # active-set fast path enabled
MF_UNIQ = 1  # check state uniqueness of Lemke solutions when m <= this (-1: never)
MF_OUTSTATE = 2  # the stored outputs are the states (skip the products)
MF_LEN = 3

# Shortest run of steps up to the next schedule entry that run_grid gives to _plain_steps.
PLAIN_MIN = 16

# Indices in the tuple of stacked per-mode matrices (each of shape (n_modes_capacity, ., .)).
I_A, I_B, I_C, I_D, I_E, I_F = 0, 1, 2, 3, 4, 5
I_PHI, I_G0, I_G1, I_K, I_M = 6, 7, 8, 9, 10
I_CY, I_DY, I_FY = 11, 12, 13  # stored probes, (r, n), (r, m), (r, p)
I_CC, I_DC, I_FC = 14, 15, 16  # switch controls, (k, n), (k, m), (k, p)
N_MATS = 17

# Switch kinds and flags.
SW_SCHEDULED = 0
SW_LOCATED = 1
SW_SAMPLED = 2
SWF_LATCH = 1
SWF_RELAY = 2

# Schedule operations (applied at the start of a grid step).
OP_SET = 0  # key = (key & ~a) | b   (source- or controller-driven switches)
OP_REARM = 1  # latched switch a: on iff its control >= vt - vh

# Event records: ev_info = switch index + EV_* (schedule events have switch index -1).
EV_SWITCH = 0
EV_SLIDE_START = 1 << 20
EV_SLIDE_END = 2 << 20

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
def _gauss(aug, n, nc):
    """Solve ``aug[:, :n] X = aug[:, n:n+nc]`` in place (partial pivoting); X ends up in
    ``aug[:, n:n+nc]``. Returns False for a singular matrix."""
    amax = 0.0
    for i in range(n):
        for j in range(n):
            v = abs(aug[i, j])
            if v > amax:
                amax = v
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(aug[r, c]) > abs(aug[p, c]):
                p = r
        if abs(aug[p, c]) <= 1e-14 * amax or aug[p, c] == 0.0:
            return False
        if p != c:
            for j in range(c, n + nc):
                tmp = aug[c, j]
                aug[c, j] = aug[p, j]
                aug[p, j] = tmp
        piv = aug[c, c]
        for r in range(c + 1, n):
            f = aug[r, c] / piv
            if f != 0.0:
                for j in range(c + 1, n + nc):
                    aug[r, j] -= f * aug[c, j]
    for col in range(n, n + nc):
        for i in range(n - 1, -1, -1):
            s = aug[i, col]
            for j in range(i + 1, n):
                s -= aug[i, j] * aug[j, col]
            aug[i, col] = s / aug[i, i]
    return True


@njit(cache=True)
def discretise_nb(A, B, C, D, E, h, theta, Phi, G0, G1, K, M):
    """Fill ``Phi, G0, G1, K, M`` for a step ``h`` (see the module docstring).

    Returns False when ``I - h θ A`` is singular (the matrices are then left unchanged).
    """
    n = A.shape[0]
    m = B.shape[1]
    p = E.shape[1]
    aug = np.zeros((n, 2 * n + p + m))
    for i in range(n):
        for j in range(n):
            aug[i, j] = (1.0 if i == j else 0.0) - h * theta * A[i, j]
            aug[i, n + j] = (1.0 if i == j else 0.0) + h * (1.0 - theta) * A[i, j]
        for j in range(p):
            aug[i, 2 * n + j] = E[i, j]
        for j in range(m):
            aug[i, 2 * n + p + j] = B[i, j]
    if n > 0 and not _gauss(aug, n, n + p + m):
        return False
    for i in range(n):
        for j in range(n):
            Phi[i, j] = aug[i, n + j]
        for j in range(p):
            G0[i, j] = h * (1.0 - theta) * aug[i, 2 * n + j]
            G1[i, j] = h * theta * aug[i, 2 * n + j]
        for j in range(m):
            K[i, j] = h * aug[i, 2 * n + p + j]
    for i in range(m):
        for j in range(m):
            s = D[i, j]
            for k in range(n):
                s += C[i, k] * K[k, j]
            M[i, j] = s
    return True


def discretise(A, B, C, D, E, h: float, theta: float) -> Discretisation:
    """Python entry to :func:`discretise_nb` (allocates the matrices).

    Raises
    ------
    ValueError
        If ``I - h θ A`` is singular.
    """
    A, B, C, D, E = (np.ascontiguousarray(a, dtype=float) for a in (A, B, C, D, E))
    n, m, p = A.shape[0], B.shape[1], E.shape[1]
    Phi = np.zeros((n, n))
    G0 = np.zeros((n, p))
    G1 = np.zeros((n, p))
    K = np.zeros((n, m))
    M = np.zeros((m, m))
    if not discretise_nb(A, B, C, D, E, float(h), float(theta), Phi, G0, G1, K, M):
        raise ValueError(f"I - h θ A is singular for h = {h:g} s, θ = {theta:g}")
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
def _popcount(v):
    c = 0
    while v:
        v &= v - 1
        c += 1
    return c


@njit(cache=True)
def _enumerate_nb(M, q, feas_tol, z, w, aug):
    """Try every complementary basis, fewest active pairs first (the direct path of
    :func:`lcs.lcp.enumerate_lcp`). Returns the basis bitmask with the solution in ``z``, or
    -1 when there is none."""
    m = q.shape[0]
    for cnt in range(m + 1):
        for mask in range(1 << m):
            if _popcount(mask) != cnt:
                continue
            if not _basis_solution(M, q, mask, z, aug):
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
                return mask
    return -1


@njit(cache=True)
def _odd_free(A, B, C, D, E, s, theta, x, u0, u1, xf, Ko, Mo, augn):
    """Free state ``xf`` and ``K, M`` of a step of length ``s`` (not the stored ``h``)."""
    n = A.shape[0]
    m = B.shape[1]
    p = E.shape[1]
    a = s * (1.0 - theta)
    for i in range(n):
        r = x[i]
        for j in range(n):
            augn[i, j] = (1.0 if i == j else 0.0) - s * theta * A[i, j]
            r += a * A[i, j] * x[j]
        for j in range(p):
            r += s * E[i, j] * ((1.0 - theta) * u0[j] + theta * u1[j])
        augn[i, n] = r
        for j in range(m):
            augn[i, n + 1 + j] = B[i, j]
    if n > 0 and not _gauss(augn, n, 1 + m):
        return False
    for i in range(n):
        xf[i] = augn[i, n]
        for j in range(m):
            Ko[i, j] = s * augn[i, n + 1 + j]
    for i in range(m):
        for j in range(m):
            v = D[i, j]
            for k in range(n):
                v += C[i, k] * Ko[k, j]
            Mo[i, j] = v
    return True


@njit(cache=True)
def _mode_step(mats, mflags, ckeys, cna, cidx, cG, j, s, regular, theta, x, u0, u1, mask, slot,
               ivars, fvars, max_piv, enum_max_m, commit, xn, lamn, W):
    """One θ step of length ``s`` from ``x`` in mode ``j`` into ``xn``, ``lamn``.

    ``mask`` is the active set to try first, ``slot`` its cache slot in mode ``j`` (-1:
    unknown; regular steps only). Returns ``(status, mask, slot)``.
    """
    xf, q, z, w, act, tab, basis, za, augm, Ko, Mo, augn = W
    A = mats[I_A][j]
    B = mats[I_B][j]
    C = mats[I_C][j]
    D = mats[I_D][j]
    E = mats[I_E][j]
    F = mats[I_F][j]
    n = A.shape[0]
    m = B.shape[1]
    p = E.shape[1]
    if regular:
        Phi = mats[I_PHI][j]
        G0 = mats[I_G0][j]
        G1 = mats[I_G1][j]
        Kk = mats[I_K][j]
        Mk = mats[I_M][j]
        for i in range(n):
            v = 0.0
            for jj in range(n):
                v += Phi[i, jj] * x[jj]
            for jj in range(p):
                v += G0[i, jj] * u0[jj] + G1[i, jj] * u1[jj]
            xf[i] = v
    else:
        Kk = Ko
        Mk = Mo
        if not _odd_free(A, B, C, D, E, s, theta, x, u0, u1, xf, Ko, Mo, augn):
            return STEP_NONFINITE, mask, slot
    for i in range(m):
        v = 0.0
        for jj in range(n):
            v += C[i, jj] * xf[jj]
        for jj in range(p):
            v += F[i, jj] * u1[jj]
        q[i] = v
    # Never a silent NaN: inf - inf and NaN both give NaN.
    v = 0.0
    for i in range(n):
        v += xf[i]
    for i in range(m):
        v += q[i]
    if v - v != 0.0:
        return STEP_NONFINITE, mask, slot
    rtol = fvars[FV_RTOL]
    if m == 0:
        for i in range(n):
            xn[i] = xf[i]
        return STEP_OK, mask, slot
    fast = mflags[j, MF_FAST] != 0
    accepted = False
    if regular and fast:
        if slot < 0:
            slot = _lookup(Mk, mask, ckeys[j], cna[j], cidx[j], cG[j], ivars)
        na = cna[j, slot]
        if na >= 0:
            accepted = True
            zmax = 0.0
            for ii in range(na):
                v = 0.0
                for jj in range(na):
                    v += cG[j, slot, ii, jj] * q[cidx[j, slot, jj]]
                za[ii] = v
                if abs(v) > zmax:
                    zmax = abs(v)
            for ii in range(na):
                if za[ii] < -rtol * zmax:
                    accepted = False
                    break
            if accepted:
                for ii in range(na, m):
                    i = cidx[j, slot, ii]
                    v = q[i]
                    sc = abs(v)
                    for jj in range(na):
                        t = Mk[i, cidx[j, slot, jj]] * za[jj]
                        v += t
                        sc += abs(t)
                    if v < -rtol * sc:
                        accepted = False
                        break
            if accepted:
                for i in range(m):
                    lamn[i] = 0.0
                for jj in range(na):
                    lamn[cidx[j, slot, jj]] = za[jj]
    elif (not regular) and fast:
        # Shortened / split / trial step: try the previous active set by a direct solve.
        if _basis_solution(Mk, q, mask, z, augm):
            accepted = True
            zmax = 0.0
            for i in range(m):
                if abs(z[i]) > zmax:
                    zmax = abs(z[i])
            for i in range(m):
                if z[i] < -rtol * zmax:
                    accepted = False
                    break
            if accepted:
                for i in range(m):
                    if (mask >> i) & 1:
                        continue
                    v = q[i]
                    sc = abs(v)
                    for jj in range(m):
                        t = Mk[i, jj] * z[jj]
                        v += t
                        sc += abs(t)
                    if v < -rtol * sc:
                        accepted = False
                        break
            if accepted:
                for i in range(m):
                    lamn[i] = z[i] if z[i] > 0.0 else 0.0
    if not accepted:
        status, piv = lemke_nb(Mk, q, max_piv, fvars[FV_PIVOT_TOL], fvars[FV_LEX_TOL], tab,
                               basis, z, w, act)
        ivars[IV_FALLBACKS] += 1
        ivars[IV_PIVOTS] += piv
        if status == LEMKE_SOLVED or status == LEMKE_TRIVIAL:
            newmask = _mask_of(act)
        else:
            newmask = -1
            if m <= enum_max_m:
                newmask = _enumerate_nb(Mk, q, fvars[FV_FEAS_TOL], z, w, augm)
            if newmask < 0:
                ivars[IV_LEMKE] = status
                fm = 0
                for i in range(m):
                    if q[i] < 0.0:
                        fm |= 1 << i
                ivars[IV_FAILMASK] = fm
                return STEP_LCP_FAILED, mask, slot
        if commit and m <= mflags[j, MF_UNIQ]:
            ivars[IV_UNIQ] += 1
            diff = _unique_state(Mk, q, Kk, xf, z, fvars[FV_UNIQ_TOL], 1e-9, w, augm)
            if diff != 0:
                ivars[IV_FAILMASK] = diff
                return STEP_NONUNIQUE, mask, slot
        for i in range(m):
            lamn[i] = z[i]
        mask = newmask
        if regular and fast:
            slot = _lookup(Mk, mask, ckeys[j], cna[j], cidx[j], cG[j], ivars)
        else:
            slot = -1
    for i in range(n):
        v = xf[i]
        for jj in range(m):
            v += Kk[i, jj] * lamn[jj]
        xn[i] = v
    # Overflow in x_free + K λ (λ itself comes from a finite LCP solve).
    v = 0.0
    for i in range(n):
        v += xn[i]
    for i in range(m):
        v += lamn[i]
    if v - v != 0.0:
        return STEP_NONFINITE, mask, slot
    return STEP_OK, mask, slot


@njit(cache=True)
def _fast_regular(Phi, G0, G1, K, M, C, F, ck, cna_j, cidx_j, cG_j, x, u0, u1, ms, mi, xf, q,
                  za, xn, lamn, rtol, ivars):
    """A regular step (stored matrices of one mode) by the cached active set ``ms[mi]``
    (slot ``ms[mi + 1]``); returns False when the active set is not accepted (then the full
    :func:`_mode_step` decides)."""
    n = x.shape[0]
    m = q.shape[0]
    p = u0.shape[0]
    chk = 0.0
    for i in range(n):
        v = 0.0
        for jj in range(n):
            v += Phi[i, jj] * x[jj]
        for jj in range(p):
            v += G0[i, jj] * u0[jj] + G1[i, jj] * u1[jj]
        xf[i] = v
        chk += v
    for i in range(m):
        v = 0.0
        for jj in range(n):
            v += C[i, jj] * xf[jj]
        for jj in range(p):
            v += F[i, jj] * u1[jj]
        q[i] = v
        chk += v
    if chk - chk != 0.0:
        return False
    if m == 0:
        for i in range(n):
            xn[i] = xf[i]
        return True
    slot = ms[mi + 1]
    if slot < 0:
        slot = _lookup(M, ms[mi], ck, cna_j, cidx_j, cG_j, ivars)
        ms[mi + 1] = slot
    na = cna_j[slot]
    if na < 0:
        return False
    zmax = 0.0
    for ii in range(na):
        v = 0.0
        for jj in range(na):
            v += cG_j[slot, ii, jj] * q[cidx_j[slot, jj]]
        za[ii] = v
        if abs(v) > zmax:
            zmax = abs(v)
    for ii in range(na):
        if za[ii] < -rtol * zmax:
            return False
    for ii in range(na, m):
        i = cidx_j[slot, ii]
        v = q[i]
        sc = abs(v)
        for jj in range(na):
            t = M[i, cidx_j[slot, jj]] * za[jj]
            v += t
            sc += abs(t)
        if v < -rtol * sc:
            return False
    for i in range(m):
        lamn[i] = 0.0
    for jj in range(na):
        lamn[cidx_j[slot, jj]] = za[jj]
    chk = 0.0
    for i in range(n):
        v = xf[i]
        for jj in range(na):
            v += K[i, cidx_j[slot, jj]] * za[jj]
        xn[i] = v
        chk += v
    return chk - chk == 0.0


@njit(cache=True)
def _row_value(Cr, Dr, Fr, r, x, lam, u):
    """``Cr[r] x + Dr[r] λ + Fr[r] u`` and the sum of the magnitudes of its terms."""
    v = 0.0
    sc = 0.0
    for jj in range(x.shape[0]):
        t = Cr[r, jj] * x[jj]
        v += t
        sc += abs(t)
    for jj in range(lam.shape[0]):
        t = Dr[r, jj] * lam[jj]
        v += t
        sc += abs(t)
    for jj in range(u.shape[0]):
        t = Fr[r, jj] * u[jj]
        v += t
        sc += abs(t)
    return v, sc


@njit(cache=True)
def _controls(mats, j, x, lam, u, c, cs, wgt, add):
    """Switch controls ``c += wgt (Cc x + Dc λ + Fc u)`` of mode ``j`` (``c = ...`` unless
    ``add``) and their floating-point scales ``cs`` (sum of the magnitudes of the terms)."""
    Cc = mats[I_CC][j]
    Dc = mats[I_DC][j]
    Fc = mats[I_FC][j]
    for i in range(Cc.shape[0]):
        v = 0.0
        sc = 0.0
        for jj in range(Cc.shape[1]):
            t = Cc[i, jj] * x[jj]
            v += t
            sc += abs(t)
        for jj in range(Dc.shape[1]):
            t = Dc[i, jj] * lam[jj]
            v += t
            sc += abs(t)
        for jj in range(Fc.shape[1]):
            t = Fc[i, jj] * u[jj]
            v += t
            sc += abs(t)
        if add:
            c[i] += wgt * v
            cs[i] += wgt * sc
        else:
            c[i] = wgt * v
            cs[i] = wgt * sc


@njit(cache=True)
def _relay_fraction(sig_off, sig_on, base_on):
    """On-fraction ``o`` of a relay ``o ∈ H(σ)`` (1 for σ > 0, 0 for σ < 0, [0, 1] at 0) with
    σ affine in o: ``σ(o) = (1 - o) sig_off + o sig_on``.

    This is the LCP ``0 <= o ⊥ -σ(o) + ν >= 0``, ``0 <= ν ⊥ 1 - o >= 0`` in closed form; in
    the repulsive case (several solutions) the switch keeps its state ``base_on``.
    """
    if sig_off > 0.0 and sig_on < 0.0:
        return sig_off / (sig_off - sig_on)
    if sig_off <= 0.0 and sig_on >= 0.0:
        return 1.0 if base_on else 0.0
    if sig_on >= 0.0:
        return 1.0
    return 0.0


@njit(cache=True)
def _advance(mats, mflags, ckeys, cna, cidx, cG, j, ja, sw, base_on, vt, s, regular, theta, x,
             u0, u1, ms, ivars, fvars, max_piv, enum_max_m, commit, xn, lamn, xa, lama, c, cs,
             sg, W):
    """One step of length ``s``: in mode ``j``, or, while switch ``sw`` slides (``sw >= 0``),
    the Filippov combination of modes ``j`` (``sw`` in state ``base_on``) and ``ja`` (``sw``
    toggled).

    ``ms = [mask, slot, mask_alt, slot_alt]`` (updated). Returns ``(status, d)`` with ``d``
    the fraction of the step spent in the toggled mode ``ja`` (0 when not sliding); the result
    is ``xn = (1 - d) x_j + d x_ja`` and the multipliers of each mode in ``lamn``, ``lama``;
    ``sg = [σ_j, σ_ja, tol]`` (relay values at the two end states and their round-off scale).
    """
    st, mk, sl = _mode_step(mats, mflags, ckeys, cna, cidx, cG, j, s, regular, theta, x, u0,
                            u1, ms[0], ms[1], ivars, fvars, max_piv, enum_max_m, commit, xn,
                            lamn, W)
    ms[0] = mk
    ms[1] = sl
    if st != STEP_OK:
        ivars[IV_FAILMODE] = j
        return st, 0.0
    if sw < 0:
        return STEP_OK, 0.0
    st, mk, sl = _mode_step(mats, mflags, ckeys, cna, cidx, cG, ja, s, regular, theta, x, u0,
                            u1, ms[2], ms[3], ivars, fvars, max_piv, enum_max_m, commit, xa,
                            lama, W)
    ms[2] = mk
    ms[3] = sl
    if st != STEP_OK:
        ivars[IV_FAILMODE] = ja
        return st, 0.0
    # Relay on the two endpoints: σ = c - vt of each mode at its own end state.
    _controls(mats, j, xn, lamn, u1, c, cs, 1.0, False)
    sig_b = c[sw] - vt
    scale = cs[sw]
    _controls(mats, ja, xa, lama, u1, c, cs, 1.0, False)
    sig_a = c[sw] - vt
    scale = max(scale, cs[sw]) + abs(vt)
    sg[0] = sig_b
    sg[1] = sig_a
    sg[2] = 1e-9 * scale
    if base_on:
        o = _relay_fraction(sig_a, sig_b, True)
        d = 1.0 - o
    else:
        o = _relay_fraction(sig_b, sig_a, False)
        d = o
    for i in range(xn.shape[0]):
        xn[i] = xn[i] + d * (xa[i] - xn[i])
    return STEP_OK, d


@njit(cache=True)
def _end_controls(mats, j, ja, d, x, lam, lama, u, c, cs):
    """Controls at the end of a step (combined over the two modes while sliding)."""
    if ja >= 0 and d != 0.0:
        _controls(mats, j, x, lam, u, c, cs, 1.0 - d, False)
        _controls(mats, ja, x, lama, u, c, cs, d, True)
    else:
        _controls(mats, j, x, lam, u, c, cs, 1.0, False)


@njit(cache=True)
def _crossing(sw_kind, sw_flags, sw_vt, sw_vh, key, slide, c, cs, g, gtol):
    """Per located comparator, ``g > 0`` when it has crossed its threshold (``-inf`` for the
    others); returns ``max g``. ``gtol`` receives the round-off scale of each ``g``."""
    G = -np.inf
    for i in range(c.shape[0]):
        g[i] = -np.inf
        gtol[i] = 0.0
        if sw_kind[i] != SW_LOCATED or i == slide:
            continue
        on = (key >> i) & 1
        if on:
            g[i] = (sw_vt[i] - sw_vh[i]) - c[i]
        else:
            if sw_flags[i] & SWF_LATCH:
                continue
            g[i] = c[i] - (sw_vt[i] + sw_vh[i])
        gtol[i] = 1e-12 * (cs[i] + abs(sw_vt[i]) + abs(sw_vh[i]))
        if g[i] > G:
            G = g[i]
    return G


@njit(cache=True)
def _hermite_root(ga, da, gb, db):
    """Root in (0, 1) of the cubic Hermite interpolant of ``g(0) = ga <= 0``, ``g'(0) = da``,
    ``g(1) = gb > 0``, ``g'(1) = db`` (safeguarded Newton from the linear guess)."""
    lo, hi = 0.0, 1.0
    tau = -ga / (gb - ga) if gb != ga else 0.5
    for _ in range(8):
        t2 = tau * tau
        t3 = t2 * tau
        p = ((2 * t3 - 3 * t2 + 1) * ga + (t3 - 2 * t2 + tau) * da + (-2 * t3 + 3 * t2) * gb
             + (t3 - t2) * db)
        dp = ((6 * t2 - 6 * tau) * ga + (3 * t2 - 4 * tau + 1) * da + (-6 * t2 + 6 * tau) * gb
              + (3 * t2 - 2 * tau) * db)
        if p > 0.0:
            hi = tau
        else:
            lo = tau
        if dp > 0.0:
            nt = tau - p / dp
        else:
            nt = 0.5 * (lo + hi)
        if not (lo < nt < hi):
            nt = 0.5 * (lo + hi)
        if abs(nt - tau) <= 1e-14:
            tau = nt
            break
        tau = nt
    return tau


@njit(cache=True)
def _control_rates(mats, j, x, lam, u, udot, rate, xdot):
    """``d/dt (Cc x + Fc u)`` from ``x' = A x + B λ + E u`` (the ``Dc λ'`` term is unknown and
    ignored: this only seeds the instant search)."""
    A = mats[I_A][j]
    B = mats[I_B][j]
    E = mats[I_E][j]
    Cc = mats[I_CC][j]
    Fc = mats[I_FC][j]
    n = A.shape[0]
    for i in range(n):
        v = 0.0
        for jj in range(n):
            v += A[i, jj] * x[jj]
        for jj in range(B.shape[1]):
            v += B[i, jj] * lam[jj]
        for jj in range(E.shape[1]):
            v += E[i, jj] * u[jj]
        xdot[i] = v
    for i in range(Cc.shape[0]):
        v = 0.0
        for jj in range(n):
            v += Cc[i, jj] * xdot[jj]
        for jj in range(Fc.shape[1]):
            v += Fc[i, jj] * udot[jj]
        rate[i] = v


@njit(cache=True)
def _store(mats, mflags, j, ja, d, slide, key, duty_sw, x, lam, lama, u, T_out, Y_out, pos, t,
           fvars):
    """Write the stored probes at time ``t`` into row ``pos``."""
    T_out[pos] = t
    n = x.shape[0]
    if mflags[j, MF_OUTSTATE] != 0 and (ja < 0 or d == 0.0):
        for i in range(n):
            Y_out[pos, i] = x[i]
        return
    Cy = mats[I_CY][j]
    Dy = mats[I_DY][j]
    Fy = mats[I_FY][j]
    for r in range(Cy.shape[0]):
        sw = duty_sw[r]
        if sw >= 0:
            if sw == slide:
                Y_out[pos, r] = fvars[FV_DUTY]
            else:
                Y_out[pos, r] = 1.0 if (key >> sw) & 1 else 0.0
            continue
        v = 0.0
        for jj in range(n):
            v += Cy[r, jj] * x[jj]
        for jj in range(Dy.shape[1]):
            v += Dy[r, jj] * lam[jj]
        for jj in range(Fy.shape[1]):
            v += Fy[r, jj] * u[jj]
        if ja >= 0 and d != 0.0:
            Cya = mats[I_CY][ja]
            Dya = mats[I_DY][ja]
            Fya = mats[I_FY][ja]
            va = 0.0
            for jj in range(n):
                va += Cya[r, jj] * x[jj]
            for jj in range(Dya.shape[1]):
                va += Dya[r, jj] * lama[jj]
            for jj in range(Fya.shape[1]):
                va += Fya[r, jj] * u[jj]
            v = (1.0 - d) * v + d * va
        Y_out[pos, r] = v


@njit(cache=True)
def _find_mode(mkey, nmodes, key):
    for i in range(nmodes):
        if mkey[i] == key:
            return i
    return -1


@njit(cache=True)
def _u_interp(U0, Um, U1, kk, tau, out):
    """Inputs at the fraction ``tau`` of grid step ``kk``: linear between the step ends (exact
    for piecewise-linear sources), or quadratic through the midpoint values ``Um`` when given
    (``Um.shape[0] > 0``: some source is not piecewise linear)."""
    if Um.shape[0] == 0:
        for i in range(out.shape[0]):
            out[i] = U0[kk, i] + (U1[kk, i] - U0[kk, i]) * tau
    else:
        for i in range(out.shape[0]):
            a = U0[kk, i]
            b = Um[kk, i]
            c = U1[kk, i]
            out[i] = a + tau * (-3.0 * a + 4.0 * b - c) + tau * tau * (2.0 * a - 4.0 * b + 2.0 * c)


@njit(cache=True)
def _locate(mats, mflags, ckeys, cna, cidx, cG, j, ja, slide, base_on, vt_s, ta, s, theta, x,
            lam, ua, ub, ms, ivars, fvars, max_piv, enum_max_m, sw_kind, sw_flags, sw_vt,
            sw_vh, key, xfull, lamfull, lamafull, dfull, c, cs, g, gt, W, S, U0, Um, U1, kk,
            tau_a):
    """Locate the first comparator crossing inside the step ``[ta, ta + s]``.

    On entry ``g``/``gt`` hold the crossing functions at the end of the full step (some
    ``g > 0``) and ``ms`` the active sets at the start. Trial steps of length ``s1`` from
    ``ta`` are taken until ``|max g(s1)|`` is round-off or the bracket is shorter than
    ``FV_ROOT_TOL * h``. Returns ``(status, s_star, d_star)``; the state at the instant is in
    ``S``'s ``xs, lams, lamas``, the crossing functions there in ``g``/``gt``.
    """
    (ga, gta, rate_a, rate_b, udot, xdot, ut, xt, lamt, lamat, xat, g_hi, gt_hi, xs, lams,
     lamas, sg, msl) = S
    k = g.shape[0]
    n = x.shape[0]
    m = lam.shape[0]
    p = ua.shape[0]
    h = fvars[FV_H]
    stol = max(fvars[FV_ROOT_TOL] * h, 8.9e-16 * abs(ta + s))
    # Crossing functions at the start (mode j; λ of the previous step, an estimate).
    _controls(mats, j, x, lam, ua, c, cs, 1.0, False)
    Ga = _crossing(sw_kind, sw_flags, sw_vt, sw_vh, key, slide, c, cs, ga, gta)
    for i in range(p):
        udot[i] = (ub[i] - ua[i]) / s
    _control_rates(mats, j, x, lam, ua, udot, rate_a, xdot)
    _control_rates(mats, j, xfull, lamfull, ub, udot, rate_b, xdot)
    Gb = -np.inf
    for i in range(k):
        g_hi[i] = g[i]
        gt_hi[i] = gt[i]
        if g[i] > Gb:
            Gb = g[i]
    for i in range(n):
        xs[i] = xfull[i]
    for i in range(m):
        lams[i] = lamfull[i]
        lamas[i] = lamafull[i]
    d_hi = dfull
    lo, glo = 0.0, min(Ga, 0.0)
    hi, ghi = s, Gb
    # First guess: root of the cubic Hermite interpolant of each crossing g (values and
    # rates at both ends), the earliest one.
    tau = 1.0
    for i in range(k):
        if g[i] > 0.0:
            sgn = -1.0 if (key >> i) & 1 else 1.0
            gai = min(ga[i], 0.0) if ga[i] != -np.inf else 0.0
            ti = _hermite_root(gai, s * sgn * rate_a[i], g[i], s * sgn * rate_b[i])
            if ti < tau:
                tau = ti
    s1 = tau * s
    if not (lo < s1 < hi):
        s1 = lo + (hi - lo) * (-glo) / (ghi - glo) if ghi != glo else 0.5 * (lo + hi)
    if s1 < stol:
        s1 = stol
    sp, gp = hi, ghi
    width_ref = hi - lo
    s_star = hi
    d_star = d_hi
    use_last = False
    d1 = 0.0
    for it in range(60):
        if s1 >= hi:
            s1 = 0.5 * (lo + hi)
        _u_interp(U0, Um, U1, kk, tau_a + (1.0 - tau_a) * (s1 / s), ut)
        for i in range(4):
            msl[i] = ms[i]
        msl[1] = -1
        msl[3] = -1
        st, d1 = _advance(mats, mflags, ckeys, cna, cidx, cG, j, ja, slide, base_on, vt_s, s1,
                          False, theta, x, ua, ut, msl, ivars, fvars, max_piv, enum_max_m,
                          False, xt, lamt, xat, lamat, c, cs, sg, W)
        ivars[IV_ROOTEVALS] += 1
        if st != STEP_OK:
            return st, s1, 0.0
        _end_controls(mats, j, ja, d1, xt, lamt, lamat, ut, c, cs)
        G1 = _crossing(sw_kind, sw_flags, sw_vt, sw_vh, key, slide, c, cs, g, gt)
        gtol = 0.0
        for i in range(k):
            if gt[i] > gtol:
                gtol = gt[i]
        if G1 > 0.0:
            hi, ghi = s1, G1
            for i in range(k):
                g_hi[i] = g[i]
                gt_hi[i] = gt[i]
            for i in range(n):
                xs[i] = xt[i]
            for i in range(m):
                lams[i] = lamt[i]
                lamas[i] = lamat[i]
            d_hi = d1
        else:
            lo, glo = s1, G1
        if abs(G1) <= gtol:
            use_last = True
            break
        if hi - lo <= stol:
            break
        # Secant through the last two trials when it falls inside the bracket, bisection
        # when the bracket has not halved in three trials.
        s2 = -1.0
        if G1 != gp:
            s2 = s1 - G1 * (s1 - sp) / (G1 - gp)
        if it % 3 == 2:
            if hi - lo > 0.5 * width_ref:
                s2 = -1.0
            width_ref = hi - lo
        if not (lo < s2 < hi):
            s2 = lo + (hi - lo) * (-glo) / (ghi - glo) if (it % 3 != 2 and ghi != glo) \
                else 0.5 * (lo + hi)
            if not (lo < s2 < hi):
                s2 = 0.5 * (lo + hi)
        sp, gp = s1, G1
        s1 = s2
    if use_last:
        s_star = s1
        d_star = d1
        for i in range(n):
            xs[i] = xt[i]
        for i in range(m):
            lams[i] = lamt[i]
            lamas[i] = lamat[i]
        for i in range(4):
            ms[i] = msl[i]
    else:
        s_star = hi
        d_star = d_hi
        for i in range(k):
            g[i] = g_hi[i]
            gt[i] = gt_hi[i]
    return STEP_OK, s_star, d_star


@njit(cache=True)
def _odd_step(A, B, C, D, E, F, s, theta, x, u0, u1, mask, xf, q, z, w, act, tab, basis, augm,
              Ko, Mo, augn, xn, lamn, fvars, ivars, max_piv, enum_max_m):
    """A trial θ step of length ``s`` in one mode (matrices discretised on the fly), trying the
    active set ``mask`` first, then Lemke, then enumeration; no uniqueness check. Returns
    ``(status, mask)``."""
    n = A.shape[0]
    m = B.shape[1]
    if not _odd_free(A, B, C, D, E, s, theta, x, u0, u1, xf, Ko, Mo, augn):
        return STEP_NONFINITE, mask
    p = u1.shape[0]
    chk = 0.0
    for i in range(m):
        v = 0.0
        for jj in range(n):
            v += C[i, jj] * xf[jj]
        for jj in range(p):
            v += F[i, jj] * u1[jj]
        q[i] = v
        chk += v
    for i in range(n):
        chk += xf[i]
    if chk - chk != 0.0:
        return STEP_NONFINITE, mask
    rtol = fvars[FV_RTOL]
    ok = False
    if m == 0:
        ok = True
    elif m <= MAX_MASK_M and _basis_solution(Mo, q, mask, z, augm):
        ok = True
        zmax = 0.0
        for i in range(m):
            if abs(z[i]) > zmax:
                zmax = abs(z[i])
        for i in range(m):
            if z[i] < -rtol * zmax:
                ok = False
                break
        if ok:
            for i in range(m):
                if (mask >> i) & 1:
                    continue
                v = q[i]
                sc = abs(v)
                for jj in range(m):
                    t = Mo[i, jj] * z[jj]
                    v += t
                    sc += abs(t)
                if v < -rtol * sc:
                    ok = False
                    break
    if m > 0 and not ok:
        status, piv = lemke_nb(Mo, q, max_piv, fvars[FV_PIVOT_TOL], fvars[FV_LEX_TOL], tab,
                               basis, z, w, act)
        ivars[IV_FALLBACKS] += 1
        ivars[IV_PIVOTS] += piv
        if status == LEMKE_SOLVED or status == LEMKE_TRIVIAL:
            mask = _mask_of(act)
        else:
            newmask = -1
            if m <= enum_max_m:
                newmask = _enumerate_nb(Mo, q, fvars[FV_FEAS_TOL], z, w, augm)
            if newmask < 0:
                ivars[IV_LEMKE] = status
                fm = 0
                for i in range(m):
                    if q[i] < 0.0:
                        fm |= 1 << i
                ivars[IV_FAILMASK] = fm
                return STEP_LCP_FAILED, mask
            mask = newmask
    chk = 0.0
    for i in range(m):
        lamn[i] = z[i] if z[i] > 0.0 else 0.0
    for i in range(n):
        v = xf[i]
        for jj in range(m):
            v += Ko[i, jj] * lamn[jj]
        xn[i] = v
        chk += v
    if chk - chk != 0.0:
        return STEP_NONFINITE, mask
    return STEP_OK, mask


@njit(cache=True)
def _crossing_rows(Cc, Dc, Fc, sw_kind, sw_flags, sw_vt, sw_vh, key, x, lam, u, c, cs, g, gt):
    """:func:`_crossing` with the controls of one mode computed here (not sliding)."""
    G = -np.inf
    for i in range(sw_kind.shape[0]):
        g[i] = -np.inf
        gt[i] = 0.0
        if sw_kind[i] != SW_LOCATED:
            continue
        on = (key >> i) & 1
        if (not on) and (sw_flags[i] & SWF_LATCH) != 0:
            continue
        v, sc = _row_value(Cc, Dc, Fc, i, x, lam, u)
        c[i] = v
        cs[i] = sc
        if on:
            g[i] = (sw_vt[i] - sw_vh[i]) - v
        else:
            g[i] = v - (sw_vt[i] + sw_vh[i])
        gt[i] = 1e-12 * (sc + abs(sw_vt[i]) + abs(sw_vh[i]))
        if g[i] > G:
            G = g[i]
    return G


@njit(cache=True)
def _locate_plain(A, B, C, D, E, F, Cc, Dc, Fc, sw_kind, sw_flags, sw_vt, sw_vh, key, ta, s,
                  theta, x, lam, ua, ub, mask, xfull, lamfull, c, cs, g, gt, W, S, fvars,
                  ivars, max_piv, enum_max_m, U0, Um, U1, kk, tau_a):
    """:func:`_locate` when no switch slides, with the mode's matrices passed directly (the
    common, faster path). Returns ``(status, s_star, mask)``; the state at the instant is in
    ``S``'s ``xs, lams``, the crossing functions there in ``g``/``gt``."""
    xf, q, z, w, act, tab, basis, za, augm, Ko, Mo, augn = W
    (ga, gta, rate_a, rate_b, udot, xdot, ut, xt, lamt, lamat, xat, g_hi, gt_hi, xs, lams,
     lamas, sg, msl) = S
    k = g.shape[0]
    n = x.shape[0]
    m = lam.shape[0]
    p = ua.shape[0]
    h = fvars[FV_H]
    stol = max(fvars[FV_ROOT_TOL] * h, 8.9e-16 * abs(ta + s))
    Ga = _crossing_rows(Cc, Dc, Fc, sw_kind, sw_flags, sw_vt, sw_vh, key, x, lam, ua, c, cs, ga,
                        gta)
    for i in range(p):
        udot[i] = (ub[i] - ua[i]) / s
    # Rates of the controls at both ends (x' = A x + B λ + E u; the Dc λ' term is ignored).
    for end in range(2):
        xe = x if end == 0 else xfull
        le = lam if end == 0 else lamfull
        ue = ua if end == 0 else ub
        rate = rate_a if end == 0 else rate_b
        for i in range(n):
            v = 0.0
            for jj in range(n):
                v += A[i, jj] * xe[jj]
            for jj in range(m):
                v += B[i, jj] * le[jj]
            for jj in range(p):
                v += E[i, jj] * ue[jj]
            xdot[i] = v
        for i in range(k):
            v = 0.0
            for jj in range(n):
                v += Cc[i, jj] * xdot[jj]
            for jj in range(p):
                v += Fc[i, jj] * udot[jj]
            rate[i] = v
    Gb = -np.inf
    for i in range(k):
        g_hi[i] = g[i]
        gt_hi[i] = gt[i]
        if g[i] > Gb:
            Gb = g[i]
    for i in range(n):
        xs[i] = xfull[i]
    for i in range(m):
        lams[i] = lamfull[i]
    lo, glo = 0.0, min(Ga, 0.0)
    hi, ghi = s, Gb
    tau = 1.0
    for i in range(k):
        if g[i] > 0.0:
            sgn = -1.0 if (key >> i) & 1 else 1.0
            gai = min(ga[i], 0.0) if ga[i] != -np.inf else 0.0
            ti = _hermite_root(gai, s * sgn * rate_a[i], g[i], s * sgn * rate_b[i])
            if ti < tau:
                tau = ti
    s1 = tau * s
    if not (lo < s1 < hi):
        s1 = lo + (hi - lo) * (-glo) / (ghi - glo) if ghi != glo else 0.5 * (lo + hi)
    if s1 < stol:
        s1 = stol
    sp, gp = hi, ghi
    width_ref = hi - lo
    use_last = False
    mask_t = mask
    for it in range(60):
        if s1 >= hi:
            s1 = 0.5 * (lo + hi)
        _u_interp(U0, Um, U1, kk, tau_a + (1.0 - tau_a) * (s1 / s), ut)
        st, mask_t = _odd_step(A, B, C, D, E, F, s1, theta, x, ua, ut, mask, xf, q, z, w, act,
                               tab, basis, augm, Ko, Mo, augn, xt, lamt, fvars, ivars, max_piv,
                               enum_max_m)
        ivars[IV_ROOTEVALS] += 1
        if st != STEP_OK:
            return st, s1, mask
        G1 = _crossing_rows(Cc, Dc, Fc, sw_kind, sw_flags, sw_vt, sw_vh, key, xt, lamt, ut, c,
                            cs, g, gt)
        gtol = 0.0
        for i in range(k):
            if gt[i] > gtol:
                gtol = gt[i]
        if G1 > 0.0:
            hi, ghi = s1, G1
            for i in range(k):
                g_hi[i] = g[i]
                gt_hi[i] = gt[i]
            for i in range(n):
                xs[i] = xt[i]
            for i in range(m):
                lams[i] = lamt[i]
        else:
            lo, glo = s1, G1
        if abs(G1) <= gtol:
            use_last = True
            break
        if hi - lo <= stol:
            break
        s2 = -1.0
        if G1 != gp:
            s2 = s1 - G1 * (s1 - sp) / (G1 - gp)
        if it % 3 == 2:
            if hi - lo > 0.5 * width_ref:
                s2 = -1.0
            width_ref = hi - lo
        if not (lo < s2 < hi):
            s2 = lo + (hi - lo) * (-glo) / (ghi - glo) if (it % 3 != 2 and ghi != glo) \
                else 0.5 * (lo + hi)
            if not (lo < s2 < hi):
                s2 = 0.5 * (lo + hi)
        sp, gp = s1, G1
        s1 = s2
    if use_last:
        for i in range(n):
            xs[i] = xt[i]
        for i in range(m):
            lams[i] = lamt[i]
        return STEP_OK, s1, mask_t
    for i in range(k):
        g[i] = g_hi[i]
        gt[i] = gt_hi[i]
    return STEP_OK, hi, mask


@njit(cache=True)
def _record(ev_t, ev_key, ev_info, ivars, t, key, info):
    e = ivars[IV_EVPOS]
    ev_t[e] = t
    ev_key[e] = key
    ev_info[e] = info
    ivars[IV_EVPOS] = e + 1


@njit(cache=True)
def _plain_steps(Phi, G0, G1, K, M, C, F, Cy, Dy, Fy, ck, cna_j, cidx_j, cG_j, outstate,
                 has_duty, duty_sw, key, tgrid, odd, U0, U1, force_out, kk, kstop, x, lam, ms,
                 xf, q, za, xn, lamn, T_out, Y_out, ivars, rtol, every, countdown, cap_row):
    """Regular grid steps ``kk .. kstop-1`` of one mode with no comparator, no sliding and no
    schedule entry: the inline fast path of :func:`run_grid` without its per-step switching
    machinery (the same arithmetic, so the same numbers). Stops at the first step it cannot
    take (shortened, active set not accepted, non-finite, output buffer nearly full), which
    :func:`run_grid` then takes; returns ``(kk, countdown)``."""
    n = x.shape[0]
    m = lam.shape[0]
    p = U0.shape[1]
    r_out = Y_out.shape[1]
    pos = ivars[IV_OUTPOS]
    steps = 0
    while kk < kstop:
        if odd[kk] or pos > cap_row:
            break
        for i in range(n):
            v = 0.0
            for jj in range(n):
                v += Phi[i, jj] * x[jj]
            for jj in range(p):
                v += G0[i, jj] * U0[kk, jj] + G1[i, jj] * U1[kk, jj]
            xf[i] = v
        chk = 0.0
        for i in range(m):
            v = 0.0
            for jj in range(n):
                v += C[i, jj] * xf[jj]
            for jj in range(p):
                v += F[i, jj] * U1[kk, jj]
            q[i] = v
            chk += v
        for i in range(n):
            chk += xf[i]
        if chk - chk != 0.0:
            break
        if m == 0:
            for i in range(n):
                xn[i] = xf[i]
        else:
            slot = ms[1]
            if slot < 0:
                slot = _lookup(M, ms[0], ck, cna_j, cidx_j, cG_j, ivars)
                ms[1] = slot
            na = cna_j[slot]
            if na < 0:
                break
            done = True
            zmax = 0.0
            for ii in range(na):
                v = 0.0
                for jj in range(na):
                    v += cG_j[slot, ii, jj] * q[cidx_j[slot, jj]]
                za[ii] = v
                if abs(v) > zmax:
                    zmax = abs(v)
            for ii in range(na):
                if za[ii] < -rtol * zmax:
                    done = False
                    break
            if done:
                for ii in range(na, m):
                    i = cidx_j[slot, ii]
                    v = q[i]
                    sc = abs(v)
                    for jj in range(na):
                        t = M[i, cidx_j[slot, jj]] * za[jj]
                        v += t
                        sc += abs(t)
                    if v < -rtol * sc:
                        done = False
                        break
            if not done:
                break
            for i in range(m):
                lamn[i] = 0.0
            for jj in range(na):
                lamn[cidx_j[slot, jj]] = za[jj]
            chk = 0.0
            for i in range(n):
                v = xf[i]
                for jj in range(na):
                    v += K[i, cidx_j[slot, jj]] * za[jj]
                xn[i] = v
                chk += v
            if chk - chk != 0.0:
                break
        for i in range(n):
            x[i] = xn[i]
        for i in range(m):
            lam[i] = lamn[i]
        steps += 1
        countdown -= 1
        if countdown == 0 or force_out[kk]:
            if countdown == 0:
                countdown = every
            tb = tgrid[kk + 1]
            T_out[pos] = tb
            if outstate and not has_duty:
                for i in range(n):
                    Y_out[pos, i] = x[i]
            else:
                for r in range(r_out):
                    sw = duty_sw[r]
                    if sw >= 0:
                        Y_out[pos, r] = 1.0 if (key >> sw) & 1 else 0.0
                        continue
                    v = 0.0
                    for jj in range(n):
                        v += Cy[r, jj] * x[jj]
                    for jj in range(m):
                        v += Dy[r, jj] * lam[jj]
                    for jj in range(p):
                        v += Fy[r, jj] * U1[kk, jj]
                    Y_out[pos, r] = v
            pos += 1
        kk += 1
    ivars[IV_OUTPOS] = pos
    ivars[IV_STEPS] += steps
    ivars[IV_GSTEP] += steps
    return kk, countdown


@njit(cache=True)
def run_grid(
    mats, mkey, mflags, ckeys, cna, cidx, cG,
    sw_kind, sw_flags, sw_vt, sw_vh,
    tgrid, odd, U0, U1, Um, force_out,
    sched_k, sched_op, sched_a, sched_b,
    x, lam, lama, ivars, fvars, max_piv, enum_max_m, every, max_sw,
    T_out, Y_out, duty_sw, ev_t, ev_key, ev_info, plain_mode,
):
    """Advance ``x`` over the grid chunk ``tgrid`` through every mode change.

    Parameters
    ----------
    mats : tuple of 17 float64 arrays, each (Q, ., .)
        Stacked per-mode matrices, indexed by ``I_*`` (rows ``< ivars[IV_NMODES]`` valid).
    mkey : int64[:], shape (Q,)
        Switch key (bit i = switch i on) of each mode.
    mflags : int64[:, :], shape (Q, MF_LEN)
    ckeys, cna, cidx, cG : arrays, shapes (Q, S), (Q, S), (Q, S, m), (Q, S, m, m)
        Active-set caches, one per mode (see ``_factor_active``).
    sw_kind, sw_flags : int64[:], shape (k,)
        ``SW_*`` kind and ``SWF_*`` flags of each switch.
    sw_vt, sw_vh : float64[:], shape (k,)
        Threshold and hysteresis half-width of each switch's comparator (control units).
    tgrid : float64[:], shape (N + 1,)
        Grid step boundaries, s; ``tgrid[0]`` is the end of the previous chunk.
    odd : bool[:], shape (N,)
        Grid steps not of length h.
    U0, U1 : float64[:, :], shape (N, p)
        Inputs at the start (right limit) and end (left limit) of each grid step; inside a
        step they are interpolated linearly (exact for piecewise-linear sources, whose
        breakpoints are grid points).
    Um : float64[:, :], shape (N, p) or (0, p)
        Inputs at the step midpoints when some source is not piecewise linear: the
        interpolation inside a step is then quadratic (O(h³)).
    force_out : bool[:], shape (N,)
        Store the end of this grid step whatever ``every`` says.
    sched_k, sched_op, sched_a, sched_b : int64[:], shape (L,)
        Schedule: before grid step ``sched_k[i]``, operation ``sched_op[i]`` (``OP_*``) with
        arguments ``a``, ``b``; sorted by ``sched_k``.
    x, lam, lama : float64[:]
        State (n,), multipliers (m,) and, while a switch slides, the other mode's multipliers
        (m,); updated in place.
    ivars, fvars : int64[:], float64[:]
        Counters, kernel state and options (``IV_*``, ``FV_*``).
    max_piv, enum_max_m, every, max_sw : int
        Lemke pivot budget; enumeration fallback up to this m; store every ``every``-th grid
        step; at most ``max_sw`` comparator switchings per grid step.
    T_out, Y_out : float64 arrays, shapes (cap,), (cap, r)
        Output buffers, written from row ``ivars[IV_OUTPOS]``.
    duty_sw : int64[:], shape (r,)
        Per output row, -1 for a probe (``Cy x + Dy λ + Fy u``) or a switch index (its
        on-fraction: 0/1, or the equivalent duty while it slides).
    ev_t, ev_key, ev_info : arrays, shape (cap_e,)
        Event records: time (s), switch key after it, ``switch + EV_*`` (-1: schedule).
    plain_mode : None or bool
        None: no plain loop (the branch is pruned when compiling, so that the per-step loop
        of runs with comparators keeps its speed); True: regular steps of runs with no
        comparator and no sliding go through :func:`_plain_steps`.

    Returns
    -------
    status : int
        ``STEP_OK`` (chunk done) or another ``STEP_*``; ``ivars[IV_K]`` and
        ``fvars[FV_TCUR]`` say where the kernel stopped (x, lam hold the state there).
    """
    n = x.shape[0]
    m = lam.shape[0]
    p = U0.shape[1]
    k = sw_kind.shape[0]
    N = tgrid.shape[0] - 1
    theta = fvars[FV_THETA]
    h = fvars[FV_H]
    W = (np.zeros(n), np.zeros(m), np.zeros(m), np.zeros(m), np.zeros(m, np.bool_),
         np.zeros((m, 2 * m + 2)), np.zeros(m, np.int64), np.zeros(m), np.zeros((m, m + 1)),
         np.zeros((n, m)), np.zeros((m, m)), np.zeros((n, n + 1 + m)))
    S = (np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(p), np.zeros(n),
         np.zeros(p), np.zeros(n), np.zeros(m), np.zeros(m), np.zeros(n), np.zeros(k),
         np.zeros(k), np.zeros(n), np.zeros(m), np.zeros(m), np.zeros(3),
         np.zeros(4, np.int64))
    sg = np.zeros(3)
    xn = np.zeros(n)
    lamn = np.zeros(m)
    xa = np.zeros(n)
    lamna = np.zeros(m)
    c = np.zeros(k)
    cs = np.zeros(k)
    g = np.zeros(k)
    gt = np.zeros(k)
    ua = np.zeros(p)
    ms = np.zeros(4, np.int64)
    ms0 = np.zeros(4, np.int64)
    ms[0] = ivars[IV_MASK]
    ms[1] = -1
    ms[2] = ivars[IV_MASK_ALT]
    ms[3] = -1
    has_located = False
    has_sampled = False
    for i in range(k):
        if sw_kind[i] == SW_LOCATED:
            has_located = True
        elif sw_kind[i] == SW_SAMPLED:
            has_sampled = True
    key = ivars[IV_KEY]
    slide = ivars[IV_SLIDE]
    tcur = fvars[FV_TCUR]
    nsched = sched_k.shape[0]
    min_step = 1e-9 * h
    countdown = every - ivars[IV_GSTEP] % every
    cap_out = T_out.shape[0]
    cap_ev = ev_t.shape[0]
    j = -1
    ja = -1
    d = 0.0
    status = STEP_OK
    # The arrays of the current mode, bound to locals when the mode changes: the regular
    # step, the comparator check and the output below are inline (a call that passes the
    # stacked matrices costs hundreds of atomic reference-count updates).
    jb = 0
    Phi_j = mats[I_PHI][0]
    G0_j = mats[I_G0][0]
    G1_j = mats[I_G1][0]
    K_j = mats[I_K][0]
    M_j = mats[I_M][0]
    C_j = mats[I_C][0]
    F_j = mats[I_F][0]
    Cy_j = mats[I_CY][0]
    Dy_j = mats[I_DY][0]
    Fy_j = mats[I_FY][0]
    Cc_j = mats[I_CC][0]
    Dc_j = mats[I_DC][0]
    Fc_j = mats[I_FC][0]
    ck_j = ckeys[0]
    cna_j = cna[0]
    cidx_j = cidx[0]
    cG_j = cG[0]
    A_j = mats[I_A][0]
    B_j = mats[I_B][0]
    D_j = mats[I_D][0]
    E_j = mats[I_E][0]
    fast_j = mflags[0, MF_FAST] != 0
    outstate_j = mflags[0, MF_OUTSTATE] != 0
    jab = 0
    Phi_a = mats[I_PHI][0]
    G0_a = mats[I_G0][0]
    G1_a = mats[I_G1][0]
    K_a = mats[I_K][0]
    M_a = mats[I_M][0]
    C_a = mats[I_C][0]
    F_a = mats[I_F][0]
    Cy_a = mats[I_CY][0]
    Dy_a = mats[I_DY][0]
    Fy_a = mats[I_FY][0]
    Cc_a = mats[I_CC][0]
    Dc_a = mats[I_DC][0]
    Fc_a = mats[I_FC][0]
    ck_a = ckeys[0]
    cna_a = cna[0]
    cidx_a = cidx[0]
    cG_a = cG[0]
    fast_a = mflags[0, MF_FAST] != 0
    Ko = W[9]
    Mo = W[10]
    augn = W[11]
    zb = W[2]
    augm = W[8]
    has_duty = False
    for r in range(duty_sw.shape[0]):
        if duty_sw[r] >= 0:
            has_duty = True
    xf = W[0]
    q = W[1]
    za = W[7]
    rtol = fvars[FV_RTOL]
    r_out = Y_out.shape[1]
    plain = not has_located and not has_sampled
    plain_skip = -1
    kk = ivars[IV_K]
    while kk < N:
        ta_grid = tgrid[kk]
        tb = tgrid[kk + 1]
        if tcur < ta_grid:
            tcur = ta_grid
        # Room for this step's rows and events.
        if (ivars[IV_OUTPOS] + max_sw + 3 > cap_out
                or ivars[IV_EVPOS] + 2 * max_sw + k + 6 + (nsched - ivars[IV_SCHED]) > cap_ev):
            status = STEP_FULL
            break
        if plain_mode is not None:
            if (plain and slide < 0 and kk != plain_skip and j >= 0 and mkey[j] == key
                    and tcur <= ta_grid and ivars[IV_INIT] != kk):
                # No comparator and no sliding: the regular steps up to the next schedule entry
                # by the plain loop (see _plain_steps); it stops where this loop must take over.
                kstop = N
                sp = ivars[IV_SCHED]
                if sp < nsched and sched_k[sp] < kstop:
                    kstop = sched_k[sp]
                # (only for runs of PLAIN_MIN steps or more: a call costs the views of the
                # mode's matrices, more than a few steps gain)
                if kstop - kk >= PLAIN_MIN and (m == 0 or mflags[j, MF_FAST] != 0):
                    k2, countdown = _plain_steps(
                        mats[I_PHI][j], mats[I_G0][j], mats[I_G1][j], mats[I_K][j], mats[I_M][j],
                        mats[I_C][j], mats[I_F][j], mats[I_CY][j], mats[I_DY][j], mats[I_FY][j],
                        ckeys[j], cna[j], cidx[j], cG[j], mflags[j, MF_OUTSTATE] != 0, has_duty,
                        duty_sw, key, tgrid, odd, U0, U1, force_out, kk, kstop, x, lam, ms, xf, q,
                        za, xn, lamn, T_out, Y_out, ivars, rtol, every, countdown,
                        cap_out - max_sw - 3)
                    plain_skip = k2
                    if k2 > kk:
                        # (the state the per-step loop leaves after plain steps)
                        for i in range(m):
                            lama[i] = lamna[i]
                        d = 0.0
                        tcur = tgrid[k2]
                        ivars[IV_INIT] = k2 - 1
                        ivars[IV_NSW] = 0
                        kk = k2
                        continue
        if ivars[IV_INIT] != kk:
            ivars[IV_INIT] = kk
            ivars[IV_NSW] = 0
        # Scheduled switchings at the start of the step.
        need = -1
        while tcur == ta_grid and ivars[IV_SCHED] < nsched and sched_k[ivars[IV_SCHED]] <= kk:
            sp = ivars[IV_SCHED]
            if sched_k[sp] < kk:  # (an entry before the resume point: already past)
                ivars[IV_SCHED] = sp + 1
                continue
            if sched_op[sp] == OP_SET:
                newkey = (key & ~sched_a[sp]) | sched_b[sp]
                info = -1
            else:
                i = sched_a[sp]
                j = _find_mode(mkey, ivars[IV_NMODES], key)
                if j < 0:
                    need = key
                    break
                _controls(mats, j, x, lam, U0[kk], c, cs, 1.0, False)
                if c[i] >= sw_vt[i] - sw_vh[i]:
                    newkey = key | (1 << i)
                else:
                    newkey = key & ~(1 << i)
                info = i
            ivars[IV_SCHED] = sp + 1
            if newkey != key:
                key = newkey
                _record(ev_t, ev_key, ev_info, ivars, ta_grid, key, info)
                if slide >= 0 and info == slide:
                    slide = -1
        if need >= 0:
            status = STEP_NEED_MODE
            ivars[IV_NEED] = need
            break
        if j < 0 or mkey[j] != key:
            j = _find_mode(mkey, ivars[IV_NMODES], key)
            ms[1] = -1
            if j < 0:
                status = STEP_NEED_MODE
                ivars[IV_NEED] = key
                break
        if slide >= 0:
            akey = key ^ (1 << slide)
            if ja < 0 or mkey[ja] != akey:
                ja = _find_mode(mkey, ivars[IV_NMODES], akey)
                ms[3] = -1
                if ja < 0:
                    status = STEP_NEED_MODE
                    ivars[IV_NEED] = akey
                    break
        else:
            ja = -1
        # Sub-steps: the whole grid step, or its parts between switching instants.
        need = -1
        while True:
            if tb - tcur <= min_step:
                # (a switching within round-off of the grid point: nothing left to integrate)
                tcur = tb
                break
            ta = tcur
            s = tb - ta
            regular = (not odd[kk]) and ta == ta_grid
            tau_a = 0.0
            if ta == ta_grid:
                for i in range(p):
                    ua[i] = U0[kk, i]
            else:
                tau_a = (ta - ta_grid) / (tb - ta_grid)
                _u_interp(U0, Um, U1, kk, tau_a, ua)
            ub = U1[kk]
            base_on = slide >= 0 and ((key >> slide) & 1) == 1
            vts = sw_vt[slide] if slide >= 0 else 0.0
            for i in range(4):
                ms0[i] = ms[i]
            if jb != j:
                jb = j
                Phi_j = mats[I_PHI][j]
                G0_j = mats[I_G0][j]
                G1_j = mats[I_G1][j]
                K_j = mats[I_K][j]
                M_j = mats[I_M][j]
                C_j = mats[I_C][j]
                F_j = mats[I_F][j]
                Cy_j = mats[I_CY][j]
                Dy_j = mats[I_DY][j]
                Fy_j = mats[I_FY][j]
                Cc_j = mats[I_CC][j]
                Dc_j = mats[I_DC][j]
                Fc_j = mats[I_FC][j]
                ck_j = ckeys[j]
                cna_j = cna[j]
                cidx_j = cidx[j]
                cG_j = cG[j]
                A_j = mats[I_A][j]
                B_j = mats[I_B][j]
                D_j = mats[I_D][j]
                E_j = mats[I_E][j]
                fast_j = mflags[j, MF_FAST] != 0
                outstate_j = mflags[j, MF_OUTSTATE] != 0
            if slide >= 0 and jab != ja:
                jab = ja
                Phi_a = mats[I_PHI][ja]
                G0_a = mats[I_G0][ja]
                G1_a = mats[I_G1][ja]
                K_a = mats[I_K][ja]
                M_a = mats[I_M][ja]
                C_a = mats[I_C][ja]
                F_a = mats[I_F][ja]
                Cy_a = mats[I_CY][ja]
                Dy_a = mats[I_DY][ja]
                Fy_a = mats[I_FY][ja]
                Cc_a = mats[I_CC][ja]
                Dc_a = mats[I_DC][ja]
                Fc_a = mats[I_FC][ja]
                ck_a = ckeys[ja]
                cna_a = cna[ja]
                cidx_a = cidx[ja]
                cG_a = cG[ja]
                fast_a = mflags[ja, MF_FAST] != 0
            done = False
            st = STEP_OK
            dd = 0.0
            if slide >= 0 and regular and (m == 0 or (fast_j and fast_a)):
                # Sliding, regular step: both modes by their cached active sets, then the relay
                # (see _advance).
                if _fast_regular(Phi_j, G0_j, G1_j, K_j, M_j, C_j, F_j, ck_j, cna_j, cidx_j,
                                 cG_j, x, ua, ub, ms, 0, xf, q, za, xn, lamn, rtol, ivars):
                    if _fast_regular(Phi_a, G0_a, G1_a, K_a, M_a, C_a, F_a, ck_a, cna_a,
                                     cidx_a, cG_a, x, ua, ub, ms, 2, xf, q, za, xa, lamna,
                                     rtol, ivars):
                        sgb, scb = _row_value(Cc_j, Dc_j, Fc_j, slide, xn, lamn, ub)
                        sga, sca = _row_value(Cc_a, Dc_a, Fc_a, slide, xa, lamna, ub)
                        sgb -= vts
                        sga -= vts
                        sg[0] = sgb
                        sg[1] = sga
                        sg[2] = 1e-9 * (max(scb, sca) + abs(vts))
                        if base_on:
                            dd = 1.0 - _relay_fraction(sga, sgb, True)
                        else:
                            dd = _relay_fraction(sgb, sga, False)
                        for i in range(n):
                            xn[i] = xn[i] + dd * (xa[i] - xn[i])
                        done = True
            elif slide < 0 and regular and (m == 0 or fast_j):
                # Inline regular step: stored matrices, cached active set.
                for i in range(n):
                    v = 0.0
                    for jj in range(n):
                        v += Phi_j[i, jj] * x[jj]
                    for jj in range(p):
                        v += G0_j[i, jj] * ua[jj] + G1_j[i, jj] * ub[jj]
                    xf[i] = v
                chk = 0.0
                for i in range(m):
                    v = 0.0
                    for jj in range(n):
                        v += C_j[i, jj] * xf[jj]
                    for jj in range(p):
                        v += F_j[i, jj] * ub[jj]
                    q[i] = v
                    chk += v
                for i in range(n):
                    chk += xf[i]
                if chk - chk == 0.0:
                    if m == 0:
                        for i in range(n):
                            xn[i] = xf[i]
                        done = True
                    else:
                        slot = ms[1]
                        if slot < 0:
                            slot = _lookup(M_j, ms[0], ck_j, cna_j, cidx_j, cG_j, ivars)
                            ms[1] = slot
                        na = cna_j[slot]
                        if na >= 0:
                            done = True
                            zmax = 0.0
                            for ii in range(na):
                                v = 0.0
                                for jj in range(na):
                                    v += cG_j[slot, ii, jj] * q[cidx_j[slot, jj]]
                                za[ii] = v
                                if abs(v) > zmax:
                                    zmax = abs(v)
                            for ii in range(na):
                                if za[ii] < -rtol * zmax:
                                    done = False
                                    break
                            if done:
                                for ii in range(na, m):
                                    i = cidx_j[slot, ii]
                                    v = q[i]
                                    sc = abs(v)
                                    for jj in range(na):
                                        t = M_j[i, cidx_j[slot, jj]] * za[jj]
                                        v += t
                                        sc += abs(t)
                                    if v < -rtol * sc:
                                        done = False
                                        break
                            if done:
                                for i in range(m):
                                    lamn[i] = 0.0
                                for jj in range(na):
                                    lamn[cidx_j[slot, jj]] = za[jj]
                                chk = 0.0
                                for i in range(n):
                                    v = xf[i]
                                    for jj in range(na):
                                        v += K_j[i, cidx_j[slot, jj]] * za[jj]
                                    xn[i] = v
                                    chk += v
                                if chk - chk != 0.0:
                                    done = False
            elif slide < 0 and (m == 0 or fast_j):
                # Inline shortened step: discretise for s, try the previous active set.
                a1 = s * (1.0 - theta)
                for i in range(n):
                    v = x[i]
                    for jj in range(n):
                        augn[i, jj] = (1.0 if i == jj else 0.0) - s * theta * A_j[i, jj]
                        v += a1 * A_j[i, jj] * x[jj]
                    for jj in range(p):
                        v += s * E_j[i, jj] * ((1.0 - theta) * ua[jj] + theta * ub[jj])
                    augn[i, n] = v
                    for jj in range(m):
                        augn[i, n + 1 + jj] = B_j[i, jj]
                if n == 0 or _gauss(augn, n, 1 + m):
                    chk = 0.0
                    for i in range(n):
                        xf[i] = augn[i, n]
                        chk += xf[i]
                        for jj in range(m):
                            Ko[i, jj] = s * augn[i, n + 1 + jj]
                    for i in range(m):
                        for jj in range(m):
                            v = D_j[i, jj]
                            for l in range(n):
                                v += C_j[i, l] * Ko[l, jj]
                            Mo[i, jj] = v
                        v = 0.0
                        for jj in range(n):
                            v += C_j[i, jj] * xf[jj]
                        for jj in range(p):
                            v += F_j[i, jj] * ub[jj]
                        q[i] = v
                        chk += v
                    if chk - chk == 0.0:
                        if m == 0:
                            done = True
                        elif _basis_solution(Mo, q, ms[0], zb, augm):
                            done = True
                            zmax = 0.0
                            for i in range(m):
                                if abs(zb[i]) > zmax:
                                    zmax = abs(zb[i])
                            for i in range(m):
                                if zb[i] < -rtol * zmax:
                                    done = False
                                    break
                            if done:
                                for i in range(m):
                                    if (ms[0] >> i) & 1:
                                        continue
                                    v = q[i]
                                    sc = abs(v)
                                    for jj in range(m):
                                        t = Mo[i, jj] * zb[jj]
                                        v += t
                                        sc += abs(t)
                                    if v < -rtol * sc:
                                        done = False
                                        break
                        if done:
                            for i in range(m):
                                lamn[i] = zb[i] if zb[i] > 0.0 else 0.0
                            chk = 0.0
                            for i in range(n):
                                v = xf[i]
                                for jj in range(m):
                                    v += Ko[i, jj] * lamn[jj]
                                xn[i] = v
                                chk += v
                            if chk - chk != 0.0:
                                done = False
            if not done:
                st, dd = _advance(mats, mflags, ckeys, cna, cidx, cG, j, ja, slide, base_on,
                                  vts, s, regular, theta, x, ua, ub, ms, ivars, fvars, max_piv,
                                  enum_max_m, True, xn, lamn, xa, lamna, c, cs, sg, W)
            if st != STEP_OK:
                status = st
                fvars[FV_FAIL_T0] = ta
                fvars[FV_FAIL_T1] = tb
                break
            G = -np.inf
            if has_located:
                # Inline comparator check (see _crossing; while sliding, the controls are the
                # combination of the two modes').
                for i in range(k):
                    g[i] = -np.inf
                    gt[i] = 0.0
                    if sw_kind[i] != SW_LOCATED or i == slide:
                        continue
                    on = (key >> i) & 1
                    if (not on) and (sw_flags[i] & SWF_LATCH) != 0:
                        continue
                    v = 0.0
                    sc = 0.0
                    for jj in range(n):
                        t = Cc_j[i, jj] * xn[jj]
                        v += t
                        sc += abs(t)
                    for jj in range(m):
                        t = Dc_j[i, jj] * lamn[jj]
                        v += t
                        sc += abs(t)
                    for jj in range(p):
                        t = Fc_j[i, jj] * ub[jj]
                        v += t
                        sc += abs(t)
                    if slide >= 0 and dd != 0.0:
                        va, sca = _row_value(Cc_a, Dc_a, Fc_a, i, xn, lamna, ub)
                        v = (1.0 - dd) * v + dd * va
                        sc = (1.0 - dd) * sc + dd * sca
                    c[i] = v
                    cs[i] = sc
                    if on:
                        g[i] = (sw_vt[i] - sw_vh[i]) - v
                    else:
                        g[i] = v - (sw_vt[i] + sw_vh[i])
                    gt[i] = 1e-12 * (sc + abs(sw_vt[i]) + abs(sw_vh[i]))
                    if g[i] > G:
                        G = g[i]
            if not (G > 0.0):
                for i in range(n):
                    x[i] = xn[i]
                for i in range(m):
                    lam[i] = lamn[i]
                    lama[i] = lamna[i]
                d = dd
                tcur = tb
                ivars[IV_STEPS] += 1
                if not regular:
                    ivars[IV_ODD] += 1
                if slide >= 0:
                    ivars[IV_SLIDESTEPS] += 1
                    fvars[FV_DUTY] = 1.0 - dd if base_on else dd
                    # Leave the surface when the on-fraction saturates and the relay holds
                    # strictly (beyond round-off) in the saturated mode.
                    tol = sg[2]
                    if dd == 0.0:
                        sgb = sg[0]
                        if (sgb > tol) if base_on else (sgb < -tol):
                            _record(ev_t, ev_key, ev_info, ivars, tb, key,
                                    slide + EV_SLIDE_END)
                            slide = -1
                            ja = -1
                    elif dd == 1.0:
                        sga = sg[1]
                        if (sga < -tol) if base_on else (sga > tol):
                            key = key ^ (1 << slide)
                            jt = j
                            j = ja
                            ja = jt
                            mt = ms[0]
                            ms[0] = ms[2]
                            ms[2] = mt
                            ms[1] = -1
                            ms[3] = -1
                            for i in range(m):
                                lam[i] = lamna[i]
                            d = 0.0
                            _record(ev_t, ev_key, ev_info, ivars, tb, key,
                                    slide + EV_SLIDE_END)
                            slide = -1
                            ja = -1
                break
            # A comparator crossed its threshold inside the step: locate the instant.
            for i in range(4):
                ms[i] = ms0[i]
            if slide < 0:
                st, s_star, mk = _locate_plain(A_j, B_j, C_j, D_j, E_j, F_j, Cc_j, Dc_j, Fc_j,
                                               sw_kind, sw_flags, sw_vt, sw_vh, key, ta, s,
                                               theta, x, lam, ua, ub, ms[0], xn, lamn, c, cs,
                                               g, gt, W, S, fvars, ivars, max_piv, enum_max_m,
                                               U0, Um, U1, kk, tau_a)
                ms[0] = mk
                dstar = 0.0
            else:
                st, s_star, dstar = _locate(mats, mflags, ckeys, cna, cidx, cG, j, ja, slide,
                                            base_on, vts, ta, s, theta, x, lam, ua, ub, ms,
                                            ivars, fvars, max_piv, enum_max_m, sw_kind,
                                            sw_flags, sw_vt, sw_vh, key, xn, lamn, lamna, dd,
                                            c, cs, g, gt, W, S, U0, Um, U1, kk, tau_a)
            if st != STEP_OK:
                status = st
                fvars[FV_FAIL_T0] = ta
                fvars[FV_FAIL_T1] = tb
                break
            xs = S[13]
            lams = S[14]
            lamas = S[15]
            flips = 0
            first = -1
            for i in range(k):
                if g[i] != -np.inf and g[i] >= -gt[i]:
                    flips |= 1 << i
                    if first < 0:
                        first = i
            if flips == 0:  # (cannot happen: the instant search ends on a crossing)
                gm = -np.inf
                for i in range(k):
                    if g[i] > gm:
                        gm = g[i]
                        first = i
                flips = 1 << first
            if s_star > min_step:
                for i in range(n):
                    x[i] = xs[i]
                for i in range(m):
                    lam[i] = lams[i]
                    lama[i] = lamas[i]
                d = dstar
                tcur = ta + s_star
                ivars[IV_STEPS] += 1
                ivars[IV_ODD] += 1
                if slide >= 0:
                    ivars[IV_SLIDESTEPS] += 1
                if every == 1:
                    ut = S[6]
                    _u_interp(U0, Um, U1, kk, (tcur - ta_grid) / (tb - ta_grid), ut)
                    pos = ivars[IV_OUTPOS]
                    _store(mats, mflags, j, ja, d, slide, key, duty_sw, x, lam, lama, ut,
                           T_out, Y_out, pos, tcur, fvars)
                    ivars[IV_OUTPOS] = pos + 1
            elif ivars[IV_LASTSW] == first and fvars[FV_LASTT] == tcur:
                # The switch it flipped at this very instant wants to flip back before the
                # state has moved: the trajectory is on an attractive switching surface.
                if (sw_flags[first] & SWF_RELAY) != 0 and slide < 0:
                    slide = first
                    _record(ev_t, ev_key, ev_info, ivars, tcur, key, slide + EV_SLIDE_START)
                    ivars[IV_LASTSW] = -1
                    akey = key ^ (1 << slide)
                    ja = _find_mode(mkey, ivars[IV_NMODES], akey)
                    ms[2] = ms[0]
                    ms[3] = -1
                    if ja < 0:
                        need = akey
                        break
                    continue
                status = STEP_SLIDING
                ivars[IV_FAILSW] = first
                fvars[FV_FAIL_T0] = tcur
                fvars[FV_FAIL_T1] = tb
                break
            key = key ^ flips
            _record(ev_t, ev_key, ev_info, ivars, tcur, key, first)
            ivars[IV_LASTSW] = first
            fvars[FV_LASTT] = tcur
            ivars[IV_LOCATED] += 1
            ivars[IV_NSW] += 1
            if ivars[IV_NSW] > max_sw:
                status = STEP_CHATTER
                ivars[IV_FAILSW] = first
                fvars[FV_FAIL_T0] = tcur
                fvars[FV_FAIL_T1] = tb
                break
            j = _find_mode(mkey, ivars[IV_NMODES], key)
            ms[1] = -1
            if j < 0:
                need = key
                break
            if slide >= 0:
                akey = key ^ (1 << slide)
                ja = _find_mode(mkey, ivars[IV_NMODES], akey)
                ms[3] = -1
                if ja < 0:
                    need = akey
                    break
        if status != STEP_OK:
            break
        if need >= 0:
            status = STEP_NEED_MODE
            ivars[IV_NEED] = need
            break
        # End of the grid step: output, sampled comparators.
        ivars[IV_GSTEP] += 1
        countdown -= 1
        if countdown == 0 or force_out[kk]:
            if countdown == 0:
                countdown = every
            pos = ivars[IV_OUTPOS]
            if jb != j or (slide >= 0 and jab != ja):
                _store(mats, mflags, j, ja, d, slide, key, duty_sw, x, lam, lama, U1[kk],
                       T_out, Y_out, pos, tb, fvars)
            elif outstate_j and (slide < 0 or d == 0.0) and not has_duty:
                T_out[pos] = tb
                for i in range(n):
                    Y_out[pos, i] = x[i]
            else:
                T_out[pos] = tb
                u_end = U1[kk]
                for r in range(r_out):
                    sw = duty_sw[r]
                    if sw >= 0:
                        if sw == slide:
                            Y_out[pos, r] = fvars[FV_DUTY]
                        else:
                            Y_out[pos, r] = 1.0 if (key >> sw) & 1 else 0.0
                        continue
                    v, sc = _row_value(Cy_j, Dy_j, Fy_j, r, x, lam, u_end)
                    if slide >= 0 and d != 0.0:
                        va, sc = _row_value(Cy_a, Dy_a, Fy_a, r, x, lama, u_end)
                        v = (1.0 - d) * v + d * va
                    Y_out[pos, r] = v
            ivars[IV_OUTPOS] = pos + 1
        if has_sampled:
            if (slide >= 0 and d != 0.0) or jb != j:
                _end_controls(mats, j, ja, d, x, lam, lama, U1[kk], c, cs)
            else:
                for i in range(k):
                    if sw_kind[i] != SW_SAMPLED:
                        continue
                    v = 0.0
                    for jj in range(n):
                        v += Cc_j[i, jj] * x[jj]
                    for jj in range(m):
                        v += Dc_j[i, jj] * lam[jj]
                    for jj in range(p):
                        v += Fc_j[i, jj] * U1[kk, jj]
                    c[i] = v
            newkey = key
            first = -1
            for i in range(k):
                if sw_kind[i] != SW_SAMPLED:
                    continue
                on = (key >> i) & 1
                if on and c[i] < sw_vt[i] - sw_vh[i]:
                    newkey &= ~(1 << i)
                elif (not on) and c[i] > sw_vt[i] + sw_vh[i]:
                    newkey |= 1 << i
                else:
                    continue
                if first < 0:
                    first = i
            if newkey != key:
                key = newkey
                _record(ev_t, ev_key, ev_info, ivars, tb, key, first)
        kk += 1
    ivars[IV_K] = kk
    ivars[IV_KEY] = key
    ivars[IV_SLIDE] = slide
    ivars[IV_MASK] = ms[0]
    ivars[IV_MASK_ALT] = ms[2]
    fvars[FV_TCUR] = tcur
    return status
