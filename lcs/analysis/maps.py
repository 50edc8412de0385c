"""Discrete-time maps of switched LCS: stroboscopic (Poincaré) and event maps.

A periodically driven converter is studied through a map ``x_{k+1} = P(x_k)``:

* :class:`StroboscopicMap` samples the state once per period T of the drive (PWM gate,
  sawtooth ramp): ``P(x) = x(t0 + T)`` from ``x(t0) = x``. The sources must be T-periodic
  from ``t0`` on (a check is made and reported in :attr:`StroboscopicMap.notes`).
* :class:`EventMap` samples at an event: a switch turning on or off, a diode starting or
  ceasing to conduct, a probe crossing a level. Its state is ``(x, phase)`` with ``phase``
  the event time modulo T (s), since the section is crossed at varying instants.
* :class:`FunctionMap` wraps any Python function, so that the analysis cores (orbits,
  continuation, bifurcation sweeps, cell mapping) can be tested on maps with known answers.

Every map is evaluated by :func:`lcs.moreau.simulate`; a map is built for one parameter
value (the system is formulated once and its modes are cached by the
:class:`~lcs.model.SwitchedLCS`). Many periods are simulated in one ``simulate`` call with
the instants ``t0 + k T`` as breakpoints and ``save_at`` points, so that exactly the period
samples are stored (no Python work per period). Should a run lack a period sample, it is
repeated storing every step and the samples are picked by time.

The map of a time-stepping scheme is the *discrete* map: its fixed points and multipliers
converge to those of the circuit with the order of the scheme as ``h`` shrinks.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..model import SwitchedLCS
from ..moreau import InconsistentHandler, MoreauOptions, simulate
from ..results import SimulationResult

__all__ = [
    "EventMap",
    "EventSpec",
    "FunctionMap",
    "Map",
    "MapError",
    "PatternSegment",
    "Samples",
    "StroboscopicMap",
    "SwitchingPattern",
    "central_jacobian",
]

# A stored sample is at a given instant when it is within this fraction of h of it. Period
# instants and source-driven switching instants are step boundaries, exact up to the
# driver's merging of boundaries (1e-9 h); comparator switchings split steps and may fall
# nanoseconds away from a period instant, so the tolerance must be much tighter than a step.
_TIME_MATCH = 1e-6
# "every" large enough to store only the first and the last point of a run.
_EVERY_NONE = 2**62
# A diode conducts when its current exceeds this fraction of the largest current seen in the
# run (plus an absolute floor, A): the Moreau λ of a blocking diode is exactly 0, up to
# round-off.
_DIODE_RTOL = 1e-9
_DIODE_ATOL = 1e-12


class MapError(RuntimeError):
    """A map evaluation failed (simulation error or non-finite state).

    Attributes
    ----------
    x : ndarray or None
        The state the evaluation started from.
    param : float or None
        The parameter value of the map.
    """

    def __init__(self, message: str, x: np.ndarray | None = None, param: float | None = None):
        super().__init__(message)
        self.x = None if x is None else np.array(x, dtype=float)
        self.param = param


@dataclass
class Samples:
    """Probe values at the map's sampling instants.

    Attributes
    ----------
    names : tuple[str, ...]
        Probe names (columns of ``values``).
    values : ndarray, shape (M, q)
        One row per recorded iterate, in the SI unit of each probe.
    x_final : ndarray, shape (dim,)
        Map state after the last iterate (to start the next parameter value from).
    ok : bool
        False if the run failed (diverged, LCP failure); rows not reached are NaN.
    message : str
        Why the run failed, empty otherwise.
    """

    names: tuple[str, ...]
    values: np.ndarray
    x_final: np.ndarray
    ok: bool = True
    message: str = ""


@dataclass(frozen=True)
class PatternSegment:
    """An interval of constant switch and diode states within a period.

    Attributes
    ----------
    start, duration : float
        Start (relative to the first sampling instant) and length, s.
    switches : tuple[bool, ...]
        Switch states (True = on) in :attr:`SwitchingPattern.switch_names` order.
    diodes : tuple[bool, ...]
        Diode states (True = conducting) in :attr:`SwitchingPattern.diode_names` order.
    """

    start: float
    duration: float
    switches: tuple[bool, ...]
    diodes: tuple[bool, ...]

    @property
    def state(self) -> tuple[tuple[bool, ...], tuple[bool, ...]]:
        return (self.switches, self.diodes)


@dataclass(frozen=True)
class SwitchingPattern:
    """The sequence of switch/diode configurations over one orbit (k periods).

    Attributes
    ----------
    switch_names, diode_names : tuple[str, ...]
    segments : tuple[PatternSegment, ...]
        In time order from the first sampling instant; consecutive segments differ.
    period : float
        Total duration, s (k T for a period-k orbit).
    """

    switch_names: tuple[str, ...]
    diode_names: tuple[str, ...]
    segments: tuple[PatternSegment, ...]
    period: float

    @property
    def signature(self) -> tuple:
        """The configuration sequence without durations, for comparing orbits.

        The sampling instant is not an event: when the first and last segments have the same
        configuration they are one interval that wraps around, and are counted once.
        """
        states = [s.state for s in self.segments]
        if len(states) > 1 and states[0] == states[-1]:
            states = states[:-1]
        return tuple(states)

    def label(self, seg: PatternSegment) -> str:
        parts = [f"{n} {'on' if on else 'off'}" for n, on in zip(self.switch_names,
                                                                   seg.switches, strict=True)]
        parts += [f"{n} {'on' if on else 'off'}" for n, on in zip(self.diode_names,
                                                                   seg.diodes, strict=True)]
        return ", ".join(parts) if parts else "single mode"

    def __str__(self) -> str:
        if not self.segments:
            return "(empty)"
        return " -> ".join(f"[{self.label(s)}] {s.duration / self.period:.4g}"
                           for s in self.segments) + f" (fractions of {self.period:.6g} s)"

    def to_list(self) -> list[dict]:
        """JSON-ready segments: ``{"start", "duration", "switches": {...}, "diodes": {...}}``."""
        return [{
            "start": float(s.start), "duration": float(s.duration),
            "switches": {n: ("on" if on else "off")
                         for n, on in zip(self.switch_names, s.switches, strict=True)},
            "diodes": {n: ("on" if on else "off")
                       for n, on in zip(self.diode_names, s.diodes, strict=True)},
        } for s in self.segments]


class Map(ABC):
    """A discrete-time map ``x -> P(x)`` on ``dim`` named states, built for one parameter.

    Attributes
    ----------
    state_names : tuple[str, ...]
    param : float or None
        Value of the parameter the map was built for.
    param_name : str or None
    x0 : ndarray or None
        A natural initial state (circuit initial conditions), if known.
    """

    state_names: tuple[str, ...] = ()
    param: float | None = None
    param_name: str | None = None
    # A natural starting state (a circuit's IC= / .ic values), shape (n,), if known.
    x0: np.ndarray | None = None

    @property
    def dim(self) -> int:
        return len(self.state_names)

    @abstractmethod
    def __call__(self, x) -> np.ndarray:
        """One iterate ``P(x)``, shape (dim,). Raises :class:`MapError` on failure."""

    def power(self, x, k: int) -> np.ndarray:
        """``P^k(x)``, shape (dim,)."""
        y = np.asarray(x, dtype=float)
        for _ in range(int(k)):
            y = self(y)
        return y

    def iterate(self, x, n: int) -> np.ndarray:
        """The orbit ``x, P(x), ..., P^n(x)``, shape (n + 1, dim)."""
        out = np.empty((int(n) + 1, self.dim))
        out[0] = np.asarray(x, dtype=float)
        for k in range(1, int(n) + 1):
            out[k] = self(out[k - 1])
        return out

    def sample(self, x, skip: int, record: int, probes: Sequence[str] | None = None
               ) -> Samples:
        """Discard ``skip`` iterates, then record probes at the next ``record`` iterates.

        Parameters
        ----------
        x : array_like, shape (dim,)
        skip, record : int
            Transient iterates discarded, iterates recorded (``P^{skip+1}(x)`` ...
            ``P^{skip+record}(x)``).
        probes : sequence of str, optional
            Names to record; this base implementation knows the state names only.

        Returns
        -------
        Samples
            Never raises for a failing run: ``ok`` is False and missing rows are NaN.
        """
        names = tuple(probes) if probes else self.state_names
        lower = [s.lower() for s in self.state_names]
        try:
            cols = [lower.index(p.lower()) for p in names]
        except ValueError:
            raise KeyError(f"unknown probe(s) in {names}; this map knows "
                           f"{', '.join(self.state_names)}") from None
        values = np.full((int(record), len(names)), np.nan)
        y = np.asarray(x, dtype=float)
        try:
            y = self.power(y, skip)
            for k in range(int(record)):
                y = self(y)
                values[k] = y[cols]
        except MapError as exc:
            return Samples(names, values, np.full(self.dim, np.nan), False, str(exc))
        return Samples(names, values, y, True)

    def pattern(self, x, k: int = 1) -> SwitchingPattern | None:
        """Switching pattern of the k iterates from ``x``; None for maps without switches."""
        return None

    def natural_scale(self) -> np.ndarray | None:
        """Typical magnitude of each state (for finite-difference steps), or None."""
        return None

    def jacobian(self, x, k: int, scale: np.ndarray, rel_step: float = 1e-5) -> np.ndarray:
        """Jacobian of ``P^k`` at ``x``, shape (dim, dim): central differences with steps
        ``rel_step * scale``."""
        return central_jacobian(lambda v: self.power(v, k), np.asarray(x, dtype=float),
                                np.asarray(scale, dtype=float), rel_step)


def central_jacobian(fn: Callable[[np.ndarray], np.ndarray], x: np.ndarray,
                     scale: np.ndarray, rel_step: float = 1e-5) -> np.ndarray:
    """Central finite-difference Jacobian of ``fn`` at ``x``.

    Parameters
    ----------
    fn : callable
        ``fn(x) -> y``, shapes (n,) -> (m,).
    x : ndarray, shape (n,)
    scale : ndarray, shape (n,)
        State scale; the step of column i is ``rel_step * scale[i]``.
    rel_step : float

    Returns
    -------
    ndarray, shape (m, n)
    """
    x = np.asarray(x, dtype=float)
    cols = []
    for i in range(x.size):
        d = rel_step * scale[i]
        xp, xm = x.copy(), x.copy()
        xp[i] += d
        xm[i] -= d
        cols.append((np.asarray(fn(xp)) - np.asarray(fn(xm))) / (2 * d))
    return np.stack(cols, axis=1) if cols else np.zeros((0, 0))


class FunctionMap(Map):
    """A map given by a Python function (tests, toy models, analytic references).

    Parameters
    ----------
    fn : callable
        ``fn(x) -> x'`` on arrays of shape (dim,). Must be picklable (a module-level function
        or a ``functools.partial`` of one) to be used with worker processes.
    state_names : sequence of str
    param : float, optional
    param_name : str, optional
    scale : array_like, shape (dim,), optional
        Typical state magnitudes.
    """

    def __init__(self, fn: Callable[[np.ndarray], np.ndarray], state_names: Sequence[str],
                 param: float | None = None, param_name: str | None = None,
                 scale=None):
        self.fn = fn
        self.state_names = tuple(state_names)
        self.param = param
        self.param_name = param_name
        self._scale = None if scale is None else np.asarray(scale, dtype=float)

    def __call__(self, x) -> np.ndarray:
        y = np.asarray(self.fn(np.asarray(x, dtype=float)), dtype=float).reshape(self.dim)
        if not np.all(np.isfinite(y)):
            raise MapError(f"non-finite image {y} of {x}", x, self.param)
        return y

    def natural_scale(self) -> np.ndarray | None:
        return self._scale


# ---------------------------------------------------------------------------------------------
# Maps of a switched LCS
# ---------------------------------------------------------------------------------------------


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


class _LcsMapBase(Map):
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
        sw_names = tuple(s.name for s in self.system.switches)
        d_names = tuple(self.system.diodes)
        t = res.t
        nstep = len(t) - 1
        # Switch mode during step j (from t[j] to t[j+1]): the last event strictly before
        # t[j+1] (an event at a step boundary belongs to the next step).
        mode0 = tuple(res.modes_visited[0]) if res.modes_visited else ()
        ev_t = np.array([e[0] for e in res.events], dtype=float)
        ev_modes = [tuple(e[1]) for e in res.events]
        tol = _TIME_MATCH * self.h
        idx = np.searchsorted(ev_t, t[1:] - tol, side="left") - 1
        modes = [mode0 if i < 0 else ev_modes[i] for i in idx.tolist()]
        if self.diode_probes:
            cur = np.stack([res[p] for p in self.diode_probes], axis=1)[1:]
            thr = _DIODE_RTOL * max(float(np.max(np.abs(cur))) if cur.size else 0.0, 1.0) \
                + _DIODE_ATOL
            dio = cur > thr
        else:
            dio = np.zeros((nstep, 0), dtype=bool)
        segs: list[PatternSegment] = []
        cur_state = None
        seg_start = t_start
        for j in range(nstep):
            state = (modes[j], tuple(bool(v) for v in dio[j]))
            if state != cur_state:
                if cur_state is not None:
                    segs.append(PatternSegment(seg_start - t_start, float(t[j]) - seg_start,
                                               *cur_state))
                cur_state = state
                seg_start = float(t[j])
        if cur_state is not None:
            segs.append(PatternSegment(seg_start - t_start, t_end - seg_start, *cur_state))
        return SwitchingPattern(sw_names, d_names, tuple(segs), t_end - t_start)


class StroboscopicMap(_LcsMapBase):
    """``P(x) = x(t0 + T)`` from ``x(t0) = x`` for a T-periodically driven switched LCS.

    Parameters
    ----------
    system : SwitchedLCS
    signals : sequence of Signal
        Resolved source waveforms, one per input (:func:`lcs.signals.resolve`).
    period : float
        Sampling period T, s (the period of the drive or ramp).
    h : float
        Time step, s. Choose T/h an integer so that every period has the same grid.
    theta : float
        Moreau θ.
    t0 : float
        Sampling phase, s.
    param, param_name : optional
        The parameter value this map was built for (bookkeeping only).
    on_inconsistent : callable, optional
        Passed to :func:`~lcs.moreau.simulate` (state jump of an inconsistent start).
    options : MoreauOptions, optional
    diode_probes : sequence of str
        One probe per diode (in ``system.diodes`` order) that is positive while the diode
        conducts, e.g. ``"i(D1)"``; used for the switching pattern.
    scale : array_like, shape (n,), optional
        Typical state magnitudes (A, V).
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # False once a run lacked a period sample (then every step is stored and the
        # samples are picked by time); save_at makes that a safety net only.
        self._save_at_ok = True

    def __call__(self, x) -> np.ndarray:
        return self.power(x, 1)

    def power(self, x, k: int) -> np.ndarray:
        """``P^k(x)`` by one simulation over k periods (only the end state is kept)."""
        k = int(k)
        x = np.asarray(x, dtype=float)
        if k == 0:
            return x.copy()
        t_end = self.t0 + k * self.period
        bps = self.t0 + self.period * np.arange(1, k + 1)
        res = self._simulate(x, self.t0, t_end, every=_EVERY_NONE, breakpoints=bps)
        if not res.ok:
            raise self._fail(res, x)
        return res.x_final.copy()

    def _run_sampled(self, x, n: int, probes: Sequence[str] | None
                     ) -> tuple[np.ndarray, np.ndarray, SimulationResult]:
        """Simulate n periods in one call; return (instants reached, values (n+1, q), result).

        The period instants are ``save_at`` points of the run (stored whatever ``every``
        says, and step boundaries). Rows of ``values`` at instants not reached (failed run)
        are NaN.
        """
        t_end = self.t0 + n * self.period
        targets = self.t0 + self.period * np.arange(n + 1)
        bps = targets[1:]
        tol = _TIME_MATCH * self.h
        attempts = [_EVERY_NONE, 1] if self._save_at_ok else [1]
        for every in attempts:
            res = self._simulate(x, self.t0, t_end, every=every, breakpoints=bps,
                                 probes=probes, save_at=bps)
            t = res.t
            pos = np.clip(np.searchsorted(t, targets - tol), 0, len(t) - 1)
            hit = np.abs(t[pos] - targets) <= tol
            t_ok = t[-1] if len(t) else self.t0
            reached = targets <= t_ok + tol
            if np.all(hit[reached]) or every == 1:
                values = np.full((n + 1, res.y.shape[1]), np.nan)
                good = reached & hit
                values[good] = res.y[pos[good]]
                return good, values, res
            self._save_at_ok = False
        raise AssertionError("unreachable")  # pragma: no cover

    def iterate(self, x, n: int) -> np.ndarray:
        """``x, P(x), ..., P^n(x)``, shape (n + 1, n_states), from one simulation."""
        n = int(n)
        good, values, res = self._run_sampled(x, n, None)
        if not res.ok or not np.all(good):
            raise self._fail(res, x)
        values[0] = np.asarray(x, dtype=float)
        return values

    def sample(self, x, skip: int, record: int, probes: Sequence[str] | None = None
               ) -> Samples:
        """Probes at the period instants ``t0 + k T``, k = skip+1 .. skip+record (one run).

        ``probes`` may name any probe the system knows (``v(out)``, ``i(D1)``, states);
        default: the states. A probe is evaluated at the end of the step landing on the
        period instant.
        """
        skip, record = int(skip), int(record)
        names = tuple(probes) if probes else self.state_names
        x = np.asarray(x, dtype=float)
        try:
            good, values, res = self._run_sampled(x, skip + record, list(names))
        except MapError as exc:  # calibration run failed
            return Samples(names, np.full((record, len(names)), np.nan),
                           np.full(self.dim, np.nan), False, str(exc))
        rows = values[skip + 1:]
        if not res.ok:
            return Samples(names, rows, np.full(self.dim, np.nan), False,
                           str(self._fail(res, x)))
        return Samples(names, rows, res.x_final.copy(), True)

    def trajectory(self, x, k: int = 1, probes: Sequence[str] | None = None
                   ) -> SimulationResult:
        """The full run over k periods from ``x`` (every step stored)."""
        k = int(k)
        bps = self.t0 + self.period * np.arange(1, k + 1)
        res = self._simulate(x, self.t0, self.t0 + k * self.period, every=1, breakpoints=bps,
                             probes=probes)
        if not res.ok:
            raise self._fail(res, x)
        return res

    def pattern(self, x, k: int = 1) -> SwitchingPattern:
        """Switch and diode configurations over k periods from ``x``."""
        probes = list(self.state_names) + list(self.diode_probes)
        res = self.trajectory(x, k, probes)
        return self._pattern_from(res, self.t0, self.t0 + int(k) * self.period)


# ---------------------------------------------------------------------------------------------
# Event maps
# ---------------------------------------------------------------------------------------------


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


class EventMap(_LcsMapBase):
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
        ``J_Σ = (DF V) V'`` has the Poincaré map's multipliers plus one exact 0.
        """
        z = np.asarray(z, dtype=float)
        scale = np.asarray(scale, dtype=float)
        n1 = z.size

        def fk(v):
            return self.power(v, k)

        f0 = fk(z)
        # Tangent vectors of Σ near f0 (scaled): one-sided differences of the images.
        T = np.empty((n1, n1))
        for i in range(n1):
            e = np.zeros(n1)
            e[i] = rel_step * scale[i]
            T[:, i] = (fk(z + e) - f0) / scale / rel_step
        U, sv, _ = np.linalg.svd(T)
        V = U[:, : n1 - 1]  # the section has one dimension less than the extended state
        cols = []
        for j in range(n1 - 1):
            d = rel_step * scale * V[:, j]
            cols.append((fk(z + d) - fk(z - d)) / scale / (2 * rel_step))
        JV = np.stack(cols, axis=1)  # (n+1, n): D F applied to V, scaled coordinates
        Js = JV @ V.T
        return Js * scale[:, None] / scale[None, :]

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
            thr = _DIODE_RTOL * max(float(np.max(np.abs(cur))), 1.0) + _DIODE_ATOL
            on = cur > thr
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

