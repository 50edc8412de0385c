"""Voltage-mode controlled buck (Deane-Hamill chaos benchmark): time responses at E = 15 V
and E = 25 V.

The converter of ``converters/netlists/vm_buck.cir`` (factory
:func:`converters.factories.vm_buck`): R = 22 Ω, L = 20 mH, C = 47 µF; the switch conducts
while a 3.8 V -> 8.2 V sawtooth of period tp = 400 µs is above the control voltage
v(con) = a (v(out) - vref), a = 8.4, vref = 11.3 V. The input E is the bifurcation parameter:
the literature (Deane & Hamill 1990; di Bernardo, Garofalo, Glielmo & Vasca 1998) reports a
stable period-1 orbit at E = 15 V and a period-2 orbit at E = 25 V (period doubling near
24.5 V). Both runs start from rest and are sampled stroboscopically at t = k tp.

Independent reference: the exact periodic orbits, computed here from the two linear
sub-systems written by hand (switch on: L i' = E - v, off: L i' = -v, both C v' = i - v/R;
CCM: i(L) stays above 0.48 A on these orbits), their matrix exponentials, and the comparator
instants (the ramp crossing a (v(t) - vref) on its rise, switch on; the crossing on its 10 ns
fall, switch off) found by root bracketing on the exact solution. The periodic points are
fixed points of the exact stroboscopic map P (period 1) or of P∘P (period 2) (Newton, scipy
``fsolve``); their Floquet multipliers are the eigenvalues of the map's Jacobian (central
differences). At E = 15 V the period-1 orbit is stable; at E = 25 V it still exists but has a
real multiplier below -1 (it has flipped), and the period-2 orbit is stable. The
stroboscopic samples of the simulation must converge to these points: their distance at the
end of the run is O(h²) (the comparator instants are located inside the step).

A second, rougher reference for E = 15 V: the averaged model, v/E = d with duty
d = 1 - (a (v - vref) - vl)/(vu - vl), gives v = 11.862 V (the simulated mean is 0.2 % lower:
the comparator acts on the instantaneous, rippling v(out)).

Run ``python examples/vm_buck_responses.py [--out DIR] [--fast]``: writes
``vm_buck_responses.png``, ``vm_buck_E15.csv``, ``vm_buck_E25.csv`` (t, i(L1), v(C1)) and
``vm_buck_orbits.csv`` (periodic points and multipliers). ``--fast``: h = 2 µs and 40 ms
instead of 1 µs and 60 ms.
"""

from __future__ import annotations

import argparse
import csv
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq, fsolve

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:  # run as a script from a checkout
    sys.path.insert(0, str(ROOT))

from converters import factories as F  # noqa: E402
from netlist.studies.transient import simulate_circuit  # noqa: E402

NAME = "vm_buck_responses"
A_GAIN, VREF, VL, VU, TP, TFALL = 8.4, 11.3, 3.8, 8.2, 400e-6, 10e-9
L, C, R = 20e-3, 47e-6, 22.0
T_RISE = TP - 2 * TFALL  # the ramp rises over this, stays at vu for TFALL, falls in TFALL


# -- exact piecewise-linear reference --------------------------------------------------------


def ramp(t: float) -> float:
    """Sawtooth voltage (V) at time t within a period (0 <= t <= tp), as the PULSE source."""
    if t <= T_RISE:
        return VL + (VU - VL) * t / T_RISE
    if t <= TP - TFALL:
        return VU
    return VU - (VU - VL) * (t - (TP - TFALL)) / TFALL


class ExactBuck:
    """Exact flows of the two CCM sub-systems and the stroboscopic map at input E."""

    def __init__(self, E: float):
        self.E = E
        A = np.array([[0.0, -1 / L], [1 / C, -1 / (R * C)]])
        # x(t) = xe + V e^(Λt) V^-1 (x0 - xe), xe = -A^-1 b: closed form, checked against
        # expm below (A has distinct eigenvalues: 1/(2RC) < 1/sqrt(LC))
        self._lam, self._V = np.linalg.eig(A)
        self._Vinv = np.linalg.inv(self._V)
        self._xe = {on: -np.linalg.solve(A, np.array([E / L if on else 0.0, 0.0]))
                    for on in (False, True)}
        M = np.zeros((3, 3))
        M[:2, :2] = A
        M[0, 2] = E / L
        x0, dt = np.array([0.3, 5.0]), 123e-6
        ref = (expm(M * dt) @ np.array([*x0, 1.0]))[:2]
        assert np.allclose(self.flow(x0, dt, True), ref, rtol=1e-12, atol=1e-12)
        self._M_off = M.copy()
        self._M_off[0, 2] = 0.0

    def flow(self, x, dt: float, on: bool) -> np.ndarray:
        """State (i, v) after dt seconds in one sub-system (exact)."""
        xe = self._xe[on]
        d = self._Vinv @ (np.asarray(x, dtype=float) - xe)
        return xe + (self._V @ (np.exp(self._lam * dt) * d)).real

    def _g(self, x0, t0: float, t: float, on: bool) -> float:
        """Ramp minus control voltage at time t, flowing from (t0, x0)."""
        v = self.flow(x0, t - t0, on)[1]
        return ramp(t) - A_GAIN * (v - VREF)

    def period(self, x0) -> tuple[np.ndarray, float, float]:
        """One ramp period from x0 (switch off at t = 0): state at tp, turn-on and turn-off
        instants (s; tp if the switch stays off)."""
        x0 = np.asarray(x0, dtype=float)
        # turn-on: first sign change of ramp - a (v - vref) on the rise (off dynamics), on a
        # grid of 400 steps walked with one step matrix
        grid = np.linspace(0.0, T_RISE, 401)
        step = expm(self._M_off * (grid[1] - grid[0]))
        z = np.empty((grid.size, 3))
        z[0] = (x0[0], x0[1], 1.0)
        for k in range(1, grid.size):
            z[k] = step @ z[k - 1]
        g = (VL + (VU - VL) * grid / T_RISE) - A_GAIN * (z[:, 1] - VREF)
        if g[0] > 0:
            raise ValueError("the switch would be on at the start of the period")
        idx = np.flatnonzero(g > 0)
        if idx.size == 0:
            return self.flow(x0, TP, False), TP, TP
        k = idx[0]
        t_on = brentq(lambda t: self._g(x0, 0.0, t, False), grid[k - 1], grid[k], xtol=1e-15,
                      rtol=1e-14)
        x_on = self.flow(x0, t_on, False)
        # turn-off: the crossing on the 10 ns fall (on dynamics)
        t_off = brentq(lambda t: self._g(x_on, t_on, t, True), TP - TFALL, TP, xtol=1e-18,
                       rtol=1e-14)
        x_off = self.flow(x_on, t_off - t_on, True)
        return self.flow(x_off, TP - t_off, False), t_on, t_off

    def map(self, x0, k: int = 1) -> np.ndarray:
        x = np.asarray(x0, dtype=float)
        for _ in range(k):
            x = self.period(x)[0]
        return x

    def periodic_point(self, guess, k: int) -> np.ndarray:
        x, info, ok, msg = fsolve(lambda x: self.map(x, k) - x, guess, full_output=True,
                                  xtol=1e-13)
        if ok != 1:
            raise RuntimeError(f"no period-{k} point near {guess}: {msg}")
        return x

    def multipliers(self, x, k: int) -> np.ndarray:
        """Eigenvalues of the Jacobian of P^k at x (central differences)."""
        J = np.zeros((2, 2))
        for j, d in enumerate((1e-6, 1e-6)):
            e = np.zeros(2)
            e[j] = d
            J[:, j] = (self.map(x + e, k) - self.map(x - e, k)) / (2 * d)
        return np.linalg.eigvals(J)

    def trajectory(self, x0, periods: int, n: int = 200) -> tuple[np.ndarray, np.ndarray]:
        """Dense exact trajectory over ``periods`` ramp periods from x0 (t from 0)."""
        ts, xs = [], []
        x = np.asarray(x0, dtype=float)
        for p in range(periods):
            _, t_on, t_off = self.period(x)
            for a, b, on in ((0.0, t_on, False), (t_on, t_off, True), (t_off, TP, False)):
                if b <= a:
                    continue
                tt = np.linspace(a, b, n)
                xa = x.copy()
                for t in tt:
                    ts.append(p * TP + t)
                    xs.append(self.flow(xa, t - a, on))
                x = self.flow(xa, b - a, on)
        return np.array(ts), np.array(xs)


def averaged_vout(E: float) -> float:
    """v(out) of the averaged model: v/E = 1 - (a (v - vref) - vl)/(vu - vl)."""
    span = VU - VL
    return (span + A_GAIN * VREF + VL) / (span / E + A_GAIN)


# -- simulation ------------------------------------------------------------------------------


@dataclass
class Response:
    E: float
    t: np.ndarray
    i: np.ndarray
    v: np.ndarray
    ramp: np.ndarray
    con: np.ndarray
    strobe: np.ndarray  # (K, 2): (i, v) at t = k tp, k = 0..K-1
    orbits: dict = field(default_factory=dict)  # "P1", "P2": periodic points (k, 2)
    multipliers: dict = field(default_factory=dict)
    checks: dict = field(default_factory=dict)
    seconds: float = 0.0


def respond(E: float, fast: bool) -> Response:
    t0 = time.perf_counter()
    h, tstop = (2e-6, 40e-3) if fast else (1e-6, 60e-3)
    c = F.circuit("vm-buck", vin=E, tstop=tstop)
    res = simulate_circuit(c, step=h, probes=["i(L1)", "v(C1)", "v(ramp)", "v(con)"]
                           ).raise_if_error()
    t = res.t
    # t = k tp are grid points (the ramp's corners are breakpoints)
    kt = np.arange(int(round(t[-1] / TP)) + 1) * TP
    idx = np.searchsorted(t, kt - 1e-12)
    assert np.allclose(t[idx], kt, atol=1e-12), "ramp period instants are not on the grid"
    r = Response(E, t, res["i(L1)"], res["v(C1)"], res["v(ramp)"], res["v(con)"],
                 np.column_stack([res["i(L1)"][idx], res["v(C1)"][idx]]))
    ex = ExactBuck(E)
    last = r.strobe[-1]
    p1 = ex.periodic_point(r.strobe[-2:].mean(axis=0), 1)
    r.orbits["P1"] = p1[None, :]
    r.multipliers["P1"] = ex.multipliers(p1, 1)
    if E > 24.5:
        q = ex.periodic_point(last, 2)
        r.orbits["P2"] = np.array([q, ex.map(q, 1)])
        r.multipliers["P2"] = ex.multipliers(q, 2)
    stable = "P2" if "P2" in r.orbits else "P1"
    pts = r.orbits[stable]
    # distance of the last two strobe samples from the stable orbit's points (any phase)
    err = max(np.min(np.abs(pts - s) / np.abs(pts).max(axis=0), axis=0).max()
              for s in r.strobe[-2:])
    sel = t >= t[-1] - 10 * TP - 1e-12
    r.checks = {
        "stable orbit": stable,
        "max rel. distance of the last strobe samples from it": float(err),
        "P1 multipliers |max|": float(np.abs(r.multipliers["P1"]).max()),
        "P1 multiplier min real": float(np.min(r.multipliers["P1"].real)),
        "mean v(out) last 10 periods [V]": float(np.trapezoid(r.v[sel], t[sel])
                                                 / (t[sel][-1] - t[sel][0])),
        "averaged-model v(out) [V]": averaged_vout(E),
        "min i(L1) last 10 periods [A]": float(r.i[sel].min()),
    }
    if "P2" in r.multipliers:
        r.checks["P2 multipliers |max|"] = float(np.abs(r.multipliers["P2"]).max())
        r.checks["P2 spread v [V]"] = float(abs(pts[0, 1] - pts[1, 1]))
    r.seconds = time.perf_counter() - t0
    return r


# -- output ----------------------------------------------------------------------------------


def plot(responses: list[Response], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ms = 1e3
    fig, axes = plt.subplots(4, 2, figsize=(13, 12), layout="constrained")
    for col, r in enumerate(responses):
        ex = ExactBuck(r.E)
        stable = r.checks["stable orbit"]
        ax = axes[0, col]
        ax.plot(r.t * ms, r.v, color="tab:red", lw=0.8, label="v(out) = v(C1)")
        ax.axhline(averaged_vout(r.E), color="k", ls="--", lw=0.9,
                   label=f"averaged model {averaged_vout(r.E):.3f} V")
        ax.set_ylabel("v(out) [V]")
        ax.set_xlabel("t [ms]")
        ax.set_title(f"E = {r.E:g} V: output voltage from rest", fontsize=10)
        ax.legend(fontsize=8, loc="lower right")
        ax = axes[1, col]
        ax.plot(r.t * ms, r.i, color="tab:blue", lw=0.6, label="i(L1)")
        ax.set_ylabel("i(L1) [A]")
        ax.set_xlabel("t [ms]")
        ax.set_title("inductor current", fontsize=10)
        ax.legend(fontsize=8, loc="lower right")
        # zoom: last 4 ramp periods, with the exact orbit started from its periodic point
        # in the matching phase
        ax = axes[2, col]
        n = 4
        t_end = r.t[-1]
        k0 = int(round(t_end / TP)) - n
        sel = r.t >= k0 * TP - 1e-12
        tz = (r.t[sel] - k0 * TP) * 1e6
        ax.plot(tz, r.ramp[sel], color="0.5", lw=1, label="ramp v(ramp)")
        ax.plot(tz, r.con[sel], color="tab:orange", lw=1.3, label="control v(con)")
        ax.set_ylabel("[V]")
        ax.set_xlabel(f"t - {k0 * TP * ms:g} ms [µs]")
        ax.set_ylim(3, 12)
        ax2 = ax.twinx()
        ax2.plot(tz, r.i[sel], color="tab:blue", lw=1.5, label="i(L1) simulated")
        pts = r.orbits[stable]
        start = r.strobe[k0]
        j = int(np.argmin(np.abs(pts - start).sum(axis=1)))
        te, xe_ = ex.trajectory(pts[j], n, 60)
        ax2.plot(te * 1e6, xe_[:, 0], color="k", lw=1, ls="--",
                 label=f"exact {stable} orbit")
        ax2.set_ylabel("i(L1) [A]", color="tab:blue")
        lo, hi = r.i[sel].min(), r.i[sel].max()
        ax2.set_ylim(lo - 0.05 * (hi - lo), hi + 0.45 * (hi - lo))  # room for the legend
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left", ncol=2)
        ax.set_title("last 4 ramp periods: the switch is on while the ramp is above v(con)",
                     fontsize=10)
        # stroboscopic samples
        ax = axes[3, col]
        k = np.arange(r.strobe.shape[0])
        ax.plot(k, r.strobe[:, 1], ".", color="tab:red", ms=3, label="v(out) at t = k tp")
        for name, pts in r.orbits.items():
            ls = "--" if name == stable else (0, (1, 1))
            what = "stable" if name == stable else "unstable"
            for m, p in enumerate(pts):
                ax.axhline(p[1], color="k" if name == stable else "tab:green", ls=ls,
                           lw=1 if name == stable else 2,
                           label=f"exact {name} point(s), {what} (|μ|max = "
                                 f"{np.abs(r.multipliers[name]).max():.3g})" if m == 0
                           else None)
        vv = r.strobe[k > k.size // 3, 1]
        pad = max(0.05, 0.3 * np.ptp(vv))
        ax.set_ylim(vv.min() - pad, vv.max() + pad)
        ax.set_xlabel("ramp period k")
        ax.set_ylabel("v(out)(k tp) [V]")
        mu = ", ".join(f"{m:.3f}" for m in r.multipliers["P1"])
        ax.set_title(f"stroboscopic samples converge to the {stable} orbit "
                     f"(P1 multipliers {mu})", fontsize=10)
        ax.legend(fontsize=8, loc="upper right")
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
    fig.suptitle("Voltage-mode controlled buck (R = 22 Ω, L = 20 mH, C = 47 µF, a = 8.4, "
                 "vref = 11.3 V, ramp 3.8-8.2 V, tp = 400 µs)", fontsize=11)
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> dict[float, Response]:
    """Run E = 15 V and E = 25 V; returns the responses by E."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default=f"out/{NAME}", help="output directory (default %(default)s)")
    p.add_argument("--fast", action="store_true", help="h = 2 µs, 40 ms")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    responses = {E: respond(E, args.fast) for E in (15.0, 25.0)}
    plot(list(responses.values()), out / f"{NAME}.png")
    rows = []
    for E, r in responses.items():
        every = max(1, r.t.size // 20000)
        np.savetxt(out / f"vm_buck_E{E:g}.csv",
                   np.column_stack([r.t, r.i, r.v])[::every], delimiter=",", comments="",
                   header="t [s],i(L1) [A],v(C1) [V]", fmt="%.9g")
        for name, pts in r.orbits.items():
            mu = r.multipliers[name]
            for k, pt in enumerate(pts):
                rows.append([E, name, k, f"{pt[0]:.10g}", f"{pt[1]:.10g}",
                             f"{mu[0]:.6g}", f"{mu[1]:.6g}"])
        print(f"E = {E:g} V: " + ", ".join(
            f"{k} = {v:.4g}" if isinstance(v, float) else f"{k} = {v}"
            for k, v in r.checks.items()) + f"  ({r.seconds:.2f} s)")
    with open(out / "vm_buck_orbits.csv", "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(["E [V]", "orbit", "point", "i(L1) [A]", "v(C1) [V]", "multiplier 1",
                     "multiplier 2"])
        wr.writerows(rows)
    return responses


if __name__ == "__main__":
    main()
