"""The DC operating point of a regulator whose error amplifier has a high gain before its
clamps (10k, then 1k, into a MOSFET's gate RC): with the clamps' diodes as inputs the DC
equations' matrix ``A`` has a condition number of 1e10 to 1e12 after row scaling, and the
point solved through ``A⁺`` lost a 5 mV gate-drain voltage as round-off or settled the
diodes' LCP on a point 0.08 V off. The run then said "no DC operating point (the DC
equations have no solution ...)" and started from zero, where the point exists (hand-derived
below) and ngspice's operating point has the MOSFET on."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import numpy as np
import pytest
from ngspice_helpers import ngspice_print

from lcs.theory.operating_point import dc_point
from netlist.parser import parse_file, parse_string
from netlist.studies.realistic import simulate_devices
from pelcs.cli import main

#: (ngspice side by side: the full suite and CI run them, not the fast subset)
pytestmark = pytest.mark.slow

DECK = """regulated boost: error amplifier and gate clamps, a VDMOS with its gate RC
V1 clock 0 PULSE(0 6 0 19u 1u 10n 20.01u)
V2 ref 0 2.5
R1 OUT outdiv 100k
R2 0 outdiv 27k
R3 outdiv x 10k
C2 err x 50n
B1 err 0 V = max(0,min(5,V(ref,x)*10k))
B2 gate 0 V = max(0,min(5,V(err,clock)*1k))
V3 +V 0 5
L1 +V lx 220u
RL lx out1 1
M1 out1 gate 0 PWR
D1 out1 OUT DS
C1 OUT cx 33u
RC cx 0 50m
R4 OUT 0 1k
.model PWR VDMOS nchan Vto=3.6 Kp=50 Rg=3 Rd=20m Rs=5m Cgdmax=.2n Cgdmin=.05n a=0.3 Cgs=.12n
.model DS D(Is=22.6u Rs=.042 N=1.094 Cjo=480p M=.61)
{analysis}
.end
"""

PROBES = ["i(L1)", "v(out1)", "v(out)", "v(gate)"]


def hand_point(vf: float = 0.1, rd: float = 0.042) -> list[float]:
    """The pwl circuit's operating point by hand: B1 and B2 clamp at 5 V (the output is
    below the regulation point), so M1 is on, RD + RS + 1/(KP (5 V - VTO)) = 39.29 mΩ; D1
    (Vf, rd) conducts into R4 || (R1 + R2); the capacitors carry no current (x and err
    settle with C2 open), so v(out1) = v solves (5 - v)/RL = v/Ron + (v - Vf)/(rd + Rl).
    The values of PROBES."""
    ron = 0.02 + 0.005 + 1 / (50 * (5 - 3.6))
    rl = 1000 * 127e3 / (1000 + 127e3)
    v = (5 / 1 + vf / (rd + rl)) / (1 / 1 + 1 / ron + 1 / (rd + rl))
    return [5 - v, v, (v - vf) / (rd + rl) * rl, 5.0]


def test_the_pwl_run_starts_from_the_operating_point():
    res = simulate_devices(parse_string(DECK.format(analysis=".tran 10n 2u")), devices="pwl",
                           pwl={"D1": (0.1, 0.042)}, probes=PROBES)
    assert not any("no DC operating point" in n for n in res.notes), res.notes
    # (before: 0 A, 0 V, 0 V, from zero with the note)
    assert res.y[0] == pytest.approx(hand_point(), rel=1e-6)


def test_the_operating_point_is_ngspices(tmp_path, ngspice):
    # ngspice's devices: M1 in its triode region (v(out1) 0.19 V against an overdrive of
    # 1.4 V), its channel a little above the pwl's 1/(KP Vov); D1 fitted at its 1 mA
    res = simulate_devices(parse_string(DECK.format(analysis=".tran 10n 2u")), devices="pwl",
                           probes=PROBES)
    ng = ngspice_print(DECK.format(analysis=".op"), ["i(V3)", "v(out1)", "v(gate)"], tmp_path)
    assert res.y[0][0] == pytest.approx(-ng["i(V3)"], rel=2e-3)  # 4.811 A, ngspice 4.808 A
    assert res.y[0][1] == pytest.approx(ng["v(out1)"], rel=3e-2)  # 0.189 V, 0.192 V
    assert res.y[0][3] == pytest.approx(ng["v(gate)"], abs=1e-6)  # 5 V


def test_ngspices_dcdc_starts_with_its_mosfet_on():
    # the corpus file this deck stands for: its operating point has M1 on (ngspice's too,
    # at its saturation current 0.93 A), where the pwl run said there was none and started
    # from zero; M1 on at t = 0 carries 5.4 A, over what its channel carries (refused)
    path = (Path(__file__).parent / "corpus" / "ngspice" / "paranoia_parallel" / "examples"
            / "vdmos" / "dcdc.sp")
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["simulate", str(path), "--devices", "pwl"])
    text = out.getvalue() + err.getvalue()
    assert "no DC operating point" not in text, text
    assert code == 2 and "M1 (VDMOS) is on as a switch" in text and "from t = 0 s" in text, text


def test_no_solution_is_said_only_with_its_proof():
    # a DC current into a lone capacitor: the DC equations' combination that nothing
    # changes (A = 0 there) is driven: "no solution" (proved)
    p = dc_point(np.zeros((1, 1)), np.zeros((1, 0)), np.zeros((0, 1)), np.zeros((0, 0)),
                 np.ones((1, 1)), np.zeros((0, 1)), np.array([1.0]), np.array([0.0]))
    assert not p.ok and "the DC equations have no solution" in p.reason and p.proved
    # a regular A whose diode's LCP has no solution at the point: not "no solution of the
    # DC equations" (x' = -x + u sets x = u = 1; the pair's w = -x - 1 = -2 < 0 whatever λ)
    p = dc_point(-np.eye(1), np.zeros((1, 1)), -np.eye(1), np.zeros((1, 1)), np.eye(1),
                 -np.ones((1, 1)), np.array([1.0]), np.array([0.0]))
    assert not p.ok and "the DC equations have no solution" not in p.reason
    assert not p.proved


def test_the_clampers_point_is_found(tmp_path, ngspice):
    # eSim's clamper with pwl diodes: capacitors that only the diodes reach, each diode of
    # five segments whose columns of B hold the formulation's round-off (1.7e-9 of the
    # diode's own) in its junction capacitor's row. Before, pelcs's leakage balance counted
    # them as acting and said "pelcs finds no DC operating point", starting from 0 V; now
    # it finds the point: no current, the junctions at 0 V where their leakage balances, as
    # ngspice's GMIN across each junction gives (1e-17 V)
    path = (Path(__file__).parent / "corpus" / "esim" / "Examples" / "Clampercircuit"
            / "Clampercircuit.cir.out")
    res = simulate_devices(parse_file(path), devices="pwl",
                           probes=["v(out_neg)", "v(out_pos)"])
    assert not any("DC operating point" in n for n in res.notes), res.notes
    deck = re.sub(r"(?ims)^\.control.*?^\.endc\s*$", "", path.read_text())
    deck = re.sub(r"(?im)^\.tran.*$", ".op", deck)
    ng = ngspice_print(deck, ["v(out_neg)", "v(out_pos)"], tmp_path,
                       files={"D.lib": (path.parent / "D.lib").read_text()})
    assert [ng["v(out_neg)"], ng["v(out_pos)"]] == pytest.approx([0.0, 0.0], abs=1e-12)
    assert res.y[0] == pytest.approx([0.0, 0.0], abs=1e-12)
