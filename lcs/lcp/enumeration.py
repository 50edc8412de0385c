"""The direct path: try every complementary basis (exponential in m, meant for tiny m).

It is also the definitive answer when Lemke ray-terminates on a matrix that is not
copositive-plus.
"""

from __future__ import annotations

import itertools

import numpy as np

from .problem import LcpOptions, LcpResult


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
