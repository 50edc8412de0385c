"""Jacobians of the exact flow: transition matrices of the segments composed with the
saltation matrix of every state-dependent event.

Across an event at ``t_e`` where ``h(x, u, u') = 0`` with ``ḣ⁻ = dh/dt`` just before it, a
perturbation of the state moves the instant by ``δt = -(h_x δx + h_u δu) / ḣ⁻`` and the
state after it by ``(f⁻ - f⁺) δt`` (the vector fields before and after): the saltation
matrix ``S = I + (f⁺ - f⁻) h_x / ḣ⁻``. For a harmonic input perturbation ``d e^{jωt}`` the
same composition carries the forced part (:func:`affine_period`); with ω = 0 and d = 0 it is
the monodromy matrix of a periodic orbit.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm

from ..integrators.exact.events import Event, Segment

__all__ = ["AffinePeriod", "affine_period", "segment_field", "segment_output"]


@dataclass
class AffinePeriod:
    """``q(t0 + T) = P q(t0) + r`` and ``∫ p dt = Iq q(t0) + Ir`` over the period (the
    outputs' perturbation ``δy = e^{jωt} p(t)``; Iq, Ir None without outputs)."""

    P: np.ndarray
    r: np.ndarray
    Iq: np.ndarray | None = None
    Ir: np.ndarray | None = None


def segment_field(seg: Segment, x: np.ndarray, at_end: bool) -> np.ndarray:
    s = seg.duration if at_end else 0.0
    f = seg.flow
    return f.Af @ x + f.Ef @ seg.piece.u(s) + f.Ed @ seg.piece.du(s)


def segment_output(seg: Segment, Y, x: np.ndarray, at_end: bool) -> np.ndarray:
    s = seg.duration if at_end else 0.0
    Yx, Yu, Yd = Y
    return Yx @ x + Yu @ seg.piece.u(s) + Yd @ seg.piece.du(s)


def affine_period(segments: Sequence[Segment], events: Sequence[Event], omega: float,
                  d: np.ndarray, Y: Sequence | None = None) -> AffinePeriod:
    """Compose the period's segments and events for the excitation ``d e^{jωt}``.

    Parameters
    ----------
    segments, events
        From :func:`.orbit.exact_orbit` or a :class:`~.events.Follower`.
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
        if not hasattr(seg, "flow"):
            raise ZeroDivisionError(
                f"a sliding motion from t = {seg.t_start:.9g} s: the exact Jacobian through "
                "a sliding mode is not computed (use the Moreau method's finite differences)")
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
        if getattr(ev, "jump", False):
            raise ZeroDivisionError(f"the state jumps at t = {ev.t:.9g} s: the exact Jacobian "
                                    "through a jump is not computed")
        if not ev.moves:
            continue
        nxt = segments[k + 1]
        xe = nxt.x_start
        df = segment_field(nxt, xe, False) - segment_field(seg, xe, True)
        if abs(ev.hdot) <= 1e-300:
            raise ZeroDivisionError(f"event {ev.kind} {ev.name} at t = {ev.t:.9g} s is "
                                    "tangential (dh/dt = 0): no saltation")
        # dt = -(row @ X) / hdot per unit of [q0; 1]
        row = np.concatenate([ev.hx, [ev.hu @ d + jw * (ev.hd @ d)]]).astype(dtype)
        dt_row = -(row @ X) / ev.hdot
        if Y is not None:
            dy = segment_output(seg, Y[k], xe, True) - segment_output(nxt, Y[k + 1], xe, False)
            Iacc += np.outer(dy, dt_row)
        X = X.copy()
        X[:n] -= np.outer(df, dt_row)
    P, r = X[:n, :n], X[:n, n]
    if Y is None:
        return AffinePeriod(P, r)
    return AffinePeriod(P, r, Iacc[:, :n], Iacc[:, n])


