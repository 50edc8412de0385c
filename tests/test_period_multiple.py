"""A ``--period`` that the netlist's switching period does not divide is refused by every
command that samples once a period (one shared check, netlist.studies.sweep.check_period_multiple):
the buck switched every 20 µs, sampled every 13 µs, has no orbit of period 13 µs (pelcs ac
once reported one of 76.9 kHz). A multiple of the period is the same steady state."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from netlist.errors import NetlistError
from netlist.parser import parse_file
from netlist.studies.sweep import check_period_multiple
from pelcs.cli import main

BUCK = Path(__file__).resolve().parents[1] / "converters" / "netlists" / "buck.cir"
REFUSAL = "--period 13 µs is not a multiple of the period the netlist defines, 20 µs"


@pytest.mark.parametrize("args", [
    ["orbit"],
    ["continue", "--param", "vin=10:12:3"],
    ["bifurcation", "--param", "vin=10:12:3", "--transient", "10", "--record", "5"],
    ["basins", "--grid", "v(C1)=0:10:5,i(L1)=0:2:5"],
    ["ac", "--inject", "Vin", "--probe", "v(out)", "--freq", "100:1k:2"],
    ["sweep", "--param", "duty=0.4:0.5:2", "--measure", "mean(v(out))"],
    ["check"],
], ids=lambda a: a[0])
def test_a_period_the_switching_does_not_divide_is_refused(args, capsys):
    code = main([args[0], str(BUCK), "--period", "13u", *args[1:]])
    err = capsys.readouterr().err
    assert code == 2, err
    assert REFUSAL in err and "(the PULSE period of Vg (control of S1))" in err
    assert "hint: leave --period out (T = 20 µs)" in err
    assert "Traceback" not in err


def test_the_check_accepts_multiples_to_round_off_only():
    c = parse_file(BUCK)
    for ok in (20e-6, 40e-6, 3 * 20e-6 * (1 + 1e-9), 1e-3):
        check_period_multiple(c, ok)
    for bad in (13e-6, 10e-6, 30e-6, 20e-6 * (1 + 1e-5)):
        with pytest.raises(NetlistError, match="is not a multiple"):
            check_period_multiple(c, bad)


def test_a_multiple_is_the_same_orbit(capsys):
    # the fixed point of the 20 µs map is the fixed point of the 40 µs map (its square)
    points = []
    for period in ("20u", "40u"):
        assert main(["orbit", str(BUCK), "--period", period, "--json"]) == 0
        points.append(np.array(json.loads(capsys.readouterr().out)["points"][0]))
    assert np.allclose(points[0], points[1], rtol=1e-6)
