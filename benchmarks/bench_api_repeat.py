"""Many simulations of one netlist from Python: the time per run outside the stepping.

A design script simulates the buck (``converters/netlists/buck.cir``) N times, each with
another value of one ``.param`` (default: ``duty`` from 0.3 to 0.7), for a few switching
periods, through ``pelcs.simulate(path, params=...)``. Per run it measures the whole call
(wall clock) and the time inside the compiled stepping kernels
(``res.stats.kernel_time``); the difference is what the Python API costs around the
stepping: reading the netlist, evaluating the parameters, the formulation, the screens, the
run's planning and its results (goal: at most 1 ms).

For comparison, the same loop

* through the uncached path, a fresh parse and formulation every run
  (``netlist.studies.transient.simulate_circuit(netlist.parser.parse_file(...))``, what the API did
  before it kept the netlist and the system: ``--fresh-runs``);
* through ngspice's shared library with PySpice (``NgSpiceShared``): the netlist text with
  the new value loaded each run, ``.tran`` run, the time, ``v(out)`` and ``i(L1)`` vectors
  fetched (``--ngspice-runs``; 0 skips it).

Run by hand::

    .venv/bin/python benchmarks/bench_api_repeat.py [--runs 1000] [--periods 20]
        [--param duty --low 0.3 --high 0.7] [--fresh-runs 100] [--ngspice-runs 1000]

The first pelcs run (kernels loaded, netlist read, system formulated) is reported apart; the
loop's figures are the mean, the median and the 10th percentile over the runs that follow
it.
"""

from __future__ import annotations

import argparse
import os
import re
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

NETLIST = ROOT / "converters" / "netlists" / "buck.cir"
FS = 50e3  # the buck's switching frequency (.param fs), Hz
PROBES = ["v(out)", "i(L1)"]


def values(args) -> np.ndarray:
    return np.linspace(args.low, args.high, args.runs)


def bench_pelcs(path: str, tstop: float, name: str, vals) -> tuple[list, list, float]:
    """(total, kernel) seconds per run, and the first run's total."""
    import pelcs

    t0 = time.perf_counter()
    pelcs.simulate(path, tstop=tstop, probes=PROBES, params={name: float(vals[0])})
    first = time.perf_counter() - t0
    total, kernel = [], []
    for v in vals:
        t0 = time.perf_counter()
        res = pelcs.simulate(path, tstop=tstop, probes=PROBES, params={name: float(v)})
        total.append(time.perf_counter() - t0)
        kernel.append(res.stats.kernel_time)
    return total, kernel, first


def bench_fresh(path: str, tstop: float, name: str, vals) -> tuple[list, list]:
    from netlist.parser import parse_file
    from netlist.studies.transient import simulate_circuit

    total, kernel = [], []
    for v in vals:
        t0 = time.perf_counter()
        res = simulate_circuit(parse_file(path, {name: float(v)}), tstop=tstop, probes=PROBES)
        res.raise_if_error()
        total.append(time.perf_counter() - t0)
        kernel.append(res.stats.kernel_time)
    return total, kernel


def ngspice_netlist(text: str, name: str, value: float, tstop: float) -> str:
    """The buck's text with ``name`` set on its .param line and the .tran of the run."""
    pattern = re.compile(rf"(?im)^(\.param\b.*?\b{re.escape(name)}\s*=\s*)(\S+)")
    if not pattern.search(text):
        raise SystemExit(f"no .param {name}= in {NETLIST}")
    text = pattern.sub(lambda m: m.group(1) + repr(float(value)), text, count=1)
    return re.sub(r"(?im)^\.tran .*$", f".tran 0.2u {tstop!r} 0 0.2u UIC", text)


def bench_ngspice(tstop: float, name: str, vals) -> list:
    import logging

    logging.getLogger("PySpice").setLevel(logging.CRITICAL)
    from PySpice.Spice.NgSpice.Shared import NgSpiceShared

    ng = NgSpiceShared.new_instance()
    text = NETLIST.read_text()
    total = []
    for v in vals:
        t0 = time.perf_counter()
        ng.load_circuit(ngspice_netlist(text, name, v, tstop))
        ng.run()
        plot = ng.plot(None, ng.last_plot)
        t = np.array(plot["time"]._data)
        y = np.column_stack([np.array(plot["out"]._data), np.array(plot["l1#branch"]._data)])
        ng.destroy()
        ng.remove_circuit()
        total.append(time.perf_counter() - t0)
    if not (len(t) > 10 and np.all(np.isfinite(y))):
        raise SystemExit("ngspice returned no usable vectors")
    return total


def ms(xs) -> str:
    """Mean, median and 10th percentile (on a shared machine the mean carries the runs that
    other jobs interrupted; the low percentile is closest to the uncontended cost)."""
    p10 = float(np.percentile(xs, 10))
    return (f"{1e3 * statistics.fmean(xs):7.3f} ms (median {1e3 * statistics.median(xs):.3f}, "
            f"p10 {1e3 * p10:.3f})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--periods", type=float, default=20, help="switching periods per run")
    ap.add_argument("--param", default="duty")
    ap.add_argument("--low", type=float, default=0.3)
    ap.add_argument("--high", type=float, default=0.7)
    ap.add_argument("--fresh-runs", type=int, default=100,
                    help="runs of the uncached path (fresh parse and formulation)")
    ap.add_argument("--ngspice-runs", type=int, default=None,
                    help="runs through PySpice's shared ngspice (default --runs; 0: none)")
    args = ap.parse_args()
    tstop = args.periods / FS
    vals = values(args)
    path = str(NETLIST.relative_to(Path.cwd())) if NETLIST.is_relative_to(Path.cwd()) \
        else str(NETLIST)

    from lcs.build.ready import load_kernels as warm_up

    load = warm_up()
    total, kernel, first = bench_pelcs(path, tstop, args.param, vals)
    outside = [a - b for a, b in zip(total, kernel, strict=True)]
    print(f"{NETLIST.name}: {args.runs} runs of {args.periods:g} periods ({tstop * 1e3:g} ms), "
          f"{args.param} from {args.low:g} to {args.high:g}; kernels loaded in {load:.2f} s; "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")
    print(f"pelcs.simulate, first run       {1e3 * first:7.3f} ms (reads and formulates)")
    print(f"pelcs.simulate, per run         {ms(total)}")
    print(f"  inside the stepping kernels   {ms(kernel)}")
    print(f"  outside the stepping          {ms(outside)}   goal <= 1 ms")
    if args.fresh_runs > 0:
        f_total, f_kernel = bench_fresh(path, tstop, args.param, vals[:args.fresh_runs])
        f_out = [a - b for a, b in zip(f_total, f_kernel, strict=True)]
        print(f"fresh parse + simulate, per run {ms(f_total)}  ({args.fresh_runs} runs)")
        print(f"  outside the stepping          {ms(f_out)}")
    n_ng = args.runs if args.ngspice_runs is None else args.ngspice_runs
    if n_ng > 0:
        ng_total = bench_ngspice(tstop, args.param, vals[:n_ng])
        print(f"ngspice (PySpice shared), run   {ms(ng_total)}  ({n_ng} runs)")
        print(f"ngspice / pelcs per run         "
              f"{statistics.fmean(ng_total) / statistics.fmean(total):7.1f}x means, "
              f"{statistics.median(ng_total) / statistics.median(total):.1f}x medians")


if __name__ == "__main__":
    main()
