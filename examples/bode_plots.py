"""Bode plots of switching converters straight from their netlists (``pelcs ac``).

1. The voltage-mode buck of ``tests/netlists/ac/buck_vc.cir`` (12 V, 100 µH, 100 µF, 1 Ω,
   100 kHz trailing-edge PWM against a 1 V sawtooth): control-to-output v(out)/v(con) by the
   exact method (the orbit linearised with the saltation of every switching instant), by the
   time-domain sweep at a few frequencies, and the CCM averaged model
   (``converters.averaged.small_signal_model``). For the buck with natural-sampling PWM the
   component at the excitation frequency equals the averaged model: the exact curve lies on
   it (to 0.02 dB) up to fs/2.
2. The peak-current-mode buck of ``tests/netlists/ac/cm_buck.cir`` (latched PWM, sensed
   current 0.1 V/A) with compensating ramps of 0, 0.05 and 0.1 V per period: control-to-output
   near fs/2 by the exact method against Ridley's model, whose double pole at fs/2 has
   Q = 1/(π (mc D' - 0.5)). Without a ramp (mc = 1, D close to 0.5) Q is large and the
   response peaks at fs/2: the current loop is close to its subharmonic instability.

Run ``python examples/bode_plots.py [--out DIR] [--fast]``: writes ``bode_vm_buck.png``,
``bode_cm_buck.png`` and ``bode_plots.csv`` (probe, case, f, dB, deg of every curve).
``--fast``: 3 sweep points from 1 kHz instead of 8 from 100 Hz.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

NAME = "bode_plots"
AC = ROOT / "tests" / "netlists" / "ac"
TS, TF = 10e-6, 10e-9
K_MOD = (TS - TF) / TS  # duty per volt of v(con): the ramp's 10 ns fall also modulates


def _ridley(f, D, vo, vr, vin=12.0, ri=0.1, L=20e-6, C=50e-6, R=2.5):
    sn, se = ri * (vin - vo) / L, vr / (TS - 2 * TF)
    mc = 1 + se / sn
    k = mc * (1 - D) - 0.5
    q = 1 / (np.pi * k)
    wn, wp = np.pi / TS, 1 / (R * C) + TS * k / (L * C)
    s = 2j * np.pi * np.asarray(f)
    return (R / ri) / (1 + R * TS * k / L) / (1 + s / wp) / (1 + s / (wn * q) + s**2 / wn**2), q


def _finish(fig, a1, a2, title: str, path: Path, **legend) -> None:
    """Both Bode panels: fs/2 marker, grid, axes labels with units, title, legend; save."""
    import matplotlib.pyplot as plt

    for ax in (a1, a2):
        ax.axvline(5e4, color="grey", ls=":", lw=1, label="fs/2")
        ax.grid(True, which="both", alpha=0.3)
    a1.set_ylabel("|v(out)/v(con)| (dB)")
    a2.set_ylabel("phase (deg)")
    a2.set_xlabel("frequency (Hz)")
    a1.set_title(title)
    a1.legend(**legend)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default=f"out/{NAME}", help="output directory (default %(default)s)")
    p.add_argument("--fast", action="store_true",
                   help="3 sweep points from 1 kHz instead of 8 from 100 Hz")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from converters.averaged import small_signal_model
    from netlist.parser import parse_file
    from netlist.studies.ac import ac_analysis

    rows: list = []
    result: dict = {}

    # 1. Voltage-mode buck: exact, sweep, averaged.
    c = parse_file(str(AC / "buck_vc.cir"))
    f = np.logspace(1, np.log10(5e4), 120)
    t = time.perf_counter()
    ex = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)"], freqs=f)
    t_exact = time.perf_counter() - t
    # (--fast: from 1 kHz, where each point simulates a tenth of the periods 100 Hz takes)
    fsw = np.logspace(3, np.log10(4e4), 3) if args.fast else np.logspace(2, np.log10(4e4), 8)
    t = time.perf_counter()
    sw = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)"], freqs=fsw, method="sweep")
    t_sweep = time.perf_counter() - t
    avg = small_signal_model("buck", 12.0, 0.5 * K_MOD, 1.0, lind=100e-6, cout=100e-6)
    Ha = avg(2j * np.pi * f)[1, 0, :] * K_MOD
    ex_at_sw = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)"], freqs=sw.freq)
    result["vm_buck"] = {
        "exact_vs_averaged_db": float(np.max(np.abs(ex.mag_db("v(out)")
                                                    - 20 * np.log10(np.abs(Ha))))),
        "sweep_vs_exact_db": float(np.max(np.abs(sw.mag_db("v(out)")
                                                 - ex_at_sw.mag_db("v(out)")))),
        "sweep_vs_exact_deg": float(np.max(np.abs(sw.phase_deg("v(out)")
                                                  - ex_at_sw.phase_deg("v(out)")))),
        "t_exact_s": t_exact, "t_sweep_s": t_sweep, "sweep_points": len(fsw),
    }
    fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.5))
    a1.semilogx(f, ex.mag_db("v(out)"), color="C0", lw=2, label="exact (saltation)")
    a1.semilogx(f, 20 * np.log10(np.abs(Ha)), color="k", ls="--", lw=1, label="averaged model")
    a1.semilogx(sw.freq, sw.mag_db("v(out)"), "o", color="C3", mfc="none",
                label="time-domain sweep")
    a2.semilogx(f, ex.phase_deg("v(out)"), color="C0", lw=2, label="exact (saltation)")
    a2.semilogx(f, np.degrees(np.unwrap(np.angle(Ha))), color="k", ls="--", lw=1,
                label="averaged model")
    a2.semilogx(sw.freq, sw.phase_deg("v(out)"), "o", color="C3", mfc="none",
                label="time-domain sweep")
    _finish(fig, a1, a2, "Voltage-mode buck, control-to-output (fs = 100 kHz)",
            out / "bode_vm_buck.png", fontsize=8)
    for label, ff, mag, ph in (("exact", f, ex.mag_db("v(out)"), ex.phase_deg("v(out)")),
                               ("averaged", f, 20 * np.log10(np.abs(Ha)),
                                np.degrees(np.unwrap(np.angle(Ha)))),
                               ("sweep", sw.freq, sw.mag_db("v(out)"), sw.phase_deg("v(out)"))):
        rows += [("vm_buck", label, a, b, d) for a, b, d in zip(ff, mag, ph, strict=True)]

    # 2. Current-mode buck near fs/2: exact against Ridley, three ramps.
    f2 = np.logspace(3, np.log10(5e4), 80)
    fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6.5))
    result["cm_buck"] = {}
    for i, vr in enumerate((0.0, 0.05, 0.1)):
        c = parse_file(str(AC / "cm_buck.cir"), params={"vr": vr})
        fr = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)"], freqs=f2)
        D = fr.orbit["events"][0]["fraction"]
        Hr, q = _ridley(f2, D, fr.orbit["x0"][1], vr)
        err = np.abs(fr.mag_db("v(out)") - 20 * np.log10(np.abs(Hr)))
        result["cm_buck"][vr] = {"Q": q, "D": D, "max_db_vs_ridley": float(np.max(err)),
                                 "db_at_half_fs_vs_ridley": float(err[-1])}
        col = f"C{i}"
        lab = f"ramp {vr:g} V (Q = {q:.2g})"
        a1.semilogx(f2, fr.mag_db("v(out)"), color=col, lw=2, label=f"exact, {lab}")
        a1.semilogx(f2, 20 * np.log10(np.abs(Hr)), color=col, ls="--", lw=1,
                    label=f"Ridley, {lab}")
        a2.semilogx(f2, fr.phase_deg("v(out)"), color=col, lw=2, label=f"exact, {lab}")
        a2.semilogx(f2, np.degrees(np.unwrap(np.angle(Hr))), color=col, ls="--", lw=1,
                    label=f"Ridley, {lab}")
        rows += [("cm_buck", f"exact vr={vr:g}", a, b, d)
                 for a, b, d in zip(f2, fr.mag_db("v(out)"), fr.phase_deg("v(out)"),
                                    strict=True)]
    _finish(fig, a1, a2, "Peak-current-mode buck: the sampling double pole at fs/2",
            out / "bode_cm_buck.png", fontsize=7, ncol=2)

    with open(out / "bode_plots.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["circuit", "curve", "f_hz", "mag_db", "phase_deg"])
        w.writerows((a, b, f"{c:.6g}", f"{d:.6g}", f"{e:.6g}") for a, b, c, d, e in rows)
    vm = result["vm_buck"]
    print(f"voltage-mode buck: exact vs averaged {vm['exact_vs_averaged_db']:.3f} dB; sweep vs "
          f"exact {vm['sweep_vs_exact_db']:.3f} dB / {vm['sweep_vs_exact_deg']:.2f} deg; "
          f"exact {t_exact:.2f} s for {len(f)} points, sweep {t_sweep:.1f} s for {len(fsw)}")
    for vr, r in result["cm_buck"].items():
        print(f"current-mode buck, ramp {vr:g} V: D = {r['D']:.4f}, Q = {r['Q']:.3g}, "
              f"|exact - Ridley| <= {r['max_db_vs_ridley']:.2f} dB "
              f"({r['db_at_half_fs_vs_ridley']:.2f} dB at fs/2)")
    return result


if __name__ == "__main__":
    main()
