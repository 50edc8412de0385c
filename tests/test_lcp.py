"""LCP solvers: Lemke (numpy and numba) against brute-force enumeration of complementary bases."""

from __future__ import annotations

import functools
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from lcs.lcp import (
    LcpOptions,
    enumerate_lcp,
    is_p_matrix,
    lemke,
    solve_lcp,
    solve_lcp_nb,
)


def brute_force(M, q, tol=1e-9, cond_limit=1e12):
    """All solutions found by trying the 2^m complementary bases (independent of lcs.lcp);
    a basis whose block is conditioned worse than ``cond_limit`` is taken as singular."""
    M = np.ascontiguousarray(M, dtype=float)
    m = len(q)
    sols = []
    for a, Maa in _regular_bases(M.tobytes(), M.shape, cond_limit):
        z = np.zeros(m)
        if a:
            z[a] = np.linalg.solve(Maa, -q[a])
        w = M @ z + q
        # Relative to the data: the tests use q from 1e-12 to 1e6.
        scale = np.abs(q).max() + np.abs(M).max() * np.abs(z).max()
        if z.min() >= -tol * scale and w.min() >= -tol * scale:
            sols.append((z, w))
    return sols


@functools.lru_cache(maxsize=4)
def _regular_bases(data: bytes, shape: tuple[int, int], cond_limit: float):
    """The bases of ``M`` (given by its bytes, to be a cache key) whose blocks are conditioned
    better than ``cond_limit``, in enumeration order, with their blocks: they depend on ``M``
    alone, and the tests that enumerate many ``q`` for one ``M`` (2^12 bases) spent most of
    their time in the condition numbers."""
    M = np.frombuffer(data, dtype=float).reshape(shape)
    m = shape[0]
    out = []
    for k in range(m + 1):
        for act in itertools.combinations(range(m), k):
            a = list(act)
            if not a:
                out.append((a, None))
                continue
            Maa = M[np.ix_(a, a)]
            if np.linalg.cond(Maa) > cond_limit:  # singular basis: no vertex solution
                continue
            out.append((a, Maa))
    return out


def random_p_matrix(rng, m):
    """Positive definite plus skew part: a P-matrix (not symmetric)."""
    G = rng.normal(size=(m, m))
    S = rng.normal(size=(m, m))
    return G @ G.T + 0.1 * np.eye(m) + (S - S.T)


def random_psd(rng, m):
    """Singular positive semidefinite, sometimes plus a skew part (monotone LCP, often
    unsolvable)."""
    r = max(1, m // 2)
    G = rng.normal(size=(m, r))
    S = rng.normal(size=(m, m)) * (rng.random() < 0.3)
    return G @ G.T + (S - S.T)


def assert_solves(M, q, z, tol=1e-8):
    w = M @ z + q
    scale = np.abs(q).max() + np.abs(M).max() * np.abs(z).max()
    assert z.min() >= -tol * scale
    assert w.min() >= -tol * scale
    assert abs(z @ w) <= tol * scale**2


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("seed", range(4))
def test_p_matrix_lemke_numba_and_enumeration_agree(seed):
    rng = np.random.default_rng(seed)
    for _ in range(100):
        m = int(rng.integers(1, 7))
        M = random_p_matrix(rng, m)
        q = rng.normal(size=m) * 10.0 ** rng.integers(-8, 4)
        sols = brute_force(M, q)
        assert len(sols) >= 1
        z_ref = sols[0][0]
        for res in (lemke(M, q), solve_lcp_nb(M, q), enumerate_lcp(M, q), solve_lcp(M, q)):
            assert res.ok, res.status
            np.testing.assert_allclose(res.z, z_ref, rtol=1e-8,
                                       atol=1e-10 * (np.abs(z_ref).max() + 1e-300))
            np.testing.assert_allclose(res.w, M @ res.z + q, rtol=1e-7,
                                       atol=1e-9 * np.abs(q).max())


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("seed", range(4))
def test_psd_solvability_matches_brute_force(seed):
    rng = np.random.default_rng(100 + seed)
    n_solved = n_unsolved = 0
    for _ in range(150):
        m = int(rng.integers(1, 7))
        M = random_psd(rng, m)
        q = rng.normal(size=m)
        exists = len(brute_force(M, q)) > 0
        r_py, r_nb = lemke(M, q), solve_lcp_nb(M, q)
        # For copositive-plus matrices Lemke's ray termination proves infeasibility.
        assert r_py.ok == exists
        assert r_nb.ok == exists
        if exists:
            n_solved += 1
            assert_solves(M, q, r_py.z)
            assert_solves(M, q, r_nb.z)
            # Same pivoting rules: the same basis.
            np.testing.assert_array_equal(r_py.basis, r_nb.basis)
            assert r_py.pivots == r_nb.pivots
        else:
            n_unsolved += 1
            assert r_py.status == r_nb.status == "ray_termination"
    assert n_solved > 20 and n_unsolved > 5


@settings(max_examples=60, deadline=None)
@given(
    st.integers(1, 5),
    st.integers(0, 2**31 - 1),
    st.sampled_from([1e-12, 1e-3, 1.0, 1e6]),
)
def test_hypothesis_p_matrix(m, seed, scale):
    rng = np.random.default_rng(seed)
    M = random_p_matrix(rng, m)
    q = rng.normal(size=m) * scale
    # Degenerate data: some exact zeros in q.
    q[rng.random(m) < 0.3] = 0.0
    sols = brute_force(M, q)
    res_py, res_nb = lemke(M, q), solve_lcp_nb(M, q)
    assert res_py.ok and res_nb.ok
    assert_solves(M, q, res_py.z)
    np.testing.assert_allclose(res_py.z, sols[0][0], rtol=1e-7, atol=1e-9 * scale)
    np.testing.assert_allclose(res_nb.z, res_py.z, rtol=1e-10, atol=1e-14 * scale)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_scale_invariance_of_degenerate_problem():
    # From a diode bridge near zero energy: q is tiny and partly zero (degenerate), the
    # lexicographic rule must not mistake tiny ratios for ties.
    M = np.array([[1e-3, 1e-3, -1.0, 0.0], [1e-3, 1e-3, 0.0, -1.0],
                  [1.0, 0.0, 0.999975, -0.999975], [0.0, 1.0, -0.999975, 0.999975]])
    q1 = np.array([0.0, 0.0, -1.0, 1.0])
    for s in (1.0, 1e-10, 1e-200, 1e10):
        for solver in (lemke, solve_lcp_nb):
            r = solver(M, s * q1)
            assert r.ok
            assert_solves(M, s * q1, r.z)
            np.testing.assert_allclose(r.z / s, solver(M, q1).z, rtol=1e-12, atol=1e-15)


def test_trivial_and_empty():
    r = solve_lcp(np.eye(2), np.array([1.0, 0.0]))
    assert r.ok and r.status == "trivial" and r.pivots == 0
    np.testing.assert_array_equal(r.z, 0.0)
    r = solve_lcp(np.zeros((0, 0)), np.zeros(0))
    assert r.ok and r.z.shape == (0,)


def test_ray_termination_reported_as_no_solution():
    # w = -z - 1 can never be >= 0 with z >= 0.
    M = np.array([[-1.0]])
    q = np.array([-1.0])
    assert lemke(M, q).status == "ray_termination"
    assert not solve_lcp_nb(M, q).ok
    r = solve_lcp(M, q)
    assert not r.ok and r.status == "no_solution"  # confirmed by enumeration
    r = solve_lcp(M, q, LcpOptions(method="lemke"))
    assert not r.ok and r.status == "ray_termination"


def test_enumeration_rescues_lemke_on_non_copositive_matrix():
    M = np.array([[-2.0, 1.0], [2.0, -2.0]])
    q = np.array([-1.0, 2.0])
    assert lemke(M, q).status == "ray_termination"
    r = solve_lcp(M, q)
    assert r.ok and r.method == "enumeration"
    assert_solves(M, q, r.z)
    assert len(brute_force(M, q)) >= 1


def test_max_pivots():
    rng = np.random.default_rng(5)
    M = random_p_matrix(rng, 6)
    q = -np.abs(rng.normal(size=6))
    r = solve_lcp(M, q, LcpOptions(method="lemke", max_pivots=1))
    assert not r.ok and r.status == "max_pivots"


def test_all_solutions_and_p_matrix_check():
    # Two solutions: z = 0 (w = q) and z = 1 (w = 0).
    M = np.array([[-1.0]])
    q = np.array([1.0])
    sols = enumerate_lcp(M, q, all_solutions=True)
    assert sorted(float(z[0]) for z, _, _ in sols) == [0.0, 1.0]
    assert is_p_matrix(np.array([[2.0, 1.0], [-1.0, 1.0]]))
    assert not is_p_matrix(M)
    assert not is_p_matrix(np.array([[1.0, 2.0], [2.0, 1.0]]))  # det < 0
    assert is_p_matrix(np.eye(13)) is None


def test_invalid_input():
    with pytest.raises(ValueError):
        solve_lcp(np.eye(2), np.ones(3))
    with pytest.raises(ValueError):
        solve_lcp(np.eye(1), np.array([np.nan]))
    with pytest.raises(ValueError):
        solve_lcp(np.eye(1), np.ones(1), LcpOptions(method="magic"))
