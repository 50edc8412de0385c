"""The regular step's column products over each column's non-zero rows only
(lcs.integrators.moreau.dense.modes.column_spans, ModeStack.span): the spans themselves, and a run
of an LCS with the multiplier's structure (Phi the identity but for a block, C triangular with zero
columns) from 16 states on, against the independent reference stepper."""

from __future__ import annotations

import numpy as np
import test_moreau_reference
from test_moreau import make_lcs
from test_moreau_reference import moreau_reference

from lcs.integrators.moreau.dense import discretise
from lcs.integrators.moreau.dense.discretise import COLUMN_MIN
from lcs.integrators.moreau.dense.modes import column_spans
from lcs.integrators.moreau.integrator import simulate_lcs


def test_column_spans():
    a = np.array([[0.0, 1.0, 0.0, 0.0],
                  [0.0, 0.0, 2.0, 0.0],
                  [0.0, 3.0, 0.0, 0.0]])
    assert column_spans(a).tolist() == [[0, 0], [0, 3], [1, 2], [0, 0]]
    assert column_spans(np.zeros((0, 3))).tolist() == [[0, 0]] * 3
    assert column_spans(np.eye(3)).tolist() == [[0, 1], [1, 2], [2, 3]]


def _structured_lcs(rng, n, m, h):
    for _ in range(200):
        A = -0.5 * np.eye(n)
        A[:6, :6] += rng.normal(size=(6, 6))          # the part a load couples
        C = np.tril(rng.normal(size=(m, n)), -2)       # triangular, two zero columns at the end
        C[:, 3] = 0.0                                   # and one inside
        B = 0.02 * rng.normal(size=(n, m))
        G = rng.normal(size=(m, m))
        D = G @ G.T + np.eye(m)
        E = rng.normal(size=(n, 1))
        F = rng.normal(size=(m, 1))
        M = discretise(A, B, C, D, E, h, 0.5).M
        if np.linalg.eigvalsh(M + M.T).min() > 0:  # positive definite: a P-matrix
            return make_lcs(A, B, C, D, E, F)
    raise RuntimeError("no P-matrix LCS found")


def _murty_lcp(M, q, tol=1e-10):
    """Murty's least-index principal pivoting (finite for P-matrices): the reference's
    enumeration of bases is out of reach at 20 pairs."""
    m = len(q)
    active = np.zeros(m, bool)
    for _ in range(100 * m):
        lam = np.zeros(m)
        a = np.flatnonzero(active)
        if a.size:
            lam[a] = np.linalg.solve(M[np.ix_(a, a)], -q[a])
        w = M @ lam + q
        scale = np.abs(q).max() + np.abs(M).max() * np.abs(lam).max()
        bad = np.flatnonzero(np.where(active, lam, w) < -tol * scale)
        if bad.size == 0:
            return lam
        active[bad[0]] = not active[bad[0]]
    raise RuntimeError("no LCP solution")


def test_sparse_columns_run_equals_reference(monkeypatch):
    monkeypatch.setattr(test_moreau_reference, "brute_force_lcp", _murty_lcp)
    rng = np.random.default_rng(4)
    n, m, h = 24, 20, 0.02
    assert n >= COLUMN_MIN and m >= COLUMN_MIN  # the column products, and solve_cached's
    lcs = _structured_lcs(rng, n, m, h)
    spans = column_spans(discretise(lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, h, 0.5).Phi)
    assert (spans[6:, 1] - spans[6:, 0] == 1).all()   # identity columns: the diagonal only
    inputs = [lambda t: 2.0 * np.sin(3.0 * t)]
    x0 = rng.normal(size=n)
    res = simulate_lcs(lcs, inputs, x0, 120 * h, h, theta=0.5)
    assert res.ok
    u = lambda t: np.array([inputs[0](np.asarray(t))])  # noqa: E731
    xs, lams = moreau_reference(lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, lcs.F, u, x0, res.t, 0.5)
    np.testing.assert_allclose(res.y, xs, rtol=0, atol=1e-11 * np.abs(xs).max())
    active = lams > 1e-12 * np.abs(lams).max()
    assert np.any(active.any(axis=0) & ~active.all(axis=0))  # some diode switched
