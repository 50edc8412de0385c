"""A resistor switched between two constants on a comparison of the circuit
(netlist.switched_resistor), against ngspice: the waveforms, and the deck pelcs writes."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_print, ngspice_wrdata

from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit

DECK = """resistors switched on comparisons: a source's voltage, a current, in a subcircuit
.subckt load p n ctl params: rlo=100
Rx p n r = 'v(ctl) < 0.5 ? 1k : {rlo}'
.ends
V1 in 0 DC 1
Vc ctl 0 PULSE(0 1 0.3m 1u 1u 0.5m 1m)
Vs in in2 0
X1 in2 a ctl load rlo=200
C1 a 0 1u
R2 a 0 1k
R3 a b R={i(Vs) > 0.6m ? 50 : 500}
C2 b 0 0.5u
.tran 1u 2m
.end
"""


def test_switched_resistors_against_ngspice(tmp_path, ngspice):
    c = parse_string(DECK)
    assert c.element("X1.Rx").value == 200 and c.element("X1.Rx#r2").value == 800
    assert c.element("R3").value == 50 and c.element("R3#r2").value == 450
    run = simulate_circuit(c, probes=["v(a)", "v(b)"])
    data = ngspice_wrdata(DECK, ["v(a)", "v(b)"], tmp_path)
    t = data[:, 0]
    # (measured: median 2e-6 and 7e-6 V, at most 0.3 and 0.7 mV just past the switching
    # instants, where ngspice's value changes at its next time point)
    for k in range(2):
        ours = np.interp(t, run.t, run.y[:, k])
        err = np.abs(ours - data[:, 2 * k + 1])
        assert np.median(err) < 2e-5 and err.max() < 2e-3, (k, err.max())
    # the deck pelcs writes: the lines flattened, the instance's parameter evaluated
    text = write_circuit(c)
    assert "R.X1.Rx in2 a R='(v(ctl) < 0.5) ? 1k : 200'" in text
    probes = ["v(a)[1500]", "v(b)[1500]"]
    (tmp_path / "w").mkdir()
    assert ngspice_print(text, probes, tmp_path / "w") == ngspice_print(DECK, probes, tmp_path)


@pytest.mark.parametrize("value, words", [
    ("'v(c) > 1 ? 0 : 1k'", "not a comparison choosing between two positive resistances"),
    ("'v(c) > 1 ? v(c) : 1k'", "depends on v(c)"),
])
def test_other_forms_are_refused_where_they_are(value, words):
    with pytest.raises(NetlistError) as exc:
        parse_string(f"t\nV1 c 0 1\nR1 c 0 R={value}\n.tran 1u 10u\n")
    assert words in str(exc.value) and "<string>:3:" in str(exc.value)
