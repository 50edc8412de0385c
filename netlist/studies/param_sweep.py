"""Parameter sweeps and Monte Carlo runs of a netlist, measured over the steady state.

:func:`run_sweep` simulates a netlist at every point of a grid of ``.param`` values (SPICE's
``.step param``), and/or many times with component values drawn within tolerances (Monte
Carlo), measures each run over its steady-state window (:mod:`netlist.studies.measure`) and
returns a :class:`~lcs.analysis.tables.SweepTable`. The runs are tasks of the engine of
:mod:`lcs.analysis.parallel`: local processes by default, or the workers of a Dask scheduler.

Tolerances (``R1=5%``, ``C*=10%``, ``L1=2u``): a pattern matches element names (glob,
case-insensitive: ``C*`` is every capacitor, ``X1.*`` everything in instance X1); an element
takes the tolerance of a pattern naming it exactly, else of the first pattern that matches it.
``5%`` is relative to the element's value at that point, a number without ``%`` is absolute
(ohm, henry, farad, volt, ampere, or the gain's unit). Elements with a value: R, L, C, DC
voltage and current sources, E F G H (gain) and K (coupling). Each run draws every toleranced
element independently:

* ``uniform`` (default): value + U(-tol, +tol);
* ``gaussian``: value + N(0, (tol/3)²), i.e. the tolerance is 3 σ (99.7 % of the draws
  within it), not truncated.

The draws are made up front, here, from ``numpy.random.default_rng(seed)`` (a matrix of runs
by toleranced elements, in run order then netlist order), so that a seed gives the same runs
whatever executes them and however the runs are split into tasks. With a parameter grid, run k
uses the same draws at every grid point (common random numbers), every grid point has its own
nominal run, and the statistics are per grid point (:meth:`SweepTable.point_statistics`).

Every run is checked for a settled window (:func:`netlist.studies.measure.settling`): a run whose
measured probes still drift over it gets a message, ``settled`` False in the table, and a note
that names it and suggests a longer stop time.
"""

from __future__ import annotations

import fnmatch
import itertools
import math
import secrets
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from lcs import interrupt
from lcs.analysis.parallel import task_engine
from lcs.analysis.tables import SweepTable

from ..circuit import TIME_STEPPED_RESISTOR, Circuit, CurrentSource, Resistor, VoltageSource
from ..errors import Diagnostic, NetlistError
from ..netlist_bytes import file_stamps
from ..parser import parse_string
from ..time_function import TimeValue
from ..time_value import time_resistor_line, time_resistor_nodes, time_resistor_segments
from ..units import format_eng, parse_number
from .measure import (
    Measurement,
    evaluate,
    parse_measurements,
    probe_unit,
    settling,
    steady_state_period,
    steady_state_window,
)
from .sweep import check_period_multiple, resolve_period
from .transient import simulate_circuit

__all__ = [
    "DISTRIBUTIONS",
    "MAX_RUNS",
    "MAX_VALUES",
    "Tolerance",
    "draw_deviations",
    "grid_values",
    "match_tolerances",
    "parse_sweep_param",
    "parse_tolerance",
    "run_sweep",
]

DISTRIBUTIONS = ("uniform", "gaussian")

#: Values of one swept parameter at most (as a netlist's ``.step``).
MAX_VALUES = 100_000
#: Runs of one sweep at most (grid points times Monte Carlo runs, nominal runs included):
#: the list of runs is built up front, and a typo such as ``1e9`` should not exhaust memory.
MAX_RUNS = 1_000_000

# Element kind -> the attribute a tolerance changes, and its unit.
_VALUE_ATTR = {"R": ("value", "Ω"), "L": ("value", "H"), "C": ("value", "F"),
               "V": ("dc", "V"), "I": ("dc", "A"), "E": ("gain", ""), "F": ("gain", ""),
               "G": ("gain", "S"), "H": ("gain", "Ω"), "K": ("k", "")}


def _usage(message: str, hint: str = "") -> NetlistError:
    # Named after the command, as its own option errors are ("pelcs sweep: error: ...").
    return NetlistError(Diagnostic(message=message, hint=hint), file="pelcs sweep")


# -- parameters ------------------------------------------------------------------------------


def _number(text: str, what: str) -> float:
    from .sweep import parse_value

    return parse_value(text, what)


def parse_sweep_param(text: str, default_count: int | None = None
                      ) -> tuple[str, float | np.ndarray]:
    """``NAME=START:STOP[:COUNT]`` (COUNT values, ``default_count`` when not given; required
    when None), ``NAME=V1,V2,...`` or ``NAME=VALUE``.

    Returns
    -------
    (str, float or ndarray)
        The name and a fixed value, or the swept values (shape (COUNT,)).
    """
    name, sep, val = text.partition("=")
    name, val = name.strip(), val.strip()
    if not sep or not name or not val:
        raise _usage(f"bad parameter {text!r}",
                     "expected NAME=START:STOP[:COUNT], NAME=V1,V2,... or NAME=VALUE, e.g. "
                     "duty=0.2:0.8:7")
    from .sweep import range_misspelling

    if (error := range_misspelling(text)) is not None:
        raise error
    if ":" in val:
        parts = val.split(":")
        if len(parts) not in (2, 3) or (len(parts) == 2 and default_count is None):
            raise _usage(f"parameter range {text!r}: expected NAME=START:STOP[:COUNT]",
                         "e.g. duty=0.2:0.8:7 (7 values from 0.2 to 0.8)")
        start, stop = _number(parts[0], f"range {text!r}"), _number(parts[1], f"range {text!r}")
        count = _number(parts[2], f"range {text!r}") if len(parts) == 3 else default_count
        if count != int(count) or count < 1:
            raise _usage(f"range {text!r}: COUNT must be an integer >= 1")
        if count > MAX_VALUES:
            raise _usage(f"range {text!r}: {count:.6g} values, at most {MAX_VALUES} per "
                         "parameter (as a .step)", "give a smaller COUNT")
        return name, grid_values(start, stop, int(count))
    if "," in val and not val.startswith(("{", "'")):
        items = [v for v in val.split(",") if v.strip()]
        if len(items) > MAX_VALUES:
            raise _usage(f"parameter {name}: {len(items)} values, at most {MAX_VALUES}")
        return name, np.array([_number(v, f"parameter {name}") for v in items])
    return name, _number(val, f"parameter {name}")


def grid_values(start: float, stop: float, count: int) -> np.ndarray:
    """``count`` values from ``start`` to ``stop``, rounded to 12 significant digits.

    ``np.linspace(0.2, 0.8, 4)`` holds ``0.6000000000000001``; rounded, the values print as
    they would be typed (and as a netlist's ``.step`` gives them).
    """
    return np.array([float(f"{v:.12g}") for v in np.linspace(start, stop, count)])


# -- tolerances ------------------------------------------------------------------------------


@dataclass(frozen=True)
class Tolerance:
    """``PATTERN=AMOUNT`` (``R1=5%``, ``C*=10%``, ``L1=2u``).

    Attributes
    ----------
    pattern : str
        Glob over element names, case-insensitive.
    amount : float
        Fraction (relative) or SI value (absolute).
    relative : bool
    text : str
        As given.
    """

    pattern: str
    amount: float
    relative: bool
    text: str

    @property
    def exact(self) -> bool:
        return not any(c in self.pattern for c in "*?[")

    def describe(self, unit: str = "") -> str:
        if self.relative:
            return f"±{100 * self.amount:.4g} %"
        return f"±{self.amount:.4g} {unit}".rstrip()


def parse_tolerance(text: str) -> Tolerance:
    """Parse ``PATTERN=AMOUNT``; ``AMOUNT`` is ``N%`` (relative) or a number (absolute)."""
    pattern, sep, amount = text.partition("=")
    pattern, amount = pattern.strip(), amount.strip()
    hint = "expected PATTERN=N% (relative) or PATTERN=VALUE (absolute), e.g. R1=5% or 'C*=10%'"
    if not sep or not pattern or not amount:
        raise _usage(f"bad tolerance {text!r}", hint)
    relative = amount.endswith("%")
    num = parse_number(amount[:-1].strip() if relative else amount)
    if num is None or not np.isfinite(num) or num < 0:
        raise _usage(f"tolerance {text!r}: {amount!r} is not a non-negative number", hint)
    return Tolerance(pattern, float(num) / 100 if relative else float(num), relative, text)


def _tolerable(el, circuit: Circuit) -> bool:
    if el.kind not in _VALUE_ATTR or "#" in el.name:
        # (pelcs's parts of one element: a resistor stepped in time varies as a whole, a
        # B source's limiter not at all)
        return False
    group = circuit.built_group(el)
    if group is not None and group.construct != TIME_STEPPED_RESISTOR:
        return False  # (a limiter's output buffer: it keeps the B source's name, no value)
    if isinstance(el, (VoltageSource, CurrentSource)):
        return el.waveform is None
    return True


def match_tolerances(circuit: Circuit, tolerances: Sequence[Tolerance]
                     ) -> list[tuple[str, Tolerance]]:
    """``(element name, tolerance)`` for every toleranced element, in netlist order.

    Raises
    ------
    NetlistError
        A pattern given twice; a pattern that matches no element with a value (D, S and
        PULSE/SIN/... sources have none), that names one exactly and it has no value, or
        whose every element has a tolerance naming it exactly.
    """
    diags = []
    first: dict[str, Tolerance] = {}
    for tol in tolerances:
        key = tol.pattern.lower()
        if key in first:
            was = first[key]
            what = was.pattern if was.exact else f"pattern {was.pattern!r}"
            diags.append(Diagnostic(
                message=f"{what} is given twice: --tolerance {was.text!r} and "
                f"--tolerance {tol.text!r}", hint="give one tolerance per element or pattern"))
        else:
            first[key] = tol
    if diags:
        raise NetlistError(diags, file="pelcs sweep")
    tolerable = [el for el in circuit.elements if _tolerable(el, circuit)]
    out: list[tuple[str, Tolerance]] = []
    used: set[int] = set()
    for el in tolerable:
        key = el.name.lower()
        chosen = None
        for i, tol in enumerate(tolerances):
            if tol.exact and tol.pattern.lower() == key:
                chosen = i
                break
        if chosen is None:
            for i, tol in enumerate(tolerances):
                if fnmatch.fnmatchcase(key, tol.pattern.lower()):
                    chosen = i
                    break
        if chosen is not None:
            used.add(chosen)
            out.append((el.name, tolerances[chosen]))
    names = ", ".join(el.name for el in tolerable) or "none"
    exact = {t.pattern.lower(): t for t in tolerances if t.exact}
    for i, tol in enumerate(tolerances):
        if i in used:
            continue
        try:
            el = circuit.element(tol.pattern) if tol.exact else None
        except KeyError:
            el = None
        hint = f"elements with a value: {names}"
        if el is not None:
            msg = (f"tolerance {tol.text!r}: {el.name} has no value to vary"
                   + (" (a source with a waveform)" if el.kind in "VI" else ""))
        else:
            matches = [e for e in circuit.elements
                       if fnmatch.fnmatchcase(e.name.lower(), tol.pattern.lower())]
            # Elements that an exact tolerance takes: the pattern varies none of them.
            taken = [e for e in matches if _tolerable(e, circuit) and e.name.lower() in exact]
            if taken:
                msg = (f"tolerance {tol.text!r} varies nothing: it matches only "
                       + ", ".join(f"{e.name} (given as {exact[e.name.lower()].text!r})"
                                   for e in taken)
                       + (" and elements without a value" if len(taken) < len(matches)
                          else ""))
                hint = "an element takes the tolerance that names it exactly: drop the " \
                    "pattern, or the exact tolerance"
            else:
                msg = (f"tolerance {tol.text!r} matches "
                       + ("only elements without a value" if matches else "no element"))
        diags.append(Diagnostic(message=msg, hint=hint))
    if diags:
        raise NetlistError(diags, file="pelcs sweep")
    return out


def draw_deviations(matched: Sequence[tuple[str, Tolerance]], runs: int, seed: int,
                    distribution: str = "uniform") -> np.ndarray:
    """Deviations of every run, shape (runs, len(matched)): fractions for relative
    tolerances, SI values for absolute ones.

    ``uniform``: U(-tol, tol); ``gaussian``: N(0, (tol/3)²). One matrix from
    ``numpy.random.default_rng(seed)``, row = run.
    """
    if distribution not in DISTRIBUTIONS:
        raise _usage(f"unknown distribution {distribution!r}",
                     f"use {' or '.join(DISTRIBUTIONS)}")
    rng = np.random.default_rng(int(seed))
    amounts = np.array([tol.amount for _, tol in matched], dtype=float)
    shape = (int(runs), len(matched))
    if distribution == "uniform":
        unit = rng.uniform(-1.0, 1.0, size=shape)
        return unit * amounts
    return rng.standard_normal(size=shape) * (amounts / 3.0)


# -- one run ---------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Job:
    """What every run shares (picklable, sent to the workers)."""

    text: str
    path: str
    fixed: tuple[tuple[str, float], ...]
    measures: tuple[Measurement, ...]
    tstop: float | None
    step: float | None
    theta: float | None
    period: float | str | None
    toleranced: tuple[tuple[str, bool], ...]  # (element, relative)


def _parse(text: str, path: str, params: tuple[tuple[str, float], ...]) -> Circuit:
    # (kept while the files it includes are as they were: a long-lived process edits them)
    key = (text, path, params)
    kept = _PARSED.get(key)
    if kept is not None and kept[0] == file_stamps(kept[1].files[1:]):
        return kept[1]
    circuit = parse_string(text, file=path, params=dict(params) or None)
    _PARSED[key] = (file_stamps(circuit.files[1:]), circuit)
    while len(_PARSED) > 16:
        del _PARSED[next(iter(_PARSED))]
    return circuit


_PARSED: dict = {}  # (text, path, params) -> (the includes' stamps, circuit)


class _DrawError(ValueError):
    """A drawn value the element cannot take; ``values`` are all the run's draws (for its
    row in the table: the value that failed is seen there)."""

    def __init__(self, message: str, values: list[float]):
        super().__init__(message)
        self.values = values


def _perturbed(circuit: Circuit, toleranced, deviations) -> tuple[Circuit, list[float]]:
    """A copy of the circuit with the deviations applied, and the values used.

    Raises
    ------
    _DrawError
        An R, L or C drawn as zero or with the opposite sign of its nominal value.
    """
    if deviations is None:
        return circuit, []
    elements = list(circuit.elements)
    groups = dict(circuit.built_groups)
    index = {el.name.lower(): i for i, el in enumerate(elements)}
    used = []
    problem = ""
    for (name, relative), d in zip(toleranced, deviations, strict=True):
        i = index[name.lower()]
        el = elements[i]
        attr = _VALUE_ATTR[el.kind][0]
        nominal = float(getattr(el, attr))
        value = nominal * (1.0 + d) if relative else nominal + d
        # A negative R (a model of an active device) may vary; only the draws that change
        # the element's sign or make it zero change what it is.
        if el.kind in "RLC" and not value * nominal > 0 and not problem:
            what = "zero" if value == 0 else f"{value:.6g}, the opposite sign of"
            problem = f"{el.name} drawn as {what} its nominal {nominal:.6g}: narrow its " \
                "tolerance"
        elements[i] = replace(el, **{attr: value})
        if isinstance(el, Resistor) and el.time_value is not None:
            # a resistor stepped in time (netlist.time_value): its every value varies, so
            # its segments (differences of its values) scale with a relative draw
            tv = TimeValue(el.time_value.times, tuple(
                v * (1.0 + d) if relative else v + d for v in el.time_value.values))
            elements[i] = replace(elements[i], time_value=tv)
            if relative:
                for part in time_resistor_segments(circuit, el):
                    j = index[part.key]
                    elements[j] = replace(elements[j], value=elements[j].value * (1.0 + d))
            # (and the line ngspice would be given for it)
            group = circuit.built_group(el)
            groups[group.name.lower()] = replace(group, line=time_resistor_line(
                el.name, time_resistor_nodes(circuit, el), tv))
        used.append(value)
    if problem:
        raise _DrawError(problem, used)
    return replace(circuit, elements=elements, built_groups=groups), used


def _run_point(job: _Job, params: tuple[tuple[str, float], ...], deviations
               ) -> tuple[np.ndarray, list[float], bool, str, tuple]:
    """Measure one run: (values, component values used, ok, message, window info).

    The window info of a run that succeeded is ``(window, periods, period, source,
    unsettled, t_end)``: ``unsettled`` holds the :class:`~netlist.studies.measure.Settling` of the
    measurements whose probe still drifts over the window.
    """
    nm = len(job.measures)
    nan = np.full(nm, np.nan)
    drawn = [np.nan] * len(job.toleranced) if deviations is not None else []
    try:
        circuit = _parse(job.text, job.path, tuple(sorted({**dict(job.fixed),
                                                           **dict(params)}.items())))
        circuit, used = _perturbed(circuit, job.toleranced, deviations)
        drawn = used or drawn
        probes = list(dict.fromkeys(m.probe for m in job.measures))
        res = simulate_circuit(circuit, tstop=job.tstop, step=job.step, theta=job.theta,
                               probes=probes)
        period = resolve_period(circuit, job.period) if job.period is not None else None
        if period is not None:
            check_period_multiple(circuit, period)
    except (NetlistError, ValueError) as exc:
        msg = exc.message if isinstance(exc, NetlistError) else str(exc)
        if isinstance(exc, _DrawError):
            drawn = exc.values
        return nan, drawn, False, msg, ()
    if res.error is not None:
        return nan, drawn, False, f"simulation failed at t = {res.error.time:.6g} s: " \
            f"{res.error.message}", ()
    if len(res.t) < 2:
        return nan, drawn, False, "the run has fewer than two time points", ()
    per, source = steady_state_period(circuit, res, period)
    window, n = steady_state_window((float(res.t[0]), float(res.t[-1])), per)
    checks = tuple(c for c in settling(res, job.measures, window, per) if not c.settled)
    return (evaluate(res, job.measures, window), drawn, True, "",
            (window, n, per, source, checks, float(res.t[-1])))


def _sweep_task(task, report) -> list:
    job, points = task
    out = []
    for params, deviations in points:
        out.append(_run_point(job, params, deviations))
        report(1)
    return out


# -- the sweep -------------------------------------------------------------------------------


def _read(source) -> tuple[str, str]:
    """(text, path) of a netlist path or netlist text."""
    from pathlib import Path

    s = str(source)
    if "\n" in s:
        return s, "<string>"
    p = Path(s)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise NetlistError(Diagnostic(message=f"cannot read the netlist: {exc.strerror or exc}",
                                      hint="check the path"), file=s) from None
    try:
        # (absolute: the runs may go to workers started in another directory, where a
        # relative .include would otherwise be looked for)
        return data.decode("utf-8"), str(p.absolute())
    except UnicodeDecodeError:
        raise NetlistError(Diagnostic(message="the netlist is not UTF-8 text",
                                      hint="save it as UTF-8"), file=s) from None


def run_sweep(
    source,
    measures: Sequence[str],
    *,
    params: Mapping[str, float | Sequence[float]] | None = None,
    tolerances: Sequence[str | Tolerance] = (),
    runs: int = 0,
    seed: int | None = None,
    distribution: str = "uniform",
    tstop: float | None = None,
    step: float | None = None,
    theta: float | None = None,
    period: float | str | None = None,
    workers: int | None = None,
    scheduler=None,
    progress: bool = False,
) -> SweepTable:
    """Sweep ``.param`` values and/or draw component values, and measure every run.

    Parameters
    ----------
    source : str or path
        Netlist file (or netlist text, with a line break).
    measures : sequence of str
        ``FUNCTION(PROBE)`` (:data:`netlist.studies.measure.FUNCTIONS`), e.g. ``"mean(v(out))"``.
    params : mapping, optional
        ``.param`` values: a number (fixed) or a sequence (swept). The grid is every
        combination, the first swept parameter varying slowest. The netlist's ``.step
        param`` lines add swept parameters (after these) unless ``params`` sets them.
    tolerances : sequence of str or Tolerance
        ``"R1=5%"``, ``"C*=10%"``... (Monte Carlo; needs ``runs``).
    runs : int
        Monte Carlo runs per grid point (0: none).
    seed : int, optional
        Random seed; default a fresh one (reported in the table: pass it to repeat the runs).
    distribution : str
        ``"uniform"`` or ``"gaussian"`` (tolerance = 3 σ).
    tstop, step : float, optional
        Stop time and step, s (default: the netlist's ``.tran``).
    theta : float, optional
        Default: 0.5, or 1 where θ < 1 is not reliable
        (:func:`netlist.studies.transient.choose_theta`).
    period : float or str, optional
        Steady-state period, s, or a ``.param`` name (evaluated per point); default the
        period of the source at a switch's control (as ``pelcs check``).
    workers : int, optional
        Local processes (default all cores).
    scheduler : None, str or distributed.Client, optional
        Where the runs go (:func:`lcs.analysis.parallel.task_engine`); the table is the same.
    progress : bool

    Returns
    -------
    SweepTable
        One row per (grid point, run); failed runs have NaN measurements and a message. A
        Monte Carlo run also simulates every grid point with the nominal values
        (``table.nominal``). Runs whose window has not settled
        (:func:`netlist.studies.measure.settling`) have ``settled`` False, a message and a note.

    Raises
    ------
    NetlistError
        Bad netlist, parameter, measurement, probe or tolerance, a non-positive stop time or
        step, a step longer than the run, more than :data:`MAX_VALUES` values of a parameter
        or :data:`MAX_RUNS` runs (checked at the first grid point before any run).
    """
    t_wall = time.perf_counter()
    text, path = _read(source)
    params = dict(params or {})
    # The netlist's .step lines sweep what params does not set (a given value wins, and the
    # note says so: the netlist's author meant that parameter to be swept).
    given = {k.lower(): k for k in params}
    step_notes = []
    for name, values in parse_string(text, file=path).steps:
        key = given.get(name.lower())
        if key is None:
            params[name] = np.asarray(values, dtype=float)
            step_notes.append(f"{name}: {len(values)} values from the netlist's .step")
            continue
        v = params[key]
        now = f"{key} = {float(np.ravel(v)[0]):.6g}" if np.ndim(v) == 0 else \
            f"{key} over {np.size(v)} given value(s)"
        step_notes.append(f"{now} replaces the netlist's .step of {name} ({len(values)} "
                          "values)")
    fixed = {k: float(v) for k, v in params.items() if np.ndim(v) == 0}
    swept = {k: np.asarray(v, dtype=float).ravel() for k, v in params.items()
             if np.ndim(v) > 0}
    for k, v in swept.items():
        if v.size == 0:
            raise _usage(f"parameter {k}: no values")
        if v.size > MAX_VALUES:
            raise _usage(f"parameter {k}: {v.size} values, at most {MAX_VALUES}")
    tols = [t if isinstance(t, Tolerance) else parse_tolerance(t) for t in tolerances]
    runs = int(runs)
    if tols and runs < 1:
        raise _usage("tolerances given but no runs", "give --runs N (Monte Carlo runs)")
    if runs and not tols:
        raise _usage("Monte Carlo runs but no tolerance", "give --tolerance, e.g. R1=5%")
    if distribution not in DISTRIBUTIONS:
        raise _usage(f"unknown distribution {distribution!r}",
                     f"use {' or '.join(DISTRIBUTIONS)}")
    if theta is not None and not 0.5 <= float(theta) <= 1.0:
        raise _usage(f"theta {theta}: θ must be in [0.5, 1]")
    n_points = math.prod(v.size for v in swept.values())
    total = n_points * (runs + 1 if runs else 1)
    if total > MAX_RUNS:
        raise _usage(f"{total} runs ({n_points} grid point(s)"
                     + (f" x ({runs} + 1 nominal) runs" if runs else "") + f"), at most "
                     f"{MAX_RUNS}", "sweep fewer values, or split the sweep")

    # Check everything at the first grid point (names, probes, tolerances, times) before any
    # run: an input error is reported as such, not as every run failing.
    first = {**fixed, **{k: float(v[0]) for k, v in swept.items()}}
    circuit = parse_string(text, file=path, params=first or None)
    _check_times(circuit, tstop, step)
    mlist = parse_measurements(list(measures), circuit)
    if period is not None:
        check_period_multiple(circuit, resolve_period(circuit, period))
    matched = match_tolerances(circuit, tols) if tols else []
    if seed is None and runs:
        seed = secrets.randbelow(2**31)
    deviations = draw_deviations(matched, runs, seed, distribution) if runs else None

    job = _Job(text, path, tuple(sorted(fixed.items())), tuple(mlist), tstop, step,
               None if theta is None else float(theta), period,
               tuple((n, t.relative) for n, t in matched))
    names = list(swept)
    grid = list(itertools.product(*swept.values())) if swept else [()]
    points: list[tuple[tuple, np.ndarray | None]] = []
    rows_in: list[list[float]] = []
    labels: list[str] = []
    # Monte Carlo: one nominal run per grid point, so that every point's spread is seen
    # against its own nominal value (run after the drawn ones).
    extra: list[tuple[tuple, np.ndarray]] = []
    extra_labels: list[str] = []
    for combo in grid:
        p = tuple(zip(names, (float(v) for v in combo), strict=True))
        where = " ".join(f"{n}={v:.6g}" for n, v in p)
        if runs:
            for k in range(runs):
                points.append((p, deviations[k]))
                rows_in.append([*combo, k])
                labels.append(f"{where} run {k}".strip())
            extra.append((p, np.zeros(len(matched))))
            extra_labels.append(f"nominal at {where}" if where else "nominal")
        else:
            points.append((p, None))
            rows_in.append(list(combo))
            labels.append(where or "the run")
    labels += extra_labels

    all_points = points + extra
    with task_engine(scheduler, workers) as engine:
        n_tasks = max(1, min(len(all_points), 4 * engine.workers))
        chunks = [c for c in np.array_split(np.arange(len(all_points)), n_tasks) if c.size]
        tasks = [(job, [all_points[i] for i in c]) for c in chunks]
        chunk_results = engine.run(_sweep_task, tasks, progress=progress,
                                   total=len(all_points), desc="sweep", unit="run",
                                   partial=True)
        engine_name = engine.description
    # An interrupt (lcs.interrupt) leaves the chunks under way unfinished: their runs are
    # left out of a sweep's table, and are rows "not run" of a Monte Carlo table (whose
    # rows are grid point by grid point, runs rows each).
    finished = np.zeros(len(all_points), dtype=bool)
    results: list = [None] * len(all_points)
    for c, chunk in zip(chunks, chunk_results, strict=True):
        if chunk is not None:
            finished[c] = True
            for i, r in zip(c, chunk, strict=True):
                results[i] = r
    interrupted = not finished.all()
    if interrupted:
        not_run = (np.full(len(mlist), np.nan), [np.nan] * len(matched), False,
                   "not run: the sweep was interrupted", ())
        results = [r if r is not None else not_run for r in results]
    done = [i for i in range(len(all_points)) if finished[i]]
    nominal = np.stack([r[0] for r in results[len(points):]]) if extra else None
    notes = step_notes + _notes([results[i] for i in done], [labels[i] for i in done],
                                int(finished[len(points):].sum()))
    if interrupted:
        signum = interrupt.requested()
        how = f" ({interrupt.signal_name(signum)})" if signum is not None else ""
        notes.insert(0, f"the sweep was interrupted{how} after {len(done)} of "
                     f"{len(all_points)} runs: "
                     + ("the runs not made are rows 'not run' (NaN); the statistics are of "
                        "the finished runs" if runs else "the table holds the finished runs"))
    results = results[:len(points)]
    if interrupted and not runs:
        keep = finished[:len(points)]
        results = [r for r, k in zip(results, keep, strict=True) if k]
        rows_in = [r for r, k in zip(rows_in, keep, strict=True) if k]
        points = [p for p, k in zip(points, keep, strict=True) if k]

    inputs = names + (["run"] if runs else []) + [n for n, _ in matched]
    input_values = np.array([row + list(r[1]) for row, r in zip(rows_in, results,
                                                                strict=True)],
                            dtype=float).reshape(len(points), len(inputs))
    values = np.stack([r[0] for r in results]) if results else np.empty((0, len(mlist)))
    ok = np.array([r[2] for r in results], dtype=bool)
    settled = np.array([r[2] and not r[4][4] for r in results], dtype=bool)
    messages = [r[3] if not r[2] else
                ("not settled: " + _describe(r[4][4]) if r[4][4] else "") for r in results]
    units = {m.text: probe_unit(m.probe) for m in mlist}
    for n, _ in matched:
        units[n] = _VALUE_ATTR[circuit.element(n).kind][1]
    tol_text = [f"{n} {t.describe(units[n])}" + ("" if t.exact else f" ({t.text})")
                for n, t in matched]
    return SweepTable(
        inputs=tuple(inputs), input_values=input_values,
        measures=tuple(m.text for m in mlist), values=values, ok=ok, messages=messages,
        swept=tuple(names), units=units, nominal=nominal, runs=runs,
        seed=int(seed) if runs else None, distribution=distribution if runs else "",
        tolerances=tol_text, notes=notes, wall_time=time.perf_counter() - t_wall,
        engine=engine_name, settled=settled,
        unsettled=[tuple(c.measure for c in r[4][4]) if r[2] else () for r in results],
    )


def _check_times(circuit: Circuit, tstop: float | None, step: float | None) -> None:
    """The stop time and step every run would use: positive, the step within the run."""
    tran = circuit.tran
    if tstop is not None and not (np.isfinite(tstop) and tstop > 0):
        raise _usage(f"--tstop {tstop:g}: the stop time must be positive",
                     "e.g. --tstop 20m")
    if step is not None and not (np.isfinite(step) and step > 0):
        raise _usage(f"--step {step:g}: the time step must be positive", "e.g. --step 0.1u")
    t_end = tstop if tstop is not None else tran.tstop if tran is not None else None
    if t_end is None:
        raise _usage("no .tran in the netlist and no stop time given",
                     "give --tstop, e.g. --tstop 20m")
    h = step if step is not None else (tran.tmax or tran.tstep) if tran is not None else None
    if h is not None and h > t_end:
        given = "--step" if step is not None else "the .tran step"
        raise _usage(f"{given} {format_eng(h, 's')} exceeds the stop time "
                     f"{format_eng(t_end, 's')}",
                     "give a smaller --step" if step is not None else "give a longer --tstop")


def _excess(check) -> float:
    """How many times its limit an unsettled measurement's drift is."""
    return check.drift / check.limit if check.limit > 0 else math.inf


def _describe(checks) -> str:
    """The worst unsettled measurement of a run, in words."""
    c = max(checks, key=_excess)
    unit = probe_unit(c.probe)
    return (f"{c.measure}: the averages of {c.probe} over {c.parts} spread "
            f"{format_eng(c.drift, unit)}, more than {c.basis}")


def _spice_time(t: float) -> str:
    return format_eng(float(f"{t:.2g}"), "").replace(" ", "").replace("µ", "u")


def _notes(results, labels: Sequence[str], nominal: int) -> list[str]:
    """The window, the failed runs and the runs not settled, in words (``nominal``: the
    Monte Carlo nominal runs, the last of ``results``)."""
    notes = []
    windows = [r[4] for r in results if r[2]]
    if windows:
        (a, b), n, per, source = windows[0][:4]
        same = all(w[1] == n and w[2] == per for w in windows)
        if n and per:
            what = (f"the last {n} period(s) of {format_eng(per, 's')} ({source})")
        else:
            what = f"the last 20 % of the run ({source})"
        notes.append(f"measured over {what}" + ("" if same else
                                                 " at the first point; per point elsewhere"))
    failed = [i for i, r in enumerate(results) if not r[2]]
    if failed:
        first = results[failed[0]]
        notes.append(f"{len(failed)} run(s) failed (NaN in the table); first ("
                     f"{labels[failed[0]]}): {first[3]}")
    loose = [i for i, r in enumerate(results) if r[2] and r[4][4]]
    if loose:
        named = "; ".join(labels[i] for i in loose[:5])
        if len(loose) > 5:
            named += f" and {len(loose) - 5} more"
        worst = max(loose, key=lambda i: max(map(_excess, results[i][4][4])))
        t_end = max(results[i][4][5] for i in loose)
        count = f"{len(loose)} of {len(results)} run(s)" + (
            f", {len(results) - nominal} drawn + {nominal} nominal," if nominal else "")
        notes.append(f"not settled: {count} ({named}): "
                     f"{_describe(results[worst][4][4])}; the measurement still drifts with the "
                     f"start-up transient: simulate longer than {format_eng(t_end, 's')}, "
                     f"e.g. --tstop {_spice_time(2 * t_end)}")
    return notes
