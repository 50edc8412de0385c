"""A diode's depletion charge with --devices pwl (netlist.junction_charge): ngspice's charge
formula, the capacitor behind RS, and the charge a reverse-biased diode takes through a
resistor, side by side with ngspice."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_run

from netlist.circuit import Capacitor, Resistor
from netlist.junction_charge import charge_params, depletion_charge, swing_capacitance
from netlist.parser import parse_string
from netlist.studies.realistic import simulate_devices

# A step of -5 V through 10 kOhm onto a reverse-biased diode: the current that flows is the
# junction's charging current, so R times the charge it moves is the area between the source
# and the anode, whatever the capacitance's shape (the leakage, IS = 1e-14 A, adds 0.1 pC
# over the run against 20 pC).
STEP = """reverse-biased diode charged through a resistor
V1 in 0 PULSE(0 -5 0.2u 1n 1n 10u 20u)
R1 in a 10k
D1 a 0 DCAP
.model DCAP D(IS=1e-14 RS=20 CJO=10p VJ=0.7 M=0.5 FC=0.5)
.tran 1n 2u
.end
"""


def test_the_depletion_charge_is_ngspices_formula():
    p = charge_params({"CJO": 10e-12, "VJ": 0.7, "M": 0.5})
    assert p == {"cjo": 10e-12, "vj": 0.7, "m": 0.5, "fc": 0.5}
    # below FC VJ: VJ CJO (1 - (1 - v/VJ)^(1-M)) / (1-M); its slope at 0 V is CJO
    assert depletion_charge(-5.0, p) == pytest.approx(
        0.7 * 10e-12 * (1 - (1 + 5 / 0.7) ** 0.5) / 0.5, rel=1e-12)
    assert swing_capacitance(p, 0.0, 0.0) == pytest.approx(10e-12, rel=1e-6)
    # above FC VJ the capacitance goes on linearly, continuous at FC VJ
    h = 1e-7
    below = (depletion_charge(0.35 - h, p) - depletion_charge(0.35 - 2 * h, p)) / h
    above = (depletion_charge(0.35 + 2 * h, p) - depletion_charge(0.35 + h, p)) / h
    assert above == pytest.approx(below, rel=1e-5)
    assert charge_params({"CJO": 0}) is None and charge_params({"IS": 1e-14}) is None


def test_the_capacitor_sits_behind_rs():
    res = simulate_devices(parse_string(STEP), devices="pwl", probes=["v(a)"])
    note = next(n for n in res.notes if n.startswith("pwl: D1: depletion charge"))
    assert "behind RS = 20 Ω" in note and "over -5..0 V" in note
    # 10 kOhm + RS with the chord's 3.4 pF: 34 ns, resolved by the 1 ns step
    assert res.theta == 0.5 and not any("does not resolve" in n for n in res.notes)


def test_an_unresolved_junction_mode_runs_at_theta_1_with_a_note():
    # through 1 Ohm: (1 + 10) Ohm with the chord's capacitance (the diode carries nothing:
    # fitted at Ron = RS, half of RS outside), 57 ps against the 1 ns step
    res = simulate_devices(parse_string(STEP.replace("R1 in a 10k", "R1 in a 1")),
                           devices="pwl", probes=["v(a)"])
    note = next(n for n in res.notes if "does not resolve" in n)
    assert "|h μ| = 17.5" in note and "the run uses θ = 1" in note
    assert res.theta == 1.0
    given = simulate_devices(parse_string(STEP.replace("R1 in a 10k", "R1 in a 1")),
                             devices="pwl", probes=["v(a)"], theta=0.5)
    assert given.theta == 0.5
    assert any("θ = 0.5 as given, which integrates it unresolved" in n for n in given.notes)


def test_a_reverse_biased_diode_takes_ngspices_charge(tmp_path, ngspice):
    circuit = parse_string(STEP)
    res = simulate_devices(circuit, devices="pwl", probes=["v(in)", "v(a)"])
    ng, log = ngspice_run(STEP, ["v(in)", "v(a)"], tmp_path)
    assert ng is not None, log
    t, area = res.t, np.trapezoid(res["v(a)"] - res["v(in)"], res.t)
    want = np.trapezoid(ng[:, 3] - ng[:, 1], ng[:, 0])
    p = charge_params({"CJO": 10e-12, "VJ": 0.7, "M": 0.5})
    analytic = 10e3 * (depletion_charge(0.0, p) - depletion_charge(-5.0, p))
    # ngspice moves the model's charge (measured to 1e-5), and so does pelcs's capacitor,
    # the chord over the swing (to 1e-11: the step conserves charge)
    assert want == pytest.approx(analytic, rel=1e-3)
    assert area == pytest.approx(analytic, rel=1e-6)
    # at nearly ngspice's pace: the anode within 0.5 V of ngspice's all along (measured
    # 0.43 V: the linear chord against ngspice's capacitance, larger near 0 V and smaller
    # near -5 V), where without the charge it would follow the source at once, 5 V apart
    assert np.max(np.abs(res["v(a)"] - np.interp(t, ng[:, 0], ng[:, 3]))) < 0.5
    assert np.max(res["v(a)"] - res["v(in)"]) > 2.5


def test_no_rs_and_a_loop_leaves_the_charge_out_with_a_note():
    deck = STEP.replace("RS=20 ", "").replace("R1 in a 10k", "C1 in a 1n")
    res = simulate_devices(parse_string(deck), devices="pwl", probes=["v(a)"])
    assert any("pwl: D1: its depletion charge (CJO) not modelled: without RS" in n
               for n in res.notes)
    assert res.error is None


def test_the_pwl_chain_splits_rs_from_ron():
    from netlist.junction_charge import with_junction_charge
    from netlist.pwl import pwl_circuit

    circuit = parse_string(STEP)
    run, fits = pwl_circuit(circuit, {"D1": 1e-3}, {}, charged={"D1"})
    assert "CJO" not in fits[0].how and len(fits[0].branches) == 2
    built = with_junction_charge(circuit, run, fits, {"D1": (20.0, 5e-12)})
    els = {e.name: e for e in built.elements}
    assert isinstance(els["D1#rs"], Resistor) and els["D1#rs"].value == 20.0
    assert els["D1#rs"].nodes == ("a", "d1#j") and els["D1"].nodes[0] == "d1#j"
    # the first segment's line less RS (the branches' resistances are not lines' slopes)
    assert els["D1#ron"].value == pytest.approx(fits[0].ron - 20.0)
    assert isinstance(els["D1#cj"], Capacitor) and els["D1#cj"].nodes == ("d1#j", "0")
    assert len(built.elements) == len(run.elements) + 2  # RS and the capacitor


def test_segments_behind_rs_keep_the_fits_characteristic():
    from netlist.pwl import lines_fit, pwl_voltage, segment_fit, segment_lines

    # the corpus doubler's BAR42 at 29 mA: three segments
    vf, ron, branches, _ = segment_fit([{"is": 1.13853e-8, "n": 1.0, "rs": 0.99517}], 0.029)
    assert len(branches) == 2
    rs = 0.99517
    inner = lines_fit([(a, b - rs) for a, b in segment_lines(vf, ron, branches)])
    i = np.logspace(-8, np.log10(0.029), 50)
    # RS in series with the junction's characteristic is the fit's characteristic
    assert rs * i + pwl_voltage(*inner, i) == pytest.approx(pwl_voltage(vf, ron, branches, i),
                                                            abs=1e-12)


def test_a_fit_at_rs_keeps_half_of_it_inside():
    # a diode that carries nothing is fitted at 1 mA with Ron = RS: RS outside would leave a
    # sliver inside, the capacitor behind a vanishing resistance (a rectifier's 8 pF behind
    # 1e-11 Ohm: round-off made its matrix unstable and the first step had no solution);
    # half of it stays inside, the characteristic unchanged, and a note says so
    from netlist.junction_charge import with_junction_charge
    from netlist.pwl import pwl_circuit

    circuit = parse_string(STEP)
    run, fits = pwl_circuit(circuit, {"D1": 0.0}, {}, charged={"D1"})
    assert fits[0].ron == 20.0 and not fits[0].branches
    notes: list[str] = []
    built = with_junction_charge(circuit, run, fits, {"D1": (20.0, 5e-12)}, notes)
    els = {e.name: e for e in built.elements}
    assert els["D1#rs"].value == 10.0 and els["D1#ron"].value == pytest.approx(10.0)
    assert els["D1#cj"].nodes == ("d1#j", "0")
    assert notes == ["D1: its junction capacitor behind 10 Ω of its RS = 20 Ω (its fit's "
                     "least slope, 20 Ω, leaves no more inside)"]
