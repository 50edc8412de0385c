"""Cost per Moreau time step: pelcs against Siconos on the same hand-written LCS.

Systems
-------
* **DiodeBridge** -- the Siconos example (an LC tank discharging through a 4-diode bridge into
  a load resistor): L = 1e-2 H, C = 1e-6 F, R = 1e3 Ω, v(0) = 10 V, h = 1e-6 s, θ = 1/2;
  2 states, 4 pairs, no input. Matrices as in Siconos's ``DiodeBridge`` example.
* **PRC** -- a parallel resonant converter: a ±100 V, 55 kHz square wave drives Lr = 150 µH
  into Cr = 68 nF, whose voltage a 4-diode bridge rectifies into Lf = 0.4 mH, Cf = 2.2 µF,
  R = 33 Ω. States ``[i(Lr), v(Cr), i(Lf), v(Cf)]``; λ = ``[i(D1), v_rev(D2), i(D3),
  v_rev(D4)]`` (currents for the diodes on the Cr node, reverse voltages for the two returns,
  so that the floating bridge output needs no algebraic current constraint); D is skew.
  The step is h = T/2000 so that the square wave's edges (10 h ramps) fall on the grid of both
  programs.

Siconos runs in a subprocess with ``/usr/bin/python3`` (``siconos.kernel``:
FirstOrderLinearTIDS, FirstOrderLinearTIR, ComplementarityConditionNSL, EulerMoreauOSI,
TimeStepping, LCP with its default Lemke solver). For the PRC the source enters Siconos as the
DS vector b, set before each step to ``(1-θ) E u(t_k) + θ E u(t_k+1)`` (only when it changes),
which is exactly what pelcs integrates.

Run: ``.venv/bin/python benchmarks/bench_step.py [--quick]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from lcs.integrators.moreau.integrator import simulate_lcs  # noqa: E402
from lcs.model import LCS, ComplementarityPair  # noqa: E402
from lcs.signals import Pulse  # noqa: E402

SICONOS_PYTHON = "/usr/bin/python3"


def diode_bridge() -> tuple[LCS, np.ndarray, float]:
    """Siconos's DiodeBridge: x = [v(C), i(L)], λ = [-v(DR1), -v(DF2), i(DF1), i(DR2)]."""
    Lv, Cv, Rv = 1e-2, 1e-6, 1e3
    A = np.array([[0.0, -1.0 / Cv], [1.0 / Lv, 0.0]])
    B = np.array([[0.0, 0.0, -1.0 / Cv, 1.0 / Cv], [0.0, 0.0, 0.0, 0.0]])
    C = np.array([[0.0, 0.0], [0.0, 0.0], [-1.0, 0.0], [1.0, 0.0]])
    D = np.array([[1.0 / Rv, 1.0 / Rv, -1.0, 0.0], [1.0 / Rv, 1.0 / Rv, 0.0, -1.0],
                  [1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
    pairs = (ComplementarityPair("DR1", "voltage"), ComplementarityPair("DF2", "voltage"),
             ComplementarityPair("DF1"), ComplementarityPair("DR2"))
    lcs = LCS(A, B, C, D, np.zeros((2, 0)), np.zeros((4, 0)), ("v(C)", "i(L)"), pairs, ())
    return lcs, np.array([10.0, 0.0]), 1e-6


PRC_F = 55e3
PRC_V = 100.0


def prc() -> tuple[LCS, np.ndarray, float, Pulse]:
    """Parallel resonant converter (see the module docstring)."""
    Lr, Cr, Lf, Cf, R = 150e-6, 68e-9, 0.4e-3, 2.2e-6, 33.0
    A = np.array([
        [0.0, -1 / Lr, 0.0, 0.0],
        [1 / Cr, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, -1 / Lf],
        [0.0, 0.0, 1 / Cf, -1 / (R * Cf)],
    ])
    # KCL at the Cr node: Cr v' = i(Lr) - i(D1) + i(D3); Lf i' = v(p) - v(n) - v(Cf) with
    # v(p) = λ2 and v(n) = -λ4.
    B = np.array([
        [0.0, 0.0, 0.0, 0.0],
        [-1 / Cr, 0.0, 1 / Cr, 0.0],
        [0.0, 1 / Lf, 0.0, 1 / Lf],
        [0.0, 0.0, 0.0, 0.0],
    ])
    # w1 = v(p) - v(Cr), w2 = i(D2) = i(Lf) - i(D1), w3 = v(Cr) - v(n), w4 = i(Lf) - i(D3).
    C = np.array([[0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 1.0, 0.0, 0.0],
                  [0.0, 0.0, 1.0, 0.0]])
    D = np.array([[0.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0],
                  [0.0, 0.0, -1.0, 0.0]])
    E = np.array([[1 / Lr], [0.0], [0.0], [0.0]])
    pairs = (ComplementarityPair("D1"), ComplementarityPair("D2", "voltage"),
             ComplementarityPair("D3"), ComplementarityPair("D4", "voltage"))
    lcs = LCS(A, B, C, D, E, np.zeros((4, 1)), ("i(Lr)", "v(Cr)", "i(Lf)", "v(Cf)"), pairs,
              ("Vin",))
    per = 1.0 / PRC_F
    h = per / 2000
    edge = 10 * h
    drive = Pulse(-PRC_V, PRC_V, 0.0, edge, edge, per / 2 - edge, per)
    return lcs, np.zeros(4), h, drive


# ---------------------------------------------------------------------------------------------
# Siconos side (runs under /usr/bin/python3)
# ---------------------------------------------------------------------------------------------

SICONOS_SCRIPT = r'''
import sys, time
import numpy as np
import siconos.kernel as sk

d = np.load(sys.argv[1])
A, B, C, D, x0 = d["A"], d["B"], d["C"], d["D"], d["x0"]
h, theta, nsteps = float(d["h"]), float(d["theta"]), int(d["nsteps"])
bseq = d["bseq"]
n, m = B.shape
if bseq.size:
    ds = sk.FirstOrderLinearTIDS(x0, A, bseq[0])
else:
    ds = sk.FirstOrderLinearTIDS(x0, A)
rel = sk.FirstOrderLinearTIR(C, B)
rel.setDPtr(D)
inter = sk.Interaction(sk.ComplementarityConditionNSL(m), rel)
nsds = sk.NonSmoothDynamicalSystem(0.0, (nsteps + 1) * h)
nsds.insertDynamicalSystem(ds)
nsds.link(inter, ds)
osi = sk.EulerMoreauOSI(theta)
td = sk.TimeDiscretisation(0.0, h)
lcp = sk.LCP()  # default solver: Lemke
sim = sk.TimeStepping(nsds, td, osi, lcp)
X = np.empty((nsteps + 1, n))
X[0] = x0
x = ds.x()
b = ds.b() if bseq.size else None
last = bseq[0].copy() if bseq.size else None
t0 = time.perf_counter()
for k in range(nsteps):
    if b is not None and not np.array_equal(bseq[k], last):
        b[:] = bseq[k]
        last = bseq[k]
    sim.computeOneStep()
    X[k + 1] = x
    sim.nextStep()
elapsed = time.perf_counter() - t0
np.savez(sys.argv[2], X=X, elapsed=elapsed)
'''


def siconos_available() -> bool:
    try:
        r = subprocess.run([SICONOS_PYTHON, "-c", "import siconos.kernel"],
                           capture_output=True, timeout=120)
    except (OSError, subprocess.TimeoutExpired):
        return False
    return r.returncode == 0


def run_siconos(lcs: LCS, x0, h, nsteps, theta, bseq=None):
    """Run the same LCS in Siconos; returns (states (nsteps+1, n), seconds in the loop)."""
    with tempfile.TemporaryDirectory() as tmp:
        inp, out, script = (os.path.join(tmp, f) for f in ("in.npz", "out.npz", "run.py"))
        Path(script).write_text(SICONOS_SCRIPT)
        np.savez(inp, A=lcs.A, B=lcs.B, C=lcs.C, D=lcs.D, x0=np.asarray(x0, float), h=h,
                 theta=theta, nsteps=nsteps,
                 bseq=np.zeros((0, lcs.n)) if bseq is None else np.asarray(bseq))
        r = subprocess.run([SICONOS_PYTHON, script, inp, out], capture_output=True, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"siconos run failed:\n{r.stderr[-3000:]}")
        d = np.load(out)
        return d["X"], float(d["elapsed"])


def run_pelcs(lcs: LCS, inputs, x0, h, nsteps, theta, repeat=3):
    """Best of ``repeat`` runs (the first one may include loading numba's cache)."""
    best = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = simulate_lcs(lcs, inputs, x0, nsteps * h, h, theta=theta)
        dt = time.perf_counter() - t0
        res.raise_if_error()
        if best is None or dt < best[1]:
            best = (res, dt)
    return best


def compare(name, lcs, inputs, x0, h, n_long, n_cmp, theta, bseq_fn, have_siconos,
            sic_repeat=3):
    res, dt = run_pelcs(lcs, inputs, x0, h, n_long, theta)
    us_pelcs = 1e6 * dt / res.stats.steps
    row = {"system": name, "n": lcs.n, "m": lcs.m, "pelcs_steps": res.stats.steps,
           "pelcs_us_per_step": us_pelcs, "lemke_fallbacks": res.stats.fallbacks,
           "odd_steps": res.stats.odd_steps}
    if have_siconos:
        short, _ = run_pelcs(lcs, inputs, x0, h, n_cmp, theta, repeat=1)
        bseq = bseq_fn(short.t) if bseq_fn else None
        # Best of a few runs: the machine may be shared, and Siconos is the slow side.
        runs = [run_siconos(lcs, x0, h, n_cmp, theta, bseq) for _ in range(sic_repeat)]
        X = runs[0][0]
        us_sic = 1e6 * min(el for _, el in runs) / n_cmp
        diff = np.abs(short.y - X[: len(short.t)]).max(axis=0) / np.abs(X).max(axis=0)
        row.update(siconos_steps=n_cmp, siconos_us_per_step=us_sic,
                   ratio=us_sic / us_pelcs, max_rel_diff=float(diff.max()))
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer steps")
    ap.add_argument("--json", action="store_true", help="print JSON rows")
    args = ap.parse_args(argv)
    theta = 0.5
    have = siconos_available()
    scale = 10 if args.quick else 1
    rows = []
    lcs, x0, h = diode_bridge()
    # Siconos's example runs 5 ms (5000 steps); pelcs is timed on a longer run.
    rows.append(compare("DiodeBridge", lcs, [], x0, h, 2_000_000 // scale, 5000, theta, None,
                        have))
    lcs, x0, h, drive = prc()

    def bseq(t):
        u = drive(t)
        return ((1 - theta) * u[:-1, None] + theta * u[1:, None]) * lcs.E[:, 0][None, :]

    rows.append(compare("PRC 55 kHz", lcs, [drive], x0, h, 2_000_000 // scale,
                        100_000 // scale, theta, bseq, have, sic_repeat=2))
    if args.json:
        print(json.dumps(rows, indent=1))
    hdr = (f"{'system':<12} {'n':>2} {'m':>2} {'pelcs steps':>12} {'pelcs us/step':>14} "
           f"{'siconos us/step':>16} {'ratio':>7} {'max rel diff':>13} {'Lemke calls':>12}")
    print(hdr)
    for r in rows:
        sic = f"{r['siconos_us_per_step']:16.3f}" if "ratio" in r else f"{'n/a':>16}"
        ratio = f"{r['ratio']:7.1f}" if "ratio" in r else f"{'n/a':>7}"
        diff = f"{r['max_rel_diff']:13.2e}" if "ratio" in r else f"{'n/a':>13}"
        print(f"{r['system']:<12} {r['n']:>2} {r['m']:>2} {r['pelcs_steps']:>12} "
              f"{r['pelcs_us_per_step']:14.3f} {sic} {ratio} {diff} {r['lemke_fallbacks']:>12}")
    if not have:
        print(f"(Siconos not available: {SICONOS_PYTHON} -c 'import siconos' failed)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
