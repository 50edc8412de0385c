"""ngspice's current-controlled switch W (CSW model) as an H source driving an S switch
(netlist.current_switch), side by side with ngspice: a 10 V sine whose current through Vs
(1 kOhm) closes W above IT + IH = 1.2 mA and opens it below IT - IH = 0.8 mA."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.errors import NetlistError
from pelcs.api import simulate

DECK = """current-controlled switch
V1 in 0 SIN(0 10 1k)
Vs in x 0
R2 x 0 1k
W1 in out Vs wm
.model wm CSW(IT=1m IH=0.2m RON=1 ROFF=1meg)
R1 out 0 1k
.tran 1u 2m
.end
"""


def test_hysteresis_and_on_resistance():
    res = simulate(DECK, probes=["v(in)", "v(out)"], devices="pwl")
    vin, vout = res.y[:, 0], res.y[:, 1]
    on = vout > 0.5 * vin.clip(min=1e-9)
    rising = np.flatnonzero(~on[:-1] & on[1:]) + 1
    falling = np.flatnonzero(on[:-1] & ~on[1:]) + 1
    assert len(rising) == 2 and len(falling) == 2
    step = 10 * 2 * np.pi * 1e3 * 1e-6  # the most v(in) moves in a step, V
    assert np.all(np.abs(vin[rising] - 1.2) <= step)
    assert np.all(np.abs(vin[falling - 1] - 0.8) <= step)
    # on: 1 kOhm after RON = 1 Ohm
    assert np.allclose(vout[on], vin[on] * 1000 / 1001, rtol=1e-9)


def test_agrees_with_ngspice(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    ng = ngspice_wrdata(DECK, ["v(out)"], tmp_path, timeout=60)
    want = np.sqrt(np.trapezoid(ng[:, 1] ** 2, ng[:, 0]) / ng[-1, 0])
    res = simulate(DECK, probes=["v(out)"], devices="pwl")
    got = np.sqrt(np.trapezoid(res.y[:, 0] ** 2, res.t) / res.t[-1])
    assert abs(got - want) <= 0.005 * want, (got, want)


def test_a_switch_model_is_not_a_csw_model():
    with pytest.raises(NetlistError, match="W1: a SW model, not CSW 'wm'"):
        simulate(DECK.replace("CSW(IT=1m IH=0.2m", "SW(VT=1m VH=0.2m"))
