"""Whether every θ step of a passive LCS mode has a unique next state, whatever λ it takes.

A step of length ``s`` (:mod:`lcs.integrators.moreau.dense.discretise`) solves the LCP
``w = M λ + q``, ``0 <= w ⊥ λ >= 0`` with ``M = D + C K``, ``K = s (I - sθA)^-1 B`` and moves the
state to ``x_free + K λ``. Its λ need not be unique (an ideal diode bridge whose four diodes
conduct: how the current splits between the legs is not determined), but for a passive mode
the next state is, as long as the step is not too long for θ < 1:

Let ``½ x'Px`` (``P = P' > 0``) be a storage function: the KYP matrix
``[[A'P + PA, PB - C'], [B'P - C, -(D + D')]]`` is negative semidefinite. For two solutions
λ1, λ2 write ``v = λ1 - λ2`` and ``δx = K v``, so that ``(I - sθA) δx = s B v``. The KYP
inequality at ``(δx, v)`` gives ``2 v'Cδx + v'(D + D')v >= δx'(A'P + PA)δx + 2 δx'PBv``, whose
left side is ``2 v'M v`` and whose last term is ``(2/s) δx'Pδx - θ δx'(A'P + PA)δx``; hence

    2 v'M v >= δx' Q_s δx,     Q_s = (2/s) P + (1 - θ)(A'P + PA).

Complementarity makes ``v'M v = (λ1 - λ2)'(w1 - w2) = -λ1'w2 - λ2'w1 <= 0``, so ``δx = 0``
whenever ``Q_s > 0``: every solution gives the same next state (Camlibel, Heemels &
Schumacher, "Consistency of a time-stepping method for a class of piecewise-linear
networks", IEEE TCAS-I 49, 2002, for θ = 1). ``Q_s`` only grows as ``s`` shrinks (``P > 0``),
so checking the longest step checks every shorter one. θ = 1 needs nothing more; for θ < 1 a
decay faster than about ``2 / ((1 - θ) s)`` in the metric of P breaks it (the 12-pulse
rectifier at θ = 1/2: its step LCP then has several next states for some q and no solution
for others).
"""

from __future__ import annotations

import numpy as np

from ..model import LCS
from .passivity import check_passivity

__all__ = ["STORAGE_RTOL", "longest_unique_step", "unique_next_state"]

#: Relative tolerance of the KYP test of the storage here: round-off only (a circuit of
#: positive R, L and C passes with margins of 1e-16), far tighter than ``pelcs lcs``'s 1e-7.
STORAGE_RTOL = 1e-9
# Q_s must stay this far (relative to 2/s) from singular.
_Q_MARGIN = 1e-9


def longest_unique_step(lcs: LCS, storage: np.ndarray, theta: float) -> float:
    """The longest θ step of ``lcs`` shown to have a unique next state (module docstring):
    ``inf`` when every step length is (θ = 1, or no decay in the metric of P), 0 when
    ``½ x' storage x`` is not verified to be a storage function of the mode (the verification
    only, no search: :func:`lcs.theory.passivity.check_passivity` with :data:`STORAGE_RTOL`).

    Parameters
    ----------
    lcs : LCS
        The mode.
    storage : ndarray (n, n)
        The candidate ``P`` (e.g. the circuit's stored-energy matrix: H on inductor
        currents, F on capacitor voltages).
    theta : float
        θ of the scheme, in [1/2, 1].

    Returns
    -------
    float
        s; steps up to it have ``Q_s = (2/s) P + (1 - θ)(A'P + PA)`` positive definite (to a
        relative margin of 1e-9).
    """
    n = lcs.n
    if n == 0:
        return np.inf  # (no state: nothing to differ)
    storage = np.asarray(storage, dtype=float)
    if storage.shape != (n, n) or not np.all(np.isfinite(storage)):
        return 0.0
    report = check_passivity(lcs, energy=storage, rtol=STORAGE_RTOL, search=False)
    if not report.passive:
        return 0.0
    if theta >= 1.0:
        return np.inf
    try:
        L = np.linalg.cholesky(report.K)
    except np.linalg.LinAlgError:
        return 0.0
    # In the coordinates z = L'x (P = L L'): Q_s -> (2/s) I + (1 - θ)(Â + Â'), Â = L' A L^-T.
    Li = np.linalg.inv(L)
    Ah = L.T @ np.asarray(lcs.A, dtype=float) @ Li.T
    lowest = float(np.linalg.eigvalsh(Ah + Ah.T)[0])
    if lowest >= 0.0:
        return np.inf
    return 2.0 * (1.0 - _Q_MARGIN) / ((1.0 - theta) * -lowest)


def unique_next_state(lcs: LCS, storage: np.ndarray, s_max: float, theta: float) -> bool:
    """Whether every θ step of ``lcs`` no longer than ``s_max`` (s) has a unique next state
    (:func:`longest_unique_step`). False when it cannot be shown: not a storage of this mode,
    or ``Q_s`` not positive definite (the next state may then still be unique)."""
    return bool(s_max <= longest_unique_step(lcs, storage, theta))
