"""The linear dynamics of one mode of an LCS: a switch configuration and a set of pairs held
at ``w = 0``.

With the held set Z (``w_Z = 0``, ``λ_Z`` free) and the other pairs at ``λ = 0``::

    x' = A x + B_Z λ_Z + E u,      0 = C_Z x + D_ZZ λ_Z + F_Z u.

Where ``D_ZZ`` is singular (a diode in series with an inductor: ``w`` is a current that the
multiplier cannot move directly), the null directions of ``D_ZZ`` are state constraints
``N^T (C_Z x + F_Z u) = 0``, differentiated once along the dynamics (index reduction, as in
the GDCM reduced dynamics of :mod:`lcs.theory.gdcm`). The multipliers then come out affine in the
state, the inputs and the inputs' time derivatives::

    λ = Lx x + Lu u + Ld u',    x' = Af x + Ef u + Ed u',    w = Wx x + Wu u + Wd u'.

The inputs of a stretch are the output of a small linear generator (:class:`InputPiece`:
ramps of piecewise-linear sources, oscillators of SIN sources), so the flow over a stretch is
one matrix exponential of the augmented system (:func:`flow_matrix`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from ...model import LCS

__all__ = ["InputPiece", "ModeFlow", "ModeFlowError", "flow_matrix", "linear_piece",
           "mode_flow"]

# Singular values of D_ZZ below this (relative to the largest entry of D, and absolutely
# to round-off) are zero: such pairs are held by a state constraint.
_RANK_RTOL = 1e-10


class ModeFlowError(ValueError):
    """The held set does not define the multipliers (relative degree above one, or pairs
    that depend on each other)."""


@dataclass(frozen=True)
class ModeFlow:
    """Affine dynamics of one (switch configuration, held set) mode.

    Shapes: n states, m pairs, p inputs.

    Attributes
    ----------
    held : tuple of int
        Indices of the pairs held at w = 0 (Z).
    Af, Ef, Ed : ndarray (n, n), (n, p), (n, p)
        ``x' = Af x + Ef u + Ed u'``.
    Lx, Lu, Ld : ndarray (m, n), (m, p), (m, p)
        Every pair's λ (zero rows outside Z).
    Wx, Wu, Wd : ndarray (m, n), (m, p), (m, p)
        Every pair's w (zero rows in Z up to round-off).
    Kx, Ku : ndarray (c, n), (c, p)
        State constraints ``Kx x + Ku u = 0`` of the mode (c may be 0).
    """

    held: tuple[int, ...]
    Af: np.ndarray
    Ef: np.ndarray
    Ed: np.ndarray
    Lx: np.ndarray
    Lu: np.ndarray
    Ld: np.ndarray
    Wx: np.ndarray
    Wu: np.ndarray
    Wd: np.ndarray
    Kx: np.ndarray
    Ku: np.ndarray

    def affine(self, Cy: np.ndarray, Dy: np.ndarray, Fy: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Outputs ``Cy x + Dy λ + Fy u`` of the mode as ``(Yx, Yu, Yd)``: the coefficients of
        x, u and u' (shapes (q, n), (q, p), (q, p))."""
        return Cy + Dy @ self.Lx, Fy + Dy @ self.Lu, Dy @ self.Ld


def mode_flow(lcs: LCS, held) -> ModeFlow:
    """The dynamics of ``lcs`` with the pairs ``held`` at w = 0 and the others at λ = 0.

    Parameters
    ----------
    lcs : LCS
        One switch configuration.
    held : iterable of int
        Pair indices (Z).

    Returns
    -------
    ModeFlow

    Raises
    ------
    ModeFlowError
        If the multipliers of Z are not determined by the state, inputs and input rates.
    """
    Z = tuple(sorted(int(i) for i in held))
    A, B, C, D, E, F = lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, lcs.F
    n, m, p = lcs.n, lcs.m, lcs.p
    Lx, Lu, Ld = np.zeros((m, n)), np.zeros((m, p)), np.zeros((m, p))
    Kx, Ku = np.zeros((0, n)), np.zeros((0, p))
    if Z:
        z = list(Z)
        Dzz, Cz, Fz, Bz = D[np.ix_(z, z)], C[z], F[z], B[:, z]
        U, s, _ = np.linalg.svd(Dzz)
        scale = max(float(np.max(np.abs(D))) if D.size else 0.0, 1e-300)
        r = int(np.sum(s > _RANK_RTOL * scale))
        Ur, Un = U[:, :r], U[:, r:]
        # Rows: the regular part of w_Z = 0, then the derivative of its singular part.
        K = np.vstack([Ur.T @ Dzz, Un.T @ Cz @ Bz])
        rhs_x = np.vstack([Ur.T @ Cz, Un.T @ Cz @ A])
        rhs_u = np.vstack([Ur.T @ Fz, Un.T @ Cz @ E])
        rhs_d = np.vstack([np.zeros((r, p)), Un.T @ Fz])
        sv = np.linalg.svd(K, compute_uv=False)
        if sv.size and sv[-1] <= 1e-11 * max(sv[0], 1e-300):
            raise ModeFlowError(
                "the multipliers of the held pairs are not determined (relative degree above "
                "one, or pairs that depend on each other)")
        Kinv = np.linalg.inv(K)
        Lx[z] = -Kinv @ rhs_x
        Lu[z] = -Kinv @ rhs_u
        Ld[z] = -Kinv @ rhs_d
        Kx, Ku = Un.T @ Cz, Un.T @ Fz
    Af = A + B @ Lx
    Ef = E + B @ Lu
    Ed = B @ Ld
    Wx = C + D @ Lx
    Wu = F + D @ Lu
    Wd = D @ Ld
    return ModeFlow(Z, Af, Ef, Ed, Lx, Lu, Ld, Wx, Wu, Wd, Kx, Ku)


@dataclass(frozen=True)
class InputPiece:
    """The inputs on a stretch as the output of a linear generator: ``u(s) = U z(s)``,
    ``z' = M z``, ``z(0) = z0`` (s from the stretch's start).

    ``z = [1, s]`` carries the constant and the ramp of piecewise-linear sources; every
    SIN source adds a damped oscillator pair ``e^{-θs} (sin ωs, cos ωs)``. Shapes: U (p, q),
    M (q, q), z0 (q,); ``z[0] = 1`` always (the event functions' constants ride on it).
    """

    U: np.ndarray
    M: np.ndarray
    z0: np.ndarray

    @property
    def linear(self) -> bool:
        return self.U.shape[1] == 2

    def z(self, s: float) -> np.ndarray:
        if self.linear:
            return np.array([1.0, s])
        return expm(self.M * s) @ self.z0

    def u(self, s: float = 0.0) -> np.ndarray:
        """Inputs at s, shape (p,)."""
        return self.U @ self.z(s)

    def du(self, s: float = 0.0) -> np.ndarray:
        """Their rates, per second."""
        return self.U @ (self.M @ self.z(s))

    def d2u(self, s: float = 0.0) -> np.ndarray:
        return self.U @ (self.M @ (self.M @ self.z(s)))

    @property
    def omega(self) -> float:
        """Fastest oscillation of the inputs, rad/s (0 for piecewise-linear inputs)."""
        if self.linear:
            return 0.0
        return float(np.max(np.abs(self.M[2:, 2:]))) if self.M.shape[0] > 2 else 0.0


def linear_piece(u0: np.ndarray, u1: np.ndarray) -> InputPiece:
    """``u = u0 + u1 s``."""
    M = np.array([[0.0, 0.0], [1.0, 0.0]])
    return InputPiece(np.column_stack([u0, u1]), M, np.array([1.0, 0.0]))


def flow_matrix(flow: ModeFlow, piece: InputPiece) -> np.ndarray:
    """The generator ``G`` of ``[x; z]`` on a stretch whose inputs are ``piece``.

    ``[x(s); z(s)] = expm(G s) [x(0); piece.z0]``; shape (n + q, n + q). With ``u = U z``
    and ``u' = U M z``: ``x' = Af x + (Ef U + Ed U M) z``.
    """
    n = flow.Af.shape[0]
    q = piece.M.shape[0]
    G = np.zeros((n + q, n + q))
    G[:n, :n] = flow.Af
    G[:n, n:] = flow.Ef @ piece.U + flow.Ed @ (piece.U @ piece.M)
    G[n:, n:] = piece.M
    return G


def propagate(G: np.ndarray, z: np.ndarray, s: float) -> np.ndarray:
    """``expm(G s) z``."""
    return expm(G * s) @ z
