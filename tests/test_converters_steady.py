"""Simulated steady states of the open-loop converters against the analytic averaged model.

Every converter is built by its factory and simulated with the Moreau θ = 1/2 scheme; the
periodic steady state (last switching period) is compared with

- the CCM conversion ratios D, 1/(1-D), -D/(1-D) (Erickson & Maksimović ch. 2) and the
  averaged model's equilibrium (:mod:`converters.averaged`) for the mean of every state;
- the DCM conversion ratios ``converters.design.conversion_ratio(topology, D, K)``
  (Erickson table 5.2);
- the peak-to-peak ripple formulas of :func:`converters.averaged.ripple`.

Parameters: fs = 100 kHz (T = 10 µs), step h = T/100 (T/200 in DCM), and components chosen
so that R C is about 50 T (1 % output ripple) and the slowest averaged-model mode decays
within about 1 ms. The run starts on the averaged steady state, shifted to the start of a
period (inductor currents at their valley: they rise while the switch is on), so only a
ripple-sized transient is left; 1000 periods (about 10 time constants) damp it below 1e-5
of the mean, which the ``drift`` check (mean of the last period against the period before)
confirms. Each run takes well under a second (about 1 µs per step).

Why the tolerances are what they are (Δv, Δi peak-to-peak ripples, V = |v(out)|):

- Buck mean: volt-second balance on L is exact in the periodic steady state and v(sw) is
  vin for exactly D T, so <v(out)> = D vin exactly; what is left is the θ-scheme error
  (second order in h on linear pieces between exact switching instants) and the decayed
  transient: 1e-4.
- Boost, buck-boost, Čuk means: the balance fixes the mean of v(out) over the off-interval
  only, which differs from the period mean by at most half the output ripple, and the
  diode-current (charge) balance likewise involves the current over one interval: rtol
  Δv/(2V) + Δi/(2I) (0.2 % to 0.6 % here).
- Δi of boost, buck-boost, Čuk L1: exact (the inductor sees the constant vin while the switch
  is on): 1e-6. Buck Δi and Čuk Δi2: the inductor sees vin - v(out) (Čuk: v(C1) + v(out)),
  which moves by the capacitor ripples: rtol the relative size of those ripples.
- Δv of boost and buck-boost: C discharges through R alone while the switch is on, an
  exponential that the linear formula V D T/(R C) over-estimates by about D T/(2 R C) and
  whose start lies Δv/2 above V: rtol D T/(R C). Buck and Čuk C2: Δi T/(8C) assumes the whole
  triangular ripple current flows into C (the load takes a share |Z_C|/R ≈ T/(2π R C)) and a
  triangle (the slopes move with the other capacitor's ripple): rtol 2 %.
- DCM ratios: the formulas hold the output voltage constant within the period; its ripple
  changes the inductor's volt-seconds by the same relative amount: rtol half the relative
  ripple of the capacitor voltages (0.2 % to 0.5 %), plus the time-stepping error of the
  diode turn-off instant, which is not a breakpoint (h = T/200 puts it below 1e-4).
"""

from __future__ import annotations

import numpy as np
import pytest

from converters import factories as F
from converters.averaged import averaged_model, effective_k, ripple
from converters.design import conversion_ratio, k_crit
from netlist.studies.transient import simulate_circuit

FS = 100e3
T = 1 / FS

CCM = {
    "buck": dict(vin=24.0, duty=0.4, fs=FS, lind=100e-6, cout=125e-6, rload=4.0),
    "boost": dict(vin=12.0, duty=0.5, fs=FS, lind=100e-6, cout=25e-6, rload=20.0),
    "buck-boost": dict(vin=12.0, duty=0.4, fs=FS, lind=100e-6, cout=62.5e-6, rload=8.0),
    "cuk": dict(vin=12.0, duty=0.4, fs=FS, l1=200e-6, c1=20e-6, l2=400e-6, c2=20e-6,
                rload=8.0),
}
IC_NAMES = {"cuk": ("il1", "vc1", "il2", "vc2")}


def _components(p: dict) -> dict:
    return {k: v for k, v in p.items() if k != "fs"}


def _last_period(res, name: str, periods_back: int = 0, period: float = T):
    """Samples of probe ``name`` over one switching period ending ``periods_back`` periods
    before the end (both ends included: the run lands exactly on every period)."""
    t_end = res.t[-1] - periods_back * period
    sel = (res.t >= t_end - period - 1e-12) & (res.t <= t_end + 1e-12)
    return res.t[sel], res[name][sel]


def _mean(t, y) -> float:
    return float(np.trapezoid(y, t) / (t[-1] - t[0]))


def _run(topology: str, p: dict, x0, periods: int, div: int):
    names = IC_NAMES.get(topology, ("il0", "vc0"))
    period = 1 / p["fs"]
    c = F.circuit(topology, **p, **dict(zip(names, map(float, x0), strict=True)),
                  tstop=periods * period)
    res = simulate_circuit(c, step=period / div)
    assert res.ok, res.error
    return res


@pytest.fixture(scope="module", params=sorted(CCM))
def ccm(request):
    topology = request.param
    p = CCM[topology]
    model = averaged_model(topology, **_components(p))
    xe = model.equilibrium()
    rp = ripple(topology, **p)
    assert (effective_k(topology, **p) > k_crit(topology, p["duty"])), "must be CCM"
    x0 = xe.copy()
    for k, s in enumerate(model.states):
        if s.startswith("i("):
            # valley at the start of the on-interval: i(L1) rises, i(L2) (b -> out, negative
            # in operation) falls, i.e. |i(L2)| rises.
            x0[k] -= np.sign(xe[k]) * rp[s] / 2
    res = _run(topology, p, x0, periods=1000, div=100)
    return topology, p, model, xe, rp, res


def test_ccm_mean_states_match_averaged_model(ccm):
    topology, p, model, xe, rp, res = ccm
    out = "v(C2)" if topology == "cuk" else "v(C1)"
    V = abs(xe[model.states.index(out)])
    for k, s in enumerate(model.states):
        mean = _mean(*_last_period(res, s))
        before = _mean(*_last_period(res, s, 1))
        assert mean == pytest.approx(before, rel=1e-5), f"{s} not settled"
        if topology == "buck":
            rtol = 1e-4
        else:
            caps = [q for q in model.states if q.startswith("v(")]
            inds = [q for q in model.states if q.startswith("i(")]
            rtol = sum(rp[q] / (2 * abs(xe[model.states.index(q)])) for q in caps + inds)
        assert mean == pytest.approx(xe[k], rel=rtol), f"{topology} {s}"
    # the conversion ratio itself
    vout = _mean(*_last_period(res, out))
    M = conversion_ratio(topology, p["duty"])
    assert vout / p["vin"] == pytest.approx(M, rel=1e-4 if topology == "buck"
                                            else rp[out] / (2 * V) + 2e-3)


def test_ccm_ripples_match_formulas(ccm):
    topology, p, model, xe, rp, res = ccm
    D, vin = p["duty"], p["vin"]
    rel = {s: rp[s] / abs(xe[model.states.index(s)]) for s in model.states}
    if topology == "buck":
        rtol = {"i(L1)": rel["v(C1)"] * xe[1] / (vin - xe[1]), "v(C1)": 0.02}
    elif topology in ("boost", "buck-boost"):
        rtol = {"i(L1)": 1e-6, "v(C1)": D * T / (p["rload"] * p["cout"])}
    else:
        rtol = {"i(L1)": 1e-6, "i(L2)": (rp["v(C1)"] + rp["v(C2)"]) / vin,
                "v(C1)": 0.02, "v(C2)": 0.02}
    for s, tol in rtol.items():
        _, y = _last_period(res, s)
        assert np.ptp(y) == pytest.approx(rp[s], rel=tol), f"{topology} {s}"


DCM = {
    "buck": dict(vin=24.0, duty=0.4, fs=FS, lind=20e-6, cout=25e-6, rload=20.0),
    # boost_dcm.cir: K = 0.04 < D (1-D)^2 = 0.147
    "boost": dict(vin=12.0, duty=0.3, fs=50e3, lind=20e-6, cout=100e-6, rload=50.0),
    "buck-boost": dict(vin=12.0, duty=0.4, fs=FS, lind=10e-6, cout=25e-6, rload=20.0),
    "cuk": dict(vin=12.0, duty=0.4, fs=FS, l1=20e-6, c1=20e-6, l2=20e-6, c2=25e-6,
                rload=20.0),
}


@pytest.mark.parametrize("topology", sorted(DCM))
def test_dcm_conversion_ratio(topology):
    p = DCM[topology]
    K = effective_k(topology, **p)
    assert K < k_crit(topology, p["duty"]), "must be DCM"
    M = conversion_ratio(topology, p["duty"], K)
    vin, period = p["vin"], 1 / p["fs"]
    # Start at the DCM steady state: output at M vin, inductor currents at zero (Čuk: C1
    # at vin - v(out), the loop voltage that keeps the freewheeling current constant).
    x0 = ([0.0, vin - M * vin, 0.0, M * vin] if topology == "cuk" else [0.0, M * vin])
    res = _run(topology, p, x0, periods=600, div=200)

    def last(name, back=0):
        return _last_period(res, name, back, period)

    out = "v(C2)" if topology == "cuk" else "v(C1)"
    caps = ["v(C1)", "v(C2)"] if topology == "cuk" else ["v(C1)"]
    means = {s: _mean(*last(s)) for s in caps}
    assert means[out] == pytest.approx(_mean(*last(out, 1)), rel=1e-6), "not settled"
    rtol = sum(np.ptp(last(s)[1]) / (2 * abs(means[s])) for s in caps) + 1e-4
    assert means[out] / vin == pytest.approx(M, rel=rtol)
    # Peak inductor current: the on-interval starts from zero (Čuk: from the freewheeling
    # value) with slope (voltage across L)/L: vin (boost, buck-boost), vin - V (buck).
    _, il = last("i(L1)")
    if topology in ("boost", "buck-boost"):
        assert il.max() == pytest.approx(vin * p["duty"] * period / p["lind"], rel=1e-6)
        assert il.min() == pytest.approx(0.0, abs=1e-9)
    elif topology == "buck":
        V = means[out]
        peak = (vin - V) * p["duty"] * period / p["lind"]
        assert il.max() == pytest.approx(peak, rel=np.ptp(last(out)[1]) / (vin - V))
        assert il.min() == pytest.approx(0.0, abs=1e-9)
    else:
        # Čuk DCM: the diode current i(L1) - i(L2) drops to zero and both inductors then
        # carry the same (freewheeling) current; Δi1 = vin D T/L1 as in CCM (exact).
        assert np.ptp(il) == pytest.approx(vin * p["duty"] * period / p["l1"], rel=1e-6)
        _, il2 = last("i(L2)")
        assert np.min(np.abs(il - il2)) < 1e-9
