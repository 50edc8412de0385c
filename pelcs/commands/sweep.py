"""``pelcs sweep FILE``: parameter sweeps and Monte Carlo runs, measured in steady state.

::

    pelcs sweep FILE --measure 'FUNC(PROBE)'... [--param NAME=START:STOP[:N]]...
                [--param NAME=V1,V2,...]... [--param NAME=VALUE]...
                [--tolerance PATTERN=N%]... [--runs N] [--seed S]
                [--distribution uniform|gaussian] [--tstop T] [--step H] [--theta TH]
                [--period T] [--workers W] [--scheduler ADDRESS]
                [-o OUT.csv] [--plot OUT.png] [--json]

The netlist's own ``.step param`` lines are swept too (a ``--param`` for the same name wins).
Every combination of the swept ``.param`` values is simulated (SPICE's ``.step param``) and
measured over the steady-state window (the last whole periods, up to 10, as ``pelcs check``):
``mean``, ``rms``, ``ripple`` (peak-to-peak), ``min``, ``max`` of any probe, or its ``final``
value. With ``--tolerance`` and ``--runs N`` each point is simulated N times with the
element values drawn within their tolerances (Monte Carlo): ``R1=5%`` (relative), ``'C*=10%'``
(a glob over element names, case-insensitive), ``L1=2u`` (absolute); uniform draws by default,
``--distribution gaussian`` takes the tolerance as 3 σ. ``--seed`` makes the draws
reproducible (without it a seed is chosen and printed).

The runs go to local processes, or to the workers of a Dask scheduler with ``--scheduler
ADDRESS`` (``local`` starts a Dask cluster on this machine); the table is the same.

With a parameter grid, every grid point also has a nominal run, and the statistics and
histograms are per grid point.

Every run is checked for a settled window: the probe of each measurement is averaged over each
period of the window (the last two periods when the window has one; four quarters without a
period), and the spread of these averages must stay within 0.1 % of the probe's RMS for
``mean``, ``rms``, ``final``, within 10 % of its ripple per period for ``ripple``, ``min``,
``max``. A run outside is flagged (``settled`` 0 in the CSV, a message, a note naming the runs
and suggesting a longer ``--tstop``); its measurements stay in the table.

Outputs: a table on the terminal (Monte Carlo: the statistics of each measurement per grid
point), ``-o OUT.csv`` (one row per run: parameters, ``run``, the drawn values, the
measurements, ``ok``, ``settled``, ``message``; SI units), ``--plot`` (measurements against the
first swept parameter, or histograms for a Monte Carlo run, one panel per grid point and
measurement), ``--json`` (the table and statistics as strict JSON: null for NaN and
infinities).

Limits: 100000 values per swept parameter (as ``.step``), 1000000 runs per sweep, histograms
of at most 12 grid points. The options, the times and the output files are checked before any
run.

Ctrl-C (SIGINT) or SIGTERM stops the sweep: the runs under way are dropped, the finished ones
are written (the table, or the Monte Carlo statistics of the finished runs, with ``not run``
rows for the others) with a note "interrupted after K of N runs"; a second Ctrl-C aborts at
once, writing nothing.

Exit status: 0 success (also when some runs failed: NaN, counted in the notes); 2 input
errors; 3 every run failed; 130 interrupted.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
from pathlib import Path

import numpy as np

from lcs.interrupt import deferred_interrupts
from netlist.errors import NetlistError
from pelcs.jsonout import dumps, json_ready
from pelcs.outputs import interrupt_message, interrupted_status, write_outputs
from pelcs.writers import write_sweep

from . import options
from .bifurcation import check_output, scheduler_errors
from .orbit import EXIT_FAILED, positive_int, usage_error

# Rows of a sweep printed on the terminal (the CSV has them all).
MAX_ROWS = 60


def register(subparsers) -> None:
    """Add the ``sweep`` subcommand."""
    p = subparsers.add_parser(
        "sweep",
        help="parameter sweeps and Monte Carlo runs, measured over the steady state",
        description="Simulate a netlist over a grid of .param values and/or with element "
        "values drawn within tolerances; measure mean, rms, ripple, min, max or the final "
        "value of probes over the steady-state window; write a table. Monte Carlo "
        "statistics and histograms are per grid point. A run is flagged 'not settled' when "
        "the averages of a measured probe over the periods of the window spread by more than "
        "0.1 % of its RMS (mean, rms, final) or 10 % of its ripple per period (ripple, min, "
        "max): simulate longer (--tstop).",
        epilog="examples: pelcs sweep buck.cir --param duty=0.2:0.8:7 --measure 'mean(v(out))'"
        " --measure 'ripple(i(L1))' -o duty.csv;  pelcs sweep buck.cir --tolerance 'C*=10%' "
        "--tolerance R1=5% --runs 200 --seed 1 --measure 'ripple(v(out))' --plot mc.png",
    )
    p.add_argument("file", help="netlist file")
    p.add_argument("--measure", action="append", default=[], metavar="FUNC(PROBE)",
                   help="mean, avg, rms, ripple, pp, min, max or final of a probe, e.g. "
                   "'mean(v(out))' (repeatable; required)")
    options.add_param(p, metavar="NAME=START:STOP[:N]",
                   help=f"a swept .param ({options.range_help('sweep')}, or NAME=V1,V2,...) "
                   "or a fixed override NAME=VALUE (repeatable)")
    p.add_argument("--tolerance", action="append", default=[], metavar="PATTERN=N%",
                   help="Monte Carlo tolerance of the elements whose names match PATTERN "
                   "(glob): N%% relative, or an absolute value (repeatable)")
    p.add_argument("--runs", metavar="N", help="Monte Carlo runs (per parameter point)")
    p.add_argument("--seed", metavar="S", help="random seed of the Monte Carlo draws")
    p.add_argument("--distribution", choices=("uniform", "gaussian"), default="uniform",
                   help="uniform within ±tol (default), or gaussian with σ = tol/3")
    p.add_argument("--tstop", metavar="T",
                   help="stop time (default: .tran TSTOP); make it long enough for the "
                   "measurements to settle (runs that have not are flagged)")
    options.add_step(p)
    options.add_theta(p,
                   help="Moreau θ in [0.5, 1] (default 0.5, or 1 where θ < 1 is found "
                   "unreliable)")
    options.add_period(p,
                   help="steady-state period (seconds or a .param name); default the period "
                   "of the source at a switch's control")
    p.add_argument("--workers", metavar="W", help="worker processes (default: all cores)")
    options.add_scheduler(p)
    options.add_output(p, "OUT.csv", help="write the table")
    p.add_argument("--plot", metavar="OUT.png",
                   help="measurements against the first swept parameter, or histograms")
    options.add_json(p,
                   help="print the results as JSON (NaN and infinities as null)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    with labelled_errors():
        return _run(args)


@contextlib.contextmanager
def labelled_errors():
    """The shared option parsers (netlist.studies.sweep, netlist.studies.measure, simulate's
    numbers) name another command or the tool only: every error of this command starts
    "pelcs sweep: error:"."""
    try:
        yield
    except NetlistError as exc:
        if exc.file in ("pelcs", "pelcs simulate"):
            exc.file = "pelcs sweep"
        raise


def prepare(args: argparse.Namespace) -> dict:
    """The parsed and checked options of a sweep (input errors raised here, before any
    run)."""
    from lcs.analysis.tables import MAX_HISTOGRAM_POINTS
    from netlist.parser import parse_file
    from netlist.studies.param_sweep import parse_sweep_param
    from netlist.studies.sweep import parse_value

    from .simulate import _number

    if not args.measure:
        raise usage_error("sweep", "nothing to measure",
                          "give --measure FUNC(PROBE), e.g. --measure 'mean(v(out))'")
    params: dict[str, float | np.ndarray] = {}
    for item in args.param:
        name, value = parse_sweep_param(item, default_count=options.RANGE_COUNTS["sweep"])
        if name.lower() in {k.lower() for k in params}:
            raise usage_error("sweep", f"--param {name} is given twice")
        params[name] = value
    runs = positive_int("sweep", "--runs", args.runs) if args.runs else 0
    seed = positive_int("sweep", "--seed", args.seed, 0) if args.seed is not None else None
    workers = positive_int("sweep", "--workers", args.workers) if args.workers else None
    theta = parse_value(args.theta, "--theta") if args.theta is not None else None
    tstop = _number("--tstop", args.tstop, ("", "s"))
    step = _number("--step", args.step, ("", "s"))
    for option, value, example in (("--tstop", tstop, "20m"), ("--step", step, "0.1u")):
        if value is not None and not value > 0:
            raise usage_error("sweep", f"{option} {getattr(args, option[2:])}: must be "
                              "positive", f"e.g. {option} {example}")
    period: float | str | None = args.period
    if args.period is not None:
        try:
            period = parse_value(args.period, "--period")
        except Exception:  # noqa: BLE001 - a .param name, resolved per point
            period = args.period
    out = check_output("sweep", "-o", args.output, (".csv",))
    plot = check_output("sweep", "--plot", args.plot, (".png", ".svg", ".pdf"))
    # The netlist's .step lines are swept parameters too: read them before judging --plot.
    circuit = parse_file(args.file, params={k: float(np.ravel(v)[0]) for k, v in
                                            params.items()} or None)
    given = {k.lower() for k in params}
    sizes = [np.size(v) for v in params.values() if np.ndim(v) > 0]
    sizes += [len(vals) for name, vals in circuit.steps if name.lower() not in given]
    if plot is not None and not sizes and not runs:
        raise usage_error("sweep", "--plot needs a swept parameter or a Monte Carlo run",
                          "give --param NAME=START:STOP:N (or a .step in the netlist), or "
                          "--tolerance with --runs")
    points = math.prod(sizes)
    if plot is not None and runs and points > MAX_HISTOGRAM_POINTS:
        raise usage_error("sweep", f"--plot: {points} grid points, histograms of at most "
                          f"{MAX_HISTOGRAM_POINTS}",
                          "sweep fewer values for the plot, or write the runs with -o")
    # Before the runs: an output that cannot be written is found now, not after them.
    for option, path in (("-o", out), ("--plot", plot)):
        if path is not None:
            _check_writable(option, path)
    return dict(out=out, plot=plot, title=circuit.title, params=params, runs=runs, seed=seed,
                workers=workers, theta=theta, tstop=tstop, step=step, period=period)


def _run(args: argparse.Namespace) -> int:
    setup = prepare(args)
    with deferred_interrupts(interrupt_message("sweep", "runs")):
        return _sweep(args, setup)


def compute(args: argparse.Namespace, setup: dict):
    """The :class:`~lcs.analysis.tables.SweepTable` of :func:`prepare`'s setup (shared with
    :func:`pelcs.sweep`)."""
    from netlist.studies.param_sweep import run_sweep

    with scheduler_errors("sweep"):
        return run_sweep(
            args.file, args.measure, params=setup["params"], tolerances=args.tolerance,
            runs=setup["runs"], seed=setup["seed"], distribution=args.distribution,
            tstop=setup["tstop"], step=setup["step"], theta=setup["theta"],
            period=setup["period"], workers=setup["workers"], scheduler=args.scheduler,
            progress=not args.no_progress)


def _sweep(args, setup: dict) -> int:
    """The runs, the files and the summary; the exit status."""
    from pelcs.sweep_plots import plot_table

    out, plot, title = setup["out"], setup["plot"], setup["title"]
    table = compute(args, setup)
    if plot is not None and not len(table):
        table.notes.append("no plot written: no run finished")
    written = write_outputs("sweep", (
        (out, lambda path: write_sweep(table, path)),
        # (nothing to plot when an interrupt came before any run finished)
        (plot if len(table) else None,
         lambda path: plot_table(table, path, title=plot_title(table, title, args.file))),
    ))
    if args.json:
        print(dumps(_results(table, args.file, title, written), indent=1))
    else:
        print(summary(table, args.file, title, written))
    not_written = written.exit_status()
    stopped = interrupted_status(args.file, table.notes, "the sweep was interrupted", written,
                                 not_written)
    if stopped is not None:
        return stopped
    return not_written or (0 if table.ok.any() else EXIT_FAILED)


def _check_writable(option: str, path: Path) -> None:
    """Check that ``path`` can be written, without changing anything: an existing file (or a
    symbolic link's target) is opened for writing without truncation; a new one is created
    and removed again; a folder that does not exist yet is not made (the writer makes it):
    its nearest existing ancestor must be a writable folder."""
    try:
        target = Path(os.path.realpath(path))  # (a symbolic link, dangling or not: its target)
        if target.is_dir():
            raise IsADirectoryError(21, "it is a directory")
        if target.exists():
            os.close(os.open(target, os.O_WRONLY))
        elif target.parent.is_dir():
            os.close(os.open(target, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644))
            target.unlink()
        else:
            ancestor = target.parent
            while not ancestor.exists():
                ancestor = ancestor.parent
            if not ancestor.is_dir():
                raise NotADirectoryError(20, f"{ancestor} is not a directory")
            if not os.access(ancestor, os.W_OK | os.X_OK):
                raise PermissionError(13, f"cannot create folders in {ancestor}")
    except OSError as exc:
        raise usage_error("sweep", f"{option}: cannot write {path}: {exc.strerror or exc}",
                          "choose a writable file") from None


def plot_title(table, title: str, file: str) -> str:
    name = title or Path(file).name
    if table.runs:
        return f"{name}: Monte Carlo, {table.runs} runs ({table.distribution}, seed {table.seed})"
    return f"{name}: sweep of {', '.join(table.swept)}"


def _fmt(v: float, unit: str) -> str:
    from netlist.units import format_eng

    if not np.isfinite(v):
        return "nan"
    return format_eng(float(v), unit) if unit else f"{v:.6g}"


def summary(table, file: str, title: str, written: list[str]) -> str:
    lines = [f"{file}: {title}".rstrip(": ")]
    n = len(table)
    what = []
    if table.swept:
        for name in table.swept:
            vals = np.unique(table.column(name))
            if not vals.size:  # (an interrupted sweep before any run finished)
                what.append(f"{name}: no value finished")
                continue
            what.append(f"{name} {vals.min():.6g}..{vals.max():.6g} ({vals.size} values)"
                        if vals.size > 1 else f"{name} = {vals[0]:.6g}")
    if table.runs:
        what.append(f"Monte Carlo {table.runs} runs, {table.distribution}, seed {table.seed}")
    lines.append(f"{'; '.join(what) or 'one run'}: {n} run(s), {int(table.ok.sum())} ok; "
                 f"{table.wall_time:.3g} s on {table.engine}")
    if table.tolerances:
        lines.append("tolerances: " + ", ".join(table.tolerances))
    for note in table.notes:
        lines.append(f"note: {note}")
    if table.runs:
        lines.extend(_stats_lines(table))
    else:
        lines.extend(_table_lines(table))
    if written:
        lines.append(f"wrote {', '.join(written)}")
    return "\n".join(lines)


def _table_lines(table) -> list[str]:
    cols = list(table.swept) + list(table.measures)
    width = [max(12, len(c) + 2) for c in cols]
    out = ["".join(c.rjust(w) for c, w in zip(cols, width, strict=True))]
    rows = range(len(table))
    shown = list(rows) if len(table) <= MAX_ROWS else list(rows[:MAX_ROWS // 2]) + [-1] + \
        list(rows[-MAX_ROWS // 2:])
    for i in shown:
        if i < 0:
            out.append(f"  ... {len(table) - MAX_ROWS} more rows (write them with -o) ...")
            continue
        cells = [f"{table.column(c)[i]:.6g}" for c in table.swept]
        cells += [_fmt(table.column(c)[i], table.units.get(c, "")) for c in table.measures]
        line = "".join(s.rjust(w) for s, w in zip(cells, width, strict=True))
        if not table.ok[i]:
            line += f"   failed: {table.messages[i]}"
        elif not table.settled[i]:
            line += f"   (not settled: {', '.join(table.unsettled[i])})"
        out.append(line)
    return out


def _stats_lines(table) -> list[str]:
    """The statistics of every measurement, one block of rows per grid point."""
    head = ["measurement", "nominal", "mean", "std", "min", "p5", "p95", "max"]
    pre = list(table.swept)
    pre_w = [max(10, len(c) + 2) for c in pre]
    width = [max(14, *(len(m) + 2 for m in table.measures))] + [13] * 7

    def line(first: list[str], cells: list[str]) -> str:
        return "".join(c.rjust(w) for c, w in zip(first, pre_w, strict=True)) + \
            ("  " if pre else "") + "".join(
                c.rjust(w) if k else c.ljust(w)
                for k, (c, w) in enumerate(zip(cells, width, strict=True)))

    out = [line(pre, head)]
    for entry in table.point_statistics():
        where = [f"{entry['params'][n]:.6g}" for n in pre]
        for name in table.measures:
            s, unit = entry["statistics"][name], table.units.get(name, "")
            cells = [name] + [_fmt(s[k], unit) if k in s else "-" for k in head[1:]]
            out.append(line(where, cells))
    return out


def to_json(table, file: str, title: str, written: list[str]) -> dict:
    """The results as JSON-ready data (strict: no NaN; ``run`` and ``n`` are integers).

    ``statistics`` (Monte Carlo) is a list with one entry per grid point:
    ``{"params": {name: value}, "statistics": {measure: {n, nominal, mean, ...}}}``.
    """
    return json_ready(_results(table, file, title, written))


def _results(table, file: str, title: str, written: list[str]) -> dict:
    """The data of :func:`to_json` before :func:`~pelcs.jsonout.json_ready` (numpy values,
    NaN): what ``--json`` hands to :func:`~pelcs.jsonout.dumps`, which makes it ready once
    (a second pass cost as much as the printing itself on 100,000 runs, 1.6 s)."""
    rows = []
    for i in range(len(table)):
        row = {n: (int(v) if n == "run" else v)
               for n, v in zip(table.inputs, table.input_values[i], strict=True)}
        row.update(zip(table.measures, table.values[i], strict=True))
        row.update(ok=bool(table.ok[i]),
                   settled=bool(table.settled[i]) if table.ok[i] else None,
                   message=table.messages[i])
        rows.append(row)
    return {
        "file": file, "title": title, "inputs": list(table.inputs),
        "measures": list(table.measures), "swept": list(table.swept),
        "units": table.units, "runs": table.runs, "seed": table.seed,
        "distribution": table.distribution, "tolerances": table.tolerances,
        "rows": rows,
        "statistics": table.point_statistics() if table.runs else None,
        "notes": table.notes, "wall_time": table.wall_time, "engine": table.engine,
        "written": written,
    }
