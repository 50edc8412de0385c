"""``pelcs simulate``: output files, options, exit statuses (0 ok, 2 input error, 3 failed run)."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pelcs.cli import main
from pelcs.commands.simulate import split_probes
from pelcs.plotting import auto_zoom, probe_unit, time_unit

SIM = Path(__file__).parent / "netlists" / "sim"
BUCK = str(SIM / "buck_ccm.cir")


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    with open(path) as fh:
        header = next(csv.reader(fh))
    return header, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)


def test_csv_header_values_and_summary(tmp_path, capsys):
    out = tmp_path / "buck.csv"
    code, text, err = run(capsys, "simulate", BUCK, "--tstop", "0.2m", "--step", "0.5u",
                          "--probe", "v(out)", "--probe", "i(L1),v(in,sw)", "-o", str(out))
    assert code == 0, err
    header, data = read_csv(out)
    # A probe with a comma is quoted in the CSV header, so csv readers split it right.
    assert header == ["time", "v(out)", "i(L1)", "v(in,sw)"]
    assert out.read_text().startswith('time,v(out),i(L1),"v(in,sw)"\n')
    assert data[0, 0] == 0.0 and data[-1, 0] == pytest.approx(0.2e-3)  # SI units: s
    assert np.all(np.diff(data[:, 0]) > 0)
    # Summary: steps, timing, modes, final values with units, file written.
    assert "steps" in text and "µs/step" in text
    assert "switch modes visited: (S1 off) (S1 on)" in text
    assert "final values (t = 200 us): v(out) = " in text.replace("µ", "u")
    assert " V, i(L1) = " in text and " A, v(in,sw) = " in text
    assert f"wrote {out}" in text


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_npz_every_and_plot(tmp_path, capsys):
    npz, png = tmp_path / "r.npz", tmp_path / "sub" / "r.png"
    code, _, err = run(capsys, "simulate", BUCK, "--tstop", "200u", "--step", "0.5u",
                       "--every", "10", "-o", str(npz), "--plot", str(png))
    assert code == 0, err
    data = np.load(npz)
    assert list(data["names"]) == ["i(L1)", "v(C1)"]  # default: every state
    assert data["y"].shape == (len(data["t"]), 2)
    np.testing.assert_array_equal(data["v(C1)"], data["y"][:, 1])
    assert str(data["error"]) == ""
    full = tmp_path / "full.npz"
    assert run(capsys, "simulate", BUCK, "--tstop", "200u", "--step", "0.5u",
               "-o", str(full))[0] == 0
    t_full = np.load(full)["t"]
    # --every 10 keeps every 10th step (plus the first and last point).
    assert len(data["t"]) == pytest.approx(len(t_full) / 10, abs=2)
    assert set(data["t"]) <= set(t_full)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000


def test_spice_suffixes_and_theta(tmp_path, capsys):
    out = tmp_path / "r.csv"
    code, text, _ = run(capsys, "simulate", BUCK, "--tstop", "0.1ms", "--step", "1u",
                        "--theta", "1", "--param", "duty=0.25", "-o", str(out))
    assert code == 0
    assert "h = 1 us" in text.replace("µ", "u") and "θ = 1" in text
    assert read_csv(out)[1][-1, 0] == pytest.approx(1e-4)


@pytest.mark.parametrize(("argv", "message"), [
    (["--probe", "v(nowhere)"], "unknown probe 'v(nowhere)'"),
    (["--probe", "i(Q1)"], "unknown probe 'i(Q1)'"),
    (["--tstop", "5x"], "--tstop: '5x' is not a number"),
    (["--theta", "0.3"], "θ must be in [0.5, 1]"),
    (["--every", "0"], "--every 0: not a positive integer"),
    (["-o", "out.txt"], "cannot tell the format"),
    (["--param", "nosuch=1"], "nosuch"),
])
def test_input_errors_exit_2_with_a_hint(capsys, argv, message):
    code, out, err = run(capsys, "simulate", BUCK, *argv)
    assert code == 2
    assert message in err
    assert "hint:" in err or "nosuch" in message
    assert "Traceback" not in err and out == ""


def test_bad_probe_hint_lists_nodes_and_elements(capsys):
    code, _, err = run(capsys, "simulate", BUCK, "--probe", "v(outt)")
    assert code == 2
    assert "hint: did you mean v(out)? (probes are v(NODE), v(NODE,NODE)" in err
    assert "i(ELEMENT)" in err and "nodes: 0, in, sw, gate, out;" in err
    assert "elements: Vin, S1, D1, L1" in err


def test_no_tran_and_no_tstop_exits_2(tmp_path, capsys):
    net = tmp_path / "notran.cir"
    net.write_text("no tran\nV1 a 0 DC 1\nR1 a b 1k\nC1 b 0 1u\n.end\n")
    code, _, err = run(capsys, "simulate", str(net))
    assert code == 2
    assert "no .tran analysis and no stop time given" in err and "--tstop" in err
    # With --tstop the step defaults (1/5000 of the run, no source period) and it runs.
    code, out, _ = run(capsys, "simulate", str(net), "--tstop", "1m")
    assert code == 0 and "h = 200 ns" in out and "no .tran step" in out


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_failed_run_exits_3_after_writing_partial_results(tmp_path, capsys):
    out, png = tmp_path / "neg.csv", tmp_path / "neg.png"
    code, text, err = run(capsys, "simulate", str(SIM / "negative_r.cir"), "--probe",
                          "v(in),i(D1)", "-o", str(out), "--plot", str(png))
    assert code == 3
    header, data = read_csv(out)
    assert header == ["time", "v(in)", "i(D1)"]
    # Everything up to the failure at 0.5 ms (the source turns positive), nothing after.
    assert data[-1, 0] == pytest.approx(0.5e-3, abs=1e-9)
    assert len(data) == 501
    assert png.exists()
    # The error names the time, the mode and the diode.
    assert "error: simulation failed (no_solution)" in err
    assert "t = 0.000501 s" in err and "mode: single LCS" in err and "D1" in err
    assert f"results up to t = 500 us written to {out}" in err.replace("µ", "u")
    assert "final values (t = 500 us)" in text.replace("µ", "u")


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_entry_point_runs(tmp_path):
    out = tmp_path / "r.csv"
    exe = Path(sys.executable).with_name("pelcs")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "pelcs.cli"]
    proc = subprocess.run([*cmd, "simulate", BUCK, "--tstop", "50u", "-o", str(out)],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    assert proc.returncode == 0, proc.stderr
    assert out.read_text().startswith("time,i(L1),v(C1)\n")


# ---------------------------------------------------------------------------------------------
# Helpers
# ---------------------------------------------------------------------------------------------


def test_split_probes():
    assert split_probes(["v(out),i(L1)", " v(a,b) ", "i(D1),"]) == \
        ["v(out)", "i(L1)", "v(a,b)", "i(D1)"]


def test_units():
    assert probe_unit("v(out)") == "V" and probe_unit("I(L1)") == "A" and probe_unit("x") == ""
    assert time_unit(5e-3) == (1e-3, "ms") and time_unit(60e-6) == (1e-6, "µs")
    assert time_unit(2.0) == (1.0, "s") and time_unit(3e-10) == (1e-9, "ns")


def test_auto_zoom_is_the_last_switching_periods():
    import pelcs

    res = pelcs.simulate(BUCK, tstop="0.4m")
    t0, t1 = auto_zoom(res)
    assert t1 == pytest.approx(0.4e-3) and t1 - t0 == pytest.approx(3 * 20e-6)
    assert auto_zoom(pelcs.simulate(str(SIM / "half_wave.cir"), tstop="20m")) is None


def test_plot_envelope_keeps_the_extremes_of_dense_waveforms():
    from pelcs.plotting import _envelope

    t = np.linspace(0.0, 1.0, 100_001)
    y = np.sin(2 * np.pi * 500 * t) + t  # 500 ripple periods
    tt, yy = _envelope(t, y)
    assert len(tt) < 10_000 and np.all(np.diff(tt) >= 0)
    assert yy.max() == y.max() and yy.min() == y.min()
    assert tt[0] == t[0] and tt[-1] == t[-1] or yy[-1] == y[-1]


def test_summary_of_many_switches_and_probes_stays_short(tmp_path, capsys):
    # A 13-phase interleaved buck: 13 switches, 14 states; the summary names at most six
    # modes, each by its closed switches, and twelve final values.
    from converters.scaling import interleaved_buck

    net = tmp_path / "ib13.cir"
    net.write_text(interleaved_buck(13, periods=2))
    out = tmp_path / "ib13.npz"
    code, text, err = run(capsys, "simulate", str(net), "-o", str(out))
    assert code == 0, err
    line = next(ln for ln in text.splitlines() if ln.startswith("switch modes visited:"))
    assert line.startswith("switch modes visited: (all off) (on: S1) (on: S1, S2) ")
    assert "S13 off" not in line and "in all); " in line
    finals = next(ln for ln in text.splitlines() if ln.startswith("final values"))
    assert finals.count(" = ") == 13  # (t = ..., then twelve values)
    assert finals.endswith("(14 probes, all in the output)")
    with np.load(out) as data:
        assert data["y"].shape[1] == len(data["names"]) == 14


def test_circuit_without_states_writes_its_node_voltages(tmp_path, capsys):
    # A resistive half-wave rectifier has no inductor or capacitor: the default probes (the
    # states) would be none, a CSV of times only. It writes the node voltages instead.
    deck = tmp_path / "halfwave_r.cir"
    deck.write_text("half-wave rectifier into a resistor\nV1 in 0 SIN(0 10 50)\n"
                    "D1 in out DI\n.model DI D\nR1 out 0 1k\n.tran 1m 20m\n.end\n")
    out = tmp_path / "r.csv"
    code, text, err = run(capsys, "simulate", str(deck), "-o", str(out))
    assert code == 0, err
    header, data = read_csv(out)
    assert header == ["time", "v(in)", "v(out)"]
    t, vin, vout = data.T
    np.testing.assert_allclose(vin, 10 * np.sin(2 * np.pi * 50 * t), atol=1e-9)
    np.testing.assert_allclose(vout, np.maximum(vin, 0.0), atol=1e-9)  # ideal diode
    assert "default probes are the node voltages" in text + err
    # with probes asked for, the default ones are not the run's: no such note
    code, text, err = run(capsys, "simulate", str(deck), "-o", str(out), "--probe", "v(out)")
    assert code == 0, err
    assert "default probes" not in text + err and read_csv(out)[0] == ["time", "v(out)"]


def test_lcs_of_a_capacitor_across_the_source(tmp_path, capsys):
    # PySpice's buck puts Cin straight across Vin: no state, and no traceback.
    deck = tmp_path / "cin.cir"
    deck.write_text("buck with an input capacitor\nVin in 0 DC 12\nCin in 0 10u\n"
                    "S1 in sw g 0 SWM\n.model SWM SW(RON=1m)\nVg g 0 DC 1\nD1 0 sw DI\n"
                    ".model DI D\nL1 sw out 10u\nC1 out 0 47u\nR1 out 0 2.5\n.end\n")
    code, text, err = run(capsys, "lcs", str(deck), "--mode", "S1=on")
    assert code == 0, err
    assert "Traceback" not in err and "passive" in text
