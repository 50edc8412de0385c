"""Design helpers against hand-computed values (Erickson & Maksimović formulas worked by hand)."""

import math

import pytest

from converters.design import ccm_duty, conversion_ratio, design, k_crit


def test_buck_design_by_hand():
    # 24 V -> 12 V, 6 ohm, 100 kHz: D = 0.5, I = 2 A, ripple 0.4 A -> L = 12*0.5*10us/0.4
    d = design("buck", 24, 12, 100e3, R=6, current_ripple=0.2, voltage_ripple=0.01)
    assert d.duty == pytest.approx(0.5)
    assert d.L == pytest.approx(150e-6)
    assert d.C == pytest.approx(0.4 * 10e-6 / (8 * 0.12))  # 4.1667 uF
    assert d.K == pytest.approx(5.0) and d.K_crit == pytest.approx(0.5)
    assert d.mode == "CCM"


def test_boost_design_by_hand():
    # 12 V -> 24 V, 20 ohm, 50 kHz: D = 0.5, IL = 2.4 A, ripple 0.48 A
    d = design("boost", 12, 24, 50e3, R=20)
    assert d.duty == pytest.approx(0.5)
    assert d.L == pytest.approx(250e-6)
    assert d.C == pytest.approx(50e-6)
    assert d.K == pytest.approx(1.25) and d.K_crit == pytest.approx(0.125)


def test_buck_boost_design_by_hand_with_power_spec():
    # 12 V -> -12 V at 12 W: R = 12 ohm
    d = design("buck-boost", 12, -12, 100e3, pout=12)
    assert d.R == pytest.approx(12)
    assert d.duty == pytest.approx(0.5)
    assert d.L == pytest.approx(150e-6)
    assert d.C == pytest.approx(12 * 0.5 * 10e-6 / (12 * 0.12))


def test_cuk_design_has_both_inductors_and_transfer_capacitor():
    d = design("Čuk", 12, -12, 100e3, R=12)
    # IL1 = 1 A, IL2 = 1 A at D = 0.5: both 12*0.5*10us/0.2 = 300 uH
    assert d.L == pytest.approx(300e-6) and d.L2 == pytest.approx(300e-6)
    assert d.C1 == pytest.approx(1 * 0.5 * 10e-6 / (0.01 * 24))
    assert d.K == pytest.approx(2 * 150e-6 / (12 * 10e-6))


def test_large_ripple_target_is_dcm():
    d = design("boost", 12, 24, 50e3, R=20, current_ripple=3.0)
    assert d.mode == "DCM" and d.K < d.K_crit


@pytest.mark.parametrize(
    "topology, duty, K, expected",
    [
        ("boost", 0.5, 0.05, (1 + math.sqrt(21)) / 2),
        ("buck", 0.5, 0.1, 2 / (1 + math.sqrt(2.6))),
        ("buck-boost", 0.5, 0.1, -0.5 / math.sqrt(0.1)),
        ("cuk", 0.4, 0.2, -0.4 / math.sqrt(0.2)),
    ],
)
def test_dcm_ratios_by_hand(topology, duty, K, expected):
    assert conversion_ratio(topology, duty, K) == pytest.approx(expected)


@pytest.mark.parametrize("topology", ["buck", "boost", "buck-boost", "cuk"])
@pytest.mark.parametrize("duty", [0.2, 0.5, 0.8])
def test_dcm_ratio_is_continuous_at_the_boundary(topology, duty):
    # At K = K_crit the DCM formula must give the CCM ratio: an independent consistency check
    # between K_crit and the DCM formulas.
    kc = k_crit(topology, duty)
    ccm = conversion_ratio(topology, duty)
    just_dcm = conversion_ratio(topology, duty, kc * (1 - 1e-9))
    assert just_dcm == pytest.approx(ccm, rel=1e-6)


def test_unreachable_ratio_is_a_clear_error():
    with pytest.raises(ValueError, match="boost converter needs"):
        ccm_duty("boost", 12, 6)
    with pytest.raises(ValueError, match="unknown topology"):
        design("flyback", 12, 5, 1e5, R=1)
    with pytest.raises(ValueError, match="exactly one"):
        design("buck", 12, 5, 1e5)
