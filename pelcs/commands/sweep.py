"""``pelcs sweep FILE``: parameter sweeps and Monte Carlo runs, measured in steady state.

::

    pelcs sweep FILE --measure 'FUNC(PROBE)'... [--param NAME=START:STOP:N]...
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

Outputs: a table on the terminal (Monte Carlo: the statistics of each measurement),
``-o OUT.csv`` (one row per run: parameters, ``run``, the drawn values, the measurements,
``ok``, ``message``; SI units), ``--plot`` (measurements against the first swept parameter,
or histograms for a Monte Carlo run), ``--json`` (the table and statistics as JSON).

Exit status: 0 success (also when some runs failed: NaN, counted in the notes); 2 input
errors; 3 every run failed.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from .bifurcation import add_scheduler_option, check_output, scheduler_errors
from .orbit import EXIT_FAILED, positive_int, usage_error, write_outputs

# Rows of a sweep printed on the terminal (the CSV has them all).
MAX_ROWS = 60


def register(subparsers) -> None:
    """Add the ``sweep`` subcommand."""
    p = subparsers.add_parser(
        "sweep",
        help="parameter sweeps and Monte Carlo runs, measured over the steady state",
        description="Simulate a netlist over a grid of .param values and/or with element "
        "values drawn within tolerances; measure mean, rms, ripple, min, max or the final "
        "value of probes over the steady-state window; write a table.",
        epilog="examples: pelcs sweep buck.cir --param duty=0.2:0.8:7 --measure 'mean(v(out))'"
        " --measure 'ripple(i(L1))' -o duty.csv;  pelcs sweep buck.cir --tolerance 'C*=10%' "
        "--tolerance R1=5% --runs 200 --seed 1 --measure 'ripple(v(out))' --plot mc.png",
    )
    p.add_argument("file", help="netlist file")
    p.add_argument("--measure", action="append", default=[], metavar="FUNC(PROBE)",
                   help="mean, avg, rms, ripple, pp, min, max or final of a probe, e.g. "
                   "'mean(v(out))' (repeatable; required)")
    p.add_argument("--param", action="append", default=[], metavar="NAME=START:STOP:N",
                   help="a swept .param (N values from START to STOP, or NAME=V1,V2,...) or "
                   "a fixed override NAME=VALUE (repeatable)")
    p.add_argument("--tolerance", action="append", default=[], metavar="PATTERN=N%",
                   help="Monte Carlo tolerance of the elements whose names match PATTERN "
                   "(glob): N%% relative, or an absolute value (repeatable)")
    p.add_argument("--runs", metavar="N", help="Monte Carlo runs (per parameter point)")
    p.add_argument("--seed", metavar="S", help="random seed of the Monte Carlo draws")
    p.add_argument("--distribution", choices=("uniform", "gaussian"), default="uniform",
                   help="uniform within ±tol (default), or gaussian with σ = tol/3")
    p.add_argument("--tstop", metavar="T", help="stop time (default: .tran TSTOP)")
    p.add_argument("--step", metavar="H", help="time step (default: the .tran step)")
    p.add_argument("--theta", metavar="TH",
                   help="Moreau θ in [0.5, 1] (default 0.5, or 1 where θ < 1 is found "
                   "unreliable)")
    p.add_argument("--period", metavar="T",
                   help="steady-state period (seconds or a .param name); default the period "
                   "of the source at a switch's control")
    p.add_argument("--workers", metavar="W", help="worker processes (default: all cores)")
    add_scheduler_option(p)
    p.add_argument("-o", "--output", metavar="OUT.csv", help="write the table")
    p.add_argument("--plot", metavar="OUT.png",
                   help="measurements against the first swept parameter, or histograms")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from netlist.param_sweep import parse_sweep_param, run_sweep
    from netlist.sweep import parse_value

    from .simulate import _number

    if not args.measure:
        raise usage_error("sweep", "nothing to measure",
                          "give --measure FUNC(PROBE), e.g. --measure 'mean(v(out))'")
    params: dict[str, float | np.ndarray] = {}
    for item in args.param:
        name, value = parse_sweep_param(item)
        if name.lower() in {k.lower() for k in params}:
            raise usage_error("sweep", f"--param {name} is given twice")
        params[name] = value
    runs = positive_int("sweep", "--runs", args.runs) if args.runs else 0
    seed = positive_int("sweep", "--seed", args.seed, 0) if args.seed is not None else None
    workers = positive_int("sweep", "--workers", args.workers) if args.workers else None
    theta = parse_value(args.theta, "--theta") if args.theta is not None else None
    tstop = _number("--tstop", args.tstop, ("", "s"))
    step = _number("--step", args.step, ("", "s"))
    period: float | str | None = args.period
    if args.period is not None:
        try:
            period = parse_value(args.period, "--period")
        except Exception:  # noqa: BLE001 - a .param name, resolved per point
            period = args.period
    out = check_output("sweep", "-o", args.output, (".csv",))
    plot = check_output("sweep", "--plot", args.plot, (".png", ".svg", ".pdf"))
    swept = [k for k, v in params.items() if np.ndim(v) > 0]
    if plot is not None and not swept and not runs:
        raise usage_error("sweep", "--plot needs a swept --param or a Monte Carlo run")
    with scheduler_errors("sweep"):
        table = run_sweep(
            args.file, args.measure, params=params, tolerances=args.tolerance, runs=runs,
            seed=seed, distribution=args.distribution, tstop=tstop, step=step, theta=theta,
            period=period, workers=workers, scheduler=args.scheduler,
            progress=not args.no_progress)
    from netlist.parser import parse_file

    title = parse_file(args.file, params={k: float(np.ravel(v)[0]) for k, v in params.items()}
                       or None).title
    written = write_outputs("sweep", (
        (out, table.to_csv),
        (plot, lambda path: table.plot(path, title=_plot_title(table, title, args.file))),
    ))
    if args.json:
        print(json.dumps(to_json(table, args.file, title, written), indent=1))
    else:
        print(summary(table, args.file, title, written))
    return 0 if table.ok.any() else EXIT_FAILED


def _plot_title(table, title: str, file: str) -> str:
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
        out.append(line)
    return out


def _stats_lines(table) -> list[str]:
    stats = table.statistics()
    head = ["measurement", "nominal", "mean", "std", "min", "p5", "p95", "max"]
    width = [max(14, *(len(m) + 2 for m in table.measures))] + [13] * 7
    out = ["".join(h.rjust(w) if k else h.ljust(w) for k, (h, w) in enumerate(
        zip(head, width, strict=True)))]
    for name in table.measures:
        s, unit = stats[name], table.units.get(name, "")
        cells = [name] + [_fmt(s[k], unit) if k in s else "-" for k in head[1:]]
        out.append("".join(c.rjust(w) if k else c.ljust(w)
                           for k, (c, w) in enumerate(zip(cells, width, strict=True))))
    return out


def to_json(table, file: str, title: str, written: list[str]) -> dict:
    def num(v):
        v = float(v)
        return v if np.isfinite(v) else None

    return {
        "file": file, "title": title, "inputs": list(table.inputs),
        "measures": list(table.measures), "swept": list(table.swept),
        "units": table.units, "runs": table.runs, "seed": table.seed,
        "distribution": table.distribution, "tolerances": table.tolerances,
        "rows": [{**{n: num(v) for n, v in zip(table.inputs, table.input_values[i],
                                                strict=True)},
                  **{n: num(v) for n, v in zip(table.measures, table.values[i], strict=True)},
                  "ok": bool(table.ok[i]), "message": table.messages[i]}
                 for i in range(len(table))],
        "statistics": table.statistics() if table.runs else None,
        "notes": table.notes, "wall_time": table.wall_time, "engine": table.engine,
        "written": written,
    }
