"""Options, results and status codes shared by the LCP solvers of :mod:`lcs.lcp`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Status codes shared by the Python and numba Lemke implementations.
LEMKE_SOLVED = 0
LEMKE_RAY = 1
LEMKE_MAX_PIVOTS = 2
LEMKE_TRIVIAL = 3  # q >= 0: z = 0 without pivoting

_STATUS_NAMES = {
    LEMKE_SOLVED: "solved",
    LEMKE_RAY: "ray_termination",
    LEMKE_MAX_PIVOTS: "max_pivots",
    LEMKE_TRIVIAL: "trivial",
}


@dataclass(frozen=True)
class LcpOptions:
    """Options of :func:`solve_lcp`.

    Parameters
    ----------
    method : str
        ``"auto"``, ``"lemke"`` or ``"enumeration"``.
    max_pivots : int or None
        Pivot budget of Lemke; ``None`` means ``max(50, 10 * m)``.
    pivot_tol : float
        A tableau entry counts as a positive pivot candidate when it exceeds ``pivot_tol``
        times the largest magnitude of the entering column (relative, so it is unit-free).
    lex_tol : float
        Relative tolerance under which two ratios are considered tied in the lexicographic
        ratio test (then the next component decides).
    feas_tol : float
        Relative tolerance of the feasibility/complementarity checks made by the enumeration
        solver and by :meth:`LcpResult` validation: ``z_i >= -feas_tol * scale``.
    enum_max_m : int
        ``"auto"`` confirms a Lemke ray termination by enumeration up to this size.
    """

    method: str = "auto"
    max_pivots: int | None = None
    pivot_tol: float = 1e-13
    lex_tol: float = 1e-12
    feas_tol: float = 1e-9
    enum_max_m: int = 10

    def pivots_for(self, m: int) -> int:
        return int(self.max_pivots) if self.max_pivots is not None else max(50, 10 * m)


@dataclass
class LcpResult:
    """Solution of an LCP.

    Attributes
    ----------
    z, w : ndarray, shape (m,)
        The complementary pair (``w = M z + q``). Undefined (zeros) when ``ok`` is False.
    ok : bool
        True when a solution was found.
    status : str
        ``"trivial"`` (q >= 0), ``"solved"``, ``"ray_termination"`` (Lemke found no
        solution), ``"no_solution"`` (enumeration proved that none exists), ``"max_pivots"``.
    pivots : int
        Lemke pivots performed (0 for the enumeration solver).
    method : str
        Which solver produced the answer.
    basis : ndarray of bool, shape (m,)
        ``basis[i]`` is True when ``z_i`` is basic (the active set of the final complementary
        basis; ``M[basis][:, basis]`` is nonsingular).
    """

    z: np.ndarray
    w: np.ndarray
    ok: bool
    status: str
    pivots: int = 0
    method: str = "lemke"
    basis: np.ndarray | None = None

