"""The rank-revealing solve of a mode's MNA system ``M z = K ξ`` (netlist.formulation):
equilibration, SVD, the null space (floating parts, singular companion networks) and which
quantities it leaves undetermined, and the round-off cleaning of the final matrices."""

from __future__ import annotations

import threading
from typing import NamedTuple

import numpy as np

from lcs import sparse_lu

from .errors import Diagnostic, NetlistError
from .limits import DENSE_UNKNOWNS
from .mna import coalesce

__all__ = ["CLEAN_RTOL", "DETERMINED_RTOL", "RANK_RTOL", "Entries", "Solution", "clean",
           "equilibrate"]

# Relative tolerance on singular values of the equilibrated MNA matrix: below it a direction
# counts as null (floating part, or a singular companion network).
RANK_RTOL = 1e-10
# Below it, relative to the largest, a singular value is round-off (a few ulps of the
# equilibrated matrix's norm times its size). A matrix whose smallest singular value lies
# between this and RANK_RTOL is regular at double precision but ill-conditioned: a part held
# to the rest only by a very large resistor (the 100 MΩ bleed resistors of a transformer
# model's floating windings). Truncated at RANK_RTOL it floats; when the truncation makes the
# equations inconsistent (a constraint that the full matrix does not have), it is solved
# whole instead.
ROUNDOFF_RTOL = 1e-13
# Relative tolerance for "this quantity does not depend on the null space" and "the
# equations are consistent for every ξ".
DETERMINED_RTOL = 1e-8
# A square system (of at least LU_MIN_SIZE unknowns: every one; the tests raise it to compare
# with the SVD) tries an LU factorisation first (lcs.sparse_lu: a fraction of a millisecond
# where the SVD takes 1.5 ms at 130 unknowns and 45 ms at 600), accepted when the 1-norm
# reciprocal condition estimate exceeds LU_RCOND: then the smallest singular value is at
# least about LU_RCOND / n of the largest, far above RANK_RTOL, and the SVD would find full
# rank.
LU_MIN_SIZE = 1
LU_RCOND = 1e-6
# Entries of the final matrices smaller than this, relative to their row, are round-off.
CLEAN_RTOL = 1e-12


class Entries(NamedTuple):
    """A matrix of ``shape`` by its non-zero entries ``values`` at ``(rows, cols)``."""

    rows: np.ndarray
    cols: np.ndarray
    values: np.ndarray
    shape: tuple[int, int]


class Solution:
    """Least-squares solution ``z = Z ξ`` of ``M z = K ξ``, with its null space.

    ``M`` is equilibrated (rows and columns scaled to unit max) before the SVD so that the
    rank decision does not depend on the units of the rows (A vs V) or on element values.
    """

    def __init__(self, M: np.ndarray | None, K: np.ndarray | Entries,
                 entries: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None):
        # (K dense, or by its non-zero Entries: the scaled right-hand sides are then written
        # straight from them, without a dense K first)
        nz, nxi = K.shape
        # The non-zero entries once (an MNA row has a few): the scaling, the LU's sparse
        # matrix and its norm from them, no dense pass over nz x nz per step of the way.
        if entries is None:
            I, J = np.nonzero(M)
            v = M[I, J]
            ncols = M.shape[1]
        else:  # (M square, given by its non-zero entries, row-major)
            I, J, v = entries
            ncols = nz
        r, c = _equilibrate_terms(nz, ncols, I, J, np.abs(v))
        self.col_scale = c
        if nz == 0:
            self._set_z(np.zeros((0, nxi)))
            self.null = np.zeros((0, 0))
            self.inconsistent = []
            return
        if not isinstance(K, Entries):
            self._solve(M, I, J, v, ncols, r, c, r[:, None] * K)
            return
        # The scaled right-hand sides in this thread's kept array (zero outside its use):
        # a fresh one is mapped a page fault at a time, 1.3 MB a mode on a 64-cell MMC arm.
        Ks = sparse_lu.kept_array(_WORK, "rhs", (nz, nxi), limit=WORK_KEPT)
        Ks[K.rows, K.cols] = r[K.rows] * K.values
        try:
            self._solve(M, I, J, v, ncols, r, c, Ks)
        finally:
            Ks[K.rows, K.cols] = 0.0

    def _solve(self, M: np.ndarray | None, I: np.ndarray, J: np.ndarray, v: np.ndarray,
               ncols: int, r: np.ndarray, c: np.ndarray, Ks: np.ndarray) -> None:
        nz, nxi = Ks.shape
        if nz >= LU_MIN_SIZE and ncols == nz and self._lu(I, J, r[I] * v * c[J], Ks, c):
            return
        limit = DENSE_UNKNOWNS.value()
        if max(nz, ncols) > limit:
            raise NetlistError(Diagnostic(
                f"the circuit's network ({max(nz, ncols)} unknowns) is singular or "
                "ill-conditioned in a switch mode, and its dense decomposition, which would "
                f"tell how, is beyond the limit of {limit:.6g} unknowns",
                None, "look for a node connected only through diodes or switches, or a "
                "floating part; " + DENSE_UNKNOWNS.hint("5000")))
        if M is None:
            M = np.zeros((nz, ncols))
            M[I, J] = v
        Ms = r[:, None] * M * c[None, :]
        U, s, Vt = np.linalg.svd(Ms)
        rank = int(np.sum(s > RANK_RTOL * s[0])) if s[0] > 0 else 0
        residual = U[:, rank:].T @ Ks
        scale = np.linalg.norm(Ks, axis=0)
        self.inconsistent = [
            j for j in range(nxi)
            if np.linalg.norm(residual[:, j]) > DETERMINED_RTOL * scale[j]
        ]
        if self.inconsistent and ncols == nz and rank < nz and s[-1] > ROUNDOFF_RTOL * s[0] \
                and self._lu(I, J, r[I] * v * c[J], Ks, c, rcond=0.0):
            # regular at double precision (ROUNDOFF_RTOL): solved whole, by the LU, whose
            # sparse elimination keeps the zeros of the parts the ill-conditioned one does
            # not reach (a dense solve would spread round-off over every entry)
            return
        self.null = Vt[rank:].T  # (nz, nz - rank), orthonormal, scaled coordinates
        zs = Vt[:rank].T @ ((U[:, :rank].T @ Ks) / s[:rank, None])
        self._set_z(c[:, None] * zs)

    def _lu(self, I: np.ndarray, J: np.ndarray, vs: np.ndarray, Ks: np.ndarray,
            c: np.ndarray, rcond: float = LU_RCOND) -> bool:
        """The regular case by an LU factorisation of the equilibrated matrix (non-zero
        entries ``vs`` at ``I, J``), when a condition estimate leaves no doubt about the rank
        (the SVD decides otherwise): :mod:`lcs.sparse_lu` (compiled; an MMC arm of 64 cells,
        515 unknowns: about 1 ms with the solve of 322 right-hand sides, and no scipy
        import), SuperLU beyond its size."""
        nz = Ks.shape[0]
        anorm = float(np.bincount(J, np.abs(vs), minlength=nz).max()) if vs.size else 0.0
        if nz <= sparse_lu.MAX_SIZE:
            lu = sparse_lu.lu_factor(nz, I, J, vs)
            if lu is None:  # exactly singular
                return False
            if not sparse_lu.lu_rcond(lu, anorm) > rcond:
                return False
            zs = sparse_lu.lu_solve(lu, Ks, out=sparse_lu.kept_array(
                _WORK, "z", (nz, Ks.shape[1]), limit=WORK_KEPT))
        else:
            from scipy.sparse import csc_matrix
            from scipy.sparse.linalg import LinearOperator, onenormest, splu

            try:
                slu = splu(csc_matrix((vs, (I, J)), shape=(nz, nz)))
            except RuntimeError:  # exactly singular
                return False
            inv = LinearOperator((nz, nz), matvec=slu.solve,
                                 rmatvec=lambda v: slu.solve(v, trans="T"), dtype=float)
            estimate = 1.0 / (anorm * onenormest(inv)) if anorm > 0 else 0.0
            if not estimate > rcond:
                return False
            zs = slu.solve(np.asfortranarray(Ks)) if Ks.shape[1] else np.zeros(Ks.shape)
        if not np.all(np.isfinite(zs)):
            return False
        self.null = np.zeros((nz, 0))
        self.inconsistent = []
        zs *= c[:, None]  # (in place: the same products, no second dense array)
        self._set_z(zs)
        return True

    def _set_z(self, Z: np.ndarray) -> None:
        """Keep ``Z`` (nz, nξ) by its non-zero entries, row by row: about 1 % of it on the
        switched families of ``converters/scaling.py`` (a 64-cell MMC arm's 97 modes kept
        129 MB of dense Z), and a form's rows are gathered from them (:meth:`_rows`)."""
        zr, zc = np.nonzero(Z)
        self._zshape = Z.shape
        self._zp = np.zeros(Z.shape[0] + 1, np.int64)
        np.cumsum(np.bincount(zr, minlength=Z.shape[0]), out=self._zp[1:])
        self._zi = zc
        self._zx = Z[zr, zc]

    @property
    def Z(self) -> np.ndarray:
        """The solution's matrix, ``z = Z ξ``, (nz, nξ), dense (a copy)."""
        return self._rows(np.arange(self._zshape[0]))

    def _rows(self, idx: np.ndarray) -> np.ndarray:
        """Rows ``idx`` of ``Z``, dense (len(idx), nξ)."""
        out = np.zeros((idx.size, self._zshape[1]))
        if idx.size:
            start = self._zp[idx]
            count = self._zp[idx + 1] - start
            total = int(count.sum())
            if total:
                pos = np.repeat(start - np.cumsum(count) + count, count) + np.arange(total)
                out[np.repeat(np.arange(idx.size), count), self._zi[pos]] = self._zx[pos]
        return out

    def determined_many(self, forms_z: np.ndarray) -> np.ndarray:
        """:meth:`determined` of every row of ``forms_z`` (k, nz) at once, bool (k,)."""
        forms_z = np.asarray(forms_z, dtype=float).reshape(-1, self.null.shape[0])
        if self.null.shape[1] == 0:
            return np.ones(forms_z.shape[0], dtype=bool)
        g = forms_z * self.col_scale
        norm = np.linalg.norm(g, axis=1)
        return (norm == 0) | (np.linalg.norm(g @ self.null, axis=1) <= DETERMINED_RTOL * norm)

    def determined(self, form_z: np.ndarray) -> bool:
        """Whether ``form_z @ z`` is the same for every solution z."""
        return bool(self.determined_many(form_z)[0])

    def evaluate_terms(self, terms: list[list[tuple[int, float]]]) -> np.ndarray:
        """:meth:`evaluate_many` of forms given as lists of (column over (z, ξ),
        coefficient) terms, the same sums without the dense forms."""
        return self._sum_terms(len(terms), *_flat_terms(terms))

    def evaluate_forms(self, terms: list[list[tuple[int, float]]], width: int) -> np.ndarray:
        """:meth:`evaluate_many` of the dense forms (of ``width`` columns) that the lists of
        (column, coefficient) terms add up to, in their order, without building them: the
        same non-zero coefficients in the same order, so the same sums (128 probes of a
        64-cell MMC arm: dense forms 2 ms a mode)."""
        return self._sum_terms(len(terms), *coalesce(*_flat_terms(terms), width))

    def evaluate_many(self, forms: np.ndarray) -> np.ndarray:
        """Rows over ξ, shape (k, nξ), of the quantities given by the rows of ``forms``
        (k, nz + nξ) over (z, ξ).

        A form names a few unknowns (a voltage two nodes, a current one branch): the sum
        runs over its non-zero coefficients only, for every form at once (an MMC arm of 64
        cells: 0.4 ms for 200 forms, where one product per form took 9 ms).
        """
        forms = np.asarray(forms, dtype=float).reshape(-1, sum(self._zshape))
        r, c = np.nonzero(forms)
        return self._sum_terms(forms.shape[0], r, c, forms[r, c])

    def _sum_terms(self, k: int, r: np.ndarray, c: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Rows (k, nξ) of the forms given as terms: coefficient ``v`` of column ``c`` over
        (z, ξ) in form ``r``. The ξ terms are added in place, the z terms as ``v Z[c]``
        summed form by form in the order given."""
        nz, nxi = self._zshape
        out = np.zeros((k, nxi))
        if not r.size:
            return out
        xi = c >= nz
        np.add.at(out, (r[xi], c[xi] - nz), v[xi])
        zr, zc, zv = r[~xi], c[~xi], v[~xi]
        if zr.size:
            order = np.argsort(zr, kind="stable")
            zr, zc, zv = zr[order], zc[order], zv[order]
            starts = np.flatnonzero(np.r_[True, zr[1:] != zr[:-1]])
            count = np.diff(np.r_[starts, zr.size])
            if count.max() > 2:
                sums = np.add.reduceat(zv[:, None] * self._rows(zc), starts, axis=0)
            else:
                # A form of one or two terms (every voltage, every current but a G
                # source's): their sum in either order is the same, that of reduceat, which
                # along the rows took 0.7 ms for 128 diodes of a 64-cell MMC arm.
                sums = zv[starts, None] * self._rows(zc[starts])
                two = starts[count == 2] + 1
                sums[count == 2] += zv[two, None] * self._rows(zc[two])
            out[zr[starts]] += sums
        return out


# This thread's kept work arrays (sparse_lu.kept_array): the scaled right-hand sides ("rhs",
# zero outside its use) and the LU's solution before it is kept sparse ("z").
_WORK = threading.local()
#: largest work array kept between modes (values; 8 MB)
WORK_KEPT = 1 << 20


def equilibrate(M: np.ndarray, iterations: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Row and column scalings ``r, c`` with ``diag(r) M diag(c)`` near unit max entries."""
    I, J = np.nonzero(M)
    return _equilibrate_terms(M.shape[0], M.shape[1], I, J, np.abs(M[I, J]), iterations)


def _equilibrate_terms(nr: int, nc: int, I: np.ndarray, J: np.ndarray, v: np.ndarray,
                       iterations: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """:func:`equilibrate` from the absolute values ``v`` of the non-zero entries at ``I,
    J``: the same maxima as over the dense matrix, in O(nnz) a pass."""
    r = np.ones(nr)
    c = np.ones(nc)
    for _ in range(iterations):
        rowmax = np.zeros(nr)
        np.maximum.at(rowmax, I, v * c[J])
        rowmax *= r
        rowmax[rowmax == 0] = 1.0
        r /= np.sqrt(rowmax)
        colmax = np.zeros(nc)
        np.maximum.at(colmax, J, v * r[I])
        colmax *= c
        colmax[colmax == 0] = 1.0
        c /= np.sqrt(colmax)
    return r, c


def clean(matrix: np.ndarray) -> np.ndarray:
    """Zero the entries that are round-off relative to the largest entry of their row."""
    out = np.array(matrix, dtype=float)
    if out.size:
        row_max = np.abs(out).max(axis=1, keepdims=True)
        out[np.abs(out) <= CLEAN_RTOL * row_max] = 0.0
    return out


def _flat_terms(terms: list[list[tuple[int, float]]]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lists of (column, coefficient) terms as (form, column, coefficient) arrays, in order."""
    rows = [k for k, form in enumerate(terms) for _ in form]
    flat = [t for form in terms for t in form]
    return (np.array(rows, dtype=np.int64), np.array([t[0] for t in flat], dtype=np.int64),
            np.array([t[1] for t in flat], dtype=float))
