"""What a Python controller measures is checked as a run's probes are: a current pelcs does not
compute (a source's, with a capacitor that sources alone join across it: its charging current
is left out) must be refused, not handed to the controller without that current."""

from __future__ import annotations

import numpy as np
import pytest

from lcs.controllers import SlidingSurface
from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit

# S1 connects Vb to the load Ry || Cy while i(V1) < 0. V1's current is Cp's and R1's: with Cp,
# i(V1) = -(v/R1 + Cp dv/dt), whose zero crossings lead v's by atan(w R1 Cp) = 51 degrees.
CIRCUIT = """controller reading a source current
V1 in 0 SIN(0 1 1k)
{cp}
R1 in 0 10
Vb b 0 DC 1
S1 b z ctl 0 sw
Rz z y 10
Ry y 0 100
Cy y 0 1u
Vc ctl 0 0
.model sw sw(vt=0.5)
.tran 1u 3m
.end
"""


def _run(cp: str):
    ctl = SlidingSurface("S1", {"i(V1)": 1.0}, on_when="negative")
    return simulate_circuit(parse_string(CIRCUIT.format(cp=cp)), probes=["v(y)"],
                            controllers=[ctl], step=1e-7, theta=1.0)


def test_a_controller_reading_a_current_pelcs_does_not_compute_is_refused():
    # Cp across V1 holds no state: pelcs's i(V1) would be R1's current alone (the run ended
    # at v(y) = 0.006 V, S1 off, where the circuit has it on at 0.909 V)
    with pytest.raises(NetlistError, match="charging current of Cp"):
        _run("Cp in 0 20u")


def test_with_the_capacitor_a_state_the_controller_reads_its_current():
    # the reference: Cp with an ESR of 1 mOhm (20 ns) is a state; at t = 3 ms v = 0 and
    # dv/dt > 0, so i(V1) = -w Cp < 0: S1 on, v(y) = Vb Ry / (Rz + Ry) = 0.909 V
    res = _run("Cp in cp 20u\nRcp cp 0 1m")
    assert res["v(y)"][-1] == pytest.approx(100 / 110, abs=1e-3)
    assert np.all(np.isfinite(res["v(y)"]))
