"""Files written whole or not at all (lcs.atomic.atomic_path), write errors reported after the
summary, and the limits on inputs (netlist.limits): each a clear error, exit 2, no traceback."""

from __future__ import annotations

import errno
import os
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lcs.atomic import atomic_path
from lcs.results import SimulationResult, SimulationStats
from pelcs.outputs import write_outputs
from pelcs.writers import write_csv, write_npz, write_parquet

# (the slow part of the suite: outside the fast subset that `-m 'not slow'` selects)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
BOOST = ROOT / "converters" / "netlists" / "boost.cir"


def _result(n: int = 1000) -> SimulationResult:
    t = np.linspace(0.0, 1e-3, n)
    y = np.column_stack([np.sin(1e4 * t), np.cos(1e4 * t)])
    return SimulationResult(t=t, names=("v(out)", "i(L1)"), y=y, x_final=y[-1],
                            lambda_final=np.zeros(0), modes_visited=[()], events=[],
                            stats=SimulationStats(), notes=["a note"], error=None)


def _leftovers(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if ".part" in p.name)


def test_atomic_path_replaces_on_success_only(tmp_path):
    target = tmp_path / "run.csv"
    target.write_text("good\n")
    os.chmod(target, 0o640)
    with atomic_path(target) as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".csv" and tmp != target
        tmp.write_text("new\n")
        assert target.read_text() == "good\n"  # untouched until complete
    assert target.read_text() == "new\n"
    assert stat.S_IMODE(target.stat().st_mode) == 0o640  # the earlier file's permissions
    for exc in (OSError(errno.ENOSPC, "No space left on device"), KeyboardInterrupt()):
        with pytest.raises(type(exc)):
            with atomic_path(target) as tmp:
                tmp.write_text("trunc")
                raise exc
        assert target.read_text() == "new\n"
        assert _leftovers(tmp_path) == []


def test_atomic_path_devices_and_links(tmp_path):
    # a device is written in place (a rename would replace /dev/null itself)
    with atomic_path("/dev/null") as tmp:
        assert str(tmp) == "/dev/null"
    real = tmp_path / "real.txt"
    real.write_text("old")
    link = tmp_path / "link.txt"
    link.symlink_to(real)
    with atomic_path(link) as tmp:
        tmp.write_text("new")
    assert link.is_symlink() and real.read_text() == "new"


@pytest.mark.parametrize("suffix, writer", [(".csv", write_csv), (".npz", write_npz),
                                            (".parquet", write_parquet)])
def test_full_disk_keeps_the_earlier_file(tmp_path, monkeypatch, suffix, writer):
    target = tmp_path / f"run{suffix}"
    writer(_result(), target)
    before = target.read_bytes()
    real_fsync = os.fsync

    def full(fd):  # the disk fills up: the data cannot be flushed
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(os, "fsync", full)
    with pytest.raises(OSError):
        writer(_result(5000), target)
    monkeypatch.setattr(os, "fsync", real_fsync)
    assert target.read_bytes() == before
    assert _leftovers(tmp_path) == []


def test_dev_full_is_an_error_that_says_so(tmp_path):
    written = write_outputs("simulate", [(Path("/dev/full"), lambda p: write_csv(_result(), p)),
                                         (tmp_path / "ok.csv",
                                          lambda p: write_csv(_result(), p))])
    assert written == [str(tmp_path / "ok.csv")]  # the other file is still written
    (err,) = written.failed
    text = err.format()
    assert "cannot write /dev/full" in text and "disk is full" in text
    assert written.exit_status() == 2


def _cli(*args: str, env: dict | None = None, timeout: float = 60, cwd=None):
    return subprocess.run([sys.executable, "-m", "pelcs.cli", *args], capture_output=True,
                          text=True, timeout=timeout, cwd=cwd,
                          env={**os.environ, "PYTHONPATH": str(ROOT), **(env or {})})


def test_include_of_a_device_a_pipe_or_too_large(tmp_path):
    (tmp_path / "zero.cir").write_text("title\n.include /dev/zero\nR1 a 0 1\n.end\n")
    fifo = tmp_path / "fifo.inc"
    os.mkfifo(fifo)
    (tmp_path / "fifo.cir").write_text(f"title\n.include {fifo}\nR1 a 0 1\n.end\n")
    for name in ("zero.cir", "fifo.cir"):
        r = _cli("info", str(tmp_path / name), timeout=20)
        assert r.returncode == 2 and "Traceback" not in r.stderr
        assert "is not a regular file" in r.stderr and ":2:10:" in r.stderr
    (tmp_path / "big.inc").write_text("* " + "x" * 5000 + "\nR1 a 0 1\n")
    (tmp_path / "big.cir").write_text("title\n.include big.inc\nV1 a 0 1\n.end\n")
    r = _cli("info", str(tmp_path / "big.cir"), env={"PELCS_MAX_FILE_BYTES": "1k"})
    assert r.returncode == 2 and "larger than 1000 bytes" in r.stderr
    assert "PELCS_MAX_FILE_BYTES" in r.stderr
    assert _cli("info", str(tmp_path / "big.cir")).returncode == 0


def _blow_up(levels: int) -> str:
    lines = ["binary tree of subcircuits", ".subckt s0 a b", "R1 a b 1", ".ends"]
    for i in range(1, levels + 1):
        lines += [f".subckt s{i} a b", f"X1 a m s{i - 1}", f"X2 m b s{i - 1}", ".ends"]
    return "\n".join([*lines, "V1 in 0 1", f"X0 in 0 s{levels}", ".end", ""])


def test_subcircuit_expansion_limit(tmp_path):
    path = tmp_path / "blow.cir"
    path.write_text(_blow_up(25))  # 2^25 resistors: counted, not expanded
    r = _cli("info", str(path), timeout=30)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "expands to more than 100000 elements" in r.stderr
    assert "3.35544e+07 in all" in r.stderr and "PELCS_MAX_ELEMENTS" in r.stderr
    assert "no elements" not in r.stderr
    path.write_text(_blow_up(6))
    assert _cli("info", str(path), env={"PELCS_MAX_ELEMENTS": "100"}).returncode == 0
    r = _cli("info", str(path), env={"PELCS_MAX_ELEMENTS": "50"})
    assert r.returncode == 2 and "more than 50 elements" in r.stderr


def test_steps_and_memory_limits(tmp_path):
    # refused before anything is allocated or compiled: a femtosecond step over 5 ms
    r = _cli("simulate", str(BOOST), "--step", "1e-15", timeout=30)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "5e+12 time steps" in r.stderr and "PELCS_MAX_STEPS" in r.stderr
    r = _cli("simulate", str(BOOST), "--step", "1n", "--probe", "v(out)",
             env={"PELCS_MAX_MEMORY": "1M"}, timeout=30)
    assert r.returncode == 2 and "5e+06 points of 1 probe (" in r.stderr
    assert "PELCS_MAX_MEMORY" in r.stderr and "--every" in r.stderr
    r = _cli("simulate", str(BOOST), env={"PELCS_MAX_STEPS": "lots"}, timeout=30)
    assert r.returncode == 2 and "PELCS_MAX_STEPS='lots' is not a positive number" in r.stderr


def test_singular_network_too_large_for_its_dense_decomposition(tmp_path):
    # 4096 resistors beside a bridge with no source (node a only between diodes): the network
    # is singular, and its SVD (cubic)
    # took 100 s a mode; refused above PELCS_MAX_DENSE_UNKNOWNS (found by the fuzzer)
    path = tmp_path / "floating.cir"
    bridge = "D1 a p DX\nD3 n a DX\nD2 0 p DX\nD4 n 0 DX\nC1 p n 1u\n.model DX D\n.end\n"
    path.write_text(_blow_up(12).replace(".end\n", bridge))
    r = _cli("lcs", str(path), timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "singular or ill-conditioned" in r.stderr and "PELCS_MAX_DENSE_UNKNOWNS" in r.stderr
    assert r.stderr.startswith(f"{path}: error:")


def test_simulate_on_a_full_disk_prints_its_summary_then_the_error(tmp_path):
    plot = tmp_path / "boost.png"
    full = tmp_path / "full.csv"
    full.symlink_to("/dev/full")  # (every write to it fails with ENOSPC)
    r = _cli("simulate", str(BOOST), "--tstop", "0.2m", "-o", str(full), "--plot", str(plot),
             "--no-progress", timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "simulated 0 to 200 µs" in r.stdout  # the summary first
    assert f"wrote {plot}" in r.stdout and plot.stat().st_size > 0  # the other file written
    assert f"cannot write {full}: No space left on device" in r.stderr
    assert "disk is full" in r.stderr


def test_recursion_and_unknown_subcircuits_deep_in_a_tree(tmp_path):
    # found by the fuzzer: the expansion met a recursive (or an unknown) subcircuit at each
    # of the 2^22 leaves of a tree, reporting it every time (minutes); now counted first
    path = tmp_path / "tree.cir"
    text = _blow_up(22)
    path.write_text(text.replace("R1 a b 1", "X9 a b s3"))  # s0 -> ... -> s3 -> s0
    r = _cli("info", str(path), timeout=30)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert r.stderr.count("instantiates itself") == 1
    assert "s0 -> s3 -> s2 -> s1 -> s0" in r.stderr or "instantiates itself (s" in r.stderr
    path.write_text(text.replace("R1 a b 1", "X9 a b nowhere"))
    r = _cli("info", str(path), timeout=30)
    assert r.returncode == 2 and "expands to more than 100000 elements" in r.stderr
