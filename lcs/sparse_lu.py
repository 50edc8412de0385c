"""LU factorisation of a sparse square matrix, compiled, with the solve of many right-hand
sides and an estimate of the reciprocal condition number.

What the formulation of a switch mode needs (:mod:`netlist.mna_solve`): ``Z = M⁻¹ K`` for an
MNA matrix ``M`` of a few hundred unknowns with one to three entries a row, and a condition
estimate that says whether the LU can be trusted (else the SVD decides the rank). SuperLU did
it, but importing ``scipy.sparse`` costs about 0.2 s of every command that formulates a large
circuit, more than the factorisations themselves; the matrices are nearly triangular after a
row permutation (no elimination updates at all on the multiplier, interleaved buck and MMC
families of ``converters/scaling.py``), so a plain partial-pivoting elimination, kept in a
dense array but touching only the non-zero entries, costs a fraction of a millisecond.

Gaussian elimination with partial pivoting (the largest entry of the pivot column, the first
row among equals), columns taken in increasing order of their number of entries (hub columns,
e.g. a node every phase of an interleaved converter joins, last, so that they fill nothing
before they are eliminated). Values are kept in a dense array, the non-zero pattern (with
fill-in) in linked lists by row and by column, so that no pass scans a whole row or column
(an MMC arm of 64 cells, 515 unknowns: 0.98 -> 0.06 ms from entries to factors). The factors
are stored by rows (``P M Q = L U``, ``L`` unit lower triangular). The condition estimate is
Hager's and Higham's 1-norm estimator of ``M⁻¹`` (LAPACK's ``dlacon``), a lower bound of
``‖M⁻¹‖₁`` that is almost always within a factor 3.

Dense storage needs ``9 nz²`` bytes: :data:`MAX_SIZE` bounds it.
"""

from __future__ import annotations

import threading
from collections import namedtuple

import numpy as np

from .jit import jitted

__all__ = ["MAX_SIZE", "LUFactors", "kept_array", "lu_factor", "lu_rcond", "lu_solve"]

#: largest size factorised here (dense storage: 9 nz² bytes, 81 MB at 3000)
MAX_SIZE = 3000


Lists = namedtuple("Lists", ["head", "nxt", "val"])
Lists.__doc__ = """Linked lists in a pool of entries (int64 arrays): list ``i`` starts at entry
``head[i]`` (-1: empty); entry ``e`` holds ``val[e]`` and continues at entry ``nxt[e]`` (-1: the
end). The pattern's lists by row hold column indices, those by column row indices."""


@jitted
def _link(lists, at, item, free):
    """Prepend ``item`` to list ``at`` of ``lists`` (:class:`Lists`), in pool entry ``free``;
    returns the next free entry, or -1 when the pool is full."""
    if free >= lists.nxt.shape[0]:
        return -1
    lists.val[free] = item
    lists.nxt[free] = lists.head[at]
    lists.head[at] = free
    return free + 1


@jitted
def _add_entry(S, r, c, by_row, by_col, fr, fc):
    """Mark ``(r, c)`` in the pattern ``S`` and link it into its row's and column's lists
    (:class:`Lists` ``by_row``, ``by_col``), unless it is there; returns the pools' next free
    entries (``fr < 0``: a pool is full)."""
    if S[r, c] != 0:
        return fr, fc
    S[r, c] = 1
    fr = _link(by_row, r, c, fr)
    fc = _link(by_col, c, r, fc)
    if fc < 0:
        fr = -1
    return fr, fc


@jitted
def _factor(I, J, v, q, pos, W, S, by_row, by_col, p):
    """Eliminate the matrix of entries ``v`` at ``(I, J)`` (summed) in the column order ``q``
    (``pos[q[k]] = k``): values in ``W`` (n, n, zero on entry), the non-zero pattern in ``S``
    (int8, zero on entry) and in the :class:`Lists` by row ``by_row`` (of column indices) and by
    column ``by_col`` (of row indices; heads -1, pools of equal size), fill-in included, so that
    every pass touches non-zero entries only. The pivot row of step k goes to ``p[k]``;
    multipliers replace the eliminated entries. Returns -1, the first step with no non-zero
    pivot candidate, or -2 when the pools are too small."""
    rhead = by_row.head
    rnext = by_row.nxt
    rcol = by_row.val
    chead = by_col.head
    cnext = by_col.nxt
    crow = by_col.val
    n = W.shape[0]
    fr = 0
    fc = 0
    for t in range(I.shape[0]):
        r = I[t]
        c = J[t]
        W[r, c] += v[t]
        fr, fc = _add_entry(S, r, c, by_row, by_col, fr, fc)
        if fr < 0:
            return -2
    done = np.zeros(n, np.bool_)
    cand = np.empty(n, np.int64)
    cols = np.empty(n, np.int64)
    for k in range(n):
        c = q[k]
        nc = 0
        best = 0.0
        pr = -1
        e = chead[c]
        while e >= 0:
            r = crow[e]
            e = cnext[e]
            if done[r]:
                continue
            a = abs(W[r, c])
            if a == 0.0:
                continue
            cand[nc] = r
            nc += 1
            if a > best or (a == best and r < pr):
                best = a
                pr = r
        if pr < 0:
            return k
        p[k] = pr
        done[pr] = True
        ncol = 0
        e = rhead[pr]
        while e >= 0:
            j = rcol[e]
            e = rnext[e]
            if pos[j] > k and W[pr, j] != 0.0:
                cols[ncol] = j
                ncol += 1
        piv = W[pr, c]
        for t in range(nc):
            r = cand[t]
            if r == pr:
                continue
            mult = W[r, c] / piv
            W[r, c] = mult
            for s in range(ncol):
                j = cols[s]
                fr, fc = _add_entry(S, r, j, by_row, by_col, fr, fc)
                if fr < 0:
                    return -2
                W[r, j] -= mult * W[pr, j]
    return -1


@jitted
def _count(W, p, pos, rhead, rnext, rcol, counts):
    """Non-zero entries of the strictly lower factor and of the upper factor (with its
    diagonal), into ``counts[0]``, ``counts[1]``."""
    n = W.shape[0]
    nl = 0
    nu = 0
    for k in range(n):
        r = p[k]
        nu += 1
        e = rhead[r]
        while e >= 0:
            j = rcol[e]
            e = rnext[e]
            if pos[j] != k and W[r, j] != 0.0:
                if pos[j] < k:
                    nl += 1
                else:
                    nu += 1
    counts[0] = nl
    counts[1] = nu


@jitted
def _compress(W, p, q, pos, rhead, rnext, rcol, Lp, Li, Lx, Up, Ui, Ux):
    """The factors by rows in the permuted coordinates: row k of L (columns below k) at
    ``Lp[k]:Lp[k+1]``; row k of U at ``Up[k]:Up[k+1]``, its diagonal first. Every entry of
    ``W`` it reads (the whole pattern) is set back to zero."""
    n = W.shape[0]
    a = 0
    b = 0
    Lp[0] = 0
    Up[0] = 0
    for k in range(n):
        r = p[k]
        Ui[b] = k
        Ux[b] = W[r, q[k]]
        b += 1
        e = rhead[r]
        while e >= 0:
            j = rcol[e]
            e = rnext[e]
            x = W[r, j]
            W[r, j] = 0.0  # (W is zero again afterwards: lu_factor reuses it)
            i = pos[j]
            if i != k and x != 0.0:
                if i < k:
                    Li[a] = i
                    Lx[a] = x
                    a += 1
                else:
                    Ui[b] = i
                    Ux[b] = x
                    b += 1
        Lp[k + 1] = a
        Up[k + 1] = b


@jitted
def _solve_rows(p, q, Lp, Li, Lx, Up, Ui, Ux, B, Y, Z):
    """``Z = M⁻¹ B`` for every column of ``B`` (n, r) at once, a row at a time (contiguous
    inner loops); ``Y`` (n, r) is work space."""
    n = B.shape[0]
    r = B.shape[1]
    for k in range(n):
        src = p[k]
        for c in range(r):
            Y[k, c] = B[src, c]
        for t in range(Lp[k], Lp[k + 1]):
            i = Li[t]
            x = Lx[t]
            for c in range(r):
                Y[k, c] -= x * Y[i, c]
    for k in range(n - 1, -1, -1):
        for t in range(Up[k] + 1, Up[k + 1]):
            i = Ui[t]
            x = Ux[t]
            for c in range(r):
                Y[k, c] -= x * Y[i, c]
        d = Ux[Up[k]]
        for c in range(r):
            Y[k, c] /= d
    for k in range(n):
        dst = q[k]
        for c in range(r):
            Z[dst, c] = Y[k, c]


@jitted
def _solve_vec(p, q, Lp, Li, Lx, Up, Ui, Ux, b, y, x):
    """``x = M⁻¹ b`` (one vector); ``y`` is work space."""
    n = b.shape[0]
    for k in range(n):
        s = b[p[k]]
        for t in range(Lp[k], Lp[k + 1]):
            s -= Lx[t] * y[Li[t]]
        y[k] = s
    for k in range(n - 1, -1, -1):
        s = y[k]
        for t in range(Up[k] + 1, Up[k + 1]):
            s -= Ux[t] * y[Ui[t]]
        y[k] = s / Ux[Up[k]]
    for k in range(n):
        x[q[k]] = y[k]


@jitted
def _solve_vec_t(p, q, Lp, Li, Lx, Up, Ui, Ux, b, y, x):
    """``x = M⁻ᵀ b``: ``Qᵀ Mᵀ Pᵀ = Uᵀ Lᵀ``, solved by scattering the rows of U and L."""
    n = b.shape[0]
    for k in range(n):
        y[k] = b[q[k]]
    for k in range(n):
        y[k] /= Ux[Up[k]]
        yk = y[k]
        for t in range(Up[k] + 1, Up[k + 1]):
            y[Ui[t]] -= Ux[t] * yk
    for k in range(n - 1, -1, -1):
        yk = y[k]
        for t in range(Lp[k], Lp[k + 1]):
            y[Li[t]] -= Lx[t] * yk
    for k in range(n):
        x[p[k]] = y[k]


@jitted
def _inv_norm1(p, q, Lp, Li, Lx, Up, Ui, Ux, work):
    """Estimate of ``‖M⁻¹‖₁`` (a lower bound): Hager's method with Higham's safeguards, as
    LAPACK's ``dlacon`` (at most 5 iterations, then the alternating-sign test vector).
    ``work`` (4, n) is work space."""
    n = p.shape[0]
    x = work[0]
    y = work[1]
    z = work[2]
    tmp = work[3]
    for i in range(n):
        x[i] = 1.0 / n
    est = 0.0
    jlast = -1
    for it in range(5):
        _solve_vec(p, q, Lp, Li, Lx, Up, Ui, Ux, x, tmp, y)
        s = 0.0
        for i in range(n):
            s += abs(y[i])
        if it > 0 and s <= est:
            break
        est = s
        for i in range(n):
            x[i] = 1.0 if y[i] >= 0.0 else -1.0
        _solve_vec_t(p, q, Lp, Li, Lx, Up, Ui, Ux, x, tmp, z)
        j = 0
        zmax = abs(z[0])
        for i in range(1, n):
            if abs(z[i]) > zmax:
                zmax = abs(z[i])
                j = i
        if it > 0 and j == jlast:
            break
        jlast = j
        for i in range(n):
            x[i] = 0.0
        x[j] = 1.0
    # Higham's test vector catches the matrices on which the iteration stalls.
    for i in range(n):
        sign = 1.0 if i % 2 == 0 else -1.0
        x[i] = sign * (1.0 + i / max(n - 1, 1))
    _solve_vec(p, q, Lp, Li, Lx, Up, Ui, Ux, x, tmp, y)
    s = 0.0
    for i in range(n):
        s += abs(y[i])
    alt = 2.0 * s / (3.0 * n)
    return alt if alt > est else est


class LUFactors:
    """The factors of :func:`lu_factor` (row and column permutations, L and U by rows)."""

    __slots__ = ("n", "p", "q", "Lp", "Li", "Lx", "Up", "Ui", "Ux")

    def __init__(self, n, p, q, Lp, Li, Lx, Up, Ui, Ux):
        self.n, self.p, self.q = n, p, q
        self.Lp, self.Li, self.Lx, self.Up, self.Ui, self.Ux = Lp, Li, Lx, Up, Ui, Ux

    def _args(self):
        return (self.p, self.q, self.Lp, self.Li, self.Lx, self.Up, self.Ui, self.Ux)


def lu_factor(n: int, rows: np.ndarray, cols: np.ndarray, values: np.ndarray
              ) -> LUFactors | None:
    """Factorise the n x n matrix with entries ``values`` at ``(rows, cols)`` (repeated
    positions are summed).

    Parameters
    ----------
    n : int
        Size, at most :data:`MAX_SIZE`.
    rows, cols : ndarray of int (nnz,)
    values : ndarray of float (nnz,)

    Returns
    -------
    LUFactors, or None when a column has no non-zero pivot left (exactly singular).
    """
    if n > MAX_SIZE:
        raise ValueError(f"lu_factor: size {n} above MAX_SIZE = {MAX_SIZE}")
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    cols = np.ascontiguousarray(cols, dtype=np.int64)
    values = np.ascontiguousarray(values, dtype=np.float64)
    q = np.argsort(np.bincount(cols, minlength=n), kind="stable").astype(np.int64)
    pos = np.empty(n, np.int64)
    pos[q] = np.arange(n)
    p = np.empty(n, np.int64)
    # (zero on entry, left zero: the elimination writes the pattern's entries only)
    W, S = kept_array(_WORK, "w", (n, n)), kept_array(_WORK, "s", (n, n), np.int8)
    clean = False
    try:
        # Pools for the pattern's lists: the entries and some fill-in, four times more on
        # overflow (then the elimination starts again from scratch).
        size = 2 * rows.size + 4 * n + 16
        while True:
            rhead = np.full(n, -1, np.int64)
            chead = np.full(n, -1, np.int64)
            lists = (np.empty(size, np.int64), np.empty(size, np.int64),
                     np.empty(size, np.int64), np.empty(size, np.int64))
            status = _factor(rows, cols, values, q, pos, W, S,
                             Lists(rhead, lists[0], lists[1]), Lists(chead, lists[2], lists[3]),
                             p)
            if status != -2:
                break
            W.fill(0.0)
            S.fill(0)
            size *= 4
        if status >= 0:
            W.fill(0.0)
            S.fill(0)
            clean = True
            return None
        rnext, rcol = lists[0], lists[1]
        counts = np.zeros(2, np.int64)
        _count(W, p, pos, rhead, rnext, rcol, counts)
        Lp = np.empty(n + 1, np.int64)
        Up = np.empty(n + 1, np.int64)
        Li = np.empty(counts[0], np.int64)
        Lx = np.empty(counts[0])
        Ui = np.empty(counts[1], np.int64)
        Ux = np.empty(counts[1])
        _compress(W, p, q, pos, rhead, rnext, rcol, Lp, Li, Lx, Up, Ui, Ux)  # (zeroes W)
        S.fill(0)
        clean = True
    finally:
        if not clean:  # (an exception between: the work arrays are not known to be zero)
            _WORK.__dict__.pop("w", None)
            _WORK.__dict__.pop("s", None)
    return LUFactors(n, p, q, Lp, Li, Lx, Up, Ui, Ux)


# Work arrays kept between calls, per thread: the pages of a fresh n x n array are mapped one
# at a time as the elimination first writes each row (a page fault each), and between two
# modes' factorisations the memory has gone back to the system. On a 64-cell MMC arm (515
# unknowns) that was 515 page faults a mode: 1.9 ms a factorisation, 0.25 ms without them.
_WORK = threading.local()
#: largest size whose work arrays are kept (9 MB at 1000; above, they are allocated per call)
WORK_KEPT = 1000


def kept_array(store: threading.local, name: str, shape: tuple[int, int],
               dtype=np.float64, limit: int = WORK_KEPT * WORK_KEPT) -> np.ndarray:
    """An array of ``shape`` over this thread's buffer ``name`` of ``store``, kept between
    calls (zero when made, grown as needed; what it holds between uses is the caller's
    affair), or a new zero one above ``limit`` values.

    Parameters
    ----------
    store : threading.local
    name : str
        The buffer's attribute in ``store``.
    shape : (int, int)
    dtype : numpy dtype
    limit : int
        Largest number of values kept.
    """
    size = shape[0] * shape[1]
    if size > limit:
        return np.zeros(shape, dtype)
    buf = getattr(store, name, None)
    if buf is None or buf.size < size:
        buf = np.zeros(max(size, 4096), dtype)
        setattr(store, name, buf)
    return buf[:size].reshape(shape)


def lu_solve(lu: LUFactors, B: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """``M⁻¹ B`` for B of shape (n,) or (n, r), into ``out`` when given (float64,
    C-contiguous, B's shape, not sharing B's memory)."""
    B = np.ascontiguousarray(B, dtype=np.float64)
    if lu.n == 0:
        return np.zeros(B.shape)
    vec = B.ndim == 1
    B2 = B.reshape(lu.n, -1)
    Y = kept_array(_WORK, "rows", B2.shape)
    if out is None:
        Z = np.empty(B2.shape)
    else:
        if (out.shape != B.shape or out.dtype != np.float64
                or not out.flags.c_contiguous or np.may_share_memory(out, B)):
            raise ValueError("lu_solve: out must be a C-contiguous float64 array of B's "
                             "shape, apart from B")
        Z = out.reshape(B2.shape)
    _solve_rows(*lu._args(), B2, Y, Z)
    return Z.reshape(lu.n) if vec else Z


def lu_rcond(lu: LUFactors, anorm: float) -> float:
    """Estimate of the reciprocal 1-norm condition number ``1 / (‖M‖₁ ‖M⁻¹‖₁)`` given
    ``anorm = ‖M‖₁`` (an over-estimate at worst by the estimator's factor, as LAPACK's
    ``dgecon``); 0 when ``anorm`` is 0."""
    if lu.n == 0:
        return 1.0
    if not anorm > 0:
        return 0.0
    inv = _inv_norm1(*lu._args(), np.empty((4, lu.n)))
    return 1.0 / (anorm * inv) if inv > 0 else 0.0
