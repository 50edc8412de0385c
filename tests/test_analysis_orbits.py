"""Newton shooting and Floquet multipliers (lcs.analysis.orbits).

References: closed-form orbits of the logistic and delayed logistic maps, and the affine
stroboscopic map of the CCM boost built with scipy.linalg.expm (test_analysis_maps).
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest
from test_analysis_maps import boost_reference, netlists  # noqa: F401 - fixture

from lcs.analysis.maps import FunctionMap
from lcs.analysis.orbits import classify_multipliers, find_orbit, jacobian, multiplier_counts
from netlist.studies.sweep import CircuitMapFactory


def logistic(x, r):
    return r * x * (1 - x)


def logistic_map(r: float) -> FunctionMap:
    return FunctionMap(functools.partial(logistic, r=r), ("x",), param=r, param_name="r")


def delayed_logistic(v, a):
    x, y = v
    return np.array([y, a * y * (1 - x)])


def test_logistic_fixed_point_and_period_two():
    r = 2.8
    o = find_orbit(logistic_map(r), [0.6])
    assert o.converged
    assert o.x[0] == pytest.approx(1 - 1 / r, abs=1e-12)
    assert o.multipliers[0].real == pytest.approx(2 - r, abs=1e-8)
    assert o.stability == "stable" and o.pattern is None
    r = 3.3
    o2 = find_orbit(logistic_map(r), [0.5], order=2, transient=50)
    # x1,2 = (r + 1 ± sqrt((r - 3)(r + 1))) / (2 r); multiplier -r^2 + 2 r + 4.
    s = math.sqrt((r - 3) * (r + 1))
    pts = sorted(o2.points[:, 0])
    assert pts == pytest.approx(sorted([(r + 1 - s) / (2 * r), (r + 1 + s) / (2 * r)]),
                                abs=1e-10)
    assert o2.multipliers[0].real == pytest.approx(-r * r + 2 * r + 4, abs=1e-7)
    # The period-1 orbit still exists, unstable through a flip.
    o1 = find_orbit(logistic_map(r), [0.7])
    assert o1.stability == "unstable (flip)" and not o1.stable


def test_delayed_logistic_complex_multipliers():
    a = 2.2
    m = FunctionMap(functools.partial(delayed_logistic, a=a), ("x", "y"), param=a)
    o = find_orbit(m, [0.5, 0.5])
    xs = 1 - 1 / a
    np.testing.assert_allclose(o.x, [xs, xs], atol=1e-12)
    # Jacobian [[0, 1], [-a y, a (1 - x)]] at the fixed point: det = a - 1, trace = 1.
    assert abs(o.multipliers[0]) == pytest.approx(math.sqrt(a - 1), rel=1e-7)
    assert o.multipliers[0].imag != 0
    assert o.stability == "unstable (neimark-sacker)"
    assert multiplier_counts(o.multipliers) == {"flip": 0, "fold": 0, "neimark-sacker": 2}


def test_classification_helpers():
    assert classify_multipliers([0.5, -0.9]) == "stable"
    assert classify_multipliers([1.0, 0.2]) == "critical"
    assert classify_multipliers([-1.5, 1.2]) == "unstable (flip, fold)"
    J = jacobian(lambda x: np.array([x[0] ** 2, x[0] * x[1]]), np.array([2.0, 3.0]),
                 np.array([1.0, 1.0]))
    np.testing.assert_allclose(J, [[4, 0], [3, 2]], atol=1e-8)


@pytest.mark.parametrize("h", [0.2e-6, 0.1e-6])
def test_boost_orbit_matches_expm_reference(netlists, h):  # noqa: F811
    """Fixed point and multipliers of Newton shooting + finite differences against
    (I - Φ)^-1 c and eig(Φ); errors O(h²) (θ = 1/2, no active diode multiplier in CCM)."""
    Phi, c = boost_reference()
    x_ref = np.linalg.solve(np.eye(2) - Phi, c)
    mu_ref = np.sort_complex(np.linalg.eigvals(Phi))
    m = CircuitMapFactory(netlists["boost"], period="ts", step=h)()
    # From a state in continuous conduction the map is affine: Newton with finite
    # differences needs two steps. (From the netlist's state at rest, i(L1) = 0, the first
    # period is discontinuous and the count depends on round-off.)
    o = find_orbit(m, [1.5, 22.0])
    assert o.converged and o.iterations <= 2  # the map is affine
    mu = np.sort_complex(o.multipliers)
    # Measured: 6.0e-7 A / 4.0e-6 V and 3.3e-8 in μ at h = 0.2 µs; /4 at 0.1 µs.
    scale = (h / 0.2e-6) ** 2
    np.testing.assert_allclose(o.x, x_ref, atol=1.2e-5 * scale)
    np.testing.assert_allclose(mu, mu_ref, atol=1e-7 * scale)
    assert o.stability == "stable"
    assert o.pattern is not None and len(o.pattern.signature) == 2
    d = o.to_dict()
    assert d["states"] == ["i(L1)", "v(C1)"] and len(d["multipliers"][0]) == 2


def test_boost_orbit_error_converges_at_second_order(netlists):  # noqa: F811
    Phi, c = boost_reference()
    x_ref = np.linalg.solve(np.eye(2) - Phi, c)
    mu_ref = np.sort_complex(np.linalg.eigvals(Phi))
    ex, emu = [], []
    for h in (0.4e-6, 0.2e-6, 0.1e-6):
        o = find_orbit(CircuitMapFactory(netlists["boost"], period="ts", step=h)(),
                       [1.8, 24.0], pattern=False)
        ex.append(np.max(np.abs(o.x - x_ref)))
        emu.append(np.max(np.abs(np.sort_complex(o.multipliers) - mu_ref)))
    for e in (ex, emu):
        assert e[0] / e[1] == pytest.approx(4, rel=0.2)
        assert e[1] / e[2] == pytest.approx(4, rel=0.2)


def test_dcm_orbit_has_a_zero_multiplier(netlists):  # noqa: F811
    """In DCM the inductor current is reset to 0 every period: one multiplier is 0."""
    m = CircuitMapFactory(netlists["boost_dcm"], period="ts")()
    o = find_orbit(m, [0.0, 20.0])
    assert o.converged
    assert abs(o.x[0]) < 1e-9
    assert abs(o.multipliers[-1]) < 1e-6 and 0.9 < abs(o.multipliers[0]) < 1
    # Ideal DCM conversion ratio M = (1 + sqrt(1 + 4 D² / K)) / 2, K = 2 L / (R T).
    K = 2 * 20e-6 / (50 * 20e-6)
    M = (1 + math.sqrt(1 + 4 * 0.3**2 / K)) / 2
    assert o.x[1] == pytest.approx(12 * M, rel=0.02)


def test_newton_reports_non_convergence():
    # x -> x + 1 has no fixed point.
    m = FunctionMap(lambda x: x + 1.0, ("x",))
    o = find_orbit(m, [0.0], max_iter=5, pattern=False)
    assert not o.converged and any("did not converge" in n for n in o.notes)
    assert o.to_dict()["multipliers"] is None
    with pytest.raises(ValueError):
        find_orbit(m, [0.0], order=0)
