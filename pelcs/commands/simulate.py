"""``pelcs simulate FILE``: Moreau time-stepping of a netlist, to CSV/NPZ and a plot.

::

    pelcs simulate FILE [--tstop T] [--step H] [--theta TH] [--param NAME=VALUE]...
                        [--kernel auto|dense|sparse]
                        [--probe EXPR]... [--output-step T | --all-steps | --every N]
                        [-o OUT.csv|OUT.npz|OUT.parquet] [--plot OUT.png]
                        [--method moreau|exact] [--events]

``--method exact`` integrates exactly between events (:mod:`lcs.integrators.exact`: one matrix
exponential per stretch, events located to round-off); the step is then the output spacing.
``--events`` prints the exact run's event list (time, element, kind, mode after).

Defaults come from the netlist's ``.tran`` (stop time TSTOP, step TMAX if given, else TSTEP);
times accept SPICE suffixes (``--tstop 5m``, ``--step 0.1u``). Probes are ``v(out)``,
``v(a,b)``, ``i(L1)``, ``i(D1)``...; the default is every state. The points written (and
plotted) are the ``.tran TSTEP`` grid, as ngspice writes it (``--output-step`` another
spacing, ``--all-steps`` every step). The CSV has the header ``time,<probe>,...`` and SI
units. A short summary goes to stdout.

Exit status: 0 success; 2 input errors (bad netlist, option or probe; printed gcc-style by
:mod:`pelcs.cli`) and output files that could not be written (after the summary; an earlier
file of the name is left as it was); 3 the run failed (an LCP without solution, a non-finite
state): the results up to the failure are written first, then the error (time, switch mode,
diodes) is printed on stderr; 130 the run was interrupted (SIGINT, i.e. Ctrl-C, or SIGTERM):
it stops after its current piece of steps (a fraction of a second) and writes the results up
to there, with a note; a second Ctrl-C aborts at once and writes nothing.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

from lcs import interrupt
from lcs.interrupt import deferred_interrupts
from lcs.results import resample
from netlist.errors import Diagnostic, NetlistError
from pelcs.outputs import Written, write_outputs
from pelcs.writers import FORMATS

from . import options

EXIT_FAILED = 3
#: Exit status of an interrupted run (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130


def register(subparsers) -> None:
    """Add the ``simulate`` subcommand to the CLI's subparsers."""
    p = subparsers.add_parser(
        "simulate",
        help="simulate a netlist (Moreau time-stepping) and write CSV/NPZ and a plot",
        description="Simulate a netlist with ideal diodes and switches by Moreau θ "
        "time-stepping (one linear complementarity problem per step). Times and numbers "
        "accept SPICE suffixes (5m, 0.1u, 50k).",
        epilog="example: pelcs simulate boost.cir --probe 'v(out)' --probe 'i(L1)' "
        "-o out/boost.csv --plot out/boost.png   (quote the probes in a shell)",
    )
    p.add_argument("file", help="netlist file")
    p.add_argument("--tstop", metavar="T", help="stop time (default: .tran TSTOP)")
    options.add_step(p,
                   help="time step (default: .tran TMAX if given, else TSTEP)")
    options.add_theta(p,
                   help="θ in [0.5, 1]: 0.5 trapezoidal (default; 1 where θ < 1 is found "
                   "unreliable, with a note), 1 backward Euler")
    options.add_param(p)
    options.add_probe(p,
                   help="v(NODE), v(NODE,NODE) or i(ELEMENT) (repeatable, or a "
                   "comma-separated list); default: every state")
    p.add_argument("--output-step", metavar="T",
                   help="spacing of the points written and plotted (default: .tran TSTEP, as "
                   "ngspice; linear interpolation between steps)")
    p.add_argument("--all-steps", action="store_true",
                   help="write every integration step (and every switching instant) instead "
                   "of the .tran TSTEP grid")
    p.add_argument("--every", metavar="N",
                   help="write every N-th integration step (implies --all-steps)")
    options.add_output(p, "OUT",
                   help="write the probes to OUT.csv, OUT.npz or OUT.parquet")
    p.add_argument("--plot", metavar="OUT.png", help="plot the probes, one panel each")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--threshold", action="append", default=[], metavar="NAME=V",
                   help="switch threshold of an idealised transistor (M, Q), by element or "
                   "model name (default: VTO of a MOSFET model, 0.7 V for a BJT); repeatable")
    p.add_argument("--devices", choices=("ideal", "pwl"), default="ideal",
                   help="ideal (default) or pwl: diodes with a Vf and Ron fitted to their "
                   "model, switches with their on-resistance (still an LCS)")
    p.add_argument("--pwl", action="append", default=[], metavar="NAME=VF:RON",
                   help="with --devices pwl: a diode's or switch's forward voltage (V) and "
                   "on-resistance (ohm), by element or model name, instead of the fit")
    p.add_argument("--losses", action="store_true",
                   help="conduction losses, input/output power and efficiency over the "
                   "steady-state window")
    p.add_argument("--load", metavar="NAME",
                   help="with --losses: the load resistor (default: the one taking the most "
                   "power)")
    options.add_method(p, ("moreau", "exact"), "moreau",
                   help="moreau: θ time-stepping (default); exact: event-driven, exact "
                   "between events (DC, PULSE, PWL, SIN sources; netlist comparators), the step "
                   "is then the output spacing")
    p.add_argument("--events", action="store_true",
                   help="with --method exact: print every event (time, element, kind, mode)")
    p.add_argument("--kernel", choices=("auto", "dense", "sparse"), default="auto",
                   help="how Moreau steps are solved: dense (stored θ-discretised matrices per "
                   "mode), sparse (factorised KKT systems of the circuit's network: a step "
                   "costs time proportional to the circuit's size) or auto (default: the one "
                   "whose estimated step is cheaper)")
    p.set_defaults(func=run)


# -- arguments -----------------------------------------------------------------------------


def _usage_error(message: str, hint: str = "") -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file="pelcs simulate")


_NUMBER = re.compile(r"([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)([a-zA-Zµ]*)")


def _number(option: str, text: str | None, units: tuple[str, ...] = ("",)) -> float | None:
    """A SPICE number from an option, or None when the option is absent.

    Parameters
    ----------
    option : str
        The option name, for messages.
    text : str or None
        ``"5m"``, ``"0.1u"``, ``"1e-3"``, ``"5ms"``...
    units : tuple of str
        Unit letters allowed after the scale suffix (lower case): ``("", "s")`` for times.
        SPICE itself ignores any letters after the suffix (``5x`` is 5); on the command line
        a typo should not silently give a 5 s run.
    """
    from netlist.units import parse_number, suffix_scale

    if text is None:
        return None
    raw = text.strip().replace("µ", "u")
    m = _NUMBER.fullmatch(raw)
    value = parse_number(raw) if m else None
    if m is not None and value is not None:
        letters = m.group(2).lower()
        power, _ = suffix_scale(letters)
        rest = letters[3:] if letters[:3] in ("meg", "mil") else (
            letters[1:] if letters and power != 0 else letters)
        if rest not in units:
            value = None
    if value is None:
        example = "5m or 0.1u (SPICE suffixes T G Meg k m u n p f)" if "s" in units else "2"
        raise _usage_error(f"{option}: {text!r} is not a number",
                           f"e.g. {option} {example}")
    return value


def split_probes(items: list[str]) -> list[str]:
    """``--probe`` values -> probe list; a value may hold several, comma-separated.

    Commas inside parentheses belong to the probe (``v(a,b)``).
    """
    from netlist.dialect import split_top_level

    return [p for item in items for p in split_top_level(item)]


def _check_path(option: str, path: str, suffixes: tuple[str, ...]) -> Path:
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise _usage_error(f"{option}: cannot tell the format of {path!r}",
                           f"use a file name ending in {' or '.join(suffixes)}")
    return p


# -- the command ---------------------------------------------------------------------------


def run(args: argparse.Namespace) -> int:
    from netlist.parser import parse_file, parse_overrides
    from netlist.studies.transient import (
        check_probes,
        check_run_size,
        passivity_unreported,
        transient_setup,
    )

    tstop = _number("--tstop", args.tstop, ("", "s"))
    step = _number("--step", args.step, ("", "s"))
    theta = _number("--theta", args.theta)
    if theta is not None and not 0.5 <= theta <= 1.0:
        raise _usage_error(f"--theta {args.theta}: θ must be in [0.5, 1]",
                           "0.5 is the trapezoidal scheme (second order), 1 backward Euler")
    every_f = _number("--every", args.every or "1")
    if every_f != int(every_f) or every_f < 1:
        raise _usage_error(f"--every {args.every}: not a positive integer", "e.g. --every 10")
    every = int(every_f)
    output_step = _number("--output-step", args.output_step, ("", "s"))
    if output_step is not None and not output_step > 0:
        raise _usage_error(f"--output-step {args.output_step}: must be positive",
                           "e.g. --output-step 1u")
    if output_step is not None and (args.all_steps or args.every):
        raise _usage_error("--output-step and --all-steps/--every both choose the points "
                           "written", "give one of them")
    out = _check_path("-o", args.output, FORMATS) if args.output else None
    plot = _check_path("--plot", args.plot, (".png", ".svg", ".pdf")) if args.plot else None

    params = parse_overrides(args.param)
    thresholds = parse_overrides(args.threshold)
    circuit = parse_file(args.file, params=params or None, thresholds=thresholds or None)
    probes = check_probes(circuit, split_probes(args.probe)) if args.probe else None
    if getattr(args, "devices", "ideal") == "pwl":
        # the ideal circuit is not the one simulated: its passivity is not reported, the
        # pwl run's is (a strict run is refused there)
        with passivity_unreported():
            setup = transient_setup(circuit, tstop=tstop, step=step, given=params)
    else:
        setup = transient_setup(circuit, tstop=tstop, step=step, given=params)

    # (before loading anything: a run too large for the machine is refused at once)
    check_run_size(setup, len(probes) if probes is not None else len(setup.system.states),
                   every, streamed=_streams(args, out, plot))
    # Load the compiled kernels first, so that the summary's time per step is the run's;
    # compiling them (the first run after an installation) is said before it starts.
    from lcs.build import kernel_setup

    if not kernel_setup.kernels_cached():
        print(kernel_setup.COMPILING_MESSAGE, file=sys.stderr, flush=True)
    else:  # (a kernel missing from a cache numba otherwise serves says so when it compiles)
        kernel_setup.announce_compiles(lambda text: print(text, file=sys.stderr, flush=True))
    from lcs.build.ready import load_kernels

    load = load_kernels()
    compiled = kernel_setup.compiled_in_process() > 0
    with deferred_interrupts(_INTERRUPT_MESSAGE):
        return _run(args, circuit, setup, probes, tstop, step, theta, every, output_step,
                    out, plot, load, compiled)


#: The switchings a run keeps (the last ones: the summary counts them all, the detail view
#: of the plot and the free-running period read the last few periods), so that a run's
#: memory does not grow with its length.
EVENTS_KEPT = 1 << 14

#: What the first Ctrl-C (or SIGTERM) of a run prints.
_INTERRUPT_MESSAGE = ("pelcs simulate: interrupted: the run stops after its current piece "
                      "of steps (or, exactly, stretch) and the results so far are written "
                      "(Ctrl-C again aborts at once, writing nothing)")


def _run(args, circuit, setup, probes, tstop, step, theta, every, output_step, out, plot,
         load, compiled=False) -> int:
    """The run, its files and its summary; the exit status."""

    spacing = _output_spacing(output_step, args.all_steps or bool(args.every), circuit, setup)
    t0 = time.perf_counter()
    stream = None
    if _streams(args, out, plot):
        from pelcs.writers import open_stream

        stream = open_stream(out)
    try:
        result = _simulated(args, circuit, setup, probes, tstop, step, theta, every, spacing,
                            stream)
    except BaseException:  # (a second Ctrl-C, an error: no file, the earlier one kept)
        _abort(stream)
        raise
    regridded = spacing is not None and not _fitted(args)
    wall = time.perf_counter() - t0

    streamed = stream is not None and result.stats.points_streamed >= 0
    if not streamed:
        _abort(stream)  # (a run that could not stream: its rows are written whole)
        stream = None
    steps_stored = result.stats.points_stored if regridded or streamed else len(result.t)
    if output_step is None and not (args.all_steps or args.every) and setup.print_note:
        result.notes.append(setup.print_note)
    if spacing is not None and not regridded:
        result = resample(result, spacing[0])
    err = result.error
    if err is not None and err.kind == "interrupted":
        result.notes.append(f"the run was interrupted at t = {_eng(err.time, 's')} "
                            f"({_eng(setup.t_stop, 's')} asked): the results end there")
    written = _write(result, out, plot, circuit.title or Path(args.file).name, args.file,
                     setup.t_stop, stream)
    switches = [s.name for s in setup.system.switches]
    if spacing is not None:
        points = (f"every {_eng(spacing[0], 's')} ({spacing[1]}; --all-steps writes all "
                  f"{steps_stored})")
    else:
        points = "every step" if every == 1 else f"every {_ordinal(every)} step"
    used = result.theta if result.theta is not None else (theta or 0.5)
    print(summary(result, args.file, circuit.title, tstop=setup.t_stop, step=setup.h,
                  theta=used, wall=wall, written=written, switches=switches, load=load,
                  method=args.method, points=points, compiled=compiled))
    if result.losses is not None:
        print("\n".join(result.losses.lines()))
    if args.events:
        for ev in result.event_log:
            mode = ", ".join(f"{k} {v}" for k, v in ev.mode.items() if k != "held")
            held = ", ".join(ev.mode.get("held", ())) or "none"
            print(f"event {_eng(ev.t, 's'):>12}  {ev.kind:<10} {ev.element or '-':<8} "
                  f"-> {mode or 'no switches'}; w = 0 held: {held}")
    not_written = written.exit_status()
    where = ((f"results up to t = {_eng(err.t_prev, 's')} written to {', '.join(written)}"
              if result.points else f"{', '.join(written)} written with no points (the run stopped "
              f"before the first point kept, t = {_eng(setup.t_save, 's')})")
             if written else "no output file written" if not_written
             else "no output file was requested (-o, --plot)") if err is not None else ""
    if err is not None and err.kind == "interrupted":
        print(f"{args.file}: {err.message}\n  {where}", file=sys.stderr)
        return EXIT_INTERRUPTED
    if interrupt.requested() is not None:
        # (a signal while the files were written: they were completed first)
        print(f"{args.file}: interrupted after the run; the files were completed",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    if err is not None:
        print(f"{args.file}: error: simulation failed ({err.kind}): {err.message}\n"
              f"  {where}", file=sys.stderr)
    return not_written or (EXIT_FAILED if err is not None else 0)


def _output_spacing(output_step: float | None, all_steps: bool, circuit, setup
                    ) -> tuple[float, str] | None:
    """The spacing of the points written and where it comes from, or None for every step.

    As ngspice writes its ``.tran TSTEP`` grid, so does pelcs by default; a TSTEP finer than
    the integration step (or a run without ``.tran``) writes every step instead, since
    interpolating below the step adds points and no information, and so does a TSTEP too
    coarse to show the sources (``netlist.studies.timestep.print_step``; the result's notes say so).
    """
    if output_step is not None:
        return output_step, "--output-step"
    if all_steps:
        return None
    if setup.print_step is None:
        return None
    return setup.print_step, ".tran TSTEP"


def _ordinal(n: int) -> str:
    """``2nd``, ``3rd``, ``4th``, ``11th``, ``21st``."""
    suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix}"


def _simulated(args, circuit, setup, probes, tstop, step, theta, every, spacing, stream):
    """The run's result (its rows to ``stream`` as it goes, where it can); the stepper's
    refusals as input errors."""
    from netlist.studies.left_out import models_left_out
    from netlist.studies.transient import run_setup

    try:
        if _fitted(args):
            from netlist.studies.realistic import simulate_devices

            given = {}
            for item in args.pwl:
                name, _, vals = item.partition("=")
                try:
                    vf, ron = (float(_number("--pwl", v)) for v in vals.split(":"))
                except (ValueError, NetlistError):
                    raise _usage_error(f"--pwl {item}: expected NAME=VF:RON",
                                       "e.g. --pwl D1=0.7:0.05 (volts, ohms)") from None
                given[name.strip()] = (vf, ron)
            return simulate_devices(circuit, pwl=given, tstop=tstop, step=step, theta=theta,
                                    probes=probes, every=every,
                                    progress=not args.no_progress, method=args.method,
                                    devices=args.devices, losses=args.losses,
                                    load=args.load)
        else:
            options = None
            if args.kernel != "auto":
                from lcs.integrators.moreau.integrator import MoreauOptions

                options = MoreauOptions(kernel=args.kernel)
            # (the output grid computed as the run goes: it holds that grid, not every step)
            result = run_setup(setup, theta=theta, probes=probes, every=every,
                               progress=not args.no_progress, method=args.method,
                               options=options,
                               output_step=spacing[0] if spacing is not None else None,
                               keep_events=EVENTS_KEPT, rows_to=stream)
            if note := models_left_out(circuit):
                result.notes.append(note)
            return result
    except NotImplementedError as exc:
        # A circuit the stepper cannot handle yet: say so like an input error, no traceback.
        raise NetlistError(Diagnostic(message=f"not supported: {exc}",
                                      hint="see docs/simulation.md"),
                           file=args.file) from exc
    except ValueError as exc:
        # The set-up of a mode failed before any step (e.g. I - hθA singular: an element
        # value of 1e-308 found by fuzzing): the values, not the run, are at fault.
        raise NetlistError(Diagnostic(message=f"cannot simulate: {exc}",
                                      hint="an element value of extreme magnitude? check the "
                                      "values and their units (pelcs lcs FILE shows the "
                                      "matrices)"), file=args.file) from exc


def _streams(args, out: Path | None, plot: Path | None) -> bool:
    """Whether the run writes its file as it goes (then it holds neither its steps nor its
    output rows). A figure needs the rows, so a run with --plot holds its output grid; the
    exact method and the piecewise-linear devices (their losses are integrated over every
    step) hold their rows too."""
    return (out is not None and plot is None and args.method == "moreau"
            and not _fitted(args))


def _fitted(args) -> bool:
    """Whether the run is of the fitted devices (``--devices pwl``, ``--losses``)."""
    return args.devices == "pwl" or args.losses


def _abort(stream) -> None:
    if stream is not None:
        stream.abort()


def _write(result, out: Path | None, plot: Path | None, title: str, file: str,
           t_stop: float, stream=None) -> Written:
    """Write the requested files (also for a failed or interrupted run); the names written
    and the errors of those that could not be. With ``stream``, ``out`` was written as the
    run went and is completed."""
    from pelcs.plotting import plot_result
    from pelcs.writers import write_result

    return write_outputs("simulate", (
        (out, lambda path: stream.close(result) if stream is not None
         else write_result(result, path)),
        (plot, lambda path: plot_result(result, path, title=f"{title}  ({Path(file).name})",
                                        t_stop=t_stop)),
    ))


def _eng(value: float, unit: str) -> str:
    from netlist.units import format_eng

    return format_eng(float(value), unit)


# The summary names at most this many modes and final values (a 64-phase converter visits
# 150 modes of 64 switches; the output file has everything).
_MAX_MODES_SHOWN = 6
_MAX_FINALS_SHOWN = 12
# Up to this many switches a mode is written in full, beyond by its closed switches.
_FULL_MODE_SWITCHES = 4


def _mode_text(switches, mode) -> str:
    """``(S1 on, S2 off)``, or with many switches ``(on: S1, S7)`` / ``(all off)``."""
    if len(switches) <= _FULL_MODE_SWITCHES:
        return "(" + ", ".join(f"{n} {'on' if on else 'off'}"
                               for n, on in zip(switches, mode, strict=True)) + ")"
    on = [n for n, closed in zip(switches, mode, strict=True) if closed]
    return f"(on: {', '.join(on)})" if on else "(all off)"


def summary(result, file: str, title: str, *, tstop: float, step: float, theta: float,
            wall: float, written: list[str], switches: list[str] = (),
            load: float | None = None, method: str = "moreau", points: str = "",
            compiled: bool = False) -> str:
    """The text printed after a run: steps and timing, modes, final values, notes, files.

    Parameters
    ----------
    result : SimulationResult
    file, title : str
        Netlist file and title.
    tstop, step : float
        Stop time and step of the run, s.
    theta : float
    wall : float
        Wall time of the run, s (includes the formulation of the modes visited).
    written : list of str
        Files written.
    switches : list of str
        Switch names in mode-key order.
    load : float, optional
        Time spent loading (or compiling) the kernels before the run, s.
    method : str
        ``"moreau"`` or ``"exact"``.
    points : str
        Which points were written (``"every 200 ns (.tran TSTEP)"``).
    compiled : bool
        Whether the kernels were compiled (not only loaded) in that time.
    """
    from pelcs.plotting import probe_unit

    st = result.stats
    lines = [f"{file}: {title}".rstrip(": ")]
    shortened = (f" ({st.odd_steps} shortened to land on source edges and switching "
                 "instants)") if st.odd_steps else ""
    if result.error is not None:
        # (a run that stopped early: how far it went, and how far it was asked to)
        tstop_text = (f"{_eng(result.error.t_prev, 's')} (of {_eng(tstop, 's')}: "
                      f"{result.error.kind.replace('_', ' ')})")
    else:
        tstop_text = _eng(tstop, 's')
    if method == "exact":
        lines.append(
            f"simulated 0 to {tstop_text} exactly (event-driven): {st.steps} stretches "
            f"between {st.located} events in {wall:.3g} s; output every {_eng(step, 's')}")
    else:
        lines.append(
            f"simulated 0 to {tstop_text}, h = {_eng(step, 's')}, θ = {theta:g}: "
            f"{st.steps} steps{shortened} in {wall:.3g} s "
            f"({1e6 * wall / max(st.steps, 1):.3g} µs/step)"
            + (f", after {load:.3g} s compiling the kernels (once: later runs load them)"
               if compiled and load else
               f", after {load:.2g} s loading the compiled kernels" if load else ""))
    if switches:
        visited = list(result.modes_visited)
        modes = [_mode_text(switches, mode) for mode in visited[:_MAX_MODES_SHOWN]]
        if len(visited) > _MAX_MODES_SHOWN:
            modes.append(f"... ({len(visited)} in all)")
        lines.append(f"switch modes visited: {' '.join(modes)}; {result.switchings} "
                     "switching events")
    if st.steps and method != "exact" and st.kernel == "sparse":
        lines.append(f"LCPs: {st.steps - st.dense_steps} of {st.steps} steps solved on the "
                     f"circuit's network (sparse kernel, {st.factorisations} factorisations), "
                     f"{st.dense_steps} by the dense kernel ({st.fallbacks} by Lemke); "
                     f"{st.warm_solves} pivoted from the previous step's active set")
    elif st.steps and method != "exact":
        lines.append(f"LCPs: {st.steps - st.fallbacks} of {st.steps} solved by the previous "
                     f"step's active set, {st.fallbacks} by Lemke ({st.lcp_pivots} pivots)")
    if len(result.t):
        finals = ", ".join(f"{n} = {_eng(v, probe_unit(n))}" for n, v in
                           zip(result.names[:_MAX_FINALS_SHOWN], result.y[-1], strict=False))
        if len(result.names) > _MAX_FINALS_SHOWN:
            finals += f", ... ({len(result.names)} probes, all in the output)"
        lines.append(f"final values (t = {_eng(result.t[-1], 's')}): {finals}")
    for note in result.notes:
        lines.append(f"note: {note}")
    if written:
        lines.append(f"wrote {', '.join(written)} ({result.points} points"
                     + (f", {points}" if points else "") + ")")
    return "\n".join(lines)

