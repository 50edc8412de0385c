"""The whole command, side by side with ngspice: what a user times.

    .venv/bin/python benchmarks/bench_command.py [--repeat N] [--periods P ...]

For the DCM boost of ``tests/netlists/sim/boost_dcm.cir`` (50 kHz, ``.tran 0.2u ... 0 0.2u``,
near-ideal models for ngspice) run for P switching periods (default 800 and 8000):

* ``pelcs simulate FILE -o OUT`` in a fresh process, for OUT = CSV, NPZ, Parquet and no file
  (the default output grid: ``.tran`` TSTEP, here every step), with the ahead-of-time kernels
  and, for comparison, with ``PELCS_AOT=0`` (numba's cache);
* ``ngspice -b -r OUT.raw FILE`` (binary raw file, every accepted time point) and the same with
  ``SPICE_ASCIIRAWFILE=1`` (an ASCII raw file, the CSV's counterpart), in a fresh process.

Each time is the best of ``--repeat`` runs (wall clock around the process). Then a breakdown
of one pelcs command by stage, measured inside a fresh process: interpreter start, imports,
parsing, set-up (formulation, screens), the run, resampling and writing.

The machine's ``PYTHONDONTWRITEBYTECODE`` (set on this workplace) is removed for the pelcs
processes, as on a user's machine: Python then reads the ``.pyc`` files ``scripts/setup``
compiled instead of compiling 70 modules (0.1 s) on every start.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
NETLIST = ROOT / "tests" / "netlists" / "sim" / "boost_dcm.cir"
PELCS = ROOT / ".venv" / "bin" / "pelcs"
PYTHON = ROOT / ".venv" / "bin" / "python"

_STAGES = r"""
import time, sys
t0 = time.perf_counter()
from pelcs.cli import build_parser
from netlist.parser import parse_file
from netlist.studies.transient import run_setup, transient_setup
from lcs.results import resample
from pelcs.writers import write_result
t1 = time.perf_counter()
circuit = parse_file(sys.argv[1])
t2 = time.perf_counter()
setup = transient_setup(circuit)
t3 = time.perf_counter()
res = run_setup(setup)
t4 = time.perf_counter()
res = resample(res, circuit.tran.tstep)
t5 = time.perf_counter()
write_result(res, sys.argv[2])
t6 = time.perf_counter()
print("STAGES", t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4, t6 - t5, res.stats.steps,
      len(res.t))
"""


def _deck(periods: int, tmp: Path) -> Path:
    text = NETLIST.read_text()
    tstop = periods / 50e3
    lines = [ln if not ln.lower().startswith(".tran") else
             f".tran 0.2u {tstop:g} 0 0.2u UIC" for ln in text.splitlines()]
    path = tmp / f"boost_dcm_{periods}.cir"
    path.write_text("\n".join(lines) + "\n")
    return path


def _best(cmd: list[str], repeat: int, env: dict | None = None) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=900)
        dt = time.perf_counter() - t0
        if r.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed: {r.stderr[-500:]}")
        best = min(best, dt)
    return best


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--periods", type=int, nargs="*", default=[800, 8000])
    args = ap.parse_args(argv)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env_numba = {**env, "PELCS_AOT": "0"}
    have_ngspice = shutil.which("ngspice") is not None
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        print(f"{'run':28s} {'pelcs s':>8s} {'ngspice s':>10s} {'ratio':>6s}")
        for periods in args.periods:
            deck = _deck(periods, tmp)
            ng_raw = ng_ascii = None
            if have_ngspice:
                ng_raw = _best(["ngspice", "-b", "-r", str(tmp / "o.raw"), str(deck)],
                               args.repeat)
                ng_ascii = _best(["ngspice", "-b", "-r", str(tmp / "a.raw"), str(deck)],
                                 args.repeat, {**os.environ, "SPICE_ASCIIRAWFILE": "1"})
            rows = [("no file", [], ng_raw), ("NPZ", ["-o", str(tmp / "o.npz")], ng_raw),
                    ("Parquet", ["-o", str(tmp / "o.parquet")], ng_raw),
                    ("CSV", ["-o", str(tmp / "o.csv")], ng_ascii)]
            for label, extra, ng in rows:
                t = _best([str(PELCS), "simulate", str(deck), "--no-progress", *extra],
                          args.repeat, env)
                peer = "binary" if ng is ng_raw else "ASCII"
                ratio = f"{ng / t:6.1f}" if ng else "   n/a"
                print(f"{periods:5d} periods, {label:9s} {'':10s} {t:8.3f} "
                      f"{(ng or float('nan')):10.3f} {ratio}  (ngspice: {peer} raw file)")
            t = _best([str(PELCS), "simulate", str(deck), "--no-progress", "-o",
                       str(tmp / "o.npz")], args.repeat, env_numba)
            print(f"{periods:5d} periods, NPZ, numba cache (PELCS_AOT=0): {t:8.3f} s")
            r = subprocess.run([str(PYTHON), "-c", _STAGES, str(deck), str(tmp / "s.csv")],
                               capture_output=True, text=True, env=env, timeout=900)
            if r.returncode == 0:
                v = r.stdout.split("STAGES")[1].split()
                names = ["imports", "parse", "set-up", "run", "resample", "write CSV"]
                parts = ", ".join(f"{n} {float(x):.3f}" for n, x in zip(names, v[:6],
                                                                          strict=True))
                print(f"{periods:5d} periods, stages in s: {parts} ({v[6]} steps, {v[7]} "
                      "points)")
        start = _best([str(PYTHON), "-c", "pass"], args.repeat, env)
        print(f"interpreter start alone: {start:.3f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
