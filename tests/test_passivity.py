"""Passivity of hand-written circuit LCS (references: circuit energy, hand algebra)."""

from __future__ import annotations

import numpy as np
import pytest

from lcs.model import LCS
from lcs.model import ComplementarityPair as Pair
from lcs.theory.passivity import check_passivity, energy_matrix

cvxpy = pytest.importorskip("cvxpy")  # the general (SDP) search needs it


# ---------------------------------------------------------------------------------------------
# Hand-derived circuits. Conventions of docs/architecture.md: i(L) n+ -> n-, v(C) = v(n+) - v(n-);
# λ = diode current with w = reverse voltage, or λ = reverse voltage with w = diode current.


def boost_open(L=100e-6, C=470e-6, R=10.0) -> LCS:
    """Boost, switch open: Vin - L - sw; D1 sw -> out; C, R at out.

    λ = reverse voltage of D1 (v_out - v_sw), w = i(D1) = i(L1).
    L i' = Vin - v_sw = Vin - v_C + λ;  C v' = i - v/R.
    """
    return LCS(
        [[0, -1 / L], [1 / C, -1 / (R * C)]], [[1 / L], [0]], [[1, 0]], [[0]],
        [[1 / L], [0]], [[0]], ("i(L1)", "v(C1)"), (Pair("D1", "voltage"),), ("Vin",),
    )


def boost_closed(L=100e-6, C=470e-6, R=10.0) -> LCS:
    """Boost, switch closed: sw at ground; λ = i(D1), w = reverse voltage = v(C1)."""
    return LCS(
        [[0, 0], [0, -1 / (R * C)]], [[0], [1 / C]], [[0, 1]], [[0]],
        [[1 / L], [0]], [[0]], ("i(L1)", "v(C1)"), (Pair("D1"),), ("Vin",),
    )


def cuk_open(L1=200e-6, C1=10e-6, L2=200e-6, C2=100e-6, R=20.0) -> LCS:
    """Čuk, switch open. States i(L1) (Vin -> a), v(C1) (a - b), i(L2) (c -> b), v(C2) (c).

    D1 anode b, cathode ground; λ = reverse voltage = -v_b, w = i(D1) = i(L1) + i(L2).
    L1 i1' = Vin - vC1 + λ;  C1 vC1' = i1;  L2 i2' = vC2 + λ;  C2 vC2' = -i2 - vC2/R.
    """
    A = [[0, -1 / L1, 0, 0], [1 / C1, 0, 0, 0], [0, 0, 0, 1 / L2],
         [0, 0, -1 / C2, -1 / (R * C2)]]
    return LCS(A, [[1 / L1], [0], [1 / L2], [0]], [[1, 0, 1, 0]], [[0]],
               [[1 / L1], [0], [0], [0]], [[0]],
               ("i(L1)", "v(C1)", "i(L2)", "v(C2)"), (Pair("D1", "voltage"),), ("Vin",))


def bridge_tank(L=1e-3, C=1e-6, Co=100e-6, R=50.0, Rg=1e3) -> LCS:
    """Four-diode bridge across a parallel LC tank (a to ground), DC side Co || R from p to
    n, Rg from n to ground. λ = the four diode currents (D1 a->p, D2 0->p, D3 n->a, D4 n->0).

    v_n = Rg (λ1 + λ2 - λ3 - λ4), so D = Rg a a' with a = (1, 1, -1, -1): singular, nonzero.
    R = inf gives the lossless tank.
    """
    g = 0.0 if np.isinf(R) else 1 / (R * Co)
    A = [[0, 1 / L, 0], [-1 / C, 0, 0], [0, 0, -g]]
    B = [[0, 0, 0, 0], [-1 / C, 0, 1 / C, 0], [1 / Co, 1 / Co, 0, 0]]
    Cm = [[0, -1, 1], [0, 0, 1], [0, 1, 0], [0, 0, 0]]
    a = np.array([1.0, 1.0, -1.0, -1.0])
    return LCS(A, B, Cm, Rg * np.outer(a, a), np.zeros((3, 0)), np.zeros((4, 0)),
               ("i(L1)", "v(C1)", "v(Co)"), tuple(Pair(f"D{i}") for i in range(1, 5)), ())


def kyp_max_eig(lcs: LCS, K: np.ndarray) -> float:
    """Largest eigenvalue of the KYP matrix, in the metric of K (independent re-implementation),
    relative to the size of its blocks."""
    A, B, C, D = lcs.A, lcs.B, lcs.C, lcs.D
    w, V = np.linalg.eigh(K)
    assert w[0] > 0
    Kh = V @ np.diag(np.sqrt(w)) @ V.T
    Khi = V @ np.diag(1 / np.sqrt(w)) @ V.T
    Ah = Kh @ A @ Khi
    top = np.hstack([Ah.T + Ah, Kh @ B - Khi @ C.T])
    bot = np.hstack([B.T @ Kh - C @ Khi, -(D + D.T)])
    M = np.vstack([top, bot])
    scale = (2 * np.linalg.norm(Ah, 2) + np.linalg.norm(Kh @ B, 2)
             + np.linalg.norm(Khi @ C.T, 2) + 2 * np.linalg.norm(D, 2))
    return float(np.linalg.eigvalsh(0.5 * (M + M.T))[-1] / scale)


def transformed(lcs: LCS, T: np.ndarray) -> LCS:
    """New state z = T x: A' = T A T^-1, B' = T B, C' = C T^-1, E' = T E."""
    Ti = np.linalg.inv(T)
    names = tuple(f"z{i}" for i in range(lcs.n))
    return LCS(T @ lcs.A @ Ti, T @ lcs.B, lcs.C @ Ti, lcs.D, T @ lcs.E, lcs.F,
               names, lcs.pairs, lcs.inputs)


# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("builder, energy", [
    (boost_open, energy_matrix([[100e-6]], [470e-6])),
    (boost_closed, energy_matrix([[100e-6]], [470e-6])),
    (cuk_open, np.diag([200e-6, 10e-6, 200e-6, 100e-6])),
    (bridge_tank, np.diag([1e-3, 1e-6, 100e-6])),
])
def test_energy_matrix_certifies_rlc_modes(builder, energy):
    lcs = builder()
    rep = check_passivity(lcs, energy=energy)
    assert rep.passive and rep.method == "energy"
    np.testing.assert_allclose(rep.K, energy)
    assert rep.names == lcs.states
    # Independent checks: K B = C' on the pairs with D = 0 rows, and the KYP eigenvalue.
    assert kyp_max_eig(lcs, energy) < 1e-12


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("builder", [boost_open, boost_closed, cuk_open, bridge_tank])
def test_general_solve_finds_certificate(builder):
    lcs = builder()
    rep = check_passivity(lcs)
    assert rep.passive and rep.method == "lmi", rep.reason
    assert np.linalg.eigvalsh(rep.K)[0] > 0
    assert kyp_max_eig(lcs, rep.K) < 1e-7


def test_boost_open_certificate_is_the_energy():
    # K B = C' forces K[:, 0] = (L, 0); A'K + KA <= 0 with a zero (1,1) entry forces
    # K22 = C: the certificate is unique and must be the stored energy.
    rep = check_passivity(boost_open())
    np.testing.assert_allclose(rep.K, np.diag([100e-6, 470e-6]), rtol=1e-6, atol=1e-12)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_similarity_transform_moves_certificate(seed):
    rng = np.random.default_rng(seed)
    base = boost_open()
    T = rng.normal(size=(2, 2)) + 2 * np.eye(2)
    lcs = transformed(base, T)
    rep = check_passivity(lcs)
    assert rep.passive, rep.reason
    Ti = np.linalg.inv(T)
    expected = Ti.T @ np.diag([100e-6, 470e-6]) @ Ti  # unique certificate, transformed
    np.testing.assert_allclose(rep.K, expected, rtol=1e-5, atol=1e-9 * np.abs(expected).max())


def test_similarity_transform_cuk_certificate_valid():
    rng = np.random.default_rng(7)
    T = rng.normal(size=(4, 4)) + 3 * np.eye(4)
    lcs = transformed(cuk_open(), T)
    rep = check_passivity(lcs)
    assert rep.passive, rep.reason
    assert kyp_max_eig(lcs, rep.K) < 1e-7
    # The energy in the new coordinates is a certificate too.
    Ti = np.linalg.inv(T)
    energy_z = Ti.T @ np.diag([200e-6, 10e-6, 200e-6, 100e-6]) @ Ti
    assert check_passivity(lcs, energy=energy_z, search=False).passive


def test_lossless_tank_with_bridge_passive_zero_margin():
    lcs = bridge_tank(R=np.inf)
    rep = check_passivity(lcs)
    assert rep.passive, rep.reason
    assert abs(rep.margin) < 1e-7  # lossless and D + D' singular: no strict margin
    assert kyp_max_eig(lcs, rep.K) < 1e-7


def test_lc_tank_single_diode_marginally_stable():
    # L || C tank, D1 from tank node to ground (λ = current, w = -v_C); lossless, A has ±jω.
    L, C = 1e-3, 1e-6
    lcs = LCS([[0, 1 / L], [-1 / C, 0]], [[0], [-1 / C]], [[0, -1]], [[0]], np.zeros((2, 0)),
              np.zeros((1, 0)), ("i(L1)", "v(C1)"), (Pair("D1"),), ())
    rep = check_passivity(lcs)
    assert rep.passive, rep.reason
    np.testing.assert_allclose(rep.K, np.diag([L, C]), rtol=1e-6, atol=1e-15)


def test_units_do_not_matter():
    # Same boost in extreme component values: nH and F.
    lcs = boost_open(L=1e-9, C=1.0, R=1e-3)
    rep = check_passivity(lcs)
    assert rep.passive, rep.reason
    np.testing.assert_allclose(rep.K, np.diag([1e-9, 1.0]), rtol=1e-5, atol=1e-15)


def test_negative_resistance_not_passive():
    lcs = boost_open(R=-10.0)
    rep = check_passivity(lcs, energy=energy_matrix([[100e-6]], [470e-6]))
    assert not rep.passive
    assert rep.K is None
    assert "unstable eigenvalue" in rep.reason and "v(C1)" in rep.reason
    assert any(a.startswith("energy matrix fails") for a in rep.attempts)


def test_negative_resistance_stable_but_not_passive():
    # A resistor -R in series with a larger positive one keeps A stable when the net is
    # positive; here the negative resistor sits in series with the diode: D = -R < 0.
    lcs = LCS([[-1.0]], [[1.0]], [[1.0]], [[-5.0]], np.zeros((1, 0)), np.zeros((1, 0)),
              ("v(C1)",), (Pair("D1"),), ())
    rep = check_passivity(lcs)
    assert not rep.passive
    assert "D + D' is not positive semidefinite" in rep.reason and "D1" in rep.reason


def test_active_vcvs_not_passive():
    # C1 with a bleed resistor; an ideal amplifier drives the anode of D1 at k v(C1) and
    # charges C2 through D1 without loading C1: B = [0, 1/C2], w = v2 - k v1.
    C1 = C2 = 1e-6
    lcs = LCS([[-1 / (1e3 * C1), 0], [0, 0]], [[0], [1 / C2]], [[-3.0, 1.0]], [[0]],
              np.zeros((2, 0)), np.zeros((1, 0)), ("v(C1)", "v(C2)"), (Pair("D1"),), ())
    energy = np.diag([C1, C2])
    rep = check_passivity(lcs, energy=energy)
    assert not rep.passive, rep.reason
    assert "v(C2)" in rep.reason or "v(C1)" in rep.reason
    # The transfer function 1/(C2 s) is positive real: only the state-space test sees it.
    assert rep.method == "lmi"


def test_active_cccs_negative_gain_not_passive():
    # D1 current leaves C1 and a CCCS pulls 3x that current out of C2: C B < 0.
    C1 = C2 = 1e-6
    lcs = LCS(np.zeros((2, 2)), [[-1 / C1], [-3 / C2]], [[-1.0, 1.0]], [[0]],
              np.zeros((2, 0)), np.zeros((1, 0)), ("v(C1)", "v(C2)"), (Pair("D1"),), ())
    rep = check_passivity(lcs)
    assert not rep.passive
    assert "C B" in rep.reason and "D1" in rep.reason


def test_jordan_block_not_passive():
    lcs = LCS([[0, 1], [0, 0]], [[0], [0]], [[0, 0]], [[1.0]], np.zeros((2, 0)),
              np.zeros((1, 0)), ("x1", "x2"), (Pair("D1"),), ())
    rep = check_passivity(lcs)
    assert not rep.passive
    assert rep.reason


def test_double_integrator_not_positive_real():
    lcs = LCS([[0, 1], [0, 0]], [[0], [1]], [[1, 0]], [[0]], np.zeros((2, 0)),
              np.zeros((1, 0)), ("x1", "x2"), (Pair("D1"),), ())
    rep = check_passivity(lcs)
    assert not rep.passive
    assert "positive real" in rep.reason


def test_wrong_candidate_falls_back_to_search():
    lcs = boost_open()
    rep = check_passivity(lcs, K=np.eye(2))
    assert rep.passive and rep.method == "lmi"
    assert rep.attempts[0].startswith("given matrix fails")
    rep2 = check_passivity(lcs, K=np.eye(2), search=False)
    assert not rep2.passive


def test_uncontrollable_isolated_state_passive():
    # A capacitor connected to nothing (x' = 0) next to a boost: any positive weight works.
    b = boost_open()
    A = np.zeros((3, 3))
    A[:2, :2] = b.A
    lcs = LCS(A, np.vstack([b.B, [[0]]]), np.hstack([b.C, [[0]]]), b.D,
              np.vstack([b.E, [[0]]]), b.F, b.states + ("v(C9)",), b.pairs, b.inputs)
    rep = check_passivity(lcs)
    assert rep.passive, rep.reason
    assert kyp_max_eig(lcs, rep.K) < 1e-7


def test_coupled_inductors_energy():
    # Two coupled inductors (M = 0.5 mH) each feeding a capacitor through its own diode;
    # energy K = blkdiag([[L1, M], [M, L2]], C1, C2). λ = reverse voltage of D_k (in series with
    # L_k), w = i(L_k). Inductor voltages: Lmat [i1', i2']' = [Vin - v1 + λ1, -v2 + λ2].
    L1, L2, M, C1, C2, R = 1e-3, 2e-3, 0.5e-3, 1e-5, 2e-5, 10.0
    Lm = np.array([[L1, M], [M, L2]])
    Li = np.linalg.inv(Lm)
    A = np.zeros((4, 4))
    A[:2, 2:] = -Li
    A[2, 0], A[3, 1] = 1 / C1, 1 / C2
    A[2, 2], A[3, 3] = -1 / (R * C1), -1 / (R * C2)
    B = np.zeros((4, 2))
    B[:2, :] = Li
    Cm = np.zeros((2, 4))
    Cm[0, 0] = Cm[1, 1] = 1
    E = np.zeros((4, 1))
    E[:2, 0] = Li[:, 0]
    lcs = LCS(A, B, Cm, np.zeros((2, 2)), E, np.zeros((2, 1)),
              ("i(L1)", "i(L2)", "v(C1)", "v(C2)"),
              (Pair("D1", "voltage"), Pair("D2", "voltage")), ("Vin",))
    energy = energy_matrix(Lm, [C1, C2])
    assert check_passivity(lcs, energy=energy).method == "energy"
    rep = check_passivity(lcs)
    assert rep.passive
    np.testing.assert_allclose(rep.K, energy, rtol=1e-5, atol=1e-12)


# ---------------------------------------------------------------------------------------------
# Integration: every mode of every bundled converter netlist, as netlist.formulation builds it.

_NETLISTS = sorted(
    p for p in __import__("pathlib").Path(__file__).resolve().parents[1].glob(
        "converters/netlists/*.cir")
)


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("path", _NETLISTS, ids=lambda p: p.stem)
def test_bundled_converters_passive(path):
    parser = pytest.importorskip("netlist.parser")
    formulation = pytest.importorskip("netlist.formulation")
    circuit = parser.parse_file(path)
    slcs = formulation.formulate(circuit)
    energy = formulation.storage_matrix(circuit)
    for key in slcs.all_keys():
        lcs = slcs.mode(key)
        rep = check_passivity(lcs, energy=energy)
        assert rep.passive and rep.method == "energy", (key, rep.reason)
        assert kyp_max_eig(lcs, energy) < 1e-9
        general = check_passivity(lcs)
        assert general.passive, (key, general.reason)
        assert kyp_max_eig(lcs, general.K) < 1e-7
