"""Small-signal frequency response of a switching converter from its netlist (``pelcs ac``).

:func:`ac_analysis` finds the periodic steady state (Newton shooting on the Moreau
stroboscopic map, :mod:`lcs.analysis.orbits`) and measures the response of probes to a small
perturbation of one independent source: a DC control source gives control-to-output, the
input source line-to-output, a zero-valued current source at the output the output
impedance. With a loop source (``loop=``), the loop gain by Middlebrook's voltage injection.

Methods: ``"exact"`` refines the orbit with exact flows and event instants
(:mod:`lcs.analysis.exact_orbit`) and linearises it with the saltation of every switching
instant (:mod:`lcs.smallsignal.ltp`); ``"sweep"`` perturbs the source by a sinusoid in the
time domain and measures (:mod:`lcs.smallsignal.sweep`), as a PLECS AC sweep does.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from lcs.analysis.exact_orbit import PwlOrbitError, exact_orbit
from lcs.analysis.orbits import find_orbit
from lcs.integrators.moreau.integrator import MoreauOptions, simulate
from lcs.smallsignal.ltp import harmonic_response, probe_forms, sampled_data
from lcs.smallsignal.response import FrequencyResponse, loop_margins
from lcs.smallsignal.sweep import sweep_response

from ..capacitor_links import capacitor_links
from ..circuit import Circuit, CurrentSource, VoltageSource
from ..errors import Diagnostic, NetlistError
from ..probes import PROBE
from ..reductions import held_capacitors
from ..units import format_eng
from .measure import _latch_clocks, _periodic_sources, defined_period
from .sweep import check_period_multiple, circuit_map, resolve_period
from .transient import check_probes

METHODS = ("exact", "sweep")

#: The longest settling the sweep chooses itself, in periods (a longer one: --settle).
MAX_SETTLE_PERIODS = 100_000


def _error(circuit: Circuit, message: str, hint: str) -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file=circuit.file)


def _source(circuit: Circuit, name: str):
    for el in circuit.elements:
        if el.name.lower() == name.lower() and isinstance(el, (VoltageSource, CurrentSource)):
            return el
    names = [el.name for el in circuit.elements if isinstance(el, (VoltageSource,
                                                                   CurrentSource))]
    raise _error(circuit, f"no independent source {name!r} to perturb",
                 f"independent sources: {', '.join(names) or 'none'} (a DC control source "
                 "gives control-to-output, the input source line-to-output, a zero-valued "
                 "current source at the output the output impedance)")


def _check_perturbed(circuit: Circuit, inject: str, probes: Sequence[str]) -> None:
    """Refuse what the perturbation of ``inject`` makes wrong where the formulation took it
    for a DC source: a loop of capacitors through it (its link's current takes the source's
    derivative, which the tree capacitors' rows leave out: every response would be wrong),
    and ``i()`` of a capacitor that sources alone join across it, or of those sources (the
    capacitor's current, zero at DC, is ``C`` times the perturbation's derivative; node
    voltages stay exact)."""
    name = inject.lower()
    held = held_capacitors(circuit)
    for link in capacitor_links(circuit, held).values():
        if name in (s.lower() for s in link.sources):
            raise _error(circuit, f"{link.name} closes a loop of capacitors through "
                         f"{inject} ({', '.join(link.path)}): pelcs takes {inject} for a DC "
                         "source there, so it cannot perturb it (the loop's capacitors would "
                         f"miss {link.name}'s current C d{inject}/dt)",
                         f"give {link.name} a series resistance (its ESR) to make it a "
                         "state, or perturb another source")
    for h in held.values():
        if not h.constant or name not in (s.lower() for s in h.path):
            continue
        keys = {h.name.lower()} | {s.lower() for s in h.path}
        for probe in probes:
            m = PROBE.match(probe)
            if m and m.group(1).lower() == "i" and m.group(3) is None \
                    and m.group(2).lower() in keys:
                raise _error(circuit, f"probe {probe!r}: {h.name} is joined by voltage "
                             f"sources alone ({', '.join(h.path)}) and holds no state; "
                             f"with {inject} perturbed its current C dv/dt flows through "
                             f"{', '.join(h.path)}, and pelcs does not compute it",
                             f"probe node voltages or the currents of the branches "
                             f"{inject} feeds, or give {h.name} a series resistance (its "
                             "ESR) to make it a state")


def self_oscillating_switches(circuit: Circuit) -> list[str]:
    """The switches of a circuit that no clock drives: every switch when no source is
    periodic and no latched switch has a clock (hysteretic or sliding-mode control, whose
    switching frequency is set by the circuit's own state), else none."""
    switches = [sw.name for sw in circuit.of_kind("S")]
    if not switches or _periodic_sources(circuit) or _latch_clocks(circuit):
        return []
    return switches


def parse_frequencies(text: str, count: int = 30, what: str = "--freq") -> np.ndarray:
    """``FMIN:FMAX[:N]`` -> N log-spaced frequencies, Hz (``count`` without N), or ``F`` -> one.

    The range syntax of every pelcs command (``NAME=START:STOP[:N]``) without the name;
    SPICE suffixes allowed (``100:50k:40``).

    Raises
    ------
    NetlistError
        Not numbers, not 0 < FMIN < FMAX, or N not an integer >= 2.
    """
    from .sweep import parse_value

    parts = str(text).split(":")
    where = "pelcs ac" if what == "--freq" else "pelcs.ac"
    hint = f"e.g. {what} 100:50k:40 (40 frequencies from 100 Hz to 50 kHz, log-spaced)"

    def bad(message: str) -> NetlistError:
        return NetlistError(Diagnostic(message=f"{what} {text}: {message}", hint=hint),
                            file=where)

    if len(parts) == 1:
        f = parse_value(parts[0], what)
        if f <= 0:
            raise bad("need a positive frequency")
        return np.array([f])
    if len(parts) not in (2, 3):
        raise bad("expected FMIN:FMAX[:N]")
    fmin, fmax = parse_value(parts[0], f"{what} FMIN"), parse_value(parts[1], f"{what} FMAX")
    n = parse_value(parts[2], f"{what} N") if len(parts) == 3 else count
    if not (0 < fmin < fmax) or n != int(n) or n < 2:
        raise bad("need 0 < FMIN < FMAX and an integer N >= 2")
    return np.logspace(np.log10(fmin), np.log10(fmax), int(n))


def default_frequencies(period: float, count: int = 30) -> np.ndarray:
    """Log-spaced from fs/1000 to fs/2, Hz."""
    fs = 1.0 / period
    return np.logspace(np.log10(fs / 1000), np.log10(fs / 2), count)


def _orbit_dict(states, x0, multipliers, events=(), t0: float = 0.0, period: float = 1.0,
                source: str = "") -> dict:
    mu = np.asarray(multipliers)
    return {
        "method": source,
        "states": list(states),
        "x0": [float(v) for v in x0],
        "multipliers": [[float(m.real), float(m.imag)] for m in mu],
        "spectral_radius": float(np.max(np.abs(mu))) if mu.size else 0.0,
        "stable": bool(np.max(np.abs(mu)) < 1.0) if mu.size else True,
        "events": [{"t": float(e.t), "fraction": float((e.t - t0) / period), "kind": e.kind,
                    "name": e.name} for e in events if e.kind != "breakpoint"],
    }


def ac_analysis(circuit: Circuit, *, period: float | str | None, inject: str | None = None,
                probes: Sequence[str] = (), freqs: Sequence[float] | None = None,
                method: str = "exact", amplitude: float | None = None,
                step: float | None = None, theta: float = 0.5, x0=None, transient: int = 0,
                cycles: int = 3, settle: float | None = None, settle_cycles: int = 2,
                loop: str | None = None, options: MoreauOptions | None = None
                ) -> FrequencyResponse:
    """Frequency response of ``probes`` to a perturbation of source ``inject``.

    Parameters
    ----------
    circuit : Circuit
    period : float or str or None
        The switching period T (s, or a ``.param`` name); None: the period the netlist
        defines (:func:`netlist.studies.measure.defined_period`, named in the notes).
    inject : str
        An independent source (V or I) whose value gets the perturbation.
    probes : sequence of str
        ``v(out)``, ``i(L1)``, ...
    freqs : sequence of float, optional
        Hz; default :func:`default_frequencies` (30 points, fs/1000 to fs/2).
    method : str
        ``"exact"`` (linearised exact orbit, with the saltation of every switching instant)
        or ``"sweep"`` (time-domain sinusoidal perturbation).
    amplitude : float, optional
        Sweep only: perturbation amplitude in the source's unit; default 1 % of its value at
        t = 0 (1 mV or 1 mA for a zero-valued source).
    step, theta, x0, transient
        Moreau time step (default the ``.tran`` step, rounded to T/integer), θ, initial guess
        of the steady state (default the netlist's IC) and periods run before Newton.
    cycles, settle, settle_cycles
        Sweep only, see :func:`lcs.smallsignal.sweep.sweep_response`; the settling time
        defaults to the time the slowest multiplier ρ of the orbit takes to decay to 1e-4
        (``ln 1e-4 / ln ρ`` periods).
    loop : str, optional
        A zero-volt source in the feedback path, its positive node facing the controller:
        the loop gain ``T = -v(n-)/v(n+)`` of the injection at it (Middlebrook) is returned
        as the probe ``"T"`` with its margins (``inject`` defaults to it).

    Returns
    -------
    FrequencyResponse
        With ``orbit`` (the steady state), ``margins`` (with a loop) and ``sampled`` /
        ``model`` (the sampled-data model, exact method).

    Raises
    ------
    NetlistError
        Unknown source, probe or method.
    lcs.analysis.MapError, lcs.integrators.exact.ExactError, SimulationError
        The steady state or a run failed (the message says why).
    """
    if method not in METHODS:
        raise _error(circuit, f"unknown method {method!r}", f"use one of {', '.join(METHODS)}")
    free = self_oscillating_switches(circuit)
    if free and (period is None or method == "exact"):
        # A self-oscillating converter has no fixed switching period: its steady state is a
        # limit cycle whose period moves with the perturbation, so there is no T-periodic
        # orbit to linearise (the Moreau map of an arbitrary T only finds one when the
        # switching happens to lock to its time steps). The time-domain sweep still
        # measures the response, valid well below the switching frequency.
        raise _error(
            circuit,
            f"{', '.join(free)} switch{'' if len(free) > 1 else 'es'} on the circuit's own "
            "state (no clock, no periodic source: hysteretic or sliding-mode control), so "
            "the converter self-oscillates with no fixed switching period; the exact "
            "small-signal method linearises a steady state that repeats every T, which does "
            "not exist here",
            "measure the response in the time domain: --method sweep --period T, with T "
            "about the switching period (from `pelcs simulate`); it is valid well below the "
            "switching frequency")
    if period is None:
        T, origin = defined_period(circuit)
        period_notes = [f"T = {format_eng(T, 's')}: the {origin} (no --period given)"]
    else:
        T, period_notes = resolve_period(circuit, period), []
        check_period_multiple(circuit, T)
    if loop is not None:
        src = _source(circuit, loop)
        if not isinstance(src, VoltageSource):
            raise _error(circuit, f"loop source {loop} is not a voltage source",
                         "insert a zero-volt source (V... DC 0) in the feedback path")
        if src.dc != 0.0 or src.waveform is not None:
            raise _error(circuit, f"loop source {src.name} is not a zero-volt source: the "
                         "loop gain is measured by injecting at a 0 V source that breaks "
                         "the feedback path",
                         "insert `Vinj a b DC 0` in the feedback path (positive node facing "
                         "the controller) and pass --loop Vinj")
        inject = inject or src.name
        a, b = src.nodes
        loop_probes = [f"v({a})", f"v({b})"]
        probes = loop_probes + [p for p in probes if p.lower() not in
                                [q.lower() for q in loop_probes]]
    if inject is None:
        raise _error(circuit, "no source to perturb", "pass --inject SOURCE (or --loop)")
    _source(circuit, inject)
    probes = check_probes(circuit, list(probes)) if probes else []
    _check_perturbed(circuit, inject, probes)
    if not probes:
        raise _error(circuit, "no probe to measure", "pass --probe, e.g. --probe 'v(out)'")
    freqs = default_frequencies(T) if freqs is None else np.asarray(freqs, dtype=float)
    if np.any(~np.isfinite(freqs)) or np.any(freqs <= 0):
        raise _error(circuit, "frequencies must be positive", "e.g. --freq 100:50k:40")
    m = circuit_map(circuit, T, step=step, theta=theta, options=options)
    # (a resistor stepped in time: the map, and the response around its orbit, take its
    # value at t0; the note says which)
    period_notes = period_notes + [n for n in m.notes if " is stepped in time (" in n]
    system = m.system
    idx = [s.lower() for s in system.inputs].index(inject.lower())
    start = m.x0 if x0 is None else np.asarray(x0, dtype=float)
    orbit = find_orbit(m, start, transient=transient, pattern=False)
    notes = list(period_notes)
    if not orbit.converged:
        notes.append(f"Newton on the Moreau map did not converge (residual "
                     f"{orbit.residual:.3g})")
    if method == "exact":
        res = m.trajectory(orbit.points[0], 1)
        key0 = tuple(res.modes_visited[0]) if res.modes_visited else ()
        try:
            eo = exact_orbit(system, m.signals, orbit.points[0], key0, m.t0, T)
        except PwlOrbitError as exc:
            if orbit.converged:
                raise
            raise PwlOrbitError(f"{exc}; it started from the Moreau map's Newton, which did "
                                f"not converge either (residual {orbit.residual:.3g}): the "
                                "converter may have no period-1 steady state here") from exc
        Y = probe_forms(eo, lambda key: system.outputs(key, probes))
        fr = harmonic_response(eo, Y, probes, idx, freqs)
        fr.orbit = _orbit_dict(system.states, eo.x0, eo.multipliers, eo.events, m.t0, T,
                               "exact")
        fr.sampled = sampled_data(eo)
    else:
        x_ss = np.asarray(orbit.points[0], dtype=float)
        # The transient excited when the sinusoid starts decays as rho^k per period; let it
        # fall below 1e-4 before measuring (it is not orthogonal to the excitation over a
        # short window: 5 dB of error at fs/8 on the buck with 16 periods of settling).
        rho = float(np.max(np.abs(orbit.multipliers))) if orbit.multipliers.size else 0.0
        if rho >= 1.0:
            # The sinusoid is applied to a simulation started on the orbit: an unstable orbit is
            # left within a few periods, and what the sweep measured is the response of wherever
            # the converter went (a longer cycle, chaos), not of the steady state.
            raise _error(circuit, f"the periodic steady state is unstable (spectral radius "
                         f"{rho:.4g}): the converter leaves it, so a time-domain sweep cannot "
                         "measure a response around it",
                         "--method exact gives the linearised response of the unstable orbit; "
                         "lower the parameter below the bifurcation (`pelcs continue`) for a "
                         "measurable one")
        if settle is None:
            periods = np.ceil(np.log(1e-4) / np.log(rho)) if 0.0 < rho < 1.0 else 0.0
            if periods > MAX_SETTLE_PERIODS or not orbit.converged:
                # (a multiplier within 1e-5 of 1 is a limit cycle's phase direction or a
                # Newton that did not converge, not a decay rate to wait for)
                why = (f"the slowest multiplier {rho:.8g} would take {periods:.3g} periods to "
                       "decay" if orbit.converged else "Newton did not find the orbit, so "
                       "its multipliers give no settling time")
                raise _error(circuit, f"cannot choose the settling time of the sweep: {why}",
                             "pass --settle T (s), e.g. 5 time constants of the slowest pole")
            settle = periods * T
        if amplitude is None:
            u0 = float(np.asarray(m.signals[idx](np.array([0.0])))[0])
            amplitude = 0.01 * abs(u0) if u0 != 0.0 else 1e-3

        def run(signals, x_start, ta, tb, names):
            return simulate(system, signals, x_start, tb, m.h, t_start=ta, theta=theta,
                            probes=list(names), options=options, on_inconsistent=None)

        fr = sweep_response(run, m.signals, idx, system.inputs[idx], x_ss, m.t0, T, freqs,
                            probes, amplitude=amplitude, cycles=cycles, settle=settle,
                            settle_cycles=settle_cycles)
        fr.orbit = _orbit_dict(system.states, x_ss, orbit.multipliers, (), m.t0, T, "moreau")
    radius = fr.orbit["spectral_radius"]
    notes.append(f"steady state: period-1 orbit, spectral radius {radius:.4g}")
    if radius >= 1.0:
        notes.append("the periodic steady state is unstable: the small-signal response "
                     "describes a state the converter does not stay in")
    fr.notes[:0] = notes
    if loop is not None:
        loop_gain = -fr.H[:, 1] / fr.H[:, 0]
        fr.H = np.column_stack([loop_gain, fr.H])
        fr.probes = ("T",) + fr.probes
        fr.margins = loop_margins(fr.freq, loop_gain)
    return fr


__all__ = ["METHODS", "ac_analysis", "default_frequencies", "parse_frequencies",
           "PwlOrbitError"]
