"""Left-looking sparse LU with partial pivoting (Gilbert and Peierls), compiled, for the many
small factorisations of the sparse KKT stepping: one per switch mode, step length and active
set, each a few hundred to a few thousand unknowns with two to four entries a column.

:mod:`lcs.sparse_lu` factorises one MNA system per mode in a dense value array (9 N² bytes
to zero each time); here nothing is proportional to N² and the work is proportional to the
arithmetic (Gilbert & Peierls 1988, as in CSparse's ``cs_lu`` and KLU): column ``k`` of the
factors is the solution of a sparse triangular system with the columns of ``L`` found so far,
whose non-zero pattern a depth-first search finds before any arithmetic.

``P A Q = L U``: the columns are taken in a given order ``q`` (a fill-reducing order, see
:mod:`.ordering`), the rows by partial pivoting with a preference for the *diagonal* row (the
row of the same index as the column: a KKT matrix's natural pairing of node and KCL row,
branch and branch equation, pair and its row), kept when its entry is at least ``tol`` times
the largest candidate, as KLU does: the fill-reducing order was chosen for the diagonal
pivots. ``L`` is unit lower triangular; both factors are stored by columns, row indices as
pivot steps.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from lcs.jit import inline, kernel

__all__ = ["FACTOR_OK", "FACTOR_SINGULAR", "FACTOR_FULL", "Factors", "factor", "solve",
           "solve_into", "lu_arrays"]

FACTOR_OK = 0
FACTOR_SINGULAR = -1  # a column with no usable pivot
FACTOR_FULL = -2  # the storage for L or U is too small

Factors = namedtuple("Factors", ["Lp", "Li", "Lx", "Up", "Ui", "Ux", "pinv"])
Factors.__doc__ = """The factors ``P A Q = L U`` of an N x N matrix (:func:`factor`), both by
columns with row indices as pivot steps: ``Lp, Up (N + 1,)`` int64, the column pointers;
``Li, Lx`` the strictly lower part of ``L`` (unit diagonal not stored) and ``Ui, Ux`` the upper
part of ``U`` with its diagonal last in each column (their capacity is their length);
``pinv (N,)`` int64, the pivot step of each row."""


@kernel
def _reach(N, Ap, Ai, col, Lp, Li, pinv, mark, stamp, xi, top):
    """The rows reachable from column ``col`` of the N x N matrix A through the columns of L
    found so far (``pinv[r] >= 0``: row r was pivot of step ``pinv[r]``), in topological
    order in ``xi[top:]`` (depth first, without recursion: ``xi[:N]`` is the stack,
    ``xi[N:2N]`` the position in each node's list; ``pinv`` and ``xi`` may be longer).
    Returns ``top``."""
    for t in range(Ap[col], Ap[col + 1]):
        r0 = Ai[t]
        if mark[r0] == stamp:
            continue
        # depth-first search from r0
        head = 0
        xi[0] = r0
        while head >= 0:
            r = xi[head]
            s = pinv[r]
            if mark[r] != stamp:
                mark[r] = stamp
                xi[N + head] = 0 if s < 0 else Lp[s]
            done = True
            if s >= 0:
                end = Lp[s + 1]
                p = xi[N + head]
                while p < end:
                    rr = Li[p]
                    p += 1
                    if mark[rr] != stamp:
                        xi[N + head] = p
                        head += 1
                        xi[head] = rr
                        done = False
                        break
                if done:
                    xi[N + head] = end
            if done:
                head -= 1
                top -= 1
                xi[top] = r
    return top


@kernel
def factor(N, Ap, Ai, Ax, q, tol, pivmin, lu, x, xi, mark):
    """Factorise the N x N matrix of columns ``Ap, Ai, Ax`` (CSC, any row order within a
    column, no duplicates) as ``P A Q = L U`` with the column order ``q`` into ``lu``
    (:class:`Factors`); a column whose largest candidate pivot is not above ``pivmin`` makes
    the matrix singular. ``x (N,)`` float, ``xi (2N,)`` and ``mark (N,)`` int64 are work space
    (``mark`` zero, or left by an earlier call: its entries are compared with a fresh stamp).

    Returns ``FACTOR_OK``, ``FACTOR_SINGULAR`` (``lu.Lp[0]`` then holds the step) or
    ``FACTOR_FULL``.
    """
    Lp = lu.Lp
    Li = lu.Li
    Lx = lu.Lx
    Up = lu.Up
    Ui = lu.Ui
    Ux = lu.Ux
    pinv = lu.pinv
    for r in range(N):
        pinv[r] = -1
    # (a stamp above every entry of ``mark``: no clearing per column)
    stamp = 0
    for r in range(N):
        if mark[r] > stamp:
            stamp = mark[r]
    capL = Li.shape[0]
    capU = Ui.shape[0]
    lnz = 0
    unz = 0
    for k in range(N):
        Lp[k] = lnz
        Up[k] = unz
        col = q[k]
        stamp += 1
        top = _reach(N, Ap, Ai, col, Lp, Li, pinv, mark, stamp, xi, N)
        for t in range(top, N):
            x[xi[t]] = 0.0
        for t in range(Ap[col], Ap[col + 1]):
            x[Ai[t]] = Ax[t]
        # x = L \ A[:, col] over the reach, in topological order
        for t in range(top, N):
            r = xi[t]
            s = pinv[r]
            if s < 0:
                continue
            xr = x[r]
            if xr != 0.0:
                for p in range(Lp[s], Lp[s + 1]):
                    x[Li[p]] -= Lx[p] * xr
        # pivot: the largest unpivoted entry, the diagonal row when within tol of it
        big = 0.0
        piv = -1
        for t in range(top, N):
            r = xi[t]
            if pinv[r] < 0:
                a = abs(x[r])
                if a > big:
                    big = a
                    piv = r
        if piv < 0 or not big > pivmin or not np.isfinite(big):
            Lp[0] = k
            return FACTOR_SINGULAR
        if pinv[col] < 0 and mark[col] == stamp and abs(x[col]) >= tol * big:
            piv = col
        # U column k (rows pivoted before), then its diagonal
        if unz + (N - top) + 1 > capU or lnz + (N - top) > capL:
            return FACTOR_FULL
        for t in range(top, N):
            r = xi[t]
            s = pinv[r]
            if s >= 0:
                Ui[unz] = s
                Ux[unz] = x[r]
                unz += 1
        d = x[piv]
        Ui[unz] = k
        Ux[unz] = d
        unz += 1
        pinv[piv] = k
        # L column k (rows not pivoted yet; their row indices become steps below)
        for t in range(top, N):
            r = xi[t]
            if pinv[r] < 0:
                Li[lnz] = r
                Lx[lnz] = x[r] / d
                lnz += 1
    Lp[N] = lnz
    Up[N] = unz
    for p in range(lnz):
        Li[p] = pinv[Li[p]]
    return FACTOR_OK


@inline
def solve_into(N, q, Lp, Li, Lx, Up, Ui, Ux, pinv, b, y, out):
    """``out = A⁻¹ b`` from the factors of :func:`factor` (``y (N,)`` work space)."""
    for r in range(N):
        y[pinv[r]] = b[r]
    for k in range(N):
        v = y[k]
        if v != 0.0:
            for p in range(Lp[k], Lp[k + 1]):
                y[Li[p]] -= Lx[p] * v
    for k in range(N - 1, -1, -1):
        end = Up[k + 1] - 1
        v = y[k] / Ux[end]
        y[k] = v
        if v != 0.0:
            for p in range(Up[k], end):
                y[Ui[p]] -= Ux[p] * v
    for k in range(N):
        out[q[k]] = y[k]


def lu_arrays(N: int, capL: int, capU: int) -> tuple[Factors, np.ndarray, np.ndarray,
                                                     np.ndarray]:
    """Allocate the factors and work arrays of :func:`factor` for an N x N matrix, with room
    for ``capL`` entries of ``L`` and ``capU`` of ``U``: ``(lu, x, xi, mark)``, the arguments
    of :func:`factor` after ``pivmin``."""
    lu = Factors(np.zeros(N + 1, np.int64), np.zeros(capL, np.int64), np.zeros(capL),
                 np.zeros(N + 1, np.int64), np.zeros(capU, np.int64), np.zeros(capU),
                 np.zeros(N, np.int64))
    return lu, np.zeros(N), np.zeros(2 * N, np.int64), np.zeros(N, np.int64)


def solve(lu: Factors, q: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Python entry: ``A⁻¹ b`` from the factors ``lu`` of :func:`factor`."""
    Lp, Li, Lx, Up, Ui, Ux, pinv = lu
    N = pinv.shape[0]
    out = np.zeros(N)
    solve_into(N, q, Lp, Li, Lx, Up, Ui, Ux, pinv, np.ascontiguousarray(b, dtype=float),
               np.zeros(N), out)
    return out
