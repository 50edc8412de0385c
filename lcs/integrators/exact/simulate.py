"""A transient run with the exact event-driven integrator (:mod:`.integrator`)."""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from ...model import OutputMap, SwitchedLCS
from ...results import SimulationResult
from ...simulation import driver
from ...simulation.problem import Problem
from .integrator import ExactIntegrator

__all__ = ["simulate_exact"]


def simulate_exact(
    system: SwitchedLCS,
    signals: Sequence,
    x0,
    t_stop: float,
    h: float,
    *,
    t_start: float = 0.0,
    probes: Sequence[str] | OutputMap | None = None,
    save_at: Sequence[float] = (),
    on_inconsistent=None,
    log_breakpoints: bool = False,
    operating_point: bool = False,
) -> SimulationResult:
    """Simulate a switched LCS exactly: one matrix exponential per stretch between events.

    Parameters
    ----------
    system : SwitchedLCS
    signals : sequence
        One resolved waveform per input (DC, PULSE, PWL or SIN).
    x0 : array_like (n,)
        Initial state.
    t_stop, h : float
        Stop time and output step, s (no time step: the flow between events is exact).
    t_start : float
    probes : sequence of str or OutputMap, optional
        As for :func:`lcs.integrators.moreau.integrator.simulate`; default every state.
    save_at : sequence of float
        Further output instants, s.
    on_inconsistent : callable, optional
        State jump, as for :func:`lcs.integrators.moreau.integrator.simulate`: for an inconsistent
        initial state, and after an event that leaves no consistent continuation (a switch closing a
        diode onto a charged capacitor); ``result.event_log`` then has a ``"jump"`` entry.
    log_breakpoints : bool
        Also list source corners in ``result.event_log``.
    operating_point : bool
        Start from the DC operating point instead of ``x0``, as for
        :func:`lcs.integrators.moreau.integrator.simulate`.

    Returns
    -------
    SimulationResult
        ``t`` the output instants and one row after each event; ``event_log`` every event;
        ``error`` set (and the data complete up to it) when the exact method had to stop:
        a sliding mode, an accumulation of events, a mode without consistent continuation.
    """
    t_wall = time.perf_counter()
    if not (h > 0 and np.isfinite(h)):
        raise ValueError(f"output step h must be positive, got {h}")
    driver.check_args(system, signals, x0, t_start, t_stop, 1)
    integ = ExactIntegrator(float(h), save_at, log_breakpoints, jump=on_inconsistent)
    result = driver.run(Problem(system, probes), list(signals), np.asarray(x0, dtype=float),
                        float(t_start), float(t_stop), integ, save_at=save_at,
                        on_inconsistent=on_inconsistent, switching="auto", t_wall=t_wall,
                        operating_point=operating_point)
    result.event_log = list(integ.event_log)
    return result
