"""GDCM regions of the bundled single-diode converters, through `pelcs lcs --json`, against
hand derivations from each netlist's orientation (names as in converters/netlists/*.cir).

Buck (S1 in->sw, D1 0->sw, L1 sw->out, C1 out-0), switch off: the diode is in series with L1,
so λ = v(sw) (its reverse voltage) and w = i(D1) = i(L1). L di/dt = λ - v(C1): CB = 1/L,
C A x = -v(C1)/L, so Γ = -(C A x + C E u)/(C B) = v(C1).

Buck-boost (S1 in->sw, L1 sw->0, D1 out->sw, C1 out-0), switch off: w = i(L1),
λ = v(sw) - v(out), L di/dt = v(sw) = λ + v(C1): Γ = -v(C1) (> 0 for the negative output).

Čuk (L1 in->a, S1 a-0, C1 a-b, D1 b->0, L2 b->out, C2 out-0), switch off: KCL at b gives
w = i(D1) = i(L1) - i(L2); λ = -v(b), v(b) = v(a) - v(C1).
L1 di1/dt = Vin - v(a) = Vin + λ - v(C1), L2 di2/dt = v(b) - v(out) = -λ - v(C2):
CB = 1/L1 + 1/L2, Γ = (L2 (v(C1) - Vin) - L1 v(C2)) / (L1 + L2).
Switch on (a = 0): D1 is across C1, so λ = i(D1), w = -v(b) = v(C1); C1 dv(C1)/dt = λ + i(L2):
Γ = -i(L2).
"""

import json
from pathlib import Path

import pytest

from pelcs.cli import main

NETLISTS = Path(__file__).parents[1] / "converters" / "netlists"


def _gdcm(capsys, name, mode):
    assert main(["lcs", str(NETLISTS / name), "--json", "--mode", mode]) == 0
    (m,) = json.loads(capsys.readouterr().out)["modes"]
    (cond,) = m["gdcm"]
    assert cond["diode"] == "D1"
    return m, cond


def test_buck_switch_off(capsys):
    m, cond = _gdcm(capsys, "buck.cir", "S1=off")
    assert m["lambda_kinds"] == {"D1": "voltage"}
    assert cond["y"] == pytest.approx({"i(L1)": 1.0})
    assert cond["gamma"] == pytest.approx({"v(C1)": 1.0})


def test_buck_boost_switch_off(capsys):
    m, cond = _gdcm(capsys, "buck_boost.cir", "S1=off")
    assert m["lambda_kinds"] == {"D1": "voltage"}
    assert cond["y"] == pytest.approx({"i(L1)": 1.0})
    assert cond["gamma"] == pytest.approx({"v(C1)": -1.0})


def test_cuk_switch_off(capsys):
    m, cond = _gdcm(capsys, "cuk.cir", "S1=off")
    assert m["lambda_kinds"] == {"D1": "voltage"}
    assert cond["y"] == pytest.approx({"i(L1)": 1.0, "i(L2)": -1.0})
    # L1 = L2 = 500 µH in the bundled netlist: weights L2/(L1+L2) = L1/(L1+L2) = 1/2
    assert cond["gamma"] == pytest.approx({"v(C1)": 0.5, "Vin": -0.5, "v(C2)": -0.5})


def test_cuk_switch_on(capsys):
    m, cond = _gdcm(capsys, "cuk.cir", "S1=on")
    assert m["lambda_kinds"] == {"D1": "current"}
    assert cond["y"] == pytest.approx({"v(C1)": 1.0})
    assert cond["gamma"] == pytest.approx({"i(L2)": -1.0})
