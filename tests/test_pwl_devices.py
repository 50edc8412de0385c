"""Piecewise-linear devices and losses: the fit, the energy balance, and the
accuracy target against ngspice on a 12 V -> 24 V boost at 50 kHz with a SW switch (RON =
0.1) or a level-1 MOSFET (VTO = 3, KP = 20, 10 V gate) and a diode D(IS=1e-9 N=1.5 RS=0.05):
with --devices pwl the steady-state mean output within 0.5 % and the efficiency within 1
percentage point of ngspice; with ideal devices about 4 % off."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import pelcs
from lcs.notices import IdealisedDeviceWarning
from netlist.pwl import VT_THERMAL, diode_fit
from netlist.studies.realistic import simulate_devices as simulate_circuit
from pelcs.cli import main

# pwl devices beside ngspice (3.5 s): in the full suite, not the fast subset
pytestmark = pytest.mark.slow

DEV = Path(__file__).parent / "netlists" / "devices"


def test_diode_fit_is_the_least_squares_line_of_the_diode_equation():
    vf, ron = diode_fit(1e-9, 1.5, 0.05, 4.0)
    i = np.logspace(np.log10(0.2), np.log10(4.0), 50)
    v = 1.5 * VT_THERMAL * np.log1p(i / 1e-9) + 0.05 * i
    A = np.column_stack([np.ones_like(i), i])
    ref = np.linalg.lstsq(A, v, rcond=None)[0]
    assert (vf, ron) == pytest.approx(tuple(ref), rel=1e-12)
    # the line is within a few mV of the exponential over the range
    assert np.max(np.abs(vf + ron * i - v)) < 0.03


def _mean(t, y, a):
    w = t >= a
    return np.trapezoid(y[w], t[w]) / (t[w][-1] - t[w][0])


@pytest.mark.parametrize("name", ["boost_sw_pwl.cir", "boost_mos_pwl.cir"])
def test_pwl_boost_against_ngspice(ngspice, name):
    from ngspice_checks.runner import run_ngspice

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = pelcs.load(DEV / name)
    pwl = simulate_circuit(c, devices="pwl", losses=True, probes=["v(out)"])
    ideal = simulate_circuit(c, losses=True, probes=["v(out)"])
    a, b = pwl.losses.window
    ng = run_ngspice((DEV / name).read_text(), ["v(out)", "i(L1)"], timeout=120,
                     workdir=DEV)
    t = ng.time
    v_ng = _mean(t, ng["v(out)"], a)
    p_out_ng = _mean(t, ng["v(out)"] ** 2 / 24.0, a)
    p_in_ng = 12.0 * _mean(t, ng["i(L1)"], a)  # the source's current is the inductor's
    eff_ng = p_out_ng / p_in_ng
    v_pwl = _mean(pwl.t, pwl["v(out)"], a)
    v_ideal = _mean(ideal.t, ideal["v(out)"], a)
    assert abs(v_pwl - v_ng) < 0.005 * v_ng
    assert abs(pwl.losses.efficiency - eff_ng) < 0.01
    assert abs(v_ideal - v_ng) > 0.03 * v_ng  # ideal devices: about 4 % off
    # energy balance of the piecewise-linear run: input = output + losses (steady state)
    assert abs(pwl.losses.balance) < 2e-3 * pwl.losses.p_in


def test_cli_prints_the_efficiency(capsys):
    assert main(["simulate", str(DEV / "boost_sw_pwl.cir"), "--devices", "pwl", "--losses",
                 "--probe", "v(out)", "--tstop", "10m"]) == 0
    out = capsys.readouterr().out
    assert "note: pwl: D1: Vf = " in out and "RON of its SW model" in out
    line = [ln for ln in out.splitlines() if ln.startswith("efficiency: ")]
    assert len(line) == 1 and line[0].endswith(" %")
    assert 90 < float(line[0].split()[1]) < 100


def test_api_returns_losses_as_data():
    res = pelcs.simulate(DEV / "boost_sw_pwl.cir", tstop="10m", probes=["v(out)"],
                         devices="pwl", losses=True)
    d = res.losses.to_dict()
    assert set(d) >= {"devices_W", "input_W", "output_W", "efficiency", "load"}
    assert d["load"] == "R1" and d["devices_W"]["D1"] > d["devices_W"]["S1"] > 0
    assert res.names == ("v(out)",)  # the losses' probes stay out of the result
    assert [f.element for f in res.device_fits] == ["S1", "D1"]


def test_a_chattering_mosfet_with_gate_drain_capacitance_is_explained():
    # ngspice's examples/vdmos/dcdc.sp with --devices pwl chatters at 6 ms on M1 (its Cgd,
    # 0.2 nF, above its Cgs): the note says why and what to do; any other failure gets none
    from lcs.results import SimulationResult
    from lcs.simulation.failures import chattering
    from netlist.parser import parse_string
    from netlist.studies.realistic import _miller_note

    deck = """vdmos boost
Vin in 0 5
L1 in d 220u
M1 d g 0 IRF510
Vg g 0 PULSE(0 5 0 1u 1u 8u 20u)
D1 d out dm
C1 out 0 33u
R1 out 0 100
.model dm D(IS=1e-9 RS=0.04)
.model IRF510 VDMOS nchan Vto=3.6 Kp=1.3 Rg=3 Cgdmax=.2n Cgdmin=.05n Cgs=.12n
.tran 10n 200u 0 5n uic
.end
"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        circuit = parse_string(deck)
    res = SimulationResult(np.zeros(1), np.zeros((1, 0)), (), np.zeros(0), np.zeros(0))
    res.error = chattering(1e-3, 1.1e-3, {}, "M1", 16)
    note = _miller_note(circuit, res)
    assert "M1's gate-drain capacitance (2e-10 F, Cgs 1.2e-10 F)" in note
    assert "--devices ideal" in note
    res.error = chattering(1e-3, 1.1e-3, {}, "nobody", 16)
    assert _miller_note(circuit, res) == ""


def test_a_pwl_run_warns_once_about_the_circuit_it_simulates(capsys, tmp_path):
    # a regulated boost after ngspice's dcdc.sp (whose pwl run is now refused from its
    # operating point, M1 over its channel's bound): its ideal circuit (which the command
    # sets up, and whose run sizes the fits) and its pwl circuit are both not passive, with
    # different eigenvalues (-2.79e3, -1.39e7); only the simulated (pwl) one is reported;
    # --strict still refuses a non-passive pwl run
    from test_ill_conditioned_operating_point import DECK

    dcdc = tmp_path / "regulated.sp"
    dcdc.write_text(DECK.format(analysis=".tran 10n 50u"))
    assert main(["simulate", str(dcdc), "--devices", "pwl", "--no-progress"]) == 0
    out = capsys.readouterr()
    warned = [ln for ln in (out.out + out.err).splitlines()
              if ln.startswith("warning:") and "not passive" in ln]
    assert len(warned) == 1
    tunnel = str(Path(__file__).parent / "netlists/sim/tunnel_nonpassive.cir")
    assert main(["simulate", tunnel, "--devices", "pwl", "--strict", "--no-progress"]) == 2
