"""Small-signal analysis around an exact periodic orbit: the linear time-periodic (LTP)
system, its sampled-data model and its harmonic transfer function at the excitation
frequency.

Around the orbit of :mod:`.pwl_orbit`, a perturbation ``δu(t) = d e^{jωt}`` of the inputs
(direction ``d``, shape (p,)) gives ``δx(t) = e^{jωt} q(t)`` with q T-periodic in the steady
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
from scipy.linalg import expm

from .pwl_orbit import Event, PwlOrbit, Segment
from .response import FrequencyResponse

__all__ = ["AffinePeriod", "SampledData", "affine_period", "harmonic_response", "probe_forms",
           "sampled_data", "sampled_data_model"]


@dataclass
class AffinePeriod:
    """``q(t0 + T) = P q(t0) + r`` and ``∫ p dt = Iq q(t0) + Ir`` over the period (the
    outputs' perturbation ``δy = e^{jωt} p(t)``; Iq, Ir None without outputs)."""

    P: np.ndarray
    r: np.ndarray
    Iq: np.ndarray | None = None
    Ir: np.ndarray | None = None


def probe_forms(orbit: PwlOrbit, outputs: Callable) -> list:
    """Per segment, the probes as ``(Yx, Yu, Yd)`` (coefficients of x, u, u'); ``outputs(key)``
    returns the :class:`~lcs.model.OutputMap` of the probes in a switch configuration."""
    return [seg.flow.affine(*_cdf(outputs(seg.key))) for seg in orbit.segments]


def _cdf(om):
    return om.Cy, om.Dy, om.Fy


def _field(seg: Segment, x: np.ndarray, at_end: bool) -> np.ndarray:
    s = seg.duration if at_end else 0.0
    f = seg.flow
    return f.Af @ x + f.Ef @ (seg.u0 + seg.u1 * s) + f.Ed @ seg.u1


def _output(seg: Segment, Y, x: np.ndarray, at_end: bool) -> np.ndarray:
    s = seg.duration if at_end else 0.0
    Yx, Yu, Yd = Y
    return Yx @ x + Yu @ (seg.u0 + seg.u1 * s) + Yd @ seg.u1


def affine_period(segments: Sequence[Segment], events: Sequence[Event], omega: float,
                  d: np.ndarray, Y: Sequence | None = None) -> AffinePeriod:
    """Compose the period's segments and events for the excitation ``d e^{jωt}``.

    Parameters
    ----------
    segments, events
        From :func:`.pwl_orbit.exact_orbit` (or ``follow_period``).
    omega : float
        rad/s (0: real arithmetic).
    d : ndarray (p,)
        Input direction.
    Y : list of (Yx, Yu, Yd), optional
        Output forms per segment (:func:`probe_forms`); then Iq, Ir are computed.
    """
    n = segments[0].flow.Af.shape[0]
    dtype = complex if omega else float
    jw = 1j * omega if omega else 0.0
    X = np.eye(n + 1, dtype=dtype)  # [q; 1] = X [q0; 1]
    q_out = 0 if Y is None else Y[0][0].shape[0]
    Iacc = np.zeros((q_out, n + 1), dtype=dtype) if Y is not None else None
    for k, seg in enumerate(segments):
        f = seg.flow
        tau = seg.duration
        Gaug = np.zeros((n + 1, n + 1), dtype=dtype)
        Gaug[:n, :n] = f.Af - jw * np.eye(n)
        Gaug[:n, n] = f.Ef @ d + jw * (f.Ed @ d)
        if Y is None:
            X = expm(Gaug * tau) @ X
        else:
            big = np.zeros((2 * (n + 1), 2 * (n + 1)), dtype=dtype)
            big[:n + 1, :n + 1] = Gaug
            big[:n + 1, n + 1:] = np.eye(n + 1)
            Eb = expm(big * tau)
            integral = Eb[:n + 1, n + 1:] @ X  # ∫ [q; 1] dt over the segment
            Yx, Yu, Yd = Y[k]
            Iacc += np.hstack([Yx, (Yu @ d + jw * (Yd @ d))[:, None]]) @ integral
            X = Eb[:n + 1, :n + 1] @ X
        if k == len(segments) - 1:
            break
        ev = events[k]
        if not ev.moves:
            continue
        nxt = segments[k + 1]
        xe = nxt.x_start
        df = _field(nxt, xe, False) - _field(seg, xe, True)
        if abs(ev.hdot) <= 1e-300:
            raise ZeroDivisionError(f"event {ev.kind} {ev.name} at t = {ev.t:.9g} s is "
                                    "tangential (dh/dt = 0): no saltation")
        # dt = -(row @ X) / hdot per unit of [q0; 1]
        row = np.concatenate([ev.hx, [ev.hu @ d + jw * (ev.hd @ d)]]).astype(dtype)
        dt_row = -(row @ X) / ev.hdot
        if Y is not None:
            dy = _output(seg, Y[k], xe, True) - _output(nxt, Y[k + 1], xe, False)
            Iacc += np.outer(dy, dt_row)
        X = X.copy()
        X[:n] -= np.outer(df, dt_row)
    P, r = X[:n, :n], X[:n, n]
    if Y is None:
        return AffinePeriod(P, r)
    return AffinePeriod(P, r, Iacc[:, :n], Iacc[:, n])


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
