"""TC1/TC2 (TCE) of resistors, capacitors and inductors at a temperature other than TNOM,
scaled as ngspice scales them (netlist.value_scaling): checked against ngspice and by hand."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit

# ngspice's regression test misc/resume-1.cir, its first part: a 1k resistor with
# TC1 = 0.03125 at .temp 91 is 1k (1 + 0.03125 (91 - 27)) = 3k: tau = 3 ms, not 1 ms
RC = """RC at 91 C
v1 1 0 dc 5
r1 1 2 1k tc1=0.03125
c2 2 0 1u
.temp 91
.tran 0.2u 2ms uic
.end
"""

# every form at once: TC2, DTEMP, an instance TEMP, TCE, a capacitor's and an inductor's TC1,
# the circuit's temperature from .options temp and TNOM from .options tnom
BRANCHES = """temperature coefficients
v1 in 0 dc 1
ra in a 1k tc1=0.01 tc2=1e-4 dtemp=10
ca a 0 1u
rb in b 2k tc1=-0.002 temp=100
cb b 0 1u tc1=0.005 tc2=2e-5
rc in c 1k tce=0.5
cc c 0 1u
rl in d 100
ld d 0 10m tc1=0.004
.options temp=60 tnom=20
.tran 1u 4m uic
.end
"""


def test_the_resistor_is_scaled_at_the_circuit_temperature():
    circuit = parse_string(RC)
    assert circuit.element("r1").value == pytest.approx(3000.0, rel=1e-12)
    assert any("r1: value scaled by 3 by its TC1, TC2 from its nominal 27 °C to its 91 °C" in n
               for n in circuit.notes)
    res = simulate_circuit(circuit, probes=["v(2)"])
    want = 5 * (1 - np.exp(-res.t / 3e-3))
    assert np.abs(res["v(2)"] - want).max() < 1e-3


def test_at_the_nominal_temperature_nothing_changes():
    circuit = parse_string(RC.replace(".temp 91\n", ""))
    assert circuit.element("r1").value == 1000.0
    assert not any("TC1" in n for n in circuit.notes)


def test_every_form_by_hand():
    c = parse_string(BRANCHES)
    d = 60 + 10 - 20
    assert c.element("ra").value == pytest.approx(1e3 * (1 + 0.01 * d + 1e-4 * d * d))
    assert c.element("rb").value == pytest.approx(2e3 * (1 - 0.002 * 80))
    assert c.element("cb").value == pytest.approx(1e-6 * (1 + 0.005 * 40 + 2e-5 * 1600))
    assert c.element("rc").value == pytest.approx(1e3 * 1.01 ** (0.5 * 40))
    assert c.element("ld").value == pytest.approx(10e-3 * (1 + 0.004 * 40))


def test_every_form_against_ngspice(tmp_path, ngspice):
    probes = ["v(a)", "v(b)", "v(c)", "v(d)"]
    ng = ngspice_wrdata(BRANCHES, probes, tmp_path)
    res = simulate_circuit(parse_string(BRANCHES), probes=probes)
    for k, probe in enumerate(probes):
        got = np.interp(ng[:, 2 * k], res.t, res[probe])
        assert np.abs(got - ng[:, 2 * k + 1]).max() < 5e-3, probe


def test_a_parameter_changed_again_keeps_the_factor():
    deck = RC.replace("r1 1 2 1k", "r1 1 2 {rv}").replace(".temp", ".param rv=1k\n.temp")
    first = parse_string(deck, params={"rv": 1000.0}, reuse=True)
    again = parse_string(deck, params={"rv": 2000.0}, reuse=True)
    assert first.element("r1").value == pytest.approx(3000.0)
    assert again.element("r1").value == pytest.approx(6000.0)
