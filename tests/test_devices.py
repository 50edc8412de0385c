"""Transistors idealised as switches: M (NMOS/PMOS/VDMOS) and Q
(NPN/PNP) elements become ideal switches (and a VDMOS its body diode), reported, refused
with --strict, written back as the devices for ngspice."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import pelcs
from lcs.notices import IdealisedDeviceWarning
from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.studies.realistic import simulate_devices
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit
from pelcs.cli import main

DEV = Path(__file__).parent / "netlists" / "devices"


def load(name: str, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        return parse_file(str(DEV / name), **kw)


def test_vdmos_buck_is_the_switch_and_body_diode_buck():
    dev = load("buck_vdmos.cir")
    ref = load("buck_switch.cir")
    a = simulate_circuit(dev, probes=["i(L1)", "v(C1)"])
    b = simulate_circuit(ref, probes=["i(L1)", "v(C1)"])
    assert np.array_equal(a.t, b.t)
    assert np.allclose(a.y, b.y, rtol=1e-12, atol=1e-12)
    (r,) = dev.replacements
    assert (r.element, r.device, r.model, r.threshold) == ("M1", "VDMOS", "MPOW", 3.5)
    assert r.source == "VTO of the model" and r.body_diode == "M1_body"
    assert "v(g,sw) > 3.5 V" in r.became


def test_pmos_and_npn_switch_where_their_thresholds_say():
    c = load("pmos_npn.cir")
    res = simulate_circuit(c, probes=["v(d)", "i(Rc)"])
    on = {mode: t for t, mode in res.events}
    # M1 on once v(s,g) = 5 - v(g) > 2 V: the gate falls 5 V in 1 us from 1 ms (at 0.4 us)
    t_m1 = [t for t, mode in res.events if mode == (True, False)][0]
    assert t_m1 == pytest.approx(1e-3 + 0.4e-6, rel=1e-12)
    # Q1 on once v(b) > 0.7 V: the base rises 1 V in 1 us from 2 ms
    t_q1 = [t for t, mode in res.events if mode == (True, True)][0]
    assert t_q1 == pytest.approx(2e-3 + 0.7e-6, rel=1e-12)
    assert on and res["v(d)"][-1] == pytest.approx(5.0)
    assert res["i(Rc)"][-1] == pytest.approx(0.05)
    # a threshold given by element name wins (and says so)
    c2 = load("pmos_npn.cir", thresholds={"q1": 0.5, "PCH": 4.0})
    r = {x.element: x for x in c2.replacements}
    assert r["Q1"].threshold == 0.5 and r["Q1"].source == "--threshold"
    assert r["M1"].threshold == 4.0
    res2 = simulate_circuit(c2, probes=["v(d)"])
    t_q1b = [t for t, mode in res2.events if mode == (True, True)][0]
    assert t_q1b == pytest.approx(2e-3 + 0.5e-6, rel=1e-12)


def test_report_in_info_and_simulate(capsys):
    assert main(["info", str(DEV / "pmos_npn.cir")]) == 0
    out, err = capsys.readouterr()
    assert "idealised (2" in out and "M1 (PMOS PCH)" in out and "Q1 (NPN QN)" in out
    assert "bulk terminal s" in out
    assert "warning:" in err and "idealised (M1, Q1)" in err
    assert main(["simulate", str(DEV / "pmos_npn.cir"), "--threshold", "Q1=0.5"]) == 0
    out = capsys.readouterr().out
    assert "note: idealised: Q1 (NPN QN)" in out and "threshold 0.5 V (--threshold)" in out


def test_strict_refuses_transistors(capsys):
    assert main(["simulate", str(DEV / "buck_vdmos.cir"), "--strict"]) == 2
    err = capsys.readouterr().err
    assert "idealised (M1)" in err and "--strict" in err
    # where the device is, as every input error: FILE:LINE:COLUMN, the line, a caret
    assert f"{DEV / 'buck_vdmos.cir'}:6:1: error:" in err
    assert "    M1 in g sw MPOW\n    ^" in err
    # a macro-model: the X line that instantiates it
    assert main(["simulate", str(DEV / "buck_vendor.cir"), "--strict"]) == 2
    err = capsys.readouterr().err
    line = next(i for i, t in enumerate((DEV / "buck_vendor.cir").read_text().splitlines(), 1)
                if t.startswith("X"))
    assert f"{DEV / 'buck_vendor.cir'}:{line}:1: error:" in err, err
    with pytest.warns(IdealisedDeviceWarning):
        pelcs.load(DEV / "buck_vdmos.cir")
    # every device where it is, not only the first
    assert main(["simulate", str(DEV / "pmos_npn.cir"), "--strict"]) == 2
    err = capsys.readouterr().err
    assert f"{DEV / 'pmos_npn.cir'}:7:1: error: 2 devices" in err
    assert f"{DEV / 'pmos_npn.cir'}:12:1: error: Q1: idealised (refused by --strict)" in err
    # and its help says so, not only 'a circuit that is not passive'
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    helptext = " ".join(capsys.readouterr().out.split())
    assert "--strict refuse a circuit that is not passive, and transistors (M, Q)" in helptext


def test_written_back_as_devices_for_ngspice():
    c = load("pmos_npn.cir")
    text = write_circuit(c)
    assert "M1 d g s s PCH" in text and "Q1 c b 0 QN" in text
    assert ".model PCH PMOS(" in text and ".model QN NPN(" in text
    assert "pelcs_sw" not in text
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        again = parse_string(text, file=c.file)
    assert again.replacements == c.replacements
    assert [e.name for e in again.elements] == [e.name for e in c.elements]
    body = write_circuit(load("buck_vdmos.cir"))
    assert "M1_body" not in body and "M1 in g sw MPOW" in body


@pytest.mark.parametrize("line, message", [
    ("M1 d g s NOPE", "unknown model 'NOPE'"),
    ("M1 d g s QN", "is a NPN model, not NMOS or PMOS or VDMOS"),
    ("M1 d g MPOW", "2 nodes before the model"),
])
def test_device_errors(line, message):
    text = f"t\nV1 d 0 DC 1\nVg g 0 DC 5\nR1 s 0 1\n{line}\n.model MPOW NMOS(VTO=1)\n" \
           ".model QN NPN\n.end\n"
    with pytest.raises(NetlistError) as info:
        parse_string(text, file="dev.cir")
    d = info.value.diagnostics[0]
    assert message in d.message and d.location.line == 5


def test_vendor_model_text_values_are_skipped():
    text = ("t\nVd d 0 DC 10\nVg g 0 DC 10\nM1 d g 0 IRF\nR1 d 0 1\n"
            ".model IRF VDMOS(Rg=3 Vto=4 Rd=.1 Ks=.5 mfg=International_Rectifier Vds=100)\n"
            ".end\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = parse_string(text)
    assert c.replacements[0].threshold == 4.0


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_ngspice_runs_the_real_device(ngspice):
    from ngspice_checks.compare import compare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        cmp = compare(DEV / "buck_vdmos.cir", timeout=60)
    assert cmp.ok
    # (RD + RS + 1/(KP (Vgs - VTO))) I_max = 23 mOhm x the start-up peak, not ngspice's 1 ohm
    assert 0 < cmp.nonideal.switch_drops["M1"] < 0.3


# --- vendor macro-models, PySpice circuits, pandas ---------------------------------------


def test_vendor_macro_models_become_one_switch_and_one_diode():
    c = load("buck_vendor.cir")
    r = {x.element: x for x in c.replacements}
    q, d = r["XQ"], r["XD"]
    assert q.device == "NMOS macro-model" and q.threshold == 3.9 and q.body_diode == "XQ_body"
    assert "v(gate,source) > 3.9 V" in q.became
    # the gate network, the charge-emulating diodes and controlled sources are dropped
    assert {"RG", "D2", "D3", "D4", "EV16", "FI1", "FI2", "CAP"} <= set(q.dropped)
    assert d.device == "diode macro-model" and d.became == "ideal diode 0 -> source"
    assert d.dropped == ("Dgr",)  # two parallel diodes merged into one ideal diode
    kinds = {el.name: el.kind for el in c.elements}
    assert kinds["XQ"] == "S" and kinds["XD"] == "D" and kinds["XQ_body"] == "D"
    assert not any(n.startswith(("XQ.", "XD.")) for n in kinds)  # nothing of the bodies


def test_vendor_buck_output_is_the_ideal_one():
    """Ideal switch and diode: mean v(out) = D_eff Vin R/(R + RL), D_eff the fraction of the
    period the 24 V gate pulse (10 ns edges) is above VTO = 3.9 V."""
    c = load("buck_vendor.cir")
    res = simulate_circuit(c, probes=["v(out)"])
    assert any("Cin: its terminals are joined by voltage sources alone" in n for n in res.notes)
    ts = 2.5e-6
    d_eff = (5 / 12 * ts + 10e-9 + 10e-9 * (24 - 3.9) / 24 - 10e-9 * 3.9 / 24) / ts
    t, v = res.t, res["v(out)"]
    win = t >= t[-1] - 10 * ts
    mean = np.trapezoid(v[win], t[win]) / (t[win][-1] - t[win][0])
    assert mean == pytest.approx(d_eff * 12 * 3.1 / (3.1 + 0.037), rel=2e-3)


def test_vendor_buck_is_written_back_with_its_subcircuits():
    text = write_circuit(load("buck_vendor.cir"))
    assert "XQ in gate source pwrfet" in text and "XD 0 source schottky" in text
    assert ".subckt pwrfet 1 2 3" in text.lower() and "EV16 10 0 9 7 1" in text
    assert "XQ_body" not in text and "pelcs_sw" not in text
    assert "Cin in 0" in text  # ngspice simulates it


def test_pyspice_circuit_in_pandas_out():
    pytest.importorskip("PySpice")
    from PySpice.Spice.Netlist import Circuit

    lib = DEV / "lib"
    c = Circuit("Buck Converter")
    c.include(str(lib / "pwrfet.lib"))
    c.include(str(lib / "schottky.lib"))
    c.V("in", "vin", c.gnd, 12)
    c.C("in", "vin", c.gnd, 10e-6)
    c.X("Q", "pwrfet", "vin", "gate", "source")
    c.R("gate", "gate", "clock", 1)
    c.PulseVoltageSource("pulse", "clock", "source", 0, 24, 1e-6, 2.5e-6)
    c.X("D", "schottky", c.gnd, "source")
    c.L(1, "source", "out", 8.5e-6)
    c.C(1, "out", c.gnd, 20e-6)
    c.R("load", "out", c.gnd, 3.1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        res = pelcs.simulate(c, tstop="100u", step="10n", probes=["v(out)", "i(L1)"])
    df = res.to_pandas()
    assert list(df.columns) == ["v(out)", "i(L1)"] and df.index.name == "time"
    assert np.array_equal(df["v(out)"].to_numpy(), res["v(out)"])
    assert any("idealised: XQ" in n for n in df.attrs["notes"])
    assert 0 < df["v(out)"].iloc[-1] < 12


def pyspice_buck():
    from converters.pyspice_examples import pyspice_buck as build

    return build(DEV / "vendor")


def test_pyspice_buck_example_with_its_vendor_libraries():
    pytest.importorskip("PySpice")
    c = pyspice_buck()
    with pytest.warns(IdealisedDeviceWarning):
        circuit = pelcs.load(c)
    r = {x.element: x for x in circuit.replacements}
    q, d = r["XQ"], r["XD"]
    # irf150: M1 (NMOS, VTO = 4.07861) with RD, RG, RS to ports 1, 2, 3 and D1 from 3 to 1
    assert q.threshold == pytest.approx(4.07861) and q.body_diode == "XQ_body"
    assert "ideal switch drain in - source source" in q.became
    assert "on while v(gate,source) > 4.07861 V" in q.became
    assert {"RG", "D2", "EV16", "FI1"} <= set(q.dropped)
    # 1N5822: two diodes in parallel from port 1 to port 2
    assert d.became == "ideal diode 0 -> source" and d.dropped == ("Dgr",)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        res = pelcs.simulate(c, tstop="200u", step="10n", probes=["v(out)"])
    # the gate is driven from ground (24 V pulse): the ideal switch conducts while
    # v(gate) - v(source) > VTO, so the output settles near Vin - the threshold at most
    assert 0.0 < res["v(out)"][-1] < 12.0
    assert any("Cin: its terminals are joined by voltage sources alone" in n for n in res.notes)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_check_takes_the_pyspice_buck_and_gives_ngspice_the_vendor_models(ngspice):
    """ngspice runs PySpice's buck with the real irf150 and 1N5822 models; pelcs the ideal
    switch and diode. The example drives the gate from ground, so the MOSFET works as a
    source follower part of the time: the comparison is reported, not asserted in tolerance
    (the idealisation cannot follow a linear-mode MOSFET)."""
    pytest.importorskip("PySpice")
    from ngspice_checks.compare import compare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        cmp = compare(pyspice_buck(), tstop=100e-6, timeout=120)
    deck = cmp.ngspice_result.netlist.lower()
    assert ".subckt irf150 1 2 3" in deck and ".subckt 1n5822 1 2" in deck
    assert "xq in gate source irf150" in deck
    assert any("idealised: XQ" in n for n in cmp.notes)
    assert cmp.probes


def test_parallel_ideal_diodes_are_merged():
    from netlist.formulation import formulate
    from netlist.reductions import parallel_diodes

    text = (Path(__file__).parent / "netlists" / "ac" / "buck_vc.cir").read_text().replace(
        "D1 0 sw DIDEAL", "D1 0 sw DIDEAL\nD2 0 sw DIDEAL")
    c = parse_string(text)
    assert parallel_diodes(c) == {"d2": "D1"}
    assert formulate(c).diodes == ("D1",)
    res = simulate_circuit(c, tstop=1e-4, probes=["v(out)", "i(D1)"])
    assert any("D2 is in parallel with D1: merged" in n for n in res.notes)
    with pytest.raises(NetlistError, match="D2 is merged into D1"):
        simulate_circuit(c, tstop=1e-4, probes=["i(D2)"])


def test_pnp_switches_on_when_its_base_is_below_its_emitter():
    text = ("PNP high-side switch\nVe e 0 DC 5\nVb b 0 PWL(0 5 1m 5 1.001m 4)\n"
            "Q1 c b e QP\nR1 c 0 100\n.model QP PNP(BF=50)\n.tran 1u 2m\n.end\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = parse_string(text)
    (r,) = c.replacements
    assert r.device == "PNP" and "v(e,b) > 0.7 V" in r.became
    res = simulate_circuit(c, probes=["i(R1)"])
    (t_on, mode), = res.events
    # v(e,b) = 5 - v(b) passes 0.7 V when the base has fallen 0.7 of its 1 V step
    assert mode == (True,) and t_on == pytest.approx(1e-3 + 0.7e-6, rel=1e-12)
    assert res["i(R1)"][-1] == pytest.approx(0.05)


def test_more_vendor_parts_as_they_come():
    """NXP's 1N4148 (a subcircuit: diode + leakage resistor) and BAV21 (a model), onsemi's
    2N2222A (an NPN model) from PySpice's libraries (origin in vendor/ORIGIN.md)."""
    c = load("vendor_parts.cir")
    r = {x.element: x for x in c.replacements}
    assert r["X1"].device == "diode macro-model" and r["X1"].dropped == ("R1",)
    assert r["Q1"].device == "NPN" and r["Q1"].threshold == 0.7
    res = simulate_circuit(c, probes=["v(k1)", "v(k2)", "i(Rc)"])
    t = res.t
    pos = (t > 0.1e-3) & (t < 0.4e-3)  # source at +10 V: both diodes conduct (ideal)
    assert np.allclose(res["v(k1)"][pos], 10.0) and np.allclose(res["v(k2)"][pos], 10.0)
    neg = (t > 0.6e-3) & (t < 0.9e-3)  # at -10 V: both block
    assert np.allclose(res["v(k1)"][neg], 0.0) and np.allclose(res["v(k2)"][neg], 0.0)
    assert res["i(Rc)"][-1] == pytest.approx(0.05)  # Q1 on: 5 V across 100 ohm
    from netlist.studies.realistic import simulate_devices

    pwl = simulate_devices(c, devices="pwl", probes=["v(k2)", "i(Rc)"])
    fit = {f.element: f for f in pwl.device_fits}
    # BAV21: IS = 21.91 nA, N = 2.233, RS = 1 mOhm, fitted over the ~10 mA it carries
    assert 0.5 < fit["D2"].top[0] < 0.9 and "IS=2.19e-08" in fit["D2"].how
    assert fit["Q1"].ron == pytest.approx(0.426673 + 0.0001) and fit["Q1"].vf == 0.2


def test_igbt_like_macro_becomes_one_switch_with_its_copack_diode():
    c = load("igbt_chopper.cir")
    (r,) = c.replacements
    assert r.device == "IGBT-like macro-model" and r.threshold == 5.0
    assert "ideal switch collector c - emitter 0, on while v(g) > 5 V" in r.became
    assert r.body_diode == "X1_body" and set(r.dropped) == {"Rg", "Q1", "Cge"}
    res = simulate_circuit(c, probes=["i(Rl)"])
    # on while the 15 V gate pulse is above 5 V: 10 A through 10 ohm from 100 V
    t, i = res.t, res["i(Rl)"]
    assert np.allclose(i[(t > 11e-6) & (t < 29e-6)], 10.0)
    assert np.allclose(i[(t > 31e-6) & (t < 59e-6)], 0.0)
    (t_on, _), (t_off, _) = res.events[:2]
    assert t_on == pytest.approx(10e-6 + 100e-9 / 3, rel=1e-9)  # 5 V of the 15 V rise


def test_explicit_vf_ron(capsys):
    assert main(["simulate", str(DEV / "boost_sw_pwl.cir"), "--devices", "pwl", "--pwl",
                 "D1=0.7:0.05", "--pwl", "SWR=0:0.2", "--tstop", "1m"]) == 0
    out = capsys.readouterr().out
    assert "D1: Vf = 0.7 V, Ron = 0.05 Ω (given)" in out
    assert "S1: Vf = 0 V, Ron = 0.2 Ω (given)" in out  # by model name
    assert main(["simulate", str(DEV / "boost_sw_pwl.cir"), "--devices", "pwl", "--pwl",
                 "D1=x"]) == 2


def test_macro_subcircuit_text_keeps_its_parameter_defaults():
    from netlist.devices import subckt_text
    from netlist.parser import read_deck

    deck = read_deck("t\n.subckt s a b params: r = 1m  c={2*x}\nD1 a b DX\nR1 a b {r}\n"
                     ".ends\n.end\n")
    text = subckt_text(deck.subckts["s"])
    assert text.splitlines() == [".subckt s a b params: r=1m c={2*x}", "D1 a b DX",
                                 "R1 a b {r}", ".ends s"]


SNUBBED_DIODE = """snubbed diode macro-model: a series resistor, and an RC across the junction
V1 a 0 sin(0 100 50)
xD1 a c pwrdiode
R1 c 0 20
.subckt pwrdiode A K
RS A N 0.5
DX N K dmod
RX A M 10k
CX M K 0.01uF
.model dmod D(Rs=0.01, CJO=100pF)
.ends
.tran 1us 40ms
.end
"""


def test_diode_macro_series_resistance_is_on_the_junctions_path(tmp_path, ngspice):
    """Only RS, between the port and the junction, is in series with it; RX leads to CX, a
    snubber across the junction (dropped), not in series with it (before: 10.5 kOhm in series,
    the pwl run's output 0.03 V against ngspice's 15 V). ngspice simulates the subcircuit."""
    from ngspice_helpers import ngspice_run

    from netlist.studies.realistic import simulate_devices

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = parse_string(SNUBBED_DIODE)
    (d,) = [el for el in c.elements if el.name == "xD1"]
    assert d.device[4] == pytest.approx(0.5)
    pwl = simulate_devices(c, devices="pwl", probes=["v(c)"])
    t, v = np.asarray(pwl.t), np.asarray(pwl["v(c)"])
    ng, log = ngspice_run(SNUBBED_DIODE, ["v(c)"], tmp_path)
    assert ng is not None, log
    keep, keep_ng = t >= 20e-3, ng[:, 0] >= 20e-3
    mean = np.trapezoid(v[keep], t[keep]) / 20e-3
    want = np.trapezoid(ng[keep_ng, 1], ng[keep_ng, 0]) / (ng[-1, 0] - 20e-3)
    assert mean == pytest.approx(want, rel=0.01)  # 30.622 V, ngspice 30.623 V


# a high-side NMOS (level 1, no body diode) whose gate a floating driver holds at its source,
# as ltspice_lean's buck writes it: at each edge, and in the ringing of discontinuous
# conduction, the switch node passes the drain, where the real channel conducts backwards
BOOTSTRAP_BUCK = """high-side nmos, floating driver
Vin in 0 12
Vpwm pwm 0 PULSE(0 12 0 10n 10n 5u 10u)
B1 drv 0 V=V(sw)+(V(pwm)>6 ? 11.5 : 0)
Rg drv gate 10
Cg gate sw 1n
M1 in gate sw 0 NMOS
D1 0 sw D
Rsw sw 0 10meg
L1 sw out 10u
C1 out 0 100u
R1 out 0 10
.model NMOS NMOS(VTO=2 KP=10)
.model D D(IS=1e-12)
.tran 10n 50u
.end
"""


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_a_mosfet_channel_that_would_conduct_backwards_is_an_error():
    # the first edge: the driver pushes Cg's current into the switch node, which nothing
    # holds while the ideal switch (on while v(gate,sw) > 2 V) is still off; ngspice's
    # channel turns on against the drain and clamps it (mean output 7.83 V over 5-9.9 ms;
    # pelcs without the check: 9.7 V, with a 4.5 kV spike at the edge)
    with pytest.raises(NetlistError) as exc:
        simulate_devices(parse_string(BOOTSTRAP_BUCK), devices="pwl", probes=["v(out)"])
    text = str(exc.value)
    assert "<string>:7:1: error: M1 (NMOS) is off in pelcs at t = " in text
    assert "against its drain in" in text and "use a VDMOS model" in text
    # probes or none (every state stored), the check reads the nodes it needs
    with pytest.raises(NetlistError):
        simulate_devices(parse_string(BOOTSTRAP_BUCK), devices="pwl")
    # a VDMOS: its body diode conducts that way, and nothing is refused
    vdmos = BOOTSTRAP_BUCK.replace("M1 in gate sw 0 NMOS", "M1 in gate sw VD").replace(
        ".model NMOS NMOS(VTO=2 KP=10)", ".model VD VDMOS(VTO=2 KP=10)")
    res = simulate_devices(parse_string(vdmos), devices="pwl", probes=["v(out)"])
    res.raise_if_error()


# a synchronous buck's low-side NMOS of ngspice's default VTO = 0 with a diode across it:
# while it is off the diode holds its drain on ground, up to rounding (1.8e-15 V below it
# in the ideal run), which is no reverse conduction of the channel
SYNC_LOW_SIDE_VTO0 = """sync buck, low-side NMOS VTO = 0, diode across it
Vin in 0 12
M1 in gh sw VD
M2 sw gl 0 0 NM
D2 0 sw DS
Vgh gh sw PULSE(0 10 100n 10n 10n 4.8u 10u)
Vgl gl 0 PULSE(10 0 0 10n 10n 5u 10u)
L1 sw out 47u
C1 out 0 10u
R1 out 0 3
.model NM NMOS(KP=10)
.model VD VDMOS(VTO=2 KP=10)
.model DS D(IS=1e-12 N=0.1)
.tran 50n 0.5m
.end
"""


def test_a_drain_on_the_source_up_to_rounding_is_no_reverse_conduction(tmp_path, ngspice):
    from ngspice_helpers import ngspice_wrdata
    res = simulate_circuit(parse_string(SYNC_LOW_SIDE_VTO0), probes=["v(out)"])
    res.raise_if_error()  # was: M2 off while the gate stands 1.776e-15 V against its drain
    keep = res.t >= 0.3e-3
    ng = ngspice_wrdata(SYNC_LOW_SIDE_VTO0, ["v(out)"], tmp_path)
    keep_ng = ng[:, 0] >= 0.3e-3
    # ideal switches and diodes: 5.78 V, ngspice 5.76 V
    assert float(np.mean(res.y[keep, 0])) == pytest.approx(float(np.mean(ng[keep_ng, 1])),
                                                           rel=0.01)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_a_mosfet_macro_model_without_body_diode_is_checked_for_reverse_conduction():
    # the same channel inside a subcircuit (read as an NMOS macro-model): it was not checked,
    # and the run printed a confident answer with the switch node at 4.5 kV
    deck = BOOTSTRAP_BUCK.replace("M1 in gate sw 0 NMOS", "X1 in gate sw MYMOS\n"
                                  ".subckt MYMOS d g s\nRg g gi 1\nM1 d gi s s NMOS\n.ends")
    with pytest.raises(NetlistError, match=r"X1 \(NMOS\) is off in pelcs at t = .* against "
                                           "its drain in"):
        simulate_devices(parse_string(deck), devices="pwl", probes=["v(out)"])


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_a_long_streamed_run_leaves_the_reverse_channel_check_out_and_says_so(monkeypatch):
    # keeping every step for the check is what writing as it goes avoids (a 2 s boost: 866 MB
    # where the streamed run holds 57 MB): past netlist.knee.KNEE_STEPS such a run leaves the
    # check out with a note; a run that keeps its steps still makes it
    import netlist.knee as knee

    monkeypatch.setattr(knee, "KNEE_STEPS", 100)
    res = simulate_devices(parse_string(BOOTSTRAP_BUCK), devices="pwl", probes=["v(out)"],
                           output_step=1e-6)
    assert any("M1: not checked for a channel that would conduct backwards" in n
               for n in res.notes)
    with pytest.raises(NetlistError):
        simulate_devices(parse_string(BOOTSTRAP_BUCK), devices="pwl", probes=["v(out)"])
