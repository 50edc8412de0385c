"""Measurements of a run over its steady-state window: ``mean(v(out))``, ``ripple(i(L1))``...

A measurement is ``FUNCTION(PROBE)`` with a probe as :func:`netlist.studies.transient.check_probes`
knows them (``v(out)``, ``v(a,b)``, ``i(L1)``, ``d(S1)``) and one of the functions of
:data:`FUNCTIONS`. Everything but ``final`` is taken over the *steady-state window*, the one
``pelcs check`` uses: the last whole periods of the steady state, up to 10 and at most a
quarter of the run, where the period is the PULSE or SIN period of the source at a switch's
control, else the longest source period, else the recurrence of the pelcs switching
(free-running converters); without any period, the last 20 % of the run.
(:mod:`ngspice_checks.compare` has the same rule for its comparisons.)

The window's ends are interpolated into the samples, so that a mean over whole periods is
exact up to the quadrature of the samples.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lcs.results import SimulationResult
from lcs.signals import Pulse, Sin

from ..circuit import GROUND, Circuit, CurrentSource, VoltageSource
from ..dialect import split_top_level
from ..errors import Diagnostic, NetlistError
from ..probes import probe_unit  # (re-exported: the unit of a measurement is its probe's)
from .transient import check_probes

__all__ = [
    "FUNCTIONS",
    "SETTLE_LEVEL",
    "SETTLE_SHAPE",
    "Measurement",
    "Settling",
    "evaluate",
    "parse_measurements",
    "probe_unit",
    "settling",
    "defined_period",
    "steady_state_period",
    "steady_state_window",
]

#: Measurement functions: name -> what it gives (for help texts and errors).
FUNCTIONS = {
    "mean": "time average over the window",
    "avg": "same as mean",
    "rms": "root mean square over the window",
    "ripple": "peak-to-peak (max - min) over the window",
    "pp": "same as ripple",
    "min": "minimum over the window",
    "max": "maximum over the window",
    "final": "value at the end of the run",
}

_MEASURE_RE = re.compile(r"^\s*([A-Za-z_]\w*)\s*\((.*)\)\s*$", re.S)


@dataclass(frozen=True)
class Measurement:
    """``func(probe)``.

    Attributes
    ----------
    func : str
        One of :data:`FUNCTIONS` (aliases resolved: ``avg`` -> ``mean``, ``pp`` -> ``ripple``).
    probe : str
        The probe as the user wrote it (stripped).
    text : str
        ``func(probe)`` as the user wrote the function, for column names.
    """

    func: str
    probe: str
    text: str

    @property
    def unit(self) -> str:
        """SI unit of the measured value (that of the probe)."""
        return probe_unit(self.probe)


def _usage(message: str, hint: str = "") -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file="pelcs")


def parse_measurements(items: Sequence[str], circuit: Circuit) -> list[Measurement]:
    """Parse ``--measure`` items (each may hold several, comma-separated at the top level).

    Raises
    ------
    NetlistError
        One diagnostic per malformed item or unknown function; unknown probes as
        :func:`~netlist.studies.transient.check_probes` reports them (with the nodes and elements).
    """
    out: list[Measurement] = []
    diags: list[Diagnostic] = []
    functions = ", ".join(f for f in FUNCTIONS)
    for item in items:
        opened, closed = item.count("("), item.count(")")
        if opened != closed:
            # Checked before the split: an unclosed '(' would swallow the rest of the item,
            # and the probe check would then blame a probe 'v(out' instead.
            diags.append(Diagnostic(
                message=f"bad measurement {item.strip()!r}: unbalanced parentheses "
                f"({opened} '(' and {closed} ')')",
                hint="close every parenthesis, e.g. mean(v(out)) or ripple(v(a,b)); quote the "
                "argument in the shell"))
            continue
        for text in split_top_level(item):
            m = _MEASURE_RE.match(text)
            bare_probe = m is not None and m.group(1).lower() in ("v", "i", "d") and \
                "(" not in m.group(2)
            if m is None or not m.group(2).strip() or bare_probe:
                diags.append(Diagnostic(
                    message=f"bad measurement {text!r}: expected FUNCTION(PROBE)"
                    + (" (this is a probe without a function)" if bare_probe else ""),
                    hint=f"e.g. mean(v(out)) or ripple(i(L1)); functions: {functions}"))
                continue
            func = m.group(1).lower()
            if func not in FUNCTIONS:
                diags.append(Diagnostic(
                    message=f"unknown measurement function {m.group(1)!r} in {text!r}",
                    hint=f"functions: {functions}"))
                continue
            func = {"avg": "mean", "pp": "ripple"}.get(func, func)
            out.append(Measurement(func, m.group(2).strip(),
                                   f"{m.group(1)}({m.group(2).strip()})"))
    if diags:
        raise NetlistError(diags, file="pelcs")
    if not out:
        raise _usage("nothing to measure", "give --measure FUNCTION(PROBE), e.g. "
                     "--measure 'mean(v(out))'")
    # Unknown probes: the same error as pelcs simulate gives.
    check_probes(circuit, [m.probe for m in out])
    seen: set[str] = set()
    for m in out:
        if m.text in seen:
            raise _usage(f"measurement {m.text!r} is given twice")
        seen.add(m.text)
    return out


# -- the steady-state window ------------------------------------------------------------------


def _source_period(wave) -> float | None:
    if isinstance(wave, Pulse) and wave.per:
        return float(wave.per)
    if isinstance(wave, Sin) and wave.freq:
        return 1.0 / float(wave.freq)
    return None


def _periodic_sources(circuit: Circuit) -> list[tuple[VoltageSource | CurrentSource, float]]:
    """The V and I sources with a PULSE or SIN period shorter than the run's TSTOP."""
    tstop = circuit.tran.tstop if circuit.tran is not None else math.inf
    sources = []
    for el in circuit.elements:
        if isinstance(el, (VoltageSource, CurrentSource)) and el.waveform is not None:
            per = _source_period(el.waveform)
            if per is not None and 0 < per < tstop:
                sources.append((el, per))
    return sources


def _control_source_period(circuit: Circuit, sources) -> tuple[float, str] | None:
    """The period of the first voltage source directly across a switch's control terminals
    (it sets that switch's switching period), and where it comes from."""
    for sw in circuit.of_kind("S"):
        ctrl = set(sw.control)
        for el, per in sources:
            if isinstance(el, VoltageSource) and (
                set(el.nodes) == ctrl or (GROUND in ctrl and set(el.nodes) & ctrl - {GROUND}
                                          and GROUND in el.nodes)
            ):
                kind = "PULSE" if isinstance(el.waveform, Pulse) else "SIN"
                return per, f"{kind} period of {el.name} (control of {sw.name})"
    return None


def _latch_clocks(circuit: Circuit) -> list[tuple[float, str]]:
    """The clock periods of the latched switches (``LATCH=1 PERIOD=T`` on the ``.model``)."""
    out = []
    for sw in circuit.of_kind("S"):
        model = circuit.models.get(sw.model.lower()) if sw.model else None
        params = {k.lower(): v for k, v in model.params.items()} if model else {}
        per = params.get("period")
        if params.get("latch") and per and float(per) > 0:
            out.append((float(per), f"clock of the latched switch {sw.name} (PERIOD=)"))
    return out


def defined_period(circuit: Circuit) -> tuple[float, str]:
    """The switching period the netlist defines, for the analyses that sample once a period.

    The PULSE or SIN period of the source across a switch's control (as
    :func:`steady_state_period`), else the one period that the latched switches' clocks and
    the periodic sources (a PWM ramp) all share.

    Returns
    -------
    (float, str)
        Period, s, and where it comes from (``"PULSE period of Vg (control of S1)"``).

    Raises
    ------
    NetlistError
        When the netlist defines no period, or several different ones.
    """
    sources = _periodic_sources(circuit)
    found = _control_source_period(circuit, sources)
    if found is not None:
        return found
    candidates = _latch_clocks(circuit) + [
        (per, f"{'PULSE' if isinstance(el.waveform, Pulse) else 'SIN'} period of {el.name}")
        for el, per in sources]
    hint = "pass --period T (seconds, e.g. 10u, or a .param name)"
    if not candidates:
        raise NetlistError(Diagnostic(
            message="the netlist defines no switching period: no PULSE or SIN source drives "
                    "a switch, no latched switch has a clock, no source is periodic",
            hint=hint), file=circuit.file)
    periods = sorted({per for per, _ in candidates})
    if periods[-1] - periods[0] > 1e-9 * periods[-1]:
        listed = "; ".join(f"{per:g} s ({origin})" for per, origin in candidates)
        raise NetlistError(Diagnostic(
            message=f"the switching period is ambiguous: the netlist defines {listed}",
            hint=hint), file=circuit.file)
    per, origin = candidates[0]
    if len(candidates) > 1:
        origin += f", as {', '.join(o for _, o in candidates[1:])}"
    return per, origin


def steady_state_period(circuit: Circuit, result: SimulationResult | None = None,
                        period: float | None = None) -> tuple[float | None, str]:
    """The period of the steady state (s) and where it comes from.

    Parameters
    ----------
    circuit : Circuit
    result : SimulationResult, optional
        A run of the circuit, for free-running converters (recurrence of the last switch
        mode in the second half of the run).
    period : float, optional
        Given by the user: returned as it is.

    Returns
    -------
    (float or None, str)
        Period, s, or None; and a phrase such as ``"PULSE period of Vg (control of S1)"``.
    """
    if period is not None:
        return float(period), "given (--period)"
    sources = _periodic_sources(circuit)
    found = _control_source_period(circuit, sources)
    if found is not None:
        return found
    if sources:
        el, per = max(sources, key=lambda s: s[1])
        kind = "PULSE period" if isinstance(el.waveform, Pulse) else "SIN period"
        return per, f"{kind} of {el.name} (longest source period)"
    if result is not None and len(result.events) >= 4:
        last = result.events[-1][1]
        starts = np.array([t for t, mode in result.events if mode == last])
        half = starts[starts >= 0.5 * (result.t[-1] + result.t[0])]
        if len(half) >= 3:
            return float(np.median(np.diff(half))), "median recurrence of the last switch " \
                "mode (free-running)"
    return None, "no periodic source or switching: last 20 % of the run"


def steady_state_window(span: tuple[float, float], period: float | None
                        ) -> tuple[tuple[float, float], int]:
    """The last whole periods of ``span`` (up to 10, at most a quarter of it).

    Parameters
    ----------
    span : (float, float)
        Start and end of the run, s.
    period : float or None
        Steady-state period, s.

    Returns
    -------
    ((float, float), int)
        The window, s, and the number of whole periods in it (0: the last 20 % of the run,
        without a period or when the run is shorter than one).
    """
    t0, t1 = span
    if period is not None and period > 0:
        n = min(10, int((t1 - t0) / 4.0 / period + 1e-9))
        if n >= 1:
            return (t1 - n * period, t1), n
        if period <= t1 - t0:
            return (t1 - period, t1), 1
    return (t1 - 0.2 * (t1 - t0), t1), 0


def _in_window(t: np.ndarray, y: np.ndarray, a: float, b: float
               ) -> tuple[np.ndarray, np.ndarray]:
    """Samples inside [a, b] with both ends interpolated in."""
    sel = (t > a) & (t < b)
    tt = np.concatenate([[a], t[sel], [b]])
    yy = np.concatenate([[np.interp(a, t, y)], y[sel], [np.interp(b, t, y)]])
    return tt, yy


def _average(tt: np.ndarray, yy: np.ndarray, a: float, b: float) -> float:
    """Time average over [a, b] of the samples :func:`_in_window` gives (trapezoidal)."""
    return np.trapezoid(yy, tt) / (b - a)


def _rms(tt: np.ndarray, yy: np.ndarray, a: float, b: float) -> float:
    """RMS over [a, b] of the samples :func:`_in_window` gives (trapezoidal)."""
    return math.sqrt(max(np.trapezoid(yy * yy, tt) / (b - a), 0.0))


def evaluate(result: SimulationResult, measurements: Sequence[Measurement],
             window: tuple[float, float]) -> np.ndarray:
    """The measurements of a run, shape (len(measurements),), in the probes' SI units.

    Parameters
    ----------
    result : SimulationResult
        A run that recorded every measured probe.
    measurements : sequence of Measurement
    window : (float, float)
        The steady-state window, s (:func:`steady_state_window`).
    """
    t = np.asarray(result.t, dtype=float)
    a, b = window
    out = np.empty(len(measurements))
    for k, m in enumerate(measurements):
        y = np.asarray(result[m.probe], dtype=float)
        if m.func == "final":
            out[k] = y[-1]
            continue
        tt, yy = _in_window(t, y, a, b)
        if m.func == "mean":
            out[k] = _average(tt, yy, a, b)
        elif m.func == "rms":
            out[k] = _rms(tt, yy, a, b)
        elif m.func == "ripple":
            out[k] = float(np.max(yy) - np.min(yy))
        elif m.func == "min":
            out[k] = float(np.min(yy))
        elif m.func == "max":
            out[k] = float(np.max(yy))
        else:  # pragma: no cover - parse_measurements admits only FUNCTIONS
            raise ValueError(m.func)
    return out


# -- has the run settled? ---------------------------------------------------------------------

#: A level measurement (mean, rms, final) is taken as settled when the averages of its probe
#: over the successive periods of the window spread by at most this fraction of the probe's
#: RMS over the window: the measurement is then off by less than about that fraction.
SETTLE_LEVEL = 1e-3
#: A shape measurement (ripple, min, max) is taken as settled when the period averages of its
#: probe spread by at most this fraction of the probe's peak-to-peak within one period (its
#: ripple): a drifting signal adds its drift to the ripple, min and max it shows.
SETTLE_SHAPE = 0.1

_SHAPE = ("ripple", "min", "max")


@dataclass(frozen=True)
class Settling:
    """The steady-state check of one measurement (:func:`settling`).

    Attributes
    ----------
    measure : str
        The measurement (``ripple(v(out))``).
    probe : str
    drift : float
        Spread (max - min) of the probe's averages over the parts of the window, in the
        probe's unit.
    limit : float
        The largest spread taken as settled, same unit.
    basis : str
        What the limit is a fraction of, e.g. ``"10 % of its ripple per period (15 mV)"``.
    parts : str
        The parts compared, e.g. ``"the last 10 periods"``.
    """

    measure: str
    probe: str
    drift: float
    limit: float
    basis: str
    parts: str

    @property
    def settled(self) -> bool:
        # (a non-finite drift, from a probe that is not finite, is not a settled window)
        return math.isfinite(self.drift) and not self.drift > self.limit


def settling(result: SimulationResult, measurements: Sequence[Measurement],
             window: tuple[float, float], period: float | None) -> list[Settling]:
    """Whether each measurement's probe has settled over the steady-state window.

    The window is cut into its periods (into the last two periods of the run when the window
    holds only one; into four equal parts without a period) and the probe is averaged over
    each part. In a periodic steady state these averages are equal up to round-off; their
    spread (max - min) is the drift that the measurement still sees. The limit is
    :data:`SETTLE_LEVEL` times the probe's RMS over the window for ``mean``, ``rms`` and
    ``final`` (and for every measurement without a period), and :data:`SETTLE_SHAPE` times its
    median peak-to-peak within one part for ``ripple``, ``min`` and ``max``.

    Parameters
    ----------
    result : SimulationResult
        The run; it recorded every measured probe.
    measurements : sequence of Measurement
    window : (float, float)
        The steady-state window, s (:func:`steady_state_window`).
    period : float or None
        Steady-state period, s.

    Returns
    -------
    list of Settling
        One per measurement; empty when the run is too short to tell (less than two periods).
    """
    from ..units import format_eng

    t = np.asarray(result.t, dtype=float)
    a, b = window
    if period is not None and period > 0:
        count = int(round((b - a) / period))
        if count < 2:
            count, a = 2, b - 2 * period
            if a < t[0] - 1e-12 * max(abs(b), 1.0):
                return []
        edges = a + period * np.arange(count + 1)
        edges[-1] = b
        parts = f"the last {count} periods"
    else:
        count = 4
        edges = np.linspace(a, b, count + 1)
        parts = "four quarters of the window (no period)"
    out = []
    cache: dict[str, tuple[float, float, float]] = {}
    for m in measurements:
        if m.probe not in cache:
            y = np.asarray(result[m.probe], dtype=float)
            means, spans = [], []
            for lo, hi in zip(edges[:-1], edges[1:], strict=True):
                tt, yy = _in_window(t, y, lo, hi)
                means.append(_average(tt, yy, lo, hi))
                spans.append(float(np.max(yy) - np.min(yy)))
            tt, yy = _in_window(t, y, edges[0], edges[-1])
            rms = _rms(tt, yy, edges[0], edges[-1])
            cache[m.probe] = (float(np.max(means) - np.min(means)), float(np.median(spans)),
                              rms)
        drift, ripple, rms = cache[m.probe]
        unit = probe_unit(m.probe)
        if m.func in _SHAPE and period is not None and ripple > 0:
            limit = SETTLE_SHAPE * ripple
            basis = f"{100 * SETTLE_SHAPE:g} % of its ripple per period " \
                f"({format_eng(ripple, unit)})"
        else:
            limit = SETTLE_LEVEL * rms
            basis = f"{100 * SETTLE_LEVEL:g} % of its RMS ({format_eng(rms, unit)})"
        out.append(Settling(m.text, m.probe, drift, limit, basis, parts))
    return out
