"""Small-signal analysis around an exact periodic orbit: the linear time-periodic (LTP)
system, its sampled-data model and its harmonic transfer function at the excitation
frequency.

Around the orbit of :mod:`lcs.analysis.exact_orbit`, a perturbation ``δu(t) = d e^{jωt}`` of the
inputs (direction ``d``, shape (p,)) gives ``δx(t) = e^{jωt} q(t)`` with q T-periodic in the steady
state. On a segment of mode k::

    q' = (Af_k - jω I) q + (Ef_k + jω Ed_k) d,

and at an instant ``t_e`` defined by ``h(x, u, u') = 0`` (a comparator crossing, a diode
turning on or off) the instant moves by ``δt = -(hx δx + hu δu + hd δu') / ḣ``, so the state
perturbation jumps by the saltation ``(f+ - f-)(hx q + (hu + jω hd) d) / ḣ`` and an output
that jumps at ``t_e`` (a switch-node voltage) gains an impulse ``(y- - y+) δt``. Composing
the segments (matrix exponentials of the augmented generators, with their integrals for the
outputs' period averages, Van Loan's block trick) gives ``q(t0 + T) = P q(t0) + r``; the
periodic q has ``q(t0) = (I - P)^{-1} r``, and the component of an output at ω per unit of
input is the period average of ``e^{-jωt} δy(t)``. This is the (0, 0) element of the harmonic
transfer function (Wereley); the other elements are the sidebands at ``ω + k ωs``.

At ω = 0 with ``d = 0``, ``P`` is the monodromy matrix of the period map; with ``d = e_j`` and
the perturbation held over the period, ``r`` is the period map's derivative in input j: the
sampled-data model ``δx_{k+1} = Φ δx_k + Γ δu_k``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..analysis.exact_orbit import PwlOrbit
from ..analysis.saltation import AffinePeriod, affine_period
from .response import FrequencyResponse

__all__ = ["AffinePeriod", "SampledData", "affine_period", "harmonic_response", "probe_forms",
           "sampled_data", "sampled_data_model"]


def probe_forms(orbit: PwlOrbit, outputs: Callable) -> list:
    """Per segment, the probes as ``(Yx, Yu, Yd)`` (coefficients of x, u, u'); ``outputs(key)``
    returns the :class:`~lcs.model.OutputMap` of the probes in a switch configuration."""
    return [seg.flow.affine(*_cdf(outputs(seg.key))) for seg in orbit.segments]


def _cdf(om):
    return om.Cy, om.Dy, om.Fy


def harmonic_response(orbit: PwlOrbit, Y: Sequence, probes: Sequence[str], inject: int,
                      freqs: Sequence[float]) -> FrequencyResponse:
    """The component of each probe at f per unit of input ``inject`` at f (exact).

    Parameters
    ----------
    orbit : PwlOrbit
    Y : list
        Probe forms per segment (:func:`probe_forms`).
    probes : sequence of str
    inject : int
        Input index.
    freqs : sequence of float
        Hz (any: above fs/2 the component at f is still computed; the response then also
        has sidebands at ``f - k fs`` not reported here).
    """
    T = orbit.period
    d = np.zeros(len(orbit.inputs))
    d[inject] = 1.0
    n = orbit.x0.size
    rows = []
    for f in freqs:
        w = 2 * np.pi * float(f)
        ap = affine_period(orbit.segments, orbit.events, w, d, Y)
        q0 = np.linalg.solve(np.eye(n) - ap.P, ap.r)
        rows.append((ap.Iq @ q0 + ap.Ir) / T)
    H = np.asarray(rows, dtype=complex).reshape(len(rows), len(probes))
    return FrequencyResponse(np.asarray(freqs, dtype=float), tuple(probes), H,
                             orbit.inputs[inject], "exact", float(T))


@dataclass
class SampledData:
    """The linearised period map ``δx_{k+1} = Φ δx_k + Γ δu_k`` (inputs held over each
    period, the state sampled at ``t0 + k T``).

    Attributes
    ----------
    Phi : ndarray (n, n)
        Monodromy matrix (its eigenvalues are the Floquet multipliers).
    Gamma : ndarray (n, p)
        Derivative of the period map in each input (state unit per input unit).
    states, inputs : tuple of str
    period : float
        T, s.
    """

    Phi: np.ndarray
    Gamma: np.ndarray
    states: tuple
    inputs: tuple
    period: float

    def to_statespace(self):
        """A discrete-time python-control ``StateSpace`` (``dt`` = T) with named states,
        inputs and outputs (the states)."""
        import control  # 0.7 s of imports: only when asked

        n, p = self.Gamma.shape
        names = list(self.states)
        return control.ss(self.Phi, self.Gamma, np.eye(n), np.zeros((n, p)), self.period,
                          inputs=list(self.inputs), outputs=names,
                          states=[f"x[{s}]" for s in names])


def sampled_data(orbit: PwlOrbit) -> SampledData:
    """The sampled-data model of the orbit's period map (see :class:`SampledData`)."""
    n, p = orbit.x0.size, len(orbit.inputs)
    Gam = np.zeros((n, p))
    for j in range(p):
        d = np.zeros(p)
        d[j] = 1.0
        Gam[:, j] = affine_period(orbit.segments, orbit.events, 0.0, d).r.real
    return SampledData(orbit.monodromy.copy(), Gam, tuple(orbit.states), tuple(orbit.inputs),
                       float(orbit.period))


def sampled_data_model(orbit: PwlOrbit):
    """:func:`sampled_data` as a discrete-time python-control ``StateSpace``."""
    return sampled_data(orbit).to_statespace()
