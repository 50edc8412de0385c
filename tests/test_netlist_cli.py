"""``pelcs info`` through the CLI entry point: output, exit status, gcc-style errors."""

import re
from pathlib import Path

import pytest

from pelcs.cli import main

HERE = Path(__file__).parent / "netlists"


def run(capsys, *argv):
    status = main(list(argv))
    out = capsys.readouterr()
    return status, out.out, out.err


def test_info_on_a_good_file(capsys):
    status, out, err = run(capsys, "info", str(HERE / "buck_sync.cir"))
    assert status == 0 and err == ""
    assert "title: Synchronous buck converter, 24 V -> 5 V, 100 kHz (ngspice style)" in out
    assert "nodes (6): 0 (ground), in, sw, gh, gl, out" in out
    # values in engineering notation, grouped by kind
    assert re.search(r"inductors \(1\):\n\s+L1\s+sw out\s+47 µH\s+IC=0 A", out)
    assert re.search(r"Rload\s+out 0\s+2.5 Ω", out)
    # sources with waveforms, switches with control and thresholds, diodes
    assert "PULSE(v1=1 V, v2=0 V, td=0 s, tr=10 ns, tf=10 ns, pw=2.083 µs, per=10 µs)" in out
    assert re.search(r"Xhi\.S1\s+in sw\s+control v\(gh,0\)\s+model SWIDEAL: on when v > "
                     r"VT=500 mV ± VH=100 mV", out)
    assert re.search(r"Xlo\.D1\s+0 -> sw\s+model DIDEAL", out)
    # initial conditions, analysis, options, ignored commands
    assert "i(L1) = 0 A" in out and "v(Cout) = 0 V" in out
    assert "analysis: .tran step 20 ns, stop 200 µs, start 0 s, max step 20 ns, UIC" in out
    assert "options: reltol=1e-4 method=gear" in out
    assert "line 22: .save v(out) i(L1)" in out
    assert "line 23: .control  ... (4 lines)" in out


def test_info_shows_ic_lines_and_other_elements(capsys):
    status, out, _ = run(capsys, "info", str(HERE / "cuk_coupled.cir"))
    assert status == 0
    assert "v(out) = 0 V" in out and "v(b) = 0 V" in out
    assert re.search(r"K12\s+L1 L2\s+k=0.6", out)
    assert re.search(r"HMON\s+mon 0\s+0.1 Ω\s+× i\(VIN\)", out)
    assert "initially OFF" in out
    assert "line 28: .plot tran v(out)" in out


def test_info_with_param_override(capsys):
    status, out, _ = run(capsys, "info", str(HERE / "interleaved_boost.cir"),
                         "--param", "lph=47u", "--param", "FS=100k")
    assert status == 0
    assert re.search(r"X1\.L1\s+x1\.a x1\.sw\s+47 µH", out)
    assert "parameters: vin=48, fs=100k, duty=0.5, lph=47u" in out


def test_info_bad_param_syntax_is_an_input_error(capsys):
    status, out, err = run(capsys, "info", str(HERE / "buck_sync.cir"), "--param", "duty")
    assert status == 2 and out == ""
    assert "error: bad parameter override 'duty': expected NAME=VALUE" in err
    assert "Traceback" not in err


def test_info_unknown_param_override(capsys):
    status, _, err = run(capsys, "info", str(HERE / "buck_sync.cir"), "--param", "nope=1")
    assert status == 2
    assert "unknown parameter 'nope' in the overrides" in err


def test_info_on_a_bad_file(capsys, tmp_path):
    bad = tmp_path / "bad.cir"
    bad.write_text("bad netlist\nV1 a 0 1\nR1 a 0 1k\nJ1 a g 0 NJF\nL1 a 0 {2*lx}\n")
    status, out, err = run(capsys, "info", str(bad))
    assert status == 2 and out == ""
    assert f"{bad}:4:1: error: unknown element type 'J' (JFET)" in err
    assert "    J1 a g 0 NJF\n    ^\n" in err
    assert "hint: pelcs simulates ideal elements" in err
    assert "Traceback" not in err


def test_info_reports_several_problems(capsys, tmp_path):
    bad = tmp_path / "bad.cir"
    bad.write_text("two problems\nV1 a 0 1\nR1 a 0 {rx}\nC1 a 0 -1u\n")
    status, _, err = run(capsys, "info", str(bad))
    assert status == 2
    assert re.search(r"bad\.cir:3:9: error: unknown parameter 'rx'", err)
    assert re.search(r"bad\.cir:4:8: error: C1: capacitance must be positive", err)


@pytest.mark.parametrize(
    "content, message",
    [(b"", "empty netlist"),
     (b"\x00\x01\x02garbage\xff\xfe", "NUL bytes"),
     (b"\xff\xfe\xfa binary \x80\x81", "not UTF-8"),
     (b"   \n\n  \n", "empty netlist")],
    ids=["empty", "binary", "non-utf8", "blank"],
)
def test_info_on_garbage_exits_2_without_traceback(capsys, tmp_path, content, message):
    p = tmp_path / "garbage.cir"
    p.write_bytes(content)
    status, out, err = run(capsys, "info", str(p))
    assert status == 2 and out == ""
    assert f"{p}:1:" in err and message in err
    assert "Traceback" not in err


def test_info_on_missing_file_and_directory(capsys, tmp_path):
    status, _, err = run(capsys, "info", str(tmp_path / "missing.cir"))
    assert status == 2 and "file not found" in err
    status, _, err = run(capsys, "info", str(tmp_path))
    assert status == 2 and "is a directory" in err
