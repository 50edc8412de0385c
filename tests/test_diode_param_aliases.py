"""A diode model that gives a parameter under both of ngspice's names (IS and JS, VJ and PB,
M and MJ, IKF and IK): ngspice reads the model's parameters in order, so the one written
last is the one it uses; the static characteristic (netlist.diode_dc) reads it alike."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_dc_voltages

from netlist.diode_dc import diode_voltage, junction_params

CURRENTS = [1e-6, 1e-3]


@pytest.mark.parametrize("params", [
    {"IS": 1e-14, "N": 1.3, "JS": 1e-12},
    {"JS": 1e-12, "N": 1.3, "IS": 1e-14},
    {"IS": 1e-14, "IKF": 1e-3, "IK": 1e-5},
])
def test_the_name_written_last_is_the_one_used(tmp_path, ngspice, params):
    model = " ".join(f"{k}={v:g}" for k, v in params.items())
    want = ngspice_dc_voltages(f"D1 a 0 DX\n.model DX D({model})\n", CURRENTS, tmp_path)
    got = diode_voltage(np.array(CURRENTS), junction_params(params))
    # (the other reading is 0.1 V and more away)
    assert np.max(np.abs(got - want)) < 2e-5, (got, want)


def test_the_later_alias_wins_in_each_pair():
    p = junction_params({"VJ": 0.5, "ISR": 1e-9, "M": 0.3, "PB": 0.8, "MJ": 0.4,
                         "IKF": 0.1, "IK": 0.2})
    assert (p["vj"], p["m"], p["ikf"]) == (0.8, 0.4, 0.2)
    p = junction_params({"PB": 0.8, "MJ": 0.4, "ISR": 1e-9, "VJ": 0.5, "M": 0.3})
    assert (p["vj"], p["m"]) == (0.5, 0.3)
