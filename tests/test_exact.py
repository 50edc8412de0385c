"""The exact event-driven integrator against closed forms and an independent
piecewise-linear reference written here.

- RLC step response and the half-wave rectifier's turn-off instant: closed forms.
- A boost into a fixed output voltage: the diode's DCM turn-off instant in closed form.
- Moreau's results converge to the exact ones at second order as h shrinks.
- Deane–Hamill's voltage-mode buck: the Floquet multipliers at E = 24 V and 28 V and the
  first period doubling (near 24.5 V) against a reference built here from matrix
  exponentials and hand-derived saltation matrices of the two-state buck.
- The peak-current-mode buck of the issue: the exact orbit converges to round-off, with the
  current-loop multiplier of Ridley's sampled-data model.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq

import pelcs
from lcs.analysis.orbits import find_orbit
from netlist.studies.sweep import CircuitMapFactory
from netlist.studies.transient import simulate_circuit
from pelcs.cli import main

# (the slow part of the suite: outside the fast subset that `-m 'not slow'` selects)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
EXACT = ROOT / "tests" / "netlists" / "exact"
VM_BUCK = ROOT / "converters" / "netlists" / "vm_buck.cir"


# --- closed forms ----------------------------------------------------------------------------


def test_rlc_step_response_to_round_off():
    res = simulate_circuit(pelcs.load(EXACT / "rlc_step.cir"), method="exact")
    assert res.error is None
    V, R, L, C, i0, v0 = 10.0, 10.0, 1e-3, 10e-6, 0.5, 2.0
    a, w0 = R / (2 * L), 1 / np.sqrt(L * C)
    wd = np.sqrt(w0**2 - a**2)
    t = res.t
    # v = V + e^{-at} (A cos wd t + B sin wd t), v(0) = v0, v'(0) = i0/C
    A = v0 - V
    B = (i0 / C + a * A) / wd
    v = V + np.exp(-a * t) * (A * np.cos(wd * t) + B * np.sin(wd * t))
    dv = np.exp(-a * t) * ((-a * A + wd * B) * np.cos(wd * t) + (-a * B - wd * A)
                           * np.sin(wd * t))
    assert np.max(np.abs(res["v(C1)"] - v)) < 1e-11 * V
    assert np.max(np.abs(res["i(L1)"] - C * dv)) < 1e-11
    assert res.stats.steps == 1  # one stretch: no event in a linear circuit


def test_half_wave_rectifier_turns_off_where_the_closed_form_says():
    res = simulate_circuit(pelcs.load(EXACT / "halfwave_triangle.cir"), method="exact")
    diode = [e for e in res.event_log if e.kind == "diode"]
    assert len(diode) == 1 and diode[0].element == "D1"
    assert diode[0].t == pytest.approx(1.4e-3, rel=1e-12)
    # conducting: v(out) = v(in); blocking: v(out) = 2 V e^{-(t - t_off)/RC}
    t, v = res.t, res["v(C1)"]
    on = (t > 1e-3) & (t < 1.4e-3)
    assert np.allclose(v[on], 10.0 - 2e4 * (t[on] - 1e-3), rtol=0, atol=1e-10)
    off = t > 1.45e-3
    assert np.allclose(v[off], 2.0 * np.exp(-(t[off] - 1.4e-3) / 1e-4), rtol=1e-9, atol=1e-15)


def test_boost_dcm_turn_off_instant():
    res = simulate_circuit(pelcs.load(EXACT / "boost_dcm_vo.cir"), method="exact")
    assert res.error is None
    sw = [e for e in res.event_log if e.element == "S1"]
    d1 = [e for e in res.event_log if e.element == "D1"]
    ons = [e.t for e in sw if e.mode["S1"] == "on"]
    offs = [e.t for e in sw if e.mode["S1"] == "off"]
    assert len(d1) == 3 and len(ons) == 3
    for t_on, t_off, ev in zip(ons, offs, d1, strict=True):
        # i rises at Vin/L for t_off - t_on, falls at (Vo - Vin)/L: zero after Vo/(Vo-Vin)
        assert ev.t == pytest.approx(t_on + (t_off - t_on) * 20 / 8, rel=1e-12)
        assert ev.mode["held"] == ("D1",)  # the diode blocks: i(L1) held at zero
    t = res.t
    idle = (t > d1[0].t + 1e-8) & (t < ons[1] - 1e-8)
    assert np.max(np.abs(res["i(L1)"][idle])) < 1e-12


def test_moreau_converges_to_exact_at_second_order():
    circuit = pelcs.load(ROOT / "tests" / "netlists" / "sim" / "boost_dcm.cir")
    tstop = 0.5e-3
    ref = simulate_circuit(circuit, method="exact", tstop=tstop, step=1e-6)["v(C1)"][-1]
    errors = [abs(simulate_circuit(circuit, step=h, tstop=tstop)["v(C1)"][-1] - ref)
              for h in (2e-7, 1e-7, 5e-8)]
    # measured: 5.0e-4, 1.26e-4, 3.4e-5 V (ratios 4.0, 3.7)
    assert errors[0] / errors[1] > 3.0 and errors[1] / errors[2] > 3.0
    assert errors[-1] < 1e-4


# --- Deane–Hamill: an independent reference ----------------------------------------------

R, L, C, A_GAIN, VREF, VL, VU, TP, TF = 22.0, 20e-3, 47e-6, 8.4, 11.3, 3.8, 8.2, 400e-6, 10e-9
TR = TP - 2 * TF
A = np.array([[0.0, -1 / L], [1 / C, -1 / (R * C)]])


def _ramp(t):
    if t <= TR:
        return VL + (VU - VL) * t / TR, (VU - VL) / TR
    if t <= TR + TF:
        return VU, 0.0
    return VU - (VU - VL) * (t - TR - TF) / TF, -(VU - VL) / TF


def _flow(E, on):
    b = np.array([E / L, 0.0]) if on else np.zeros(2)
    G = np.zeros((3, 3))
    G[:2, :2], G[:2, 2] = A, b
    return G, b


def _go(G, x, s):
    return (expm(G * s) @ np.append(x, 1.0))[:2]


def _h(x, t):  # S1 on while the ramp is above a (v - vref)
    return _ramp(t)[0] - A_GAIN * (x[1] - VREF)


def _reference_map(E, x):
    """P(x) and its Jacobian for the buck in CCM: off until the ramp rises past the control,
    on until the ramp's reset crosses it, off to the period's end (S1 starts off: the orbit
    has a(v - vref) above VL)."""
    Goff, boff = _flow(E, False)
    Gon, bon = _flow(E, True)
    hx = np.array([0.0, -A_GAIN])
    J = np.eye(2)
    assert _h(x, 0.0) < 0
    t1 = brentq(lambda s: _h(_go(Goff, x, s), s), 0.0, TR, xtol=1e-18, rtol=1e-15)
    x1 = _go(Goff, x, t1)
    J = expm(A * t1) @ J
    fm, fp = A @ x1 + boff, A @ x1 + bon
    hdot = hx @ fm + _ramp(t1)[1]
    J = (np.eye(2) + np.outer(fp - fm, hx) / hdot) @ J
    t2 = brentq(lambda s: _h(_go(Gon, x1, s - t1), s), TR + TF, TP, xtol=1e-18, rtol=1e-15)
    x2 = _go(Gon, x1, t2 - t1)
    J = expm(A * (t2 - t1)) @ J
    fm, fp = A @ x2 + bon, A @ x2 + boff
    hdot = hx @ fm + _ramp(t2)[1]
    J = (np.eye(2) + np.outer(fp - fm, hx) / hdot) @ J
    x3 = _go(Goff, x2, TP - t2)
    J = expm(A * (TP - t2)) @ J
    return x3, J


def _reference_orbit(E, x=(0.6, 12.0)):
    x = np.asarray(x, dtype=float)
    for _ in range(50):
        px, J = _reference_map(E, x)
        if np.max(np.abs(px - x)) < 1e-13 * np.max(np.abs(x)):
            break
        x = x - np.linalg.solve(J - np.eye(2), px - x)
    mu = np.linalg.eigvals(_reference_map(E, x)[1])
    return x, mu[np.argsort(mu.real)]


def _pelcs_orbit(E, x=(0.6, 12.0)):
    m = CircuitMapFactory(path=str(VM_BUCK), period="tp", param="vin", method="exact")(E)
    orb = find_orbit(m, np.asarray(x, dtype=float), tol=1e-13)
    assert orb.converged
    mu = orb.multipliers
    return orb.points[0], mu[np.argsort(mu.real)], orb


@pytest.mark.parametrize("E", [24.0, 28.0])
def test_deane_hamill_multipliers_match_the_reference(E):
    x_ref, mu_ref = _reference_orbit(E)
    x, mu, orb = _pelcs_orbit(E)
    assert np.allclose(x, x_ref, rtol=1e-9, atol=0)
    assert np.max(np.abs(mu - mu_ref)) < 1e-6
    if E == 28.0:
        assert mu[0].real < -1  # past the flip: the period-1 orbit is unstable
    assert orb.iterations <= 6  # exact Jacobian: Newton converges in a few steps


def test_deane_hamill_first_period_doubling():
    def flip(orbit):
        def g(E):
            return orbit(E)[1][0].real + 1.0
        return brentq(g, 24.0, 25.0, xtol=1e-9)

    e_ref = flip(_reference_orbit)
    e_pel = flip(_pelcs_orbit)
    assert 24.4 < e_ref < 24.6
    assert abs(e_pel - e_ref) < 1e-5


# --- peak current mode ------------------------------------------------------------------


def test_cm_buck_orbit_converges_with_ridleys_multiplier(capsys):
    """The issue's converter (100 kHz, 100 uH, 1 mF, 8 ohm, compensation ramp): the exact
    map's Newton converges to round-off, with Ridley's current multiplier. (Newton from the
    netlist's initial state: 400 transient periods before it gave the same orbit.)"""
    code = main(["orbit", str(EXACT / "cm_buck_issue.cir"), "--period", "ts",
                 "--method", "exact", "--json", "--transient", "0"])
    out = capsys.readouterr().out
    assert code == 0, out
    import json

    r = json.loads(out)
    assert r["converged"] and r["residual"] < 1e-10 and r["method"] == "exact"
    vin, vo, L, ri, vr, ts = 12.0, r["points"][0][1], 100e-6, 0.5, 0.2, 1e-5
    m1, m2 = ri * (vin - vo) / L, ri * vo / L
    mc = vr / (ts - 2e-8)  # the ramp rises over ts - 2 tf
    expected = -(m2 - mc) / (m1 + mc)
    mu = [complex(a, b) for a, b in r["multipliers"]]
    current = min(mu, key=lambda z: z.real)
    # the formula takes vo constant over the period; the output ripple bounds the accuracy
    assert abs(current.real - expected) < 1e-3 and abs(current.imag) < 1e-9
    slow = max(mu, key=lambda z: z.real)
    assert 0.99 < slow.real < 1.0  # the output capacitor's slow pole


# --- CLI and errors -----------------------------------------------------------------------


def test_cli_simulate_exact_lists_events(capsys):
    code = main(["simulate", str(EXACT / "boost_dcm_vo.cir"), "--method", "exact", "--events"])
    out = capsys.readouterr().out
    assert code == 0
    assert "exactly (event-driven)" in out
    assert sum(line.startswith("event") for line in out.splitlines()) == 9, out
    assert "diode      D1" in out


def test_exact_refuses_exp_sources_by_name(tmp_path, capsys):
    text = (EXACT / "halfwave_triangle.cir").read_text().replace(
        "PWL(0 0 1m 10 2m -10 3m 0)", "EXP(0 10 0 1m 1.5m 1m)")
    path = tmp_path / "exp.cir"
    path.write_text(text)
    code = main(["simulate", str(path), "--method", "exact"])
    err = capsys.readouterr().err
    assert code == 3
    assert "V1" in err and "piecewise-linear or SIN" in err


# --- SIN sources: the oscillator in the augmented system ------------------------------------


def test_half_wave_sine_conduction_angle():
    res = simulate_circuit(pelcs.load(EXACT / "halfwave_sin.cir"), method="exact")
    assert res.error is None
    Vm, w, Rl, Cl = 10.0, 2 * np.pi * 50, 1e3, 10e-6
    tau = Rl * Cl
    ev = [e.t for e in res.event_log if e.element == "D1"]
    # by hand: off where i(D1) = C Vm w cos wt + Vm sin(wt)/R = 0, then on again where the
    # next rising sine meets the decaying v(out)
    expected = []
    t_on = 0.0
    for _ in range(3):
        k = np.floor(w * t_on / (2 * np.pi))
        t_off = (2 * np.pi * k + np.pi - np.arctan(w * tau)) / w
        v_off = Vm * np.sin(w * t_off)
        t_next = brentq(lambda t, t_off=t_off, v_off=v_off: Vm * np.sin(w * t)
                        - v_off * np.exp(-(t - t_off) / tau),
                        (2 * np.pi * (k + 1)) / w, (2 * np.pi * (k + 1) + np.pi / 2) / w,
                        xtol=1e-15)
        expected += [t_off, t_next]
        t_on = t_next
    assert len(ev) >= 5
    assert np.allclose(ev[:5], expected[:5], rtol=1e-10, atol=0)
    # between, v(out) follows the sine exactly
    t = res.t
    on = (t > 1e-3) & (t < expected[0] - 1e-5)
    assert np.allclose(res["v(C1)"][on], Vm * np.sin(w * t[on]), rtol=0, atol=1e-9)


def test_bridge_rectifier_sine_agrees_with_moreau():
    c = pelcs.load(ROOT / "converters" / "netlists" / "bridge_rectifier.cir")
    ex = simulate_circuit(c, method="exact", tstop=0.06)
    mo = simulate_circuit(c, tstop=0.06, step=1e-6)
    assert ex.error is None
    # Moreau at h = 1 us (second order) against exact: 5e-9 relative measured
    assert abs(ex["v(C1)"][-1] - mo["v(C1)"][-1]) < 1e-6 * abs(ex["v(C1)"][-1])
    kinds = {e.kind for e in ex.event_log}
    assert kinds == {"diode"}


# --- sliding -------------------------------------------------------------------------------


def test_sliding_mode_boost_follows_the_closed_form():
    """Boost under the ideal relay s = i(L1) - Iref (VH = 0): once both modes cross the
    surface back, i(L1) stays at Iref and by power balance C v v' = Vin Iref - v^2/R, so
    v^2 = R Vin Iref + (v_a^2 - R Vin Iref) e^{-2 (t - t_a)/(R C)}; the equivalent duty is
    1 - Vin/v. Moreau's implicit relay converges to it at first order."""
    circuit = pelcs.load(ROOT / "tests" / "netlists" / "closed_loop" / "boost_smc.cir")
    res = simulate_circuit(circuit, method="exact", tstop=3e-3,
                           probes=["i(L1)", "v(C1)", "d(S1)"])
    assert res.error is None
    assert len(res.sliding) == 1 and res.sliding[0][0] == "S1" and res.sliding[0][2] is None
    R_, vin, iref, C_ = 50.0, 12.0, 2.0, 100e-6
    t0 = res.sliding[0][1]
    assert any(e.kind == "slide" and e.mode["S1"] == "sliding" for e in res.event_log)
    t, v = res.t, res["v(C1)"]
    k = np.searchsorted(t, t0) + 1
    ta, va = t[k], v[k]
    ref = np.sqrt(R_ * vin * iref + (va**2 - R_ * vin * iref) * np.exp(-2 * (t[k:] - ta)
                                                                        / (R_ * C_)))
    assert np.max(np.abs(v[k:] - ref)) < 1e-9
    assert np.max(np.abs(res["i(L1)"][k:] - iref)) < 1e-12
    assert np.allclose(res["d(S1)"][k:], 1 - vin / v[k:], rtol=0, atol=1e-9)
    errors = [abs(simulate_circuit(circuit, tstop=3e-3, step=h, probes=["v(C1)"])["v(C1)"][-1]
                  - v[-1]) for h in (2e-7, 1e-7)]
    assert 1.8 < errors[0] / errors[1] < 2.2  # first order (measured 2.0)


def test_exact_continuation_locates_the_dcm_border_collision(capsys):
    """As the load grows the buck's inductor current touches zero before the next turn-on
    and a stretch with every switch and diode off appears: a border collision. With exact
    stretches the located load is where the current at the turn-on instant is zero."""
    path = str(EXACT / "buck_border.cir")
    code = main(["continue", path, "--period", "ts", "--param", "rload=3.9:4.1:4",
                 "--method", "exact", "--locate-tol", "1e-9", "--json"])
    out = capsys.readouterr().out
    assert code == 0
    import json

    r = json.loads(out)
    border = [b for b in r["bifurcations"] if b["type"] == "border"]
    assert len(border) == 1
    r_b = border[0]["param"]
    assert 3.98 < r_b < 3.99
    f = CircuitMapFactory(path=path, period="ts", param="rload", method="exact")
    for R_, sign in ((r_b - 1e-6, 1), (r_b + 1e-6, -1)):
        m = f(R_)
        # (Newton from the guess: its restarts reach the orbit without a long transient)
        orb = find_orbit(m, np.array([1.0, 6.0]), tol=1e-12)
        segs, _, _ = m.follow(orb.points[0])
        # the inductor current at the turn-on instant (the last stretch's start, S1 on)
        i_on = [s.x_start[0] for s in segs if s.key == (True,)][-1]
        if sign > 0:
            assert 0 < i_on < 1e-5  # CCM just before: a current that vanishes at the border
        else:
            assert abs(i_on) < 1e-12  # DCM just after: the current is held at zero


def test_state_jump_at_an_event_conserves_charge():
    """S1 closes a diode path from C1 (10 V) onto C2 (0 V) at 1 ms: no continuation without
    an impulse, so the state jumps to the charge-conserving 5 V on both, which then decay
    together through R2: 5 V e^{-(t - 1 ms)/(R2 (C1 + C2))}."""
    res = simulate_circuit(pelcs.load(EXACT / "cap_share.cir"), method="exact")
    assert res.error is None
    assert [e.kind for e in res.event_log] == ["switch", "jump"]
    t = res.t
    t_j = res.event_log[0].t  # the gate crosses VT half-way up its 1 ns edge
    assert t_j == pytest.approx(1e-3 + 0.5e-9, rel=1e-12)
    after = t > t_j
    ref = 5.0 * np.exp(-(t[after] - t_j) / 2e-3)
    assert np.allclose(res["v(C1)"][after], ref, rtol=1e-11, atol=0)
    assert np.allclose(res["v(C2)"][after], ref, rtol=1e-11, atol=0)
    before = t < 1e-3
    assert np.all(res["v(C1)"][before] == 10.0) and np.all(res["v(C2)"][before] == 0.0)


def test_diode_behind_an_open_switch_is_not_flagged_non_passive():
    import warnings

    from lcs.notices import NonPassiveWarning

    with warnings.catch_warnings():
        warnings.simplefilter("error", NonPassiveWarning)
        system = pelcs.formulate(EXACT / "cap_share.cir")
    off = system.mode({"S1": False})
    assert np.all(off.C == 0) and np.all(off.D == 0)  # its current is zero identically
