"""ngspice's start of a ``.tran`` without UIC: the DC operating point (capacitors open,
inductors shorted, sources at t = 0), element IC= values ignored; with UIC the initial
conditions. Checked on a hand-derived LCS, analytic circuits and ngspice side by side."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from lcs.simulation.initial import unsettled_in_note
from lcs.theory.operating_point import dc_point
from netlist.parser import parse_string
from netlist.studies.realistic import simulate_devices
from netlist.studies.transient import simulate_circuit


def test_dc_point_of_a_hand_derived_lcs():
    # x = (i_L, v_C): L from a 10 V source through 1 Ω into C || 4 Ω, and an ideal diode from
    # the node to a 3 V clamp: i_L' = (10 - i_L - v_C)/L, v_C' = (i_L - v_C/4 - λ)/C,
    # w = 3 - v_C >= 0 (the diode conducts λ when v_C would pass 3 V).
    # DC: v_C = 10 - i_L; unclamped 8 V > 3 V, so the diode holds v_C = 3 V, i_L = 7 A and
    # λ = i_L - v_C/4 = 6.25 A.
    A = np.array([[-1.0, -1.0], [1.0, -0.25]])
    B = np.array([[0.0], [-1.0]])
    C = np.array([[0.0, -1.0]])
    D = np.zeros((1, 1))
    E = np.array([[10.0], [0.0]])
    F = np.array([[3.0]])
    p = dc_point(A, B, C, D, E, F, np.array([1.0]), np.zeros(2))
    assert p.ok and not p.free.any()
    assert p.x == pytest.approx([7.0, 3.0]) and p.lam == pytest.approx([6.25])
    # with the clamp at 9 V the diode stays off: v_C = 8 V, i_L = 2 A
    p = dc_point(A, B, C, D, E, 3 * F, np.array([1.0]), np.zeros(2))
    assert p.x == pytest.approx([2.0, 8.0]) and p.lam == pytest.approx([0.0])


def test_a_state_no_dc_equation_sets_keeps_its_given_value():
    # two capacitors in series, only each other: their common charge is free; a DC current
    # into a capacitor alone has no operating point
    A = np.zeros((1, 1))
    p = dc_point(A, np.zeros((1, 0)), np.zeros((0, 1)), np.zeros((0, 0)), np.zeros((1, 1)),
                 np.zeros((0, 1)), np.array([0.0]), np.array([2.5]))
    assert p.ok and p.free.all() and p.x == pytest.approx([2.5])
    p = dc_point(A, np.zeros((1, 0)), np.zeros((0, 1)), np.zeros((0, 0)), np.ones((1, 1)),
                 np.zeros((0, 1)), np.array([1.0]), np.array([0.0]))
    assert not p.ok and "no solution" in p.reason


RC = "rc\nV1 in 0 DC 5\nR1 in a 1k\nC1 a 0 1u{ic}\n.tran 10u 1m{uic}\n.end\n"


def test_an_rc_starts_where_ngspice_does(tmp_path, ngspice):
    for ic, uic, start in (("", "", 5.0), (" IC=2", "", 5.0), (" IC=2", " uic", 2.0)):
        deck = RC.format(ic=ic, uic=uic)
        res = simulate_circuit(parse_string(deck), probes=["v(a)"])
        ng = ngspice_wrdata(deck, ["v(a)"], tmp_path)
        assert res["v(a)"][0] == pytest.approx(start)
        assert ng[0, 1] == pytest.approx(start, abs=1e-3)  # (its first row, t = 0 or just after)
        assert np.interp(ng[:, 0], res.t, res["v(a)"]) == pytest.approx(ng[:, 1], abs=2e-3)
        assert any("IC= of C1 ignored" in n for n in res.notes) == (ic != "" and uic == "")


BOOST = """boost that starts switching at 20 us
Vin in 0 DC 12
L1 in sw 100u
S1 sw 0 g 0 smod
.model smod SW(VT=2.5 RON=10m ROFF=1e9)
Vg g 0 PULSE(0 5 20u 10n 10n 4u 10u)
D1 sw out dmod
.model dmod D(IS=1e-12 RS=20m)
C1 out 0 100u
R1 out 0 10
.tran 0.1u 200u
.end
"""


def test_a_boost_starts_from_its_operating_point_as_in_ngspice(tmp_path, ngspice):
    # switch off at t = 0: the inductor carries (12 V - Vd)/10 Ω through the diode and the
    # capacitor holds 12 V - Vd (ideal diode: 1.2 A and 12 V)
    ideal = simulate_circuit(parse_string(BOOST), probes=["i(L1)", "v(out)"])
    assert ideal["i(L1)"][0] == pytest.approx(1.2) and ideal["v(out)"][0] == pytest.approx(12)
    res = simulate_devices(parse_string(BOOST), devices="pwl", probes=["i(L1)", "v(out)"])
    ng = ngspice_wrdata(BOOST, ["i(L1)", "v(out)"], tmp_path)
    assert res["i(L1)"][0] == pytest.approx(ng[0, 1], rel=0.01)
    assert res["v(out)"][0] == pytest.approx(ng[0, 3], rel=0.01)
    for col, probe in ((1, "i(L1)"), (3, "v(out)")):
        got = np.interp(ng[:, 0], res.t, res[probe])
        assert np.abs(got - ng[:, col]).max() <= 0.02 * np.abs(ng[:, col]).max()


def test_a_regulating_loop_has_no_operating_point_and_says_so():
    # the comparator turns the switch on while v(out) < 5 V: on, the operating point is
    # 12 V (off); off, it is 0 V (on)
    deck = """bang-bang buck
Vin in 0 DC 12
S1 in sw out 0 smod
.model smod SW(VT=5)
Vd 0 sw DC 0
L1 sw out 100u
C1 out 0 10u
R1 out 0 10
.tran 1u 200u
.end
""".replace("S1 in sw out 0 smod", "S1 in sw ref out smod\nVref ref 0 5").replace(
        ".model smod SW(VT=5)", ".model smod SW(VT=0)").replace("Vd 0 sw DC 0\n",
                                                                  "D1 0 sw dm\n.model dm D\n")
    res = simulate_circuit(parse_string(deck), probes=["v(out)"])
    assert any("no DC operating point: the comparators (S1) have no consistent state" in n
               for n in res.notes)
    assert unsettled_in_note(res.notes) == ["S1"]
    assert res["v(out)"][0] == 0.0


def test_a_free_combination_keeps_its_conserved_charge_or_flux():
    # Two inductors in parallel from a 5 V source through 10 Ω: at DC they carry 0.5 A
    # between them, and their loop flux L1 i1 - L2 i2 is never changed by anything (zero
    # from the start): i1 = 1/3 A, i2 = 1/6 A, where the transient from zero currents also
    # ends. (The split orthogonal to the DC equations, 0.25 A each, carries a loop flux of
    # -0.25 mWb that no circuit gave it.) ngspice's own operating point fails here (singular
    # matrix) and it ends its transient at 0.3333 / 0.16667 A.
    deck = ("lloop\nV1 in 0 DC 5\nR1 in a 10\nL1 a 0 1m\nL2 a 0 2m\n.tran 1u 1m\n.end\n")
    res = simulate_circuit(parse_string(deck), probes=["i(L1)", "i(L2)"])
    assert res["i(L1)"][0] == pytest.approx(1 / 3) and res["i(L2)"][0] == pytest.approx(1 / 6)
    assert res["i(L1)"][-1] == pytest.approx(1 / 3)
    # A 1 mA source into 1 kΩ || C1 and the series C2 (a-b), C3 (b-0): v(a) = 1 V at DC and
    # node b, reached only by capacitors, keeps its charge (zero): v(b) = C2/(C2 + C3) v(a).
    deck = ("isrc\nI1 0 a DC 1m\nR1 a 0 1k\nC1 a 0 1u\nC2 a b 1u\nC3 b 0 2u\n.tran 10u 5m\n"
            ".end\n")
    res = simulate_circuit(parse_string(deck), probes=["v(a)", "v(b)"])
    assert res["v(a)"][0] == pytest.approx(1.0) and res["v(b)"][0] == pytest.approx(1 / 3)
    assert res["v(b)"][-1] == pytest.approx(1 / 3)


def test_dc_point_keeps_the_conserved_combinations_of_the_given_state():
    # x = (i1, i2), the two inductors of the test above with x0 = (0.1, 0): the loop flux
    # L1 i1 - L2 i2 = 1e-4 Wb is kept: i1 + i2 = 0.5, 1e-3 i1 - 2e-3 i2 = 1e-4
    L1, L2, R = 1e-3, 2e-3, 10.0
    A = -R * np.array([[1 / L1, 1 / L1], [1 / L2, 1 / L2]])
    E = np.array([[1 / L1], [1 / L2]])
    p = dc_point(A, np.zeros((2, 0)), np.zeros((0, 2)), np.zeros((0, 0)), E, np.zeros((0, 1)),
                 np.array([5.0]), np.array([0.1, 0.0]))
    i2 = (0.5 * L1 - 1e-4) / (L1 + L2)
    assert p.ok and p.x == pytest.approx([0.5 - i2, i2])


SAMPLE = """capacitor that only an open switch reaches at t = 0
V1 in 0 DC 5
R1 in a 1k
C1 a 0 1u
S1 a b g 0 smod
.model smod SW(VT=2.5 RON=1 ROFF=1e12)
Vg g 0 PULSE(0 5 100u 1n 1n 1 2)
R2 b c 1
C2 c 0 1u
.tran 1u 1m
.end
"""


def test_a_capacitor_only_an_open_switch_reaches_starts_as_in_ngspice(tmp_path, ngspice):
    # C2 is reached only by S1, open at t = 0: no DC equation of the ideal circuit sets its
    # voltage. ngspice's operating point sets it through S1's ROFF (any finite one: no DC
    # current, so no drop): 5 V, the voltage on S1's other side, the limit pelcs takes
    # (before: 0 V, and at 1 ms 3.405 V against ngspice's 5.000 V)
    res = simulate_circuit(parse_string(SAMPLE), probes=["v(c)"])
    ng = ngspice_wrdata(SAMPLE, ["v(c)"], tmp_path)
    assert ng[0, 1] == pytest.approx(5.0, abs=1e-3)
    assert res["v(c)"][0] == pytest.approx(5.0)
    assert not any("leave free" in n for n in res.notes), res.notes
    late = ng[:, 0] > 150e-6  # (away from S1's edge at 100 us)
    assert np.interp(ng[late, 0], res.t, res["v(c)"]) == pytest.approx(ng[late, 1], abs=2e-3)
    # with UIC both start from the initial conditions and agree
    uic = SAMPLE.replace(".tran 1u 1m", ".tran 1u 1m uic")
    res = simulate_circuit(parse_string(uic), probes=["v(c)"])
    ng = ngspice_wrdata(uic, ["v(c)"], tmp_path)
    assert res["v(c)"][0] == 0.0
    late = ng[:, 0] > 150e-6
    assert np.interp(ng[late, 0], res.t, res["v(c)"]) == pytest.approx(ng[late, 1], abs=0.02)


def test_a_capacitor_only_diodes_charge_in_a_hand_derived_lcs():
    # x = v_C: D1 from a 10 V source through 1 Ω into C (w1 = v_C - 10 + λ1, its reverse
    # voltage), D2 from ground into C (w2 = v_C): v_C' = (λ1 + λ2)/C. At DC no current
    # enters C (λ = 0) and both block for any v_C >= 10 V; the diodes' leakage takes the
    # least w1^2 + w2^2 there: v_C = 10 V (D1 held at w1 = 0, as its exponential holds it
    # against D2's leak), not the unbounded least squares' 5 V, where D1 would conduct
    Cap = 10e-6
    A, B = np.zeros((1, 1)), np.array([[1 / Cap, 1 / Cap]])
    C, D = np.array([[1.0], [1.0]]), np.diag([1.0, 0.0])
    E, F = np.zeros((1, 1)), np.array([[-10.0], [0.0]])
    p = dc_point(A, B, C, D, E, F, np.array([1.0]), np.zeros(1))
    assert p.ok and not p.free.any()
    assert p.x == pytest.approx([10.0]) and p.lam == pytest.approx([0.0, 0.0])
    # beside it a capacitor nothing reaches (x2): it keeps its given 2.5 V and is said free
    p = dc_point(np.zeros((2, 2)), np.vstack([B, np.zeros((1, 2))]), np.hstack([C, [[0], [0]]]),
                 D, np.zeros((2, 1)), F, np.array([1.0]), np.array([0.0, 2.5]))
    assert p.ok and p.x == pytest.approx([10.0, 2.5]) and list(p.free) == [False, True]
    # D2 from C into a 4 V source instead (w2 = 4 - v_C, its current leaving C): a DC
    # current can pass through C's node (λ1 = λ2), so λ = 0 is not implied; said, not chosen
    B2 = np.array([[1 / Cap, -1 / Cap]])
    p = dc_point(A, B2, np.array([[1.0], [-1.0]]), D, E, np.array([[-10.0], [4.0]]),
                 np.array([1.0]), np.zeros(1))
    assert not p.ok and "leakage" in p.reason


PEAK = ("peak\nV1 in 0 DC 10\nR0 in a 1\nD1 a out dm\n.model dm D(IS=1e-14)\n"
        "C1 out 0 10u\n.tran 1u 100u\n.end\n")


def test_a_capacitor_only_a_diode_charges_starts_where_its_leakage_balances(tmp_path, ngspice):
    # C1 is reached only by D1: the DC equations hold for any v(C1) at which D1 blocks
    # (>= 10 V); ngspice's diode leakage puts it at the source's 10 V (9.99997 V), and so
    # does pelcs now. Before: the initial conditions' 0 V, with a note
    res = simulate_circuit(parse_string(PEAK), probes=["v(out)"])
    ng = ngspice_wrdata(PEAK, ["v(out)"], tmp_path)
    assert ng[0, 1] == pytest.approx(10.0, abs=1e-3)
    assert res["v(out)"][0] == pytest.approx(10.0)
    assert not any("DC operating point" in n for n in res.notes), res.notes
    assert np.interp(ng[:, 0], res.t, res["v(out)"]) == pytest.approx(ng[:, 1], abs=1e-3)


RECTIFIER = """bridge rectifier with no load, fed by a sine with a DC offset
V1 a 0 SIN(5 3 1k)
D1 a op dm
D2 0 op dm
D3 on a dm
D4 on 0 dm
C1 op on 10u
.model dm D(IS=1e-14 N=0.01)
.tran 1u 2m
.end
"""


def test_a_bridge_with_no_load_starts_at_its_dc_input_as_in_ngspice(tmp_path, ngspice):
    # at t = 0 the input is its 5 V offset; C1 only the bridge's diodes charge, so at DC all
    # block for any v(op, on) >= 5 V, and their leakage holds D1 and D4 at zero voltage:
    # 5 V (ngspice 4.9968 V); then the peaks charge it to 8 V. Before: 0 V with a note, and
    # a jump to 5 V at t = 0 through D4
    res = simulate_circuit(parse_string(RECTIFIER), probes=["v(op,on)"])
    ng = ngspice_wrdata(RECTIFIER, ["v(op,on)"], tmp_path)
    assert res["v(op,on)"][0] == pytest.approx(5.0)
    assert ng[0, 1] == pytest.approx(5.0, abs=0.01)
    assert not any("DC operating point" in n or "inconsistent" in n for n in res.notes), \
        res.notes
    # (while the peaks charge C1, ngspice's two conducting diodes drop about 8 mV each at
    # N = 0.01: 16 mV at most over the run)
    assert np.interp(ng[:, 0], res.t, res["v(op,on)"]) == pytest.approx(ng[:, 1], abs=0.02)


def test_an_inductor_a_blocking_diode_holds_at_zero(tmp_path, ngspice):
    # A boost with S1 open at t = 0 and no load: the inductor's current is the diode's, zero
    # at DC, and the diode blocks for any v(C1) >= 12 V; its reverse voltage (the pair's λ in
    # this mode) is zero at the point nearest the given state: v(out) = 12 V, where ngspice's
    # diode leakage also puts it (11.9989 V). (Round-off of 1e-16 in the DC equations' inverse
    # made the LCP w = 0 λ - 1e-16 read as having no solution.)
    deck = (BOOST.replace("L1 in sw 100u", "Rin in a 1\nL1 a sw 100u")
            .replace("C1 out 0 100u\nR1 out 0 10\n", "C1 out 0 10u\n")
            .replace(".tran 0.1u 200u", ".tran 0.1u 20u"))
    assert "R1" not in deck and "Rin in a 1" in deck
    res = simulate_circuit(parse_string(deck), probes=["i(L1)", "v(out)"])
    ng = ngspice_wrdata(deck, ["i(L1)", "v(out)"], tmp_path)
    assert not any("no DC operating point" in n or "inconsistent" in n for n in res.notes), \
        res.notes
    assert res["i(L1)"][0] == 0.0
    assert res["v(out)"][0] == pytest.approx(12.0)
    assert ng[0, 3] == pytest.approx(12.0, abs=2e-3)
    assert np.interp(ng[:, 0], res.t, res["v(out)"]) == pytest.approx(ng[:, 3], abs=2e-3)


TIE = """a comparator whose control sits inside its band at the operating point
V1 in 0 DC 5
R1 in a 1k
R2 a 0 1k
C1 a 0 1u
V2 s 0 DC 3
S1 s c a 0 smod
.model smod SW(VT=2.5 {vh} RON=1m ROFF=1e12)
Rc c b 10
R3 b 0 1k
C3 b 0 1u
.tran 1u 1m
.end
"""


def test_a_comparator_inside_its_band_starts_as_ngspice_decides(tmp_path, ngspice):
    # v(a) = 2.5 V at DC, inside S1's band: with VH <= 0 ngspice's operating point takes
    # the switch's state before it as off and its control as entering the band from below:
    # on (v(b) = 3 V · 1k/1.01k), as for a source-driven control (docs/switching.md); with
    # VH > 0 the netlist's OFF (default): v(b) = 0
    for vh, on in (("VH=-0.5", True), ("", True), ("VH=0.5", False)):
        deck = TIE.format(vh=vh)
        res = simulate_circuit(parse_string(deck), probes=["v(b)"])
        ng = ngspice_wrdata(deck, ["v(b)"], tmp_path)
        want = 3.0 / 1.01 if on else 0.0
        assert ng[0, 1] == pytest.approx(want, abs=1e-3)
        assert res["v(b)"][0] == pytest.approx(want, abs=1e-3), vh
        if vh:  # (VH = 0: the control sits on VT, a relay question after t = 0)
            got = np.interp(ng[:, 0], res.t, res["v(b)"])
            assert got == pytest.approx(ng[:, 1], abs=1e-3)


def test_an_inductor_an_open_switch_holds_at_zero_is_no_free_state(tmp_path, ngspice):
    # L1's only path is S1, open at t = 0: the mode holds its current at zero, as ngspice's
    # ROFF does (12 V / 1 GΩ): nothing to warn about
    deck = """inductor whose only path is an open switch
Vin in 0 DC 12
L1 in sw 100u
S1 sw 0 g 0 smod
.model smod SW(VT=2.5 RON=10m ROFF=1e9)
Vg g 0 PULSE(0 5 20u 10n 10n 4u 10u)
L2 in x 10u
R2 x 0 10
.tran 0.1u 10u
.end
"""
    res = simulate_circuit(parse_string(deck), probes=["i(L1)", "i(L2)"])
    ng = ngspice_wrdata(deck, ["i(L1)", "i(L2)"], tmp_path)
    assert ng[0, 1] == pytest.approx(0.0, abs=1e-6) and res["i(L1)"][0] == 0.0
    assert res["i(L2)"][0] == pytest.approx(1.2) and ng[0, 3] == pytest.approx(1.2)
    assert not any("leave free" in n for n in res.notes), res.notes


BRIDGE = """full bridge with split input capacitors, S1 and S4 on at t = 0
V1 in 0 DC 100
R0 in p 1
C1 p mid 10u
C2 mid 0 10u
S1 p a g1 0 sw
S2 a 0 g2 0 sw
S3 p b g2 0 sw
S4 b 0 g1 0 sw
Vg1 g1 0 PULSE(5 0 5u 10n 10n 5u 10u)
Vg2 g2 0 PULSE(0 5 5u 10n 10n 5u 10u)
R1 a b 10
Ra a 0 1meg
Rb b 0 1meg
.model sw SW(VT=2.5 RON=10m ROFF=1e9)
.tran 0.1u 20u
.end
"""


def test_open_switches_that_reach_no_free_state_move_nothing():
    # S2 and S3 are open at t = 0; their voltages (v(a) = v(p), v(p) - v(b) = v(p)) do not
    # depend on the split of the input capacitors (the charge of node mid, free at DC): their
    # leak reaches it only by round-off (1e-21), which moved v(mid) to -1.5e18 V without a
    # note. DC: v(p) = 100 R/(1 + R) with R = 10 || 2 Meg, the capacitors' charge at mid
    # zero from zero: v(mid) = v(p)/2, said free.
    res = simulate_circuit(parse_string(BRIDGE), probes=["v(p)", "v(mid)"])
    r = 1.0 / (1 / 10 + 1 / 2e6)
    assert res["v(p)"][0] == pytest.approx(100 * r / (1 + r), rel=1e-6)
    assert res["v(mid)"][0] == pytest.approx(res["v(p)"][0] / 2, rel=1e-6)
    assert np.abs(res["v(mid)"]).max() < 100
    assert any("leave free" in n and "v(C1) = 45.45" in n for n in res.notes)


def test_a_diode_voltage_the_lcp_leaves_open_is_set_by_the_leaks():
    # x = (i_L, v_C): a buck's inductor from the switch node into C, no load, the switch
    # open: the freewheeling diode's pair is w = i_L (its current), λ = v(sw) (its reverse
    # voltage); DC: i_L = 0 and v_C = λ for any λ >= 0 (M = 0, q = 0). The open switch's
    # leak v(in, sw) = 12 - λ sets λ = 12 V; without a leak the least λ (ngspice's diode
    # leakage, GMIN: the diode's voltage as near zero as the circuit lets it), v_C = 0 V.
    L, Cap = 47e-6, 22e-6
    A = np.array([[0.0, -1 / L], [1 / Cap, 0.0]])
    B = np.array([[1 / L], [0.0]])
    C, D = np.array([[1.0, 0.0]]), np.zeros((1, 1))
    E, F = np.zeros((2, 1)), np.zeros((1, 1))
    u, x0 = np.array([12.0]), np.zeros(2)
    w = 1 / np.sqrt(1e9)
    leaks = (np.zeros((1, 2)), np.array([[-w]]), np.array([[w]]))
    p = dc_point(A, B, C, D, E, F, u, x0, leaks=leaks)
    assert p.ok and not p.free.any()
    assert p.x == pytest.approx([0.0, 12.0]) and p.lam == pytest.approx([12.0])
    p = dc_point(A, B, C, D, E, F, u, x0)
    assert p.ok and not p.free.any() and p.x == pytest.approx([0.0, 0.0])


BUCK_NO_LOAD = """buck with no load, its switch open at t = 0
V1 in 0 DC 12
S1 in sw g 0 sw
D1 0 sw dd
Vg g 0 PULSE(0 5 20u 10n 10n 5u 10u)
L1 sw out 47u
C1 out 0 22u
.model sw SW(VT=2.5 RON=1m ROFF=1e9)
.model dd D(IS=1e-14 N=0.01)
.tran 0.05u 40u
.end
"""


def test_a_buck_with_no_load_starts_at_its_input_as_in_ngspice(tmp_path, ngspice):
    # the inductor's only DC path is the blocking diode: the LCP leaves v(sw) = v(out)
    # anywhere the diode blocks; ngspice's point puts it at 12 V through S1's ROFF (11.988 V:
    # ROFF 1e9 against the diode's GMIN 1e12). Before: 0 V without a note, and the run
    # stayed there (1.40 V at 40 us against ngspice's 11.988 V)
    res = simulate_circuit(parse_string(BUCK_NO_LOAD), probes=["v(out)"])
    ng = ngspice_wrdata(BUCK_NO_LOAD, ["v(out)"], tmp_path)
    assert res["v(out)"][0] == pytest.approx(12.0)
    assert not any("leave free" in n or "no DC operating point" in n for n in res.notes)
    assert ng[0, 1] == pytest.approx(12.0, abs=0.02)
    assert np.interp(ng[:, 0], res.t, res["v(out)"]) == pytest.approx(ng[:, 1], abs=0.02)


def test_an_lc_behind_a_diode_starts_at_the_source_without_a_note(tmp_path, ngspice):
    # the diode's reverse voltage (v(out) - 10 V) is any value >= 0 at DC: the least, 0,
    # is where ngspice's diode leakage puts it (9.994 V), with no note of free states
    deck = """diode into an LC with no load
V1 in 0 DC 10
D1 in b dd
L1 b out 1m
C1 out 0 1u
.model dd D(IS=1e-14 N=0.01)
.tran 1u 100u
.end
"""
    res = simulate_circuit(parse_string(deck), probes=["v(out)"])
    ng = ngspice_wrdata(deck, ["v(out)"], tmp_path)
    assert res["v(out)"][0] == pytest.approx(10.0)
    assert not any("leave free" in n for n in res.notes), res.notes
    assert np.interp(ng[:, 0], res.t, res["v(out)"]) == pytest.approx(ng[:, 1], abs=0.01)


def test_a_leak_sets_what_it_reaches_and_leaves_the_rest_free():
    # two free states, one leak 5 - x1 (an open switch from a 5 V node to x1): x1 = 5, x2
    # keeps its given 2 and is said free
    A, B, C, D = np.zeros((2, 2)), np.zeros((2, 0)), np.zeros((0, 2)), np.zeros((0, 0))
    leaks = (np.array([[1.0, 0.0]]), np.zeros((1, 0)), np.array([[-5.0]]))
    p = dc_point(A, B, C, D, np.zeros((2, 1)), np.zeros((0, 1)), np.array([1.0]),
                 np.array([1.0, 2.0]), leaks=leaks)
    assert p.ok and p.x == pytest.approx([5.0, 2.0]) and list(p.free) == [False, True]


def test_pairs_of_very_different_sizes_are_no_set_of_solutions():
    # x' = -x + λ0, w = diag(2^-14, 2^20) λ + F u (a pair in volts beside one in amperes):
    # the unique solution λ = (2, 3), x = 2 (exact in binary, so that Lemke returns w = 0).
    # Judged against its largest entry, M's 6.1e-5 read as zero, a set of solutions along
    # λ0, and the least λ0 moved the point to x = 0, λ0 = 0, where w0 < 0
    A, B, E = np.array([[-1.0]]), np.array([[1.0, 0.0]]), np.zeros((1, 1))
    C, D = np.zeros((2, 1)), np.diag([2.0**-14, 2.0**20])
    F = np.array([[-2 * 2.0**-14], [-3 * 2.0**20]])
    p = dc_point(A, B, C, D, E, F, np.array([1.0]), np.zeros(1))
    assert p.ok and p.x == pytest.approx([2.0]) and p.lam == pytest.approx([2.0, 3.0])


# .ic without UIC: ngspice's operating point holds the .ic nodes (its matrix row of such a node
# replaced by v = value, or a 1e10 S conductance to it where a branch current enters), then
# the transient releases them. pelcs: the operating point of the circuit with a voltage source
# on each .ic node.
RC_IC = ("rc\nV1 in 0 DC 5\nR1 in out 1k\nC1 out 0 1u{ic}\nC2 out b 1u{ic}\nR3 b 0 1k\n"
         ".ic v(out)=2\n.tran 10u 5m\n.end\n")


def _close(res, ng, probes, tol, after=-1.0):
    """pelcs's run against ngspice's rows at their times (those after ``after``)."""
    rows = ng[ng[:, 0] > after]
    for j, probe in enumerate(probes):
        got = np.interp(rows[:, 0], res.t, res[probe])
        assert got == pytest.approx(rows[:, 2 * j + 1], abs=tol), probe


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_an_ic_node_is_held_during_the_operating_point_as_in_ngspice(tmp_path, ngspice):
    # v(out) starts at 2 V and relaxes to the 5 V source; C2 (out to b) starts at 2 V, its
    # IC= ignored as ngspice ignores it without UIC
    for ic in ("", " IC=3"):
        deck = RC_IC.format(ic=ic)
        res = simulate_circuit(parse_string(deck), probes=["v(out)", "v(b)", "v(C2)"])
        ng = ngspice_wrdata(deck, ["v(out)", "v(b)"], tmp_path)
        assert res.y[0] == pytest.approx([2.0, 0.0, 2.0]) and ng[0, [1, 3]] == pytest.approx(
            [2.0, 0.0])
        _close(res, ng, ["v(out)", "v(b)"], 2e-3)
        assert any("with the .ic nodes held (v(out) = 2 V)" in n for n in res.notes)
        assert not any("pelcs starts from the .ic values" in n for n in res.notes)
        assert any("IC= of C1, C2 ignored" in n for n in res.notes) == (ic != "")


def test_an_inductor_starts_at_its_dc_current_with_the_ic_node_held(tmp_path, ngspice):
    # L1 feeds the held capacitor node: i(L1) = (5 V - 2 V)/10 Ω = 0.3 A, R2's current taken
    # by the hold (ngspice: 0.3 A, v(a) = 2 V)
    deck = ("rlc\nV1 in 0 DC 5\nR1 in a 10\nL1 a out 1m\nC1 out 0 10u\nR2 out 0 100\n"
            ".ic v(out)=2\n.tran 1u 2m\n.end\n")
    probes = ["v(out)", "i(L1)", "v(a)"]
    res = simulate_circuit(parse_string(deck), probes=probes)
    ng = ngspice_wrdata(deck, probes, tmp_path)
    assert res.y[0] == pytest.approx([2.0, 0.3, 2.0])
    assert ng[0, [1, 3, 5]] == pytest.approx([2.0, 0.3, 2.0], abs=1e-9)
    _close(res, ng, probes, 2e-3)


def test_a_boost_with_ic_on_its_output_starts_as_in_ngspice(tmp_path, ngspice):
    # out held at 20 V above the 12 V input: the diode blocks, the inductor (whose only path
    # with S1 open is the diode) carries nothing; then the output discharges into R1 until
    # the switching starts (ngspice: i(L1) = 1.2e-8 A, v(out) = 20 V)
    deck = BOOST.replace(".tran", ".ic v(out)=20\n.tran")
    probes = ["i(L1)", "v(out)"]
    ideal = simulate_circuit(parse_string(deck), probes=probes)
    assert ideal.y[0] == pytest.approx([0.0, 20.0])
    assert not any("no DC operating point" in n for n in ideal.notes)
    res = simulate_devices(parse_string(deck), devices="pwl", probes=probes)
    ng = ngspice_wrdata(deck, probes, tmp_path)
    assert ng[0, [1, 3]] == pytest.approx([0.0, 20.0], abs=1e-6)
    assert res.y[0] == pytest.approx([0.0, 20.0])
    for col, probe in ((1, "i(L1)"), (3, "v(out)")):
        got = np.interp(ng[:, 0], res.t, res[probe])
        assert np.abs(got - ng[:, col]).max() <= 0.01 * np.abs(ng[:, col]).max()


def test_an_ic_node_a_source_fixes_keeps_the_source_value(tmp_path, ngspice):
    # ngspice's source equation holds (its .ic row sets only the source's current): 5 V
    deck = "vs\nV1 in 0 DC 5\nR1 in out 1k\nC1 out 0 1u\n.ic v(in)=2\n.tran 10u 5m\n.end\n"
    res = simulate_circuit(parse_string(deck), probes=["v(in)", "v(out)"])
    ng = ngspice_wrdata(deck, ["v(in)", "v(out)"], tmp_path)
    assert res.y[0] == pytest.approx([5.0, 5.0]) and ng[0, [1, 3]] == pytest.approx([5.0, 5.0])
    _close(res, ng, ["v(in)", "v(out)"], 1e-9)
    assert any(".ic on in: voltage sources tie it to ground" in n for n in res.notes)


def test_several_ic_nodes_and_element_ics_start_as_in_ngspice(tmp_path, ngspice):
    # the states at the held point: v(C1) = 3 V, v(C2) = 5 - 2 = 3 V, L1 shorted puts d at
    # 3 V with i(L1) = 3 V / 10 Ω = 0.3 A (its IC= ignored), v(C3) = v(d) - v(e) = -4 V (its
    # IC= ignored). Released at t = 0, the nodes no state holds (b, c, d, e) move at once:
    # ngspice's row at t = 0 is its operating point, pelcs's the start of the transient, so
    # the node waveforms are compared after it
    from test_transient import IC_NETLIST

    probes = ["v(a)", "v(b,c)", "v(d,e)", "i(L1)", "v(d)", "v(e)"]
    res = simulate_circuit(parse_string(IC_NETLIST), probes=probes)
    ng = ngspice_wrdata(IC_NETLIST, probes, tmp_path)
    assert res.y[0, :4] == pytest.approx([3.0, 3.0, -4.0, 0.3])
    assert ng[0, [1, 3, 5, 7]] == pytest.approx([3.0, 3.0, -4.0, 0.3], abs=1e-9)
    _close(res, ng, probes, 1e-4, after=0.0)


def test_ic_nodes_a_source_joins_or_an_inductor_shorts_say_how_the_start_differs():
    # two .ic nodes a source joins: pelcs holds the first alone (ngspice shares the
    # differences out: 4 V and -1 V from .ic 1 V and 2 V), and says so
    deck = ("grp\nV1 a b DC 5\nR1 a 0 1k\nR2 b 0 1k\nC1 a 0 1u\nC2 b 0 1u\n"
            ".ic v(a)=1 v(b)=2\n.tran 10u 1m\n.end\n")
    res = simulate_circuit(parse_string(deck), probes=["v(a)", "v(b)"])
    assert res.y[0] == pytest.approx([1.0, -4.0])
    assert any(".ic on a, b: voltage sources join these nodes" in n for n in res.notes)
    # a held node an inductor shorts to a source: no DC point (ngspice's has 3e10 A in L1)
    deck = ("ind\nV1 in 0 DC 5\nL1 in out 1m\nR1 out 0 10\nC1 out 0 1u\n.ic v(out)=2\n"
            ".tran 1u 1m\n.end\n")
    res = simulate_circuit(parse_string(deck), probes=["v(out)", "i(L1)"])
    assert res.y[0] == pytest.approx([2.0, 0.0])
    assert any(n.startswith("no DC operating point") and "initial conditions" in n
               for n in res.notes)


def test_a_source_the_diodes_take_on_a_free_state_sets_their_multipliers():
    # an inductor whose only path is a blocking diode, 12 V on one side and 20 V on the
    # other: i_L' = (12 - 20 + λ)/L, w = i_L. DC: λ = 8 V (the diode's reverse voltage) and
    # i_L = 0; with 5 V on the other side λ = -7 V: no point (ngspice's has 306 A through
    # the diode's RS)
    A, B, C, D = np.zeros((1, 1)), np.array([[1e4]]), np.ones((1, 1)), np.zeros((1, 1))
    E, F = np.array([[1e4, -1e4]]), np.zeros((1, 2))
    p = dc_point(A, B, C, D, E, F, np.array([12.0, 20.0]), np.array([0.5]))
    assert p.ok and p.x == pytest.approx([0.0]) and p.lam == pytest.approx([8.0])
    assert not dc_point(A, B, C, D, E, F, np.array([12.0, 5.0]), np.zeros(1)).ok


def test_an_inductor_a_source_holds_its_diode_off_in_a_switch_mode():
    # the two-phase buck with S1 on and S2 off: L1 shorts the 24 V input onto the 2 Ω load
    # (12 A, 24 V); L2's only path is D2, which the output holds 24 V reverse-biased: i(L2) =
    # 0, λ(D2) = 24 V. The point is checked against the DC equations and the LCP, where a
    # remainder of 2e-16 A in L2 (1.8 A moved to 0) counts as zero.
    from pathlib import Path

    from lcs.lcp import LcpOptions
    from lcs.simulation.held_point import mode_point
    from lcs.simulation.problem import Problem
    from netlist.parser import parse_file
    from netlist.studies.transient import transient_setup

    s = transient_setup(parse_file(Path(__file__).parent / "netlists" / "closed_loop"
                                   / "two_phase_buck.cir"))
    u0 = np.array([sig(0.0) for sig in s.signals])
    for x0 in (np.zeros(3), np.array([0.0, 1.8, 0.0])):
        p = mode_point(Problem(s.system, None), (True, False), u0, x0, LcpOptions())
        assert p.ok
        assert dict(zip(s.system.states, p.x, strict=True)) == pytest.approx(
            {"i(L1)": 12.0, "i(L2)": 0.0, "v(C1)": 24.0})
        assert p.lam == pytest.approx([0.0, 24.0])
