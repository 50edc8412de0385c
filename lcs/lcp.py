"""Linear complementarity problems: find ``z`` with ``w = M z + q``, ``0 <= w ⊥ z >= 0``.

One driver, :func:`solve_lcp`, with one options dataclass, :class:`LcpOptions`, and separate
solvers behind it (as Siconos/numerics separates its LCP solvers):

* ``"lemke"`` -- Lemke's complementary pivoting with covering vector ``d = 1`` and
  lexicographic degeneracy resolution (the ratio test compares the rows
  ``(B^-1 q, B^-1) / (B^-1 column)`` lexicographically, so the method cannot cycle). Ray
  termination means Lemke found no solution; for a copositive-plus ``M`` (P-matrices, positive
  semidefinite matrices: every passive circuit) it proves that none exists.
* ``"enumeration"`` -- the direct path: try every complementary basis (subsets of active
  indices, smallest first) and solve the reduced linear system. Exponential, meant for tiny m;
  it is also the definitive answer when Lemke ray-terminates on a matrix that is not
  copositive-plus.
* ``"auto"`` (default) -- Lemke, then enumeration to confirm a ray termination when
  ``m <= enum_max_m``.

:func:`lemke_nb` is the same Lemke algorithm compiled with numba, callable from inside a numba
time-stepping loop without allocating (the caller passes the work arrays).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numba import njit

# Status codes shared by the Python and numba Lemke implementations.
LEMKE_SOLVED = 0
LEMKE_RAY = 1
LEMKE_MAX_PIVOTS = 2
LEMKE_TRIVIAL = 3  # q >= 0: z = 0 without pivoting

_STATUS_NAMES = {
    LEMKE_SOLVED: "solved",
    LEMKE_RAY: "ray_termination",
    LEMKE_MAX_PIVOTS: "max_pivots",
    LEMKE_TRIVIAL: "trivial",
}


@dataclass(frozen=True)
class LcpOptions:
    """Options of :func:`solve_lcp`.

    Parameters
    ----------
    method : str
        ``"auto"``, ``"lemke"`` or ``"enumeration"``.
    max_pivots : int or None
        Pivot budget of Lemke; ``None`` means ``max(50, 10 * m)``.
    pivot_tol : float
        A tableau entry counts as a positive pivot candidate when it exceeds ``pivot_tol``
        times the largest magnitude of the entering column (relative, so it is unit-free).
    lex_tol : float
        Relative tolerance under which two ratios are considered tied in the lexicographic
        ratio test (then the next component decides).
    feas_tol : float
        Relative tolerance of the feasibility/complementarity checks made by the enumeration
        solver and by :meth:`LcpResult` validation: ``z_i >= -feas_tol * scale``.
    enum_max_m : int
        ``"auto"`` confirms a Lemke ray termination by enumeration up to this size.
    """

    method: str = "auto"
    max_pivots: int | None = None
    pivot_tol: float = 1e-13
    lex_tol: float = 1e-12
    feas_tol: float = 1e-9
    enum_max_m: int = 10

    def pivots_for(self, m: int) -> int:
        return int(self.max_pivots) if self.max_pivots is not None else max(50, 10 * m)


@dataclass
class LcpResult:
    """Solution of an LCP.

    Attributes
    ----------
    z, w : ndarray, shape (m,)
        The complementary pair (``w = M z + q``). Undefined (zeros) when ``ok`` is False.
    ok : bool
        True when a solution was found.
    status : str
        ``"trivial"`` (q >= 0), ``"solved"``, ``"ray_termination"`` (Lemke found no
        solution), ``"no_solution"`` (enumeration proved that none exists), ``"max_pivots"``.
    pivots : int
        Lemke pivots performed (0 for the enumeration solver).
    method : str
        Which solver produced the answer.
    basis : ndarray of bool, shape (m,)
        ``basis[i]`` is True when ``z_i`` is basic (the active set of the final complementary
        basis; ``M[basis][:, basis]`` is nonsingular).
    """

    z: np.ndarray
    w: np.ndarray
    ok: bool
    status: str
    pivots: int = 0
    method: str = "lemke"
    basis: np.ndarray | None = None


# ---------------------------------------------------------------------------------------------
# Lemke, plain numpy (reference implementation; vectorised row operations)
# ---------------------------------------------------------------------------------------------


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


# ---------------------------------------------------------------------------------------------
# Enumeration (direct path for tiny m)
# ---------------------------------------------------------------------------------------------


def _solve_basis(M: np.ndarray, q: np.ndarray, active: tuple[int, ...], feas_tol: float):
    """Solution with ``w_i = 0`` on ``active`` and ``z_i = 0`` elsewhere, if feasible."""
    m = q.size
    z = np.zeros(m)
    if active:
        idx = list(active)
        Maa = M[np.ix_(idx, idx)]
        try:
            za = np.linalg.solve(Maa, -q[idx])
        except np.linalg.LinAlgError:
            return None
        if not np.all(np.isfinite(za)):
            return None
        # Reject near-singular bases: the residual of the reduced system must be round-off.
        if np.abs(Maa @ za + q[idx]).max() > feas_tol * (np.abs(q[idx]).max()
                                                        + np.abs(Maa).max() * np.abs(za).max()):
            return None
        z[idx] = za
    w = M @ z + q
    scale_w = np.abs(q) + np.abs(M) @ np.abs(z)
    scale_z = np.abs(z).max() if m else 0.0
    if np.any(z < -feas_tol * scale_z) or np.any(w < -feas_tol * scale_w):
        return None
    return z, w


def enumerate_lcp(M: np.ndarray, q: np.ndarray, options: LcpOptions | None = None,
                  all_solutions: bool = False):
    """Direct solver: try every complementary basis, fewest active indices first.

    Parameters
    ----------
    M : ndarray, shape (m, m)
    q : ndarray, shape (m,)
    options : LcpOptions, optional
        Uses ``feas_tol``.
    all_solutions : bool
        When True, return the list of all basic solutions ``[(z, w, active), ...]`` instead of
        an :class:`LcpResult` for the first one.
    """
    opts = options or LcpOptions()
    M = np.asarray(M, dtype=float)
    q = np.asarray(q, dtype=float).ravel()
    m = q.size
    found = []
    for k in range(m + 1):
        for active in itertools.combinations(range(m), k):
            sol = _solve_basis(M, q, active, opts.feas_tol)
            if sol is None:
                continue
            basis = np.zeros(m, bool)
            basis[list(active)] = True
            if not all_solutions:
                z, w = sol
                return LcpResult(z, w, True, "solved", 0, "enumeration", basis)
            found.append((sol[0], sol[1], basis))
    if all_solutions:
        return found
    return LcpResult(np.zeros(m), np.zeros(m), False, "no_solution", 0, "enumeration", None)


def solve_lcp(M: np.ndarray, q: np.ndarray, options: LcpOptions | None = None) -> LcpResult:
    """Solve ``w = M z + q, 0 <= w ⊥ z >= 0``.

    Parameters
    ----------
    M : array_like, shape (m, m)
    q : array_like, shape (m,)
    options : LcpOptions, optional
        ``method`` selects the solver (see the module docstring).

    Returns
    -------
    LcpResult
        Check ``ok``; ``status`` says why not.
    """
    opts = options or LcpOptions()
    M = np.asarray(M, dtype=float)
    q = np.asarray(q, dtype=float).ravel()
    m = q.size
    if M.shape != (m, m):
        raise ValueError(f"M must be ({m}, {m}) for q of size {m}, got {M.shape}")
    if not (np.all(np.isfinite(M)) and np.all(np.isfinite(q))):
        raise ValueError("LCP data contain NaN or infinity")
    if opts.method == "enumeration":
        return enumerate_lcp(M, q, opts)
    if opts.method not in ("auto", "lemke"):
        raise ValueError(f"unknown LCP method {opts.method!r}")
    res = lemke(M, q, opts)
    if res.ok or opts.method == "lemke" or m > opts.enum_max_m:
        return res
    # Lemke may stop on a ray for matrices that are not copositive-plus although a solution
    # exists; for small m enumeration settles it.
    alt = enumerate_lcp(M, q, opts)
    alt.pivots = res.pivots
    if not alt.ok:
        alt.status = "no_solution"
    return alt


def is_p_matrix(M: np.ndarray, max_m: int = 12) -> bool | None:
    """Whether every principal minor of ``M`` is positive (then the LCP has a unique solution
    for every q). Returns None when ``m > max_m`` (not checked: 2^m minors)."""
    M = np.asarray(M, dtype=float)
    m = M.shape[0]
    if m > max_m:
        return None
    scale = max(1.0, np.abs(M).max()) if m else 1.0
    for k in range(1, m + 1):
        for idx in itertools.combinations(range(m), k):
            if np.linalg.det(M[np.ix_(idx, idx)]) <= 1e-12 * scale**k:
                return False
    return True


# ---------------------------------------------------------------------------------------------
# Lemke, numba (the same algorithm, allocation-free, for use inside compiled stepping loops)
# ---------------------------------------------------------------------------------------------


@njit(cache=True)
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


@njit(cache=True)
def _rhs_max(T, m):
    v = 0.0
    for i in range(m):
        if abs(T[i, 2 * m + 1]) > v:
            v = abs(T[i, 2 * m + 1])
    return v


@njit(cache=True)
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
