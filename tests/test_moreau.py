"""Moreau θ time-stepping of single LCS: agreement with an independent implementation of the
Siconos formulas, analytic RC/RL/RLC solutions and convergence orders, rectifiers, errors,
energy balance. LCS are written by hand here (no netlist)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.optimize import brentq
from test_moreau_reference import moreau_reference

from lcs.integrators.moreau.dense import discretise
from lcs.integrators.moreau.integrator import MoreauOptions, simulate_lcs
from lcs.lcp import is_p_matrix
from lcs.model import LCS, ComplementarityPair, OutputMap
from lcs.results import SimulationError
from lcs.signals import Dc, Pwl


def make_lcs(A, B, C, D, E, F, states=None, pairs=None, inputs=None):
    A = np.atleast_2d(np.asarray(A, float))
    n = A.shape[0]
    B = np.asarray(B, float).reshape(n, -1)
    m = B.shape[1]
    E = np.asarray(E, float).reshape(n, -1)
    p = E.shape[1]
    states = states or tuple(f"x{i}" for i in range(n))
    pairs = pairs or tuple(ComplementarityPair(f"D{i + 1}") for i in range(m))
    inputs = inputs or tuple(f"V{j + 1}" for j in range(p))
    return LCS(A, B, np.asarray(C, float).reshape(m, n), np.asarray(D, float).reshape(m, m),
               E, np.asarray(F, float).reshape(m, p), tuple(states), tuple(pairs),
               tuple(inputs))


# ---------------------------------------------------------------------------------------------
# Agreement with the independent reference
# ---------------------------------------------------------------------------------------------


def random_lcs(rng, n, m, p, h):
    """Random LCS whose step LCP matrix D + h C W B is a P-matrix (unique solutions)."""
    for _ in range(100):
        A = rng.normal(size=(n, n)) - 1.5 * np.eye(n)
        B = rng.normal(size=(n, m))
        C = rng.normal(size=(m, n))
        G = rng.normal(size=(m, m))
        S = rng.normal(size=(m, m))
        D = G @ G.T + 0.5 * np.eye(m) + 0.5 * (S - S.T)
        E = rng.normal(size=(n, p))
        F = rng.normal(size=(m, p))
        lcs = make_lcs(A, B, C, D, E, F)
        ok = all(is_p_matrix(discretise(A, B, C, D, E, hh, th).M)
                 for hh in (h, h / 3) for th in (0.5, 1.0))
        if ok:
            return lcs
    raise RuntimeError("no P-matrix LCS found")


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("theta", [0.5, 0.75, 1.0])
def test_agrees_with_independent_siconos_formulas(seed, theta):
    rng = np.random.default_rng(seed)
    for _attempt in range(20):
        n, m, p = int(rng.integers(1, 4)), int(rng.integers(1, 4)), int(rng.integers(1, 3))
        h = float(rng.choice([0.01, 0.04]))
        lcs = random_lcs(rng, n, m, p, h)
        freqs = rng.uniform(1.0, 6.0, size=p)
        inputs = [lambda t, w=w: 3.0 * np.sin(w * t) + 0.3 for w in freqs]
        x0 = rng.normal(size=n)
        # An extra breakpoint forces one shortened step, which must match too.
        t_stop = 150 * h + 0.37 * h
        res = simulate_lcs(lcs, inputs, x0, t_stop, h, theta=theta, breakpoints=[61.5 * h])
        assert res.ok
        u = lambda t, fs=inputs: np.array([f(np.asarray(t)) for f in fs])  # noqa: E731
        xs, lams = moreau_reference(lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, lcs.F, u, x0, res.t,
                                    theta)
        scale = np.abs(xs).max()
        np.testing.assert_allclose(res.y, xs, rtol=0, atol=1e-11 * scale)
        np.testing.assert_allclose(res.lambda_final, lams[-1], rtol=1e-9,
                                   atol=1e-11 * (np.abs(lams).max() + 1e-300))
        assert res.stats.odd_steps == 2  # the breakpoint and the final partial step
        # Keep drawing until some diode switched during the run (the interesting case).
        active = lams > 1e-12 * np.abs(lams).max()
        if np.any(active.any(axis=0) & ~active.all(axis=0)):
            break
    else:
        pytest.fail("no random LCS with diode switching found")


# ---------------------------------------------------------------------------------------------
# Analytic solutions and convergence orders
# ---------------------------------------------------------------------------------------------


def observed_order(errors):
    e = np.asarray(errors)
    return np.log2(e[:-1] / e[1:])


def rc_lowpass(tau):
    # v' = (u - v) / tau, no pairs (m = 0).
    return make_lcs([[-1 / tau]], np.zeros((1, 0)), np.zeros((0, 1)), np.zeros((0, 0)),
                    [[1 / tau]], np.zeros((0, 1)), states=("v(C1)",), inputs=("Vin",))


@pytest.mark.parametrize("theta, order", [(0.5, 2.0), (1.0, 1.0)])
def test_rc_sine_analytic_and_order(theta, order):
    tau, w = 0.2, 2 * np.pi
    lcs = rc_lowpass(tau)

    def exact(t):
        wt = w * tau
        return (np.sin(w * t) - wt * np.cos(w * t) + wt * np.exp(-t / tau)) / (1 + wt**2)

    errs = []
    for h in (1e-2, 5e-3, 2.5e-3):
        res = simulate_lcs(lcs, [lambda t: np.sin(w * t)], [0.0], 1.0, h, theta=theta)
        assert res.t[-1] == 1.0 and len(res.t) == round(1.0 / h) + 1
        errs.append(np.abs(res["v(C1)"] - exact(res.t)).max())
    assert errs[-1] < (2e-4 if order == 2 else 5e-3)
    np.testing.assert_allclose(observed_order(errs), order, atol=0.15)


@pytest.mark.parametrize("theta, order", [(0.5, 2.0), (1.0, 1.0)])
def test_rl_step_response_and_order(theta, order):
    R, L, V = 2.0, 0.5, 3.0
    # i' = (u - R i) / L with u = 3 V DC; exact i = V/R (1 - exp(-R t / L)).
    lcs = make_lcs([[-R / L]], np.zeros((1, 0)), np.zeros((0, 1)), np.zeros((0, 0)),
                   [[1 / L]], np.zeros((0, 1)), states=("i(L1)",))
    errs = []
    for h in (2e-2, 1e-2, 5e-3):
        res = simulate_lcs(lcs, [Dc(V)], [0.0], 1.0, h, theta=theta)
        errs.append(np.abs(res["i(L1)"] - V / R * (1 - np.exp(-R * res.t / L))).max())
    np.testing.assert_allclose(observed_order(errs), order, atol=0.15)


@pytest.mark.parametrize("theta, order", [(0.5, 2.0), (1.0, 1.0)])
def test_rlc_free_response_and_order(theta, order):
    R, L, C = 1.0, 1e-3, 1e-6  # underdamped, f0 ≈ 5 kHz
    A = np.array([[-R / L, -1 / L], [1 / C, 0.0]])  # x = [i(L1), v(C1)]
    lcs = make_lcs(A, np.zeros((2, 0)), np.zeros((0, 2)), np.zeros((0, 0)), np.zeros((2, 0)),
                   np.zeros((0, 0)), states=("i(L1)", "v(C1)"))
    x0 = np.array([0.0, 5.0])
    t_stop = 2e-4  # one period: backward Euler's damping error stays asymptotic
    errs = []
    for h in (1e-6, 5e-7, 2.5e-7):
        res = simulate_lcs(lcs, [], x0, t_stop, h, theta=theta, every=5)
        exact = np.array([expm(A * t) @ x0 for t in res.t])
        errs.append(np.abs(res.y[:, 1] - exact[:, 1]).max())
        # every=5: start, every fifth step, and the end.
        assert len(res.t) == round(t_stop / h) // 5 + 1
    np.testing.assert_allclose(observed_order(errs), order, atol=0.2)


def rl_diode():
    """Source → diode → L → R (series). λ = reverse voltage of D1, w = i(D1) = i(L1)."""
    R, L = 10.0, 0.05
    return make_lcs([[-R / L]], [[1 / L]], [[1.0]], [[0.0]], [[1 / L]], [[0.0]],
                    states=("i(L1)",), pairs=(ComplementarityPair("D1", "voltage"),),
                    inputs=("Vs",)), R, L


@pytest.mark.parametrize("theta, order", [(0.5, 2.0), (1.0, 1.0)])
def test_rl_freewheel_with_diode_order(theta, order):
    lcs, R, L = rl_diode()
    errs = []
    for h in (4e-4, 2e-4, 1e-4):
        res = simulate_lcs(lcs, [Dc(0.0)], [2.0], 0.02, h, theta=theta)
        errs.append(np.abs(res["i(L1)"] - 2.0 * np.exp(-R / L * res.t)).max())
    np.testing.assert_allclose(observed_order(errs), order, atol=0.15)


def test_rl_half_wave_rectifier_conduction_interval():
    # i(t) = V/Z [sin(wt - φ) + sin φ e^{-t/τ}] from i(0) = 0 until it returns to zero; then
    # the diode blocks (λ = -u >= 0) until u turns positive again at the next period.
    lcs, R, L = rl_diode()
    V, f = 10.0, 50.0
    w = 2 * np.pi * f
    Z, phi, tau = np.hypot(R, w * L), np.arctan2(w * L, R), L / R

    def i_on(t):
        return V / Z * (np.sin(w * t - phi) + np.sin(phi) * np.exp(-t / tau))

    t_off = brentq(i_on, 0.5 / f, 0.99 / f)
    h = 1e-5
    res = simulate_lcs(lcs, [lambda t: V * np.sin(w * t)], [0.0], 2 / f, h,
                       probes=OutputMap(("i(L1)", "lam"), np.array([[1.0], [0.0]]),
                                        np.array([[0.0], [1.0]]), np.zeros((2, 1))))
    tp = np.mod(res.t, 1 / f)
    exact = np.where(tp <= t_off, i_on(tp), 0.0)
    assert np.abs(res["i(L1)"] - exact).max() < 2e-3 * V / Z
    blocked = res["lam"] > 1e-9 * V
    # Blocking intervals: (t_off, T) in each period, within two steps.
    on_to_off = res.t[1:][blocked[1:] & ~blocked[:-1]]
    np.testing.assert_allclose(on_to_off, [t_off, t_off + 1 / f], atol=2 * h)
    assert res["i(L1)"].min() >= -1e-12


def test_rc_half_wave_rectifier_analytic():
    # Sine source, ideal diode, R || C load. λ = i(D1), w = v(C1) - u (D = 0). While the
    # diode conducts v = u and i(D1) = C u' + u / R; it turns off when that current would
    # reverse: tan(w t) = -w R C, i.e. w t_off = π - atan(w R C). Then v decays with RC
    # until the source catches up again (t_on).
    V, f, R, C = 10.0, 50.0, 1e3, 100e-6
    w = 2 * np.pi * f
    lcs = make_lcs([[-1 / (R * C)]], [[1 / C]], [[1.0]], [[0.0]], [[0.0]], [[-1.0]],
                   states=("v(C1)",), inputs=("Vs",))
    T = 1 / f
    t_off = (np.pi - np.arctan(w * R * C)) / w
    v_off = V * np.sin(w * t_off)

    def decay(t):
        return v_off * np.exp(-(t - t_off) / (R * C))

    t_on = brentq(lambda t: V * np.sin(w * t) - decay(t), T, T + T / 4)

    def exact(t):
        return np.where((t <= t_off) | ((t >= t_on) & (t <= T + t_off)), V * np.sin(w * t),
                        np.where(t < t_on, decay(t), decay(t - T)))

    h = 1e-5
    probes = OutputMap(("v(C1)", "i(D1)"), np.array([[1.0], [0.0]]), np.array([[0.0], [1.0]]),
                       np.zeros((2, 1)))
    res = simulate_lcs(lcs, [lambda t: V * np.sin(w * t)], [0.0], T + t_off + T / 8, h,
                       probes=probes)
    assert res.ok
    assert np.abs(res["v(C1)"] - exact(res.t)).max() < 5e-3
    # (λ(0) = 0: at t = 0 with v = u the instantaneous LCP is degenerate; skip the start.)
    cond = (res["i(D1)"] > 1e-6) | (res.t < 3 * h)
    t_turn_off = res.t[1:][~cond[1:] & cond[:-1]]
    t_turn_on = res.t[1:][cond[1:] & ~cond[:-1]]
    np.testing.assert_allclose(t_turn_off, [t_off, T + t_off], atol=2 * h)
    np.testing.assert_allclose(t_turn_on, [t_on], atol=2 * h)
    # Conducting: i(D1) = C u' + u/R up to O(h), except on the first step after a turn-on
    # (where λ also pays for the O(h) catch-up of v).
    steady = np.concatenate(([False], cond[1:] & cond[:-1])) & (res.t > 3 * h)
    t = res.t[steady]
    np.testing.assert_allclose(res["i(D1)"][steady],
                               C * V * w * np.cos(w * t) + V * np.sin(w * t) / R,
                               atol=0.01 * V * w * C)


@pytest.mark.parametrize("theta", [0.5, 1.0])
def test_rc_diode_charging_is_first_order(theta):
    # PWL source 0 → 5 V at t = 0..0.1, held, then ramped down to 0: the diode charges C
    # through R, then blocks and holds the voltage. While the pair is active the impulse
    # h W B λ_{k+1} is implicit Euler (Siconos's EulerMoreauOSI without γ), so the scheme is
    # first order for every θ: documented behaviour, checked here.
    R, C, V = 1e3, 1e-4, 5.0
    tau = R * C
    lcs = make_lcs([[0.0]], [[1 / C]], [[1.0]], [[R]], [[0.0]], [[-1.0]], states=("v(C1)",))
    src = Pwl((0.0, 0.1, 0.4, 0.5), (0.0, V, V, 0.0))
    # Exact: v = 5 (t - τ + τ e^{-t/τ}) / 0.1 on the ramp, v' = (5 - v)/τ on the plateau,
    # and while u ramps down the diode conducts until u falls to v, then v holds.
    v1 = V / 0.1 * (0.1 - tau + tau * np.exp(-0.1 / tau))
    v4 = V - (V - v1) * np.exp(-0.3 / tau)
    slope = -V / 0.1

    def v_down(s):  # v at 0.4 + s while conducting, with u = V + slope s
        return V + slope * (s - tau) - (V - slope * tau - v4) * np.exp(-s / tau)

    # Conduction stops where λ = (u - v)/R = 0, i.e. where v' = 0.
    s_off = brentq(lambda s: V + slope * s - v_down(s), 1e-9, 0.1)
    v_hold = v_down(s_off)
    errs = []
    for h in (4e-3, 2e-3, 1e-3):
        res = simulate_lcs(lcs, [src], [0.0], 0.6, h, theta=theta)
        assert np.all(np.isin([0.1, 0.4, 0.5], res.t))  # breakpoints hit exactly
        late = res.t > 0.45
        np.testing.assert_allclose(res["v(C1)"][late], res["v(C1)"][-1], rtol=1e-12)
        errs.append(abs(res["v(C1)"][-1] - v_hold))
    np.testing.assert_allclose(observed_order(errs), 1.0, atol=0.2)


# ---------------------------------------------------------------------------------------------
# Errors, initial states, outputs
# ---------------------------------------------------------------------------------------------


def test_lcp_without_solution_stops_with_error_and_keeps_partial_result():
    # x' = -1, w = x - λ (D = -1, not a diode a circuit can make): once x < 0 no λ >= 0 gives
    # w >= 0. h = 1/64 keeps x exact: x = 0 at t = 1, the step to 65/64 fails.
    lcs = make_lcs([[0.0]], [[0.0]], [[1.0]], [[-1.0]], [[-1.0]], [[0.0]], states=("x",))
    h = 1 / 64
    res = simulate_lcs(lcs, [Dc(1.0)], [1.0], 2.0, h)
    err = res.error
    assert isinstance(err, SimulationError)
    assert err.kind == "no_solution"
    assert err.time == 65 / 64 and err.t_prev == 1.0
    assert err.pairs == ("D1",)
    assert "D1" in str(err) and "t = 1.015625 s" in str(err)
    assert err.result is res
    assert res.t[-1] == 1.0 and len(res.t) == 65
    np.testing.assert_allclose(res["x"], 1.0 - res.t, atol=1e-15)
    assert res.x_final[0] == 0.0
    with pytest.raises(SimulationError):
        res.raise_if_error()


def test_nan_input_is_reported_not_propagated():
    lcs = rc_lowpass(0.1)
    res = simulate_lcs(lcs, [lambda t: np.where(t > 0.5, np.nan, 1.0)], [0.0], 1.0, 0.01)
    assert res.error is not None and res.error.kind == "non_finite"
    assert np.all(np.isfinite(res.y)) and np.isfinite(res.x_final).all()
    assert res.t[-1] == pytest.approx(0.5)


def test_inconsistent_initial_state():
    # RC fed through an ideal diode with D = 0 (no series resistance): v(C1) = 0 below a
    # 5 V source is inconsistent (the capacitor must jump to 5 V).
    C, R = 1e-6, 1e3
    lcs = make_lcs([[-1 / (R * C)]], [[1 / C]], [[1.0]], [[0.0]], [[0.0]], [[-1.0]],
                   states=("v(C1)",))
    calls = []

    def jump(lcs_, x, u):
        calls.append((x.copy(), u.copy()))
        return np.maximum(x, u)  # charge the capacitor to the source voltage

    res = simulate_lcs(lcs, [Dc(5.0)], [0.0], 1e-4, 1e-6, on_inconsistent=jump)
    assert len(calls) == 1 and len(res.notes) == 1 and "inconsistent" in res.notes[0]
    np.testing.assert_allclose(res["v(C1)"], 5.0, rtol=1e-12)
    # Without a handler the first step absorbs the jump (and a note says so).
    res = simulate_lcs(lcs, [Dc(5.0)], [0.0], 1e-4, 1e-6)
    assert res["v(C1)"][0] == 0.0 and "absorbs" in res.notes[0]
    np.testing.assert_allclose(res["v(C1)"][1:], 5.0, rtol=1e-12)


def test_outputs_every_and_getitem():
    lcs, R, L = rl_diode()
    probes = OutputMap(("i(L1)", "v(D1)", "v(R1)"), np.array([[1.0], [0.0], [R]]),
                       np.array([[0.0], [-1.0], [0.0]]), np.zeros((3, 1)))
    res = simulate_lcs(lcs, [Dc(-1.0)], [1.0], 0.1037, 1e-4, probes=probes, every=7)
    n_steps = res.stats.steps
    assert n_steps == 1037
    assert len(res.t) == 1 + n_steps // 7 + 1  # start, every 7th, the end
    np.testing.assert_allclose(np.diff(res.t[:-1]), 7e-4, rtol=1e-9)
    assert res.t[-1] == 0.1037
    np.testing.assert_allclose(res["V(r1)"], R * res["i(L1)"])
    with pytest.raises(KeyError, match="stored probes"):
        res["v(nope)"]
    # Current reaches zero, then the diode blocks with v(D1) = u = -1 V.
    assert res["v(D1)"][-1] == pytest.approx(-1.0)
    with pytest.raises(KeyError, match="OutputMap"):
        simulate_lcs(lcs, [Dc(0.0)], [1.0], 1e-3, 1e-4, probes=["v(out)"])


def test_fast_path_statistics_and_option():
    lcs, R, L = rl_diode()
    src = [lambda t: 10 * np.sin(2 * np.pi * 50 * t)]
    fast = simulate_lcs(lcs, src, [0.0], 0.1, 1e-5)
    slow = simulate_lcs(lcs, src, [0.0], 0.1, 1e-5, options=MoreauOptions(fast_path=False))
    np.testing.assert_allclose(fast.y, slow.y, rtol=0, atol=1e-12)
    assert slow.stats.fallbacks == slow.stats.steps
    # Two diode transitions per period, 5 periods: only a handful of Lemke calls.
    assert fast.stats.fallbacks < 30 < fast.stats.steps


def test_argument_checks():
    lcs = rc_lowpass(1.0)
    with pytest.raises(ValueError, match="theta"):
        simulate_lcs(lcs, [Dc(1.0)], [0.0], 1.0, 0.1, theta=0.4)
    with pytest.raises(ValueError, match="signal"):
        simulate_lcs(lcs, [], [0.0], 1.0, 0.1)
    with pytest.raises(ValueError, match="x0"):
        simulate_lcs(lcs, [Dc(1.0)], [0.0, 1.0], 1.0, 0.1)
    with pytest.raises(ValueError, match="t_stop"):
        simulate_lcs(lcs, [Dc(1.0)], [0.0], 0.0, 0.1)


def test_energy_balance_rlc_diode():
    # Sine source → D1 → L1 → node b; C1 and R1 from b to ground. x = [i(L1), v(C1)],
    # λ = reverse voltage of D1, w = i(L1). The ideal diode dissipates nothing (v_D i_D = 0),
    # so source energy = Δ(½ L i² + ½ C v²) + ∫ v²/R.
    L, C, R, V, f = 1e-3, 10e-6, 20.0, 10.0, 1e3
    A = np.array([[0.0, -1 / L], [1 / C, -1 / (R * C)]])
    lcs = make_lcs(A, [[1 / L], [0.0]], [[1.0, 0.0]], [[0.0]], [[1 / L], [0.0]], [[0.0]],
                   states=("i(L1)", "v(C1)"), pairs=(ComplementarityPair("D1", "voltage"),))
    w = 2 * np.pi * f
    src = lambda t: V * np.sin(w * t)  # noqa: E731
    errs = []
    for h in (4e-6, 1e-6):
        res = simulate_lcs(lcs, [src], [0.0, 0.0], 3e-3, h)
        i, v, t = res["i(L1)"], res["v(C1)"], res.t
        e_src = np.trapezoid(src(t) * i, t)
        e_stored = 0.5 * L * i[-1] ** 2 + 0.5 * C * v[-1] ** 2
        e_r = np.trapezoid(v**2 / R, t)
        errs.append(abs(e_src - e_stored - e_r) / e_src)
        assert i.min() >= -1e-12  # the diode blocks reverse current
        assert (i == 0).sum() > 100  # and does block for a while
    assert errs[1] < errs[0] / 4 and errs[1] < 2e-4


def test_progress_bar_only_on_terminal(monkeypatch):
    import io

    import lcs.integrators.moreau.integrator as mo

    class Tty(io.StringIO):
        def isatty(self):
            return True

    lcs = rc_lowpass(0.1)
    fake = Tty()
    monkeypatch.setattr("sys.stderr", fake)
    simulate_lcs(lcs, [Dc(1.0)], [0.0], 1.0, 1e-3, progress=True)
    assert fake.getvalue() == ""  # expected to be quick: no bar
    monkeypatch.setattr(mo, "_EST_STEP_S", 1.0)  # pretend every step takes a second
    simulate_lcs(lcs, [Dc(1.0)], [0.0], 1.0, 1e-3, progress=True)
    assert "step" in fake.getvalue()
    plain = io.StringIO()  # not a terminal: never a bar
    monkeypatch.setattr("sys.stderr", plain)
    simulate_lcs(lcs, [Dc(1.0)], [0.0], 1.0, 1e-3, progress=True)
    assert plain.getvalue() == ""


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_lcs_package_does_not_import_netlist():
    import subprocess
    import sys

    code = "import sys, lcs.integrators.moreau.integrator, lcs.lcp; print('netlist' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "False"
