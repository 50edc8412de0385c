"""Nonsmooth bifurcations of the voltage-mode controlled buck (Deane and Hamill).

``converters/netlists/vm_buck.cir`` (R = 22 Ω, L = 20 mH, C = 47 µF, ramp 3.8 -> 8.2 V,
T = 400 µs, A = 8.4, Vref = 11.3 V) with the input voltage vin as the parameter:

1. **Bifurcation diagram** of v(out) sampled once per ramp period, vin from 20 V to 35 V,
   following the attractor up and down (hysteresis shows as differing up/down branches).
2. **Continuation** of the period-1 orbit: complex multipliers below the first period
   doubling, a multiplier through -1 at about 24.52 V (the flip), located by bisection.
3. **Continuation of the period-2 orbit** born there, up to its own period doubling (about
   31 V).
4. **Basins** of attraction by simple cell mapping in the (v(C1), i(L1)) plane.

Outputs in ``--out`` (default ``out/``): ``vm_buck_diagram.png/.npz``,
``vm_buck_continuation.json``, ``vm_buck_basins.png/.npz``, and a summary on stdout.
``--fast`` runs a coarse version of everything (seconds).

Run: ``.venv/bin/python examples/bifurcation_vm_buck.py [--fast] [--out DIR]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from lcs.analysis.basins import cell_basins  # noqa: E402
from lcs.analysis.bifurcation import attractor_period, bifurcation_diagram  # noqa: E402
from lcs.analysis.continuation import continue_orbit  # noqa: E402
from lcs.analysis.orbits import find_orbit  # noqa: E402
from netlist.studies.sweep import CircuitMapFactory  # noqa: E402
from pelcs.analysis_plots import plot_basins, plot_bifurcation  # noqa: E402
from pelcs.writers import write_basins, write_bifurcation  # noqa: E402

NETLIST = ROOT / "converters" / "netlists" / "vm_buck.cir"


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out", help="output directory")
    ap.add_argument("--fast", action="store_true", help="coarse grids (seconds)")
    ap.add_argument("--netlist", default=str(NETLIST))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fast = args.fast
    f = CircuitMapFactory(args.netlist, period="tp", param="vin")
    results: dict = {}

    # 1. Bifurcation diagram, following the attractor up and down.
    t = time.perf_counter()
    vin = np.linspace(20.0, 35.0, 31 if fast else 300)
    d = bifurcation_diagram(f, vin, x0=f(20.0).x0, transient=200 if fast else 300,
                            record=24 if fast else 100, probes=["v(out)"], follow=True,
                            directions=("up", "down"), progress=True, param_name="vin")
    write_bifurcation(d, out / "vm_buck_diagram.npz")
    plot_bifurcation(d, out / "vm_buck_diagram.png",
                     title="voltage-mode buck: v(out) at t = kT")
    up = d.branch("up")
    periods = [attractor_period(s, 1e-7) for s in up.samples]
    results["diagram"] = {"values": up.values, "periods": periods,
                          "wall": time.perf_counter() - t}
    print(f"diagram: {vin.size} values x 2 directions in {results['diagram']['wall']:.1f} s")

    # 2. Period-1 orbit: multipliers and the first flip.
    t = time.perf_counter()
    p1 = continue_orbit(f, 20.0, 35.0, steps=6 if fast else 60, tol=1e-3, param_name="vin")
    o20 = find_orbit(f(20.0), f(20.0).x0, transient=100)
    results["orbit20"] = o20
    results["period1"] = p1
    print(f"period-1 orbit at 20 V: {o20.x} (i(L1) A, v(C1) V), multipliers "
          f"{', '.join(f'{m:.4f}' for m in o20.multipliers)}")
    for b in p1.bifurcations:
        print(f"  period-1 branch: {b.type} at vin = {b.param:.4f} V  ({b.detail[:100]})")

    # 3. Period-2 orbit from just above the flip.
    flips = [b for b in p1.bifurcations if b.type == "flip"]
    if flips:
        start = flips[0].param + 0.5
        m = f(start)
        x2 = m.iterate(f(start).x0, 300)[-1]
        p2 = continue_orbit(f, start, 34.0, steps=5 if fast else 40, order=2, x0=x2,
                            tol=1e-3, param_name="vin")
        results["period2"] = p2
        for b in p2.bifurcations:
            print(f"  period-2 branch: {b.type} at vin = {b.param:.4f} V")
        for note in p2.notes:
            print(f"  period-2 branch: {note}")
    results["continuation_wall"] = time.perf_counter() - t
    with open(out / "vm_buck_continuation.json", "w") as fh:
        json.dump({"period1": p1.to_dict(),
                   "period2": results["period2"].to_dict() if "period2" in results else None},
                  fh, indent=1)

    # 4. Basins at 30 V (period-2 region).
    t = time.perf_counter()
    n = 40 if fast else 200
    bm = cell_basins(f, [("v(C1)", 8.0, 16.0, n), ("i(L1)", 0.0, 2.5, n)], param=30.0,
                     progress=True)
    write_basins(bm, out / "vm_buck_basins.npz")
    plot_basins(bm, out / "vm_buck_basins.png", title="vm buck, vin = 30 V: basins")
    results["basins"] = bm
    print(f"basins at 30 V ({n} x {n} cells, {time.perf_counter() - t:.1f} s): "
          f"{len(bm.attractors)} attractor(s), "
          + ", ".join(f"{a.period} cells around v(C1) = {a.points[:, 0].mean():.3f} V"
                      for a in bm.attractors))
    return results


if __name__ == "__main__":
    main()
