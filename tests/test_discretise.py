"""lcs.integrators.moreau.dense.discretise against the θ-step formulas evaluated with numpy's LAPACK
solve: dense matrices, and the sparse structures the row-wise, zero-skipping loops are for (an arrow
A, as a shared inductor or capacitor makes, and a C whose rows name one or two states)."""

from __future__ import annotations

import numpy as np
import pytest

from lcs.integrators.moreau.dense import discretise


def _reference(A, B, C, D, E, h, theta):
    n = A.shape[0]
    W = np.linalg.inv(np.eye(n) - h * theta * A)
    K = h * W @ B
    return dict(Phi=W @ (np.eye(n) + h * (1 - theta) * A), G0=h * (1 - theta) * W @ E,
                G1=h * theta * W @ E, K=K, M=D + C @ K)


def _arrow(rng, n, m):
    A = np.zeros((n, n))
    A[:-1, -1] = rng.normal(size=n - 1) * 1e4   # every capacitor sees the shared current
    A[-1, :-1] = rng.normal(size=n - 1) * 1e3   # which every voltage drives
    A[-1, -1] = -10.0
    C = np.zeros((m, n))
    C[np.arange(m), rng.integers(0, n, m)] = 1.0
    C[np.arange(m), -1] = rng.choice([0.0, -1.0], m)
    return A, C


@pytest.mark.parametrize("structure", ["dense", "arrow"])
@pytest.mark.parametrize("theta", [0.5, 1.0])
def test_matches_numpy_formulas(structure, theta):
    rng = np.random.default_rng(7)
    for n, m, p in ((1, 1, 1), (5, 3, 2), (40, 70, 3)):
        if structure == "dense":
            A = rng.normal(size=(n, n)) * 1e3
            C = rng.normal(size=(m, n))
        else:
            A, C = _arrow(rng, n, m)
        B = rng.normal(size=(n, m))
        D = rng.normal(size=(m, m)) * (rng.random((m, m)) < 0.2)
        E = rng.normal(size=(n, p))
        h = 1e-6
        got = discretise(A, B, C, D, E, h, theta)
        ref = _reference(A, B, C, D, E, h, theta)
        for name, want in ref.items():
            mat = getattr(got, name)
            scale = max(np.abs(want).max(), 1e-300)
            assert np.abs(mat - want).max() <= 1e-12 * scale, (structure, n, name)


def test_singular_step_matrix_is_refused():
    A = np.array([[2.0]])  # I - h θ A = 0 at h θ = 1/2
    with pytest.raises(ValueError, match="singular"):
        discretise(A, np.ones((1, 1)), np.ones((1, 1)), np.zeros((1, 1)), np.ones((1, 1)),
                   1.0, 0.5)
