"""What the maps of a switched LCS share: the system, its sources and the stepper.

:class:`LcsMapBase` holds a :class:`~lcs.model.SwitchedLCS` built for one parameter value,
its resolved sources, the period T and the step h, and runs
:func:`lcs.integrators.moreau.integrator.simulate` from a state over a span;
:class:`~.stroboscopic.StroboscopicMap` and
:class:`~.event_map.EventMap` sample those runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..integrators.moreau.integrator import InconsistentHandler, MoreauOptions, simulate
from ..model import SwitchedLCS
from ..results import SimulationResult
from .base import Map, MapError
from .patterns import SwitchingPattern, switching_pattern

__all__ = ["LcsMapBase"]

# A stored sample is at a given instant when it is within this fraction of h of it. Period
# instants and source-driven switching instants are step boundaries, exact up to the
# driver's merging of boundaries (1e-9 h); comparator switchings split steps and may fall
# nanoseconds away from a period instant, so the tolerance must be much tighter than a step.
_TIME_MATCH = 1e-6
# "every" large enough to store only the first and the last point of a run.
_EVERY_NONE = 2**62


def _check_periodic(signals: Sequence, period: float, t0: float) -> list[str]:
    """Notes for sources that are not ``period``-periodic from ``t0`` on (sampled check)."""
    notes = []
    t = t0 + period * np.linspace(0.0, 1.0, 97, endpoint=False) + period * 1e-3
    for j, sig in enumerate(signals):
        try:
            a = np.asarray(sig(t), dtype=float)
            b = np.asarray(sig(t + period), dtype=float)
            c = np.asarray(sig(t + 7 * period), dtype=float)
        except Exception:  # noqa: BLE001 - a waveform that cannot be sampled is just not checked
            continue
        scale = max(float(np.max(np.abs(a))), 1e-12)
        if np.max(np.abs(a - b)) > 1e-9 * scale or np.max(np.abs(a - c)) > 1e-9 * scale:
            notes.append(f"input {j} is not periodic with T = {period:g} s from t0 = {t0:g} s: "
                         "the stroboscopic map then depends on the sampling period index")
    return notes


class LcsMapBase(Map):
    """What stroboscopic and event maps share: the system, its sources and the stepper."""

    def __init__(
        self,
        system: SwitchedLCS,
        signals: Sequence,
        period: float,
        h: float,
        *,
        theta: float = 0.5,
        t0: float = 0.0,
        param: float | None = None,
        param_name: str | None = None,
        on_inconsistent: InconsistentHandler | None = None,
        options: MoreauOptions | None = None,
        diode_probes: Sequence[str] = (),
        scale=None,
    ):
        if not (period > 0 and math.isfinite(period)):
            raise ValueError(f"period must be positive, got {period}")
        if not (h > 0 and h <= period):
            raise ValueError(f"step h must be in (0, period], got {h}")
        self.system = system
        self.signals = list(signals)
        self.period = float(period)
        self.h = float(h)
        self.theta = float(theta)
        self.t0 = float(t0)
        self.param = param
        self.param_name = param_name
        self.on_inconsistent = on_inconsistent
        self.options = options
        self.diode_probes = tuple(diode_probes)
        self.state_names = tuple(system.states)
        self._scale = None if scale is None else np.asarray(scale, dtype=float)
        self.notes: list[str] = _check_periodic(self.signals, self.period, self.t0)
        self.evaluations = 0  # simulate() calls, for benchmarks
        self.simulated_periods = 0.0

    def natural_scale(self) -> np.ndarray | None:
        return self._scale

    def _simulate(self, x, t_start: float, t_stop: float, *, every: int,
                  breakpoints: Sequence[float] = (), probes: Sequence[str] | None = None,
                  save_at: Sequence[float] = ()) -> SimulationResult:
        self.evaluations += 1
        self.simulated_periods += (t_stop - t_start) / self.period
        kwargs = {"save_at": save_at} if len(save_at) else {}
        return simulate(
            self.system, self.signals, np.asarray(x, dtype=float), t_stop, self.h,
            theta=self.theta, t_start=t_start, probes=probes, every=every,
            breakpoints=breakpoints, on_inconsistent=self.on_inconsistent,
            options=self.options, **kwargs,
        )

    def _fail(self, res: SimulationResult, x) -> MapError:
        err = res.error
        return MapError(f"simulation failed at parameter {self.param}: "
                        f"{err.message if err is not None else 'unknown error'}", x, self.param)

    def _pattern_from(self, res: SimulationResult, t_start: float, t_end: float
                      ) -> SwitchingPattern:
        """Segments of constant (switch mode, conducting diodes) of a run stored every step."""
        return switching_pattern(
            res, t_start, t_end, switch_names=[s.name for s in self.system.switches],
            diode_names=self.system.diodes, diode_probes=self.diode_probes,
            time_tol=_TIME_MATCH * self.h)
