"""``pelcs basins FILE``: basins of attraction by simple cell mapping.

::

    pelcs basins FILE [--period T] --grid "v(C1)=A:B:N,i(L1)=C:D:M" [--param NAME=VALUE]...
                 [--x0 STATE=V,...] [--step H] [--theta TH] [--t0 T0] [--workers W]
                 [--scheduler ADDRESS] [--no-merge] [-o OUT.npz] [--plot OUT.png]

The rectangle of the two grid states (the others fixed at the netlist initial state or
``--x0``) is cut into N x M cells; each cell centre is mapped once through the stroboscopic
map (one period T, in parallel: local processes, or the workers of a Dask scheduler with
``--scheduler ADDRESS``, ``local`` for a Dask cluster on this machine); the periodic groups of
the resulting cell map are the attractors, and every cell is labelled with the attractor its
chain ends in and the number of periods it takes (Hsu's simple cell mapping). Chains that
leave the rectangle end in the *sink*. Touching periodic groups are merged into one attractor
unless ``--no-merge``.

Outputs: a summary (attractors, their cells and basin sizes), ``-o OUT.npz`` (``group``,
``steps``, ``image`` arrays and the axes) and ``--plot`` (basins and transient time).

Ctrl-C (SIGINT) or SIGTERM stops the map: the cells under way are dropped; the cells not
computed, and those whose image chain reaches one, get group and steps -1 (white in the plot;
``computed`` in the NPZ), and the rest is written with a note "interrupted after K of N
cells"; a second Ctrl-C aborts at once, writing nothing.

Exit status: 0 success; 2 input errors; 130 interrupted.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from lcs.interrupt import deferred_interrupts
from pelcs.outputs import interrupt_message, interrupted_status, write_outputs
from pelcs.writers import write_basins

from . import options
from .bifurcation import check_output, scheduler_errors
from .orbit import (
    add_map_options,
    initial_state,
    make_factory,
    period_notes,
    positive_int,
    usage_error,
)


def register(subparsers) -> None:
    """Add the ``basins`` subcommand."""
    p = subparsers.add_parser(
        "basins",
        help="basins of attraction of the stroboscopic map (simple cell mapping)",
        description="Cell-to-cell mapping over a grid of two states: attractors, their "
        "basins and the periods each cell takes to reach its attractor.",
        epilog="example: pelcs basins vm_buck.cir --period tp --param vin=30 "
        "--grid \"v(C1)=10:14:200,i(L1)=0:1.2:200\" --plot basins.png",
    )
    add_map_options(p, param_help="override a global .param (repeatable)")
    p.add_argument("--grid", required=True, metavar="S1=A:B[:N],S2=C:D[:M]",
                   help="two states with their ranges and cell counts: "
                   f"{options.range_help('basins', 'STATE', 'cells')}")
    p.add_argument("--workers", metavar="W", help="worker processes (default: all cores)")
    options.add_scheduler(p)
    p.add_argument("--no-merge", action="store_true",
                   help="keep touching periodic groups as separate attractors")
    options.add_output(p, "OUT.npz", help="write the cell data")
    p.add_argument("--plot", metavar="OUT.png", help="plot basins and transient time")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from pelcs.analysis_plots import plot_basins

    setup = prepare(args)
    factory, m, out, plot = setup["factory"], setup["m"], setup["out"], setup["plot"]
    with deferred_interrupts(interrupt_message("basins", "cells")):
        bm = compute(args, setup)
        title = factory.circuit().title
        written = write_outputs("basins", (
            (out, lambda path: write_basins(bm, path)),
            (plot, lambda path: plot_basins(bm, path,
                                            title=f"basins: {title or Path(args.file).name}")),
        ))
        print(summary(bm, args.file, title, m, written))
        not_written = written.exit_status()
        status = interrupted_status(args.file, bm.notes, "the basins were interrupted",
                                    written, not_written)
        return not_written if status is None else status


def prepare(args: argparse.Namespace) -> dict:
    """The parsed options, the factory and the map (input errors raised here)."""
    from netlist.parser import parse_overrides
    from netlist.studies.sweep import parse_grid

    fixed = parse_overrides(args.param)
    factory = make_factory(args, "basins", fixed=fixed)
    axes = parse_grid(args.grid, default_count=options.RANGE_COUNTS["basins"])
    workers = positive_int("basins", "--workers", args.workers) if args.workers else None
    out = check_output("basins", "-o", args.output, (".npz",))
    plot = check_output("basins", "--plot", args.plot, (".png", ".svg", ".pdf"))
    m = factory()
    lower = [s.lower() for s in m.state_names]
    for name, *_ in axes:
        if name.lower() not in lower:
            raise usage_error("basins", f"--grid: {name!r} is not a state of the circuit",
                              f"states: {', '.join(m.state_names)}")
    if axes[0][0].lower() == axes[1][0].lower():
        raise usage_error("basins", "--grid: the two axes must be different states")
    base = initial_state(args, m)
    return dict(factory=factory, m=m, axes=axes, workers=workers, base=base, out=out,
                plot=plot)


def compute(args: argparse.Namespace, setup: dict):
    """The :class:`~lcs.analysis.basins.BasinMap` of :func:`prepare`'s setup, its notes
    starting with the period's (shared with :func:`pelcs.basins`)."""
    from lcs.analysis.basins import cell_basins

    with scheduler_errors("basins"):
        bm = cell_basins(setup["factory"], setup["axes"], param=None,
                         base_state=setup["base"], merge_adjacent=not args.no_merge,
                         workers=setup["workers"], progress=not args.no_progress,
                         scheduler=args.scheduler)
    bm.notes[:0] = period_notes(setup["m"])
    return bm


def summary(bm, file: str, title: str, m, written: list[str]) -> str:
    from netlist.units import format_eng

    a0, a1 = bm.grid.axes
    n = bm.grid.size
    lines = [f"{file}: {title}".rstrip(": ")]
    others = [f"{s} = {v:.6g}" for i, (s, v) in enumerate(zip(m.state_names, bm.base_state,
                                                             strict=True))
              if i not in bm.state_indices]
    lines.append(f"simple cell mapping: {a0.name} {a0.lo:g}..{a0.hi:g} ({a0.count} cells) x "
                 f"{a1.name} {a1.lo:g}..{a1.hi:g} ({a1.count} cells)"
                 + (f", {', '.join(others)}" if others else "")
                 + f"; T = {format_eng(m.period, 's')}, {_how(m)}; "
                 f"{bm.wall_time:.3g} s" + (f" on {bm.engine}" if bm.engine else ""))
    sink = int(np.count_nonzero(bm.group == 0))
    lines.append(f"{len(bm.attractors)} attractor(s); {sink} of {n} cells "
                 f"({100 * sink / n:.1f} %) leave the grid")
    for at in bm.attractors:
        centre = ", ".join(f"{nm} = {v:.6g}" for nm, v in
                           zip((a0.name, a1.name), at.points.mean(axis=0), strict=True))
        steps = bm.steps.ravel()[bm.group.ravel() == at.group]
        lines.append(f"  attractor {at.group}: {at.period} periodic cell(s) around {centre}; "
                     f"basin {at.basin_cells} cells ({100 * at.basin_cells / n:.1f} %), "
                     f"reached in at most {int(steps.max())} periods")
    for note in bm.notes:
        lines.append(f"note: {note}")
    if written:
        lines.append(f"wrote {', '.join(written)}")
    return "\n".join(lines)


def _how(m) -> str:
    """How the map integrates: its step, or "exact"."""
    from netlist.units import format_eng

    if getattr(m, "method", "moreau") == "exact":
        return "exact flows and events"
    return f"h = {format_eng(m.h, 's')}"
