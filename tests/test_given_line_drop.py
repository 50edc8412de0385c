"""The drop ``pelcs check`` estimates for a diode line the user gives (``--pwl
NAME=VF:RON``): the distance from that line to the diode's model at its current, on the
characteristic the fits follow (netlist.diode_dc: the area, ISR, IKF), not Shockley's
equation of the model's IS, N and RS alone."""

from __future__ import annotations

import math

from netlist.diode_dc import VT_THERMAL
from netlist.parser import parse_string
from ngspice_checks.measures import _nonideality_drop

DECK = """diode of area 100
V1 a 0 1
D1 a 0 DX area=100
.model DX D(IS=1e-14 N=1 RS=0.5)
.tran 1u 1m
.end
"""


def test_a_line_on_the_diodes_characteristic_drops_nothing():
    c = parse_string(DECK)
    # ngspice's diode of area 100 at 1 A: IS 1e-12 A, RS 5 mOhm
    v = VT_THERMAL * math.log1p(1.0 / 1e-12) + 0.005 * 1.0
    assert _nonideality_drop(c, c.element("D1"), 1.0, v, 0.0) < 1e-4
    # (the area left out: Vt ln(100) + 0.495 V away)
    assert abs(_nonideality_drop(c, c.element("D1"), 1.0, v + 0.1, 0.0) - 0.1) < 1e-4
