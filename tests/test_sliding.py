"""Sliding-mode control of a boost converter (12 V in, L = 1 mH, C = 100 µF, R = 50 Ω) with the
surface s = i(L1) - Iref built in the netlist: the three switching methods.

* implicit (VH = 0, default): Filippov relay solved with the two modes' LCPs at every step;
  the trajectory stays on the surface to round-off, the duty is the equivalent control
  1 - E/v(out), v(out) follows C dv/dt = E Iref / v - v / R (first order in h) towards
  sqrt(R E Iref);
* explicit: the sign of s sampled once per step: chattering of amplitude O(h);
* hysteresis (VH > 0): finite switching frequency given by the band.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from lcs.integrators.moreau.integrator import MoreauOptions, simulate
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import transient_setup

BOOST = Path(__file__).parent / "netlists" / "closed_loop" / "boost_smc.cir"
E, IREF, R, C, L = 12.0, 2.0, 50.0, 100e-6, 1e-3
V_STEADY = np.sqrt(R * E * IREF)


def setup(**params):
    return transient_setup(parse_file(BOOST, params=params or None))


def orders(errors):
    e = np.asarray(errors)
    return np.log2(e[:-1] / e[1:])


def test_implicit_reaches_and_stays_on_the_surface():
    s = setup()
    res = simulate(s.system, s.signals, s.x0, 30e-3, 1e-6, probes=["i(L1)", "v(out)", "d(S1)"])
    assert res.ok and res.switching == {"S1": "implicit"}
    # One sliding interval from the first time i(L1) reaches Iref to the end; no chattering.
    assert len(res.sliding) == 1
    name, t_s, t_e = res.sliding[0]
    assert name == "S1" and t_e is None
    assert len(res.events) <= 3 and res.stats.sliding_steps > 0.95 * (30e-3 - t_s) / 1e-6
    after = res.t >= t_s
    i = res["i(L1)"][after]
    assert np.abs(i - IREF).max() < 1e-12
    # Equivalent duty = 1 - E / v(out) (to O(h)), strictly inside (0, 1).
    v, d = res["v(out)"][after][1:], res["d(S1)"][after][1:]
    late = res.t[after][1:] > t_s + 1e-4
    np.testing.assert_allclose(d[late], 1 - E / v[late], atol=2e-4)
    assert 0 < d.min() and d.max() < 1
    # v(out) approaches sqrt(R E Iref) (within the O(h) error of the method).
    assert res["v(out)"][-1] == pytest.approx(V_STEADY, rel=5e-3)


def test_implicit_on_surface_follows_equivalent_dynamics_first_order():
    s = setup()
    x0 = np.array([IREF, 20.0])  # on the surface, v > E: sliding from t = 0
    tt = np.linspace(0, 10e-3, 11)
    ref = solve_ivp(lambda t, v: [(E * IREF / v[0] - v[0] / R) / C], (0, 10e-3), [20.0],
                    t_eval=tt, rtol=1e-12, atol=1e-12).y[0]
    errs, derrs = [], []
    for h in (2e-6, 1e-6, 0.5e-6):
        res = simulate(s.system, s.signals, x0, 10e-3, h, probes=["i(L1)", "v(out)", "d(S1)"],
                       save_at=tt[1:], every=10**9)
        assert res.sliding == [("S1", 0.0, None)]
        idx = np.searchsorted(res.t, tt)
        v, d = res["v(out)"][idx], res["d(S1)"][idx]
        errs.append(np.abs(v - ref).max())
        derrs.append(np.abs(d[1:] - (1 - E / v[1:])).max())
        assert np.abs(res["i(L1)"] - IREF).max() < 1e-12
    np.testing.assert_allclose(orders(errs), 1.0, atol=0.1)
    np.testing.assert_allclose(orders(derrs), 1.0, atol=0.1)
    assert errs[-1] < 0.06 and derrs[-1] < 5e-5


def test_explicit_chattering_shrinks_with_h():
    s = setup()
    amps = []
    for h in (2e-6, 1e-6, 0.5e-6):
        res = simulate(s.system, s.signals, np.array([IREF, V_STEADY]), 2e-3, h,
                       probes=["i(L1)", "v(out)"], switching="explicit")
        assert res.ok and res.switching == {"S1": "explicit"} and res.stats.located == 0
        i = res["i(L1)"][res.t > 1e-3]
        amps.append(np.ptp(i))
        # Chattering at the step rate: a switching at most every couple of steps.
        assert len(res.events) > 0.3 * 2e-3 / h
    np.testing.assert_allclose(orders(amps), 1.0, atol=0.15)
    # The band is a few (E / L) h, as for a digital controller sampling at 1 / h.
    assert amps[-1] < 2 * (V_STEADY - E) / L * 0.5e-6 + 1e-9


def test_explicit_from_model_parameter():
    txt = BOOST.read_text().replace("VT=0 VH={vh}", "VT=0 VH={vh} EXPLICIT=1")
    s = transient_setup(parse_string(txt))
    res = simulate(s.system, s.signals, np.array([IREF, V_STEADY]), 1e-4, 1e-6)
    assert res.switching == {"S1": "explicit"}
    # The run-level method overrides the model's.
    res = simulate(s.system, s.signals, np.array([IREF, V_STEADY]), 1e-4, 1e-6,
                   options=MoreauOptions(switching="implicit"))
    assert res.switching == {"S1": "implicit"} and res.sliding


def test_hysteresis_switching_frequency_matches_band():
    vh = 0.05  # ±50 mA around Iref (1 V per A)
    s = setup(vh=vh)
    res = simulate(s.system, s.signals, s.x0, 30e-3, 0.2e-6, probes=["i(L1)", "v(out)"])
    assert res.ok and res.switching == {"S1": "hysteresis"} and not res.sliding
    i = res["i(L1)"][res.t > 25e-3]
    assert i.min() == pytest.approx(IREF - vh, abs=1e-9)
    assert i.max() == pytest.approx(IREF + vh, abs=1e-9)
    t_on = np.array([t for t, md in res.events if md[0] and t > 25e-3])
    f = 1 / np.diff(t_on).mean()
    v = res["v(out)"][res.t > 25e-3].mean()
    # Triangle of 2 vh: rises at E / L (on), falls at (v - E) / L (off).
    f_band = 1 / (2 * vh * L / E + 2 * vh * L / (v - E))
    assert f == pytest.approx(f_band, rel=2e-3)
    assert v == pytest.approx(V_STEADY, rel=5e-3)


def test_hysteresis_method_without_band_reports_sliding():
    s = setup()
    res = simulate(s.system, s.signals, s.x0, 5e-3, 1e-6, switching="hysteresis")
    err = res.error
    assert err is not None and err.kind == "sliding" and err.switch == "S1"
    assert "S1" in str(err) and "implicit" in str(err)
    assert err.time == pytest.approx(res.t[-1])
    assert 0.1e-3 < err.time < 2e-3
