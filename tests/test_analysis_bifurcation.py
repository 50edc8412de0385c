"""Bifurcation sweeps (lcs.analysis.bifurcation) and continuation (lcs.analysis.continuation).

Known answers: the logistic map (period doubling at r = 3 and 1 + √6), a cubic map with an
S-shaped equilibrium curve (hysteresis between the folds at p = ±2/(3√3)), the delayed
logistic map (Neimark-Sacker at a = 2), a pitchfork (+1 multiplier at p = 1), a piecewise
linear map with a pattern (border collision at p = 0), and on a circuit the DCM boost whose
diode leaves discontinuous conduction near the ideal boundary D (1 - D)² = K.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from test_analysis_maps import buck_reference, netlists  # noqa: F401 - fixture
from test_analysis_orbits import delayed_logistic, logistic

from lcs.analysis.bifurcation import attractor_period, bifurcation_diagram
from lcs.analysis.continuation import continue_orbit
from lcs.analysis.maps import FunctionMap, Map, PatternSegment, SwitchingPattern
from netlist.studies.sweep import CircuitMapFactory
from pelcs.analysis_plots import plot_bifurcation
from pelcs.writers import write_bifurcation

# bifurcation diagrams (3.1 s): in the full suite, not the fast subset
pytestmark = pytest.mark.slow

# -- map factories (module level: picklable for the worker processes) ----------------------


def logistic_factory(r: float) -> FunctionMap:
    return FunctionMap(functools.partial(logistic, r=r), ("x",), param=r, param_name="r")


def cubic(x, p):
    """Relaxation towards the S-curve p + x - x³ = 0: bistable for |p| < 2/(3√3)."""
    return x + 0.3 * (p + x - x**3)


def cubic_factory(p: float) -> FunctionMap:
    return FunctionMap(functools.partial(cubic, p=p), ("x",), param=p)


def delayed_factory(a: float) -> FunctionMap:
    return FunctionMap(functools.partial(delayed_logistic, a=a), ("x", "y"), param=a)


def pitchfork(x, p):
    return p * x - x**3


def pitchfork_factory(p: float) -> FunctionMap:
    return FunctionMap(functools.partial(pitchfork, p=p), ("x",), param=p)


class BorderMap(Map):
    """x -> 0.5 x + p for x < 0, -0.5 x + p for x >= 0 ("switch on" while x >= 0).

    The fixed point crosses the border x = 0 at p = 0: the pattern changes and the
    multiplier jumps from 0.5 to -0.5 (no smooth bifurcation in between).
    """

    def __init__(self, p: float):
        self.p = p
        self.param = p
        self.param_name = "p"
        self.state_names = ("x",)

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        return np.where(x < 0, 0.5 * x + self.p, -0.5 * x + self.p)

    def pattern(self, x, k=1):
        on = bool(np.asarray(x)[0] >= 0)
        return SwitchingPattern(("S",), (), (PatternSegment(0.0, 1.0, (on,), ()),), 1.0)


def border_factory(p: float) -> BorderMap:
    return BorderMap(p)


# -- bifurcation diagrams -------------------------------------------------------------------


def test_logistic_diagram_fixed_initial_condition():
    r = np.linspace(2.8, 3.55, 31)
    d = bifurcation_diagram(logistic_factory, r, x0=[0.3], transient=2000, record=64,
                            workers=1, param_name="r")
    b = d.branches[0]
    assert b.direction == "fixed" and b.samples.shape == (31, 64, 1) and b.ok.all()
    periods = [attractor_period(s, 1e-6) for s in b.samples]
    for rv, k in zip(r, periods, strict=True):
        if rv < 2.99:
            assert k == 1
        elif 3.01 < rv < 1 + math.sqrt(6) - 0.01:
            assert k == 2
        elif 1 + math.sqrt(6) + 0.01 < rv < 3.54:
            assert k == 4
    # The period-1 branch is the fixed point 1 - 1/r.
    np.testing.assert_allclose(b.samples[r < 2.99, -1, 0], 1 - 1 / r[r < 2.99], atol=1e-9)


def test_parallel_sweep_equals_serial():
    r = np.linspace(2.9, 3.6, 24)
    kw = dict(x0=[0.3], transient=200, record=16, param_name="r")
    s1 = bifurcation_diagram(logistic_factory, r, workers=1, **kw)
    s2 = bifurcation_diagram(logistic_factory, r, workers=2, **kw)
    np.testing.assert_array_equal(s1.branches[0].samples, s2.branches[0].samples)
    f1 = bifurcation_diagram(cubic_factory, r - 3.25, follow=True,
                             directions=("up", "down"), workers=1, x0=[0.0], transient=200,
                             record=4)
    f2 = bifurcation_diagram(cubic_factory, r - 3.25, follow=True,
                             directions=("up", "down"), workers=2, x0=[0.0], transient=200,
                             record=4)
    for a, b in zip(f1.branches, f2.branches, strict=True):
        np.testing.assert_array_equal(a.samples, b.samples)


def test_follow_mode_shows_hysteresis(tmp_path):
    pfold = 2 / (3 * math.sqrt(3))
    p = np.linspace(-1, 1, 41)
    d = bifurcation_diagram(cubic_factory, p, x0=[-1.0], transient=300, record=3,
                            follow=True, directions=("up", "down"), workers=2)
    up, down = d.branch("up"), d.branch("down")
    np.testing.assert_array_equal(down.values, p[::-1])
    xu = dict(zip(up.values, up.samples[:, -1, 0], strict=True))
    xd = dict(zip(down.values, down.samples[:, -1, 0], strict=True))
    for pv in p:
        if abs(pv) < pfold - 0.03:
            # Up: still on the lower branch; down: still on the upper one.
            assert xu[pv] < 0 < xd[pv]
        elif abs(pv) > pfold + 0.03:
            assert xu[pv] == pytest.approx(xd[pv], abs=1e-9)
    # Fixed initial condition: no memory, the lower branch everywhere it exists.
    fixed = bifurcation_diagram(cubic_factory, p, x0=[-1.0], transient=300, record=3)
    assert (fixed.branches[0].samples[p < pfold - 0.03, -1, 0] < 0).all()
    # Chunks: each piece starts from x0 (documented), the first value of each piece as in
    # fixed mode.
    ch = bifurcation_diagram(cubic_factory, p, x0=[-1.0], transient=300, record=3,
                             follow=True, directions=("down",), chunks=2, workers=2)
    dn = ch.branch("down").samples[:, -1, 0]
    assert dn[20] > 0 > dn[21]  # the second piece restarts at p = -0.05 from x0 = -1
    # Outputs.
    write_bifurcation(d, tmp_path / "d.npz")
    write_bifurcation(d, tmp_path / "d.csv")
    plot_bifurcation(d, tmp_path / "d.png")
    z = np.load(tmp_path / "d.npz")
    np.testing.assert_array_equal(z["down_samples"], down.samples)
    assert list(z["directions"]) == ["up", "down"]
    lines = (tmp_path / "d.csv").read_text().splitlines()
    assert lines[0] == "direction,p,k,x" and len(lines) == 1 + 2 * 41 * 3
    assert (tmp_path / "d.png").stat().st_size > 5000


def test_failed_values_are_nan_and_follow_restarts():
    def_x0 = [0.3]
    # r = 5: the logistic map escapes to -inf (overflow -> MapError) from x0 = 0.3.
    r = np.array([2.5, 5.0, 2.6])
    with np.errstate(over="ignore", invalid="ignore"):
        d = bifurcation_diagram(logistic_factory, r, x0=def_x0, transient=2000, record=2,
                                follow=True, directions=("up",), workers=1)
    b = d.branch("up")
    assert list(b.ok) == [True, False, True]
    assert np.isnan(b.samples[1]).all() and b.messages[1]
    assert b.samples[2, -1, 0] == pytest.approx(1 - 1 / 2.6)
    assert any("failed" in n for n in d.notes)


def test_circuit_sweep(netlists):  # noqa: F811
    f = CircuitMapFactory(netlists["buck"], period="ts", param="duty")
    duty = np.linspace(0.3, 0.7, 5)
    d = bifurcation_diagram(f, duty, x0=[0.0, 0.0], transient=60, record=3,
                            probes=["v(out)", "i(D1)"], workers=2, param_name="duty")
    b = d.branches[0]
    assert d.probes == ("v(out)", "i(D1)") and d.state_names == ("i(L1)", "v(C1)")
    # Damped buck in CCM: the samples are the fixed point of the affine expm reference map.
    for k, dv in enumerate(duty):
        Phi, c = buck_reference(dv)
        x_ref = np.linalg.solve(np.eye(2) - Phi, c)
        assert b.samples[k, -1, 0] == pytest.approx(x_ref[1], abs=2e-3)
    assert (b.samples[:, :, 1] > 0).all()  # the diode conducts at t = kT (switch off)
    assert (np.abs(np.diff(b.samples[:, :, 0], axis=1)) < 1e-6).all()  # settled


# -- continuation ---------------------------------------------------------------------------


def test_continuation_locates_logistic_period_doublings():
    res = continue_orbit(logistic_factory, 2.5, 3.5, steps=10, x0=[0.5], tol=1e-6,
                         param_name="r")
    assert res.complete and [b.type for b in res.bifurcations] == ["flip"]
    b = res.bifurcations[0]
    assert b.param == pytest.approx(3.0, abs=1e-6) and b.located
    assert abs(b.bracket[1] - b.bracket[0]) <= 1e-6
    res2 = continue_orbit(logistic_factory, 3.2, 3.5, steps=6, x0=[0.5], order=2,
                          tol=1e-6)
    assert [b.type for b in res2.bifurcations] == ["flip"]
    assert res2.bifurcations[0].param == pytest.approx(1 + math.sqrt(6), abs=1e-6)
    # Continued backwards past its birth, the period-2 orbit collapses onto period 1.
    res3 = continue_orbit(logistic_factory, 3.2, 2.9, steps=6, x0=[0.5], order=2)
    assert not res3.complete and "collapsed" in res3.notes[0]
    d = res.to_dict()
    assert d["bifurcations"][0]["type"] == "flip" and len(d["branch"]) == 11


def test_continuation_neimark_sacker_and_fold():
    res = continue_orbit(delayed_factory, 1.5, 2.5, steps=8, x0=[0.4, 0.4], transient=0,
                         tol=1e-6)
    assert [b.type for b in res.bifurcations] == ["neimark-sacker"]
    assert res.bifurcations[0].param == pytest.approx(2.0, abs=1e-6)
    res = continue_orbit(pitchfork_factory, 0.5, 1.5, steps=8, x0=[0.0], transient=0,
                         tol=1e-6)
    assert [b.type for b in res.bifurcations] == ["fold"]
    assert res.bifurcations[0].param == pytest.approx(1.0, abs=1e-6)
    # Down the range: the same point, found from the other side.
    res = continue_orbit(pitchfork_factory, 1.5, 0.5, steps=8, x0=[0.0], transient=0,
                         tol=1e-6)
    assert res.bifurcations[0].param == pytest.approx(1.0, abs=1e-6)


def test_border_collision_with_multiplier_jump():
    res = continue_orbit(border_factory, -1.0, 1.0, steps=7, x0=[-2.0], transient=0,
                         tol=1e-7)
    # The multiplier jumps from 0.5 to -0.5: a border collision, not a flip.
    assert [b.type for b in res.bifurcations] == ["border"]
    assert res.bifurcations[0].param == pytest.approx(0.0, abs=1e-7)


def test_circuit_border_collision_dcm_to_ccm(netlists):  # noqa: F811
    """DCM boost, duty up: the diode stops leaving DCM near D (1 - D)² = K (small-ripple
    theory; the simulated boundary includes the output ripple and the 5 ns gate delay:
    measured 0.77261 for both h = 0.2 µs and 0.1 µs, theory 0.77244)."""
    from scipy.optimize import brentq

    K = 2 * 20e-6 / (50 * 20e-6)
    d_ideal = brentq(lambda D: D * (1 - D) ** 2 - K, 0.5, 0.95)
    f = CircuitMapFactory(netlists["boost_dcm"], period="ts", param="duty")
    res = continue_orbit(f, 0.74, 0.8, steps=3, tol=1e-4, x0=[0.0, 45.0], transient=0,
                         param_name="duty")
    assert res.complete
    assert [b.type for b in res.bifurcations] == ["border"]
    b = res.bifurcations[0]
    assert b.param == pytest.approx(d_ideal, abs=1e-3)
    assert "continuous conduction" in b.detail
    # DCM side: one zero multiplier; CCM side: none.
    assert min(abs(b.before.multipliers)) < 1e-6 < min(abs(b.after.multipliers))
