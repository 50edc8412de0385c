"""Event (Poincaré) maps of a switched LCS: sampled when a switch turns on or off, a diode
starts or ceases to conduct, or a probe crosses a level.

The map state is ``(x, phase)`` with ``phase`` the event time modulo T (s), since the
section is crossed at varying instants.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..model import SwitchedLCS
from ..results import SimulationResult
from .base import MapError
from .jacobians import section_jacobian
from .lcs_map import _TIME_MATCH, LcsMapBase
from .patterns import conducting

__all__ = ["EventMap", "EventSpec"]


@dataclass(frozen=True)
class EventSpec:
    """Which event defines the section of an :class:`EventMap`.

    Attributes
    ----------
    kind : str
        ``"switch"`` (a switch changes state), ``"diode"`` (a diode starts / stops
        conducting) or ``"probe"`` (a probe crosses ``level``).
    name : str
        Switch name, diode name or probe name.
    rising : bool
        Switch turning on / diode starting to conduct / probe crossing upwards (True), or
        the opposite (False).
    level : float
        Crossing level of a probe (its SI unit).
    """

    kind: str
    name: str
    rising: bool = True
    level: float = 0.0

    @staticmethod
    def parse(text: str) -> EventSpec:
        """``"S1:on"``, ``"S1:off"``, ``"D1:on"``, ``"D1:off"``, ``"v(out)>12"``, ``"i(L1)<0"``.

        Whether ``S1``/``D1`` is a switch or a diode is decided when the map is built (by the
        system's names); here a ``NAME:on|off`` is stored with kind ``"element"``.
        """
        s = text.strip()
        for op, rising in ((">", True), ("<", False)):
            if op in s:
                probe, _, level = s.partition(op)
                return EventSpec("probe", probe.strip(), rising, float(level))
        name, sep, state = s.partition(":")
        if not sep or state.strip().lower() not in ("on", "off"):
            raise ValueError(f"event {text!r}: expected NAME:on, NAME:off, PROBE>LEVEL or "
                             "PROBE<LEVEL")
        return EventSpec("element", name.strip(), state.strip().lower() == "on")


class EventMap(LcsMapBase):
    """Poincaré map on an event section: ``(x, φ) -> (x, φ)`` at the next event.

    The map state is the circuit state at the event followed by its phase φ = (t_event -
    t0) mod T (s). Starting from state x at time ``t0 + φ``, the circuit is simulated until
    the first event strictly later than ``t0 + φ + h/2`` (at most ``max_periods`` periods).

    Events of a switch come from the run's ``events`` (exact instants for source-driven
    switches); a diode starts conducting at the first step whose λ makes it conduct (time
    resolution h); a probe crossing is located by linear interpolation between steps. The
    state at the event is the stored state at that instant (or interpolated).

    For a section crossed at a fixed phase (a source-driven switch) φ stays constant and the
    map equals the stroboscopic map with ``t0`` at that phase. The Jacobian of the extended
    state has one more multiplier, 0 (the phase is a function of x on the section).

    Parameters
    ----------
    event : EventSpec or str
    max_periods : int
        Give up (``MapError``) if no event occurs within this many periods.
    Other parameters as :class:`StroboscopicMap`.
    """

    def __init__(self, system: SwitchedLCS, signals: Sequence, period: float, h: float,
                 event: EventSpec | str, *, max_periods: int = 20, **kwargs):
        super().__init__(system, signals, period, h, **kwargs)
        spec = EventSpec.parse(event) if isinstance(event, str) else event
        if spec.kind == "element":
            sw = [s.name.lower() for s in system.switches]
            di = [d.lower() for d in system.diodes]
            if spec.name.lower() in sw:
                spec = EventSpec("switch", spec.name, spec.rising)
            elif spec.name.lower() in di:
                spec = EventSpec("diode", spec.name, spec.rising)
            else:
                raise KeyError(f"event {spec.name!r}: no switch or diode of that name "
                               f"(switches: {', '.join(s.name for s in system.switches) or '-'};"
                               f" diodes: {', '.join(system.diodes) or '-'})")
        if spec.kind == "diode" and len(self.diode_probes) != len(system.diodes):
            raise ValueError("diode events need diode_probes (one per diode)")
        self.event = spec
        self.max_periods = int(max_periods)
        self.state_names = tuple(system.states) + ("phase",)
        self._probes = list(system.states)
        if spec.kind == "diode":
            self._probes.append(self.diode_probes[[d.lower() for d in system.diodes]
                                                  .index(spec.name.lower())])
        elif spec.kind == "probe":
            self._probes.append(spec.name)

    def natural_scale(self) -> np.ndarray | None:
        if self._scale is None:
            return None
        return np.concatenate([self._scale[: self.dim - 1], [self.period]])

    def jacobian(self, z, k: int, scale: np.ndarray, rel_step: float = 1e-5) -> np.ndarray:
        """Jacobian of ``F^k`` restricted to the section, extended by 0 across it.

        Every image of F lies on the section Σ, and a state on Σ sits on a switching
        surface when the event is a switching: F is only piecewise smooth across Σ (the
        perturbed start is in one mode or the other), so central differences straddling Σ
        average two one-sided derivatives. Instead: the tangent space of Σ is estimated
        from the images of perturbed states (they lie on Σ), the central differences are
        taken along an orthonormal basis V of it (in scaled coordinates), and the result
        ``J_Σ = (DF V) V'`` has the Poincaré map's multipliers plus one exact 0
        (:func:`~.jacobians.section_jacobian`).
        """
        return section_jacobian(lambda v: self.power(v, k), np.asarray(z, dtype=float),
                                np.asarray(scale, dtype=float), rel_step)

    def _find_events(self, res: SimulationResult, after: float) -> list[tuple[float, np.ndarray]]:
        """(time, state) of every section crossing in a run stored every step, after ``after``."""
        n = self.dim - 1
        t, y = res.t, res.y
        out: list[tuple[float, np.ndarray]] = []
        ev = self.event
        if ev.kind == "switch":
            i = [s.name.lower() for s in self.system.switches].index(ev.name.lower())
            prev = tuple(res.modes_visited[0]) if res.modes_visited else ()
            for te, mode in res.events:
                if mode[i] != prev[i] and mode[i] == ev.rising and te > after:
                    out.append((float(te), self._state_at(t, y[:, :n], te)))
                prev = mode
        elif ev.kind == "diode":
            cur = y[:, n]
            on = conducting(cur)
            change = np.flatnonzero(on[1:] != on[:-1]) + 1
            for j in change:
                if on[j] == ev.rising and t[j] > after:
                    out.append((float(t[j]), y[j, :n].copy()))
        else:
            c = y[:, n] - ev.level
            above = c > 0
            change = np.flatnonzero(above[1:] != above[:-1])
            for j in change:
                if above[j + 1] != ev.rising:
                    continue
                frac = c[j] / (c[j] - c[j + 1]) if c[j] != c[j + 1] else 0.0
                te = t[j] + frac * (t[j + 1] - t[j])
                if te > after:
                    out.append((float(te), y[j, :n] + frac * (y[j + 1, :n] - y[j, :n])))
        return out

    def _state_at(self, t: np.ndarray, x: np.ndarray, te: float) -> np.ndarray:
        j = int(np.searchsorted(t, te - _TIME_MATCH * self.h))
        j = min(j, len(t) - 1)
        if abs(t[j] - te) <= _TIME_MATCH * self.h:
            return x[j].copy()
        j = max(1, j)
        frac = (te - t[j - 1]) / (t[j] - t[j - 1])
        return x[j - 1] + frac * (x[j] - x[j - 1])

    def _collect(self, z, count: int) -> list[tuple[float, np.ndarray]]:
        """The next ``count`` section crossings (time, state) from the map state ``z``."""
        z = np.asarray(z, dtype=float)
        x = z[:-1]
        t_start = self.t0 + float(z[-1])
        after = t_start + 0.5 * self.h
        limit = t_start + self.max_periods * max(count, 1) * self.period
        found: list[tuple[float, np.ndarray]] = []
        t_a = t_start
        while len(found) < count:
            if t_a >= limit - self.h:
                raise MapError(f"no {self._describe()} within {self.max_periods} periods "
                               f"(parameter {self.param})", z, self.param)
            # Windows end half a period off the start phase: an event exactly at a window's
            # end would be the next window's initial mode and go unreported, and events at
            # the start phase (a section crossed at a fixed phase) are then well inside.
            t_b = min(t_a + (count - len(found) + 0.5) * self.period, limit)
            k0 = math.floor((t_a - self.t0) / self.period) + 1
            k1 = math.floor((t_b - self.t0) / self.period)
            bps = self.t0 + self.period * np.arange(k0, k1 + 1)
            res = self._simulate(x, t_a, t_b, every=1, breakpoints=bps, probes=self._probes)
            if not res.ok:
                raise self._fail(res, z)
            found.extend(self._find_events(res, after))
            if found:
                after = found[-1][0] + 0.5 * self.h
            x = res.x_final.copy()
            t_a = t_b
        return found[:count]

    def _describe(self) -> str:
        ev = self.event
        if ev.kind == "switch":
            return f"switch {ev.name} turning {'on' if ev.rising else 'off'}"
        if ev.kind == "diode":
            return f"diode {ev.name} {'starting' if ev.rising else 'ceasing'} to conduct"
        return f"{ev.name} crossing {ev.level:g} {'upwards' if ev.rising else 'downwards'}"

    def _as_state(self, te: float, x: np.ndarray) -> np.ndarray:
        phase = math.fmod(te - self.t0, self.period)
        if phase < 0:
            phase += self.period
        # Round-off just below T is the phase 0 of the next period.
        if self.period - phase <= _TIME_MATCH * self.h:
            phase = 0.0
        return np.concatenate([x, [phase]])

    def __call__(self, z) -> np.ndarray:
        (te, x), = self._collect(z, 1)
        return self._as_state(te, x)

    def power(self, z, k: int) -> np.ndarray:
        if int(k) == 0:
            return np.asarray(z, dtype=float).copy()
        te, x = self._collect(z, int(k))[-1]
        return self._as_state(te, x)

    def iterate(self, z, n: int) -> np.ndarray:
        found = self._collect(z, int(n))
        out = np.empty((int(n) + 1, self.dim))
        out[0] = np.asarray(z, dtype=float)
        for k, (te, x) in enumerate(found, start=1):
            out[k] = self._as_state(te, x)
        return out

    def event_times(self, z, n: int) -> np.ndarray:
        """Absolute times (s) of the next n events from ``z``."""
        return np.array([te for te, _ in self._collect(z, int(n))])
