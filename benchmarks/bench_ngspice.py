"""pelcs against ngspice on the same converter netlists: wall time and accuracy (run by hand).

    .venv/bin/python benchmarks/bench_ngspice.py [--repeat N] [--netlist FILE]...

For each netlist (default: the buck in CCM and the boost in DCM of tests/netlists/sim/, whose
comments derive their analytic operating points), the steady-state mean of v(out) over the
last whole switching periods is compared with the analytic value (buck in CCM: D·Vin, exact
for ideal elements; boost in DCM: M·Vin, M = (1 + sqrt(1 + 4D²/K))/2,
:func:`converters.design.conversion_ratio`).

* ngspice runs the netlist as written (its ``.tran`` step and TMAX) through
  :func:`ngspice_checks.runner.run_ngspice`, which climbs a ladder of settings when ngspice
  fails (timestep too small); the time reported is ngspice's load + run time of the rung that
  worked (``wall_time``, best of repeated runs of that rung), and the whole first call
  (``total_time``, with the failed rungs and the worker start-up) is shown too. Without the
  runner (or PySpice), ``ngspice -b`` runs the deck with a ``.control`` block and
  ``wrdata``; its time is the process's wall time.
* pelcs runs at a ladder of steps h = T/k; the step reported is the coarsest one whose error
  is at most ngspice's, so the speed ratio is at equal or better accuracy. Its time is
  parse + formulation + Moreau run, best of ``--repeat`` warm runs (the first run in a
  process also loads numba's compiled kernels from the cache, about 0.3 s, shown as "cold").

ngspice cannot simulate ideal elements: the netlists' near-ideal models (diode N = 0.05,
RS = 1 mΩ; switch RON = 1 mΩ) drop some tens of mV, which is part of its error against the
ideal analytic value — that is the point of comparing the two against the same ideal
reference.
"""

from __future__ import annotations

import argparse
import math
import re
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from converters.design import conversion_ratio, k_crit  # noqa: E402
from netlist.parser import parse_file  # noqa: E402
from netlist.studies.transient import simulate_circuit  # noqa: E402

DEFAULT_NETLISTS = [ROOT / "tests/netlists/sim/buck_ccm.cir",
                    ROOT / "tests/netlists/sim/boost_dcm.cir"]
# Steps per switching period tried for pelcs, coarsest first.
STEPS_PER_PERIOD = [10, 20, 25, 50, 100, 200, 400, 800]
AVERAGE_PERIODS = 10


@dataclass
class Reference:
    topology: str
    value: float  # analytic mean v(out), V
    period: float  # switching period, s
    text: str


def analytic(path: Path) -> Reference:
    """The analytic mean output voltage of a converter netlist from its parameters.

    The netlist's title says which converter it is; its ``.param`` lines give vin, duty, fs
    (or ts), lval and rload.
    """
    circuit = parse_file(path)
    p = circuit.params
    title = circuit.title.lower()
    topology = "buck" if "buck" in title else "boost"
    T = p["ts"] if "ts" in p else 1.0 / p["fs"]
    K = 2 * p["lval"] / (p["rload"] * T)
    mode = "CCM" if K > k_crit(topology, p["duty"]) else "DCM"
    M = conversion_ratio(topology, p["duty"], K)
    return Reference(topology, M * p["vin"], T,
                     f"{topology} in {mode}: D = {p['duty']:g}, K = {K:.3g}, "
                     f"K_crit = {k_crit(topology, p['duty']):.3g}, M = {M:.6g}")


def window_mean(t: np.ndarray, y: np.ndarray, t0: float, t1: float) -> float:
    """Time average of samples over [t0, t1] (trapezoidal, the ends interpolated), V."""
    inside = (t > t0) & (t < t1)
    ts = np.concatenate(([t0], t[inside], [t1]))
    ys = np.concatenate(([np.interp(t0, t, y)], y[inside], [np.interp(t1, t, y)]))
    return float(0.5 * np.sum((ys[1:] + ys[:-1]) * np.diff(ts)) / (t1 - t0))


def steady_mean(t: np.ndarray, y: np.ndarray, period: float) -> float:
    """Mean over the last AVERAGE_PERIODS whole periods (the run ends on a period)."""
    t1 = round(float(t[-1]) / period) * period
    return window_mean(t, y, t1 - AVERAGE_PERIODS * period, t1)


# -- pelcs ---------------------------------------------------------------------------------


def pelcs_run(path: Path, h: float) -> tuple[float, np.ndarray, np.ndarray]:
    """(wall time of parse + formulate + simulate in s, t, v(out))."""
    t0 = time.perf_counter()
    circuit = parse_file(path)
    res = simulate_circuit(circuit, step=h, probes=["v(out)"])
    wall = time.perf_counter() - t0
    res.raise_if_error()
    return wall, res.t, res["v(out)"]


# -- ngspice -------------------------------------------------------------------------------


def ngspice_run(path: Path, repeat: int, batch: bool = False) -> dict:
    """Run the netlist in ngspice: runner (PySpice shared library) first, else ``ngspice -b``.

    The first run climbs the runner's ladder; ``repeat`` more runs reuse the rung that worked
    and the reported time is the best of the runs of that rung (the machine may be shared:
    the minimum is the least disturbed measurement, for ngspice and pelcs alike).
    """
    text = path.read_text()
    try:
        from ngspice_checks.runner import NgspiceError, run_ngspice
    except ImportError:
        run_ngspice = None
    if batch:
        run_ngspice = None
    if run_ngspice is not None:
        try:
            r = run_ngspice(text, ["v(out)"], workdir=path.parent)
            walls = [r.wall_time]
            for _ in range(repeat):
                again = run_ngspice(text, ["v(out)"], workdir=path.parent,
                                    settings=r.settings_used)
                walls.append(again.wall_time)
            return {"t": r.time, "v": r["v(out)"], "wall": min(walls),
                    "total": r.total_time, "how": f"runner, rung {r.rung} "
                    f"({r.settings_used.name})", "points": len(r.time)}
        except NgspiceError as exc:
            print(f"  (runner failed: {str(exc)[:200]}; trying ngspice -b)")
    runs = [ngspice_batch(text, path.parent) for _ in range(1 + repeat)]
    out = runs[0]
    out["wall"] = min(r["wall"] for r in runs)
    return out


def ngspice_batch(text: str, cwd: Path) -> dict:
    """``ngspice -b`` on the deck with a ``.control`` block writing v(out) with ``wrdata``."""
    exe = shutil.which("ngspice")
    if exe is None:
        raise RuntimeError("ngspice is not installed")
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "out.txt"
        control = f".control\nrun\nwrdata {data} v(out)\n.endc\n"
        deck = re.sub(r"^\.end\s*$", control + ".end", text, flags=re.M | re.I)
        cir = Path(tmp) / "deck.cir"
        cir.write_text(deck)
        t0 = time.perf_counter()
        proc = subprocess.run([exe, "-b", str(cir)], cwd=cwd, capture_output=True, text=True,
                              timeout=900)
        wall = time.perf_counter() - t0
        # ngspice -b exits with 1 after "no .plot lines" even when the control block ran.
        if not data.exists() or data.stat().st_size == 0:
            raise RuntimeError(f"ngspice -b failed: {proc.stderr[-500:]}")
        arr = np.loadtxt(data)
    return {"t": arr[:, 0], "v": arr[:, 1], "wall": wall, "total": wall,
            "how": "ngspice -b", "points": len(arr)}


# -- main ----------------------------------------------------------------------------------


def bench(path: Path, repeat: int, batch: bool = False) -> dict:
    ref = analytic(path)
    print(f"\n{path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}: {ref.text}")
    print(f"  analytic mean v(out) = {ref.value:.6f} V")

    ng = ngspice_run(path, min(repeat, 3), batch)
    ng_mean = steady_mean(ng["t"], ng["v"], ref.period)
    ng_err = abs(ng_mean / ref.value - 1)
    print(f"  ngspice ({ng['how']}): {ng['points']} points, {ng['wall']:.3f} s "
          f"best (first call with the ladder {ng['total']:.2f} s), mean {ng_mean:.6f} V, "
          f"error {ng_err:.2e}")

    rows = []
    cold = None
    for k in STEPS_PER_PERIOD:
        h = ref.period / k
        walls = []
        for _ in range(repeat + (1 if cold is None else 0)):
            wall, t, v = pelcs_run(path, h)
            if cold is None:
                cold = wall  # first run in this process: numba cache load included
                continue
            walls.append(wall)
        mean = steady_mean(t, v, ref.period)
        err = abs(mean / ref.value - 1)
        rows.append((k, h, min(walls), len(t) - 1, mean, err))
        print(f"  pelcs h = T/{k:<4d} ({h * 1e9:7.1f} ns): {len(t) - 1:7d} steps, "
              f"{min(walls) * 1e3:8.2f} ms, mean {mean:.6f} V, error {err:.2e}")
    ok = [r for r in rows if r[5] <= ng_err]
    if not ok:
        print("  pelcs did not reach ngspice's accuracy with the steps tried")
        return {"path": path, "ratio": math.nan}
    k, h, wall, steps, mean, err = ok[0]
    ratio = ng["wall"] / wall
    print(f"  => coarsest pelcs step at least as accurate as ngspice: T/{k} ({err:.1e} vs "
          f"{ng_err:.1e}); pelcs {wall * 1e3:.2f} ms vs ngspice {ng['wall'] * 1e3:.1f} ms: "
          f"{ratio:.0f}x faster ({ng['total'] / wall:.0f}x against the first ngspice call; "
          f"{ng['wall'] / cold:.1f}x against pelcs' cold first run, {cold:.2f} s)")
    best = min(rows, key=lambda r: r[5])
    print(f"     most accurate pelcs run: T/{best[0]}, error {best[5]:.1e} in "
          f"{best[2] * 1e3:.1f} ms ({ng['wall'] / best[2]:.0f}x faster than ngspice)")
    return {"path": path, "ratio": ratio, "pelcs_err": err, "ng_err": ng_err}


def lengthened(path: Path, factor: int, workdir: Path) -> Path:
    """A copy of the netlist whose ``.tran`` TSTOP is ``factor`` times longer.

    pelcs has a fixed cost per run (parsing, building the switch modes, the search for the
    gate's switching instants: about 2-3 ms) that ngspice does not have in the same form;
    on a short run it dominates, so the comparison is made at both lengths.
    """
    tstop = parse_file(path).tran.tstop
    text = re.sub(r"(?im)^(\.tran\s+\S+\s+)\S+", lambda m: f"{m.group(1)}{tstop * factor:.9g}",
                  path.read_text(), count=1)
    out = workdir / f"{path.stem}_x{factor}{path.suffix}"
    out.write_text(text)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--netlist", action="append", type=Path,
                    help="converter netlist (buck or boost, with .param vin duty fs lval "
                    "rload); default: the buck (CCM) and boost (DCM) of tests/netlists/sim")
    ap.add_argument("--repeat", type=int, default=5, help="warm pelcs runs per step")
    ap.add_argument("--batch", action="store_true",
                    help="run ngspice -b on the netlist as written instead of the runner")
    ap.add_argument("--long", type=int, default=10,
                    help="also run each netlist with TSTOP this many times longer (1: off)")
    args = ap.parse_args()
    paths = [p.resolve() for p in (args.netlist or DEFAULT_NETLISTS)]
    with tempfile.TemporaryDirectory() as tmp:
        if args.long > 1:
            paths += [lengthened(p, args.long, Path(tmp)) for p in paths]
        results = [bench(p, args.repeat, args.batch) for p in paths]
    print("\nsummary (ngspice time / pelcs time at equal or better accuracy):")
    for r in results:
        print(f"  {r['path'].name:20s} {r['ratio']:8.0f}x")


if __name__ == "__main__":
    main()
