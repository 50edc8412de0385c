"""The DC operating point of a run's initial mode, found on the system itself or on an
auxiliary one and read back into the run's states.

The auxiliary system is the run's with some constraints added for the operating point only
(a circuit whose ``.ic`` nodes sources hold during it, as ngspice's ``.tran`` without ``UIC``
does): the same switches and diodes, its own states and inputs. Its operating point
(:func:`lcs.theory.operating_point.dc_point`) gives the run's states through its output
rows: ``x = Cy x_a + Dy λ_a + Fy u_a``, then the run goes on with the constraints released.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..lcp import LcpOptions
from ..model import TERMINALS_OPTION, ModeKey
from ..theory.operating_point import DcPoint, dc_point
from .problem import Problem
from .switches import switch_option

__all__ = ["AuxiliaryPoint", "mode_point", "switch_leaks"]


def mode_point(problem: Problem, mode: ModeKey, u0: np.ndarray, x0: np.ndarray,
               lcp: LcpOptions) -> DcPoint:
    """The operating point of ``mode`` of ``problem``'s system, its open switches' leaks
    choosing where the DC equations leave a choice (:func:`switch_leaks`)."""
    return dc_point(*problem.mode_arrays(mode), u0, x0, lcp, leaks=switch_leaks(problem, mode),
                    offsets=getattr(problem.system, "offsets", None))


@dataclass(eq=False)
class AuxiliaryPoint:
    """The operating point of a run taken from an auxiliary system's (module docstring).

    Attributes
    ----------
    problem : Problem
        The auxiliary system's, with the run's switches and diodes in the run's order.
    inputs : ndarray of int, shape (p_a,)
        For each auxiliary input, the index of the run's input it is, or -1.
    values : ndarray, shape (p_a,)
        The auxiliary inputs' values where ``inputs`` is -1 (V or A).
    states : ndarray of int, shape (n_a,)
        For each auxiliary state, the index of the run's state of the same name, or -1: the
        given values of the states no DC equation sets (else zero).
    probes : tuple of str
        The run's states, in the run's order, as outputs of the auxiliary system.
    """

    problem: Problem
    inputs: np.ndarray
    values: np.ndarray
    states: np.ndarray
    probes: tuple[str, ...]

    def __call__(self, mode: ModeKey, u0: np.ndarray, x0: np.ndarray, lcp: LcpOptions
                 ) -> DcPoint:
        """The run's operating point in ``mode``: the run's state, multipliers and free
        states (those that read a state the auxiliary DC equations leave free)."""
        u0, x0 = np.asarray(u0, dtype=float), np.asarray(x0, dtype=float)
        u = np.where(self.inputs >= 0, u0[np.maximum(self.inputs, 0)] if u0.size else 0.0,
                     self.values)
        xa0 = np.where(self.states >= 0, x0[np.maximum(self.states, 0)] if x0.size else 0.0,
                       0.0)
        try:
            point = mode_point(self.problem, mode, u, xa0, lcp)
            out = self.problem.system.outputs(mode, list(self.probes))
        except Exception as exc:  # (a mode the auxiliary system cannot build, whatever its
            # builder raises: a closed switch between a held node and a source)
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            return DcPoint(False, x0.copy(), np.zeros(len(self.problem.system.diodes)),
                           np.zeros(x0.shape, bool),
                           f"the operating point's constraints cannot hold in this mode: {first}")
        free = np.abs(out.Cy[:, point.free]).max(axis=1, initial=0.0) > 1e-9
        if not point.ok:
            return DcPoint(False, x0.copy(), np.zeros_like(point.lam), free, point.reason,
                           point.proved)
        x = out.Cy @ point.x + out.Dy @ point.lam + out.Fy @ u
        return DcPoint(True, x, point.lam, free)


def auxiliary_indices(names: Sequence[str], run_names: Sequence[str]) -> np.ndarray:
    """For each of ``names``, its index in ``run_names``, or -1."""
    where = {name: i for i, name in enumerate(run_names)}
    return np.array([where.get(name, -1) for name in names], dtype=np.int64)


def switch_leaks(problem: Problem, mode: ModeKey) -> tuple[np.ndarray, ...] | None:
    """The voltages across the switches open in ``mode`` (their option
    :data:`~lcs.model.TERMINALS_OPTION`), weighted by ``1/sqrt(ROFF)`` (ngspice's default
    ``ROFF`` 1e12 Ω): :func:`lcs.theory.operating_point.dc_point`'s leaks."""
    probes, weights = [], []
    for on, sw in zip(mode, problem.system.switches, strict=True):
        probe = switch_option(sw.options, TERMINALS_OPTION)
        if on or not probe:
            continue
        roff = switch_option(sw.options, "roff", None)
        roff = float(roff) if roff is not None and float(roff) > 0 else 1e12
        probes.append(probe)
        weights.append(1.0 / np.sqrt(roff))
    rows = []
    for probe, weight in zip(probes, weights, strict=True):
        try:
            out = problem.system.outputs(mode, [probe])
        except Exception:  # (a probe this system cannot read, whatever its builder raises:
            # no leak through that switch)
            continue
        rows.append((weight * out.Cy, weight * out.Dy, weight * out.Fy))
    if not rows:
        return None
    return tuple(np.vstack([r[j] for r in rows]) for j in range(3))
