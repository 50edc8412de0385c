"""A small-signal analysis perturbs a source that the formulation took for a DC one: a
capacitor that it alone holds (netlist.reductions.held_capacitors) then carries a current
through it, and a loop of capacitors through it (netlist.capacitor_links) takes the source's
derivative. The node voltages of the first stay exact; the rest must be refused, not printed.

References: ngspice's AC analysis of the same linear circuits (without the switch, which
drives a separate resistor only)."""

from __future__ import annotations

import numpy as np
import pytest

from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.ac import ac_analysis

# S1 only switches R3 on its own source: it gives the analysis its period (10 µs).
CLOCK = """Vg g 0 PULSE(0 1 0 1n 1n 5u 10u)
S1 y 0 g 0 sw
R3 y g2 1k
V2 g2 0 1
.model sw sw(vt=0.5)
"""

# Cin across the DC input V1, R1 C2 from it.
HELD = "held\nV1 a 0 10\nCin a 0 10u\nR1 a b 100\nC2 b 0 1u\n" + CLOCK + \
    ".tran 0.1u 1m\n.end\n"

# Three capacitors in series across V1 (C3 closes the loop), a resistor from each inner node.
CHAIN = "chain\nV1 a 0 10\nC1 a m 1u\nC2 m p 2u\nC3 p 0 1u IC=10\nR1 m 0 1k\nR2 p 0 1k\n" \
    + CLOCK + ".tran 0.1u 1m uic\n.end\n"


def test_current_of_a_perturbed_source_with_a_held_capacitor_is_refused():
    # ngspice (AC 1 on V1): i(V1) is +16.30 dB at 100 kHz (Cin's j w C V1); pelcs printed
    # -40.00 dB (R1's current alone)
    with pytest.raises(NetlistError, match="Cin") as exc:
        ac_analysis(parse_string(HELD), period=None, inject="V1", probes=["i(V1)"],
                    freqs=np.array([1e5]))
    assert "perturb" in str(exc.value)
    with pytest.raises(NetlistError, match="Cin"):
        ac_analysis(parse_string(HELD), period=None, inject="V1", probes=["i(Cin)"],
                    freqs=np.array([1e5]))


def test_node_voltages_beside_a_held_capacitor_stay_exact():
    # v(b)/V1 = 1/(1 + j w R1 C2): ngspice -1.4453 dB at 1 kHz
    fr = ac_analysis(parse_string(HELD), period=None, inject="V1", probes=["v(b)"],
                     freqs=np.array([1e3]))
    want = 1 / (1 + 2j * np.pi * 1e3 * 100 * 1e-6)
    assert fr.H[0, 0] == pytest.approx(want, rel=1e-3)


def test_a_perturbed_source_in_a_loop_of_capacitors_is_refused():
    # ngspice (AC 1 on V1): v(m) -4.437 dB, v(p) -7.959 dB at 100 kHz; pelcs printed 0.000 dB
    # for both (the tree capacitors' rows miss C3 C_L dV1/dt)
    with pytest.raises(NetlistError, match="C3") as exc:
        ac_analysis(parse_string(CHAIN), period=None, inject="V1", probes=["v(m)", "v(p)"],
                    freqs=np.array([1e5]))
    assert "perturb" in str(exc.value)
