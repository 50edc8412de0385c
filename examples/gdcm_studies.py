"""Generalized discontinuous conduction modes (GDCM) of the boost and Čuk converters.

Three single-mode runs (the switch's gate is a DC source, so the switch never changes state)
show the three ways a GDCM can behave. For each, the GDCM region of the diode D1 comes from
:func:`lcs.theory.gdcm.gdcm_conditions` on the LCS of that switch mode: ``y = w(D1)`` (a linear
function of the state) must be zero and ``Γ`` (the λ that holds y at zero, also a linear
function of the state and input) must be positive. The simulated w(t), λ(t) go through
:func:`lcs.theory.gdcm.detect_gdcm_intervals`, and the figure shows the trajectory in the (y, Γ)
plane with the region {y = 0, Γ > 0} marked, λ(t) (with Γ(t) on top: inside the region the
simulated λ must equal Γ) and w(t).

1. Boost, switch open: finite GDCM, no re-entry
-----------------------------------------------
Vin = 12 V, L = 1 mH, C = 100 µF, R = 10 Ω; start at i(L) = 0, v(C) = 24 V (e.g. a DCM boost
at the instant its inductor current reaches zero, when the gate stops). With S1 open the
diode's pair is ``w = i(L1)`` (the diode current), ``λ`` = its reverse voltage, and the
region is ``i(L1) = 0``, ``Γ = v(C1) - Vin > 0``. In it, L1 carries nothing and C1
discharges through R alone: ``v(C1) = 24 e^(-t/RC)`` until it reaches Vin at
``t_exit = R C ln(24/12) = 0.693 ms``; then Γ < 0 and the diode conducts. From then on the
circuit is Vin - L - C||R, with equilibrium (Vin/R, Vin). At the exit the deviation from it
is (-Vin/R, 0), with stored "deviation energy" ½ L (Vin/R)². That energy decreases strictly
(dissipation δv²/R, zero only at the equilibrium), and a re-entry needs i(L1) = 0, i.e.
δi = -Vin/R, i.e. at least the same energy: impossible. One finite interval, no re-entry
(the ring decays at 1/(2RC) = 500 1/s with ω0 = 1/sqrt(LC) = 3.2 krad/s, its first minimum
of i(L1) stays near 0.76 A).

2. Čuk, switch closed: finite and re-entrant
--------------------------------------------
Bundled Čuk values (L1 = L2 = 500 µH, C1 = 10 µF, C2 = 100 µF, R = 20 Ω), starting from the
12 V -> -12 V operating point (i(L1) = 0.6 A, v(C1) = 24 V, i(L2) = -0.6 A, v(C2) = -12 V)
with the gate stuck on. Node a is grounded: L1 only charges from Vin (it is decoupled) and
D1 (anode b, cathode ground = a) sits across C1: ``w = v(C1)`` (the reverse voltage),
``λ = i(D1)``, region ``v(C1) = 0``, ``Γ = -i(L2) > 0``. C1 first discharges into L2 and
the load; when v(C1) reaches zero with i(L2) < 0, D1 clamps it (entry). In the region, b is
grounded and L2 - C2||R rings freely (ω = 1/sqrt(L2 C2) = 4.5 krad/s, decay 250 1/s):
i(L2) rises through zero, Γ = -i(L2) < 0, the diode releases C1 (finite interval). Outside,
the loop C1 - L2 - C2||R is an underdamped oscillation whose only equilibrium is
i(L2) = v(C1) = v(C2) = 0, on the region's boundary: v(C1) swings back to zero with
i(L2) < 0 and the diode clamps it again (re-entry). The result is a sequence of short
intervals, one per ring period of the loop (about 0.43 ms), with decaying λ.

3. Čuk, switch open: a GDCM that lasts indefinitely
---------------------------------------------------
L1 = L2 = 500 µH, C1 = 100 µF, C2 = 10 µF, R = 20 Ω, starting from this converter's
operating point (as above: 0.6 A, 24 V, -0.6 A, -12 V) with the gate stuck off. With S1
open, node a connects only L1 and C1, so ``w = i(D1) = i(L1) - i(L2)`` and ``λ`` is the
reverse voltage: region ``i(L1) = i(L2)``, ``Γ = (L2 (v(C1) - Vin) - L1 v(C2))/(L1 + L2)``.
The diode current falls at (v(C1) - Vin)/L1 - v(C2)/L2 = 48 A/ms and reaches zero after
25 µs: entry with Γ ≈ 12 V. In the region both inductors carry one current around the loop
Vin - L1 - C1 - L2 - C2||R. With C1 ≫ C2 that loop has a fast, well damped mode (L1 + L2
against C2 with R across it: Q = R sqrt(C2/(L1+L2)) = 2) and a slow real mode, C1 draining
its excess v(C1) - Vin through the loop and R (about -1/(R C1) = -500 1/s). On the slow mode
C2 and the inductors follow quasi-statically (v(C2) ≈ -(v(C1) - Vin), i ≈ v(C2)/R), so
``Γ ≈ v(C1) - Vin > 0`` decays exponentially without changing sign: the trajectory
approaches the equilibrium (v(C1) = Vin, everything else zero), which lies on the region's
boundary Γ = 0, only as t -> ∞, and never leaves. The script checks this beyond the end of
the run: from the final state, Γ(t) = Γ_eq + Σ c_k e^(s_k t) over the modes of the reduced
dynamics; it verifies that the slowest mode is real with c > 0 and that Γ(t) > 0 on a fine
grid until that mode dominates all others by 1e6. (With the bundled values, C1 ≪ C2, the
slow mode is the lightly damped L - C1 ring instead, Γ oscillates about zero and the GDCM is
left and re-entered every half period.)

Run ``python examples/gdcm_studies.py [--out DIR] [--fast]``: one PNG and one CSV per case
(``gdcm_<case>.png``, ``gdcm_<case>.csv`` with t, states, w, λ, y, Γ) and
``gdcm_intervals.csv`` (the detected intervals); ``--fast`` uses a 4x coarser step and
shorter runs (same behaviour).
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
from lcs.theory.gdcm import GdcmCondition, GdcmInterval, detect_gdcm_intervals, gdcm_condition  # noqa: E402
from netlist.formulation import formulate  # noqa: E402
from netlist.studies.transient import simulate_circuit  # noqa: E402

NAME = "gdcm_studies"


@dataclass
class Case:
    """One GDCM study: a single-mode netlist and what it should show."""

    key: str
    title: str
    text: str
    on: bool  # switch state of the run
    step: float  # s
    expect: str  # "finite-once", "reentrant", "indefinite"


@dataclass
class CaseResult:
    """Simulated signals of one case and the detected GDCM intervals."""

    case: Case
    t: np.ndarray
    states: tuple[str, ...]
    x: np.ndarray  # (N, n)
    w: np.ndarray
    lam: np.ndarray
    y: np.ndarray
    gamma: np.ndarray
    cond: GdcmCondition
    intervals: list[GdcmInterval]
    w_label: str
    lam_label: str
    checks: dict[str, float | bool] = field(default_factory=dict)
    seconds: float = 0.0


def cases(fast: bool = False) -> list[Case]:
    """The three studies (``fast``: 4x coarser step, shorter runs)."""
    k = 4 if fast else 1
    vin, duty, R = 12.0, 0.5, 20.0
    V = vin * duty / (1 - duty)
    I = V / R  # noqa: E741 - load current magnitude
    cuk_op = dict(il1=I * duty / (1 - duty), vc1=vin + V, il2=-I, vc2=-V)
    return [
        Case("boost_switch_open", "Boost, switch open: finite GDCM without re-entry",
             F.boost(vin=12, lind=1e-3, cout=100e-6, rload=10, il0=0.0, vc0=24.0,
                     gate="off", tstop=4e-3 if fast else 8e-3),
             on=False, step=0.2e-6 * k, expect="finite-once"),
        Case("cuk_switch_closed", "Čuk, switch closed: finite, re-entrant GDCM",
             F.cuk(vin=vin, rload=R, **cuk_op, gate="on", tstop=2e-3 if fast else 4e-3),
             on=True, step=0.2e-6 * k, expect="reentrant"),
        Case("cuk_switch_open", "Čuk, switch open: GDCM that lasts indefinitely",
             F.cuk(vin=vin, l1=500e-6, l2=500e-6, c1=100e-6, c2=10e-6, rload=R, **cuk_op,
                   gate="off", tstop=5e-3 if fast else 10e-3),
             on=False, step=0.2e-6 * k, expect="indefinite"),
    ]


def _form_values(form, X: np.ndarray, U: np.ndarray) -> np.ndarray:
    """A LinearForm evaluated along a trajectory (rows of X and U)."""
    return X @ form.cx + (U @ form.cu if form.cu.size else 0.0)


def run_case(case: Case) -> CaseResult:
    """Simulate one case, evaluate y and Γ along it and detect the GDCM intervals."""
    t0 = time.perf_counter()
    from netlist.parser import parse_string

    circuit = parse_string(case.text, file=f"<{case.key}>")
    system = formulate(circuit)
    lcs = system.mode((case.on,))
    pair = lcs.pairs[0]
    diode = circuit.element(pair.name)
    anode, cathode = diode.nodes[0], diode.nodes[1]
    i_probe, v_probe = f"i({pair.name})", f"v({cathode},{anode})"  # current, reverse voltage
    probes = list(system.states) + [i_probe, v_probe]
    res = simulate_circuit(circuit, step=case.step, probes=probes).raise_if_error()
    assert all(mode == (case.on,) for mode in res.modes_visited), "the run left its mode"
    X = np.column_stack([res[s] for s in system.states])
    # Inputs are DC (Vin, and the gate held at 0 or 1 V): constant along the run.
    u = np.array([circuit.element(name).dc for name in system.inputs])
    U = np.tile(u, (res.t.size, 1))
    if pair.lam == "current":
        lam, w = res[i_probe], res[v_probe]
        lam_label, w_label = f"λ = i({pair.name}) [A]", f"w = v({cathode},{anode}) [V]"
    else:
        lam, w = res[v_probe], res[i_probe]
        lam_label, w_label = f"λ = v({cathode},{anode}) [V]", f"w = i({pair.name}) [A]"
    # λ belongs to a step (it is the step's LCP solution); the t = 0 sample has none yet.
    lam = lam.copy()
    lam[0] = np.nan
    cond = gdcm_condition(lcs, [pair.name])
    y = _form_values(cond.y[0], X, U)
    gamma = _form_values(cond.gamma[0], X, U)
    # Absolute tolerances relative to the signal sizes: w is zero to round-off in a GDCM
    # (the step's LCP solution is exact), λ must be clearly positive.
    w_tol = 1e-9 * max(np.abs(w).max(), 1e-12)
    lam_tol = 1e-9 * max(np.nanmax(np.abs(lam)), 1e-12)
    intervals = detect_gdcm_intervals(res.t, w, lam, (w_tol, lam_tol), names=[pair.name],
                                      min_samples=2)
    out = CaseResult(case, res.t, system.states, X, w, lam, y, gamma, cond, intervals,
                     w_label, lam_label)
    _check(out, u)
    out.seconds = time.perf_counter() - t0
    return out


def _check(r: CaseResult, u: np.ndarray) -> None:
    """Independent checks of what the case claims (stored in ``r.checks``)."""
    inside = np.zeros(r.t.size, dtype=bool)
    for iv in r.intervals:
        # The first and last step of an interval are partial: the step that lands on w = 0
        # has λ between 0 and Γ (it stops the rest of the motion), so compare the interior.
        inside[iv.i_start + 1:iv.i_end] = True
    # Inside the region the simulated λ is Γ(x, u) and w is y (both computed independently:
    # λ, w from the run's probes, y, Γ from the GDCM forms of lcs.theory.gdcm).
    # λ of a step is Γ at some instant of that step (θ = 1/2: about its middle), so it may
    # differ from Γ at the sample time by up to h max|Γ'|.
    scale = np.nanmax(np.abs(r.lam))
    err = np.abs(r.lam - r.gamma)[inside]
    bound = r.case.step * np.abs(np.gradient(r.gamma, r.t))[inside]
    r.checks["max |λ - Γ| inside / max λ"] = float(err.max() / scale) if inside.any() else 0.0
    r.checks["max |λ - Γ| inside / (h max|dΓ/dt|)"] = (
        float(err.max() / bound.max()) if inside.any() else 0.0)
    r.checks["max |w - y|"] = float(np.abs(r.w - r.y).max())
    if r.case.key == "boost_switch_open":
        import re

        vals = dict(re.findall(r"(\w+)=([0-9.e+-]+)", r.case.text.split("\n")[2]))
        R, C, vin = float(vals["rload"]), float(vals["cout"]), float(vals["vin"])
        t_exit = R * C * np.log(r.x[0, r.states.index("v(C1)")] / vin)
        r.checks["t_exit analytic [s]"] = float(t_exit)
        r.checks["t_exit simulated [s]"] = r.intervals[0].t_end if r.intervals else np.nan
    if r.case.key == "cuk_switch_open":
        r.checks.update(_indefinite_certificate(r.cond, r.x[-1], u))


def _indefinite_certificate(cond: GdcmCondition, x_end: np.ndarray, u: np.ndarray) -> dict:
    """Γ(t) > 0 for all t after the run, from the modes of the reduced dynamics.

    On the region x' = A_red x + E_red u. Its equilibrium on the manifold is x_eq (solved in
    the least-squares sense; A_red is singular along the direction the projection removes)
    and x(t) - x_eq = Σ c_k e^(s_k t) v_k, so Γ(t) - Γ(x_eq) = Σ g_k e^(s_k t) with
    g_k = Γ_x · v_k c_k. Γ(x_eq) = 0 here (the equilibrium is on the boundary).
    """
    A, E = cond.A_red, cond.E_red
    x_eq, *_ = np.linalg.lstsq(A, -E @ u, rcond=None)
    # move x_eq onto the manifold y = 0 along the null direction of A (keeps A x_eq + E u = 0)
    null = np.linalg.svd(A)[2][-1]
    y_form, g_form = cond.y[0], cond.gamma[0]
    x_eq = x_eq - null * (y_form.cx @ x_eq + y_form.cu @ u) / (y_form.cx @ null)
    assert np.allclose(A @ x_eq + E @ u, 0, atol=1e-9 * np.abs(E @ u).max())
    s, V = np.linalg.eig(A)
    c = np.linalg.solve(V, x_end - x_eq)
    g = (g_form.cx @ V) * c
    gamma_eq = float(g_form.cx @ x_eq + g_form.cu @ u)
    live = np.abs(g) > 1e-12 * np.abs(g).max()
    decaying = live & (s.real < -1e-9 * np.abs(s).max())
    slow = np.argmax(np.where(decaying, s.real, -np.inf))
    others = decaying & (np.arange(s.size) != slow)
    # after t_dom the slow mode beats the sum of the others by 1e6 (and they decay faster)
    gap = s.real[slow] - s.real[others].max() if others.any() else 1.0
    ratio = np.abs(g[others]).sum() / abs(g[slow]) if others.any() else 0.0
    t_dom = max(0.0, np.log(1e6 * max(ratio, 1e-300)) / -gap) if others.any() else 0.0
    tt = np.concatenate([np.linspace(0, t_dom, 20001), [t_dom * 2 + 1e-3]])
    gam = gamma_eq + (np.exp(np.outer(tt, s)) @ g).real
    return {
        "Γ at the equilibrium [V]": gamma_eq,
        "slowest mode [1/s]": float(s.real[slow]),
        "slowest mode real": bool(abs(s[slow].imag) <= 1e-9 * abs(s[slow])),
        "slowest mode coefficient of Γ [V]": float(g[slow].real),
        "min Γ after the run [V] (to dominance)": float(gam.min()),
        "dominance time after the run [s]": float(t_dom),
        "Γ stays positive after the run": bool(gam.min() > 0 and g[slow].real > 0
                                               and abs(s[slow].imag) <= 1e-9 * abs(s[slow])
                                               and abs(gamma_eq) < 1e-9),
    }


# -- output ----------------------------------------------------------------------------------


def plot_case(r: CaseResult, path: Path) -> None:
    """Three panels: (y, Γ) trajectory with the region, λ(t) with Γ(t), w(t)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ms = 1e3
    fig = plt.figure(figsize=(13, 5.6), layout="constrained")
    gs = fig.add_gridspec(2, 2, width_ratios=[1, 1.5])
    ax0 = fig.add_subplot(gs[:, 0])
    ax1 = fig.add_subplot(gs[0, 1])
    ax2 = fig.add_subplot(gs[1, 1], sharex=ax1)
    yu = "A" if "i(" in r.cond.y[0].__str__() else "V"
    gu = "V" if "[V]" in r.lam_label else "A"
    # region {y = 0, Γ > 0}
    gmax = max(r.gamma.max(), 1e-12) * 1.1
    ax0.plot([0, 0], [0, gmax], color="tab:green", lw=6, alpha=0.35, solid_capstyle="butt",
             label="GDCM region: y = 0, Γ > 0")
    ax0.plot(r.y, r.gamma, color="tab:blue", lw=1.2, label="trajectory")
    ax0.plot(r.y[0], r.gamma[0], "o", color="k", ms=6, label="start")
    ax0.plot(r.y[-1], r.gamma[-1], "s", color="k", ms=6, label="end")
    for n, iv in enumerate(r.intervals):
        ax0.plot(r.y[iv.i_start], r.gamma[iv.i_start], ">", color="tab:green", ms=8,
                 label="entry" if n == 0 else None)
        if not iv.open_end:
            ax0.plot(r.y[iv.i_end], r.gamma[iv.i_end], "x", color="tab:red", ms=8, mew=2,
                     label="exit" if n == 0 else None)
    ax0.axhline(0, color="0.5", lw=0.8)
    ax0.axvline(0, color="0.5", lw=0.8)
    ax0.set_xlabel(f"y = {r.cond.y[0]}  [{yu}]")
    ax0.set_ylabel(f"Γ = {r.cond.gamma[0]}  [{gu}]")
    ax0.set_title("trajectory in the (y, Γ) plane")
    ax0.legend(loc="best", fontsize=8)
    ax0.grid(alpha=0.3)

    for ax in (ax1, ax2):
        for n, iv in enumerate(r.intervals):
            ax.axvspan(iv.t_start * ms, iv.t_end * ms, color="tab:green", alpha=0.2, lw=0,
                       label="detected GDCM" if n == 0 else None)
        ax.axhline(0, color="0.5", lw=0.8)
        ax.grid(alpha=0.3)
    ax1.plot(r.t * ms, r.gamma, color="tab:orange", lw=1, ls="--", label="Γ(x, u)")
    ax1.plot(r.t * ms, r.lam, color="tab:blue", lw=1.2, label="λ (simulated)")
    if r.case.expect == "indefinite" and "slowest mode [1/s]" in r.checks:
        # On a log scale the tail is the straight line of the slow real mode.
        ins = ax1.inset_axes([0.42, 0.38, 0.3, 0.55])
        ins.semilogy(r.t * ms, r.lam, color="tab:blue", lw=1)
        s_slow = r.checks["slowest mode [1/s]"]
        ref = r.lam[-1] * np.exp(s_slow * (r.t - r.t[-1]))
        half = r.t >= r.t[-1] / 2
        ins.semilogy(r.t[half] * ms, ref[half], "k:", lw=1.5,
                     label=f"e^({s_slow:.0f} t)")
        ins.set_ylabel("λ (log)", fontsize=7)
        ins.tick_params(labelsize=7)
        ins.legend(fontsize=7, loc="lower left")
        ins.grid(alpha=0.3)
    ax1.set_ylabel(r.lam_label)
    ax1.set_title("λ(t): equals Γ inside the GDCM")
    ax1.legend(loc="best", fontsize=8)
    ax2.plot(r.t * ms, r.w, color="tab:purple", lw=1.2, label="w (simulated)")
    ax2.set_ylabel(r.w_label)
    ax2.set_xlabel("t [ms]")
    ax2.set_title("w(t): held at zero in the GDCM")
    ax2.legend(loc="best", fontsize=8)
    n = len(r.intervals)
    kind = {"finite-once": "finite, no re-entry", "reentrant": "finite, re-entrant",
            "indefinite": "lasts to the end of the run and beyond"}[r.case.expect]
    fig.suptitle(f"{r.case.title}  ({n} GDCM interval{'s' if n != 1 else ''} of "
                 f"{r.cond.pairs[0]}: {kind})", fontsize=12)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_csv(r: CaseResult, path: Path, every: int = 1) -> None:
    """t, states, w, λ, y, Γ of one case."""
    header = ["t [s]", *r.states, "w", "lambda", "y", "Gamma"]
    data = np.column_stack([r.t, r.x, r.w, r.lam, r.y, r.gamma])[::every]
    np.savetxt(path, data, delimiter=",", header=",".join(header), comments="", fmt="%.9g")


def write_intervals(results: list[CaseResult], path: Path) -> None:
    with open(path, "w", newline="") as fh:
        wr = csv.writer(fh)
        wr.writerow(["case", "pair", "occurrence", "t_start [s]", "t_end [s]",
                     "duration [s]", "open_end", "lambda_min", "lambda_max"])
        for r in results:
            for iv in r.intervals:
                wr.writerow([r.case.key, iv.pair, iv.occurrence, f"{iv.t_start:.9g}",
                             f"{iv.t_end:.9g}", f"{iv.duration:.9g}", iv.open_end,
                             f"{iv.lam_min:.6g}", f"{iv.lam_max:.6g}"])


def main(argv: list[str] | None = None) -> dict[str, CaseResult]:
    """Run the three studies; returns the results by case key."""
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", default=f"out/{NAME}", help="output directory (default %(default)s)")
    p.add_argument("--fast", action="store_true", help="coarser step, shorter runs")
    args = p.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    results: dict[str, CaseResult] = {}
    for case in cases(args.fast):
        r = run_case(case)
        results[case.key] = r
        plot_case(r, out / f"gdcm_{case.key}.png")
        write_csv(r, out / f"gdcm_{case.key}.csv", every=10)
        print(f"{case.key}: {len(r.intervals)} interval(s) "
              + ", ".join(f"[{iv.t_start * 1e3:.4g}, {iv.t_end * 1e3:.4g}"
                          f"{'...' if iv.open_end else ''}] ms" for iv in r.intervals[:6])
              + (" ..." if len(r.intervals) > 6 else "") + f"  ({r.seconds:.2f} s)")
        for k, v in r.checks.items():
            print(f"    {k}: {v:.6g}" if isinstance(v, float) else f"    {k}: {v}")
    write_intervals(list(results.values()), out / "gdcm_intervals.csv")
    return results


if __name__ == "__main__":
    main()
