"""Periodic orbits of maps: Newton shooting, Floquet multipliers, classification.

A period-k orbit of a map P is a fixed point of ``P^k``: ``G(x) = P^k(x) - x = 0``. It is found
by Newton's method with the Jacobian ``DP^k`` from central finite differences (each column
costs two k-period simulations). The eigenvalues of ``DP^k`` at the orbit are its Floquet
(characteristic) multipliers; the orbit is stable when they all lie inside the unit circle,
and loses stability through a multiplier crossing

* -1: period doubling ("flip"),
* +1: saddle-node / fold ("fold"),
* the unit circle as a complex pair: Neimark-Sacker ("neimark-sacker").

Finite differences of a piecewise-smooth map are exact enough when the orbit's switching
instants move smoothly with the state (transversal crossings, no grazing): the central
difference step is small relative to the state scale (default 1e-5), and a switching
instant located inside the time step keeps the numerical map differentiable. For a
source-driven PWM converter in continuous conduction the discrete map is affine and the
differences are exact up to round-off.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .maps import Map, MapError, SwitchingPattern, central_jacobian

__all__ = [
    "PeriodicOrbit",
    "classify_multipliers",
    "find_orbit",
    "jacobian",
    "multiplier_counts",
    "state_scale",
]

# |Im μ| below this (relative to max(1, |μ|)) counts as a real multiplier: eigenvalues of a
# finite-difference Jacobian carry ~1e-8 noise, and a genuinely complex pair close to the
# real axis is about to become real anyway.
REAL_TOL = 1e-7
# Multipliers within this distance of the unit circle are reported as critical.
CRITICAL_TOL = 1e-6


def state_scale(x: np.ndarray, scale: np.ndarray | None = None, floor: float = 1e-3
                ) -> np.ndarray:
    """Typical magnitude of each state, shape (n,), for steps and tolerances.

    ``max(|x_i|, floor * max|x|, given scale_i, 1e-9)``: states near zero get a step relative to
    the largest state rather than to themselves.
    """
    x = np.asarray(x, dtype=float)
    s = np.maximum(np.abs(x), floor * float(np.max(np.abs(x))) if x.size else 0.0)
    if scale is not None:
        s = np.maximum(s, np.asarray(scale, dtype=float))
    return np.maximum(s, 1e-9)


def jacobian(fn, x: np.ndarray, scale: np.ndarray, rel_step: float = 1e-5) -> np.ndarray:
    """Central finite-difference Jacobian of ``fn`` at ``x`` (see
    :func:`~.maps.central_jacobian`), shape (m, n)."""
    return central_jacobian(fn, x, scale, rel_step)


def _is_real(mu: complex) -> bool:
    return abs(mu.imag) <= REAL_TOL * max(1.0, abs(mu))


def multiplier_counts(multipliers) -> dict[str, int]:
    """How many multipliers lie outside the unit circle, by the way they left it.

    Returns
    -------
    dict
        ``{"flip": real μ < -1, "fold": real μ > 1, "neimark-sacker": complex |μ| > 1}``.
        A change of one count between two parameter values brackets that bifurcation.
    """
    out = {"flip": 0, "fold": 0, "neimark-sacker": 0}
    for mu in np.asarray(multipliers, dtype=complex):
        if _is_real(mu):
            if mu.real < -1:
                out["flip"] += 1
            elif mu.real > 1:
                out["fold"] += 1
        elif abs(mu) > 1:
            out["neimark-sacker"] += 1
    return out


def classify_multipliers(multipliers) -> str:
    """``"stable"``, ``"critical"`` (a multiplier on the unit circle within 1e-6) or
    ``"unstable (flip, fold, neimark-sacker)"`` listing how multipliers left the circle."""
    mu = np.asarray(multipliers, dtype=complex)
    if mu.size == 0:
        return "stable"
    r = np.abs(mu)
    if np.all(r < 1 - CRITICAL_TOL):
        return "stable"
    counts = multiplier_counts(mu)
    kinds = [k for k, v in counts.items() if v]
    if not kinds:
        return "critical"
    return f"unstable ({', '.join(kinds)})"


@dataclass
class PeriodicOrbit:
    """A period-k orbit of a map and its stability.

    Attributes
    ----------
    points : ndarray, shape (k, n)
        ``x, P(x), ..., P^{k-1}(x)`` (units of the states).
    multipliers : ndarray of complex, shape (n,)
        Eigenvalues of ``DP^k(points[0])``, sorted by decreasing modulus.
    jacobian : ndarray, shape (n, n)
        ``DP^k`` at ``points[0]`` (finite differences).
    state_names : tuple[str, ...]
    param, param_name : optional
        Parameter of the map.
    converged : bool
        Newton reached the tolerance.
    residual : float
        ``max_i |P^k(x)_i - x_i| / scale_i`` at ``points[0]``.
    iterations : int
        Newton iterations.
    pattern : SwitchingPattern or None
        Switch/diode configurations over the k periods.
    """

    points: np.ndarray
    multipliers: np.ndarray
    jacobian: np.ndarray
    state_names: tuple[str, ...]
    param: float | None = None
    param_name: str | None = None
    converged: bool = True
    residual: float = 0.0
    iterations: int = 0
    pattern: SwitchingPattern | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def order(self) -> int:
        return int(self.points.shape[0])

    @property
    def x(self) -> np.ndarray:
        """The orbit's first point, shape (n,)."""
        return self.points[0]

    @property
    def spectral_radius(self) -> float:
        return float(np.max(np.abs(self.multipliers))) if self.multipliers.size else 0.0

    @property
    def stable(self) -> bool:
        return self.spectral_radius < 1.0

    @property
    def stability(self) -> str:
        return classify_multipliers(self.multipliers)

    def to_dict(self) -> dict:
        """JSON-ready description (``multipliers`` as ``[re, im]`` pairs)."""
        return {
            "param_name": self.param_name,
            "param": self.param,
            "order": self.order,
            "states": list(self.state_names),
            "points": [[float(v) for v in p] for p in self.points],
            "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers],
            "multiplier_moduli": [float(abs(m)) for m in self.multipliers],
            "stability": self.stability,
            "stable": bool(self.stable),
            "converged": bool(self.converged),
            "residual": float(self.residual),
            "iterations": int(self.iterations),
            "jacobian": [[float(v) for v in row] for row in self.jacobian],
            "pattern": self.pattern.to_list() if self.pattern is not None else None,
            "pattern_text": str(self.pattern) if self.pattern is not None else None,
            "notes": list(self.notes),
        }


def find_orbit(
    m: Map,
    x0,
    order: int = 1,
    *,
    transient: int = 0,
    tol: float = 1e-10,
    max_iter: int = 40,
    rel_step: float = 1e-5,
    scale=None,
    pattern: bool = True,
) -> PeriodicOrbit:
    """Period-``order`` orbit of ``m`` by Newton shooting from ``x0``.

    Parameters
    ----------
    m : Map
    x0 : array_like, shape (n,)
        Initial guess (e.g. the previous orbit in a continuation, or a state after a
        transient).
    order : int
        k: the orbit is a fixed point of ``P^k``.
    transient : int
        Iterate ``P^k`` this many times before Newton (to land near an attractor).
    tol : float
        Convergence when the scaled residual ``max |P^k(x) - x| / scale`` or the scaled
        Newton step is below ``tol``.
    max_iter : int
    rel_step : float
        Central-difference step relative to the state scale.
    scale : array_like, optional
        State magnitudes (A, V); default from the guess and the map's natural scale.
    pattern : bool
        Also compute the switching pattern.

    Returns
    -------
    PeriodicOrbit
        With ``converged`` False if Newton did not reach ``tol`` (the last iterate is
        returned, with its multipliers).

    Raises
    ------
    MapError
        The map could not be evaluated at the guess.
    """
    k = int(order)
    if k < 1:
        raise ValueError(f"order must be >= 1, got {order}")
    x = np.asarray(x0, dtype=float).copy()
    if transient:
        x = m.power(x, k * int(transient))
    nat = m.natural_scale() if scale is None else np.asarray(scale, dtype=float)
    sc = state_scale(x, nat)

    def pk(v):
        return m.power(v, k)

    def resid(g):
        # (a state that has grown past float range gives an infinite residual, reported as
        # such, not a numpy warning)
        with np.errstate(over="ignore"):
            return float(np.max(np.abs(g) / sc)) if g.size else 0.0

    g = pk(x) - x
    r = resid(g)
    n = x.size
    # The residual is relative to the state: a map whose "fixed point" is at infinity (no
    # orbit) would look converged far out. Newton stops when the state grows this much.
    bound = 1e6 * max(1.0, float(np.max(np.abs(x))) if n else 1.0,
                      float(np.max(nat)) if nat is not None else 1.0)
    eye = np.eye(n)
    it = 0
    converged = r <= tol
    notes: list[str] = []
    while not converged and it < max_iter:
        it += 1
        J = m.jacobian(x, k, sc, rel_step)
        try:
            dx = np.linalg.solve(J - eye, -g)
        except np.linalg.LinAlgError:
            dx = np.linalg.lstsq(J - eye, -g, rcond=None)[0]
            notes.append("singular Newton matrix (a multiplier at +1: fold?)")
        # Damped step: halve until the residual decreases (or the map fails less).
        lam = 1.0
        accepted = False
        for _ in range(12):
            xt = x + lam * dx
            try:
                gt = pk(xt) - xt
            except MapError:
                lam *= 0.5
                continue
            rt = resid(gt)
            if rt < r or lam < 1e-3:
                accepted = True
                break
            lam *= 0.5
        if not accepted:
            break
        step = float(np.max(np.abs(lam * dx) / sc))
        if float(np.max(np.abs(xt))) > bound:
            notes.append("Newton diverged (the state grew without bound)")
            break
        x, g, r = xt, gt, rt
        sc = state_scale(x, nat)
        converged = r <= tol or (step <= tol and r <= 1e3 * tol)
    if not converged:
        notes.append(f"Newton did not converge in {it} iterations (scaled residual {r:.3g})")
    J = m.jacobian(x, k, sc, rel_step)
    mu = np.linalg.eigvals(J) if n else np.empty(0, complex)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    pts = m.iterate(x, k - 1) if k > 1 else x[None, :].copy()
    pat = m.pattern(x, k) if pattern else None
    return PeriodicOrbit(points=pts, multipliers=mu, jacobian=J, state_names=m.state_names,
                         param=m.param, param_name=m.param_name, converged=bool(converged),
                         residual=r, iterations=it, pattern=pat, notes=notes)
