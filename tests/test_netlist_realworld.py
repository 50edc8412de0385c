"""Converter netlists in ngspice style: expected elements, round trip, ngspice acceptance."""

import dataclasses
import subprocess
from pathlib import Path

import pytest
from ngspice_helpers import ngspice_executable

from lcs.signals import Exp, Pulse, Pwl, Sin
from netlist.circuit import IgnoredCommand, Tran
from netlist.parser import parse_file, parse_string
from netlist.writer import spice_name, write_circuit

HERE = Path(__file__).parent / "netlists"
REPO = Path(__file__).parent.parent
NETLISTS = sorted(HERE.glob("*.cir")) + sorted((REPO / "converters" / "netlists").glob("*.cir"))


def kinds(c):
    return {e.name: e.kind for e in c.elements}


def same_wave(sig, expected):
    """Waveforms equal up to rounding (values computed from parameter expressions)."""
    if type(sig) is not type(expected):
        return False
    a, b = dataclasses.asdict(sig), dataclasses.asdict(expected)
    return all(a[k] == b[k] if b[k] is None else a[k] == pytest.approx(b[k], rel=1e-12)
               for k in a)


def test_buck_sync():
    c = parse_file(HERE / "buck_sync.cir")
    assert kinds(c) == {
        "Vin": "V", "Xhi.S1": "S", "Xhi.D1": "D", "Xlo.S1": "S", "Xlo.D1": "D",
        "L1": "L", "Cout": "C", "Rload": "R", "Vgh": "V", "Vgl": "V",
    }
    # .lib section: the switching cell; .include: the models
    assert c.element("Xhi.S1").nodes == ("in", "sw")
    assert c.element("Xhi.S1").control == ("gh", "0")
    assert c.element("Xlo.D1").nodes == ("0", "sw")
    assert set(c.models) == {"dideal", "swideal"}
    assert c.models["swideal"].params["vh"] == 0.1
    duty, ts = 5 / 24, 1e-5
    assert c.params == pytest.approx({"ts": ts, "vin": 24, "vout": 5, "fs": 1e5, "duty": duty})
    assert c.element("Rload").value == pytest.approx(2.5)
    # the continuation line of Vgl carries PW and PER
    assert same_wave(c.element("Vgl").waveform, Pulse(1, 0, 0, 10e-9, 10e-9, duty * ts, ts))
    assert same_wave(c.element("Vgh").waveform,
                     Pulse(0, 1, 50e-9, 10e-9, 10e-9, duty * ts - 100e-9, ts))
    assert c.tran == Tran(20e-9, 200e-6, 0.0, 20e-9, True)
    assert c.options == {"reltol": "1e-4", "method": "gear"}
    assert [i.text.split("\n")[0] for i in c.ignored] == [".save v(out) i(L1)", ".control"]
    assert c.element("L1").ic == 0.0 and c.element("Cout").ic == 0.0


def test_cuk_coupled():
    c = parse_file(HERE / "cuk_coupled.cir")
    assert kinds(c) == {
        "VIN": "V", "L1": "L", "L2": "L", "K12": "K", "C1": "C", "S1": "S", "D1": "D",
        "C2": "C", "RL": "R", "VG": "V", "VSENSE": "V", "RSENSE": "R", "HMON": "H",
        "RMON": "R",
    }
    assert c.element("K12").inductors == ("L1", "L2") and c.element("K12").k == 0.6
    assert c.element("L2").value == 220e-6 and c.element("L2").ic == 0.0
    assert c.element("S1").initial is False
    assert c.element("HMON").source == "VIN"
    assert c.initial_conditions == {"out": 0.0, "b": 0.0}
    assert same_wave(c.element("VG").waveform, Pulse(0, 1, 0, 10e-9, 10e-9, 8e-6, 20e-6))
    assert c.nodes == ["0", "in", "a", "b", "out", "gate", "in2", "mon"]


def test_interleaved_boost():
    c = parse_file(HERE / "interleaved_boost.cir")
    names = [e.name for e in c.elements]
    assert names[:11] == ["Vin", "X1.Rs", "X1.L1", "X1.Xsw.S1", "X1.Xsw.Rsn", "X1.D1",
                          "X2.Rs", "X2.L1", "X2.Xsw.S1", "X2.Xsw.Rsn", "X2.D1"]
    k = kinds(c)
    assert sum(1 for v in k.values() if v == "S") == 2
    assert k["Emon"] == "E" and k["Gerr"] == "G" and k["Isrc"] == "I"
    assert c.element("X2.Rs").value == 20e-3 and c.element("X1.Rs").value == 10e-3
    assert c.element("X1.L1").value == 33e-6
    assert c.element("X2.Xsw.S1").nodes == ("x2.sw", "0")
    assert c.element("X2.Xsw.S1").control == ("g2", "0")
    assert same_wave(c.element("Vg2").waveform, Pulse(0, 1, 2.5e-6, 1e-9, 1e-9, 2.5e-6, 5e-6))
    assert c.element("Isrc").waveform == Sin(0, 10e-3, 1e3)
    assert c.element("Iexp").waveform == Exp(0, 1e-3, 1e-6, 2e-6, 5e-6, 3e-6)
    assert c.element("Vpwl").waveform == Pwl((0, 1e-6, 2e-6), (0, 1, 1))
    assert [i.text.split()[0] for i in c.ignored] == [".four", ".meas"]


def test_overrides_reach_subcircuits():
    c = parse_file(HERE / "interleaved_boost.cir", params={"lph": 47e-6, "fs": 100e3})
    assert c.element("X1.L1").value == 47e-6
    assert c.element("Vg1").waveform.per == pytest.approx(1e-5)


@pytest.mark.parametrize("path", NETLISTS, ids=lambda p: p.name)
def test_round_trip(path):
    c = parse_file(path)
    text = write_circuit(c)
    again = parse_string(text, file=c.file)
    assert again == c
    # and the written text is a fixed point of write(parse(.))
    assert write_circuit(again) == text


def test_writer_names_and_values():
    c = parse_file(HERE / "interleaved_boost.cir")
    text = write_circuit(c)
    assert "S.X1.Xsw.S1 x1.sw 0 g1 0 SWIDEAL" in text
    assert "L.X1.L1 x1.a x1.sw 33u" in text
    assert spice_name("X1.L1") == "L.X1.L1" and spice_name("R1") == "R1"
    assert text.startswith(c.title + "\n")
    assert text.rstrip().endswith(".end")


def _run_ngspice(exe, text, path):
    path.write_text(text)
    proc = subprocess.run([exe, "-b", str(path)], capture_output=True, text=True, timeout=60,
                          cwd=path.parent)
    log = proc.stdout + proc.stderr
    errors = [line for line in log.splitlines() if "error" in line.lower()]
    return proc.returncode, errors, log


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("path", NETLISTS, ids=lambda p: p.name)
def test_ngspice_accepts_written_netlist(path, tmp_path):
    exe = ngspice_executable()
    c = parse_file(path)
    # 1. the written text as it is: ngspice builds the circuit (unknown models, bad lines and
    # missing nodes are reported) but, without .print, runs nothing and exits with 1
    _, errors, log = _run_ngspice(exe, write_circuit(c), tmp_path / "full.cir")
    assert not errors, log
    assert f"circuit: {c.title.lower()}" in log.lower()
    # 2. a short transient (100 steps) that prints one node, so that the exit status says
    # whether ngspice accepted and simulated the circuit; the user's own output commands are
    # left out since they may measure beyond the shortened run
    tstep = c.tran.tstep if c.tran else 1e-7
    node = next(n for n in c.nodes if n != "0")
    short = dataclasses.replace(
        c, tran=Tran(tstep, 100 * tstep, 0.0, tstep, c.tran.uic if c.tran else False),
        ignored=[IgnoredCommand(f".print tran v({node})")])
    status, errors, log = _run_ngspice(exe, write_circuit(short), tmp_path / "short.cir")
    assert status == 0, log
    assert not errors, log


def test_round_trip_of_odd_but_valid_names():
    # dotted element names inside a subcircuit, non-ASCII model parameter names, a K and an F
    # that refer to elements of an instance: all must survive write -> parse
    text = (
        "odd names\n"
        ".subckt s a\nR1.x a m 1\nL.1 m 0 1u\nL2 m 0 1u\nK1 L.1 L2 0.5\nV.s m n 0\n"
        "F.f n 0 V.s 2\nRn n 0 1\n.ends\n"
        "V1 a 0 1\nX1 a s\nD1 a 0 DM\n.model DM D(\u00b5x=1 IS=1n)\n"
    )
    c = parse_string(text)
    assert [e.name for e in c.elements][:5] == ["V1", "X1.R1.x", "X1.L.1", "X1.L2", "X1.K1"]
    written = write_circuit(c)
    assert "R.X1.R1.x a x1.m 1" in written and "K.X1.K1 L.X1.L.1 L.X1.L2 0.5" in written
    assert "F.X1.F.f x1.n 0 V.X1.V.s 2" in written
    assert parse_string(written) == c
