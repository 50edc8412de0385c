"""Parallel resonant converter: waveforms, diode currents and output voltage against frequency.

The converter of ``converters/netlists/prc.cir`` (factory :func:`converters.factories.prc`):
a ±50 V square wave drives Lr = 150 µH into the tank capacitor Cr = 68 nF, whose voltage a
4-diode bridge rectifies into the filter Lf = 0.4 mH, Cf = 2.2 µF and the load R = 33 Ω.
The tank resonates at f0 = 1/(2π sqrt(Lr Cr)) = 49.8 kHz; its characteristic impedance is
R0 = sqrt(Lr/Cr) = 47.0 Ω.

1. One run at fs = 55 kHz from rest (2 ms): the four states over the run and, zoomed on the
   last two periods, the tank waveforms and the four diode currents. The inductive output
   filter makes the bridge current-fed: the conducting diode pair carries i(Lf), the pairs
   commutate when v(Cr) changes sign, and while they commutate all four diodes conduct and
   clamp v(Cr) at zero (the tank current then flows through the bridge).
2. The steady-state output voltage (mean v(out,n) over the last 40 periods of an 8 ms run
   with h = T/1600; 4 ms and T/400 with ``--fast``) for 25 drive frequencies from 25 to
   100 kHz (3 with ``--fast``), against

   - the first-harmonic approximation (FHA; Erickson & Maksimović ch. 19): the current-fed
     bridge with its LC filter looks like Re = π² R/8 = 40.7 Ω to the fundamental; with
     F = fs/f0 and Qe = Re/R0 = 0.867 the tank transfer is
     |H| = 1/sqrt((1 - F²)² + (F/Qe)²), and v(out) = mean |v(Cr)| = (2/π)(4 vin/π)|H| =
     (8/π²) vin |H|. FHA ignores the harmonics of the square wave and the clamped
     intervals of v(Cr), so it is a guide, not a reference: it is within 8 % of the
     simulation from f0 up, but up to 17 % low between 0.6 f0 and f0, where the tank
     waveforms are far from sinusoidal (and the third harmonic of the drive nears
     resonance at f0/3);
   - ngspice on the same netlist text (near-ideal diode model: two forward drops of about
     0.04 V each and 1 mΩ, so ngspice should lie about 0.1 % lower), at 6 of the
     frequencies (1 with ``--fast``), when ngspice is installed.

   A third, internal check: the steady-state input power mean(v(drv) i(Lr)) must equal the
   load power mean(v(out,n)²)/R (ideal elements are lossless).

   Near 59 kHz the steady state is not period 1: the mean of v(out,n) over single drive
   periods varies irregularly by about ±0.02 V from period to period, in pelcs and in
   ngspice alike (checked at 59.375 kHz, h = T/1600: the two sequences agree to 0.01 V), a
   quasi-periodic or long-period response; the 40-period average is steady to 2e-5.

Run ``python examples/prc_study.py [--out DIR] [--fast]``: writes ``prc_waveforms.png``,
``prc_waveforms.csv``, ``prc_sweep.png`` and ``prc_sweep.csv``.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from converters import factories as F  # noqa: E402
from netlist.parser import parse_string  # noqa: E402
from netlist.studies.transient import simulate_circuit  # noqa: E402

NAME = "prc_study"
VIN, LR, CR, LF, CF, R = 50.0, 150e-6, 68e-9, 0.4e-3, 2.2e-6, 33.0
F0 = 1 / (2 * math.pi * math.sqrt(LR * CR))
R0 = math.sqrt(LR / CR)
RE = math.pi**2 * R / 8
# Sweep runs: steps per drive period and run length (full / --fast). The diode commutations
# (zero crossings of v(Cr)) fall inside steps, so the error is first order in h: measured
# at 31.25 kHz, T/400 gives v(out) 0.4 % low, T/1600 0.1 %, T/6400 0.02 %. Some
# frequencies (56 kHz) take 6-7 ms to settle.
SWEEP = {False: (1600, 8e-3), True: (400, 4e-3)}
AVG_PERIODS = 40
PROBES = ["i(Lr)", "v(Cr)", "i(Lf)", "v(out,n)", "i(D1)", "i(D2)", "i(D3)", "i(D4)", "v(drv)"]


def fha_vout(fs, vin: float = VIN) -> np.ndarray:
    """First-harmonic estimate of the output voltage (V) at drive frequency ``fs`` (Hz)."""
    F_ = np.asarray(fs, dtype=float) / F0
    Qe = RE / R0
    return 8 / math.pi**2 * vin / np.sqrt((1 - F_**2) ** 2 + (F_ / Qe) ** 2)


@dataclass
class SweepPoint:
    """Steady state at one frequency."""

    fs: float
    vout: float  # mean v(out,n) over the last AVG_PERIODS periods, V
    drift: float  # relative change against the AVG_PERIODS before, 1
    p_in: float  # mean v(drv) i(Lr), W
    p_out: float  # mean v(out,n)^2 / R, W
    fha: float
    ngspice: float = float("nan")
    seconds: float = 0.0


def _means(t, ys, t0, t1):
    sel = (t >= t0 - 1e-12) & (t <= t1 + 1e-12)
    return [float(np.trapezoid(y[sel], t[sel]) / (t[sel][-1] - t[sel][0])) for y in ys]


def steady_state(fs: float, fast: bool = False) -> SweepPoint:
    """Simulate at ``fs`` (8 ms; 4 ms fast) and average the output over the last 40 periods."""
    t0 = time.perf_counter()
    T = 1 / fs
    spp, tstop = SWEEP[fast]
    circuit = parse_string(F.prc(fs=fs, tstop=tstop), file=f"<prc {fs:g} Hz>")
    res = simulate_circuit(circuit, step=T / spp,
                           probes=["v(out,n)", "i(Lr)", "v(drv)"]).raise_if_error()
    t, v, i, d = res.t, res["v(out,n)"], res["i(Lr)"], res["v(drv)"]
    end = t[-1]
    # whole periods: the drive is periodic from t = 0
    end = math.floor(end / T + 1e-9) * T
    a = end - AVG_PERIODS * T
    vout, p_in, p_out = _means(t, [v, d * i, v * v / R], a, end)
    (before,) = _means(t, [v], a - AVG_PERIODS * T, a)
    return SweepPoint(fs, vout, vout / before - 1, p_in, p_out, float(fha_vout(fs)),
                      seconds=time.perf_counter() - t0)


def ngspice_vout(fs: float, fast: bool = False) -> float:
    """The same measurement in ngspice (NaN if ngspice is not usable here).

    ngspice's maximum step is T/1600 (T/800 fast): with T/400 its result at 81 kHz is 0.4 %
    high (its truncation-error control does not see the diode commutations well enough).
    """
    try:
        from ngspice_checks import available, run_ngspice
    except ImportError:  # pragma: no cover - the package is part of pelcs
        return float("nan")
    if not available():
        return float("nan")
    T = 1 / fs
    tstop = SWEEP[fast][1]
    r = run_ngspice(F.prc(fs=fs, tstop=tstop, tstep=T / (800 if fast else 1600)),
                    ["v(out,n)"], timeout=600)
    t, v = r.time, r["v(out,n)"]
    end = math.floor(t[-1] / T + 1e-9) * T
    (vout,) = _means(t, [v], end - AVG_PERIODS * T, end)
    return vout


def waveforms(fast: bool):
    """The 55 kHz run from rest: time, probes."""
    fs = 55e3
    step = 1 / (fs * (100 if fast else 400))
    res = simulate_circuit(parse_string(F.prc(), file="<prc>"), step=step,
                           probes=PROBES).raise_if_error()
    return fs, res


# -- output ----------------------------------------------------------------------------------


def plot_waveforms(fs: float, res, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    T = 1 / fs
    t = res.t
    ms, us = 1e3, 1e6
    fig, axes = plt.subplots(2, 2, figsize=(13, 7.5), layout="constrained")
    ax = axes[0, 0]
    ax.plot(t * ms, res["v(Cr)"], color="tab:blue", lw=0.5, label="v(Cr) [V]")
    ax.plot(t * ms, res["v(out,n)"], color="tab:red", lw=1.5, label="v(Cf) = v(out,n) [V]")
    ax.set_title("tank and output voltage over the run (from rest)")
    ax.set_ylabel("[V]")
    ax.legend(fontsize=8, loc="lower right")
    ax = axes[1, 0]
    ax.plot(t * ms, res["i(Lr)"], color="tab:blue", lw=0.5, label="i(Lr) [A]")
    ax.plot(t * ms, res["i(Lf)"], color="tab:red", lw=1.5, label="i(Lf) [A]")
    ax.set_title("tank and filter inductor currents over the run")
    ax.set_ylabel("[A]")
    ax.set_xlabel("t [ms]")
    ax.legend(fontsize=8, loc="lower right")
    # zoom: last two periods
    sel = t >= t[-1] - 2 * T - 1e-12
    tz = (t[sel] - t[sel][0]) * us
    ax = axes[0, 1]
    ax.plot(tz, res["v(drv)"][sel], color="0.5", lw=1, label="drive v(drv) [V]")
    ax.plot(tz, res["v(Cr)"][sel], color="tab:blue", lw=1.5, label="v(Cr) [V]")
    ax.plot(tz, res["v(out,n)"][sel], color="tab:red", lw=1.5, label="v(out,n) [V]")
    ax.set_ylabel("[V]")
    ax.set_title("last two periods: drive, tank and output voltage, tank current")
    ax2 = ax.twinx()
    ax2.plot(tz, res["i(Lr)"][sel], color="tab:green", lw=1.2, ls="--", label="i(Lr) [A]")
    ax2.set_ylabel("i(Lr) [A]", color="tab:green")
    # room above the waveforms for one legend of both axes
    vmax = max(np.abs(res["v(Cr)"][sel]).max(), VIN)
    imax = np.abs(res["i(Lr)"][sel]).max()
    ax.set_ylim(-1.15 * vmax, 1.75 * vmax)
    ax2.set_ylim(-1.15 * imax, 1.75 * imax)
    h1, l1 = ax.get_legend_handles_labels()
    h2, l2 = ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper center", ncol=4)
    ax = axes[1, 1]
    for k, c in zip(range(1, 5), ("tab:blue", "tab:orange", "tab:green", "tab:purple"),
                    strict=True):
        ax.plot(tz, res[f"i(D{k})"][sel], color=c, lw=1.4 if k in (1, 4) else 1.0,
                ls="-" if k in (1, 4) else "--", label=f"i(D{k})")
    ax.plot(tz, res["i(Lf)"][sel], color="k", lw=0.8, ls=":", label="i(Lf)")
    ax.set_title("last two periods: bridge diode currents (D1, D4: v(Cr) > 0)")
    ax.set_ylabel("[A]")
    ax.set_xlabel("t - (t_end - 2T) [µs]")
    ax.legend(fontsize=8, loc="center", ncol=5)
    for a in axes.ravel():
        a.grid(alpha=0.3)
    fig.suptitle(f"Parallel resonant converter, ±{VIN:g} V square wave at {fs / 1e3:g} kHz "
                 f"(f0 = {F0 / 1e3:.1f} kHz): Lr = 150 µH, Cr = 68 nF, Lf = 0.4 mH, "
                 f"Cf = 2.2 µF, R = 33 Ω", fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_sweep(points: list[SweepPoint], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(9, 7), layout="constrained", sharex=True,
                                  gridspec_kw={"height_ratios": [2.2, 1]})
    fs = np.array([p.fs for p in points])
    v = np.array([p.vout for p in points])
    ng = np.array([p.ngspice for p in points])
    dense = np.linspace(min(fs.min(), 20e3), fs.max(), 400)
    ax.plot(dense / 1e3, fha_vout(dense), color="0.4", ls="--",
            label=f"first-harmonic approximation (Re = π²R/8, Qe = {RE / R0:.3f})")
    ax.plot(fs / 1e3, v, "o-", color="tab:blue", ms=5, label="pelcs, Moreau θ = 1/2")
    if np.isfinite(ng).any():
        ax.plot(fs / 1e3, ng, "x", color="tab:red", ms=9, mew=2, label="ngspice, same netlist")
    ax.axvline(F0 / 1e3, color="tab:green", lw=1, ls=":", label=f"f0 = {F0 / 1e3:.1f} kHz")
    ax.set_ylabel("steady-state v(out,n) [V]")
    ax.set_title(f"Output voltage against drive frequency (±{VIN:g} V drive, R = {R:g} Ω)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax2.plot(fs / 1e3, 100 * (np.array([p.fha for p in points]) / v - 1), "s-",
             color="0.4", ms=4, label="FHA vs pelcs")
    if np.isfinite(ng).any():
        ok = np.isfinite(ng)
        dev = 100 * (ng[ok] / v[ok] - 1)
        ax2.plot(fs[ok] / 1e3, dev, "x", color="tab:red", ms=8, mew=2,
                 label=f"ngspice vs pelcs (max |Δ| = {np.abs(dev).max():.2f} %)")
    ax2.axhline(0, color="0.5", lw=0.8)
    ax2.set_ylabel("difference [%]")
    ax2.set_xlabel("drive frequency fs [kHz]")
    ax2.legend(fontsize=8)
    ax2.grid(alpha=0.3)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict:
    """Run the waveform study and the frequency sweep; returns the results."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default=f"out/{NAME}", help="output directory (default %(default)s)")
    p.add_argument("--fast", action="store_true", help="3 frequencies, coarser waveform run")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    t0 = time.perf_counter()
    fs_w, res = waveforms(args.fast)
    plot_waveforms(fs_w, res, out / "prc_waveforms.png")
    every = max(1, res.t.size // 20000)
    np.savetxt(out / "prc_waveforms.csv", np.column_stack([res.t, res.y])[::every],
               delimiter=",", header=",".join(["t [s]", *res.names]), comments="",
               fmt="%.9g")
    print(f"waveforms at {fs_w / 1e3:g} kHz: {res.t.size} samples, "
          f"{time.perf_counter() - t0:.2f} s")

    freqs = [40e3, 55e3, 80e3] if args.fast else list(np.linspace(25e3, 100e3, 25))
    ng_freqs = {55e3} if args.fast else {freqs[i] for i in (2, 6, 10, 14, 18, 24)}
    points = []
    for fs in freqs:
        pt = steady_state(fs, args.fast)
        if fs in ng_freqs:
            pt.ngspice = ngspice_vout(fs, args.fast)
        points.append(pt)
        if fs not in ng_freqs:
            ng_text = "ngspice not run at this frequency"
        elif math.isnan(pt.ngspice):
            ng_text = "ngspice not available here"
        else:
            ng_text = f"ngspice {pt.ngspice:8.4f} V"
        print(f"fs = {fs / 1e3:6.2f} kHz: v(out) = {pt.vout:8.4f} V (drift {pt.drift:+.1e}), "
              f"FHA {pt.fha:8.4f} V, {ng_text}, P_in/P_out - 1 = "
              f"{pt.p_in / pt.p_out - 1:+.1e}  ({pt.seconds:.2f} s)")
    plot_sweep(points, out / "prc_sweep.png")
    with open(out / "prc_sweep.csv", "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(["fs [Hz]", "vout pelcs [V]", "drift", "P_in [W]", "P_out [W]",
                     "vout FHA [V]", "vout ngspice [V]"])
        for pt in points:
            wr.writerow([f"{pt.fs:.6g}", f"{pt.vout:.9g}", f"{pt.drift:.3g}",
                         f"{pt.p_in:.9g}", f"{pt.p_out:.9g}", f"{pt.fha:.9g}",
                         "" if math.isnan(pt.ngspice) else f"{pt.ngspice:.9g}"])
    return {"waveforms": res, "sweep": points}


if __name__ == "__main__":
    main()
