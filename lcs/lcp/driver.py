"""The LCP driver: one entry, :func:`solve_lcp`, over the solvers of this package."""

from __future__ import annotations

import itertools

import numpy as np

from .enumeration import enumerate_lcp
from .lemke import lemke
from .problem import LcpOptions, LcpResult


def solve_lcp(M: np.ndarray, q: np.ndarray, options: LcpOptions | None = None) -> LcpResult:
    """Solve ``w = M z + q, 0 <= w ⊥ z >= 0``.

    Parameters
    ----------
    M : array_like, shape (m, m)
    q : array_like, shape (m,)
    options : LcpOptions, optional
        ``method`` selects the solver (see the module docstring).

    Returns
    -------
    LcpResult
        Check ``ok``; ``status`` says why not.
    """
    opts = options or LcpOptions()
    M = np.asarray(M, dtype=float)
    q = np.asarray(q, dtype=float).ravel()
    m = q.size
    if M.shape != (m, m):
        raise ValueError(f"M must be ({m}, {m}) for q of size {m}, got {M.shape}")
    if not (np.all(np.isfinite(M)) and np.all(np.isfinite(q))):
        raise ValueError("LCP data contain NaN or infinity")
    if opts.method == "enumeration":
        return enumerate_lcp(M, q, opts)
    if opts.method not in ("auto", "lemke"):
        raise ValueError(f"unknown LCP method {opts.method!r}")
    res = lemke(M, q, opts)
    if res.ok or opts.method == "lemke" or m > opts.enum_max_m:
        return res
    # Lemke may stop on a ray for matrices that are not copositive-plus although a solution
    # exists; for small m enumeration settles it.
    alt = enumerate_lcp(M, q, opts)
    alt.pivots = res.pivots
    if not alt.ok:
        alt.status = "no_solution"
    return alt


def is_p_matrix(M: np.ndarray, max_m: int = 12) -> bool | None:
    """Whether every principal minor of ``M`` is positive (then the LCP has a unique solution
    for every q). Returns None when ``m > max_m`` (not checked: 2^m minors)."""
    M = np.asarray(M, dtype=float)
    m = M.shape[0]
    if m > max_m:
        return None
    scale = max(1.0, np.abs(M).max()) if m else 1.0
    for k in range(1, m + 1):
        for idx in itertools.combinations(range(m), k):
            if np.linalg.det(M[np.ix_(idx, idx)]) <= 1e-12 * scale**k:
                return False
    return True
