"""Comparator-driven switches (closed loops built in the netlist): the voltage-mode buck of the
chaos literature (period 1 at E = 15 V and 24 V, period 2 at 25 V), second-order switching
instants and stroboscopic maps against an exact event-driven solution (matrix exponentials),
latched trailing-edge PWM, the sampled (explicit) method and the chattering guard."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

from lcs.integrators.moreau.integrator import simulate
from netlist.parser import parse_file
from netlist.studies.transient import transient_setup

HERE = Path(__file__).parent / "netlists" / "closed_loop"
VM_BUCK = HERE / "vm_buck.cir"
LATCHED = HERE / "vm_buck_latched.cir"

# Parameters of vm_buck.cir (Hamill, Deane and Jefferies 1992; di Bernardo et al. 1998).
A, VREF, VL, VU, TP, TF = 8.4, 11.3, 3.8, 8.2, 400e-6, 1e-9
R, L, C = 22.0, 20e-3, 47e-6


def vm_setup(e: float):
    return transient_setup(parse_file(VM_BUCK, params={"e": e}))


def strobe(e: float, periods: int, h: float, x0=(0.0, 0.0), **kw):
    """States at t = k T, k = 0..periods (probes i(L1), v(C1))."""
    s = vm_setup(e)
    t = TP * np.arange(1, periods + 1)
    res = simulate(s.system, s.signals, np.asarray(x0, float), periods * TP, h,
                   probes=["i(L1)", "v(C1)"], every=10**9, save_at=t, **kw)
    assert res.ok, res.error
    keep = np.isin(res.t, t)
    assert keep.sum() == periods
    return res, res.y[keep]


# ---------------------------------------------------------------------------------------------
# Exact event-driven reference (CCM: the diode conducts whenever the switch is off)
# ---------------------------------------------------------------------------------------------


def flow(x, t, on, e):
    """Exact solution after t seconds in one mode, x = [i(L1), v(C1)]."""
    M = np.zeros((3, 3))
    M[0, 1] = -1 / L
    M[1, 0] = 1 / C
    M[1, 1] = -1 / (R * C)
    if on:
        M[0, 2] = e / L
    return (expm(M * t) @ np.array([x[0], x[1], 1.0]))[:2]


def ramp(t):
    tr = TP - 2 * TF
    if t <= tr:
        return VL + (VU - VL) * t / tr
    if t <= TP - TF:
        return VU
    return VU - (VU - VL) * (t - (TP - TF)) / TF


def exact_period(x0, e):
    """Turn-on and turn-off instants in the first period and the state at T."""
    t_on = brentq(lambda t: ramp(t) - A * (flow(x0, t, False, e)[1] - VREF), 0, TP - 2 * TF,
                  xtol=1e-18, rtol=1e-15)
    x1 = flow(x0, t_on, False, e)
    t_off = brentq(lambda t: ramp(t) - A * (flow(x1, t - t_on, True, e)[1] - VREF), TP - TF,
                   TP, xtol=1e-20, rtol=1e-15)
    x2 = flow(x1, t_off - t_on, True, e)
    return t_on, t_off, flow(x2, TP - t_off, False, e)


def orders(errors):
    e = np.asarray(errors)
    return np.log2(e[:-1] / e[1:])


# ---------------------------------------------------------------------------------------------
# Tests
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("e, period", [(15.0, 1), (24.0, 1), (25.0, 2)])
def test_vm_buck_period_one_and_two(e, period):
    res, x = strobe(e, 150, TP / 100)
    assert res.switching == {"S1": "implicit"}
    v = x[-20:, 1]
    if period == 1:
        assert np.ptp(v) < 1e-7 * v.mean()
    else:
        assert np.ptp(v[0::2]) < 1e-7 * v.mean() and np.ptp(v[1::2]) < 1e-7 * v.mean()
        assert abs(v[0] - v[1]) > 1e-3
    if e == 15.0:
        # Averaged loop: v = E d, d = (VU - A (v - VREF)) / (VU - VL).
        v_avg = e * (VU + A * VREF) / (VU - VL) / (1 + e * A / (VU - VL))
        assert v.mean() == pytest.approx(v_avg, rel=0.01)
    # Two switchings per period (on when the ramp passes the control, off at the reset).
    assert 2 * 150 - 40 <= res.stats.located <= 2 * 150


def test_switching_instants_and_state_second_order():
    e = 15.0
    x0 = np.array([0.55, 11.8])
    t_on, t_off, x_t = exact_period(x0, e)
    s = vm_setup(e)
    err_on, err_off, err_x = [], [], []
    for div in (50, 100, 200):
        res = simulate(s.system, s.signals, x0, TP, TP / div, probes=["i(L1)", "v(C1)"])
        assert res.ok
        (ta, ma), (tb, mb) = res.events
        assert ma == (True,) and mb == (False,)
        err_on.append(abs(ta - t_on))
        err_off.append(abs(tb - t_off))
        err_x.append(np.abs(res.x_final - x_t).max())
    assert np.all(orders(err_on) > 1.85), err_on
    assert np.all(orders(err_x) > 1.85), err_x
    assert err_on[-1] < 2e-10 and err_off[-1] < 1e-14
    # The instant search costs a few trial steps per switching.
    assert res.stats.root_evaluations <= 4 * res.stats.located


def test_stroboscopic_map_converges_second_order():
    e = 15.0
    x0 = np.array([0.55, 11.8])
    x = x0.copy()
    exact = []
    for _ in range(8):
        x = exact_period(x, e)[2]
        exact.append(x)
    exact = np.array(exact)
    errs = []
    for div in (40, 80, 160):
        _, xs = strobe(e, 8, TP / div, x0=x0)
        errs.append(np.abs(xs - exact).max())
    assert np.all(orders(errs) > 1.85), errs


def test_save_at_is_exact_and_independent_of_every():
    s = vm_setup(15.0)
    t = TP * np.arange(1, 11)
    a = simulate(s.system, s.signals, s.x0, 10 * TP, TP / 50, save_at=t, every=7)
    b = simulate(s.system, s.signals, s.x0, 10 * TP, TP / 50)
    assert set(t) <= set(a.t)
    ia = np.searchsorted(a.t, t)
    ib = np.searchsorted(b.t, t)
    np.testing.assert_allclose(a.y[ia], b.y[ib], rtol=1e-13)


def test_latched_pwm_one_turn_off_per_period():
    T = 20e-6
    text = LATCHED.read_text()
    res = {}
    for label, txt in (("latched", text), ("plain", text.replace("LATCH=1 PERIOD={tp}", ""))):
        s = transient_setup(parse_file_text(txt))
        r = simulate(s.system, s.signals, s.x0, 1e-3, T / 40, probes=["v(out)", "d(S1)"])
        assert r.ok, r.error
        res[label] = r
    lat, plain = res["latched"], res["plain"]
    assert lat.switching == {"S1": "latched"} and plain.switching == {"S1": "implicit"}

    def per_period(r):
        t = np.array([t for t, _ in r.events])
        return np.bincount(np.floor(t / T + 1e-9).astype(int))

    assert per_period(lat).max() == 2 and per_period(plain).max() > 2
    ev = [(t, md[0]) for t, md in lat.events]
    on_t = np.array([t for t, on in ev if on])
    # Turn-on only at the clock edges, turn-off only by the comparator.
    np.testing.assert_allclose(on_t / T, np.round(on_t / T), rtol=0, atol=1e-9)
    assert lat.stats.located == sum(1 for _, on in ev if not on)
    # The on-state probe d(S1) is 0/1.
    assert set(np.unique(lat["d(S1)"])) <= {0.0, 1.0}


def parse_file_text(text: str):
    from netlist.parser import parse_string

    return parse_string(text, file=str(LATCHED))


def test_latch_needs_period():
    from netlist.parser import parse_string

    txt = LATCHED.read_text().replace("LATCH=1 PERIOD={tp}", "LATCH=1")
    s = transient_setup(parse_string(txt))
    with pytest.raises(ValueError, match="PERIOD"):
        simulate(s.system, s.signals, s.x0, 1e-4, 1e-6)


def test_explicit_method_switches_on_grid_points():
    s = vm_setup(15.0)
    h = TP / 100
    res = simulate(s.system, s.signals, np.array([0.55, 11.8]), 20 * TP, h,
                   switching="explicit")
    assert res.ok and res.switching == {"S1": "explicit"} and res.stats.located == 0
    t = np.array([t for t, _ in res.events])
    assert t.size >= 38
    # Sampled: every switching instant is a grid point (k h or a ramp breakpoint).
    k = (t % TP) / h
    assert np.all((np.abs(k - np.round(k)) < 1e-6) | (np.abs(t % TP) < 2 * TF)
                  | (np.abs(TP - t % TP) < 2 * TF))
    # Close to the located solution (first order in h).
    ref = simulate(s.system, s.signals, np.array([0.55, 11.8]), 20 * TP, h)
    assert abs(res.x_final[1] - ref.x_final[1]) < 0.01


def test_hysteresis_oscillator_period():
    # The hysteresis band fixes the switching frequency: instants located at the band edges.
    s = transient_setup(parse_file(HERE / "relaxation.cir"))
    res = simulate(s.system, s.signals, s.x0, 50e-6, 20e-9, probes=["v(c)"])
    assert res.ok and res.switching == {"S1": "hysteresis"}
    t_on = np.array([t for t, md in res.events if md[0]])
    period = 0.8e-6 * np.log(2.0) + 4e-6 * np.log(1.5)
    np.testing.assert_allclose(np.diff(t_on[2:]), period, rtol=2e-4)
    v = np.interp([t for t, _ in res.events[3:]], res.t, res["v(c)"])
    np.testing.assert_allclose(np.sort(np.unique(np.round(v, 6))), [4.0, 6.0], atol=1e-6)


def test_chattering_guard_names_switch_and_time():
    # The same oscillator with steps of 50 us: about 45 switchings per grid step.
    s = transient_setup(parse_file(HERE / "relaxation.cir"))
    res = simulate(s.system, s.signals, s.x0, 200e-6, 50e-6)
    err = res.error
    assert err is not None and err.kind == "chattering" and err.switch == "S1"
    assert "S1" in str(err) and "max_switchings" in str(err)
    assert err.t_prev < 50e-6 and err.time == 50e-6
    assert res.t[-1] <= err.time


@pytest.mark.skipif(shutil.which("ngspice") is None, reason="ngspice not installed")
@pytest.mark.parametrize("path", [VM_BUCK, LATCHED], ids=lambda p: p.name)
def test_ngspice_accepts_the_netlists(path, tmp_path):
    # ngspice must run these decks: pelcs-only model parameters (LATCH, PERIOD) are only
    # warned about.
    deck = path.read_text().replace(".end", ".control\nrun\nquit\n.endc\n.end")
    deck = deck.replace(".tran 4u 40m", ".tran 4u 4m").replace(".tran 0.1u 1m", ".tran 0.1u 0.1m")
    f = tmp_path / path.name
    f.write_text(deck)
    out = subprocess.run(["ngspice", "-b", str(f)], capture_output=True, text=True, timeout=300)
    text = out.stdout + out.stderr
    assert "rror" not in text.replace("unrecognized", ""), text[-2000:]
    if path == LATCHED:
        assert "unrecognized parameter (latch)" in text
