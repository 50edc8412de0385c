"""``pelcs continue FILE [--period T] --param NAME=START:STOP[:N]``: follow a periodic orbit.

::

    pelcs continue FILE [--period T] --param NAME=START:STOP[:N] [--param OTHER=VALUE]...
                        [--order K] [--tol TOL] [--locate-tol DP] [--transient N] [--x0 ...]
                        [--step H] [--theta TH] [--t0 T0] [--json]
                        [--start STATE=V|STATE=A:B:N,...]... [--workers W]
                        [--scheduler ADDRESS]

Natural continuation of the period-K orbit of the stroboscopic map over N values from START
to STOP, N - 1 steps (default N = 41; the older ``--steps N - 1`` is still taken, with a
deprecation note on stderr), Newton shooting at each value from the secant prediction;
between steps, a change in the multipliers outside the unit circle or in the switching
pattern is located by bisection to ``--locate-tol`` (default |STOP - START| * 1e-4); ``--tol``
is the Newton tolerance on the scaled residual, as in ``pelcs orbit`` (default 1e-10). Bifurcations:
``flip`` (a multiplier through -1, period doubling), ``fold`` (+1), ``neimark-sacker`` (a
complex pair through the unit circle), ``border`` (the switching pattern changes: skipped
cycle, a diode entering discontinuous conduction, a border collision). ``--json`` prints one
object with ``bifurcations`` (a list of ``{"type", "param", "bracket", "detail", ...}``) and
``branch`` (the orbits), strict JSON: NaN and infinities are null.

``--start`` (repeatable) continues from many starting states at once, to find and follow
coexisting orbits: each ``--start`` item is ``STATE=VALUE`` or ``STATE=START:STOP:N`` (every
combination of the values is a start; the other states come from the netlist or ``--x0``).
The continuations run in parallel on local processes (``--workers``) or on the workers of a
Dask scheduler (``--scheduler ADDRESS``; ``local`` for a Dask cluster on this machine); each
is reported, those that found an orbit already found from an earlier start are marked as
such. ``--json`` then prints ``continuations`` (one object per start, with ``x0`` and
``same_as``, the index of the earlier start with the same orbit, or null).

The CLI module is ``continuation`` because ``continue`` is a Python keyword.

Exit status: 0 success; 2 input errors; 3 no orbit at START or the continuation stopped early
(with ``--start``: for every start).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from pelcs.jsonout import dumps

from . import options
from .bifurcation import scheduler_errors
from .orbit import (
    EXIT_FAILED,
    add_map_options,
    initial_state,
    make_factory,
    map_header,
    period_notes,
    positive_int,
    usage_error,
)


def register(subparsers) -> None:
    """Add the ``continue`` subcommand."""
    p = subparsers.add_parser(
        "continue",
        help="continue a periodic orbit in a parameter and locate its bifurcations",
        description="Follow a period-K orbit of the stroboscopic map as a .param varies; "
        "detect and locate period doubling (flip), fold, Neimark-Sacker and border "
        "collisions (switching-pattern changes).",
        epilog="example: pelcs continue vm_buck.cir --period tp --param vin=20:30:41",
    )
    add_map_options(p, param_help="the continuation parameter (once): "
                    f"{options.range_help('continue')}, N - 1 continuation steps; "
                    "NAME=VALUE: a fixed override (repeatable)")
    p.add_argument("--steps", metavar="N",
                   help="deprecated: continuation steps; give N + 1 values in the range "
                   "instead (NAME=START:STOP:N+1)")
    p.add_argument("--order", default="1", metavar="K", help="period of the orbit in periods T")
    options.add_tol(p)
    p.add_argument("--locate-tol", metavar="DP",
                   help="bisection tolerance in the parameter of a located bifurcation "
                   "(default |STOP-START|*1e-4)")
    p.add_argument("--transient", default="100", metavar="N",
                   help="periods simulated before the first Newton solve (default 100)")
    p.add_argument("--no-locate", action="store_true",
                   help="report the step brackets without bisection")
    p.add_argument("--start", action="append", default=[], metavar="STATE=V|STATE=A:B:N,...",
                   help="continue from these starting states too (repeatable; ranges give "
                   "every combination), in parallel")
    p.add_argument("--workers", metavar="W",
                   help="with --start: worker processes (default: all cores)")
    options.add_scheduler(p)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    options.add_json(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from lcs.analysis.maps import MapError

    setup = prepare(args)
    if args.start:
        report, results = compute_many(args, setup)
        if args.json:
            print(dumps(report, indent=1))
        else:
            print(format_many(report, Path(args.file).name))
        return 0 if any(r.complete for r in results) else EXIT_FAILED
    try:
        report, res = compute(args, setup)
    except MapError as exc:
        print(f"{args.file}: error: {exc}", file=sys.stderr)
        return EXIT_FAILED
    if args.json:
        print(dumps(report, indent=1))
    else:
        print(format_continuation(report, Path(args.file).name))
    return 0 if res.complete else EXIT_FAILED


def prepare(args: argparse.Namespace) -> dict:
    """The parsed options of a continuation, its factory and the map at START (input errors
    raised here, before any run)."""
    from netlist.studies.sweep import parse_value, split_params

    ranges, fixed = split_params(args.param)
    if len(ranges) != 1:
        raise usage_error("continue", "give exactly one --param NAME=START:STOP[:N]",
                          "e.g. --param vin=20:30:41 (fixed values: --param a=8.4)")
    rng = ranges[0]
    steps = continuation_steps(args.steps, rng)
    factory = make_factory(args, "continue", swept=rng.name, fixed=fixed)
    order = positive_int("continue", "--order", args.order)
    transient = positive_int("continue", "--transient", args.transient, 0)
    tol = parse_value(args.locate_tol, "--locate-tol") if args.locate_tol else None
    newton_tol = parse_value(args.tol, "--tol")
    if args.tol != options.NEWTON_TOL and args.locate_tol is None:
        # (before, continue's --tol was the bisection tolerance: a script giving it gets
        # the new meaning said once)
        print("pelcs continue: note: --tol is the Newton tolerance on the scaled residual, "
              "as in `pelcs orbit`; the bisection tolerance in the parameter (the earlier "
              "meaning of --tol here) is --locate-tol", file=sys.stderr)
    m = factory(rng.start)  # validates the netlist and the parameter name here
    x0 = initial_state(args, m)
    return dict(factory=factory, m=m, rng=rng, x0=x0, steps=steps, order=order,
                transient=transient, tol=tol, newton_tol=newton_tol)


def compute(args: argparse.Namespace, setup: dict) -> tuple[dict, object]:
    """One continuation (no ``--start``): ``(report, result)``, the report being what
    ``--json`` prints (shared with :func:`pelcs.continuation`). Raises MapError when the map
    fails."""
    from lcs.analysis.continuation import continue_orbit, continue_orbits

    factory, m, rng, x0 = setup["factory"], setup["m"], setup["rng"], setup["x0"]
    kw = dict(steps=setup["steps"], order=setup["order"], transient=setup["transient"],
              tol=setup["tol"], newton_tol=setup["newton_tol"], locate=not args.no_locate,
              progress=not args.no_progress, param_name=rng.name)
    if args.scheduler:  # one continuation, on a worker of the cluster
        with scheduler_errors("continue"):
            res, = continue_orbits(factory, rng.start, rng.stop, [x0],
                                   scheduler=args.scheduler, raise_errors=True, **kw)
    else:
        res = continue_orbit(factory, rng.start, rng.stop, x0=x0, **kw)
    report = {"file": args.file, "title": factory.circuit(rng.start).title,
              **map_header(m, factory), "order": setup["order"], "start": rng.start,
              "stop": rng.stop, "steps": setup["steps"], **res.to_dict()}
    report["notes"] = period_notes(m) + list(report.get("notes", []))
    return report, res


def continuation_steps(steps_option: str | None, rng) -> int:
    """The continuation steps: N - 1 for a range of N values; the deprecated ``--steps``
    (said on stderr) when the range has no N; else the default count's."""
    count = rng.count
    if steps_option is not None:
        steps = positive_int("continue", "--steps", steps_option)
        if count is not None and count - 1 != steps:
            raise usage_error("continue", f"--steps {steps_option} disagrees with --param "
                              f"{rng.name}=...:{count} ({count} values, {count - 1} steps)",
                              "drop --steps: the range's N is the number of values")
        options.deprecated("continue", f"--steps {steps}",
                           f"give the values in the range: --param "
                           f"{rng.name}={rng.start:g}:{rng.stop:g}:{steps + 1}")
        return steps
    return (count or options.RANGE_COUNTS["continue"]) - 1


def compute_many(args: argparse.Namespace, setup: dict) -> tuple[dict, list]:
    """``--start``: continuations from every starting state, in parallel: ``(report,
    results)``, the report being what ``--json`` prints."""
    import numpy as np

    from lcs.analysis.continuation import continue_orbits, same_orbit
    from netlist.studies.sweep import parse_starts

    factory, m, rng, x0 = setup["factory"], setup["m"], setup["rng"], setup["x0"]
    starts = [x0]
    for text in args.start:
        starts += parse_starts(text, m.state_names[: np.size(x0)], x0)
    if args.start:
        starts = starts[1:]  # the netlist / --x0 state is the default of every start
    workers = positive_int("continue", "--workers", args.workers) if args.workers else None
    with scheduler_errors("continue"):
        results = continue_orbits(
            factory, rng.start, rng.stop, starts, workers=workers, scheduler=args.scheduler,
            progress=not args.no_progress, steps=setup["steps"], order=setup["order"],
            transient=setup["transient"], tol=setup["tol"], newton_tol=setup["newton_tol"],
            locate=not args.no_locate,
            param_name=rng.name)
    conts = []
    for i, (x, res) in enumerate(zip(starts, results, strict=True)):
        same = None
        if res.orbits and res.orbits[0].converged:
            for j in range(i):
                prev = results[j]
                if prev.orbits and prev.orbits[0].converged and same_orbit(prev.orbits[0],
                                                                           res.orbits[0]):
                    same = j
                    break
        conts.append({"x0": [float(v) for v in x], "same_as": same, **res.to_dict()})
    report = {"file": args.file, "title": factory.circuit(rng.start).title,
              **map_header(m, factory), "order": setup["order"], "start": rng.start,
              "stop": rng.stop, "steps": setup["steps"], "states": list(m.state_names),
              "continuations": conts}
    return report, results


def format_many(report: dict, name: str) -> str:
    """Text report of the continuations from several starting states."""
    conts = report["continuations"]
    blocks = [f"{name}: {report['title']}".rstrip(": "),
              f"{len(conts)} continuation(s) from different starting states"]
    for i, c in enumerate(conts):
        start = ", ".join(f"{s} = {v:.6g}" for s, v in zip(report["states"], c["x0"],
                                                            strict=False))
        head = f"start {i + 1} ({start})"
        if c["same_as"] is not None:
            blocks.append(f"{head}: the same orbit as start {c['same_as'] + 1}")
            continue
        blocks.append(f"{head}:")
        blocks.append(format_continuation({**report, **c}, name).split("\n", 1)[1])
    return "\n".join(blocks)


def format_continuation(r: dict, name: str) -> str:
    """Text report: the branch (parameter, multiplier moduli, stability) and bifurcations."""
    from .orbit import fmt_complex

    pn = r["param_name"]
    lines = [f"{name}: {r['title']}".rstrip(": ")]
    lines.append(f"period-{r['order']} orbit continued in {pn} from {r['start']:g} to "
                 f"{r['stop']:g} ({len(r['branch'])} orbits, {r['wall_time']:.3g} s)")
    lines.append(f"  {pn:>12}  {'max |μ|':>10}  {'multipliers':<48} stability")
    for o in r["branch"]:
        if o["multipliers"] is None:  # not an orbit: no multipliers to show
            lines.append(f"  {o['param']:>12.6g}  {'-':>10}  {'-':<48} {o['stability']}")
            continue
        mus = [complex(a, b) for a, b in o["multipliers"]]
        mx = max((abs(v) for v in mus), default=0.0)
        text = ", ".join(fmt_complex(v) for v in mus)
        lines.append(f"  {o['param']:>12.6g}  {mx:>10.6g}  {text:<48} {o['stability']}")
    if r["bifurcations"]:
        lines.append("bifurcations:")
        for b in r["bifurcations"]:
            where = f"{b['param']:.8g}"
            if not b["located"]:
                where += f" (bracket {b['bracket'][0]:.6g} .. {b['bracket'][1]:.6g})"
            lines.append(f"  {b['type']:<15} {pn} = {where}")
            lines.append(f"      {b['detail']}")
    else:
        lines.append("no bifurcation found")
    for note in r.get("notes", []):
        lines.append(f"note: {note}")
    return "\n".join(lines)
