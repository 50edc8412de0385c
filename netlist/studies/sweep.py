"""Maps of circuits for the bifurcation analysis: one map per parameter value.

:class:`CircuitMapFactory` is the picklable recipe ``value -> map`` that the analysis cores
(:mod:`lcs.analysis`) call, in this process or in worker processes: it re-parses the netlist
with the parameter overridden (a few ms), formulates it once and wraps it in a
:class:`~lcs.analysis.maps.StroboscopicMap` (or an :class:`~lcs.analysis.maps.EventMap`).
Built maps are cached per process, so Newton iterations and bisections at one value reuse the
formulated modes.

Parameter specifications (command line): ``NAME=START:STOP:COUNT`` (sweeps),
``NAME=START:STOP`` (continuation) and ``NAME=VALUE`` (fixed overrides), with SPICE numbers
(``400u``, ``24``).
"""

from __future__ import annotations

import functools
import itertools
import re
from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from lcs.analysis.event_map import EventSpec
from lcs.analysis.maps import EventMap, StroboscopicMap
from lcs.integrators.moreau.integrator import MoreauOptions
from lcs.model import LCS
from lcs.theory.wellposed import state_jump

from ..circuit import Circuit
from ..dialect import split_top_level
from ..errors import Diagnostic, NetlistError
from ..netlist_bytes import file_stamps
from ..parser import parse_file, parse_overrides, parse_string
from ..time_value import frozen_at
from ..units import format_eng, parse_number
from .measure import defined_period
from .transient import check_probes, choose_theta, transient_setup

__all__ = [
    "CircuitMapFactory",
    "ParamRange",
    "check_period_multiple",
    "circuit_map",
    "parse_grid",
    "parse_range",
    "parse_starts",
    "parse_state",
    "parse_value",
    "resolve_period",
    "split_params",
]


def _usage(message: str, hint: str = "", where: str = "pelcs") -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file=where)


@dataclass(frozen=True)
class ParamRange:
    """A parameter range ``NAME=START:STOP[:COUNT]``.

    Attributes
    ----------
    name : str
    start, stop : float
    count : int or None
        Number of values (``linspace(start, stop, count)``), None when not given.
    """

    name: str
    start: float
    stop: float
    count: int | None = None

    def values(self, default_count: int = 50) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.count or default_count)


def _number(text: str, what: str) -> float:
    v = parse_number(text.strip())
    if v is None:
        try:
            v = next(iter(parse_overrides([f"x={text.strip()}"]).values()))
        except NetlistError:
            v = None
    if v is None or not np.isfinite(v):
        raise _usage(f"{what}: {text!r} is not a number", "use a number with optional SPICE "
                     "suffix, e.g. 24, 400u, 1.5k")
    return float(v)


def parse_value(text: str, what: str) -> float:
    """A number with optional SPICE suffix (``400u``, ``24``, ``1.5k``) or a constant
    expression; NetlistError naming ``what`` otherwise."""
    return _number(text, what)


def parse_state(text: str, states: Sequence[str], default) -> np.ndarray:
    """``"v(C1)=12,i(L1)=1.5"`` -> a full state vector, others from ``default``.

    Parameters
    ----------
    text : str
        Comma-separated ``STATE=VALUE`` items (commas inside parentheses belong to names).
    states : sequence of str
        State names (case-insensitive match).
    default : array_like, shape (n,)
    """
    x = np.array(default, dtype=float).copy()
    lower = [s.lower() for s in states]
    for item in split_top_level(text):
        name, sep, val = item.partition("=")
        if not sep or name.strip().lower() not in lower:
            raise _usage(f"bad state assignment {item!r}",
                         f"expected STATE=VALUE with STATE one of {', '.join(states)}")
        x[lower.index(name.strip().lower())] = _number(val, f"state {name.strip()}")
    return x


def parse_starts(text: str, states: Sequence[str], default) -> list[np.ndarray]:
    """``"v(C1)=8:16:5,i(L1)=1"`` -> starting states: every combination of the values.

    Each comma-separated item is ``STATE=VALUE`` or ``STATE=START:STOP:COUNT`` (COUNT values
    from START to STOP); states not named come from ``default``. The list runs over the
    first range slowest.

    Returns
    -------
    list of ndarray, each shape (n,)
    """
    lower = [s.lower() for s in states]
    axes: list[tuple[int, np.ndarray]] = []
    for item in split_top_level(text):
        name, sep, val = item.partition("=")
        key = name.strip().lower()
        if not sep or key not in lower:
            raise _usage(f"bad starting state {item!r}",
                         f"expected STATE=VALUE or STATE=START:STOP:COUNT with STATE one of "
                         f"{', '.join(states)}")
        if ":" in val:
            r = parse_range(f"{name.strip()}={val}", need_count=True)
            axes.append((lower.index(key), r.values()))
        else:
            axes.append((lower.index(key), np.array([_number(val, f"state {name.strip()}")])))
    base = np.array(default, dtype=float)
    out = []
    for combo in itertools.product(*(v for _, v in axes)):
        x = base.copy()
        for (i, _), v in zip(axes, combo, strict=True):
            x[i] = v
        out.append(x)
    return out


def parse_range(text: str, *, need_count: bool = False) -> ParamRange:
    """Parse ``NAME=START:STOP[:COUNT]``.

    Raises
    ------
    NetlistError
        Malformed text, non-numeric bounds, a count below 2, or a missing count when
        ``need_count``.
    """
    name, sep, rng = text.partition("=")
    parts = rng.split(":")
    if not sep or not name.strip() or len(parts) not in (2, 3):
        raise _usage(f"bad parameter range {text!r}",
                     "expected NAME=START:STOP:COUNT, e.g. vin=20:35:300"
                     if need_count else "expected NAME=START:STOP, e.g. vin=20:30")
    start = _number(parts[0], f"range {text!r}")
    stop = _number(parts[1], f"range {text!r}")
    count = None
    if len(parts) == 3:
        c = _number(parts[2], f"range {text!r}")
        if c != int(c) or c < 2:
            raise _usage(f"range {text!r}: COUNT must be an integer >= 2")
        count = int(c)
    elif need_count:
        raise _usage(f"range {text!r} has no COUNT", "expected NAME=START:STOP:COUNT")
    if start == stop:
        raise _usage(f"range {text!r} is empty (START = STOP)")
    return ParamRange(name.strip(), start, stop, count)


_OTHER_RANGE = re.compile(r"^\s*([^.\s][^\s]*?)\s*(?:\.\.\.?|…)\s*([^\s:]+?)"
                          r"(?:\s*[:/,]\s*(\d+))?\s*$")


def range_misspelling(text: str) -> NetlistError | None:
    """The error for a range written ``NAME=A..B`` (or ``A...B``, ``A…B``, with an optional
    ``:N``), with "did you mean NAME=A:B[:N]"; None for any other text."""
    name, sep, val = text.partition("=")
    m = _OTHER_RANGE.match(val) if sep else None
    if m is None:
        return None
    good = f"{name.strip()}={m.group(1)}:{m.group(2)}" + (f":{m.group(3)}" if m.group(3) else "")
    return _usage(f"bad parameter range {text!r}: did you mean {good}?",
                  "a range is NAME=START:STOP[:N] (N values from START to STOP)")


def split_params(items: Sequence[str]) -> tuple[list[ParamRange], dict[str, float]]:
    """Split ``--param`` items into ranges (values containing ':') and fixed overrides."""
    ranges, fixed = [], []
    for item in items or []:
        if (error := range_misspelling(item)) is not None:
            raise error
        (ranges if ":" in item.partition("=")[2] else fixed).append(item)
    return [parse_range(r) for r in ranges], parse_overrides(fixed)


def parse_grid(text: str, default_count: int | None = None
               ) -> list[tuple[str, float, float, int]]:
    """Parse ``"v(C1)=A:B:N,i(L1)=C:D:M"`` -> ``[(name, lo, hi, count), ...]`` (two axes);
    an axis without ``:N`` gets ``default_count`` cells (required when None)."""
    axes = []
    for part in split_top_level(text):
        if (error := range_misspelling(part)) is not None:
            raise error
        r = parse_range(part.strip(), need_count=default_count is None)
        axes.append((r.name, r.start, r.stop, int(r.count or default_count)))
    if len(axes) != 2:
        raise _usage(f"--grid {text!r}: expected two axes",
                     'e.g. --grid "v(C1)=0:20:200,i(L1)=0:4:200"')
    return axes


def resolve_period(circuit: Circuit, text: str | float) -> float:
    """The sampling period: a number (``400u``), or a ``.param`` name or ``{expr}`` of it."""
    if isinstance(text, (int, float)):
        value = float(text)
    else:
        s = text.strip().strip("{}").strip()
        value = circuit.params.get(s.lower())
        if value is None:
            value = parse_number(s)
        if value is None:
            try:
                from ..expressions import parse_expression

                value = parse_expression(s).evaluate(dict(circuit.params))
            except Exception:  # noqa: BLE001 - any failure is the same input error
                value = None
    if value is None or not (np.isfinite(value) and value > 0):
        raise _usage(f"--period {text!r} is not a positive time",
                     "give seconds (e.g. 400u) or the name of a .param (e.g. tp)")
    return float(value)


def check_period_multiple(circuit: Circuit, period: float) -> None:
    """Refuse a period that the netlist's own switching period does not divide.

    Every analysis that samples once a period (orbits, continuation, bifurcation diagrams,
    basins, small-signal responses) maps the state from ``t0`` to ``t0 + period`` with the
    sources as they are from ``t0``: unless the sources repeat every ``period``, the next
    period starts from another phase, so the map is not the same map twice, and a state that
    returns to itself after one ``period`` is no periodic orbit (the buck switched every
    20 µs sampled at 13 µs gave a "period-1 orbit" of 76.9 kHz).

    Parameters
    ----------
    circuit : Circuit
    period : float
        The sampling period asked for, s.

    Raises
    ------
    NetlistError
        When the netlist defines one switching period
        (:func:`netlist.studies.measure.defined_period`) and ``period`` is not a whole multiple
        of it (to a relative 1e-6). A netlist that defines none, or several, is not checked.
    """
    try:
        own, origin = defined_period(circuit)
    except NetlistError:
        return  # (none, or several: nothing to check against)
    ratio = period / own
    if abs(ratio - round(ratio)) > 1e-6 * max(1.0, ratio) or round(ratio) < 1:
        raise NetlistError(Diagnostic(
            message=f"--period {format_eng(period, 's')} is not a multiple of the period the "
                    f"netlist defines, {format_eng(own, 's')} (the {origin}): the sources, so "
                    f"the steady state, do not repeat every {format_eng(period, 's')}",
            hint=f"leave --period out (T = {format_eng(own, 's')}), or give a multiple of it "
                 "for a subharmonic orbit"), file=circuit.file)


class _StateJump:
    """Picklable ``on_inconsistent`` handler: the passive state jump with the circuit energy.

    The passivity certificate of each mode is computed once (it is the expensive part, and a
    cell map over a grid of states starts from many inconsistent states).
    """

    def __init__(self, energy: np.ndarray | None):
        self.energy = energy
        self._reports: dict[int, tuple[LCS, object]] = {}

    def __getstate__(self):
        return {"energy": self.energy}

    def __setstate__(self, state):
        self.energy = state["energy"]
        self._reports = {}

    def __call__(self, lcs: LCS, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        from lcs.theory.passivity import check_passivity

        entry = self._reports.get(id(lcs))
        if entry is None or entry[0] is not lcs:
            entry = (lcs, check_passivity(lcs, energy=self.energy))
            self._reports[id(lcs)] = entry
        return state_jump(lcs, x, u, entry[1], energy=self.energy).x_plus


def circuit_map(
    circuit: Circuit,
    period: float | str | None,
    *,
    step: float | None = None,
    theta: float | None = None,
    t0: float = 0.0,
    event: str | None = None,
    param: float | None = None,
    param_name: str | None = None,
    options: MoreauOptions | None = None,
    max_periods: int = 20,
    method: str = "moreau",
) -> StroboscopicMap | EventMap:
    """The stroboscopic (or event) map of a parsed circuit.

    Parameters
    ----------
    circuit : Circuit
    period : float or str or None
        T, s, or a ``.param`` name; None: the period the netlist defines
        (:func:`netlist.studies.measure.defined_period`, named in the map's ``notes``).
    step : float, optional
        Time step h, s; default the ``.tran`` step (TMAX or TSTEP), reduced if needed so that
        T/h is an integer (every period then has the same grid).
    theta : float, optional
        Default 0.5, or 1 where θ < 1 is not reliable
        (:func:`netlist.studies.transient.choose_theta`; the map's ``notes`` say why).
    t0 : float
        Sampling phase, s.
    event : str, optional
        ``"S1:on"``, ``"D1:on"``, ``"v(out)>12"``...: an event map instead.
    method : str
        ``"moreau"`` (θ time-stepping, finite-difference Jacobians) or ``"exact"``
        (:class:`lcs.analysis.exact_map.ExactStroboscopicMap`: exact flows and events, exact
        Jacobian; stroboscopic maps only).

    Returns
    -------
    StroboscopicMap or EventMap
        With ``x0`` attribute set to the circuit's initial state (``IC=``/``.ic``) and the
        diode probes ``i(D)`` for switching patterns; ``period_note`` says which period the
        netlist defined when ``period`` is None (else None).
    """
    # (one value of each resistor stepped in time: a periodic orbit has one load)
    circuit, frozen = frozen_at(circuit, t0)
    period_notes = []
    if period is None:
        T, origin = defined_period(circuit)
        period_notes.append(f"T = {format_eng(T, 's')}: the {origin} (no --period given)")
    else:
        T = resolve_period(circuit, period)
        check_period_multiple(circuit, T)
    if step is None:
        tran = circuit.tran
        if tran is None:
            raise _usage("no .tran in the netlist and no step given", "pass --step")
        step = tran.tmax if tran.tmax else tran.tstep
    step = float(step)
    if step > T:
        raise _usage(f"time step {step:g} s exceeds the period {T:g} s", "choose a smaller step")
    # A whole number of steps per period.
    nper = int(np.ceil(T / step - 1e-9))
    h = T / nper
    tstop = circuit.tran.tstop if circuit.tran is not None else T
    setup = transient_setup(circuit, tstop=max(tstop, T), step=h)
    system = setup.system
    if not len(system.states):
        # no inductor or capacitor: nothing is carried from one period to the next
        raise NetlistError(Diagnostic(
            message="the circuit has no state (no inductor or capacitor): no periodic orbit "
                    "or map to analyse; its waveforms follow the sources instant by instant",
            hint="pelcs simulate FILE (its steady state is the transient itself)"),
            file=circuit.file)
    if method == "exact":
        if event:
            raise _usage("--event needs the Moreau method", "drop --method exact")
        from lcs.analysis.exact_map import ExactStroboscopicMap
        from lcs.simulation.switches import initially_on

        key0 = tuple(initially_on(s.options) for s in system.switches)
        em = ExactStroboscopicMap(system, setup.signals, T, t0=t0, key0=key0, param=param,
                                  param_name=param_name,
                                  diode_probes=[f"i({d})" for d in system.diodes])
        em.x0 = setup.x0.copy()
        em.period_note = period_notes[0] if period_notes else None
        em.notes[:0] = period_notes + frozen + list(setup.notes)
        return em
    if method != "moreau":
        raise _usage(f"unknown method {method!r}", "moreau or exact")
    theta, theta_note = choose_theta(setup, theta)
    kwargs = dict(theta=theta, t0=t0, param=param, param_name=param_name,
                  on_inconsistent=_StateJump(setup.energy), options=options,
                  diode_probes=[f"i({d})" for d in system.diodes])
    if event:
        spec = EventSpec.parse(event)
        if spec.kind == "probe":  # read as a run's probe: a current pelcs does not compute
            check_probes(circuit, [spec.name])
        m = EventMap(system, setup.signals, T, h, event, max_periods=max_periods, **kwargs)
    else:
        m = StroboscopicMap(system, setup.signals, T, h, **kwargs)
    m.x0 = setup.x0.copy()
    m.setup = setup  # (its knees: check_orbit_knees)
    if setup.knees:  # (each bifurcation value's record: lcs.analysis.bifurcation)
        m.check_attractor = functools.partial(attractor_problem, m)
    m.period_note = period_notes[0] if period_notes else None
    m.notes[:0] = (period_notes + frozen + list(setup.notes)
                   + ([theta_note] if theta_note else []))
    return m


def check_orbit_knees(m, orbit) -> list[str]:
    """Check the knees of a converged orbit's circuit (a core's field, knee capacitors, a
    MOSFET channel that would conduct backwards or saturate: :mod:`netlist.knee`) on a
    transient run of its ``order`` periods from its first point, at the map's step and θ;
    the notes it gives.

    Raises
    ------
    NetlistError
        The orbit leaves a knee: where and when (from the orbit's sampling instant).
    """
    setup = getattr(m, "setup", None)
    if setup is None or not setup.knees or not orbit.converged:
        return []
    if _off_phase(m):
        return [_OFF_PHASE]
    try:
        notes = knees_over(m, orbit.points[0], orbit.order)
    except NetlistError as exc:
        raise NetlistError([replace(d, message=f"the periodic orbit ({orbit.order} period(s) "
                                    f"from its first point, t from 0): {d.message}")
                            for d in exc.diagnostics], exc.file) from None
    return [f"orbit, checked over its {orbit.order} period(s): {note}" for note in notes]


def knees_over(m, x, periods: int) -> list[str]:
    """The knees' notes of a transient run of ``periods`` periods of map ``m``'s circuit
    from state ``x`` at its sampling phase, at the map's step and θ (the callers check the
    phase is a whole number of periods from t = 0, where the netlist's sources start).

    Raises
    ------
    NetlistError
        The run leaves a knee (:func:`netlist.knee.check_knees`).
    """
    setup = m.setup
    from .transient import run_setup

    n = len(setup.system.states)
    # (from the state, as the map runs: not from the DC operating point that a .tran
    # without UIC starts the netlist's own run at)
    res = run_setup(replace(setup, x0=np.asarray(x[:n], dtype=float),
                            t_stop=periods * m.period, t_save=0.0, operating_point=False),
                    theta=m.theta, probes=[])
    return [note for note in res.notes if note not in setup.notes
            and any(note.startswith(f"{k.name}:") for k in setup.knees)]


_OFF_PHASE = ("the knees (netlist.knee) are not checked at a sampling phase t0 that is not a "
              "whole number of periods")


def _off_phase(m) -> bool:
    return abs(m.t0 / m.period - round(m.t0 / m.period)) > 1e-9


def knee_notes(m, periods: int) -> list[str]:
    """The note of a bifurcation diagram on its knees: each value's attractor checked on a run
    of ``periods`` periods (:func:`attractor_problem`), or not checked (an off phase)."""
    setup = getattr(m, "setup", None)
    if setup is None or not setup.knees:
        return []
    if _off_phase(m):
        return [_OFF_PHASE]
    names = ", ".join(dict.fromkeys(k.name for k in setup.knees))
    return [f"the knees ({names}: netlist.knee) are checked "
            f"on a run of {periods} period(s) from each value's last state; a value whose run "
            "leaves one failed, with the reason"]


def attractor_problem(m, x, periods: int) -> str | None:
    """Why map ``m``'s attractor through state ``x`` is not the circuit's over ``periods``
    periods (a knee it leaves: :func:`knees_over`), or None: the check
    :func:`lcs.analysis.bifurcation.bifurcation_diagram` makes of each value's record."""
    if _off_phase(m):
        return None  # (knee_notes says so)
    try:
        knees_over(m, x, periods)
    except NetlistError as exc:
        return (f"a run of {periods} period(s) from its state at the sampling instant (t "
                f"from 0): " + "; ".join(d.message for d in exc.diagnostics))
    return None


@dataclass(frozen=True)
class CircuitMapFactory:
    """Picklable recipe ``factory(value) -> map`` of a netlist file.

    Attributes
    ----------
    path : str
        Netlist file.
    period : float or str or None
        Sampling period, s, or a ``.param`` name (evaluated per parameter value); None: the
        period the netlist defines (found per parameter value).
    param : str or None
        The parameter that ``value`` sets (None: ``value`` is ignored).
    overrides : tuple of (str, float)
        Fixed ``.param`` overrides.
    step : float or None
        Time step, s (default from ``.tran``).
    theta : float or None
        None: 0.5, or 1 where θ < 1 is not reliable (see :func:`circuit_map`).
    t0 : float
    event : str or None
        Event section (see :func:`circuit_map`); None for the stroboscopic map.
    text : str or None
        The netlist text, parsed instead of reading ``path`` (which then only names the
        file in messages and locates ``.include`` files): see :meth:`portable`.
    """

    path: str
    period: float | str | None
    param: str | None = None
    overrides: tuple[tuple[str, float], ...] = ()
    step: float | None = None
    theta: float | None = None
    t0: float = 0.0
    event: str | None = None
    text: str | None = field(default=None, repr=False)
    method: str = "moreau"

    def portable(self) -> CircuitMapFactory:
        """A copy that carries the netlist text, for workers on other machines.

        Dask workers then need the netlist file only for its ``.include``/``.lib`` files,
        and a long-lived worker never reuses a map it cached for an older version of the
        file (the text is part of the factory's identity). The file stays as it is if it
        cannot be read as UTF-8 here (the error then comes from the worker's parse).
        """
        if self.text is not None:
            return self
        try:
            text = Path(self.path).read_bytes().decode("utf-8")
        except (OSError, UnicodeDecodeError):
            return self
        return replace(self, text=text)

    def params(self, value: float | None) -> dict[str, float]:
        p = dict(self.overrides)
        if self.param is not None and value is not None:
            p[self.param] = float(value)
        return p

    def circuit(self, value: float | None = None) -> Circuit:
        p = self.params(value)
        if self.text is not None:
            return parse_string(self.text, file=self.path, params=p or None)
        return parse_file(self.path, params=p or None)

    def __call__(self, value: float | None = None) -> StroboscopicMap | EventMap:
        # (kept by the stamps of the files read: a long-lived process, a design script, edits
        # the netlist or one of its includes between calls)
        value = None if value is None else float(value)
        key = (self, value)
        kept = _MAPS.get(key)
        if kept is not None and kept[0] == file_stamps(kept[1]):
            _MAPS.move_to_end(key)
            return kept[2]
        circuit = self.circuit(value)
        files = circuit.files if self.text is None else circuit.files[1:]
        m = circuit_map(circuit, self.period, step=self.step, theta=self.theta, t0=self.t0,
                        event=self.event, param=value, param_name=self.param,
                        method=self.method)
        _MAPS[key] = (file_stamps(files), files, m)
        while len(_MAPS) > _MAPS_KEPT:
            _MAPS.popitem(last=False)
        return m


_MAPS: OrderedDict = OrderedDict()  # (factory, value) -> (stamps, files, map)
_MAPS_KEPT = 16
