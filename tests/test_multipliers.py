"""Instance multipliers as ngspice reads them: ``m=`` on R, L and C is that many elements in
parallel (R/m, L/m, C*m), and a diode's ``area=`` times its ``m=`` scales the junction (IS
times it, RS divided by it), which the ``--devices pwl`` fit follows. xschem writes ``m=1`` on
every R and C. Each deck is run side by side with ngspice. SPICE3's positional area (the
first value after the model) is refused, as ngspice 39 refuses it."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.errors import NetlistError
from pelcs.api import simulate

# an RC charge (C 1u m=2: 2 uF) and an RL rise (L 2 m=4: 0.5 H), both from 1 V through
# R 1k m=2 (500 Ohm): tau 1 ms each (a step at t = 0, from rest in ngspice too)
PASSIVES = """multipliers
V1 in 0 PULSE(0 1 0 1n 1n 1 2)
R1 in c 1k m=2
C1 c 0 1u m=2
R2 in l 1k m=2
L1 l 0 2 m=4
R3 l 0 1G
.tran 10u 1m
.end
"""

# a half-wave rectifier into 100 Ohm from 2 V: the diode's drop is a quarter of the output,
# and AREA 10 times m=2 lowers it by Vt ln(20) = 77 mV
RECTIFIER = """diode area
V1 in 0 SIN(0 2 1k)
D1 in out dm area=10 m=2
R1 out 0 100
.model dm D(IS=1e-14 RS=0.5)
.tran 1u 2m
.end
"""


def _mean(t, y):
    return float(np.trapezoid(y, t) / (t[-1] - t[0]))


def test_m_puts_passives_in_parallel(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    res = simulate(PASSIVES, probes=["v(c)", "i(L1)"], step=1e-6)
    ng = ngspice_wrdata(PASSIVES, ["v(c)", "i(L1)"], tmp_path)
    # analytic, 1 ms in: v(c) = 1 - exp(-1), i(L1) = (1 - exp(-1)) / 500 Ohm
    want = [1 - np.exp(-1.0), (1 - np.exp(-1.0)) / 500]
    assert np.allclose(res.y[-1], want, rtol=2e-3)
    assert np.allclose(ng[-1, [1, 3]], want, rtol=2e-3)


def test_diode_area_and_m_scale_the_pwl_fit(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    ng = ngspice_wrdata(RECTIFIER, ["v(out)"], tmp_path)
    want = _mean(ng[:, 0], ng[:, 1])
    res = simulate(RECTIFIER, probes=["v(out)"], devices="pwl")
    got = _mean(res.t, res.y[:, 0])
    assert abs(got - want) <= 0.03 * want
    # the same diode at area 1: ngspice's output drops by more than the tolerance above
    plain = ngspice_wrdata(RECTIFIER.replace("dm area=10 m=2", "dm"), ["v(out)"], tmp_path)
    assert want - _mean(plain[:, 0], plain[:, 1]) > 0.06 * want


def test_a_multiplier_must_be_positive():
    with pytest.raises(NetlistError, match="R1: m must be positive, got 0"):
        simulate(PASSIVES.replace("R1 in c 1k m=2", "R1 in c 1k m=0"))


def test_m_with_ltspice_parasitics_is_refused():
    with pytest.raises(NetlistError, match="m= together with LTspice's Rser="):
        simulate(PASSIVES.replace("C1 c 0 1u m=2", "C1 c 0 1u m=2 Rser=1"))


def test_a_positional_diode_area_is_refused(tmp_path, ngspice):
    for spelled in ("20", "20 OFF"):
        deck = RECTIFIER.replace("area=10 m=2", spelled)
        with pytest.raises(NetlistError, match="diode area '20' written without area=") as exc:
            simulate(deck, probes=["v(out)"], devices="pwl")
        assert "write area=20" in str(exc.value)
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    deck = tmp_path / "deck.cir"
    deck.write_text(RECTIFIER.replace("area=10 m=2", "20 OFF"))
    r = subprocess.run(["ngspice", "-b", deck.name], cwd=tmp_path, capture_output=True,
                       text=True, timeout=60, env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"})
    assert "could not find a valid modelname" in r.stdout + r.stderr
