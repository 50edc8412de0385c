"""The operating point's state where the diodes' multipliers cancel a source exactly (a pwl
diode's Vf held by its λ on an inductor whose only path it is): the round-off of that
cancellation (1e-16 A) is zero, as the rest of the operating point's round-off, not a current
the diode would have to take in an impulse. The run said "t = 0: the initial state is
inconsistent with the diodes ... the state jumps ()" of a state ngspice starts at (0)."""

from __future__ import annotations

import pytest

from netlist.parser import parse_string
from netlist.studies.realistic import simulate_devices

DECK = """forward converter's secondary, coupled inductors
V1 in 0 PULSE(0 10 0 1u 1u 20u 50u)
R0 in p 1
L1 p 0 100u
L2 s 0 100u
K1 L1 L2 0.95
D1 s out DM
C1 out 0 10u
R1 out 0 50
.model DM D(IS=1e-14)
{ic}.tran 0.1u 200u
.end
"""


@pytest.mark.parametrize("ic", ["", ".ic v(out)=4\n"])
def test_the_start_is_consistent_without_a_note(ic):
    res = simulate_devices(parse_string(DECK.format(ic=ic)), devices="pwl",
                           probes=["i(L1)", "i(L2)", "v(out)"])
    assert not any("inconsistent" in n for n in res.notes), res.notes
    # (ngspice: 0 A, 0 A and 0 V or the .ic's 4 V)
    assert res.y[0] == pytest.approx([0.0, 0.0, 4.0 if ic else 0.0], abs=1e-12)
