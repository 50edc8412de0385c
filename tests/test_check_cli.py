"""``pelcs check``: table, report files, JSON, exit codes, and no PySpice noise."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from pelcs.cli import main

ROOT = Path(__file__).resolve().parents[1]
BUCK = str(ROOT / "converters" / "netlists" / "buck.cir")


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_within_tolerance_exits_0_and_writes_the_report(ngspice, tmp_path, capsys):
    rc = main(["check", BUCK, "--tstop", "2m", "--probe", "v(out),i(L1)",
               "--report", str(tmp_path)])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "within tolerance" in out
    assert "v(out)" in out and "i(L1)" in out and "switch S1 (source)" in out
    assert "rung 0 (as-written" in out  # which ngspice settings ran
    assert "pelcs:" in out and "ngspice:" in out  # both wall times
    for name in ("buck.md", "buck.json", "buck.png", "buck.ngspice.cir"):
        assert (tmp_path / name).stat().st_size > 0, name
    md = (tmp_path / "buck.md").read_text()
    assert "**Within tolerance**" in md and "![pelcs vs ngspice](buck.png)" in md
    assert "| wall time |" in md
    data = json.loads((tmp_path / "buck.json").read_text())
    assert data["ok"] is True and data["ngspice"]["rung"] == 0
    assert [p["probe"] for p in data["probes"]] == ["v(out)", "i(L1)"]
    assert data["period"] == pytest.approx(20e-6)
    assert data["pelcs"]["wall_time"] > 0 and data["ngspice"]["wall_time"] > 0
    assert "vpelcs_d1" in (tmp_path / "buck.ngspice.cir").read_text().lower()


def test_a_deliberate_difference_is_out_of_tolerance(ngspice, capsys):
    # duty 0.52 instead of 0.5 in pelcs only: the output moves by 4 %
    rc = main(["check", BUCK, "--tstop", "2m", "--pelcs-param", "duty=0.52"])
    out = capsys.readouterr().out
    assert rc == 1, out
    assert "OUT OF TOLERANCE" in out and "deliberate difference" in out
    assert "FAIL (" in out


def test_json_on_stdout(ngspice, capsys):
    rc = main(["check", BUCK, "--tstop", "1m", "--json"])
    data = json.loads(capsys.readouterr().out)
    assert rc == 0 and data["ok"] is True
    assert [p["probe"] for p in data["probes"]] == ["i(L1)", "v(C1)"]  # default: the states
    assert data["probes"][1]["ngspice_probe"] == "v(out)"


@pytest.mark.parametrize("argv, message", [
    (["--tstop", "5x"], "--tstop: '5x' is not a number"),
    (["--period", "-1"], "--period must be positive"),
    (["--probe", "v(nope)"], "unknown probe 'v(nope)'"),
    (["--probe", "d(S1)"], "exists in pelcs only"),
    (["--param", "nope=1"], "nope"),
])
def test_input_errors_exit_2(argv, message, capsys):
    rc = main(["check", BUCK, *argv])
    err = capsys.readouterr().err
    assert rc == 2 and message in err
    assert "Traceback" not in err


def test_bad_netlist_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.cir"
    bad.write_text("bad\nJ1 d g 0 NJF\n.tran 1u 1m\n.end\n")
    assert main(["check", str(bad)]) == 2
    assert "bad.cir:2:1: error" in capsys.readouterr().err
    assert main(["check", str(tmp_path / "missing.cir")]) == 2


def test_missing_ngspice_exits_3_with_a_clear_message(monkeypatch, capsys):
    from ngspice_checks import runner

    monkeypatch.setattr(runner, "_check_available",
                        lambda: (False, "PySpice is not installed; install it"))
    rc = main(["check", BUCK, "--tstop", "0.1m"])
    err = capsys.readouterr().err
    assert rc == 3
    assert "ngspice is not available, nothing was compared" in err
    assert "PySpice is not installed" in err


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_no_pyspice_noise_reaches_the_terminal(ngspice):
    # a fresh process: PySpice warns "Unsupported Ngspice version 39" on import and
    # libngspice prints to stdout/stderr; the runner's worker keeps all of it
    proc = subprocess.run(
        [sys.executable, "-m", "pelcs.cli", "check", BUCK, "--tstop", "0.5m"],
        capture_output=True, text=True, cwd=ROOT, timeout=300,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert proc.stderr == ""
    text = proc.stdout.lower()
    for word in ("pyspice", "unsupported", "warning", "ngspice-39", "circuit:"):
        assert word not in text, word
