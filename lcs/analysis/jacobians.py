"""Finite-difference Jacobians of maps: central differences, and restricted to a section.

The maps of a time-stepping scheme are evaluated by simulation, so their Jacobians are taken
by differences: :func:`central_jacobian` for a map on the whole state space (stroboscopic
map), :func:`section_jacobian` for a map whose images lie on a Poincaré section (event map).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["central_jacobian", "section_jacobian"]


def central_jacobian(fn: Callable[[np.ndarray], np.ndarray], x: np.ndarray,
                     scale: np.ndarray, rel_step: float = 1e-5) -> np.ndarray:
    """Central finite-difference Jacobian of ``fn`` at ``x``.

    Parameters
    ----------
    fn : callable
        ``fn(x) -> y``, shapes (n,) -> (m,).
    x : ndarray, shape (n,)
    scale : ndarray, shape (n,)
        State scale; the step of column i is ``rel_step * scale[i]``.
    rel_step : float

    Returns
    -------
    ndarray, shape (m, n)
    """
    x = np.asarray(x, dtype=float)
    cols = []
    for i in range(x.size):
        d = rel_step * scale[i]
        xp, xm = x.copy(), x.copy()
        xp[i] += d
        xm[i] -= d
        cols.append((np.asarray(fn(xp)) - np.asarray(fn(xm))) / (2 * d))
    return np.stack(cols, axis=1) if cols else np.zeros((0, 0))


def section_jacobian(fk: Callable[[np.ndarray], np.ndarray], z: np.ndarray,
                     scale: np.ndarray, rel_step: float = 1e-5) -> np.ndarray:
    """Jacobian of a map whose images lie on a section Σ, restricted to Σ, extended by 0.

    Every image of ``fk`` lies on the section Σ (codimension 1), and a state on Σ sits on a
    switching surface when the section is a switching: ``fk`` is only piecewise smooth
    across Σ (the perturbed start is in one mode or the other), so central differences
    straddling Σ average two one-sided derivatives. Instead: the tangent space of Σ is
    estimated from the images of perturbed states (they lie on Σ), the central differences
    are taken along an orthonormal basis V of it (in scaled coordinates), and the result
    ``J_Σ = (DF V) V'`` has the Poincaré map's multipliers plus one exact 0.

    Parameters
    ----------
    fk : callable
        ``fk(z) -> z'``, shapes (n,) -> (n,).
    z : ndarray, shape (n,)
    scale : ndarray, shape (n,)
        State scale; steps are ``rel_step * scale``.
    rel_step : float

    Returns
    -------
    ndarray, shape (n, n)
    """
    z = np.asarray(z, dtype=float)
    scale = np.asarray(scale, dtype=float)
    n1 = z.size
    f0 = fk(z)
    # Tangent vectors of Σ near f0 (scaled): one-sided differences of the images.
    T = np.empty((n1, n1))
    for i in range(n1):
        e = np.zeros(n1)
        e[i] = rel_step * scale[i]
        T[:, i] = (fk(z + e) - f0) / scale / rel_step
    U, sv, _ = np.linalg.svd(T)
    V = U[:, : n1 - 1]  # the section has one dimension less than the extended state
    cols = []
    for j in range(n1 - 1):
        d = rel_step * scale * V[:, j]
        cols.append((fk(z + d) - fk(z - d)) / scale / (2 * rel_step))
    JV = np.stack(cols, axis=1)  # (n+1, n): D F applied to V, scaled coordinates
    Js = JV @ V.T
    return Js * scale[:, None] / scale[None, :]
