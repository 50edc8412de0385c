"""Start-up transients and steady-state ripple of the open-loop PWM converters.

Buck, boost, inverting buck-boost and Čuk (factories of :mod:`converters.factories`) start
from rest (all states zero) with a fixed duty cycle and are simulated through start-up into
the periodic steady state. Each figure overlays

- the simulated states (thin), their average over one switching period (sliding window),
  and the state-space averaged CCM model ``x' = (D A_on + (1-D) A_off) x + ...`` started
  from the same zero state (:mod:`converters.averaged`, written by hand from the circuits);
- the switching periods in which an inductor current touches zero, shaded: there the
  converter is in DCM for part of the period (the diode blocks with the current at zero)
  and the CCM averaged model does not apply — the start-up overshoot of these
  lightly damped designs drives the inductor current to zero for a few dozen periods;
- zooms on the last periods with the averaged model's steady state and the ripple
  formulas of :func:`converters.averaged.ripple` drawn as a band mean ± Δ/2.

The designs (fs = 100 kHz, R C about 50 switching periods, output ripple about 1 %) are the
ones of ``tests/test_converters_steady.py``; their steady states agree with the averaged
model and the ripple formulas to the accuracy derived there (measured: means within
0.05 %, the buck's within 0.004 % as volt-second balance makes it exact; ripples within
0.05 %; see ``open_loop_summary.csv``). After the last DCM period the averaged model,
restarted from the simulated period average, follows it within 0.15 % (buck: 2e-7, its
averaged model being exact for period averages).

Run ``python examples/open_loop_startup.py [--out DIR] [--fast]``: writes
``open_loop_<converter>.png``, ``open_loop_<converter>.csv`` (t, simulated states, averaged
model states) and ``open_loop_summary.csv``. ``--fast`` uses a 2.5x coarser step (h = T/40).
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from converters import factories as F  # noqa: E402
from converters.averaged import AveragedModel, averaged_model, ripple  # noqa: E402
from converters.design import conversion_ratio  # noqa: E402
from netlist.studies.transient import simulate_circuit  # noqa: E402

NAME = "open_loop_startup"
FS = 100e3
T = 1 / FS
TSTOP = 10e-3

#: Designs (V, Hz, H, F, Ω) as in tests/test_converters_steady.py.
DESIGNS = {
    "buck": dict(vin=24.0, duty=0.4, fs=FS, lind=100e-6, cout=125e-6, rload=4.0),
    "boost": dict(vin=12.0, duty=0.5, fs=FS, lind=100e-6, cout=25e-6, rload=20.0),
    "buck-boost": dict(vin=12.0, duty=0.4, fs=FS, lind=100e-6, cout=62.5e-6, rload=8.0),
    "cuk": dict(vin=12.0, duty=0.4, fs=FS, l1=200e-6, c1=20e-6, l2=400e-6, c2=20e-6,
                rload=8.0),
}
TITLES = {"buck": "Buck", "boost": "Boost", "buck-boost": "Inverting buck-boost",
          "cuk": "Čuk"}


@dataclass
class StartupResult:
    """One converter's run, its averaged model and the steady-state comparison."""

    topology: str
    params: dict
    t: np.ndarray
    states: tuple[str, ...]
    x: np.ndarray  # simulated (N, n)
    xbar: np.ndarray  # period average of x (N, n), NaN in the first period
    xavg: np.ndarray  # averaged model (N, n)
    xre: np.ndarray  # averaged model restarted after the last DCM period (NaN before)
    t_restart: float
    model: AveragedModel
    dcm_periods: list[int]
    summary: list[dict] = field(default_factory=list)
    seconds: float = 0.0

    def dcm_spans(self) -> list[tuple[int, int]]:
        """Runs of DCM periods as [first, last + 1) period indices."""
        return _spans(self.dcm_periods)


def _period_average(t: np.ndarray, y: np.ndarray, h: float) -> np.ndarray:
    """Average of y over the switching period centred on every sample (NaN near the ends).

    The run's grid has extra points at the gate edges, so y is first put on a uniform grid
    of step h (linear interpolation, exact for the piecewise-linear currents), then averaged
    with a cumulative trapezoid over exactly T/h steps. Centring the window makes the
    average comparable with the averaged model at the same instant (a trailing window lags
    by T/2).
    """
    n = int(round(T / h))
    tu = np.arange(0.0, t[-1] + 0.5 * h, h)
    yu = np.interp(tu, t, y)
    c = np.concatenate([[0.0], np.cumsum(0.5 * (yu[1:] + yu[:-1]) * h)])
    avg = np.full(tu.size, np.nan)
    avg[n:] = (c[n:] - c[:-n]) / T
    # the window [t - T, t] is centred on t - T/2
    return np.interp(t, tu - T / 2, avg, left=np.nan, right=np.nan)


def run(topology: str, fast: bool = False) -> StartupResult:
    """Simulate one converter's start-up and compare with its averaged model."""
    t0 = time.perf_counter()
    p = DESIGNS[topology]
    h = T / (40 if fast else 100)
    res = simulate_circuit(F.circuit(topology, **p, tstop=TSTOP), step=h).raise_if_error()
    comps = {k: v for k, v in p.items() if k != "fs"}
    model = averaged_model(topology, **comps)
    states = model.states
    x = np.column_stack([res[s] for s in states])
    xbar = np.column_stack([_period_average(res.t, x[:, k], h) for k in range(len(states))])
    xavg = model.response(res.t)
    # periods in which some inductor current reaches zero (the diode blocks: DCM)
    k = np.minimum((res.t / T).astype(int), int(round(TSTOP / T)) - 1)
    currents = [j for j, s in enumerate(states) if s.startswith("i(")]
    if topology == "cuk":
        # the Čuk diode current is i(L1) - i(L2): DCM when it reaches zero
        diode = x[:, 0] - x[:, 2]
    else:
        diode = x[:, currents[0]]
    per_min = np.full(k.max() + 1, np.inf)
    np.minimum.at(per_min, k, np.abs(diode))
    dcm = [int(j) for j in np.flatnonzero(per_min <= 1e-9 * np.abs(diode).max())]
    # Once the converter is back in CCM for good, the averaged model started from the
    # simulated period average must follow the period average again.
    t_restart = ((dcm[-1] + 2) if dcm else 1) * T
    i_r = int(np.searchsorted(res.t, t_restart))
    xre = np.full_like(x, np.nan)
    xre[i_r:] = model.response(res.t[i_r:] - res.t[i_r], xbar[i_r])
    out = StartupResult(topology, p, res.t, states, x, xbar, xavg, xre, res.t[i_r], model,
                        dcm)
    out.summary = _steady_state(out)
    out.seconds = time.perf_counter() - t0
    return out


def _last_period(r: StartupResult, j: int) -> tuple[np.ndarray, np.ndarray]:
    sel = r.t >= r.t[-1] - T - 1e-12
    return r.t[sel], r.x[sel, j]


def _steady_state(r: StartupResult) -> list[dict]:
    """Mean and peak-to-peak ripple of every state over the last period against the
    averaged model's equilibrium and the ripple formulas."""
    xe = r.model.equilibrium()
    rp = ripple(r.topology, **r.params)
    rows = []
    for j, s in enumerate(r.states):
        t, y = _last_period(r, j)
        mean = float(np.trapezoid(y, t) / (t[-1] - t[0]))
        rows.append({"converter": r.topology, "quantity": f"mean {s}", "simulated": mean,
                     "predicted": float(xe[j]), "rel_error": mean / xe[j] - 1,
                     "reference": "averaged-model equilibrium"})
        pp = float(np.ptp(y))
        rows.append({"converter": r.topology, "quantity": f"ripple {s} (p-p)", "simulated": pp,
                     "predicted": rp[s], "rel_error": pp / rp[s] - 1,
                     "reference": "ripple formula (Erickson ch. 2)"})
    # after the last DCM period: period average against the restarted averaged model
    sel = (r.t >= r.t_restart) & np.all(np.isfinite(r.xbar), axis=1)
    for j, s in enumerate(r.states):
        scale = abs(xe[j])
        dev = float(np.max(np.abs(r.xbar[sel, j] - r.xre[sel, j])) / scale)
        rows.append({"converter": r.topology, "quantity": f"max |period average - averaged "
                     f"model| of {s} after the DCM periods / |steady state|",
                     "simulated": dev, "predicted": 0.0, "rel_error": dev,
                     "reference": "averaged model restarted from the simulated average"})
    out = "v(C2)" if r.topology == "cuk" else "v(C1)"
    vout = rows[2 * r.states.index(out)]["simulated"]
    M = conversion_ratio(r.topology, r.params["duty"])
    rows.append({"converter": r.topology, "quantity": "conversion ratio v(out)/vin",
                 "simulated": vout / r.params["vin"], "predicted": M,
                 "rel_error": vout / r.params["vin"] / M - 1,
                 "reference": "M(D) in CCM"})
    return rows


# -- output ----------------------------------------------------------------------------------


def plot(r: StartupResult, path: Path) -> None:
    """Start-up (voltages, currents) and steady-state zooms with the ripple bands."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ms = 1e3
    volts = [j for j, s in enumerate(r.states) if s.startswith("v(")]
    amps = [j for j, s in enumerate(r.states) if s.startswith("i(")]
    colors = {0: "tab:blue", 1: "tab:red", 2: "tab:green", 3: "tab:purple"}
    fig, axes = plt.subplots(2, 2, figsize=(13, 7.5), layout="constrained",
                             gridspec_kw={"width_ratios": [1.6, 1]})
    xe = r.model.equilibrium()
    rp = ripple(r.topology, **r.params)
    for row, group, unit in ((0, volts, "V"), (1, amps, "A")):
        ax = axes[row, 0]
        for n, j in enumerate(r.dcm_spans()):
            ax.axvspan(j[0] * T * ms, j[1] * T * ms, color="0.85", lw=0,
                       label="DCM in the period" if n == 0 else None)
        for j in group:
            c = colors[j]
            tb, lo, hi = _envelope(r.t, r.x[:, j], 1500)
            ax.fill_between(tb * ms, lo, hi, color=c, alpha=0.3, lw=0)
            step = max(1, r.t.size // 3000)  # smooth curves: 3000 points are plenty
            ax.plot(r.t[::step] * ms, r.xbar[::step, j], color=c, lw=1.4,
                    label=f"{r.states[j]}: simulated, period average")
            ax.plot(r.t[::step] * ms, r.xavg[::step, j], color="k", lw=1.1, ls="--",
                    label="averaged CCM model from zero" if j == group[0] else None)
            ax.plot(r.t[::step] * ms, r.xre[::step, j], color="tab:orange", lw=1.1, ls="-.",
                    label="averaged CCM model restarted after the DCM periods"
                    if j == group[0] else None)
        ax.axhline(0, color="0.5", lw=0.6)
        ax.set_ylabel(f"[{unit}]")
        ax.set_title(("capacitor voltages" if unit == "V" else "inductor currents")
                     + " during start-up (shaded: switching ripple envelope)")
        ax.grid(alpha=0.3)
        # the legend goes where the settled curves are not: below positive ones, above
        # negative ones, between mixed ones
        final = [xe[j] for j in group]
        loc = ("lower right" if min(final) > 0 else "upper right" if max(final) < 0
               else "center right")
        ax.legend(fontsize=8, loc=loc)
        # zoom on the last three periods, on the state that matters most in the group
        j = group[-1] if unit == "V" else group[0]
        z = axes[row, 1]
        sel = r.t >= r.t[-1] - 3 * T - 1e-12
        tz = (r.t[sel] - r.t[sel][0]) * 1e6
        z.plot(tz, r.x[sel, j], color=colors[j], lw=1.3, label=f"{r.states[j]} simulated")
        z.axhline(xe[j], color="k", ls="--", lw=1, label="averaged steady state")
        # the band is centred on the simulated mean: it shows the ripple amplitude, the
        # mean itself is compared with the dashed line
        tl, yl = r.t[sel], r.x[sel, j]
        mean = np.trapezoid(yl, tl) / (tl[-1] - tl[0])
        for sgn in (-1, 1):
            z.axhline(mean + sgn * rp[r.states[j]] / 2, color="tab:orange", ls=":", lw=1.5,
                      label="simulated mean ± Δ/2 (ripple formula)" if sgn == 1 else None)
        z.set_title(f"steady state, last 3 periods: Δ{r.states[j]} = "
                    f"{np.ptp(r.x[r.t >= r.t[-1] - T - 1e-12, j]):.4g} {unit} "
                    f"(formula {rp[r.states[j]]:.4g})", fontsize=9)
        z.set_ylabel(f"{r.states[j]} [{unit}]")
        z.grid(alpha=0.3)
        # room below the waveform for the legend
        lo, hi = min(yl.min(), mean - rp[r.states[j]] / 2), max(yl.max(), xe[j])
        z.set_ylim(lo - 0.75 * (hi - lo), hi + 0.1 * (hi - lo))
        z.legend(fontsize=8, loc="lower center", ncol=1)
    axes[1, 0].set_xlabel("t [ms]")
    axes[1, 1].set_xlabel("t - (t_end - 3T) [µs]")
    p = r.params
    comps = ", ".join(_component(k, v) for k, v in p.items() if k not in ("vin", "duty", "fs"))
    M = conversion_ratio(r.topology, p["duty"])
    fig.suptitle(f"{TITLES[r.topology]} converter, open-loop start-up: vin = {p['vin']:g} V, "
                 f"D = {p['duty']:g}, fs = {p['fs'] / 1e3:g} kHz, {comps} "
                 f"(M(D) = {M:.4g})", fontsize=11)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _envelope(t: np.ndarray, y: np.ndarray, bins: int):
    """Bin centres, minima and maxima of y over ``bins`` equal time bins."""
    k = np.minimum((t / t[-1] * bins).astype(int), bins - 1)
    lo = np.full(bins, np.inf)
    hi = np.full(bins, -np.inf)
    np.minimum.at(lo, k, y)
    np.maximum.at(hi, k, y)
    ok = np.isfinite(lo)
    centres = (np.arange(bins) + 0.5) * t[-1] / bins
    return centres[ok], lo[ok], hi[ok]


def _component(name: str, value: float) -> str:
    """``lind=1e-4`` -> ``L = 100 µH`` for titles."""
    label = {"lind": "L", "cout": "C", "rload": "R", "l1": "L1", "l2": "L2", "c1": "C1",
             "c2": "C2"}.get(name, name)
    unit = {"L": "H", "C": "F", "R": "Ω"}[label[0]]
    for scale, prefix in ((1.0, ""), (1e-3, "m"), (1e-6, "µ"), (1e-9, "n")):
        if abs(value) >= scale * 0.999:
            return f"{label} = {value / scale:g} {prefix}{unit}"
    return f"{label} = {value:g} {unit}"


def _spans(periods: list[int]) -> list[tuple[int, int]]:
    """Consecutive period indices merged into [first, last + 1) spans."""
    spans: list[tuple[int, int]] = []
    for j in periods:
        if spans and spans[-1][1] == j:
            spans[-1] = (spans[-1][0], j + 1)
        else:
            spans.append((j, j + 1))
    return spans


def write_csv(r: StartupResult, path: Path, every: int) -> None:
    header = ["t [s]", *r.states, *(f"averaged {s}" for s in r.states)]
    data = np.column_stack([r.t, r.x, r.xavg])[::every]
    np.savetxt(path, data, delimiter=",", header=",".join(header), comments="", fmt="%.9g")


def main(argv: list[str] | None = None) -> dict[str, StartupResult]:
    """Run the four converters; returns the results by topology."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default=f"out/{NAME}", help="output directory (default %(default)s)")
    p.add_argument("--fast", action="store_true", help="coarser step (h = T/40)")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results = {}
    rows = []
    for topology in DESIGNS:
        r = run(topology, args.fast)
        results[topology] = r
        key = topology.replace("-", "_")
        plot(r, out / f"open_loop_{key}.png")
        write_csv(r, out / f"open_loop_{key}.csv", every=10)
        rows += r.summary
        ratio = r.summary[-1]
        print(f"{topology}: M = {ratio['simulated']:.6g} (M(D) = {ratio['predicted']:.6g}, "
              f"{ratio['rel_error']:+.1e}); {len(r.dcm_periods)} start-up periods in DCM; "
              f"{r.seconds:.2f} s")
    with open(out / "open_loop_summary.csv", "w", newline="") as fh:
        wr = csv.DictWriter(fh, fieldnames=list(rows[0]))
        wr.writeheader()
        for row in rows:
            wr.writerow({k: (f"{v:.9g}" if isinstance(v, float) else v) for k, v in row.items()})
    return results


if __name__ == "__main__":
    main()
