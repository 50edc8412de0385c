"""Inductors coupled with |k| = 1 read as an ideal transformer and its magnetizing
inductance (:mod:`netlist.perfect_coupling`), side by side with ngspice, which runs them."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_run

from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.realistic import simulate_devices
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit

FLYBACK = """flyback, K = 1
V1 a 0 PULSE(0 10 0 1n 1n 5u 10u)
R1 a b 1
L1 b 0 10u
L2 c 0 40u
K1 L1 L2 1
D1 c o dm
C1 o 0 1u
R2 o 0 100
.model dm D
.tran 10n 200u
.end
"""

# k = -1 (the dots opposite), initial currents, a resistive secondary: the signs and the
# magnetizing current's start im = i1 + n i2, n = -2
REVERSED = """transformer, k = -1, initial currents
V1 a 0 SIN(0 5 50k)
R1 a b 2
L1 b 0 10u IC=0.1
L2 c 0 40u IC=0.02
K1 L1 L2 -1
R2 c 0 50
.tran 10n 100u UIC
.end
"""


def _mean(t, y, t0):
    keep = t >= t0
    return float(np.trapezoid(y[keep], t[keep]) / (t[keep][-1] - t[keep][0]))


def test_flyback_with_unity_coupling_against_ngspice(tmp_path, ngspice):
    c = parse_string(FLYBACK)
    names = {el.name for el in c.elements}
    assert {"VL1", "L1_m", "FL2", "EL2", "VL2"} <= names and "L1" not in names
    assert any("turns ratios to L1: L2 2)" in n for n in c.notes)
    res = simulate_devices(c, devices="pwl", probes=["v(o)", "i(VL2)"])
    ng, log = ngspice_run(FLYBACK, ["v(o)", "i(L2)"], tmp_path)
    assert ng is not None, log
    t = np.asarray(res.t)
    # mean output over the second half: ngspice 9.52 V; pelcs 9.53 V (pwl diode)
    want = _mean(ng[:, 0], ng[:, 1], 100e-6)
    assert _mean(t, np.asarray(res["v(o)"]), 100e-6) == pytest.approx(want, rel=0.01)
    # the secondary winding's current is i(L2) of ngspice
    want_i = _mean(ng[:, 2], ng[:, 3], 100e-6)
    assert _mean(t, np.asarray(res["i(VL2)"]), 100e-6) == pytest.approx(want_i, rel=0.01)


def test_reversed_coupling_and_initial_currents_against_ngspice(tmp_path, ngspice):
    c = parse_string(REVERSED)
    (lm,) = [el for el in c.elements if el.name == "L1_m"]
    assert lm.ic == pytest.approx(0.1 - 2 * 0.02)
    res = simulate_circuit(c, probes=["v(c)", "i(L1)", "i(L2)", "i(VL1)"])
    # i(L1), i(L2) name the winding currents, as in ngspice: the 0 V sources' currents
    assert np.array_equal(np.asarray(res["i(L1)"]), np.asarray(res["i(VL1)"]))
    ng, log = ngspice_run(REVERSED, ["v(c)", "i(L1)", "i(L2)"], tmp_path)
    assert ng is not None, log
    tt = np.linspace(1e-6, 100e-6, 400)
    for k, p in enumerate(["v(c)", "i(L1)", "i(L2)"]):
        want = np.interp(tt, ng[:, 2 * k], ng[:, 2 * k + 1])
        got = np.interp(tt, np.asarray(res.t), np.asarray(res[p]))
        assert np.max(np.abs(got - want)) <= 0.01 * np.max(np.abs(want)), p


def test_the_deck_written_for_ngspice_has_the_windings_and_the_k_line(tmp_path, ngspice):
    # the transformer's elements are a group built for the K line: ngspice gets the
    # netlist's L and K lines back, and runs them as it runs the netlist
    written = write_circuit(parse_string(REVERSED))
    assert "L1 b 0 10u" in written and "L2 c 0 40u" in written and "K1 L1 L2 -1" in written
    assert "VL1" not in written and "L1_m" not in written and "EL2" not in written
    (tmp_path / "netlist").mkdir()
    (tmp_path / "written").mkdir()
    ng, log = ngspice_run(REVERSED, ["v(c)"], tmp_path / "netlist")
    ngw, logw = ngspice_run(written, ["v(c)"], tmp_path / "written")
    assert ng is not None and ngw is not None, (log, logw)
    tt = np.linspace(1e-6, 100e-6, 400)
    a = np.interp(tt, ng[:, 0], ng[:, 1])
    b = np.interp(tt, ngw[:, 0], ngw[:, 1])
    assert np.max(np.abs(a - b)) <= 1e-6 * np.max(np.abs(a))


def test_a_winding_in_two_couplings_stays_refused():
    deck = FLYBACK.replace("K1 L1 L2 1\n", "K1 L1 L2 1\nL3 c 0 40u\nK2 L1 L3 0.5\n")
    with pytest.raises(NetlistError, match="inductance matrix"):
        simulate_circuit(parse_string(deck), probes=["v(o)"])


# a full-wave rectifier from a centre-tapped secondary: three windings, all pairs k = 1
CENTRE_TAP = """centre-tapped full-wave rectifier
V1 a 0 SIN(0 10 1k)
R1 a b 0.5
L1 b 0 10m
L2 s1 0 2.5m
L3 0 s2 2.5m
K1 L1 L2 1
K2 L2 L3 1
K3 L1 L3 1
D1 s1 o dm
D2 s2 o dm
C1 o 0 100u
R2 o 0 50
.model dm D(IS=1e-14 RS=0.05)
.tran 1u 10m
.end
"""


def test_centre_tapped_secondary_against_ngspice(tmp_path, ngspice):
    c = parse_string(CENTRE_TAP)
    assert any("turns ratios to L1: L2 0.5, L3 0.5" in n for n in c.notes)
    res = simulate_devices(c, devices="pwl", probes=["v(o)"])
    ng, log = ngspice_run(CENTRE_TAP, ["v(o)"], tmp_path)
    assert ng is not None, log
    want = _mean(ng[:, 0], ng[:, 1], 5e-3)
    got = _mean(np.asarray(res.t), np.asarray(res["v(o)"]), 5e-3)
    assert got == pytest.approx(want, rel=0.02)  # 3.9982 V, ngspice 3.9976 V



# a flyback whose primary switch opens the primary (the magnetizing current goes over to the
# secondary then), and a SEPIC with its two inductors on one core: the transformer's E and F
# sources impose no voltage or current, so neither the topology checks nor the diode types
# read them as sources (both were refused: a cutset L1_m, FL2; no explicit LCS with S1=off)
FLYBACK_SWITCHED = """flyback, primary switch, k = 1
V1 in 0 DC 24
R1 in n1 10m
L1 n1 n2 1.8m
L2 0 n3 1.8m
K12 L1 L2 1
S1 n2 0 g 0 swm
.model swm sw(vt=1 ron=0.1 roff=1e9)
Vg g 0 PULSE(0 5 0 1n 1n 8u 16.7u)
D1 n3 out dm
.model dm d(is=1e-14)
C3 out 0 36u
R2 out 0 115
.tran 1u 5m
.end
"""
SEPIC = FLYBACK_SWITCHED.replace("flyback, primary switch", "sepic").replace(
    "L2 0 n3 1.8m", "C2 n2 n3 1u\nL2 0 n3 1.8m")


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("deck", [FLYBACK_SWITCHED, SEPIC], ids=["flyback", "sepic"])
def test_a_switched_primary_with_unity_coupling_against_ngspice(tmp_path, ngspice, deck):
    res = simulate_devices(parse_string(deck), devices="pwl", probes=["v(out)"])
    ng, log = ngspice_run(deck, ["v(out)"], tmp_path)
    assert ng is not None, log
    t, y = np.asarray(res.t), np.asarray(res["v(out)"])
    # the start-up overshoot and its decay (ngspice: 28.8 V at 1 ms, 19.3 V at 5 ms) and the
    # mean over the second half (flyback: ngspice 24.19 V, pelcs 24.18 V; SEPIC 24.19, 24.00)
    for at in (1e-3, 3e-3, 5e-3):
        assert np.interp(at, t, y) == pytest.approx(np.interp(at, ng[:, 0], ng[:, 1]),
                                                    rel=0.02)
    assert _mean(t, y, 2.5e-3) == pytest.approx(_mean(ng[:, 0], ng[:, 1], 2.5e-3), rel=0.01)
    # (the ideal run too: a closed S1 ties C2 to the transformer's E, no capacitor loop)
    simulate_circuit(parse_string(deck), probes=["v(out)"])


def test_an_element_built_for_a_k_line_is_located_at_its_winding_and_names_the_line():
    c = parse_string(SEPIC)
    el, note = c.located(["L1_m", "D1"])
    assert el.name == "L1_m" and el.location.line == 4
    assert note == "; L1_m is part of what pelcs built for K12 (ideal transformer)"
    assert c.located(["D1"]) == (c.element("D1"), "")
