"""Loops of capacitors and voltage sources (netlist.capacitor_loops): two capacitors in
series across a source keep one state, the charge at their midpoint, checked against
analytic answers and against ngspice (initial conditions that break the loop: ngspice keeps
the midpoint's charge)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from netlist.errors import NetlistError
from netlist.formulation import formulate
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit

# 1 µF from a 10 V source to m, 3 µF from m to ground, 1 kΩ from m to ground: with UIC the
# midpoint starts where the charge at m puts it, then decays with τ = R (C1 + C2) = 4 ms.
DIVIDER = """two capacitors in series across a source
V1 a 0 DC 10
C1 a m 1u {ic1}
C2 m 0 3u {ic2}
R1 m 0 1k
.tran 10u 8m uic
.end
"""

TAU = 1e3 * 4e-6


@pytest.mark.parametrize("ic1, ic2, v0", [
    ("", "", 2.5),  # charge 0 at m: 1u (v - 10) + 3u v = 0
    ("IC=2", "IC=3", 4.25),  # 1u (v - 10) + 3u v = 1u (-2) + 3u (3): they break the loop
])
def test_the_midpoint_keeps_its_charge_and_decays_with_the_sum(ic1, ic2, v0):
    c = parse_string(DIVIDER.format(ic1=ic1, ic2=ic2))
    system = formulate(c)
    assert list(system.states) == ["v(C1_C2)"]
    res = simulate_circuit(c, probes=["v(m)", "v(a,m)"])
    want = v0 * np.exp(-res.t / TAU)
    assert np.max(np.abs(res["v(m)"] - want)) < 2e-3 * v0
    # the voltage of C1 follows from the source and the state: Kirchhoff's law holds
    assert np.allclose(res["v(a,m)"] + res["v(m)"], 10.0)
    note = next(n for n in res.notes if n.startswith("C1, C2: in a loop"))
    assert "V1" in note and "C1_C2 = 4 µF" in note
    assert ("jump at t = 0" in note) == bool(ic1)


def test_driven_through_the_divider_matches_the_analytic_response():
    # (C1 + C2) v' + v / R = C1 V'(t), V = sin(ωt): v = |H| sin(ωt + φ) + B exp(-t/τ),
    # H = jωRC1 / (1 + jωτ), B from v(0) = 0
    text = DIVIDER.replace("DC 10", "SIN(0 1 200)").format(ic1="", ic2="")
    res = simulate_circuit(parse_string(text), probes=["v(m)"], step=2e-6)
    w = 2 * math.pi * 200
    h = 1j * w * 1e3 * 1e-6 / (1 + 1j * w * TAU)
    t = res.t
    want = abs(h) * np.sin(w * t + np.angle(h)) - abs(h) * math.sin(np.angle(h)) \
        * np.exp(-t / TAU)
    assert np.max(np.abs(res["v(m)"] - want)) < 2e-3 * abs(h)


def test_a_chain_of_three_on_a_varying_source_stays_refused():
    # the node between C2 and C3 reaches the source through capacitors only: not a star,
    # and the loop's charge constraint would need the source's derivative
    text = ("chain\nV1 a 0 SIN(0 10 1k)\nC1 a m 1u\nC2 m p 1u\nC3 p 0 1u\nR1 m 0 1k\n"
            "R2 p 0 1k\n.tran 1u 1m\n.end\n")
    with pytest.raises(NetlistError, match="loop of capacitors/voltage sources"):
        formulate(parse_string(text)).mode(())


def test_uic_initial_conditions_against_ngspice(ngspice):
    from ngspice_checks.runner import run_ngspice

    text = DIVIDER.format(ic1="IC=2", ic2="IC=3")
    res = simulate_circuit(parse_string(text), probes=["v(m)"])
    ng = run_ngspice(text, ["v(m)"], timeout=60)
    # ngspice's first point (after t = 0) already holds the kept charge: 4.25 V
    assert abs(ng["v(m)"][ng.time > 0][0] - 4.25) < 1e-3
    got = np.interp(ng.time, res.t, res["v(m)"])
    assert np.max(np.abs(got - ng["v(m)"])[ng.time > 0]) < 5e-3 * 4.25


# A half bridge: S1 and S2 switch the RL load between the supply and ground, its other end
# at the capacitors' midpoint m; the two switches turn at the same instant (one control).
HALF_BRIDGE = """small half bridge
V1 a 0 DC 20
C1 a m 20u
C2 m 0 20u
S1 a sw g 0 SWP
S2 sw 0 0 g SWN
L1 sw x 1m
R1 x m 5
Rm1 a m 10k
Rm2 m 0 10k
Vg g 0 PULSE(0 1 0 1n 1n 39.998u 80u)
.model SWP SW(VT=0.5 RON=1m ROFF=1e9)
.model SWN SW(VT=-0.5 RON=1m ROFF=1e9)
.tran 0.1u 2m uic
.end
"""


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_half_bridge_against_ngspice(ngspice):
    from ngspice_checks.runner import run_ngspice

    probes = ["v(m)", "i(L1)"]
    res = simulate_circuit(parse_string(HALF_BRIDGE), probes=probes)
    ng = run_ngspice(HALF_BRIDGE, probes, timeout=120)
    keep = ng.time > 1e-3
    for p in probes:
        got = np.interp(ng.time, res.t, res[p])[keep]
        want = ng[p][keep]
        swing = np.max(want) - np.min(want)
        # within 2 % of the swing everywhere past 1 ms (the switch instants differ by a step)
        assert np.max(np.abs(got - want)) < 0.02 * swing + 1e-6, p
    rms = lambda y: float(np.sqrt(np.mean(y * y)))  # noqa: E731
    assert abs(rms(np.interp(ng.time, res.t, res["i(L1)"])[keep]) - rms(ng["i(L1)"][keep])) \
        < 0.01 * rms(ng["i(L1)"][keep])


def test_a_probe_of_a_reduced_capacitor_says_what_to_probe():
    c = parse_string(DIVIDER.format(ic1="", ic2=""))
    with pytest.raises(NetlistError) as info:
        simulate_circuit(c, probes=["v(C1)"])
    (d,) = info.value.diagnostics
    assert "reduced with the others to one capacitor, C1_C2" in d.message
    assert d.hint.startswith("probe v(a,m)")
    with pytest.raises(NetlistError) as info:
        simulate_circuit(c, probes=["i(C2)"])
    assert "i(C1_C2) is their current out of node m" in info.value.diagnostics[0].hint
