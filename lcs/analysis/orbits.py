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

import warnings
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
# The stability of a point Newton did not converge to.
NOT_AN_ORBIT = "unknown: no orbit found (Newton did not converge)"


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
        """JSON-ready description (``multipliers`` as ``[re, im]`` pairs).

        An orbit Newton did not converge to is no orbit: its ``multipliers``,
        ``multiplier_moduli``, ``jacobian`` and ``stable`` are None and ``stability`` says
        why (the last iterate's Jacobian describes a point that is not periodic).
        """
        ok = self.converged
        return {
            "param_name": self.param_name,
            "param": self.param,
            "order": self.order,
            "states": list(self.state_names),
            "points": [[float(v) for v in p] for p in self.points],
            "multipliers": [[float(m.real), float(m.imag)] for m in self.multipliers]
            if ok else None,
            "multiplier_moduli": [float(abs(m)) for m in self.multipliers] if ok else None,
            "stability": self.stability if ok else NOT_AN_ORBIT,
            "stable": bool(self.stable) if ok else None,
            "converged": bool(self.converged),
            "residual": float(self.residual),
            "iterations": int(self.iterations),
            "jacobian": [[float(v) for v in row] for row in self.jacobian] if ok else None,
            "pattern": self.pattern.to_list() if self.pattern is not None else None,
            "pattern_text": str(self.pattern) if self.pattern is not None else None,
            "notes": list(self.notes),
        }


# Newton's damping: the smallest step fraction tried before the iteration is declared stalled.
_LAMBDA_MIN = 1.0 / 1024
# Periods of transient (times the order) simulated before each restart of a stalled Newton:
# the map is then iterated towards the attractor, whose switching pattern the orbit shares.
RESTARTS = (16, 64, 256, 1024)


@dataclass
class _Newton:
    """Newton shooting on ``G(x) = P^k(x) - x`` with a natural-level-function line search."""

    m: Map
    k: int
    nat: np.ndarray | None
    tol: float
    rel_step: float
    bound: float
    notes: list[str] = field(default_factory=list)
    iterations: int = 0

    def g(self, x: np.ndarray) -> np.ndarray:
        return self.m.power(x, self.k) - x

    @staticmethod
    def norm(v: np.ndarray, sc: np.ndarray) -> float:
        # (a state grown past float range gives an infinite norm, reported as such)
        with np.errstate(over="ignore"):
            return float(np.max(np.abs(v) / sc)) if v.size else 0.0

    def solve(self, x: np.ndarray, max_iter: int) -> tuple[np.ndarray, float, bool, bool]:
        """Iterate from ``x``: ``(x, scaled residual, converged, diverged)``.

        The step ``dx = -(DG)^-1 G(x)`` is damped by the natural monotonicity test
        (Deuflhard): a fraction ``lam`` is accepted when the simplified Newton correction at
        ``x + lam dx``, ``(DG(x))^-1 G(x + lam dx)``, is shorter than ``(1 - lam/4) |dx|``.
        The test measures the distance to the orbit in the state's own units whatever the
        multipliers: the residual's norm does not, since a multiplier near 1 (a large output
        capacitor, 0.9985) makes ``G`` tiny along its direction while the state is far from
        the orbit, and a step that fixes that direction may raise the residual of the fast
        ones.
        """
        from scipy.linalg import LinAlgWarning, lu_factor, lu_solve

        x = np.asarray(x, dtype=float).copy()
        sc = state_scale(x, self.nat)
        g = self.g(x)
        r = self.norm(g, sc)
        n = x.size
        eye = np.eye(n)
        for _ in range(max_iter):
            if r <= self.tol:
                return x, r, True, False
            self.iterations += 1
            A = self.m.jacobian(x, self.k, sc, self.rel_step) - eye
            with warnings.catch_warnings():  # a singular matrix is handled below
                warnings.simplefilter("ignore", LinAlgWarning)
                lu = lu_factor(A, check_finite=False)
            if not np.all(np.isfinite(lu[0])) or np.min(np.abs(np.diag(lu[0]))) <= \
                    1e-14 * max(float(np.max(np.abs(A))), 1e-300):
                self.notes.append("singular Newton matrix (a multiplier at +1: fold?)")

                def solve(b, A=A):
                    return np.linalg.lstsq(A, b, rcond=None)[0]
            else:
                def solve(b, lu=lu):
                    return lu_solve(lu, b, check_finite=False)
            dx = solve(-g)
            nd = self.norm(dx, sc)
            if not np.isfinite(nd):
                return x, r, False, False
            lam, accepted = 1.0, False
            while lam >= _LAMBDA_MIN:
                xt = x + lam * dx
                try:
                    gt = self.g(xt)
                except MapError:
                    lam *= 0.5
                    continue
                rt = self.norm(gt, sc)
                if rt <= self.tol:
                    accepted = True
                    break
                nbar = self.norm(solve(-gt), sc)
                if nbar <= (1.0 - 0.25 * lam) * nd:
                    accepted = True
                    break
                lam *= 0.5
            if not accepted:
                return x, r, False, False
            if float(np.max(np.abs(xt))) > self.bound:
                self.notes.append("Newton diverged (the state grew without bound)")
                return x, r, False, True
            x, g, r = xt, gt, rt
            sc = state_scale(x, self.nat)
            if r <= self.tol or (lam == 1.0 and nd <= self.tol and r <= 1e3 * self.tol):
                return x, r, True, False
        return x, r, r <= self.tol, False


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
    restarts: tuple[int, ...] = RESTARTS,
) -> PeriodicOrbit:
    """Period-``order`` orbit of ``m`` by Newton shooting from ``x0``.

    Newton's step is damped by the natural monotonicity test (see ``_Newton.solve``). From
    a guess whose switching pattern differs from the orbit's (a start-up state: the switch
    on all period, the diode off) the Jacobian describes another piece of the piecewise-smooth
    map and the damped steps can stall; Newton is then restarted from the guess iterated
    further by the map (``restarts`` more periods each time, a continuation from the
    transient), which brings it onto the attractor's pattern.

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
        Newton iterations per start.
    rel_step : float
        Central-difference step relative to the state scale.
    scale : array_like, optional
        State magnitudes (A, V); default from the guess and the map's natural scale.
    pattern : bool
        Also compute the switching pattern.
    restarts : tuple of int
        Iterates of ``P^k`` added to the guess before each restart of a stalled Newton
        (cumulative); ``()``: no restart.

    Returns
    -------
    PeriodicOrbit
        With ``converged`` False if Newton did not reach ``tol`` (the last iterate is
        returned; its multipliers are not an orbit's, and :meth:`PeriodicOrbit.to_dict`
        leaves them out).

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
    n = x.size
    # The residual is relative to the state: a map whose "fixed point" is at infinity (no
    # orbit) would look converged far out. Newton stops when the state grows this much.
    bound = 1e6 * max(1.0, float(np.max(np.abs(x))) if n else 1.0,
                      float(np.max(nat)) if nat is not None else 1.0)
    newton = _Newton(m, k, nat, float(tol), float(rel_step), bound)
    best = newton.solve(x, max_iter)
    xt, iterated = x, 0
    for extra in restarts:
        if best[2] or best[3]:
            break
        try:
            xt = m.power(xt, k * int(extra))
        except MapError:
            break
        iterated += int(extra)
        if float(np.max(np.abs(xt), initial=0.0)) > bound:
            newton.notes.append("the transient grew without bound (diverged)")
            break
        trial = newton.solve(xt, max_iter)
        if trial[2] or trial[1] < best[1]:
            best = trial
        if trial[2]:
            newton.notes.append(f"Newton converged from the guess iterated {iterated} more "
                                f"period(s) (it stalled from the guess itself)")
    x, r, converged = best[0], best[1], best[2]
    notes = list(dict.fromkeys(newton.notes))
    it = newton.iterations
    if not converged:
        notes.append(f"Newton did not converge in {it} iterations (scaled residual {r:.3g})"
                     + (f", restarted after up to {iterated} more periods of transient"
                        if iterated else ""))
    sc = state_scale(x, nat)
    J = m.jacobian(x, k, sc, rel_step)
    mu = np.linalg.eigvals(J) if n else np.empty(0, complex)
    mu = mu[np.argsort(-np.abs(mu), kind="stable")]
    pts = m.iterate(x, k - 1) if k > 1 else x[None, :].copy()
    pat = m.pattern(x, k) if pattern else None
    return PeriodicOrbit(points=pts, multipliers=mu, jacobian=J, state_names=m.state_names,
                         param=m.param, param_name=m.param_name, converged=bool(converged),
                         residual=r, iterations=it, pattern=pat, notes=notes)
