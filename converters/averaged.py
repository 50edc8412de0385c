"""State-space averaged models and ripple formulas of the open-loop PWM converters in CCM.

Independent references for the simulated converters of :mod:`converters.factories`: the
equations below are written by hand from the circuits (not taken from pelcs's formulation),
in the factories' sign conventions and state order, so that a disagreement points at a bug
in one of the two.

Averaged model (Erickson & Maksimović, *Fundamentals of Power Electronics*, 2nd ed., ch. 7):
in CCM every period has the switch on for D T (the diode blocks) and off for (1-D) T (the
diode conducts), each interval linear, ``x' = A_on x + b_on vin`` and ``x' = A_off x + b_off
vin``; averaging over a period gives ``x' = (D A_on + (1-D) A_off) x + (D b_on + (1-D) b_off)
vin``, accurate when the state moves little within one period (small-ripple approximation).

- buck (i(L1) sw->out, v(out)): ``L i' = D vin - v``, ``C v' = i - v/R``;
- boost (i(L1) in->sw, v(out)): ``L i' = vin - (1-D) v``, ``C v' = (1-D) i - v/R``;
- buck-boost (i(L1) sw->0, v(out) < 0): ``L i' = D vin + (1-D) v``,
  ``C v' = -(1-D) i - v/R``;
- Čuk (i(L1) in->a, v(C1) = v(a,b), i(L2) b->out, v(C2) = v(out)):
  ``L1 i1' = vin - (1-D) v1``, ``C1 v1' = (1-D) i1 + D i2``, ``L2 i2' = -D v1 - v2``,
  ``C2 v2' = i2 - v2/R``.

Derivation of the buck-boost and Čuk rows (the others are textbook): buck-boost, switch on:
L sees vin, C feeds R alone; off: the diode connects out to sw, so L sees v(out) and its
current leaves the output node (C v' = -i - v/R). Čuk, switch on (a grounded): L1 sees vin,
v(b) = -v(C1), so L2 sees -v1 - v2 and C1 carries i2 (a -> b); off (b grounded by D1): L1 sees
vin - v1, L2 sees -v2, C1 carries i1.

Ripple formulas (peak to peak, CCM, Erickson ch. 2) are in :func:`ripple`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from converters.design import _check_topology

__all__ = ["AveragedModel", "averaged_model", "ripple", "effective_k", "small_signal_model"]


@dataclass(frozen=True)
class AveragedModel:
    """Linear averaged model ``x' = A x + b vin`` in CCM.

    Attributes
    ----------
    states : tuple of str
        pelcs state names, in the factories' order.
    A : ndarray (n, n)
        Averaged state matrix, 1/s.
    b : ndarray (n,)
        Input vector (per volt of vin), A/(V s) or V/(V s).
    vin : float
        Input voltage, V.
    """

    states: tuple[str, ...]
    A: np.ndarray
    b: np.ndarray
    vin: float

    def equilibrium(self) -> np.ndarray:
        """The averaged steady state ``-A⁻¹ b vin`` (A, V)."""
        return -np.linalg.solve(self.A, self.b * self.vin)

    def response(self, t, x0=None) -> np.ndarray:
        """Exact solution of the averaged model from ``x0`` (default zero).

        Parameters
        ----------
        t : array_like (N,)
            Times (s), from 0.
        x0 : array_like (n,), optional
            State at t = 0.

        Returns
        -------
        ndarray (N, n)
            ``x(t) = xe + expm(A t) (x0 - xe)``.
        """
        t = np.asarray(t, dtype=float)
        xe = self.equilibrium()
        d = (np.zeros_like(xe) if x0 is None else np.asarray(x0, dtype=float)) - xe
        # Eigen-decomposition once, instead of one expm per sample; A is diagonalisable for
        # these RLC networks (distinct eigenvalues), checked against expm at the end point.
        lam, V = np.linalg.eig(self.A)
        c = np.linalg.solve(V, d)
        x = (np.exp(np.outer(t, lam)) * c) @ V.T
        x = xe + x.real
        if t.size:
            ref = xe + expm(self.A * t[-1]) @ d
            if not np.allclose(x[-1], ref, rtol=1e-6, atol=1e-9 * (1 + np.abs(ref).max())):
                raise RuntimeError("eigen-decomposition of the averaged model is inaccurate")
        return x


def averaged_model(topology: str, vin: float, duty: float, rload: float, *,
                   lind: float | None = None, cout: float | None = None,
                   l1: float | None = None, c1: float | None = None,
                   l2: float | None = None, c2: float | None = None) -> AveragedModel:
    """The CCM averaged model of a factory converter (keyword names as in the factories).

    Parameters
    ----------
    topology : str
        ``"buck"``, ``"boost"``, ``"buck-boost"`` or ``"cuk"``.
    vin, duty, rload : float
        Input voltage (V), duty cycle, load (Ω).
    lind, cout : float
        Inductor (H) and capacitor (F) of buck, boost, buck-boost.
    l1, c1, l2, c2 : float
        Čuk: input inductor, transfer capacitor, output inductor, output capacitor.

    Returns
    -------
    AveragedModel
    """
    t = _check_topology(topology)
    D, R = duty, rload
    if t == "cuk":
        A = np.array([
            [0.0, -(1 - D) / l1, 0.0, 0.0],
            [(1 - D) / c1, 0.0, D / c1, 0.0],
            [0.0, -D / l2, 0.0, -1 / l2],
            [0.0, 0.0, 1 / c2, -1 / (R * c2)],
        ])
        b = np.array([1 / l1, 0.0, 0.0, 0.0])
        return AveragedModel(("i(L1)", "v(C1)", "i(L2)", "v(C2)"), A, b, vin)
    L, C = lind, cout
    if t == "buck":
        A = np.array([[0.0, -1 / L], [1 / C, -1 / (R * C)]])
        b = np.array([D / L, 0.0])
    elif t == "boost":
        A = np.array([[0.0, -(1 - D) / L], [(1 - D) / C, -1 / (R * C)]])
        b = np.array([1 / L, 0.0])
    else:  # buck-boost
        A = np.array([[0.0, (1 - D) / L], [-(1 - D) / C, -1 / (R * C)]])
        b = np.array([D / L, 0.0])
    return AveragedModel(("i(L1)", "v(C1)"), A, b, vin)


def effective_k(topology: str, duty: float, fs: float, rload: float, *,
                lind: float | None = None, l1: float | None = None,
                l2: float | None = None, **_) -> float:
    """Erickson's K = 2 L_e/(R T) (Čuk: L_e = L1 L2/(L1 + L2)); other keywords ignored."""
    t = _check_topology(topology)
    L = l1 * l2 / (l1 + l2) if t == "cuk" else lind
    return 2.0 * L * fs / rload


def ripple(topology: str, vin: float, duty: float, fs: float, rload: float, *,
           lind: float | None = None, cout: float | None = None,
           l1: float | None = None, c1: float | None = None,
           l2: float | None = None, c2: float | None = None, **_) -> dict[str, float]:
    """Peak-to-peak CCM ripples of the states (Erickson ch. 2, small-ripple approximation).

    Parameters
    ----------
    topology, vin, duty, fs, rload, lind, cout, l1, c1, l2, c2
        As in the factories (V, Hz, Ω, H, F); other keywords are ignored.

    Returns
    -------
    dict
        State name -> ripple (A or V). The formulas, with V = |v(out)| = |M| vin and T = 1/fs:

        - buck: Δi = (vin - V) D T/L (on-interval slope); Δv = Δi T/(8 C) (the triangular
          ripple current charges C for half a period, area Δi T/8);
        - boost: Δi = vin D T/L (exact: L sees vin while on); Δv = V D T/(R C) (C alone feeds
          the load current V/R while on);
        - buck-boost: Δi = vin D T/L (exact); Δv = V D T/(R C);
        - Čuk: Δi1 = vin D T/L1 and Δi2 = vin D T/L2 (both inductors see ±vin while on,
          exact when v(C1) + v(out) = vin); Δv(C1) = I1 (1-D) T/C1 with I1 = V²/(R vin)
          (C1 carries i1 while off); Δv(C2) = Δi2 T/(8 C2).
    """
    t = _check_topology(topology)
    D, T, R = duty, 1.0 / fs, rload
    if t == "buck":
        V = D * vin
        di = (vin - V) * D * T / lind
        return {"i(L1)": di, "v(C1)": di * T / (8 * cout)}
    if t in ("boost", "buck-boost"):
        V = vin / (1 - D) if t == "boost" else vin * D / (1 - D)
        return {"i(L1)": vin * D * T / lind, "v(C1)": V * D * T / (R * cout)}
    V = vin * D / (1 - D)
    I1 = V * V / (R * vin)
    di2 = vin * D * T / l2
    return {"i(L1)": vin * D * T / l1, "v(C1)": I1 * (1 - D) * T / c1, "i(L2)": di2,
            "v(C2)": di2 * T / (8 * c2)}



def small_signal_model(topology: str, vin: float, duty: float, rload: float, **elements):
    """The averaged model linearised at its equilibrium, as a python-control ``StateSpace``.

    The averaged matrices are affine in the duty D (``A = D A_on + (1-D) A_off``), so the
    derivative in D is ``A(1) - A(0)`` exactly: ``δx' = A δx + (A_D x_e + b_D vin) δd +
    b δvin``.

    Parameters
    ----------
    topology, vin, duty, rload, **elements
        As :func:`averaged_model` (``lind``, ``cout`` or the Čuk's ``l1 c1 l2 c2``).

    Returns
    -------
    control.StateSpace
        Inputs ``("d", "vin")`` (duty, per unit; input voltage, V), outputs the states
        (``i(L1)``, ``v(C1)``, ...), continuous time.
    """
    import control

    model = averaged_model(topology, vin, duty, rload, **elements)
    at1 = averaged_model(topology, vin, 1.0, rload, **elements)
    at0 = averaged_model(topology, vin, 0.0, rload, **elements)
    xe = model.equilibrium()
    bd = (at1.A - at0.A) @ xe + (at1.b - at0.b) * vin
    B = np.column_stack([bd, model.b])
    n = len(model.states)
    return control.ss(model.A, B, np.eye(n), np.zeros((n, 2)), inputs=["d", "vin"],
                      outputs=list(model.states), states=list(model.states))
