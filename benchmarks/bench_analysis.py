"""Wall time of the bifurcation analysis on the voltage-mode buck (``vm_buck.cir``).

Cases
-----
* **diagram** -- bifurcation diagram over the input voltage: 300 values of vin from 20 V to
  35 V, 300 transient and 100 recorded periods each (T = 400 µs, h = 1 µs: 400 steps per
  period, 48 million steps in total), fixed initial state, all cores.
* **follow** -- the same diagram following the attractor up and down (two parallel
  sequential sweeps, 96 million steps).
* **basins** -- simple cell mapping on a 200 x 200 grid of (v(C1), i(L1)) at vin = 30 V
  (40 000 one-period map evaluations, 16 million steps), all cores.
* **continuation** -- the period-1 orbit from 20 V to 35 V in 30 steps with bisection of the
  bifurcations to 1 mV.

Printed: seconds per case, steps per second, the number of worker processes, and a short
check of the result (attractor periods along vin; attractors of the basin map; the
bifurcations found). ``--quick`` runs a tenth of each case.

``--engines processes,local`` runs the diagram and basins cases on each task engine of
:mod:`lcs.analysis.parallel` -- the process pool (``processes``) and a Dask local cluster
started for the call (``local``; its start-up is part of the time, as it is for a user) --
and checks that the results are identical; ``--scheduler ADDRESS`` adds a running Dask
scheduler. This is the measurement behind :data:`lcs.analysis.parallel.LOCAL_DEFAULT`.

Run: ``.venv/bin/python benchmarks/bench_analysis.py [--quick] [--cases diagram,basins]
[--engines processes,local] [--sizes 10,30,300] [--repeat 3]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from lcs.analysis.basins import cell_basins  # noqa: E402
from lcs.analysis.bifurcation import attractor_period, bifurcation_diagram  # noqa: E402
from lcs.analysis.continuation import continue_orbit  # noqa: E402
from lcs.analysis.parallel import default_workers  # noqa: E402
from netlist.studies.sweep import CircuitMapFactory  # noqa: E402

NETLIST = str(ROOT / "converters" / "netlists" / "vm_buck.cir")


def _period_summary(values: np.ndarray, samples: np.ndarray) -> str:
    labels = [attractor_period(s, 1e-7) for s in samples]
    runs: list[list] = []
    for v, k in zip(values, labels, strict=True):
        if runs and runs[-1][2] == k:
            runs[-1][1] = v
        else:
            runs.append([v, v, k])
    return "; ".join(f"{a:.2f}-{b:.2f} V: " + (f"P{k}" if k else "chaotic/long")
                     for a, b, k in runs[:12]) + (" ..." if len(runs) > 12 else "")


def bench_diagram(quick: bool, follow: bool, engine=None, n: int | None = None) -> dict:
    n = n or (30 if quick else 300)
    f = CircuitMapFactory(NETLIST, period="tp", param="vin")
    m = f(20.0)
    steps_per_period = round(m.period / m.h)
    vin = np.linspace(20.0, 35.0, n)
    t = time.perf_counter()
    d = bifurcation_diagram(f, vin, x0=m.x0, transient=300, record=100, probes=["v(out)"],
                            follow=follow, directions=("up", "down"), progress=True,
                            param_name="vin", scheduler=engine)
    wall = time.perf_counter() - t
    steps = n * 400 * steps_per_period * len(d.branches)
    b = d.branches[0]
    return {"case": "follow" if follow else "diagram", "wall": wall, "steps": steps,
            "check": _period_summary(b.values, b.samples),
            "failed": int(sum((~br.ok).sum() for br in d.branches)),
            "data": np.concatenate([br.samples.ravel() for br in d.branches]),
            "engine": d.engine}


def bench_basins(quick: bool, engine=None, n: int | None = None) -> dict:
    n = n or (63 if quick else 200)
    f = CircuitMapFactory(NETLIST, period="tp", param="vin")
    m = f(30.0)
    t = time.perf_counter()
    bm = cell_basins(f, [("v(C1)", 8.0, 16.0, n), ("i(L1)", 0.0, 2.5, n)], param=30.0,
                     progress=True, scheduler=engine)
    wall = time.perf_counter() - t
    steps = n * n * round(m.period / m.h)
    check = ", ".join(f"#{a.group}: {a.period} cells, basin {a.basin_cells}"
                      for a in bm.attractors[:6])
    sink = int(np.count_nonzero(bm.group == 0))
    return {"case": "basins", "wall": wall, "steps": steps,
            "check": f"{len(bm.attractors)} attractor(s) ({check}); sink {sink} cells; "
                     f"max steps {int(bm.steps.max())}",
            "data": np.concatenate([bm.image.ravel(), bm.group.ravel()]).astype(float),
            "engine": bm.engine}


def bench_continuation(quick: bool) -> dict:
    f = CircuitMapFactory(NETLIST, period="tp", param="vin")
    t = time.perf_counter()
    res = continue_orbit(f, 20.0, 35.0, steps=6 if quick else 30, tol=1e-3, param_name="vin")
    wall = time.perf_counter() - t
    bifs = ", ".join(f"{b.type} at {b.param:.4f} V" for b in res.bifurcations)
    return {"case": "continuation", "wall": wall, "steps": 0,
            "check": bifs + ("" if res.complete else f" (stopped: {res.notes[-1]})")}


def compare_engines(args) -> int:
    """Wall time of the same work on each engine (best and median of ``--repeat`` runs,
    interleaved, on a machine that may be shared); the results must be identical."""
    engines = [e.strip() for e in args.engines.split(",") if e.strip()]
    if args.scheduler:
        engines.append(args.scheduler)
    sizes = [int(v) for v in args.sizes.split(",")] if args.sizes else [30 if args.quick
                                                                       else 300]
    print(f"vm_buck.cir, {default_workers()} core(s); engines: {', '.join(engines)}; "
          f"best / median of {args.repeat}")
    CircuitMapFactory(NETLIST, period="tp", param="vin")(20.0).iterate([0.5, 12.0], 2)
    for case in args.cases.split(","):
        if case not in ("diagram", "basins"):
            continue
        for size in sizes:
            cells = max(4, round(size * 2 / 3))
            what = (f"{size} values x 400 periods" if case == "diagram"
                    else f"{cells}^2 cells")
            times: dict[str, list[float]] = {e: [] for e in engines}
            ref, same = None, True
            for _ in range(args.repeat):
                for eng in engines:
                    r = (bench_diagram(False, False, engine=eng, n=size) if case == "diagram"
                         else bench_basins(False, engine=eng, n=cells))
                    times[eng].append(r["wall"])
                    if ref is None:
                        ref = r["data"]
                    same &= bool(np.array_equal(ref, r["data"], equal_nan=True))
            for eng in engines:
                t = np.array(times[eng])
                print(f"{case:>8} {what:>24}  {eng:>28}: best {t.min():6.2f} s, median "
                      f"{np.median(t):6.2f} s")
            print(f"{'':>8} results {'identical' if same else 'DIFFERENT'} on every engine")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="a tenth of each case")
    ap.add_argument("--cases", default="diagram,follow,basins,continuation")
    ap.add_argument("--engines", help="compare task engines on the diagram and basins cases: "
                    "processes,local")
    ap.add_argument("--scheduler", help="with --engines: also this Dask scheduler address")
    ap.add_argument("--sizes", help="with --engines: diagram values (basins: cells per axis "
                    "= 2/3 of it), e.g. 10,30,300")
    ap.add_argument("--repeat", type=int, default=3, help="with --engines: runs per engine")
    args = ap.parse_args(argv)
    if args.engines:
        return compare_engines(args)
    print(f"vm_buck.cir, {default_workers()} worker process(es)")
    # Warm-up: numba kernels compiled / loaded from cache before timing.
    CircuitMapFactory(NETLIST, period="tp", param="vin")(20.0).iterate([0.5, 12.0], 2)
    for case in args.cases.split(","):
        if case in ("diagram", "follow"):
            r = bench_diagram(args.quick, case == "follow")
        elif case == "basins":
            r = bench_basins(args.quick)
        elif case == "continuation":
            r = bench_continuation(args.quick)
        else:
            raise SystemExit(f"unknown case {case}")
        rate = f", {r['steps'] / r['wall'] / 1e6:.2f} M steps/s" if r["steps"] else ""
        print(f"{r['case']:>13}: {r['wall']:7.2f} s{rate}")
        print(f"{'':>15}{r['check']}")
        if r.get("failed"):
            print(f"{'':>15}{r['failed']} value(s) failed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
