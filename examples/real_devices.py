"""Netlists with real devices: PySpice's buck example, its vendor MOSFET and Schottky models
idealised by pelcs, against ngspice with the real models.

PySpice's ``examples/switched-power-supplies/buck-converter.py`` (12 V -> 5 V, 2 A, 400 kHz,
the irf150 MOSFET macro-model and the 1N5822 Schottky macro-model) is built with the PySpice
API (``converters.pyspice_examples.pyspice_buck``) and simulated three ways over 1 ms:

- pelcs with ideal devices (the irf150 becomes one ideal switch at VTO = 4.08 V with its body
  diode, the 1N5822 one ideal diode);
- pelcs with piecewise-linear devices (``--devices pwl``: the diode's Vf and Ron fitted to its
  two parallel junctions, the switch's channel and series resistances, and its gate as a
  linear RC: the macro's 12.1 Ω gate resistor, its gate-source and gate-drain capacitances);
- ngspice with the vendor models as written.

Prints the idealisation report, the steady-state output and efficiency of each, and writes
``real_devices_buck.png`` (v(out) and i(L1) over the last periods, the three runs). The pwl
model takes the conduction drops into account, and the gate RC the turn-off delay of the
macro's gate network (about 70 ns, as in ngspice); while the MOSFET follows its gate through
its linear region pelcs slides on the gate RC, and its efficiency is then not computed
(``LossReport.caveat`` says why).

Run ``python examples/real_devices.py [--out DIR] [--fast]`` (needs PySpice and ngspice;
``--fast``: 0.6 ms instead of 1 ms).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

NAME = "real_devices"
PERIOD = 2.5e-6
R_LOAD = 5 / (0.8 * 2)


def _mean(t, y, a):
    w = t >= a
    return float(np.trapezoid(y[w], t[w]) / (t[w][-1] - t[w][0]))


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=str(ROOT / "docs" / "gallery"))
    ap.add_argument("--fast", action="store_true")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import pelcs
    from converters.pyspice_examples import pyspice_buck
    from lcs.notices import IdealisedDeviceWarning
    from netlist.studies.realistic import simulate_devices
    from netlist.writer import write_circuit
    from ngspice_checks.runner import run_ngspice

    tstop = 0.6e-3 if args.fast else 1e-3
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        circuit = pelcs.load(pyspice_buck())
    print("idealisation report (pelcs info):")
    for r in circuit.replacements:
        print("  " + r.line())
    runs, caveats = {}, {}
    for dev in ("ideal", "pwl"):
        res = simulate_devices(circuit, devices=dev, losses=True, probes=["v(out)", "i(L1)"],
                               tstop=tstop, step=10e-9)
        runs[dev] = (res.t, res["v(out)"], res["i(L1)"], res.losses.efficiency)
        caveats[dev] = res.losses.caveat
        for f in res.device_fits:
            print(f"  pwl: {f.line()}")
    ng = run_ngspice(write_circuit(circuit), ["v(out)", "i(L1)", "v(in)", "i(Vin)"],
                     tstop=tstop, tstep=10e-9, timeout=600)
    t = ng.time
    a = tstop - 10 * PERIOD
    p_out = _mean(t, ng["v(out)"] ** 2 / R_LOAD, a)
    p_in = _mean(t, -ng["v(in)"] * ng["i(Vin)"], a)
    runs["ngspice"] = (t, ng["v(out)"], ng["i(L1)"], p_out / p_in)

    summary = {}
    print(f"steady state over the last 10 periods (from {a * 1e3:.3f} ms):")
    for name, (tt, v, _, eff) in runs.items():
        summary[name] = {"vout": _mean(tt, v, a), "efficiency": eff}
        print(f"  {name:8s} mean v(out) = {summary[name]['vout']:.4f} V, efficiency "
              + (f"{100 * eff:.2f} %" if eff == eff else f"n/a ({caveats[name]})"))

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    colors = {"ideal": "tab:blue", "pwl": "tab:green", "ngspice": "tab:red"}
    labels = {"ideal": "pelcs, ideal devices", "pwl": "pelcs, --devices pwl",
              "ngspice": "ngspice, vendor models"}
    for name, (tt, v, i, _) in runs.items():
        w = tt >= tstop - 4 * PERIOD
        ax1.plot(tt[w] * 1e6, v[w], color=colors[name], label=labels[name])
        ax2.plot(tt[w] * 1e6, i[w], color=colors[name], label=labels[name])
    ax1.set_ylabel("v(out) [V]")
    ax2.set_ylabel("i(L1) [A]")
    ax2.set_xlabel("time [µs]")
    ax1.legend(loc="best", fontsize=8)
    ax1.set_title("PySpice's buck (irf150, 1N5822): pelcs ideal and pwl vs ngspice")
    fig.tight_layout()
    fig.savefig(out / "real_devices_buck.png", dpi=110)
    plt.close(fig)
    print(f"wrote {out / 'real_devices_buck.png'}")
    return summary


if __name__ == "__main__":
    main()
