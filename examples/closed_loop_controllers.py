"""Python controllers driving netlist switches (lcs.controllers), without editing the netlists.

1. Digital PI voltage loop on the bundled buck (``converters/netlists/buck.cir``, 24 V, 50 kHz):
   the output is sampled at every period start, ``d = d0 + kp e + I`` sets that period's duty;
   the integral finds the lossless duty v/Vin. The netlist's own PULSE gate is ignored.
2. Open-loop complementary PWM with dead time on a synchronous buck
   (``tests/netlists/closed_loop/sync_buck.cir``): the body diode of the low-side switch
   carries the inductor current during the dead times.
3. Sliding-mode current control of the boost from surface coefficients,
   ``s = i(L1) - 2 A`` (on while s < 0), equal to the surface built with controlled sources in
   ``tests/netlists/closed_loop/boost_smc.cir``.

Run ``python examples/closed_loop_controllers.py [--out DIR] [--fast]``: writes
``closed_loop_controllers.png`` (the three output voltages) into DIR (default
``out/closed_loop_controllers``). The whole study takes about 2 s, so ``--fast`` (taken
as by every example) changes nothing: shorter runs would stop the synchronous buck before it
settles (17.3 V instead of 9.7 V at a quarter of its 1 ms). ``--plot FILE.png`` writes the
figure to FILE instead.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from lcs.controllers import PIPWM, OpenLoopPWM, SlidingSurface  # noqa: E402
from lcs.integrators.moreau.integrator import simulate  # noqa: E402
from netlist.parser import parse_file  # noqa: E402
from netlist.studies.transient import transient_setup  # noqa: E402

CL = ROOT / "tests" / "netlists" / "closed_loop"


NAME = "closed_loop_controllers"


def pi_buck(t_stop: float = 20e-3):
    s = transient_setup(parse_file(ROOT / "converters" / "netlists" / "buck.cir"))
    pi = PIPWM("S1", "v(out)", reference=10.0, kp=0.02, ki=20.0, frequency=50e3, d0=0.4)
    res = simulate(s.system, s.signals, s.x0, t_stop, 0.2e-6, probes=["v(out)", "i(L1)"],
                   controllers=[pi], every=5).raise_if_error()
    t, y, d = np.array(pi.history).T
    print(f"PI buck: v(out) = {res['v(out)'][-1]:.4f} V at {t_stop * 1e3:g} ms (reference "
          "10 V), duty "
          f"{d[-1]:.4f} (v/Vin = {10 / 24:.4f}), {len(t)} samples, "
          f"{res.stats.wall_time * 1e3:.0f} ms")
    return res


def sync_buck(t_stop: float = 1e-3):
    s = transient_setup(parse_file(CL / "sync_buck.cir"))
    pwm = OpenLoopPWM("S1", 100e3, 0.42, complement="S2", dead_time=200e-9)
    res = simulate(s.system, s.signals, s.x0, t_stop, 20e-9,
                   probes=["v(out)", "i(L1)", "i(D2)"], controllers=[pwm]).raise_if_error()
    late = res.t > 0.9 * t_stop
    diode = np.trapezoid(res["i(D2)"][late], res.t[late]) / np.trapezoid(
        np.abs(res["i(L1)"][late]), res.t[late])
    print(f"sync buck: v(out) = {res['v(out)'][late].mean():.3f} V (duty x Vin = "
          f"{0.42 * 24:.3f} V), body diode carries {100 * diode:.1f} % of the inductor "
          "charge (the dead times)")
    return res


def smc_boost(t_stop: float = 20e-3):
    s = transient_setup(parse_file(CL / "boost_smc.cir"))
    probes = ["i(L1)", "v(out)", "d(S1)"]
    ctl = simulate(s.system, s.signals, s.x0, t_stop, 1e-6, probes=probes,
                   controllers=[SlidingSurface("S1", {"i(L1)": 1.0}, offset=-2.0)])
    net = simulate(s.system, s.signals, s.x0, t_stop, 1e-6, probes=probes)
    d = ctl["d(S1)"][-1]
    v = ctl["v(out)"][-1]
    print(f"SMC boost: sliding {ctl.sliding}, v(out) = {v:.3f} V (sqrt(R E Iref) = "
          f"{np.sqrt(50 * 12 * 2):.3f}), duty {d:.4f} (1 - E/v = {1 - 12 / v:.4f}); "
          f"max difference to the netlist surface {np.abs(ctl.y - net.y).max():.1e}")
    return ctl


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("out") / NAME,
                    help="output directory (default %(default)s)")
    ap.add_argument("--fast", action="store_true",
                    help="the same runs (the study takes about 2 s)")
    ap.add_argument("--plot", type=Path, help="write the figure to this file instead")
    args = ap.parse_args(argv)
    runs = [pi_buck(), sync_buck(), smc_boost()]
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8, 8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(3, 1)
    titles = ("PI buck (reference 10 V)", "synchronous buck, dead time 200 ns",
              "sliding-mode boost (i(L1) = 2 A)")
    for ax, res, title in zip(axes, runs, titles, strict=True):
        ax.plot(res.t * 1e3, res["v(out)"], lw=0.8, label="v(out)")
        ax.set_title(title)
        ax.set_xlabel("time (ms)")
        ax.set_ylabel("v(out) (V)")
        ax.legend(fontsize=8, loc="lower right")
    path = args.plot or args.out / f"{NAME}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
