"""A switch's ROFF, modelled where the resistances at its terminals make its leakage matter
(:mod:`netlist.switch_leakage`), side by side with ngspice."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from ngspice_helpers import ngspice_run

from netlist.circuit import Resistor
from netlist.parser import parse_string
from netlist.studies.realistic import simulate_devices
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit

# ngspice's manual, its switch example (examples/probe/switches-manual-p92.cir, ROFF = 10k
# against 10k loads): S switches with hysteresis, OFF and ON on the line, a CSW switch
MANUAL = """switches with ROFF near their loads
v1 1 0 DC 0.0 PWL (0 0 2e-3 2 4e-3 0)
v2 2 0 DC 0.0 PWL (0 0.9 2e-3 2 4e-3 0.4)
i3 3 0 DC 0.0 PWL (0 0 2e-3 2m 4e-3 0)
v4 4 0 DC 2.0
r3 3 33 10k
vm3 0 33 dc 0
r10 4 10 10k
r20 4 20 10k
r30 4 30 10k
r40 4 40 10k
s1 10 0 1 0 switch1 OFF
s2 20 0 2 0 switch1 OFF
s3 30 0 2 0 switch1 ON
.model switch1 sw vt=1 vh=0.2 ron=1 roff=10k
w1 40 0 vm3 wswitch1 off
.model wswitch1 csw it=1m ih=0.2m ron=1k roff=10k
.tran 2us 5ms
.end
"""

PROBES = ["v(10)", "v(20)", "v(30)", "v(40)"]


def _parse(text: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return parse_string(text)


def test_roff_near_the_loads_is_modelled_as_ngspice_has_it(tmp_path, ngspice):
    c = _parse(MANUAL)
    added = [el for el in c.elements if isinstance(el, Resistor) and el.built_for]
    assert sorted(el.name for el in added) == ["Rs1_off", "Rs2_off", "Rs3_off", "Rw1_off"]
    assert any("ROFF = 10 kΩ" in n and "Rs1_off" in n for n in c.notes)
    res = simulate_circuit(c, probes=PROBES)
    ng, log = ngspice_run(MANUAL, PROBES, tmp_path)
    assert ng is not None, log
    t = np.linspace(0.0, 5e-3, 5001)
    for k, p in enumerate(PROBES):
        want = np.interp(t, ng[:, 2 * k], ng[:, 2 * k + 1])
        got = np.interp(t, np.asarray(res.t), np.asarray(res[p]))
        # off: 1 V (10k over 10k), not the 2 V of an open switch; on: ~0 (ideal; w1's RON of
        # 1k, 0.18 V in ngspice, is left out: only its off state compared). Apart from the
        # switching instants (a point either side) the runs agree within 1 mV
        keep = want > 0.5 if p == "v(40)" else np.ones_like(t, bool)
        off = keep & (np.abs(got - want) > 1e-3)
        assert off.sum() <= 6, (p, t[off])
        assert got.max() == pytest.approx(1.0, abs=1e-3)
    # ngspice is given the switch lines alone (their own ROFF), not the resistors
    deck = write_circuit(c)
    assert "Rs1_off" not in deck.replace("* Rs1_off", "") and "s1 10 0 1 0" in deck.lower()


def test_a_power_switch_stays_open():
    """ROFF = 1 MΩ beside a 5 Ω load (and a 10k gate pull-down on the control side): its
    leakage is 12 µA, the switch is left as it is."""
    c = _parse("""buck
Vin in 0 12
Vg g 0 PULSE(0 5 0 1n 1n 4u 10u)
Rgs g 0 10k
S1 in sw g 0 sm
.model sm SW(VT=2.5 RON=10m ROFF=1meg)
D1 0 sw dm
.model dm D
L1 sw out 100u
C1 out 0 100u
R1 out 0 5
.tran 0.1u 1m
.end
""")
    assert not any(isinstance(el, Resistor) and el.built_for for el in c.elements)
    assert not any("ROFF" in n for n in c.notes)


# a sample-and-hold: the open switch is the hold capacitor's only path for direct current,
# so its ROFF (1 MΩ, with 1 nF a time constant of 1 ms) discharges the held 5 V towards the
# input's 0 V, no resistor anywhere at the switch's terminals
HOLD = """sample and hold
V1 in 0 PULSE(5 0 1m 1u 1u 100m 200m)
Vc ctl 0 PULSE(1 0 0.5m 1n 1n 100m 200m)
S1 in c ctl 0 SMOD
C1 c 0 1n
.model SMOD SW(VT=0.5 VH=0 RON=10 ROFF=1MEG)
.tran 10u 5m
.end
"""


def test_roff_as_a_capacitor_s_only_dc_path_is_modelled(tmp_path, ngspice):
    """v(c) after the hold: ngspice's decays as exp(-(t - 1 ms) / 1 ms) (0.092 V at 5 ms);
    an open switch held 5 V."""
    c = _parse(HOLD)
    assert [el.name for el in c.elements if isinstance(el, Resistor) and el.built_for] \
        == ["RS1_off"]
    assert any("RS1_off" in n and "direct current" in n for n in c.notes)
    res = simulate_devices(c, devices="pwl", probes=["v(c)"])
    ng, log = ngspice_run(HOLD, ["v(c)"], tmp_path)
    assert ng is not None, log
    t = np.linspace(1.5e-3, 5e-3, 351)
    want = np.interp(t, ng[:, 0], ng[:, 1])
    got = np.interp(t, np.asarray(res.t), np.asarray(res["v(c)"]))
    assert want[-1] == pytest.approx(5 * np.exp(-4), rel=0.05)
    assert np.max(np.abs(got - want)) < 0.02


def test_check_runs_the_hold_as_simulate_pwl_does(tmp_path, ngspice, capsys):
    """pelcs check --devices pwl on the sample-and-hold: its ideal switch closes a loop with
    the source and the capacitor, which pelcs simulate --devices pwl sizes from a run at RON;
    the check stopped at that loop (advising --devices pwl). (RON = 10 kΩ and a 1 µs step:
    the check runs both from UIC, and a charge through RON = 10 Ω in 10 ns is a mode the
    step would not resolve.)"""
    from pelcs.cli import main

    deck = tmp_path / "hold.cir"
    deck.write_text(HOLD.replace("RON=10 ", "RON=10k ").replace(".tran 10u", ".tran 1u"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rc = main(["check", str(deck), "--devices", "pwl", "--probe", "v(c)"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "within tolerance" in out.splitlines()[-1]


def test_a_hold_charged_through_ron_from_uic_follows_ngspice(tmp_path, ngspice):
    """From UIC the hold capacitor charges through RON = 10 Ω in 10 ns, a mode the 10 µs
    step does not resolve: at θ = 1/2 v(c) alternated between 0 and 10 V (1.1 V at 5 ms,
    ngspice 0.09 V); the pwl run takes θ = 1 for it, with a note."""
    deck = HOLD.replace(".tran 10u 5m", ".tran 10u 5m UIC")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate_devices(parse_string(deck), devices="pwl", probes=["v(c)"])
    assert any("on resistance and C1" in n and "θ = 1" in n for n in res.notes)
    ng, log = ngspice_run(deck, ["v(c)"], tmp_path)
    assert ng is not None, log
    t = np.linspace(0.1e-3, 5e-3, 491)
    want = np.interp(t, ng[:, 0], ng[:, 1])
    got = np.interp(t, np.asarray(res.t), np.asarray(res["v(c)"]))
    # (backward Euler at h = 1 % of the 1 ms decay: within 0.05 V of 5 V)
    assert np.max(np.abs(got - want)) < 0.05
