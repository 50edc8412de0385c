"""Cost per time step of switched converters, mode changes included.

Cases
-----
* ``buck.cir`` (bundled, open loop, PULSE gate at 50 kHz) at h = 0.2 µs (100 steps per period)
  and h = T/17 (17 steps per period: mode changes dominate);
* the voltage-mode buck of the chaos literature (``tests/netlists/closed_loop/vm_buck.cir``,
  comparator-driven switch, instants located inside the steps) at E = 25 V, h = T/17, T/50 and
  T/200;
* the sliding-mode boost (``tests/netlists/closed_loop/boost_smc.cir``) with the implicit
  (Filippov) method, h = 1 µs.

Times are the best of ``--repeat`` runs of :func:`netlist.studies.transient.run_setup` (set-up and
formulation excluded, everything else included: source events, grid, inputs, kernel, results),
divided by the steps taken. The machine may be shared: best-of-N is the fair number.

Run: ``.venv/bin/python benchmarks/bench_step_switching.py [--repo PATH] [--quick]``; ``--repo``
points at another checkout (e.g. a ``git worktree`` of an older commit) to measure "before"
(cases it cannot run are reported as such).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]


def cases(root: Path, quick: bool):
    n = 4 if quick else 1
    buck = root / "converters" / "netlists" / "buck.cir"
    vm = HERE / "tests" / "netlists" / "closed_loop" / "vm_buck.cir"
    smc = HERE / "tests" / "netlists" / "closed_loop" / "boost_smc.cir"
    return [
        ("buck.cir h=0.2us", buck, {}, 20e-3 / n, 0.2e-6),
        ("buck.cir h=T/17", buck, {}, 20e-3 / n, 20e-6 / 17),
        ("vm_buck E=25 h=T/17", vm, {"e": 25}, 80e-3 / n, 400e-6 / 17),
        ("vm_buck E=25 h=T/50", vm, {"e": 25}, 80e-3 / n, 400e-6 / 50),
        ("vm_buck E=25 h=T/200", vm, {"e": 25}, 80e-3 / n, 400e-6 / 200),
        ("boost SMC implicit h=1us", smc, {}, 30e-3 / n, 1e-6),
    ]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repo", type=Path, default=HERE, help="checkout whose code is timed")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--quick", action="store_true", help="shorter runs")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(args.repo.resolve()))
    from netlist.parser import parse_file
    from netlist.studies.transient import run_setup, transient_setup

    rows = []
    for name, path, params, tstop, h in cases(args.repo.resolve(), args.quick):
        try:
            setup = transient_setup(parse_file(path, params=params or None), tstop=tstop,
                                    step=h)
            run_setup(setup)  # load the compiled kernels
            best = float("inf")
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                res = run_setup(setup)
                best = min(best, time.perf_counter() - t0)
            stats = res.stats
            rows.append({"case": name, "steps": stats.steps, "events": len(res.events),
                         "us_per_step": 1e6 * best / stats.steps,
                         "located": getattr(stats, "located", 0),
                         "sliding_steps": getattr(stats, "sliding_steps", 0),
                         "ok": res.ok})
        except Exception as exc:  # an older checkout may not support a case
            rows.append({"case": name, "error": f"{type(exc).__name__}: {str(exc)[:60]}"})
    if args.json:
        print(json.dumps(rows, indent=1))
    print(f"{'case':<26} {'steps':>8} {'events':>7} {'located':>8} {'us/step':>8}")
    for r in rows:
        if "error" in r:
            print(f"{r['case']:<26} {r['error']}")
            continue
        print(f"{r['case']:<26} {r['steps']:>8} {r['events']:>7} {r['located']:>8} "
              f"{r['us_per_step']:>8.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
