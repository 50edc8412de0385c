"""Lemke's complementary pivoting method, in numpy (reference) and numba (inside compiled loops).

Covering vector ``d = 1`` and lexicographic degeneracy resolution: the ratio test compares the
rows ``(B^-1 q, B^-1) / (B^-1 column)`` lexicographically, so the method cannot cycle. Ray
termination means Lemke found no solution; for a copositive-plus ``M`` (P-matrices, positive
semidefinite matrices: every passive circuit) it proves that none exists.
"""

from __future__ import annotations

import numpy as np

from ..jit import jitted
from .problem import (
    _STATUS_NAMES,
    LEMKE_MAX_PIVOTS,
    LEMKE_RAY,
    LEMKE_SOLVED,
    LEMKE_TRIVIAL,
    LcpOptions,
    LcpResult,
)


def _lex_pick(T: np.ndarray, rows: np.ndarray, col: np.ndarray, m: int, lex_tol: float,
              largest: bool) -> int:
    """Row of ``rows`` with the lexicographically smallest (or largest) ratio vector.

    The ratio vector of row i is ``(T[i, rhs], T[i, 0:m]) / col[i]``; ``T[:, 0:m]`` is the
    current basis inverse, whose rows are independent, so the order is strict.
    """
    rhs = T[:, 2 * m + 1].copy()
    # Basic values within round-off of zero are degenerate: make them exactly zero so that
    # the tie goes to the lexicographic components instead of to noise.
    rhs[np.abs(rhs) <= lex_tol * np.abs(rhs).max()] = 0.0
    best = int(rows[0])
    for i in rows[1:]:
        i = int(i)
        a = np.concatenate(([rhs[i]], T[i, :m])) / col[i]
        b = np.concatenate(([rhs[best]], T[best, :m])) / col[best]
        for k, (ak, bk) in enumerate(zip(a, b, strict=True)):
            # Ratios of basic values: relative test (they may all be tiny); entries of the
            # basis inverse: the identity's scale.
            floor = 0.0 if k == 0 else 1.0
            if abs(ak - bk) <= lex_tol * max(floor, abs(ak), abs(bk)):
                continue
            if (ak > bk) if largest else (ak < bk):
                best = i
            break
    return best


def lemke(M: np.ndarray, q: np.ndarray, options: LcpOptions | None = None) -> LcpResult:
    """Lemke's method with covering vector 1 and lexicographic ratio test (numpy version).

    Parameters
    ----------
    M : ndarray, shape (m, m)
    q : ndarray, shape (m,)
    options : LcpOptions, optional

    Returns
    -------
    LcpResult
        ``status`` is ``"trivial"``, ``"solved"``, ``"ray_termination"`` or
        ``"max_pivots"``.
    """
    opts = options or LcpOptions()
    M = np.asarray(M, dtype=float)
    q = np.asarray(q, dtype=float).ravel()
    m = q.size
    if m == 0 or q.min() >= 0.0:
        return LcpResult(np.zeros(m), q.copy(), True, "trivial", 0, "lemke", np.zeros(m, bool))
    # Tableau B^-1 [I, -M, -d, q]; variables 0..m-1 are w, m..2m-1 are z, 2m is z0.
    T = np.zeros((m, 2 * m + 2))
    T[:, :m] = np.eye(m)
    T[:, m:2 * m] = -M
    T[:, 2 * m] = -1.0
    T[:, 2 * m + 1] = q
    basis = np.arange(m)
    z0 = 2 * m
    # First pivot: z0 enters at the value that makes every w >= 0; the leaving row attains
    # the largest ratio q_i / (-d_i) (lexicographically, to break ties).
    col = T[:, z0].copy()
    rows = np.flatnonzero(col < 0)
    r = _lex_pick(T, rows, col, m, opts.lex_tol, largest=True)
    pivots = 0
    entering = z0
    max_piv = opts.pivots_for(m)
    while True:
        # Pivot on (r, entering).
        T[r] /= T[r, entering]
        others = np.arange(m) != r
        T[others] -= np.outer(T[others, entering], T[r])
        leaving = int(basis[r])
        basis[r] = entering
        pivots += 1
        if leaving == z0:
            status = LEMKE_SOLVED
            break
        if pivots >= max_piv:
            status = LEMKE_MAX_PIVOTS
            break
        entering = leaving + m if leaving < m else leaving - m
        col = T[:, entering].copy()
        cmax = np.abs(col).max()
        rows = np.flatnonzero(col > opts.pivot_tol * cmax) if cmax > 0 else np.empty(0, int)
        if rows.size == 0:
            status = LEMKE_RAY
            break
        r = _lex_pick(T, rows, col, m, opts.lex_tol, largest=False)
    if status != LEMKE_SOLVED:
        return LcpResult(np.zeros(m), np.zeros(m), False, _STATUS_NAMES[status], pivots,
                         "lemke", None)
    z = np.zeros(m)
    w = np.zeros(m)
    basic_z = np.zeros(m, bool)
    for i, b in enumerate(basis):
        if b < m:
            w[b] = T[i, 2 * m + 1]
        else:
            z[b - m] = T[i, 2 * m + 1]
            basic_z[b - m] = True
    return LcpResult(z, w, True, "solved", pivots, "lemke", basic_z)



@jitted
def _lex_less_nb(T, i, ci, j, cj, m, lex_tol, largest, rhs_zero):
    """True when the ratio vector of row i beats row j (smaller, or larger if ``largest``).

    Basic values below ``rhs_zero`` in magnitude count as exact zeros (degenerate rows).
    """
    rhs = 2 * m + 1
    ra = T[i, rhs] if abs(T[i, rhs]) > rhs_zero else 0.0
    rb = T[j, rhs] if abs(T[j, rhs]) > rhs_zero else 0.0
    a = ra / ci
    b = rb / cj
    if abs(a - b) > lex_tol * max(abs(a), abs(b)):
        return (a > b) if largest else (a < b)
    for k in range(m):
        a = T[i, k] / ci
        b = T[j, k] / cj
        if abs(a - b) > lex_tol * max(1.0, abs(a), abs(b)):
            return (a > b) if largest else (a < b)
    return False


@jitted
def _rhs_max(T, m):
    v = 0.0
    for i in range(m):
        if abs(T[i, 2 * m + 1]) > v:
            v = abs(T[i, 2 * m + 1])
    return v


@jitted
def lemke_nb(M, q, max_pivots, pivot_tol, lex_tol, T, basis, z, w, active):
    """Lemke's method, numba version of :func:`lemke` (same pivoting rules).

    Parameters
    ----------
    M : float64[:, :], shape (m, m)
    q : float64[:], shape (m,)
    max_pivots : int
    pivot_tol, lex_tol : float
        As in :class:`LcpOptions`.
    T : float64[:, :], shape (m, 2m + 2)
        Work array (the tableau).
    basis : int64[:], shape (m,)
        Work array.
    z, w : float64[:], shape (m,)
        Output: the solution (zeros unless solved).
    active : bool[:], shape (m,)
        Output: which ``z_i`` are basic at the end.

    Returns
    -------
    status : int
        ``LEMKE_SOLVED`` (0), ``LEMKE_RAY`` (1), ``LEMKE_MAX_PIVOTS`` (2) or ``LEMKE_TRIVIAL``
        (3).
    pivots : int
    """
    m = q.shape[0]
    qmin = 0.0
    for i in range(m):
        z[i] = 0.0
        w[i] = q[i]
        active[i] = False
        if q[i] < qmin:
            qmin = q[i]
    if qmin >= 0.0:
        return LEMKE_TRIVIAL, 0
    ncol = 2 * m + 2
    for i in range(m):
        for j in range(ncol):
            T[i, j] = 0.0
        T[i, i] = 1.0
        for j in range(m):
            T[i, m + j] = -M[i, j]
        T[i, 2 * m] = -1.0
        T[i, 2 * m + 1] = q[i]
        basis[i] = i
    z0 = 2 * m
    # First pivot: every column entry is -1 < 0; pick the lexicographically largest ratio.
    r = -1
    rz = lex_tol * _rhs_max(T, m)
    for i in range(m):
        if r < 0 or _lex_less_nb(T, i, T[i, z0], r, T[r, z0], m, lex_tol, True, rz):
            r = i
    entering = z0
    pivots = 0
    status = LEMKE_SOLVED
    while True:
        piv = T[r, entering]
        for j in range(ncol):
            T[r, j] /= piv
        for i in range(m):
            if i != r:
                f = T[i, entering]
                if f != 0.0:
                    for j in range(ncol):
                        T[i, j] -= f * T[r, j]
        leaving = basis[r]
        basis[r] = entering
        pivots += 1
        if leaving == z0:
            status = LEMKE_SOLVED
            break
        if pivots >= max_pivots:
            status = LEMKE_MAX_PIVOTS
            break
        entering = leaving + m if leaving < m else leaving - m
        cmax = 0.0
        for i in range(m):
            if abs(T[i, entering]) > cmax:
                cmax = abs(T[i, entering])
        thr = pivot_tol * cmax
        rz = lex_tol * _rhs_max(T, m)
        r = -1
        for i in range(m):
            ci = T[i, entering]
            if cmax > 0.0 and ci > thr:
                if r < 0 or _lex_less_nb(T, i, ci, r, T[r, entering], m, lex_tol, False, rz):
                    r = i
        if r < 0:
            status = LEMKE_RAY
            break
    if status != LEMKE_SOLVED:
        for i in range(m):
            w[i] = 0.0
        return status, pivots
    for i in range(m):
        w[i] = 0.0
    for i in range(m):
        b = basis[i]
        if b < m:
            w[b] = T[i, 2 * m + 1]
        else:
            z[b - m] = T[i, 2 * m + 1]
            active[b - m] = True
    return status, pivots


def solve_lcp_nb(M: np.ndarray, q: np.ndarray, options: LcpOptions | None = None) -> LcpResult:
    """Convenience wrapper: run :func:`lemke_nb` from Python (allocates its work arrays)."""
    opts = options or LcpOptions()
    M = np.ascontiguousarray(M, dtype=float)
    q = np.ascontiguousarray(q, dtype=float).ravel()
    m = q.size
    T = np.empty((m, 2 * m + 2))
    basis = np.empty(m, np.int64)
    z = np.empty(m)
    w = np.empty(m)
    active = np.empty(m, np.bool_)
    status, pivots = lemke_nb(M, q, opts.pivots_for(m), opts.pivot_tol, opts.lex_tol, T, basis,
                              z, w, active)
    ok = status in (LEMKE_SOLVED, LEMKE_TRIVIAL)
    return LcpResult(z, w, ok, _STATUS_NAMES[status], int(pivots), "lemke_nb",
                     active if ok else None)
