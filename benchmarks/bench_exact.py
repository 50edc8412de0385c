"""The exact event-driven method against Moreau time-stepping, side by side.

Run by hand: ``.venv/bin/python benchmarks/bench_exact.py`` (about a minute on 2 cores).

1. Orbit and Floquet multipliers of Deane–Hamill's voltage-mode buck at E = 24 V (stable,
   near the flip) and 28 V (past it): the exact map (exact Jacobian) against Moreau maps at
   several steps (finite-difference Jacobians); the multiplier error of each against the
   exact multipliers, and the wall time. "Equal accuracy" is the Moreau step whose
   multipliers are within 1e-6 of the exact ones (or the finest tried).
2. Continuation of the period-1 orbit over E = 20..26 V (13 points, flip location).
3. A transient: the DCM boost over 2 ms (exact vs Moreau at the netlist's step).
4. Whole commands (``pelcs orbit``), start-up and parsing included.
"""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

VM_BUCK = ROOT / "converters" / "netlists" / "vm_buck.cir"
BOOST_DCM = ROOT / "tests" / "netlists" / "sim" / "boost_dcm.cir"


def _orbit(method: str, E: float, step: float | None = None):
    from lcs.analysis.orbits import find_orbit
    from netlist.studies.sweep import CircuitMapFactory

    f = CircuitMapFactory(path=str(VM_BUCK), period="tp", param="vin", method=method,
                          step=step)
    wall = np.inf
    for _ in range(3):  # best of three, the map built anew each time
        _build_cache_clear()
        t = time.perf_counter()
        m = f(E)
        orb = find_orbit(m, np.array([0.6, 12.0]), tol=1e-12)
        wall = min(wall, time.perf_counter() - t)
    mu = orb.multipliers
    return np.sort_complex(mu), wall, orb


def _build_cache_clear() -> None:
    from netlist.studies.sweep import _build_map

    _build_map.cache_clear()


def orbits() -> None:
    _orbit("exact", 24.0)  # imports, kernels: not part of either side's time
    _orbit("moreau", 24.0, 1e-6)
    print("1. Deane-Hamill buck: orbit + multipliers (Newton from (0.6 A, 12 V))")
    print(f"{'E':>5} {'method':>16} {'wall s':>8} {'|mu - mu_exact|':>16} {'iters':>6}")
    for E in (24.0, 28.0):
        mu_x, wall_x, orb_x = _orbit("exact", E)
        print(f"{E:5g} {'exact':>16} {wall_x:8.3f} {0.0:16.2e} {orb_x.iterations:6d}")
        equal = None
        for h in (1e-6, 0.25e-6, 0.1e-6):
            mu, wall, orb = _orbit("moreau", E, h)
            err = float(np.max(np.abs(mu - mu_x)))
            print(f"{E:5g} {'moreau h=' + f'{h * 1e6:g}us':>16} {wall:8.3f} {err:16.2e} "
                  f"{orb.iterations:6d}")
            if equal is None and err <= 1e-6:
                equal = (h, wall)
            last = (h, wall, err)
        if equal is None:
            print(f"      Moreau never reached 1e-6 (finest h = {last[0]:g} s: error "
                  f"{last[2]:.1e}, {last[1] / wall_x:.1f}x the exact time)")
        else:
            print(f"      equal accuracy (1e-6): Moreau h = {equal[0]:g} s takes "
                  f"{equal[1] / wall_x:.1f}x the exact time")


def continuation() -> None:
    print("2. continuation E = 20..26 V, 13 points, flip located")
    for method in ("exact", "moreau"):
        t = time.perf_counter()
        out = subprocess.run([str(ROOT / ".venv" / "bin" / "pelcs"), "continue", str(VM_BUCK),
                              "--period", "tp", "--param", "vin=20:26", "--steps", "13",
                              "--method", method, "--workers", "1"],
                             capture_output=True, text=True, check=True).stdout
        wall = time.perf_counter() - t
        flip = [ln.strip() for ln in out.splitlines() if ln.strip().startswith("flip ")]
        print(f"   {method:>7}: {wall:6.2f} s (whole command)  {flip[0] if flip else ''}")


def transient() -> None:
    import pelcs
    from netlist.studies.transient import simulate_circuit

    print("3. DCM boost, 2 ms transient (output every 0.2 us)")
    c = pelcs.load(BOOST_DCM)
    simulate_circuit(c, tstop=1e-5)  # kernels loaded
    walls = {}
    for method in ("exact", "moreau"):
        t = time.perf_counter()
        r = simulate_circuit(c, tstop=2e-3, method=method)
        walls[method] = time.perf_counter() - t
        print(f"   {method:>7}: {walls[method]:6.3f} s, v(C1) at 2 ms = {r['v(C1)'][-1]:.9g} V")
    print(f"   exact / moreau = {walls['exact'] / walls['moreau']:.2f}")


def commands() -> None:
    print("4. whole command: pelcs orbit vm_buck.cir --period tp --param vin=24")
    for method in ("exact", "moreau"):
        t = time.perf_counter()
        subprocess.run([str(ROOT / ".venv" / "bin" / "pelcs"), "orbit", str(VM_BUCK),
                        "--period", "tp", "--param", "vin=24", "--method", method],
                       capture_output=True, check=True)
        print(f"   {method:>7}: {time.perf_counter() - t:6.2f} s")


if __name__ == "__main__":
    orbits()
    continuation()
    transient()
    commands()
