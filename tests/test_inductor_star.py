"""Inductor cutsets at a floating group of voltage sources (netlist.inductor_cutsets): a
three-phase source whose star point floats, a line inductor on each phase into an
unbalanced grounded-star load. Checked against the phasor solution and against ngspice."""

from __future__ import annotations

import math

import numpy as np
import pytest

from netlist.formulation import formulate
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit

R = (10.0, 20.0, 40.0)
L = (10e-3, 20e-3, 5e-3)
AMP, F = 100.0, 50.0

STAR = f"""floating star point
V1 a n SIN(0 {AMP} {F} 0 0 0)
V2 b n SIN(0 {AMP} {F} 0 0 -120)
V3 c n SIN(0 {AMP} {F} 0 0 120)
L1 a x {L[0]} {{ic1}}
L2 b y {L[1]}
L3 c z {L[2]}
R1 x 0 {R[0]}
R2 y 0 {R[1]}
R3 z 0 {R[2]}
.tran 20u 200m uic
.end
"""


def _phasors():
    """Line currents and star-point voltage (complex amplitudes, sin reference)."""
    w = 2 * math.pi * F
    u = [AMP * np.exp(1j * math.radians(p)) for p in (0.0, -120.0, 120.0)]
    y = [1.0 / (r + 1j * w * lk) for r, lk in zip(R, L, strict=True)]
    phi = -sum(uk * yk for uk, yk in zip(u, y, strict=True)) / sum(y)
    return [(phi + uk) * yk for uk, yk in zip(u, y, strict=True)], phi


def _wave(z, t):
    return np.abs(z) * np.sin(2 * math.pi * F * t + np.angle(z))


def test_the_star_keeps_three_states_and_the_sum_at_zero():
    c = parse_string(STAR.format(ic1=""))
    system = formulate(c)
    assert list(system.states) == ["i(L1)", "i(L2)", "i(L3)"]
    res = simulate_circuit(c, probes=["i(L1)", "i(L2)", "i(L3)", "v(n)"])
    total = res["i(L1)"] + res["i(L2)"] + res["i(L3)"]
    assert np.max(np.abs(total)) < 1e-9
    currents, phi = _phasors()
    late = res.t > 0.15  # the transients (L/R at most 1 ms) long gone
    for k, z in enumerate(currents, start=1):
        want = _wave(z, res.t[late])
        assert np.max(np.abs(res[f"i(L{k})"][late] - want)) < 5e-3 * abs(z), k
    assert np.max(np.abs(res["v(n)"][late] - _wave(phi, res.t[late]))) < 5e-3 * AMP
    assert any(n.startswith("L1, L2, L3: the only branches") for n in res.notes)


def test_initial_currents_that_break_the_cutset_are_projected():
    res = simulate_circuit(parse_string(STAR.format(ic1="IC=1")), probes=["i(L1)", "i(L2)"])
    # c = 1 A / (100 + 50 + 200) 1/H: each current moves by c / L_k
    c = 1.0 / sum(1 / lk for lk in L)
    assert res["i(L1)"][0] == pytest.approx(1 - c / L[0])
    assert res["i(L2)"][0] == pytest.approx(-c / L[1])
    assert any("initial currents sum to 1 A" in n for n in res.notes)


def test_the_star_against_ngspice(ngspice):
    from ngspice_checks.runner import run_ngspice

    text = STAR.format(ic1="")
    probes = ["i(L1)", "i(L3)", "v(n)"]
    res = simulate_circuit(parse_string(text), probes=probes)
    ng = run_ngspice(text, probes, timeout=120)
    for p in probes:
        got = np.interp(ng.time, res.t, res[p])
        swing = np.max(np.abs(ng[p]))
        assert np.max(np.abs(got - ng[p])) < 0.01 * swing, p
