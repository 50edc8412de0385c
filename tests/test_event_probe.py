"""An event map's probe crossing (``pelcs orbit --event 'i(V1)>0'``) is checked as a run's
probes are: a current pelcs does not compute (a source's, with a capacitor that sources alone
join across it) must be refused, not sampled without that capacitor's current."""

from __future__ import annotations

import pytest

from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.sweep import circuit_map

# i(V1) = -(v/R1 + Cp dv/dt) with v = sin(w t): it crosses 0 upwards at w t = pi -
# atan(w R1 Cp), t = 0.357 ms (Cp made a state by 1 mOhm: the event map's phase 0.3569 ms).
# pelcs, leaving Cp's current out of i(V1), printed a converged orbit at phase 0.5 ms.
EVENT = """event on a source current
V1 in 0 SIN(0 1 1k)
Cp in 0 20u
R1 in 0 10
Vg g 0 PULSE(0 1 0 1n 1n 0.5m 1m)
S1 b y g 0 sw
Vb b 0 DC 1
Rz y z 10
Cz z 0 10u
Rl z 0 100
.model sw sw(vt=0.5)
.tran 1u 5m
.end
"""


def test_an_event_on_a_current_pelcs_does_not_compute_is_refused():
    with pytest.raises(NetlistError, match="charging current of Cp"):
        circuit_map(parse_string(EVENT), None, event="i(V1)>0")


def test_an_event_on_a_node_voltage_beside_it_is_read():
    m = circuit_map(parse_string(EVENT), None, event="v(in)<0")
    assert m is not None
