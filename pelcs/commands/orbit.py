"""``pelcs orbit FILE [--period T]``: a periodic orbit of the stroboscopic map and its stability.

::

    pelcs orbit FILE [--period T] [--order K] [--param NAME=VALUE]... [--x0 STATE=V,...]
                     [--transient N] [--step H] [--theta TH] [--t0 T0] [--event EV] [--json]

The circuit is sampled every T (a number with SPICE suffix, or a ``.param`` name such as
``tp``) from the phase ``--t0``; the period-K orbit is found by Newton shooting from the
circuit's initial state (``IC=``, ``.ic``, or ``--x0``) after ``--transient`` periods. Printed:
the orbit's points (states named as ``pelcs lcs`` names them), its Floquet multipliers (from a
central-difference Jacobian of the K-period map), the stability and the switching pattern.
``--json`` prints one object: ``{"file", "title", "period", "step", "theta", "order",
"states", "points", "multipliers" ([re, im] pairs), "stability", "pattern", ...}``, strict
JSON: NaN and infinities are null (e.g. the scaled ``residual`` of an unconverged orbit of a
strongly unstable circuit, beyond the largest float).
``--event S1:on`` (or ``D1:off``, ``'v(out)>12'``) uses the map sampled at that event instead;
its state ends with ``phase`` (the event time modulo T, s) and it has one extra multiplier 0.

Without ``--period``, T is the period the netlist defines: the PULSE or SIN period of the
source at a switch's control, else the one period shared by the latched switches' clocks
(``LATCH=1 PERIOD=T``) and the periodic sources such as a PWM ramp (a note names it); no such
period, or several different ones, is an input error asking for ``--period``. The same holds
for ``continue``, ``bifurcation``, ``basins`` and ``ac``.

This module also holds the options that ``bifurcation``, ``continue`` and ``basins`` share.

Newton's steps are damped by the natural monotonicity test, and a Newton that stalls is
restarted from the state iterated further by the map (16, 64, 256 and 1024 more periods), so
that it converges from the initial state of a periodic converter. When it does not, the last
iterate is printed without multipliers (``multipliers``, ``stability`` in JSON: null and
"unknown: ...") and the exit status is 3.

Exit status: 0 success; 2 input errors; 3 Newton did not converge or the map failed.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from netlist.errors import Diagnostic, NetlistError
from pelcs.jsonout import dumps

from . import options

EXIT_FAILED = 3


# -- options shared by the analysis commands ---------------------------------------------


def add_map_options(p: argparse.ArgumentParser, *, param_help: str) -> None:
    """``file``, ``--period``, ``--param``, ``--step``, ``--theta``, ``--t0``, ``--x0``."""
    p.add_argument("file", help="netlist file")
    options.add_period(p,
                   help="sampling period: seconds with SPICE suffix (400u) or a .param name "
                   "(default: the PULSE or SIN period of the source at a switch's control, "
                   "else the one period of the latched switches' clocks and the periodic "
                   "sources, such as a PWM ramp; the report names it)")
    options.add_param(p, help=param_help)
    options.add_step(p, help="time step (default: the .tran step, rounded down to T/integer)")
    options.add_theta(p)
    p.add_argument("--t0", metavar="T0", default="0",
                   help="sampling phase: the map samples at t0 + k T (default 0)")
    p.add_argument("--x0", metavar="STATE=V,...",
                   help="initial state, e.g. 'v(C1)=12,i(L1)=1' (others: the netlist's IC)")
    options.add_method(p, ("moreau", "exact"), "moreau",
                   help="moreau: θ time-stepping map, finite-difference Jacobians (default); "
                   "exact: exact flows and events, exact Jacobians (saltation), for "
                   "DC, PULSE, PWL and SIN sources and netlist comparators")


def add_event_option(p: argparse.ArgumentParser) -> None:
    """``--event``: an event (Poincaré section) map instead of the stroboscopic map."""
    p.add_argument("--event", metavar="EVENT",
                   help="sample at an event instead of every T: S1:on, S1:off (a switch), "
                   "D1:on, D1:off (a diode starts/stops conducting), 'v(out)>12' (a probe "
                   "crossing); the map state gets a 'phase' (event time mod T, s)")


def usage_error(command: str, message: str, hint: str = "") -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file=f"pelcs {command}")


def make_factory(args: argparse.Namespace, command: str, *, swept: str | None = None,
                 fixed: dict[str, float] | None = None):
    """The :class:`~netlist.studies.sweep.CircuitMapFactory` of the parsed options."""
    from netlist.studies.sweep import CircuitMapFactory, parse_value

    theta = parse_value(args.theta, "--theta") if args.theta is not None else None
    if theta is not None and not 0.5 <= theta <= 1.0:
        raise usage_error(command, f"--theta {args.theta}: θ must be in [0.5, 1]")
    step = parse_value(args.step, "--step") if args.step else None
    if step is not None and step <= 0:
        raise usage_error(command, f"--step {args.step}: must be positive")
    t0 = parse_value(args.t0, "--t0")
    period: float | str | None = args.period  # None: the netlist's, found per circuit
    if period is not None:
        try:
            period = parse_value(args.period, "--period")
        except NetlistError:
            pass  # a .param name, resolved per parameter value
    event = getattr(args, "event", None)
    if event:
        from lcs.analysis.maps import EventSpec

        try:
            EventSpec.parse(event)
        except ValueError as exc:
            raise usage_error(command, f"--event: {exc}",
                              "e.g. --event S1:on or --event 'v(out)>12'") from None
    return CircuitMapFactory(
        path=args.file, period=period, param=swept,
        overrides=tuple(sorted((fixed or {}).items())), step=step, theta=theta, t0=t0,
        event=event or None, method=getattr(args, "method", "moreau"),
    )


def initial_state(args: argparse.Namespace, m) -> np.ndarray:
    """``--x0`` over the circuit's initial state (circuit states only, no event phase)."""
    from netlist.studies.sweep import parse_state

    x0 = np.asarray(m.x0, dtype=float)
    if args.x0:
        return parse_state(args.x0, m.state_names[: x0.size], x0)
    return x0


def period_notes(m) -> list[str]:
    """The note naming the period taken from the netlist (none when --period was given)."""
    note = getattr(m, "period_note", None)
    return [note] if note else []


def positive_int(command: str, option: str, text, minimum: int = 1) -> int:
    from netlist.studies.sweep import parse_value

    v = parse_value(str(text), option)
    if v != int(v) or v < minimum:
        raise usage_error(command, f"{option} {text}: expected an integer >= {minimum}")
    return int(v)


def fmt_complex(mu: complex) -> str:
    if abs(mu.imag) <= 1e-12 * max(1.0, abs(mu)):
        return f"{mu.real:.8g}"
    return f"{mu.real:.8g} {'+' if mu.imag >= 0 else '-'} {abs(mu.imag):.8g}j"


def map_header(m, factory) -> dict:
    """Map settings for reports; the exact map has no step or θ (None)."""
    return {"period": m.period, "step": getattr(m, "h", None),
            "theta": getattr(m, "theta", None), "t0": m.t0,
            "method": getattr(m, "method", "moreau"),
            "params": dict(factory.overrides), "event": factory.event}


# -- the command -------------------------------------------------------------------------


def register(subparsers) -> None:
    """Add the ``orbit`` subcommand."""
    p = subparsers.add_parser(
        "orbit",
        help="periodic orbit of the stroboscopic map: points, Floquet multipliers, pattern",
        description="Find a period-K orbit of the stroboscopic map (state sampled every T) by "
        "Newton shooting; print its points, Floquet multipliers, stability and switching "
        "pattern.",
        epilog="example: pelcs orbit vm_buck.cir --period tp --param vin=20 --json",
    )
    add_map_options(p, param_help="override a global .param (repeatable)")
    add_event_option(p)
    p.add_argument("--order", default="1", metavar="K", help="period of the orbit in periods T")
    p.add_argument("--transient", default="100", metavar="N",
                   help="periods simulated before Newton (default 100)")
    options.add_tol(p)
    options.add_json(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from lcs.analysis.maps import MapError

    try:
        report, orbit = compute(args)
    except MapError as exc:
        print(f"{args.file}: error: {exc}", file=sys.stderr)
        return EXIT_FAILED
    if args.json:
        print(dumps(report, indent=1))
    else:
        print(format_orbit(report, Path(args.file).name))
    return 0 if orbit.converged else EXIT_FAILED


def compute(args: argparse.Namespace) -> tuple[dict, object]:
    """The orbit of the parsed options: ``(report, orbit)``, the report being what
    ``--json`` prints and ``orbit`` the :class:`~lcs.analysis.orbits.Orbit` (shared with
    :func:`pelcs.orbit`).

    Raises
    ------
    NetlistError
        Input errors.
    MapError
        The map failed.
    """
    from lcs.analysis.orbits import find_orbit
    from netlist.parser import parse_overrides
    from netlist.studies.sweep import check_orbit_knees, parse_value

    fixed = parse_overrides(args.param)
    factory = make_factory(args, "orbit", fixed=fixed)
    order = positive_int("orbit", "--order", args.order)
    transient = positive_int("orbit", "--transient", args.transient, 0)
    tol = parse_value(args.tol, "--tol")
    try:
        m = factory()
    except KeyError as exc:  # an event naming no switch or diode
        raise usage_error("orbit", f"--event: {exc.args[0]}") from None
    x0 = initial_state(args, m)
    if len(x0) < m.dim:  # event map: the phase starts at the sampling phase
        x0 = np.concatenate([x0, [0.0]])
    orbit = find_orbit(m, x0, order, transient=transient, tol=tol)
    orbit.notes.extend(check_orbit_knees(m, orbit))
    circuit_title = factory.circuit().title
    report = {"file": args.file, "title": circuit_title, **map_header(m, factory),
              **orbit.to_dict(), "notes": list(m.notes) + list(orbit.notes)}
    return report, orbit


def format_orbit(r: dict, name: str) -> str:
    """Text report of an orbit (the JSON object of ``run``)."""
    from netlist.units import format_eng

    lines = [f"{name}: {r['title']}".rstrip(": ")]
    params = ", ".join(f"{k} = {v:g}" for k, v in r["params"].items())
    kind = f"event map ({r['event']})" if r.get("event") else "stroboscopic map"
    how = ("exact flows and events" if r.get("method") == "exact" else
           f"h = {format_eng(r['step'], 's')}, θ = {r['theta']:g}")
    what = (f"period-{r['order']} orbit of the {kind}" if r["converged"] else
            f"NO period-{r['order']} orbit found for the {kind}")
    lines.append(f"{what}: T = "
                 f"{format_eng(r['period'], 's')}, {how}" + (f"; {params}" if params else ""))
    states = r["states"]
    width = max(15, *(len(s) + 2 for s in states))
    lines.append("points:" if r["converged"] else "last Newton iterate:")
    lines.append("  k " + "".join(s.rjust(width) for s in states))
    for k, pt in enumerate(r["points"]):
        lines.append(f"  {k:<2}" + "".join(f" {v:>{width - 1}.9g}" for v in pt))
    if r["multipliers"] is None:
        lines.append("no periodic orbit: Newton did not converge; the point above is its "
                     "last iterate, not an orbit, and its multipliers are not printed")
    else:
        lines.append("Floquet multipliers (eigenvalues of the Jacobian of the map iterated "
                     f"{r['order']} time(s)):")
        for (re_, im), mod in zip(r["multipliers"], r["multiplier_moduli"], strict=True):
            lines.append(f"  {fmt_complex(complex(re_, im)):>32}   |μ| = {mod:.8g}")
    lines.append(f"stability: {r['stability']}")
    if r.get("pattern_text"):
        lines.append(f"switching pattern: {r['pattern_text']}")
    conv = "converged" if r["converged"] else "NOT converged"
    lines.append(f"Newton: {conv} in {r['iterations']} iteration(s), scaled residual "
                 f"{r['residual']:.3g}")
    for note in r.get("notes", []):
        lines.append(f"note: {note}")
    return "\n".join(lines)
