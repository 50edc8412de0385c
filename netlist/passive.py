"""Passivity by construction: circuits whose every switch mode is passive with no computation.

A network of positive resistors, inductors (with a positive definite inductance matrix, K
couplings included) and capacitors, ideal diodes and ideal switches, driven by independent
sources, is a linear passive network in every switch configuration (Camlibel, Heemels &
Schumacher, "On linear passive complementarity systems", 2002): its stored energy is a storage
function of each mode's LCS. The numerical screen (:func:`lcs.theory.screening.screen_modes`) is for
the other circuits.
"""

from __future__ import annotations

import numpy as np

from .circuit import Circuit

__all__ = ["structurally_passive"]

#: element kinds of a network that is passive in every switch mode when its R, L and C are
#: positive and its inductance matrix is positive definite
_PASSIVE_KINDS = frozenset("RLCKVIDS")


def structurally_passive(circuit: Circuit, energy: np.ndarray) -> bool:
    """Whether every switch mode of the circuit is passive by construction (module
    docstring): its stored energy ``½ x' K x`` (:func:`netlist.formulation.storage_matrix`)
    is then a storage function of each mode's LCS, whose port is the diodes'. Controlled
    sources and non-positive values can break passivity: those circuits get False.

    Parameters
    ----------
    circuit : Circuit
        Flattened (no subcircuit instances).
    energy : ndarray (n, n)
        :func:`~netlist.formulation.storage_matrix` of the circuit.
    """
    for el in circuit.elements:
        if el.kind not in _PASSIVE_KINDS:
            return False
        if el.kind in "RLC" and not float(el.value) > 0.0:
            return False
    if circuit.of_kind("K"):
        try:
            np.linalg.cholesky(energy)
        except np.linalg.LinAlgError:
            return False
    return True
