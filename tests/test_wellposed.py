"""Well-posedness, consistent states and state jumps (references: charge conservation and
energy balances worked out by hand)."""

from __future__ import annotations

import numpy as np
import pytest

from lcs.model import LCS
from lcs.model import ComplementarityPair as Pair
from lcs.theory.passivity import check_passivity
from lcs.theory.wellposed import (
    check_wellposedness,
    consistent_set,
    is_consistent,
    sol_cone_rays,
    state_jump,
)

pytest.importorskip("cvxpy")


def two_caps(C1=2e-6, C2=3e-6) -> LCS:
    """C1 (node 1) -> D1 -> C2 (node 2), both to ground. λ = i(D1), w = v2 - v1."""
    return LCS(np.zeros((2, 2)), [[-1 / C1], [1 / C2]], [[-1, 1]], [[0]], np.zeros((2, 0)),
               np.zeros((1, 0)), ("v(C1)", "v(C2)"), (Pair("D1"),), ())


def source_charges_cap(C=1e-6) -> LCS:
    """Vs -> D1 -> C1 to ground: λ = i(D1), w = v(C1) - Vs."""
    return LCS([[0]], [[1 / C]], [[1]], [[0]], [[0]], [[-1]], ("v(C1)",), (Pair("D1"),),
               ("Vs",))


def boost_open(L=100e-6, C=470e-6, R=10.0) -> LCS:
    return LCS([[0, -1 / L], [1 / C, -1 / (R * C)]], [[1 / L], [0]], [[1, 0]], [[0]],
               [[1 / L], [0]], [[0]], ("i(L1)", "v(C1)"), (Pair("D1", "voltage"),), ("Vin",))


def boost_closed(L=100e-6, C=470e-6, R=10.0) -> LCS:
    return LCS([[0, 0], [0, -1 / (R * C)]], [[0], [1 / C]], [[0, 1]], [[0]],
               [[1 / L], [0]], [[0]], ("i(L1)", "v(C1)"), (Pair("D1"),), ("Vin",))


def bridge_tank(L=1e-3, C=1e-6, Co=100e-6, R=50.0, Rg=1e3) -> LCS:
    """Bridge across an LC tank (see tests/test_passivity.py): D = Rg a a'."""
    A = [[0, 1 / L, 0], [-1 / C, 0, 0], [0, 0, -1 / (R * Co)]]
    B = [[0, 0, 0, 0], [-1 / C, 0, 1 / C, 0], [1 / Co, 1 / Co, 0, 0]]
    Cm = [[0, -1, 1], [0, 0, 1], [0, 1, 0], [0, 0, 0]]
    a = np.array([1.0, 1.0, -1.0, -1.0])
    return LCS(A, B, Cm, Rg * np.outer(a, a), np.zeros((3, 0)), np.zeros((4, 0)),
               ("i(L1)", "v(C1)", "v(Co)"), tuple(Pair(f"D{i}") for i in range(1, 5)), ())


# ---------------------------------------------------------------------------------------------
# State jumps


@pytest.mark.parametrize("use_energy", [True, False])
def test_capacitor_dump_charge_conservation(use_energy):
    C1, C2, v1, v2 = 2e-6, 3e-6, 5.0, 1.0
    lcs = two_caps(C1, C2)
    energy = np.diag([C1, C2]) if use_energy else None
    res = state_jump(lcs, [v1, v2], energy=energy)
    v_plus = (C1 * v1 + C2 * v2) / (C1 + C2)
    np.testing.assert_allclose(res.x_plus, [v_plus, v_plus], rtol=1e-9)
    np.testing.assert_allclose(res.eta, [C1 * C2 * (v1 - v2) / (C1 + C2)], rtol=1e-9)
    loss = C1 * C2 * (v1 - v2) ** 2 / (2 * (C1 + C2))
    np.testing.assert_allclose(res.energy_before - res.energy_after, loss, rtol=1e-6)
    np.testing.assert_allclose(res.dissipated, loss, rtol=1e-6)
    assert res.jumped and res.energy_after <= res.energy_before


def test_consistent_state_does_not_jump():
    lcs = two_caps()
    res = state_jump(lcs, [1.0, 5.0])
    assert not res.jumped
    np.testing.assert_array_equal(res.x_plus, [1.0, 5.0])
    assert res.dissipated == 0.0


def test_source_charges_capacitor_half_energy_lost():
    # Charging C from 0 to Vs through an ideal diode: the source delivers C Vs², half is lost.
    C, Vs = 1e-6, 5.0
    res = state_jump(source_charges_cap(C), [0.0], [Vs], energy=np.array([[C]]))
    np.testing.assert_allclose(res.x_plus, [Vs])
    np.testing.assert_allclose(res.supplied, C * Vs**2)
    np.testing.assert_allclose(res.dissipated, 0.5 * C * Vs**2)
    np.testing.assert_allclose(res.energy_after - res.energy_before,
                               res.supplied - res.dissipated, rtol=1e-12)


def test_inductor_current_forced_to_zero():
    # Boost with switch open and i(L) < 0: the diode cannot carry it; the current jumps to 0
    # and L i² / 2 is lost (η = -L i volt-seconds of reverse voltage).
    L, C = 100e-6, 470e-6
    lcs = boost_open(L, C)
    res = state_jump(lcs, [-2.0, 10.0], [12.0], energy=np.diag([L, C]))
    np.testing.assert_allclose(res.x_plus, [0.0, 10.0], atol=1e-12)
    np.testing.assert_allclose(res.eta, [2.0 * L])
    np.testing.assert_allclose(res.dissipated, 0.5 * L * 4.0)


@pytest.mark.parametrize("x0, expected_pair", [
    ([0.1, 5.0, 1.0], ("D1", "D4")),
    ([0.1, -5.0, 1.0], ("D2", "D3")),
])
def test_bridge_jump_is_charge_sharing(x0, expected_pair):
    # Consistent set by hand: v(Co) >= |v(C1)|. From v(C1) = ±5 > v(Co) = 1 the conducting pair
    # connects C1 and Co in parallel (with sign): charge sharing, i(L1) unchanged.
    C, Co = 1e-6, 100e-6
    lcs = bridge_tank(C=C, Co=Co)
    res = state_jump(lcs, x0, energy=np.diag([1e-3, C, Co]))
    vc, vo = x0[1], x0[2]
    v = (C * abs(vc) + Co * vo) / (C + Co)
    np.testing.assert_allclose(res.x_plus, [x0[0], np.sign(vc) * v, v], rtol=1e-9)
    names = tuple(p.name for p, e in zip(lcs.pairs, res.eta, strict=True) if e > 1e-12)
    assert names == expected_pair
    assert res.energy_after <= res.energy_before
    np.testing.assert_allclose(res.energy_before - res.energy_after,
                               C * Co * (abs(vc) - vo) ** 2 / (2 * (C + Co)), rtol=1e-6)
    assert is_consistent(lcs, res.x_plus)


def test_energy_never_increases_without_inputs():
    rng = np.random.default_rng(3)
    lcs = bridge_tank()
    rep = check_passivity(lcs, energy=np.diag([1e-3, 1e-6, 100e-6]))
    for _ in range(20):
        x0 = rng.normal(size=3) * [0.1, 5.0, 5.0]
        res = state_jump(lcs, x0, passivity=rep)
        assert res.energy_after <= res.energy_before * (1 + 1e-12)
        assert is_consistent(lcs, res.x_plus)
        # Pythagoras of the K-projection onto a cone (u = 0).
        np.testing.assert_allclose(res.energy_before, res.energy_after + res.dissipated,
                                   rtol=1e-9)


def test_state_jump_refuses_non_passive():
    lcs = LCS([[1.0]], [[1.0]], [[1.0]], [[0]], np.zeros((1, 0)), np.zeros((1, 0)),
              ("x",), (Pair("D1"),), ())
    with pytest.raises(ValueError, match="passive"):
        state_jump(lcs, [-1.0])


# ---------------------------------------------------------------------------------------------
# Consistent set


def test_consistent_set_description_d_zero():
    cs = consistent_set(boost_closed())
    assert cs.describe().splitlines()[1].strip() == "w(D1) = v(C1) >= 0"
    assert is_consistent(boost_closed(), [1.0, 3.0], [12.0])
    assert not is_consistent(boost_closed(), [1.0, -3.0], [12.0])


def test_consistent_set_with_input():
    lcs = source_charges_cap()
    assert "v(C1) - Vs" in consistent_set(lcs).describe()
    assert is_consistent(lcs, [5.0], [5.0])
    assert not is_consistent(lcs, [4.0], [5.0])


def test_bridge_consistent_set_by_hand():
    lcs = bridge_tank()
    for vc, vo in [(1.0, 2.0), (-1.0, 2.0), (2.0, 2.0)]:
        assert is_consistent(lcs, [0.0, vc, vo])
    for vc, vo in [(3.0, 2.0), (-3.0, 2.0), (0.0, -0.1)]:
        assert not is_consistent(lcs, [0.0, vc, vo])


def test_sol_cone_rays_by_hand():
    # D + D' = 0 (skew): λ >= 0, Dλ = (λ2, -λ1) >= 0 -> λ1 = 0: the single ray (0, 1).
    np.testing.assert_allclose(sol_cone_rays(np.array([[0.0, 1.0], [-1.0, 0.0]])), [[0], [1]])
    # D = R a a' (bridge): λ >= 0 with λ1 + λ2 = λ3 + λ4: the four "one up, one down" rays.
    a = np.array([1.0, 1.0, -1.0, -1.0])
    rays = sol_cone_rays(np.outer(a, a))
    got = {tuple(np.round(r, 9)) for r in rays.T}
    assert got == {(1, 0, 1, 0), (1, 0, 0, 1), (0, 1, 1, 0), (0, 1, 0, 1)}
    # D positive definite: SOL = {0}, every state consistent.
    assert sol_cone_rays(np.diag([1.0, 2.0])).shape == (2, 0)
    with pytest.raises(ValueError):
        sol_cone_rays(np.array([[-1.0]]))


def test_positive_definite_d_everything_consistent():
    lcs = LCS([[-1.0]], [[1.0]], [[1.0]], [[2.0]], np.zeros((1, 0)), np.zeros((1, 0)),
              ("v(C1)",), (Pair("D1"),), ())
    assert is_consistent(lcs, [-100.0])
    assert "every state is consistent" in consistent_set(lcs).describe()


# ---------------------------------------------------------------------------------------------
# Well-posedness


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("builder", [boost_open, boost_closed, two_caps])
def test_wellposed_circuits(builder):
    rep = check_wellposedness(builder())
    assert rep.wellposed and rep.lambda_unique and rep.passive and rep.rank_ok, rep.reason
    assert "full column rank" in rep.reason


def test_parallel_diodes_rank_fails():
    # Two identical diodes in parallel from C1 to C2: B columns equal, D = 0.
    C1, C2 = 1e-6, 1e-6
    lcs = LCS(np.zeros((2, 2)), [[-1 / C1, -1 / C1], [1 / C2, 1 / C2]], [[-1, 1], [-1, 1]],
              np.zeros((2, 2)), np.zeros((2, 0)), np.zeros((2, 0)), ("v(C1)", "v(C2)"),
              (Pair("D1"), Pair("D2")), ())
    rep = check_wellposedness(lcs, energy=np.diag([C1, C2]))
    # x is unique (passivity) but λ is not: the split between the parallel diodes is free.
    assert rep.passive and not rep.rank_ok and rep.wellposed and not rep.lambda_unique
    assert "only λ is not unique" in rep.reason
    assert rep.rank == 1 and rep.deficient_pairs == ("D1", "D2")
    (combo,) = rep.null_combinations
    assert combo["D1"] == pytest.approx(-combo["D2"])
    assert "D1, D2" in rep.reason


def test_bridge_rank_fails_with_all_four():
    rep = check_wellposedness(bridge_tank(), energy=np.diag([1e-3, 1e-6, 100e-6]))
    assert rep.passive and not rep.rank_ok and rep.wellposed and not rep.lambda_unique
    assert rep.deficient_pairs == ("D1", "D2", "D3", "D4")
    (combo,) = rep.null_combinations
    np.testing.assert_allclose([combo[k] for k in ("D1", "D2", "D3", "D4")],
                               np.array([1, -1, 1, -1]) * np.sign(combo["D1"]))


def test_not_passive_but_p_matrix():
    # Unstable A (negative resistance) but D = R > 0 is a P-matrix: λ is Lipschitz in x.
    lcs = LCS([[1.0]], [[1.0]], [[1.0]], [[2.0]], np.zeros((1, 0)), np.zeros((1, 0)),
              ("v(C1)",), (Pair("D1"),), ())
    rep = check_wellposedness(lcs)
    assert not rep.passive and rep.p_matrix and rep.wellposed and rep.lambda_unique
    assert "P-matrix" in rep.reason


def test_not_passive_not_wellposed():
    lcs = LCS([[1.0]], [[1.0]], [[1.0]], [[0.0]], np.zeros((1, 0)), np.zeros((1, 0)),
              ("x",), (Pair("D1"),), ())
    rep = check_wellposedness(lcs)
    assert not rep.wellposed and not rep.lambda_unique and not rep.passive
    assert "not passive" in rep.reason
