"""Run a deck in pelcs (the CLI) and ngspice (``-b``, ``wrdata``) and compare probes.

usage: python audit/cmp.py DECK PROBE [PROBE...] [--devices pwl] [--from T]

Prints pelcs's output, then per probe the time-mean, RMS, min, max and last value over
[T, tstop] of each, and the largest difference relative to ngspice's range (ngspice
interpolated onto pelcs's points: at a jump of a waveform this is the jump itself).
"""

import csv
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np


def _option(args: list[str], name: str, default=None):
    if name not in args:
        return default
    i = args.index(name)
    value = args[i + 1]
    del args[i:i + 2]
    return value


def _stats(a: np.ndarray, t: np.ndarray) -> str:
    span = t[-1] - t[0]
    mean = np.trapezoid(a, t) / span if span > 0 else a.mean()
    rms = np.sqrt(np.trapezoid(a * a, t) / span) if span > 0 else abs(a).mean()
    return f"mean {mean:.5g} rms {rms:.5g} min {a.min():.5g} max {a.max():.5g} end {a[-1]:.5g}"


def main() -> None:
    args = sys.argv[1:]
    devices = _option(args, "--devices")
    t_from = float(_option(args, "--from", "0"))
    deck, probes = Path(args[0]).resolve(), args[1:]
    tmp = Path(tempfile.mkdtemp())
    out = tmp / "out.csv"
    cmd = [sys.executable, "-m", "pelcs.cli", "simulate", str(deck), "-o", str(out),
           "--no-progress", *(x for p in probes for x in ("--probe", p))]
    if devices:
        cmd += ["--devices", devices]
    root = str(Path(__file__).resolve().parents[1])
    r = subprocess.run(cmd, capture_output=True, text=True, cwd=deck.parent,
                       env={**os.environ, "PYTHONPATH": root})
    print("pelcs rc", r.returncode)
    print((r.stdout + r.stderr)[-3000:])
    ngout = tmp / "ng.txt"
    lines = deck.read_text().splitlines()
    end = max((k for k, t in enumerate(lines) if t.strip().lower() == ".end"),
              default=len(lines))
    control = [".control", "run", f"wrdata {ngout} {' '.join(probes)}", "quit", ".endc"]
    ngfile = deck.parent / (".ng_" + deck.name)
    ngfile.write_text("\n".join(lines[:end] + control + [".end"]) + "\n")
    rn = subprocess.run(["ngspice", "-b", ngfile.name], capture_output=True, text=True,
                        cwd=deck.parent, timeout=300)
    ngfile.unlink()
    if not ngout.exists():
        print("ngspice wrote nothing:\n", (rn.stdout + rn.stderr)[-3000:])
        return
    ng = np.loadtxt(ngout, ndmin=2)
    if r.returncode != 0 or not out.exists():
        print("ngspice ran; pelcs did not")
        return
    with open(out) as f:
        rows = list(csv.reader(f))
    head = [h.lower() for h in rows[0]]
    data = np.array([[float(x) for x in row] for row in rows[1:]])
    t = data[:, 0]
    for k, p in enumerate(probes):
        y = data[:, head.index(p.lower())]
        tn, yn = ng[:, 2 * k], ng[:, 2 * k + 1]
        m, mn = t >= t_from, tn >= t_from
        rng = max(np.ptp(yn[mn]), abs(yn[mn]).max(), 1e-30)
        print(f"{p}: pelcs   {_stats(y[m], t[m])}")
        print(f"{p}: ngspice {_stats(yn[mn], tn[mn])}")
        print(f"{p}: max|diff|/range {np.abs(y[m] - np.interp(t[m], tn, yn)).max() / rng:.3%}")


if __name__ == "__main__":
    main()
