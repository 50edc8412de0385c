"""Voltage-mode controlled buck (Deane and Hamill; di Bernardo et al. 1998): period-1 orbit,
Floquet multipliers against an independent saltation-matrix reference, the first period
doubling between 24 V and 25 V located to 0.01 V for two step sizes, and a small
bifurcation sweep.

Parameters: R = 22 Ω, L = 20 mH, C = 47 µF, ramp 3.8 V -> 8.2 V over T = 400 µs,
A = 8.4, Vref = 11.3 V. The switch conducts while the control voltage A (v_C - Vref) is below
the ramp: it turns on at t1 inside the period (ramp crossing the control) and off at the ramp
reset (t2, a few ns before T).

The reference orbit is computed here with scipy: the state is propagated exactly with
matrix exponentials between the switching instants, the orbit and its instants solve
``x(T) = x(0)``, ``g(x(t_i), t_i) = 0`` (``g = ramp - control``), and the monodromy matrix is
``Φ_off(T - t2) S2 Φ_on(t2 - t1) S1 Φ_off(t1)`` with the saltation matrices
``S = I + (f+ - f-) ∇g' / (∇g·f- + ∂g/∂t)``.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import fsolve

from lcs.analysis.bifurcation import attractor_period, bifurcation_diagram
from lcs.analysis.continuation import continue_orbit
from lcs.analysis.orbits import find_orbit
from netlist.studies.sweep import CircuitMapFactory

VM_BUCK_TEXT = """Voltage-mode controlled buck converter (Deane and Hamill)
.param vin=15 a=8.4 vref=11.3 vl=3.8 vu=8.2 tp=400u
.param tfall=10n
Vin in 0 DC {vin}
S1 in sw ramp con SWIDEAL
D1 0 sw DIDEAL
L1 sw out 20m
C1 out 0 47u IC=0
R1 out 0 22
Vref ref 0 DC {vref}
Econ con 0 out ref {a}
Vramp ramp 0 PULSE({vl} {vu} 0 {tp-2*tfall} {tfall} {tfall} {tp})
.model SWIDEAL SW(VT=0 VH=0 RON=1m ROFF=1e9)
.model DIDEAL D(IS=1e-12 N=0.05 RS=1m)
.tran 1u 40m 0 1u UIC
.end
"""

R, L, C, A, VREF, VL, VU, T, TF = 22.0, 20e-3, 47e-6, 8.4, 11.3, 3.8, 8.2, 400e-6, 10e-9

A_ON = np.array([[0.0, -1 / L], [1 / C, -1 / (R * C)]])  # the diode blocks
A_OFF = A_ON  # the diode conducts (CCM): v(sw) = 0, same matrix, no input


@pytest.fixture(scope="module")
def vm_buck(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("vm_buck") / "vm_buck.cir"
    path.write_text(VM_BUCK_TEXT)
    return str(path)


def _flow(Am, b, t):
    M = np.zeros((3, 3))
    M[:2, :2], M[:2, 2] = Am, b
    E = expm(M * t)
    return E[:2, :2], E[:2, 2]


def reference_orbit(vin: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x(0), (t1, t2), multipliers) of the period-1 orbit by exact propagation."""
    b_on = np.array([vin / L, 0.0])
    slope_up = (VU - VL) / (T - 2 * TF)
    slope_down = -(VU - VL) / TF

    def ramp(t):
        return VL + slope_up * t if t <= T - 2 * TF else VU + slope_down * (t - (T - TF))

    def con(x):
        return A * (x[1] - VREF)

    def residual(z):
        x0, t1, t2 = z[:2], z[2], z[3]
        P1, c1 = _flow(A_OFF, np.zeros(2), t1)
        x1 = P1 @ x0 + c1
        P2, c2 = _flow(A_ON, b_on, t2 - t1)
        x2 = P2 @ x1 + c2
        P3, c3 = _flow(A_OFF, np.zeros(2), T - t2)
        xT = P3 @ x2 + c3
        return np.concatenate([xT - x0, [ramp(t1) - con(x1), ramp(t2) - con(x2)]])

    guess = np.array([vin / 40, 12.0, 0.4 * T, T - 5e-9])
    z = fsolve(residual, guess, xtol=1e-14)
    assert np.max(np.abs(residual(z))) < 1e-9
    x0, t1, t2 = z[:2], z[2], z[3]
    x1 = _flow(A_OFF, np.zeros(2), t1)[0] @ x0
    P2, c2 = _flow(A_ON, b_on, t2 - t1)
    x2 = P2 @ x1 + c2
    grad = np.array([0.0, -A])  # ∇(ramp - control)

    def saltation(x, f_minus, f_plus, dgdt):
        return np.eye(2) + np.outer(f_plus - f_minus, grad) / (grad @ f_minus + dgdt)

    S1 = saltation(x1, A_OFF @ x1, A_ON @ x1 + b_on, slope_up)
    S2 = saltation(x2, A_ON @ x2 + b_on, A_OFF @ x2, slope_down)
    M = (_flow(A_OFF, np.zeros(2), T - t2)[0] @ S2 @ P2 @ S1
         @ _flow(A_OFF, np.zeros(2), t1)[0])
    mu = np.linalg.eigvals(M)
    return x0, np.array([t1, t2]), mu


@pytest.mark.parametrize("vin", [20.0, 23.0])
def test_period_one_orbit_matches_saltation_reference(vm_buck, vin):
    x_ref, (t1, t2), mu_ref = reference_orbit(vin)
    m = CircuitMapFactory(vm_buck, period="tp", param="vin")(vin)
    o = find_orbit(m, m.x0, transient=100)
    assert o.converged and o.stable
    # Below the first period doubling the multipliers are a complex pair inside the circle.
    assert abs(o.multipliers[0].imag) > 0.05 and o.multipliers[0] == np.conj(o.multipliers[1])
    # Measured at h = 1 µs: 1.6e-7 / 2.0e-7 in x (O(h²): /4 per halving of h) and 1.5e-6 /
    # 1.8e-6 in μ (the finite-difference noise floor) for vin = 20 / 23 V.
    np.testing.assert_allclose(o.x, x_ref, rtol=2e-6)
    np.testing.assert_allclose(np.sort_complex(o.multipliers), np.sort_complex(mu_ref),
                               atol=1e-5)
    # Switching pattern: off (diode on) until t1, on until the ramp reset, off again.
    pat = o.pattern
    on = [s for s in pat.segments if s.switches == (True,)]
    assert len(on) == 1
    assert on[0].start == pytest.approx(t1, abs=1e-8)
    assert on[0].start + on[0].duration == pytest.approx(t2, abs=1e-8)
    assert all(s.diodes == (not s.switches[0],) for s in pat.segments)  # CCM


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_flip_between_24_and_25_volts_independent_of_h(vm_buck):
    found = []
    for h in (1e-6, 0.5e-6):
        f = CircuitMapFactory(vm_buck, period="tp", param="vin", step=h)
        res = continue_orbit(f, 24.0, 25.0, steps=2, tol=0.005, transient=100,
                             param_name="vin")
        flips = [b for b in res.bifurcations if b.type == "flip"]
        assert len(flips) == 1 and flips[0].located
        b = flips[0]
        assert 24.0 < b.param < 25.0
        assert abs(b.bracket[1] - b.bracket[0]) <= 0.005
        # Before: stable with a multiplier just above -1; after: just below.
        assert -1 < min(b.before.multipliers.real) < -0.98
        assert -1.02 < min(b.after.multipliers.real) < -1
        found.append(b.param)
    # Measured: 24.5177 V for h = 1 µs, 0.5 µs and 0.25 µs (to 3e-7 V at tol 1e-7).
    assert abs(found[0] - found[1]) < 0.01


def test_small_bifurcation_sweep(vm_buck):
    f = CircuitMapFactory(vm_buck, period="tp", param="vin")
    vin = np.array([20.0, 27.0])
    d = bifurcation_diagram(f, vin, x0=[0.0, 0.0], transient=300, record=16,
                            probes=["v(out)"], workers=2, param_name="vin")
    b = d.branches[0]
    assert b.ok.all()
    assert attractor_period(b.samples[0], 1e-5) == 1
    assert attractor_period(b.samples[1], 1e-5) == 2


def test_event_map_at_comparator_switch_on(vm_buck):
    """The Poincaré map on the switching surface (S1 turning on): fixed point = the orbit's
    state at t1 with phase t1; multipliers = the stroboscopic ones, plus an exact 0 (the
    Jacobian is taken along the section: across it the map is only piecewise smooth)."""
    x_ref, (t1, _), mu_ref = reference_orbit(20.0)
    x1_ref = _flow(A_OFF, np.zeros(2), t1)[0] @ x_ref
    em = CircuitMapFactory(vm_buck, period="tp", param="vin", event="S1:on")(20.0)
    assert em.state_names == ("i(L1)", "v(C1)", "phase")
    o = find_orbit(em, np.concatenate([x_ref, [0.0]]), transient=1)
    assert o.converged
    np.testing.assert_allclose(o.x[:2], x1_ref, rtol=2e-6)
    assert o.x[2] == pytest.approx(t1, abs=1e-10)
    assert abs(o.multipliers[-1]) < 1e-12
    np.testing.assert_allclose(np.sort_complex(o.multipliers[:2]), np.sort_complex(mu_ref),
                               atol=1e-5)
