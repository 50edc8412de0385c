"""The sparse network behind one mode's LCS: what the sparse KKT stepping
(:mod:`lcs.integrators.moreau.sparse`) integrates instead of the LCS's dense matrices.

A circuit's LCS comes from a linear network solved once per mode: the formulation writes
``Y z = S ξ`` (``z`` node voltages and branch currents, ``ξ = (x, λ, u)``) and reads the state
derivatives and the pairs' ``w`` off ``z``::

    x' = Rx z = Rx Y⁻¹ S ξ        (A, B, E)
    w  = Rw z = Rw Y⁻¹ S ξ        (C, D, F)

``Y``, ``S``, ``Rx`` and ``Rw`` have a few entries a row, while ``A ... F`` are often dense
(a voltage multiplier's capacitor voltages all enter the diodes' w further up its ladder), so
a step solved with the network's factors costs a time proportional to the circuit's size
where the dense step's costs its square.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["NetworkRealisation"]


@dataclass(frozen=True)
class NetworkRealisation:
    """``x' = Rx Y⁻¹ S ξ``, ``w = Rw Y⁻¹ S ξ`` with ``ξ = (x, λ, u)``, every matrix sparse.

    Attributes
    ----------
    nz : int
        Network unknowns (node voltages, V, and branch currents, A).
    n, m, p : int
        States, pairs, inputs of the LCS.
    Y : tuple of ndarray
        ``(rows, cols, values)`` of the regular ``nz x nz`` network matrix (no duplicates).
        Its index ``i`` pairs row i with unknown i (a node's KCL with its voltage, a
        branch's equation with its current): the sparse factorisation prefers those pivots.
    S : tuple of ndarray
        ``(rows, cols, values)`` of the ``nz x (n + m + p)`` right-hand side over ``ξ``.
    Rx : tuple of ndarray
        ``(rows, cols, values)`` of the ``n x nz`` map to the state derivatives (1/F on a
        capacitor's current, the inverse inductance matrix on the inductors' voltages).
    Rw : tuple of ndarray
        ``(rows, cols, values)`` of the ``m x nz`` map to the pairs' ``w``.
    zero_w : tuple of int
        Pairs whose ``w`` vanishes identically in this mode (a diode shorted by closed
        switches, or in series with an open one): the LCS has zero rows there, and the
        stepping keeps their λ at 0.
    """

    nz: int
    n: int
    m: int
    p: int
    Y: tuple[np.ndarray, np.ndarray, np.ndarray]
    S: tuple[np.ndarray, np.ndarray, np.ndarray]
    Rx: tuple[np.ndarray, np.ndarray, np.ndarray]
    Rw: tuple[np.ndarray, np.ndarray, np.ndarray]
    zero_w: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        nxi = self.n + self.m + self.p
        for name, (rows, cols) in (("Y", (self.nz, self.nz)), ("S", (self.nz, nxi)),
                                   ("Rx", (self.n, self.nz)), ("Rw", (self.m, self.nz))):
            r, c, v = getattr(self, name)
            if not (len(r) == len(c) == len(v)):
                raise ValueError(f"{name}: rows, cols and values differ in length")
            if len(r) and (r.min() < 0 or r.max() >= rows or c.min() < 0 or c.max() >= cols):
                raise ValueError(f"{name}: an entry lies outside its {rows} x {cols} shape")

    @staticmethod
    def _dense(coo, shape) -> np.ndarray:
        out = np.zeros(shape)
        np.add.at(out, (coo[0], coo[1]), coo[2])
        return out

    def dense(self) -> tuple[np.ndarray, ...]:
        """``(A, B, C, D, E, F)`` by dense solves (for checks and small systems)."""
        n, m, nz = self.n, self.m, self.nz
        nxi = n + m + self.p
        Y = self._dense(self.Y, (nz, nz))
        S = self._dense(self.S, (nz, nxi))
        Z = np.linalg.solve(Y, S) if nz else np.zeros((0, nxi))
        dx = self._dense(self.Rx, (n, nz)) @ Z
        w = self._dense(self.Rw, (m, nz)) @ Z
        w[list(self.zero_w)] = 0.0
        return (dx[:, :n], dx[:, n:n + m], w[:, :n], w[:, n:n + m], dx[:, n + m:],
                w[:, n + m:])
