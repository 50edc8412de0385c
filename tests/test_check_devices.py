"""Real device models in ``--devices pwl`` and ``pelcs check``: the diode fits against
Shockley's equation, the current range they are fitted over, the MOSFET's gate RC, PySpice's
rectifier and buck decks against ngspice, and the check's verdicts (a tenfold load error is
never "within tolerance"; tolerances over 10 % are inconclusive)."""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

import pelcs
from lcs.notices import IdealisedDeviceWarning
from netlist.pwl import VT_THERMAL, carried_current, diode_fit, parallel_fit

# pelcs check runs beside ngspice (4.5 s): in the full suite, not the fast subset
pytestmark = pytest.mark.slow

DEV = Path(__file__).parent / "netlists" / "devices"

# vendor models (IS A, N, RS Ω): small-signal, Schottky (junction || guard ring), power
SMALL_SIGNAL = {"1N4148": [(4.352e-9, 1.906, 0.6458)], "BAV21": [(21.91e-9, 2.233, 1e-3)]}
SCHOTTKY = {"1N5822": [(2.37487e-7, 1.98477, 0.0171579), (1.27781e-5, 1.2149, 0.0250254)]}
POWER = {"1N4007": [(7.02767e-9, 1.80803, 0.0341512)]}


def _shockley_v(i, junctions):
    """Voltage of junctions in parallel carrying ``i`` in total: Shockley with RS, each
    branch's current by bisection in v (independent of netlist.pwl)."""
    def total(v):
        out = 0.0
        for is_, n, rs in junctions:
            lo, hi = 0.0, max(v / rs, 1e3) if rs > 0 else 1e3
            for _ in range(100):  # branch current: v = n Vt ln(1 + ib/IS) + RS ib
                mid = 0.5 * (lo + hi)
                if n * VT_THERMAL * math.log1p(mid / is_) + rs * mid < v:
                    lo = mid
                else:
                    hi = mid
            out += lo
        return out

    vs = []
    for target in np.atleast_1d(i):
        lo, hi = 0.0, 5.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if total(mid) < target else (lo, mid)
        vs.append(0.5 * (lo + hi))
    return np.array(vs)


@pytest.mark.parametrize("name, junctions, currents", [
    *[(k, v, (1e-3, 0.05, 0.3)) for k, v in SMALL_SIGNAL.items()],
    *[(k, v, (0.1, 1.0, 3.0)) for k, v in SCHOTTKY.items()],
    *[(k, v, (0.1, 1.0, 10.0)) for k, v in POWER.items()],
])
def test_fitted_diodes_follow_shockley_over_the_fitted_range(name, junctions, currents):
    for i_max in currents:
        params = [{"is": a, "n": b, "rs": c} for a, b, c in junctions]
        vf, ron = parallel_fit(params, i_max)
        i = np.logspace(np.log10(i_max / 20), np.log10(i_max), 25)
        v = _shockley_v(i, junctions)
        err = np.abs(vf + ron * i - v)
        n_max = max(n for _, n, _ in junctions)
        # a line through N Vt ln(i) over 20:1 stays within 0.65 N Vt (+ the grid's 0.5 mV)
        assert err.max() < 0.66 * n_max * VT_THERMAL + 1e-3, (name, i_max, err.max())
        # physical bounds: Vf between 0 and the drop at the top; Ron from the series
        # resistance(s) up to the diode's slope at the bottom of the range
        assert 0.0 <= vf <= v[-1]
        rs_par = 1 / sum(1 / c for _, _, c in junctions)
        slope_lo = (v[1] - v[0]) / (i[1] - i[0])
        assert rs_par * 0.99 <= ron <= slope_lo * 1.05


def test_the_fit_is_bounded_where_least_squares_would_leave_physics():
    # IS far above the range: the curve is almost a line of slope N Vt / IS; Ron stays
    # within [RS, dv/di at the bottom], Vf >= 0
    vf, ron = diode_fit(1e-3, 1.0, 0.1, 1e-4)
    assert vf >= 0.0 and 0.1 <= ron <= VT_THERMAL / (1e-3 + 5e-6) + 0.1


def test_carried_current_leaves_out_a_step_limited_inrush():
    t = np.linspace(0.0, 20e-3, 2001)
    i = np.clip(np.sin(2 * np.pi * 50 * t), 0, None) * 0.5  # 0.5 A half-waves
    i[1] = 400.0  # an ideal diode charging a capacitor from a step: one step long
    assert carried_current(t, i) == pytest.approx(0.5, rel=0.02)
    assert np.max(i) == 400.0


def test_a_macros_port_to_port_leakage_is_not_series_resistance():
    """NXP's 1N4148 is a diode with a 5.8 GΩ resistor across it: not 5.8 GΩ in series."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = pelcs.load(DEV / "vendor_parts.cir")
    x1 = c.element("X1")
    assert x1.device[4] == 0.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        res = pelcs.simulate(DEV / "vendor_parts.cir", devices="pwl", probes=["v(k1)"],
                             tstop="2m")
    fit = {f.element: f for f in res.device_fits}["X1"]
    # 10 V into 1 kΩ: about 9 mA; the line there: Vf ~ 0.6 V, Ron ~ 6..30 Ω
    vf, ron = fit.top
    assert 0.4 < vf < 0.8 and 1.0 < ron < 50.0
    assert res["v(k1)"].max() > 9.0


def test_the_mosfet_macro_keeps_its_gate_rc():
    from converters.pyspice_examples import pyspice_buck

    pytest.importorskip("PySpice")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = pelcs.load(pyspice_buck(DEV / "vendor"))
    rg, cgs, cgd = c.element("XQ").gate_rc
    # irf150: RG 12.1; CGSO 3.57784e-5 F/m and CGDO 4.96221e-7 F/m at W = 100 µm; the
    # feedback capacitor CAP 3.78329 nF on the output of EV16 = v(drain) - v(gate)
    assert rg == pytest.approx(12.1)
    assert cgs == pytest.approx(3.57784e-5 * 100e-6)
    assert cgd == pytest.approx(4.96221e-7 * 100e-6 + 3.78329e-9)


def test_one_sided_switching_fails():
    from ngspice_checks.compare import Tolerances, _compare_switch
    from ngspice_checks.measures import _Instants

    class R:
        sliding = ()

    on = np.array([1e-6, 3e-6, 5e-6])
    pel, ng = _Instants(on, on + 1e-6), _Instants(np.empty(0), np.empty(0))
    for a, b in ((pel, ng), (ng, pel)):
        s = _compare_switch("S1", "implicit", "v(c)", a, b, R(), (0.0, 1e-5), (8e-6, 1e-5),
                            2e-6, "PULSE period", 1e-8, 1e-8, Tolerances(), 0.0)
        assert not s.ok and "switches" in s.reason
    both = _compare_switch("S1", "source", "v(c)", ng, ng, R(), (0.0, 1e-5), (8e-6, 1e-5),
                           2e-6, "PULSE period", 1e-8, 1e-8, Tolerances(), 0.0)
    assert both.ok and both.reason == "neither switches"


# --------------------------------------------------------------------------------------------
# against ngspice


def _mean_last(t, y, a, b):
    w = (t >= a) & (t <= b)
    return float(np.trapezoid(y[w], t[w]) / (t[w][-1] - t[w][0]))


def _runs(circuit, probe, tstop, extra=(), **kw):
    """pelcs ideal, pelcs pwl and ngspice on one circuit: (t, y of ``probe``, the result)
    each (``extra``: further probes in the results)."""
    import copy

    from netlist.circuit import Tran
    from netlist.studies.realistic import simulate_devices
    from netlist.writer import write_circuit
    from ngspice_checks.runner import run_ngspice

    probes = [probe, *extra]
    out = {}
    for devices in ("ideal", "pwl"):
        r = simulate_devices(circuit, devices=devices, probes=probes, tstop=tstop, **kw)
        out[devices] = (np.asarray(r.t), np.asarray(r[probe]), r)
    c = copy.deepcopy(circuit)  # UIC, as pelcs check gives it: both start from 0
    c.tran = Tran(tstep=circuit.tran.tstep if circuit.tran else 10e-9, tstop=tstop,
                  uic=True)
    ng = run_ngspice(write_circuit(c), probes, timeout=300)
    out["ngspice"] = (np.asarray(ng.time), np.asarray(ng[probe]), ng)
    return out


@pytest.mark.parametrize("kind, capacitor, probe", [
    ("half", False, "v(output)"),
    ("half", True, "v(output)"),
    ("bridge", True, "v(output_plus,output_minus)"),
])
def test_pyspice_rectifiers_pwl_is_closer_to_ngspice_than_ideal(ngspice, kind, capacitor,
                                                                 probe):
    pytest.importorskip("PySpice")
    from converters.pyspice_examples import pyspice_rectifier

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = pelcs.load(pyspice_rectifier(kind, capacitor, DEV / "vendor"))
    runs = _runs(c, probe, 40e-3)
    grid = np.linspace(0.0, 40e-3, 4001)
    ng = np.interp(grid, *runs["ngspice"][:2])
    err = {k: float(np.max(np.abs(np.interp(grid, *runs[k][:2]) - ng)))
           for k in ("ideal", "pwl")}
    means = {k: _mean_last(*runs[k][:2], 20e-3, 40e-3) for k in runs}
    fits = {f.element: f for f in runs["pwl"][2].device_fits}
    assert all(f.top[1] < 50.0 for f in fits.values())  # not the 5.8 GΩ leakage
    assert means["pwl"] > 0.5 * means["ngspice"] > 1.0  # not 0 V
    # the figures of the docs: largest difference over the run and mean of the 2nd period
    assert err["pwl"] < 0.5 * err["ideal"], (err, means)
    assert abs(means["pwl"] - means["ngspice"]) < 0.03 * abs(means["ngspice"]), means


def test_pyspice_buck_pwl_keeps_the_gate_delays(ngspice):
    """IRF150 + 1N5822, 12 V -> 5 V at 400 kHz: the pwl switch keeps the gate's RC, so it
    turns off after the command as ngspice's does, and the diode and channel drops."""
    pytest.importorskip("PySpice")
    from converters.pyspice_examples import pyspice_buck

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = pelcs.load(pyspice_buck(DEV / "vendor"))
    tstop = BUCK_TSTOP
    runs = _runs(c, "v(out)", tstop, extra=["v(source)"], step=5e-9)
    period = 2.5e-6
    a = tstop - 40 * period
    means = {k: _mean_last(*runs[k][:2], a, tstop) for k in runs}
    # ngspice 4.911 V, pwl 4.831 V, ideal 4.962 V (last 40 periods of 400 µs): the gate RC's
    # Cgd, the chord of the macro's charge over its swing (netlist.gate_charge), keeps the
    # edges' total gate charge, not how it splits between the turn-off and the turn-on
    assert means["pwl"] == pytest.approx(means["ngspice"], rel=0.02), means

    def delay(t, v, rising: bool):
        # the switch node through 6 V after the command (k T on, k T + D T off)
        t0 = (int(tstop / period) - 5 + (0 if rising else 5 / 12)) * period
        sel = (t > t0 - 20e-9) & (t < t0 + 400e-9)
        return float(t[sel][np.argmax((v[sel] > 6.0) if rising else (v[sel] < 6.0))] - t0)

    off = {k: delay(runs[k][0], runs[k][2]["v(source)"], False) for k in runs}
    on = {k: delay(runs[k][0], runs[k][2]["v(source)"], True) for k in runs}
    # turn-off: ngspice 72 ns (its gate network), pwl 55 ns (the gate RC), ideal one step;
    # turn-on: ngspice 19 ns, pwl 30 ns
    assert off["ngspice"] > 50e-9 and abs(off["pwl"] - off["ngspice"]) < 25e-9, off
    assert abs(off["ideal"] - off["ngspice"]) > 50e-9, off
    assert abs(on["pwl"] - on["ngspice"]) < 15e-9, on


BUCK_TSTOP = 400e-6


def _check(argv, capsys):
    from pelcs.cli import main

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        rc = main(["check", *argv])
    return rc, capsys.readouterr().out


def test_check_bridge_with_1n4148_uses_pwl_and_catches_a_tenfold_load_error(ngspice, capsys):
    deck = str(DEV / "bridge_1n4148.cir")
    rc, out = _check([deck, "--probe", "v(output_plus,output_minus)"], capsys)
    assert rc == 0, out
    assert "pelcs devices: pwl" in out and "within tolerance" in out
    rc, out = _check([deck, "--probe", "v(output_plus,output_minus)", "--pelcs-param",
                      "rload=10"], capsys)
    assert rc in (1, 4), out
    assert "within tolerance" not in out.splitlines()[-1]


def test_check_with_ideal_devices_on_real_models_is_inconclusive(ngspice, capsys):
    deck = str(DEV / "bridge_1n4148.cir")
    rc, out = _check([deck, "--devices", "ideal", "--probe", "v(output_plus,output_minus)",
                      "--pelcs-param", "rload=10"], capsys)
    assert rc in (1, 4), out
    assert "within tolerance" not in out.splitlines()[-1]
    rc, out = _check([deck, "--devices", "ideal", "--probe", "v(output_plus,output_minus)"],
                     capsys)
    assert rc == 4, out
    assert out.splitlines()[-1].startswith("INCONCLUSIVE: tolerances of up to")
    row = next(ln for ln in out.splitlines() if ln.startswith("v(output_plus"))
    assert row.endswith("inconclusive")  # the probe's own verdict
    rc, out = _check([deck, "--devices", "ideal", "--probe", "v(output_plus,output_minus)",
                      "--json"], capsys)
    data = json.loads(out)
    assert rc == 4 and data["verdict"] == "inconclusive" and data["ok"] is False
    assert data["devices"] == "ideal" and data["probes"][0]["conclusive"] is False


def test_check_does_not_agree_where_charge_storage_matters(ngspice, capsys):
    """A Villard doubler at 100 MHz with 1N4148s: ideal devices get 250 % tolerances
    (inconclusive), pwl devices a few % (and fail on the charge-up): never agreement."""
    deck = str(DEV / "multiplier_100meg.cir")
    for devices in ("ideal", "pwl"):
        rc, out = _check([deck, "--probe", "v(n4)", "--devices", devices], capsys)
        assert rc in (1, 4), out
        assert out.splitlines()[-1].startswith(("OUT OF TOLERANCE", "INCONCLUSIVE"))


def test_losses_are_not_computed_where_the_mosfet_slides():
    """The vendor buck's pwl MOSFET follows its gate through its linear region (Filippov
    sliding on the gate RC) at turn-off: the currents recorded there combine two modes'
    steps, so the input power and the device losses are not given, the output power is."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        res = pelcs.simulate(DEV / "buck_vendor.cir", tstop="200u", probes=["v(out)"],
                             devices="pwl", losses=True)
    rep = res.losses
    assert any(s[0] == "XQ" for s in res.sliding)
    assert math.isnan(rep.p_in) and math.isnan(rep.efficiency) and math.isnan(rep.devices["XQ"])
    assert rep.p_out > 0 and "XQ slides over" in rep.caveat
    # (200 µs is not a steady state either: the line says so after the n/a)
    assert any(line.startswith("efficiency: n/a") for line in rep.lines())


def test_vendor_buck_with_a_floating_gate_drive_pwl_is_closer_to_ngspice(ngspice):
    """tests/netlists/devices/buck_vendor.cir (a MODPEX-style MOSFET driven from 24 V through
    1 Ω, floating on its source): the turn-off is the Miller plateau (the gate-drain
    capacitor discharging while the source falls), which the gate RC keeps. Mean output over
    the last 10 periods of 200 µs: ngspice 5.48 V, pwl 5.60 V, ideal 4.85 V."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = pelcs.load(DEV / "buck_vendor.cir")
    runs = _runs(c, "v(out)", 200e-6)
    means = {k: _mean_last(*runs[k][:2], 175e-6, 200e-6) for k in runs}
    err = {k: abs(means[k] - means["ngspice"]) for k in ("ideal", "pwl")}
    assert err["pwl"] < 0.4 * err["ideal"] and err["pwl"] < 0.03 * means["ngspice"], means


def test_the_fit_range_is_not_an_inrush_only_the_step_limits():
    """A square wave into a capacitor through an ideal diode: each rising edge charges the
    capacitor in one step (C dV / h, 1000 A at h = 1 µs); the diode carries about
    10 V / 100 Ω = 0.1 A otherwise. The fit is over what it carries."""
    from netlist.parser import parse_string
    from netlist.studies.realistic import simulate_devices

    c = parse_string("inrush\nVs a 0 PULSE(0 10 0 0 0 0.5m 1m)\nD1 a k D4148\n"
                     "C1 k 0 100u\nR1 k 0 100\n.model D4148 D(IS=4.352n N=1.906 RS=0.6458)\n"
                     ".tran 1u 5m\n.end\n")
    ideal = simulate_devices(c, probes=["i(D1)"])
    assert np.max(np.abs(ideal["i(D1)"])) > 100.0
    res = simulate_devices(c, devices="pwl", probes=["v(k)"])
    fit = res.device_fits[0]
    top = float(fit.how.split("..")[1].split()[0])
    assert 0.05 < top < 1.0, fit.how
    # the line at the current it carries: within 0.65 N Vt of the model
    v = 1.906 * VT_THERMAL * np.log1p(0.1 / 4.352e-9) + 0.6458 * 0.1
    assert abs(fit.voltage(0.1) - v) < 0.65 * 1.906 * VT_THERMAL


def test_the_check_uses_the_theta_a_run_would(ngspice):
    # ngspice's dcdc.sp: θ = 1/2 is unreliable at its 5 ns step (a 20 ps time constant its
    # diodes cancel; and D1's 0.23 nF junction behind its RS adds a 0.2 ns mode the step does
    # not resolve), so `pelcs simulate` runs θ = 1; the check compares that run, not θ = 1/2
    from ngspice_checks.compare import compare

    dcdc = Path(__file__).parent / "corpus/ngspice/examples/vdmos/dcdc.sp"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cmp = compare(str(dcdc), ["v(C1)"], tstop=2e-3)
    assert cmp.theta == 1.0
    assert any("θ = 0.5 is not reliable" in n or "the run uses θ = 1" in n for n in cmp.notes)
