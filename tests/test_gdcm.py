"""GDCM regions against hand derivations (boost, Čuk, relative degree two, sets of diodes)
and interval detection on synthetic and simulated trajectories."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import brentq

from lcs.model import LCS
from lcs.model import ComplementarityPair as Pair
from lcs.theory.gdcm import detect_gdcm_intervals, gdcm_condition, gdcm_conditions

L, C, R = 100e-6, 470e-6, 10.0


def boost_open(extra_current_source=False) -> LCS:
    """Boost, switch open: λ = reverse voltage of D1, w = i(D1) = i(L1).

    L i' = Vin - v + λ, C v' = i - v/R (+ Is/C with an optional current source into C).
    """
    E = [[1 / L, 0], [0, 1 / C]] if extra_current_source else [[1 / L], [0]]
    F = [[0, 0]] if extra_current_source else [[0]]
    inputs = ("Vin", "Is") if extra_current_source else ("Vin",)
    return LCS([[0, -1 / L], [1 / C, -1 / (R * C)]], [[1 / L], [0]], [[1, 0]], [[0]], E, F,
               ("i(L1)", "v(C1)"), (Pair("D1", "voltage"),), inputs)


def test_boost_region_by_hand():
    (g,) = gdcm_conditions(boost_open())
    assert g.pairs == ("D1",) and g.relative_degree == 1 and g.unique
    # y = i(L1); Γ = -(C A x + C E u)/(C B) = -((-v + Vin)/L) L = v - Vin.
    assert g.y[0].as_dict() == {"i(L1)": 1.0}
    gam = g.gamma[0].as_dict(tol=1e-12)
    assert gam == pytest.approx({"v(C1)": 1.0, "Vin": -1.0})
    np.testing.assert_allclose(g.markov, [[1 / L]])
    # Reduced dynamics: i' = 0, v' = (i - v/R)/C.
    np.testing.assert_allclose(g.A_red, [[0, 0], [1 / C, -1 / (R * C)]], atol=1e-9)
    np.testing.assert_allclose(g.E_red, [[0], [0]], atol=1e-12)
    assert g.dimension_loss == 1
    text = g.describe()
    assert "w(D1) = i(L1) = 0" in text and "λ(D1) = v(C1) - Vin > 0" in text


def test_boost_classification():
    (g,) = gdcm_conditions(boost_open())
    assert g.classify([0.0, 20.0], [12.0]) == "gdcm"
    assert g.contains([0.0, 20.0], [12.0])
    assert g.classify([0.0, 10.0], [12.0]) == "leaving"  # v < Vin: the inductor charges
    assert g.classify([1.0, 20.0], [12.0]) == "off-manifold"
    # On Γ = 0 (v = Vin) the load discharges C: Γ' = v' = -v/(RC) < 0, DCM ends.
    assert g.classify([0.0, 12.0], [12.0]) == "exiting"
    np.testing.assert_allclose(g.gamma_rate[0]([0.0, 12.0], [12.0]), -12.0 / (R * C))


def test_boost_boundary_entering_with_current_source():
    (g,) = gdcm_conditions(boost_open(extra_current_source=True))
    # Γ = v - Vin still; Γ' = v' = (Is - v/R)/C: positive when Is > v/R.
    assert g.classify([0.0, 12.0], [12.0, 5.0]) == "entering"
    assert g.classify([0.0, 12.0], [12.0, 0.1]) == "exiting"
    assert g.classify([0.0, 12.0], [12.0, 1.2]) == "grazing"  # Is = v/R exactly


def cuk_open(L1=200e-6, C1=10e-6, L2=300e-6, C2=100e-6, RL=20.0) -> LCS:
    """Čuk, switch open (see tests/test_passivity.py); w = i(L1) + i(L2), λ = -v_b."""
    A = [[0, -1 / L1, 0, 0], [1 / C1, 0, 0, 0], [0, 0, 0, 1 / L2],
         [0, 0, -1 / C2, -1 / (RL * C2)]]
    return LCS(A, [[1 / L1], [0], [1 / L2], [0]], [[1, 0, 1, 0]], [[0]],
               [[1 / L1], [0], [0], [0]], [[0]],
               ("i(L1)", "v(C1)", "i(L2)", "v(C2)"), (Pair("D1", "voltage"),), ("Vin",))


def test_cuk_region_by_hand():
    L1, C1, L2, C2, RL = 200e-6, 10e-6, 300e-6, 100e-6, 20.0
    (g,) = gdcm_conditions(cuk_open(L1, C1, L2, C2, RL))
    assert g.y[0].as_dict() == {"i(L1)": 1.0, "i(L2)": 1.0}
    # Γ = (L2 (v(C1) - Vin) - L1 v(C2)) / (L1 + L2)
    expected = {"v(C1)": L2 / (L1 + L2), "v(C2)": -L1 / (L1 + L2), "Vin": -L2 / (L1 + L2)}
    assert g.gamma[0].as_dict(tol=1e-12) == pytest.approx(expected)
    # In DCM the inductors act in series: i1' = -i2' = (Vin - v(C1) - v(C2)) / (L1 + L2).
    Ls = L1 + L2
    A_red = [[0, -1 / Ls, 0, -1 / Ls], [1 / C1, 0, 0, 0], [0, 1 / Ls, 0, 1 / Ls],
             [0, 0, -1 / C2, -1 / (RL * C2)]]
    np.testing.assert_allclose(g.A_red, A_red, rtol=1e-12, atol=1e-6)
    np.testing.assert_allclose(g.E_red, [[1 / Ls], [0], [-1 / Ls], [0]], rtol=1e-12)
    # DCM operating point: v(C1) = Vin - v(C2) with v(C2) < 0: Γ = -v(C2) = |Vout|.
    x = [0.3, 12.0 + 5.0, -0.3, -5.0]
    assert g.classify(x, [12.0]) == "gdcm"
    assert g.gamma[0](x, [12.0]) == pytest.approx(5.0)


def test_relative_degree_two():
    # Unilateral contact: x1' = x2, x2' = λ + u (u = gravity), w = x1 >= 0.
    lcs = LCS([[0, 1], [0, 0]], [[0], [1]], [[1, 0]], [[0]], [[0], [1]], [[0]],
              ("x1", "x2"), (Pair("D1"),), ("g",))
    (g,) = gdcm_conditions(lcs)
    assert g.relative_degree == 2 and g.dimension_loss == 2 and g.unique
    assert [f.as_dict() for f in g.y] == [{"x1": 1.0}, {"x2": 1.0}]
    assert [f.label for f in g.y] == ["w(D1)", "w(D1)'"]
    assert g.gamma[0].as_dict() == {"g": -1.0}  # resting force = -g
    np.testing.assert_allclose(g.markov, [[1.0]])
    np.testing.assert_allclose(g.A_red, [[0, 1], [0, 0]])
    np.testing.assert_allclose(g.E_red, [[0], [0]])
    assert g.classify([0, 0], [-9.81]) == "gdcm"
    assert g.classify([0, 0], [1.0]) == "leaving"
    assert g.classify([0, 0.5], [-9.81]) == "off-manifold"


def test_negative_markov_parameter_not_unique():
    lcs = LCS([[0, 1], [0, 0]], [[0], [-1]], [[1, 0]], [[0]], [[0], [1]], [[0]],
              ("x1", "x2"), (Pair("D1"),), ("g",))
    (g,) = gdcm_conditions(lcs)
    assert g.relative_degree == 2 and not g.unique
    assert g.gamma[0].as_dict() == {"g": 1.0}


def interleaved_boost(L1=100e-6, L2=150e-6) -> LCS:
    """Two inductors from Vin into one capacitor through D1, D2 (both switches open).

    λ_k = reverse voltage of D_k, w_k = i(L_k): L_k i_k' = Vin - v + λ_k, C v' = i1 + i2 - v/R.
    """
    A = [[0, 0, -1 / L1], [0, 0, -1 / L2], [1 / C, 1 / C, -1 / (R * C)]]
    B = [[1 / L1, 0], [0, 1 / L2], [0, 0]]
    return LCS(A, B, [[1, 0, 0], [0, 1, 0]], np.zeros((2, 2)), [[1 / L1], [1 / L2], [0]],
               [[0], [0]], ("i(L1)", "i(L2)", "v(C1)"),
               (Pair("D1", "voltage"), Pair("D2", "voltage")), ("Vin",))


def test_set_of_two_diodes_by_hand():
    L1, L2 = 100e-6, 150e-6
    g = gdcm_condition(interleaved_boost(L1, L2), ["D1", "d2"])
    assert g.pairs == ("D1", "D2") and g.relative_degree == 1 and g.unique
    np.testing.assert_allclose(g.markov, np.diag([1 / L1, 1 / L2]))
    for f in g.gamma:
        assert f.as_dict(tol=1e-12) == pytest.approx({"v(C1)": 1.0, "Vin": -1.0})
    np.testing.assert_allclose(g.A_red, [[0, 0, 0], [0, 0, 0], [1 / C, 1 / C, -1 / (R * C)]],
                               atol=1e-9)
    assert g.dimension_loss == 2 and g.others == ()


def test_single_diode_of_two_has_other_pair_condition():
    conds = gdcm_conditions(interleaved_boost())
    assert [c.pairs for c in conds] == [("D1",), ("D2",)]
    g1 = conds[0]
    (other,) = g1.others
    assert other.label == "w(D2)" and other.as_dict() == {"i(L2)": 1.0}
    assert g1.classify([0.0, 2.0, 20.0], [12.0]) == "gdcm"
    assert g1.classify([0.0, -2.0, 20.0], [12.0]) == "other-pair-violated"


def test_singular_set_rejected():
    # Two identical diodes in parallel: C_J B_J singular.
    lcs = LCS([[0, -1 / L], [1 / C, -1 / (R * C)]], [[1 / L, 1 / L], [0, 0]],
              [[1, 0], [1, 0]], np.zeros((2, 2)), [[1 / L], [0]], [[0], [0]],
              ("i(L1)", "v(C1)"), (Pair("D1", "voltage"), Pair("D2", "voltage")), ("Vin",))
    with pytest.raises(ValueError, match="singular"):
        gdcm_condition(lcs, ["D1", "D2"])


def test_pairs_with_feedthrough_skipped():
    lcs = LCS([[-1.0]], [[1.0]], [[1.0]], [[2.0]], [[0.0]], [[0.0]], ("x",), (Pair("D1"),),
              ("u",))
    assert gdcm_conditions(lcs) == []
    with pytest.raises(ValueError, match="D is not zero"):
        gdcm_condition(lcs, ["D1"])
    with pytest.raises(KeyError):
        gdcm_condition(lcs, ["D7"])


# ---------------------------------------------------------------------------------------------
# Detection


def test_detect_synthetic_intervals():
    t = np.arange(100) * 1e-6
    w = np.ones((100, 2))
    lam = np.zeros((100, 2))
    # pair 0: GDCM on samples 10..20 and 30..40 with a dropout at 35
    for a, b in [(10, 20), (30, 40)]:
        w[a:b + 1, 0] = 0.0
        lam[a:b + 1, 0] = 3.0
    w[35, 0], lam[35, 0] = 0.5, 0.0
    # pair 1: from the start to sample 5, and from 90 to the end
    for a, b in [(0, 5), (90, 99)]:
        w[a:b + 1, 1] = 1e-12
        lam[a:b + 1, 1] = 2.0
    ivs = detect_gdcm_intervals(t, w, lam, 1e-9, names=["D1", "D2"])
    got = [(iv.pair, iv.i_start, iv.i_end, iv.occurrence) for iv in ivs]
    assert got == [("D2", 0, 5, 1), ("D1", 10, 20, 1), ("D1", 30, 34, 2), ("D1", 36, 40, 3),
                   ("D2", 90, 99, 2)]
    assert ivs[0].open_start and not ivs[0].open_end and ivs[-1].open_end
    assert ivs[1].t_start == pytest.approx(10e-6) and ivs[1].duration == pytest.approx(10e-6)
    merged = detect_gdcm_intervals(t, w, lam, 1e-9, names=["D1", "D2"], merge_gap=2.5e-6)
    d1 = [iv for iv in merged if iv.pair == "D1"]
    assert [(iv.i_start, iv.i_end, iv.reentry_count) for iv in d1] == [(10, 20, 0), (30, 40, 1)]
    # λ must be positive: w = 0 with λ = 0 is not GDCM
    lam2 = lam.copy()
    lam2[10:21, 0] = 0.0
    assert all(iv.i_start != 10 for iv in detect_gdcm_intervals(t, w, lam2, 1e-9))
    # separate tolerances (w_tol, lam_tol)
    assert detect_gdcm_intervals(t, w, lam, (1e-9, 2.5)) == [
        iv for iv in detect_gdcm_intervals(t, w, lam, 1e-9) if iv.index == 0]


def test_detect_on_simulated_boost_dcm():
    # Exact piecewise-linear simulation of the boost with the switch open from i(L) = 2 A,
    # v(C) = 20 V, Vin = 12 V: the diode conducts (λ = 0, w = i) until i hits zero at t1
    # (root of the free solution), then DCM (w = 0, λ = v - Vin > 0) with i frozen.
    lcs = boost_open()
    u = np.array([12.0])
    x0 = np.array([2.0, 20.0])
    Aaug = np.zeros((3, 3))
    Aaug[:2, :2] = lcs.A
    Aaug[:2, 2] = lcs.E @ u

    def free(t):
        return (sla.expm(Aaug * t) @ np.append(x0, 1.0))[:2]

    t1 = brentq(lambda s: free(s)[0], 1e-9, 1e-4)  # i' = (12 - 20)/L: about 25 µs
    (g,) = gdcm_conditions(lcs)
    t = np.linspace(0, 2e-3, 2001)
    w, lam = np.zeros(t.size), np.zeros(t.size)
    x1 = free(t1)
    x1[0] = 0.0
    Ared_aug = np.zeros((3, 3))
    Ared_aug[:2, :2] = g.A_red
    Ared_aug[:2, 2] = g.E_red @ u
    for k, tk in enumerate(t):
        if tk < t1:
            x = free(tk)
            w[k], lam[k] = x[0], 0.0
        else:
            x = (sla.expm(Ared_aug * (tk - t1)) @ np.append(x1, 1.0))[:2]
            w[k], lam[k] = x[0], x[1] - u[0]
    assert np.all(lam[t >= t1] > 0)  # v(C) stays above Vin over this window
    (iv,) = detect_gdcm_intervals(t, w, lam, 1e-9, names=["D1"])
    assert iv.pair == "D1" and iv.open_end and not iv.open_start
    assert t[iv.i_start] >= t1 and t[iv.i_start] - t1 < t[1] - t[0]
