"""Peak memory of a run against its length, side by side with ngspice.

    .venv/bin/python benchmarks/bench_memory.py [--periods P ...] [--points N] [--no-ngspice]
                                                [--every-step]

The open-loop buck of ``converters/netlists/buck.cir`` (50 kHz, h = 0.2 us, 104 steps a
period) run for P switching periods (default 1e3, 1e4, 1e5 and 1e6), always written on N
output points (default 1001: ``--output-step`` = run / 1000), each in a fresh process whose
peak resident memory (``/usr/bin/time -f %M``: the largest RSS, KB) and wall time are
recorded:

* ``pelcs simulate buck.cir --tstop T --output-step T/1000 -o OUT.csv``: the output grid
  computed as the run goes (``lcs.simulation.regrid``);
* the same run keeping every step and resampling at the end (what ``pelcs simulate`` did
  before; ``netlist.studies.transient.simulate_circuit`` then ``lcs.results.resample``), up to 1e5
  periods (1e6 would hold 1e8 rows);
* ``ngspice -b -r OUT.raw`` on the same deck with ``.tran T/1000 T 0 0.2u UIC``,
  ``.options interp`` and ``.save v(out) i(l1)`` (ngspice writes its raw file as it goes), up
  to 1e5 periods (1e6 takes ngspice about 10 minutes).

``pelcs simulate`` keeps the last 16,384 switchings (and counts them all) and plans the run a
stretch at a time: its memory stops growing once the run is longer than one stretch.

With ``--every-step`` the output is every step (the deck's ``.tran 0.2u``: P * 100 + 1
points, written to an NPZ file), so that the output grows with the run: ``pelcs simulate``
writes its file as the run goes (:func:`pelcs.writers.open_stream`), as ngspice writes its
raw file; the middle column is the run held whole and written at the end. Results go to
``benchmarks/results/bench_memory.json`` (``bench_memory_every_step.json``) and the table to
stdout.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
NETLIST = ROOT / "converters" / "netlists" / "buck.cir"
PERIOD = 20e-6  # s (50 kHz)

_KEEP_ALL = r"""
import sys
from lcs.results import resample
from netlist.parser import parse_file
from netlist.studies.transient import simulate_circuit
from pelcs.writers import write_result
res = simulate_circuit(parse_file(sys.argv[1]), tstop=float(sys.argv[2]))
write_result(resample(res, float(sys.argv[3])), sys.argv[4])
"""


def _timed(cmd: list[str], env: dict | None = None) -> tuple[float, float, str]:
    """Peak RSS (MB) and wall time (s) of ``cmd`` in a fresh process, and its stdout."""
    t0 = time.perf_counter()
    proc = subprocess.run(["/usr/bin/time", "-f", "MAXRSS %M", *cmd], capture_output=True,
                          text=True, env=env)
    wall = time.perf_counter() - t0
    match = re.search(r"MAXRSS (\d+)", proc.stderr)
    if proc.returncode not in (0,) or match is None:
        raise RuntimeError(f"{cmd[0]} failed ({proc.returncode}): {proc.stderr[-2000:]}")
    return int(match.group(1)) / 1024.0, wall, proc.stdout


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--periods", type=float, nargs="+", default=[1e3, 1e4, 1e5, 1e6])
    ap.add_argument("--points", type=int, default=1001)
    ap.add_argument("--no-ngspice", action="store_true")
    ap.add_argument("--every-step", action="store_true",
                    help="write every step (the output grows with the run)")
    ap.add_argument("--json")
    args = ap.parse_args()
    name = "bench_memory_every_step.json" if args.every_step else "bench_memory.json"
    args.json = args.json or str(ROOT / "benchmarks" / "results" / name)

    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        deck_text = NETLIST.read_text()
        for periods in args.periods:
            tstop = periods * PERIOD
            steps = round(tstop / 0.2e-6)
            points = steps + 1 if args.every_step else args.points
            dt = 0.2e-6 if args.every_step else tstop / (args.points - 1)
            row: dict = {"periods": periods, "steps": steps, "points": points}
            grid = [] if args.every_step else ["--output-step", repr(dt)]
            mb, wall, stdout = _timed([sys.executable, "-m", "pelcs.cli", "simulate",
                                       str(NETLIST), "--tstop", repr(tstop), *grid,
                                       "-o", str(out / "p.npz"), "--no-progress"], env)
            with np.load(out / "p.npz") as data:
                written = len(data["t"])
            assert written == points, (written, points)
            row["pelcs_mb"], row["pelcs_s"] = mb, wall
            events = re.search(r"(\d+) switching events", stdout)
            row["events"] = int(events.group(1)) if events else None
            if periods <= 1e5:
                mb, wall, _ = _timed([sys.executable, "-c", _KEEP_ALL, str(NETLIST),
                                      repr(tstop), repr(dt), str(out / "k.npz")], env)
                row["keep_all_mb"], row["keep_all_s"] = mb, wall
            if not args.no_ngspice and periods <= 1e5:
                deck = out / "ng.cir"
                deck.write_text(re.sub(
                    r"(?m)^\.tran.*$", f".tran {dt!r} {tstop!r} 0 0.2u UIC\n.options interp\n"
                    ".save v(out) i(l1)", deck_text))
                mb, wall, _ = _timed(["ngspice", "-b", "-r", str(out / "ng.raw"), str(deck)])
                row["ngspice_mb"], row["ngspice_s"] = mb, wall
                row["ngspice_raw_mb"] = (out / "ng.raw").stat().st_size / 1e6
            rows.append(row)
            print(json.dumps(row), flush=True)

    Path(args.json).parent.mkdir(parents=True, exist_ok=True)
    Path(args.json).write_text(json.dumps(rows, indent=1) + "\n")
    print()
    print("| periods | steps | points written | pelcs peak RSS | pelcs, every step kept then "
          "written | ngspice -b -r peak RSS |")
    print("|---|---|---|---|---|---|")

    def cell(mb, s):
        return f"{mb:.0f} MB ({s:.1f} s)" if mb is not None else "-"

    for r in rows:
        print(f"| {r['periods']:.0e} | {r['steps']:.2e} | {r['points']:.3g} "
              f"| {cell(r['pelcs_mb'], r['pelcs_s'])} "
              f"| {cell(r.get('keep_all_mb'), r.get('keep_all_s'))} "
              f"| {cell(r.get('ngspice_mb'), r.get('ngspice_s'))} |")


if __name__ == "__main__":
    main()
