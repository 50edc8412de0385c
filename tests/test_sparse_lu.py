"""lcs.sparse_lu: the compiled LU of the formulation against numpy's LAPACK solve and exact
condition numbers, and the formulation it serves against SuperLU's."""

from __future__ import annotations

import numpy as np
import pytest

from converters.scaling import interleaved_buck, mmc_arm
from lcs import sparse_lu
from lcs.sparse_lu import lu_factor, lu_rcond, lu_solve
from netlist import mna_solve
from netlist.formulation import formulate
from netlist.parser import parse_string


def _random_sparse(rng, n, density):
    M = np.where(rng.random((n, n)) < density, rng.normal(size=(n, n)), 0.0)
    M += np.diag(np.where(rng.random(n) < 0.8, 3.0 * rng.normal(size=n), 0.0))
    return M


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_solve_matches_lapack_within_the_condition_bound():
    rng = np.random.default_rng(11)
    solved = 0
    for _ in range(300):
        n = int(rng.integers(1, 70))
        M = _random_sparse(rng, n, rng.uniform(0.02, 0.6))
        I, J = np.nonzero(M)
        lu = lu_factor(n, I, J, M[I, J])
        if np.linalg.matrix_rank(M) < n:
            continue  # (exactly singular ones: next test)
        assert lu is not None
        B = rng.normal(size=(n, 4))
        Z = lu_solve(lu, B)
        ref = np.linalg.solve(M, B)
        cond = np.linalg.cond(M, 1)
        assert np.abs(Z - ref).max() <= 1e-13 * cond * np.abs(ref).max()
        assert np.allclose(lu_solve(lu, B[:, 0]), Z[:, 0], rtol=0, atol=0)
        solved += 1
    assert solved > 150


def test_heavy_fill_in_grows_the_pattern_pools():
    # A random pattern at 5 % fills most of the factors: far more entries than the pools'
    # first size (twice the matrix's entries), so the elimination restarts with larger ones.
    rng = np.random.default_rng(2)
    n = 200
    M = _random_sparse(rng, n, 0.05) + 5 * np.eye(n)
    I, J = np.nonzero(M)
    lu = lu_factor(n, I, J, M[I, J])
    assert lu.Lx.size + lu.Ux.size > 4 * I.size
    B = rng.normal(size=(n, 3))
    ref = np.linalg.solve(M, B)
    assert np.abs(lu_solve(lu, B) - ref).max() <= 1e-13 * np.linalg.cond(M, 1) * np.abs(ref).max()


def test_kept_work_arrays_are_zero_after_every_kind_of_call():
    # lu_factor reuses this thread's dense work arrays, which must be zero on entry: after a
    # regular factorisation, an exactly singular one and one whose pattern pools overflowed
    # (heavy fill-in), they are zero again, and a factorisation after them equals one made
    # with fresh arrays bit for bit.
    rng = np.random.default_rng(5)
    M = _random_sparse(rng, 40, 0.1) + 4 * np.eye(40)
    I, J = np.nonzero(M)
    sparse_lu._WORK.__dict__.pop("w", None)
    sparse_lu._WORK.__dict__.pop("s", None)
    fresh = lu_factor(40, I, J, M[I, J])
    heavy = _random_sparse(rng, 120, 0.05) + 5 * np.eye(120)
    Ih, Jh = np.nonzero(heavy)
    singular = np.array([[1.0, 2.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]])
    Is, Js = np.nonzero(singular)
    for call in (lambda: lu_factor(120, Ih, Jh, heavy[Ih, Jh]),
                 lambda: lu_factor(3, Is, Js, singular[Is, Js]),
                 lambda: lu_factor(40, I, J, M[I, J])):
        call()
        W, S = sparse_lu._WORK.w, sparse_lu._WORK.s
        assert not W.any() and not S.any()
        again = lu_factor(40, I, J, M[I, J])
        for name in ("p", "q", "Lp", "Li", "Lx", "Up", "Ui", "Ux"):
            assert np.array_equal(getattr(again, name), getattr(fresh, name)), name


def test_threads_factorise_with_their_own_work_arrays():
    import threading

    rng = np.random.default_rng(8)
    mats = [_random_sparse(rng, 60, 0.08) + 4 * np.eye(60) for _ in range(6)]
    B = rng.normal(size=(60, 2))
    errors = []

    def work(M):
        I, J = np.nonzero(M)
        ref = np.linalg.solve(M, B)
        for _ in range(30):
            Z = lu_solve(lu_factor(60, I, J, M[I, J]), B)
            if not np.abs(Z - ref).max() <= 1e-12 * np.linalg.cond(M, 1) * np.abs(ref).max():
                errors.append(1)

    threads = [threading.Thread(target=work, args=(M,)) for M in mats]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors


def test_repeated_positions_are_summed_and_pivoting_handles_zero_diagonals():
    # [[0, 2], [1, 1]] with the (0, 1) entry given as 1.5 + 0.5: needs a row exchange.
    lu = lu_factor(2, np.array([0, 0, 1, 1]), np.array([1, 1, 0, 1]),
                   np.array([1.5, 0.5, 1.0, 1.0]))
    assert np.allclose(lu_solve(lu, np.array([2.0, 3.0])), [2.0, 1.0], rtol=0, atol=1e-15)


def test_exactly_singular_matrices_are_reported():
    # A zero column, and a column that elimination empties (two equal rows).
    assert lu_factor(3, np.array([0, 1, 2]), np.array([0, 0, 2]), np.ones(3)) is None
    M = np.array([[1.0, 2.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]])
    I, J = np.nonzero(M)
    assert lu_factor(3, I, J, M[I, J]) is None


def test_rcond_estimate_bounds_the_exact_value():
    """Hager-Higham's estimate of ‖M⁻¹‖₁ is a lower bound, so the reciprocal condition
    estimate is at least the exact one; on these matrices at most 3 times it."""
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(2, 60))
        M = _random_sparse(rng, n, rng.uniform(0.05, 0.5))
        if np.linalg.matrix_rank(M) < n:
            continue
        I, J = np.nonzero(M)
        lu = lu_factor(n, I, J, M[I, J])
        exact = 1.0 / np.linalg.cond(M, 1)
        est = lu_rcond(lu, np.abs(M).sum(axis=0).max())
        assert exact * (1 - 1e-9) <= est <= 3.0 * exact
    # Nearly singular: the estimate says so.
    M = np.array([[1.0, 1.0], [1.0, 1.0 + 1e-12]])
    I, J = np.nonzero(M)
    assert lu_rcond(lu_factor(2, I, J, M[I, J]), 2.0) < 1e-11


def test_size_limit_is_stated():
    with pytest.raises(ValueError, match="MAX_SIZE"):
        lu_factor(sparse_lu.MAX_SIZE + 1, np.zeros(0, int), np.zeros(0, int), np.zeros(0))


@pytest.mark.parametrize("text", [mmc_arm(20, periods=1), interleaved_buck(40, periods=1)],
                         ids=["mmc20", "ib40"])
def test_formulation_equals_superlus(text, monkeypatch):
    """The LCS of every mode reached from the initial one, by this LU and by SuperLU (the
    path beyond MAX_SIZE), agree to round-off (160 to 200 unknowns a mode)."""
    ours = formulate(parse_string(text))
    key = tuple(False for _ in ours.switches)
    keys = [key] + [tuple(j == i for j in range(len(key))) for i in range(0, len(key), 7)]
    models = []
    for k in keys:
        try:
            models.append(ours.mode(k))
        except Exception as exc:  # noqa: BLE001 (a degenerate mode fails both ways)
            models.append(type(exc))
    monkeypatch.setattr(sparse_lu, "MAX_SIZE", 0)
    theirs = formulate(parse_string(text))
    sizes = []
    original = mna_solve.Solution.__init__

    def spy(self, M, K, entries=None):
        sizes.append(K.shape[0])
        original(self, M, K, entries)

    monkeypatch.setattr(mna_solve.Solution, "__init__", spy)
    for k, mine in zip(keys, models, strict=True):
        try:
            ref = theirs.mode(k)
        except Exception as exc:  # noqa: BLE001
            assert mine is type(exc)
            continue
        for name in "ABCDEF":
            a, b = getattr(mine, name), getattr(ref, name)
            assert np.allclose(a, b, rtol=1e-12, atol=1e-12 * max(np.abs(b).max(), 1.0)), name
    assert min(sizes) >= 150


def test_empty_system():
    lu = lu_factor(0, np.zeros(0, int), np.zeros(0, int), np.zeros(0))
    assert lu_solve(lu, np.zeros((0, 3))).shape == (0, 3)
    assert lu_rcond(lu, 0.0) == 1.0
