"""netlist.mna_solve.Solution: the LU path of large regular systems equals the SVD path, and a
singular system (a floating node) still goes through the SVD with its null space."""

from __future__ import annotations

import numpy as np
import pytest

import netlist.mna_solve as ms


def _svd_only(M, K):
    old = ms.LU_MIN_SIZE
    ms.LU_MIN_SIZE = 10**9
    try:
        return ms.Solution(M, K)
    finally:
        ms.LU_MIN_SIZE = old


def test_lu_equals_svd_on_a_large_regular_system():
    rng = np.random.default_rng(3)
    n = 200
    # A conductance-like matrix with entries over six decades (units of A and V rows).
    M = rng.normal(size=(n, n)) * np.logspace(-3, 3, n)[:, None] + 50 * np.eye(n)
    K = rng.normal(size=(n, 40))
    lu, svd = ms.Solution(M, K), _svd_only(M, K)
    assert lu.null.shape == (n, 0) and lu.inconsistent == []
    np.testing.assert_allclose(lu.Z, svd.Z, rtol=1e-9, atol=1e-12 * np.abs(svd.Z).max())
    np.testing.assert_allclose(M @ lu.Z, K, atol=1e-9 * np.abs(K).max())


def test_singular_large_system_keeps_its_null_space():
    rng = np.random.default_rng(4)
    n = 180
    M = rng.normal(size=(n, n)) + 30 * np.eye(n)
    M[:, 7] = 0.0  # an unknown nothing determines (a floating node's voltage)
    M[7, :] = 0.0
    K = rng.normal(size=(n, 5))
    K[7] = 0.0
    sol = ms.Solution(M, K)
    assert sol.null.shape[1] == 1
    e = np.zeros(n)
    e[7] = 1.0
    assert not sol.determined(e) and sol.determined(np.eye(n)[3])


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_sparse_lu_equals_svd_and_refuses_a_near_singular_system():
    rng = np.random.default_rng(5)
    n = 300
    # A ladder-like MNA pattern: a diagonal and two off-diagonals, units over six decades.
    M = np.diag(rng.uniform(1, 2, n) * np.logspace(-3, 3, n))
    for k in (1, 7):
        idx = np.arange(n - k)
        M[idx, idx + k] = rng.normal(size=n - k) * 0.3 * np.diag(M)[idx]
        M[idx + k, idx] = rng.normal(size=n - k) * 0.3 * np.diag(M)[idx + k]
    assert np.count_nonzero(M) <= 0.05 * n * n  # the sparse path
    K = rng.normal(size=(n, 30))
    lu, svd = ms.Solution(M, K), _svd_only(M, K)
    assert lu.null.shape == (n, 0)
    np.testing.assert_allclose(lu.Z, svd.Z, rtol=1e-8, atol=1e-11 * np.abs(svd.Z).max())
    # Two rows equal up to 1e-13 (a near-singular system): the condition estimate sends it
    # to the SVD, which finds the null direction.
    M2 = M.copy()
    M2[5] = M2[4] * (1 + 1e-13)
    K2 = K.copy()
    K2[5] = K2[4]
    sol = ms.Solution(M2, K2)
    assert sol.null.shape[1] == 1



def test_terms_are_summed_as_reduceat_sums_them():
    # Forms of one or two z terms are summed without np.add.reduceat, the others with it:
    # the sums must be reduceat's over each form's terms (round-off included).
    rng = np.random.default_rng(8)
    n, nxi, k = 30, 7, 40
    sol = ms.Solution(rng.normal(size=(n, n)) + 10 * np.eye(n), rng.normal(size=(n, nxi)))
    for most in (2, 5):
        for _ in range(20):
            r = np.repeat(np.arange(k), rng.integers(0, most + 1, size=k))
            c = rng.integers(0, n + nxi, size=r.size)
            v = rng.normal(size=r.size) * 10.0 ** rng.integers(-8, 8, size=r.size)
            order = rng.permutation(r.size)  # (the forms' terms interleaved)
            r, c, v = r[order], c[order], v[order]
            want = np.zeros((k, nxi))
            xi = c >= n
            np.add.at(want, (r[xi], c[xi] - n), v[xi])
            z = np.argsort(np.where(xi, k, r), kind="stable")[:np.count_nonzero(~xi)]
            zr = r[z]
            starts = np.flatnonzero(np.r_[True, zr[1:] != zr[:-1]]) if zr.size else []
            if zr.size:
                want[zr[starts]] += np.add.reduceat(v[z, None] * sol.Z[c[z]], starts, axis=0)
            assert np.array_equal(sol._sum_terms(k, r, c, v), want)


def test_sparse_entries_path_keeps_z_by_its_entries_and_leaves_the_work_array_zero():
    # A right-hand side given by its entries goes through this thread's kept (zeroed) work
    # array; Z is kept by its non-zero entries. Z and every gathered row equal the dense
    # right-hand side's solution bit for bit, and the work array is zero afterwards, also
    # after a singular system that went on to the SVD.
    rng = np.random.default_rng(12)
    for n, nxi, singular in ((60, 25, False), (40, 9, True), (60, 25, False)):
        M = np.where(rng.random((n, n)) < 0.05, rng.normal(size=(n, n)), 0.0) + 6 * np.eye(n)
        if singular:
            M[:, 3] = 0.0
            M[3, :] = 0.0
        K = np.where(rng.random((n, nxi)) < 0.1, rng.normal(size=(n, nxi)), 0.0)
        I, J = np.nonzero(M)
        rows, cols = np.nonzero(K)
        sol = ms.Solution(None, ms.Entries(rows, cols, K[rows, cols], (n, nxi)),
                          entries=(I, J, M[I, J]))
        dense = ms.Solution(M, K)
        assert np.array_equal(sol.Z, dense.Z)
        idx = rng.integers(0, n, size=17)
        assert np.array_equal(sol._rows(idx), dense.Z[idx])
        assert sol._zx.size == np.count_nonzero(dense.Z)
        assert not ms._WORK.rhs.any()
        assert (sol.null.shape[1] > 0) == singular
