"""An ideal run of a netlist whose diodes and switches have models says what it leaves out of
them: a half-wave rectifier's 1N4007 drops about 0.7 V of 10 V, so the ideal run's mean output
is 10 % above ngspice's (a third-party rectifier: 3.18 V against 2.90 V)."""

from __future__ import annotations

from netlist.parser import parse_string
from pelcs.api import simulate

RECTIFIER = """half-wave rectifier
V1 in 0 SIN(0 10 100)
D1 in out D1N4007
R1 out 0 10k
S1 out x in 0 SW1
R2 x 0 1meg
.model D1N4007 D(IS=7.02767n RS=0.0341512 N=1.80803)
.model SW1 SW(VT=20)
.tran 10u 20m
.end
"""


def test_the_ideal_run_names_the_models_it_leaves_out():
    res = simulate(RECTIFIER, probes=["v(out)"])
    note = next(n for n in res.notes if n.startswith("ideal devices:"))
    # (ngspice's SW default RON is 1 ohm)
    assert ("D1's forward voltage (D1N4007: 0.55 V at 1 mA), S1's on-resistance (1 Ω) left "
            "out") in note
    assert "--devices pwl" in note


def test_the_pwl_run_and_a_circuit_without_models_say_nothing():
    res = simulate(RECTIFIER, probes=["v(out)"], devices="pwl")
    assert not any(n.startswith("ideal devices:") for n in res.notes)
    from netlist.studies.left_out import models_left_out

    assert models_left_out(parse_string("t\nV1 a 0 1\nR1 a 0 1\n.tran 1m 1\n")) is None
