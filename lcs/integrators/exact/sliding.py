"""Filippov sliding on a comparator surface in the exact method.

A switch without hysteresis slides when, on its surface ``control = VT``, the vector field
with the switch on drives the control down and the one with it off drives it up: each mode
sends the state straight back across. The motion then follows the equivalent (Filippov)
dynamics, the convex combination that keeps the control on the surface::

    x' = (1 - d) f_off + d f_on,      d = c'_off / (c'_off - c'_on),

``c'_m`` the control's rate in mode m (the implicit relay of the Moreau method converges to
the same motion). With mode-dependent fields ``d`` is a ratio of affine functions of the state,
so the sliding motion is not linear: it is integrated with an 8th-order Runge–Kutta method
(DOP853, relative tolerance 1e-12) with dense output, not by a matrix exponential. Sliding ends
where ``d`` reaches 0 or 1 (the control's rate in one mode turns), located by the
integrator's event finder; the switch then stays in that mode. A diode changing state while
the switch slides stops the run with :class:`~.events.ExactError`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from .flow import InputPiece, ModeFlow

__all__ = ["SlidingSegment", "slide"]

_RTOL = 1e-12


@dataclass
class SlidingSegment:
    """A stretch in which switch ``switch`` slides.

    Attributes
    ----------
    t_start, t_end : float
        s.
    switch : int
        Index of the sliding switch.
    key : tuple of bool
        Switch states with the sliding switch on (the others as they are).
    flows : (ModeFlow, ModeFlow)
        Off and on dynamics (same held diodes).
    piece : InputPiece
    t_piece : float
        Time origin of ``piece``, s.
    x_start : ndarray (n,)
    sol : callable
        Dense output ``sol(t) -> x`` on ``[t_start, t_end]``.
    rates : callable
        ``rates(t, x) -> (c'_off, c'_on)``.
    """

    t_start: float
    t_end: float
    switch: int
    key: tuple
    flows: tuple
    piece: InputPiece
    t_piece: float
    x_start: np.ndarray
    sol: object
    rates: object

    @property
    def duration(self) -> float:
        return self.t_end - self.t_start

    def duty(self, t: float, x: np.ndarray) -> float:
        """The equivalent duty d in [0, 1] at (t, x)."""
        c_off, c_on = self.rates(t, x)
        den = c_off - c_on
        return float(np.clip(c_off / den, 0.0, 1.0)) if den > 0 else 0.5

    def field(self, t: float, x: np.ndarray, mode: int) -> np.ndarray:
        s = t - self.t_piece
        f = self.flows[mode]
        return f.Af @ x + f.Ef @ self.piece.u(s) + f.Ed @ self.piece.du(s)


def _control_rate(row, flow: ModeFlow, piece: InputPiece, s: float, x) -> float:
    gx, gu, gd = row
    du = piece.du(s)
    f = flow.Af @ x + flow.Ef @ piece.u(s) + flow.Ed @ du
    return float(gx @ f + gu @ du + gd @ piece.d2u(s))


def slide(j: int, key_on: tuple, flows: tuple, rows: tuple, piece: InputPiece, t_piece: float,
          x0: np.ndarray, t0: float, t1: float, scale: float):
    """Integrate the sliding motion of switch j from ``(t0, x0)`` until it ends or ``t1``.

    Parameters
    ----------
    rows : ((gx, gu, gd), (gx, gu, gd))
        The control of switch j as a function of ``(x, u, u')`` in the off and on modes.
    scale : float
        Typical state magnitude (absolute tolerance ``1e-12 scale``).

    Returns
    -------
    (SlidingSegment, x_end, exit)
        ``exit`` is None when the motion still slides at ``t1``, else 0 (the switch stays
        off) or 1 (on).
    """
    f_off, f_on = flows

    def rates(t, x):
        s = t - t_piece
        return (_control_rate(rows[0], f_off, piece, s, x),
                _control_rate(rows[1], f_on, piece, s, x))

    def rhs(t, x):
        c_off, c_on = rates(t, x)
        den = c_off - c_on
        d = min(max(c_off / den, 0.0), 1.0) if den > 0 else 0.5
        s = t - t_piece
        u, du = piece.u(s), piece.du(s)
        a = f_off.Af @ x + f_off.Ef @ u + f_off.Ed @ du
        b = f_on.Af @ x + f_on.Ef @ u + f_on.Ed @ du
        return a + d * (b - a)

    def leave_off(t, x):  # c'_off falls to 0: the off mode no longer crosses back
        return rates(t, x)[0]

    def leave_on(t, x):  # c'_on rises to 0
        return -rates(t, x)[1]

    leave_off.terminal = leave_on.terminal = True
    leave_off.direction = leave_on.direction = -1
    sol = solve_ivp(rhs, (t0, t1), x0, method="DOP853", rtol=_RTOL,
                    atol=_RTOL * max(scale, 1e-300), dense_output=True,
                    events=(leave_off, leave_on))
    exit_ = None
    t_end = float(sol.t[-1])
    if sol.status == 1:
        exit_ = 0 if len(sol.t_events[0]) else 1
        t_end = float((sol.t_events[0] if exit_ == 0 else sol.t_events[1])[0])
    x_end = sol.sol(t_end)
    seg = SlidingSegment(t0, t_end, j, key_on, flows, piece, t_piece, np.asarray(x0).copy(),
                         sol.sol, rates)
    return seg, np.asarray(x_end, dtype=float), exit_
