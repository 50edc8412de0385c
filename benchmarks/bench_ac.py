"""Bode plots of switching converters: the exact method against the time-domain sweep.

Cases (``tests/netlists/ac``): the voltage-mode buck (control-to-output), the boost
(control-to-output) and the peak-current-mode buck (control-to-output), 2 states each.

For each case and method the script times, best of ``--repeat`` (the machine may be shared):

* ``orbit``: the periodic steady state (Newton on the Moreau map; plus the exact refinement
  for the exact method);
* ``response``: the ``--points`` frequencies from fs/1000 to fs/2 after the orbit is found;
* ``command``: the whole ``pelcs ac`` command in a fresh process (start-up, parsing, orbit,
  response, output), measured once.

The sweep is run at ``--sweep-points`` frequencies (it costs about a second per point) and its
per-point cost scaled to ``--points``; the ratio printed is sweep/exact per Bode plot, and the
largest difference between the two methods at the sweep's frequencies (below fs/2) is printed
alongside, so that the speed is compared at agreeing results.

Run: ``.venv/bin/python benchmarks/bench_ac.py [--points 100] [--sweep-points 8]``.
Writes ``benchmarks/results/bench_ac.json``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE))

CASES = [
    ("voltage-mode buck", "buck_vc.cir", "Vc", "v(out)"),
    ("boost", "boost_vc.cir", "Vc", "v(out)"),
    ("current-mode buck", "cm_buck.cir", "Vc", "v(out)"),
]


def _best(fn, repeat: int):
    best, out = np.inf, None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t)
    return best, out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=100)
    ap.add_argument("--sweep-points", type=int, default=8)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()

    from lcs.analysis.exact_orbit import exact_orbit
    from lcs.analysis.orbits import find_orbit
    from lcs.smallsignal.ltp import harmonic_response, probe_forms
    from netlist.parser import parse_file
    from netlist.studies.ac import ac_analysis, default_frequencies
    from netlist.studies.sweep import circuit_map

    rows = []
    print(f"{'case':20s} {'orbit':>9s} {'exact':>9s} {'sweep':>9s} {'ratio':>7s} "
          f"{'max dB':>7s} {'max deg':>7s} {'cmd exact':>9s}")
    for label, name, inject, probe in CASES:
        path = HERE / "tests" / "netlists" / "ac" / name
        c = parse_file(str(path))
        m = circuit_map(c, "ts")
        T = m.period
        freqs = default_frequencies(T, args.points)

        def orbit(m=m, T=T):
            o = find_orbit(m, m.x0, pattern=False)
            key0 = tuple(m.trajectory(o.points[0], 1).modes_visited[0])
            return exact_orbit(m.system, m.signals, o.points[0], key0, 0.0, T)

        t_orbit, eo = _best(orbit, args.repeat)
        idx = [s.lower() for s in m.system.inputs].index(inject.lower())

        def exact(m=m, eo=eo, probe=probe, idx=idx, freqs=freqs):
            Y = probe_forms(eo, lambda key: m.system.outputs(key, [probe]))
            return harmonic_response(eo, Y, [probe], idx, freqs)

        t_exact, _ = _best(exact, args.repeat)
        fsw = default_frequencies(T, args.sweep_points)[:-1]  # below fs/2 (see sweep.py)
        t0 = time.perf_counter()
        sw = ac_analysis(c, period="ts", inject=inject, probes=[probe], freqs=fsw,
                         method="sweep")
        t_sweep = (time.perf_counter() - t0) * args.points / len(fsw)
        ex = ac_analysis(c, period="ts", inject=inject, probes=[probe], freqs=sw.freq)
        d_db = float(np.max(np.abs(sw.mag_db(probe) - ex.mag_db(probe))))
        d_deg = float(np.max(np.abs(sw.phase_deg(probe) - ex.phase_deg(probe))))
        cmd = [str(HERE / ".venv" / "bin" / "pelcs"), "ac", str(path), "--period", "ts",
               "--inject", inject, "--probe", probe, "--freq",
               f"{freqs[0]}:{freqs[-1]}:{args.points}", "-o", "/dev/null"]
        t0 = time.perf_counter()
        subprocess.run(cmd, check=True, capture_output=True)
        t_cmd = time.perf_counter() - t0
        ratio = t_sweep / t_exact
        print(f"{label:20s} {t_orbit:8.3f}s {t_exact:8.3f}s {t_sweep:8.1f}s {ratio:6.0f}x "
              f"{d_db:7.3f} {d_deg:7.2f} {t_cmd:8.2f}s")
        rows.append({"case": label, "points": args.points, "orbit_s": t_orbit,
                     "exact_response_s": t_exact, "sweep_response_s_scaled": t_sweep,
                     "sweep_points_run": len(fsw), "ratio_sweep_over_exact": ratio,
                     "max_diff_db": d_db, "max_diff_deg": d_deg, "command_exact_s": t_cmd})
    out = HERE / "benchmarks" / "results" / "bench_ac.json"
    out.parent.mkdir(exist_ok=True)
    out.write_text(json.dumps(rows, indent=1))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
