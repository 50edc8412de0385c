"""``pelcs bifurcation FILE``: bifurcation diagram of a netlist over one ``.param``.

::

    pelcs bifurcation FILE --param NAME=START:STOP[:N] [--period T] --transient N --record M
                      [--probe EXPR]... [--follow [--direction up|down|both]] [--chunks C]
                      [--param OTHER=VALUE]... [--x0 ...] [--step H] [--theta TH] [--t0 T0]
                      [--workers W] [--scheduler ADDRESS] [-o OUT.csv|OUT.npz]
                      [--plot OUT.png] [--confirm]

For each of COUNT values from START to STOP the circuit is simulated for N + M periods T from
the initial state (netlist ``IC=``/``.ic`` or ``--x0``); the probes (default: every state)
sampled at the last M period instants are the diagram. ``--follow`` starts every value from
the final state of the previous one instead (the attractor is followed; default direction
``both``: an up sweep and a down sweep, which shows hysteresis). Values run in parallel on all
cores (``--workers``); a follow sweep is sequential per direction (the two directions run in
parallel; ``--chunks C`` splits each direction into C pieces that each start from the initial
state). ``--scheduler ADDRESS`` runs the values on the workers of a Dask scheduler instead
(``tcp://host:8786``; ``local`` starts a Dask cluster on this machine): the diagram is the same.
A summary of the attractor period along the parameter is printed: a period only where the
recorded points have settled (a record whose cycle shrinks geometrically towards a lower
period is a transient: "not settled"), and the reason of every failed value. ``--confirm``
runs the orbit solver at the middle value of each run, from its recorded state, and prints
the orbit's stability and multipliers.

Outputs: ``-o OUT.csv`` (rows ``direction, NAME, k, probes...``) or ``-o OUT.npz`` (arrays
per direction, see :meth:`lcs.analysis.bifurcation.BifurcationDiagram.arrays`); ``--plot``
a scatter plot (PNG/SVG/PDF).

Ctrl-C (SIGINT) or SIGTERM stops the diagram: the values under way are dropped, the finished
ones are written and summarised with a note "interrupted after K of N parameter values"; a
second Ctrl-C aborts at once, writing nothing.

Exit status: 0 success (also when some values diverged: they are NaN and counted in the
summary); 2 input errors; 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
from pathlib import Path

import numpy as np

from lcs import interrupt
from lcs.interrupt import deferred_interrupts
from pelcs.outputs import interrupt_message, interrupted_status, write_outputs
from pelcs.writers import write_bifurcation

from . import options
from .orbit import (
    add_map_options,
    initial_state,
    make_factory,
    period_notes,
    positive_int,
    usage_error,
)


def register(subparsers) -> None:
    """Add the ``bifurcation`` subcommand."""
    p = subparsers.add_parser(
        "bifurcation",
        help="bifurcation diagram: sweep a .param, record the sampled attractor",
        description="Sweep one .param; at each value discard a transient and record the "
        "probes once per period T (stroboscopic samples). Fixed initial state, or --follow "
        "the attractor up and down the range.",
        epilog="example: pelcs bifurcation vm_buck.cir --param vin=20:35:300 --period tp "
        "--transient 300 --record 100 --probe 'v(out)' --plot diagram.png",
    )
    add_map_options(p, param_help="the swept parameter (once): "
                    f"{options.range_help('bifurcation')}; NAME=VALUE: a fixed override "
                    "(repeatable)")
    p.add_argument("--transient", required=True, metavar="N", help="periods discarded")
    p.add_argument("--record", required=True, metavar="M", help="periods recorded")
    options.add_probe(p,
                   help="v(NODE), v(A,B), i(ELEMENT) or a state (repeatable); "
                   "default: every state")
    p.add_argument("--follow", action="store_true",
                   help="start each value from the previous value's final state")
    p.add_argument("--direction", choices=("up", "down", "both"), default="both",
                   help="with --follow: sweep direction(s) (default both)")
    p.add_argument("--chunks", metavar="C",
                   help="with --follow: independent pieces per direction (default 1)")
    p.add_argument("--workers", metavar="W", help="worker processes (default: all cores)")
    options.add_scheduler(p)
    options.add_output(p, "OUT", help="write OUT.csv or OUT.npz")
    p.add_argument("--plot", metavar="OUT.png", help="scatter plot of the diagram")
    p.add_argument("--confirm", action="store_true",
                   help="confirm each run of the summary with the orbit solver (Newton from "
                   "the recorded state at the run's middle value): the orbit's multipliers")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


@contextlib.contextmanager
def scheduler_errors(command: str):
    """Turn a :class:`~lcs.analysis.parallel.SchedulerError` into an input error (exit 2)."""
    from lcs.analysis.parallel import SchedulerError

    try:
        yield
    except SchedulerError as exc:
        raise usage_error(command, f"--scheduler: {exc}",
                          exc.hint or "start a scheduler with 'dask scheduler' and workers "
                          "with 'dask worker ADDRESS' (same pelcs version), or drop "
                          "--scheduler to run on this machine") from None


def check_output(command: str, option: str, path: str | None, suffixes: tuple[str, ...]
                 ) -> Path | None:
    if path is None:
        return None
    p = Path(path)
    if p.suffix.lower() not in suffixes:
        raise usage_error(command, f"{option}: cannot tell the format of {path!r}",
                          f"use a file name ending in {' or '.join(suffixes)}")
    return p


def run(args: argparse.Namespace) -> int:
    from pelcs.analysis_plots import plot_bifurcation

    setup = prepare(args)
    factory, m, circuit = setup["factory"], setup["m"], setup["circuit"]
    out, plot = setup["out"], setup["plot"]
    with deferred_interrupts(interrupt_message("bifurcation", "values")):
        diagram = compute(args, setup)
        stopped = interrupt.requested() is not None
        if plot is not None and not any(b.values.size for b in diagram.branches):
            diagram.notes.append("no plot written: no value finished")
        written = write_outputs("bifurcation", (
            (out, lambda path: write_bifurcation(diagram, path)),
            # (nothing to plot when an interrupt came before any value finished)
            (plot if any(b.values.size for b in diagram.branches) else None,
             lambda path: plot_bifurcation(diagram, path,
                                           title=circuit.title or Path(args.file).name)),
        ))
        confirmations = confirm_runs(diagram, factory) if args.confirm and not stopped \
            else None
        if args.confirm and stopped:
            diagram.notes.append("--confirm skipped: the run was interrupted")
        print(summary(diagram, args.file, circuit.title, m, written, confirmations))
        not_written = written.exit_status()
        status = interrupted_status(args.file, diagram.notes, "the diagram was interrupted",
                                    written, not_written)
        return not_written if status is None else status


def prepare(args: argparse.Namespace) -> dict:
    """The parsed options of a diagram, its factory, the map and circuit at the first value
    (input errors raised here, before any run)."""
    from netlist.studies.sweep import split_params
    from netlist.studies.transient import check_probes

    from .simulate import split_probes

    ranges, fixed = split_params(args.param)
    if len(ranges) != 1:
        raise usage_error("bifurcation", "give exactly one --param NAME=START:STOP[:N]",
                          "e.g. --param vin=20:35:300 (fixed values: --param a=8.4)")
    rng = ranges[0]
    transient = positive_int("bifurcation", "--transient", args.transient, 0)
    record = positive_int("bifurcation", "--record", args.record)
    workers = positive_int("bifurcation", "--workers", args.workers) if args.workers else None
    chunks = positive_int("bifurcation", "--chunks", args.chunks) if args.chunks else None
    out = check_output("bifurcation", "-o", args.output, (".csv", ".npz"))
    plot = check_output("bifurcation", "--plot", args.plot, (".png", ".svg", ".pdf"))
    factory = make_factory(args, "bifurcation", swept=rng.name, fixed=fixed)
    values = rng.values(options.RANGE_COUNTS["bifurcation"])
    m = factory(float(values[0]))  # validates netlist, parameter name and period here
    circuit = factory.circuit(float(values[0]))
    probes = check_probes(circuit, split_probes(args.probe)) if args.probe else None
    if probes:
        m.system.outputs(m.system.key(None), probes)
    x0 = initial_state(args, m)
    directions = ("up", "down") if args.direction == "both" else (args.direction,)
    return dict(rng=rng, values=values, factory=factory, m=m, circuit=circuit, x0=x0,
                probes=probes, transient=transient, record=record, workers=workers,
                chunks=chunks, directions=directions, out=out, plot=plot)


def compute(args: argparse.Namespace, setup: dict):
    """The :class:`~lcs.analysis.bifurcation.BifurcationDiagram` of :func:`prepare`'s setup,
    its notes starting with the period's (shared with :func:`pelcs.bifurcation`)."""
    from lcs.analysis.bifurcation import bifurcation_diagram

    with scheduler_errors("bifurcation"):
        diagram = bifurcation_diagram(
            setup["factory"], setup["values"], x0=setup["x0"], transient=setup["transient"],
            record=setup["record"], probes=setup["probes"], follow=args.follow,
            directions=setup["directions"], workers=setup["workers"],
            chunks=setup["chunks"], progress=not args.no_progress,
            param_name=setup["rng"].name, scheduler=args.scheduler,
        )
    from netlist.studies.sweep import knee_notes

    diagram.notes[:0] = period_notes(setup["m"]) + knee_notes(setup["m"], setup["record"])
    return diagram


def period_runs(values: np.ndarray, samples: np.ndarray, ok: np.ndarray,
                messages: list[str] | None = None) -> list[tuple[float, float, str]]:
    """Contiguous parameter runs with the same verdict: ``(from, to, label)``.

    The verdict is :func:`~lcs.analysis.bifurcation.classify_attractor`'s (a period only
    when the record has settled), or ``failed: <why>`` for a value whose run failed.
    """
    labels = [a.label if a is not None else f"failed: {msg or 'no reason given'}"
              for a, msg in zip(verdicts(samples, ok), messages or [""] * len(ok),
                                strict=True)]
    runs: list[tuple[float, float, str]] = []
    for v, lab in zip(values, labels, strict=True):
        if runs and runs[-1][2] == lab:
            runs[-1] = (runs[-1][0], float(v), lab)
        else:
            runs.append((float(v), float(v), lab))
    return runs


def verdicts(samples: np.ndarray, ok: np.ndarray) -> list:
    """The :class:`~lcs.analysis.bifurcation.Attractor` of each value (None where it failed)."""
    from lcs.analysis.bifurcation import classify_attractor

    return [classify_attractor(s, rtol=1e-7) if good else None
            for s, good in zip(samples, ok, strict=True)]


def confirm_runs(diagram, factory, *, tol: float = 1e-10) -> list[str]:
    """Lines confirming each run of the summary with the orbit solver.

    For every contiguous run of values with one verdict, the value in its middle: Newton
    shooting (:func:`~lcs.analysis.orbits.find_orbit`) from the recorded final state for the
    orbit of the run's period (a run not settled: the period it decays onto), and its
    multipliers. A run that is not the attractor the solver finds says so.
    """
    from lcs.analysis.maps import MapError
    from lcs.analysis.orbits import find_orbit

    from .orbit import fmt_complex

    lines = []
    for b in diagram.branches:
        att = verdicts(b.samples, b.ok)
        i = 0
        while i < len(att):
            j = i
            lab = att[i].label if att[i] is not None else None
            while j + 1 < len(att) and (att[j + 1].label if att[j + 1] is not None
                                        else None) == lab:
                j += 1
            mid = (i + j) // 2
            a, v = att[mid], float(b.values[mid])
            i = j + 1
            if a is None or (a.period == 0 and a.settled) or (not a.settled and not a.onto):
                continue
            order = a.period if a.settled else a.onto
            where = f"{diagram.param_name} = {v:.6g} ({b.direction})"
            try:
                orb = find_orbit(factory(v), b.x_final[mid], order, tol=tol, pattern=False)
            except MapError as exc:
                lines.append(f"  {where}: the orbit solver failed: {exc}")
                continue
            if not orb.converged:
                lines.append(f"  {where}: no period-{order} orbit found near the recorded "
                             f"state (Newton: scaled residual {orb.residual:.3g})")
                continue
            mu = ", ".join(fmt_complex(m) for m in orb.multipliers)
            lines.append(f"  {where}: period-{order} orbit, {orb.stability}; multipliers "
                         f"{mu}")
    return lines or ["  nothing to confirm (no run with a period)"]


def summary(diagram, file: str, title: str, m, written: list[str],
            confirmations: list[str] | None = None) -> str:
    from netlist.units import format_eng

    lines = [f"{file}: {title}".rstrip(": ")]
    k = diagram.branches[0].values.size
    mode = ("follow (" + " and ".join(b.direction for b in diagram.branches) + ")"
            if diagram.follow else "fixed initial state")
    lines.append(f"{diagram.param_name}: {k} values, {mode}; T = {format_eng(m.period, 's')}, "
                 f"{_how(m)}; {diagram.transient} periods discarded, "
                 f"{diagram.record} recorded; {diagram.wall_time:.3g} s"
                 + (f" on {diagram.engine}" if diagram.engine else ""))
    unsettled = 0
    for b in diagram.branches:
        lines.append(f"attractor period along {diagram.param_name} ({b.direction}):")
        for lo, hi, lab in period_runs(b.values, b.samples, b.ok, b.messages):
            span = f"{lo:.6g}" if lo == hi else f"{lo:.6g} .. {hi:.6g}"
            lines.append(f"  {span:>24}: {lab}")
        unsettled += sum(a is not None and not a.settled for a in verdicts(b.samples, b.ok))
    if confirmations is not None:
        lines.append("orbit solver, at the middle of each run (from its recorded state):")
        lines.extend(confirmations)
    for note in diagram.notes:
        lines.append(f"note: {note}")
    if unsettled:
        lines.append(f"note: {unsettled} value(s) have not settled: lengthen --transient"
                     + ("" if confirmations is not None else
                        ", or --confirm the runs with the orbit solver"))
    if written:
        lines.append(f"wrote {', '.join(written)}")
    return "\n".join(lines)


def _how(m) -> str:
    """How the map integrates: its step, or "exact"."""
    from netlist.units import format_eng

    if getattr(m, "method", "moreau") == "exact":
        return "exact flows and events"
    return f"h = {format_eng(m.h, 's')}"
