"""Linear complementarity problems: find ``z`` with ``w = M z + q``, ``0 <= w ⊥ z >= 0``.

One driver, :func:`solve_lcp`, with one options dataclass, :class:`LcpOptions`, and separate
solvers behind it (as Siconos/numerics separates its LCP solvers):

* ``"lemke"`` -- Lemke's complementary pivoting with covering vector ``d = 1`` and
  lexicographic degeneracy resolution (the ratio test compares the rows
  ``(B^-1 q, B^-1) / (B^-1 column)`` lexicographically, so the method cannot cycle). Ray
  termination means Lemke found no solution; for a copositive-plus ``M`` (P-matrices, positive
  semidefinite matrices: every passive circuit) it proves that none exists.
* ``"enumeration"`` -- the direct path: try every complementary basis (subsets of active
  indices, smallest first) and solve the reduced linear system. Exponential, meant for tiny m;
  it is also the definitive answer when Lemke ray-terminates on a matrix that is not
  copositive-plus.
* ``"auto"`` (default) -- Lemke, then enumeration to confirm a ray termination when
  ``m <= enum_max_m``.

:func:`lemke_nb` is the same Lemke algorithm compiled with numba, callable from inside a numba
time-stepping loop without allocating (the caller passes the work arrays).

Modules: :mod:`.problem` (options, results, status codes), :mod:`.lemke`, :mod:`.enumeration`,
:mod:`.driver` (:func:`solve_lcp`, :func:`is_p_matrix`) and :mod:`.compiled` (the LCP of a
time step inside compiled integration loops: cached active sets, then Lemke, then
enumeration, behind one interface).
"""

from .driver import is_p_matrix, solve_lcp
from .enumeration import enumerate_lcp
from .lemke import lemke, lemke_nb, solve_lcp_nb
from .problem import (
    LEMKE_MAX_PIVOTS,
    LEMKE_RAY,
    LEMKE_SOLVED,
    LEMKE_TRIVIAL,
    LcpOptions,
    LcpResult,
)

__all__ = [
    "LEMKE_MAX_PIVOTS",
    "LEMKE_RAY",
    "LEMKE_SOLVED",
    "LEMKE_TRIVIAL",
    "LcpOptions",
    "LcpResult",
    "enumerate_lcp",
    "is_p_matrix",
    "lemke",
    "lemke_nb",
    "solve_lcp",
    "solve_lcp_nb",
]
