"""The exact periodic steady state of a switched LCS with piecewise-linear sources.

One period is followed with :class:`~.events.Follower`; Newton's method on the start state,
with the exact monodromy matrix of the saltation-corrected linearisation
(:mod:`.saltation`), converges to the periodic orbit: event instants and states to
round-off, not to a time step.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..integrators.exact.events import ExactError, Follower
from ..model import ModeKey, SwitchedLCS
from .saltation import affine_period

__all__ = ["PwlOrbit", "PwlOrbitError", "exact_orbit", "follow_period"]

#: the orbit's errors are the exact follower's
PwlOrbitError = ExactError


@dataclass
class PwlOrbit:
    """A periodic orbit followed exactly.

    Attributes
    ----------
    t0, period : float
        Sampling instant and period, s.
    x0 : ndarray (n,)
        State at ``t0``.
    segments : list of Segment
        Over ``[t0, t0 + period]`` in time order.
    events : list of Event
        ``len(segments) - 1`` boundaries.
    monodromy : ndarray (n, n)
        Jacobian of the period map at ``x0`` (saltation included).
    residual : float
        ``max |P(x0) - x0|`` (state units).
    iterations : int
        Newton iterations.
    states, inputs : tuple of str
    diodes : tuple of str
    """

    t0: float
    period: float
    x0: np.ndarray
    segments: list
    events: list
    monodromy: np.ndarray
    residual: float
    iterations: int
    states: tuple
    inputs: tuple
    diodes: tuple
    notes: list = field(default_factory=list)

    @property
    def multipliers(self) -> np.ndarray:
        """Eigenvalues of the monodromy matrix, by decreasing modulus."""
        mu = np.linalg.eigvals(self.monodromy)
        return mu[np.argsort(-np.abs(mu))]

    def describe(self) -> list[str]:
        """One line per mode change: instant (fraction of the period), what changed."""
        lines = []
        for ev in self.events:
            if ev.kind == "breakpoint":
                continue
            seg = self.segments[ev.index + 1]
            held = ", ".join(self.diodes[i] for i in seg.flow.held) or "none"
            lines.append(f"{(ev.t - self.t0) / self.period:.6f} T: {ev.kind} {ev.name} -> "
                         f"held diodes {held}")
        return lines


def follow_period(system: SwitchedLCS, signals: Sequence, x0, key0: ModeKey, t0: float,
                  period: float):
    """Segments, events and end state of one period from ``x0`` (see :class:`Follower`)."""
    return Follower(system, signals, t0, period).follow(x0, key0)


def exact_orbit(system: SwitchedLCS, signals: Sequence, x_guess, key0: ModeKey, t0: float,
                period: float, *, tol: float = 1e-11, max_iter: int = 30) -> PwlOrbit:
    """The period-1 orbit through ``t0`` by Newton's method with the exact monodromy.

    Parameters
    ----------
    system : SwitchedLCS
    signals : sequence
        One piecewise-linear source per input, resolved (:func:`lcs.signals.resolve`).
    x_guess : array_like (n,)
        A state near the orbit at ``t0`` (e.g. from the Moreau stroboscopic map).
    key0 : ModeKey
        Switch states at ``t0`` (the comparators with hysteresis need it).
    t0, period : float
        s.
    tol : float
        Convergence when ``|P(x) - x| <= tol (|x| + 1)`` componentwise (max).

    Raises
    ------
    PwlOrbitError
        A mode with no consistent continuation, sliding, a non-PWL source, or no
        convergence.
    """
    ctx = Follower(system, signals, t0, period)
    x = np.asarray(x_guess, dtype=float).copy()
    n = x.size
    res = np.inf
    for it in range(1, max_iter + 1):
        segs, events, x_end = ctx.follow(x, key0)
        Phi = affine_period(segs, events, 0.0, np.zeros(ctx.p)).P.real
        r = x_end - x
        sc = np.abs(x) + np.abs(x_end) + 1.0
        res = float(np.max(np.abs(r) / sc))
        if res <= tol:
            orbit = PwlOrbit(t0, period, x, segs, events, Phi, float(np.max(np.abs(r))), it,
                             tuple(system.states), tuple(system.inputs),
                             tuple(system.diodes))
            return orbit
        try:
            dx = np.linalg.solve(Phi - np.eye(n), -r)
        except np.linalg.LinAlgError:
            raise PwlOrbitError("the monodromy matrix has a multiplier 1: the orbit is not "
                                "isolated") from None
        x = x + dx
    raise PwlOrbitError(f"Newton's method did not converge in {max_iter} iterations "
                        f"(relative residual {res:.3g})")
