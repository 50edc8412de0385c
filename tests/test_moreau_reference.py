"""An independent, deliberately naive implementation of Siconos's EulerMoreauOSI(θ) for
first-order linear LCS (plain numpy, brute-force LCP by enumeration of complementary bases),
used by the Moreau tests as the reference. It shares no code with lcs/."""

from __future__ import annotations

import itertools

import numpy as np


def brute_force_lcp(M, q, tol=1e-10):
    """The solution of w = M λ + q, 0 <= w ⊥ λ >= 0 with fewest active pairs (unique for a
    P-matrix)."""
    m = len(q)
    if m == 0:
        return np.zeros(0)
    for k in range(m + 1):
        for act in itertools.combinations(range(m), k):
            lam = np.zeros(m)
            a = list(act)
            if a:
                Maa = M[np.ix_(a, a)]
                if np.linalg.cond(Maa) > 1e12:
                    continue
                lam[a] = np.linalg.solve(Maa, -q[a])
            w = M @ lam + q
            scale = np.abs(q).max() + np.abs(M).max() * np.abs(lam).max()
            if lam.min() >= -tol * scale and w.min() >= -tol * scale:
                return lam
    raise RuntimeError("LCP without solution")


def moreau_reference(A, B, C, D, E, F, u, x0, times, theta, mode_of_step=None):
    """θ-stepping on the given time grid.

    ``u(t)`` returns the input vector (p,). ``mode_of_step(k)`` may return per-step matrices
    ``(A, B, C, D, E, F)`` (switched systems). Returns states (N+1, n) and λ (N, m).
    """
    x = np.asarray(x0, dtype=float)
    xs = [x.copy()]
    lams = []
    for k in range(len(times) - 1):
        if mode_of_step is not None:
            A, B, C, D, E, F = mode_of_step(k)
        n = len(x)
        h = times[k + 1] - times[k]
        W = np.linalg.inv(np.eye(n) - h * theta * A)
        u0, u1 = np.asarray(u(times[k]), float), np.asarray(u(times[k + 1]), float)
        xfree = W @ ((np.eye(n) + h * (1 - theta) * A) @ x
                     + h * ((1 - theta) * E @ u0 + theta * E @ u1))
        M = D + h * C @ W @ B
        q = C @ xfree + F @ u1
        lam = brute_force_lcp(M, q)
        x = xfree + h * W @ B @ lam
        xs.append(x.copy())
        lams.append(lam)
    return np.array(xs), np.array(lams).reshape(len(times) - 1, -1)


def test_reference_matches_trapezoid_rule_without_pairs():
    # m = 0, θ = 1/2: the reference must reduce to the trapezoidal rule.
    A = np.array([[-1.0, 2.0], [-2.0, -0.5]])
    E = np.array([[1.0], [0.0]])
    z = np.zeros((2, 0))
    times = np.linspace(0.0, 1.0, 11)
    xs, _ = moreau_reference(A, z, z.T, np.zeros((0, 0)), E, np.zeros((0, 1)),
                             lambda t: np.array([np.cos(t)]), [1.0, 0.0], times, 0.5)
    x = np.array([1.0, 0.0])
    h = 0.1
    for k in range(10):
        t0, t1 = times[k], times[k + 1]
        rhs = x + h / 2 * (A @ x + E[:, 0] * np.cos(t0) + E[:, 0] * np.cos(t1))
        x = np.linalg.solve(np.eye(2) - h / 2 * A, rhs)
    np.testing.assert_allclose(xs[-1], x, rtol=0, atol=1e-14)


def test_reference_lcp():
    M = np.array([[2.0, 1.0], [0.0, 1.0]])
    lam = brute_force_lcp(M, np.array([-2.0, 1.0]))
    np.testing.assert_allclose(lam, [1.0, 0.0])
