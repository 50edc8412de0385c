"""Netlists exported from LTspice schematics: Rser/Lser/Rpar/Cpar made explicit,
`.tran 0 ...`, `.backanno` and `.lib standard.*` accepted with notes; anything else a clear
error naming it."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.circuit import Capacitor, Inductor, Resistor
from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit

LT = Path(__file__).parent / "netlists" / "ltspice" / "buck_ltspice.cir"


def test_parasitics_become_elements_with_notes():
    c = parse_file(str(LT))
    by = {el.name: el for el in c.elements}
    # Rser in series between the element and its second node
    assert by["L1"].nodes == ("sw", "l1_rser") and by["R_L1_ser"].nodes == ("l1_rser", "out")
    assert by["R_L1_ser"].value == pytest.approx(20e-3)
    assert by["C1"].nodes == ("out", "c1_rser") and by["R_C1_ser"].value == pytest.approx(5e-3)
    assert by["V1"].nodes == ("in", "v1_rser") and by["R_V1_ser"].nodes == ("v1_rser", "0")
    assert any("L1: LTspice parasitics made explicit" in n for n in c.notes)
    assert any(".lib standard.dio" in n and "ignored" in n for n in c.notes)
    assert c.tran.tstep == pytest.approx(1e-7)  # `.tran 0 2m 0 0.1u`: TSTEP from TMAX
    assert any(".backanno" in ig.text.lower() for ig in c.ignored)
    # written back for ngspice as plain elements
    text = write_circuit(c)
    assert "R_L1_ser l1_rser out" in text and "Rser" not in text


def test_parallel_parasitics_and_lser():
    c = parse_string("t\nV1 a 0 1\nR0 a b 1\nC1 b 0 1u Rser=1m Lser=2n Rpar=1Meg Cpar=1p\n"
                     "L1 b 0 1m Rpar=10k Cpar=2p\n.tran 1u 1m\n.end\n")
    by = {el.name: el for el in c.elements}
    assert isinstance(by["L_C1_ser"], Inductor) and isinstance(by["R_C1_ser"], Resistor)
    assert by["C1"].nodes[0] == "b" and by["L_C1_ser"].nodes[1] == "0"
    assert isinstance(by["C_C1_par"], Capacitor) and by["C_C1_par"].nodes == ("b", "0")
    assert by["R_L1_par"].value == pytest.approx(1e4) and by["C_L1_par"].nodes == ("b", "0")


@pytest.mark.parametrize("line, message", [
    ("L1 a 0 1m Rx=1", "unsupported parameter 'Rx' on inductor 'L1'"),
    ("V2 a 0 1 Lser=1n", "unsupported parameter 'Lser' on source 'V2'"),
])
def test_other_parameters_are_named_errors(line, message):
    with pytest.raises(NetlistError) as info:
        parse_string(f"t\nV1 a 0 1\n{line}\n.end\n", file="lt.cir")
    d = info.value.diagnostics[0]
    assert message in d.message and d.location.line == 3


def test_lib_with_one_file_is_an_include(tmp_path):
    (tmp_path / "m.lib").write_text(".model DX D(IS=1e-12)\n")
    (tmp_path / "top.cir").write_text("t\nV1 a 0 1\nD1 a 0 DX\n.lib m.lib\n.end\n")
    c = parse_file(str(tmp_path / "top.cir"))
    assert "dx" in c.models


def test_if_function_tran_tstop_and_a_floating_gate_drive(tmp_path, ngspice):
    """LTspice's if(c, a, b) is c ? a : b; its .tran TSTOP is .tran 0 TSTOP, whose step
    follows the sources (1/100 of the PWM period, 5000 steps a run at least: 20 ns here,
    not TSTOP/1000, which a longer run would make a PWM period);
    'V(sw) + if(...)' is a comparator whose branches are linear (v(sw) + 11.5, v(sw)). The
    driver's output against ngspice's, the if() written as the ternary ngspice reads."""
    deck = """ltspice forms
Vpwm pwm 0 PULSE(0 12 0 10n 10n 5u 10u)
Vsw sw 0 SIN(3 2 33k)
B1 drv 0 V=V(sw)+if(V(pwm)>6, 11.5, 0)
R1 drv 0 1k
.tran 100u
.end
"""
    c = parse_string(deck)
    assert c.tran.tstop == 100e-6 and c.tran.no_tstep
    res = simulate_circuit(c, probes=["v(drv)"])
    res.raise_if_error()
    assert any("step h = 20 ns: LTspice's .tran 0 TSTOP gives no step" in n
               for n in res.notes)
    assert any(".tran TSTOP (LTspice" in n for n in c.notes)
    ng = ngspice_wrdata(deck.replace("if(V(pwm)>6, 11.5, 0)", "(V(pwm)>6 ? 11.5 : 0)")
                        .replace(".tran 100u", ".tran 10n 100u"), ["v(drv)"], tmp_path)
    # away from the PWM edges (10 ns ramps), on every ngspice point
    t = ng[:, 0]
    away = np.abs(((t + 2.5e-6) % 5e-6) - 2.5e-6) > 0.2e-6
    got = np.interp(t[away], res.t, res["v(drv)"])
    assert np.max(np.abs(got - ng[away, 1])) < 1e-3


def test_tran_0_tstop_steps_by_the_sources():
    # a 100 kHz PWM over 10 ms: 1/100 of its period, where TSTOP/1000 (the print interval)
    # would be one step a period (a bootstrapped buck then read 9.7 V for ngspice's 7.8 V)
    from netlist.studies.timestep import tran_step

    c = parse_string("t\nV1 a 0 PULSE(0 1 0 10n 10n 5u 10u)\nR1 a 0 1\n.tran 0 10m\n.end\n")
    h, note = tran_step(c.tran, [c.element("V1").waveform], c.tran.tstop)
    assert h == pytest.approx(100e-9) and "LTspice's .tran 0 TSTOP" in note
    assert c.tran.tstep == pytest.approx(10e-6)  # (the print interval)


def test_tran_0_tstop_resolves_an_exp_source():
    # an EXP of 1 us time constants into an RC of 1 us over 10 ms: .tran 0 10m stepped by
    # 5000 steps a run (2 us) put v(o) at 0.2162 V 1 us after the rise where the analytic
    # 1 - (1 + t/tau) e^(-t/tau) is 0.26424 V; the step also resolves the smooth sources
    body = "V1 g 0 EXP(0 1 1m 1u 5m 1u)\nR1 g o 1k\nC1 o 0 1n\n"
    for tran in (".tran 0 10m", ".tran 10m"):
        res = simulate_circuit(parse_string(f"t\n{body}{tran}\n.end\n"), probes=["v(o)"])
        for dt, want in ((1e-6, 1 - 2 * np.exp(-1)), (2e-6, 1 - 3 * np.exp(-2))):
            got = np.interp(1e-3 + dt, res.t, res["v(o)"])
            assert got == pytest.approx(want, rel=1e-3)  # 0.26413 V against 0.26424 V


def test_a_tran_without_tstep_writes_ngspice_a_tstep_and_reads_back_the_same_circuit():
    from netlist.parser import parse_string
    from netlist.writer import write_circuit

    c = parse_string("t\nV1 a 0 1\nR1 a 0 1\nC1 a 0 1u\n.tran 2m\n.end\n")
    assert c.tran.no_tstep and c.tran.tstep == 2e-6
    text = write_circuit(c)
    assert ".tran 2u 2m" in text  # (ngspice refuses TSTEP 0)
    back = parse_string(text)
    assert back == c and not back.tran.no_tstep
