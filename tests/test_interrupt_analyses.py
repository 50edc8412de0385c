"""Interrupts of the analyses made of many runs (sweep, bifurcation, basins): the first
SIGINT drops the runs under way, writes the finished ones with a note saying how many of how
many were done, and exits 130 (the worker processes ignore SIGINT: the parent alone answers
it)."""

from __future__ import annotations

import csv
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import as_from_a_terminal
from terminal_run import Interrupted, interrupt_on_progress

# (the slow part of the suite: outside the fast subset that `-m 'not slow'` selects)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
BUCK = ROOT / "converters" / "netlists" / "buck.cir"


def _run_and_interrupt(args: list[str], enough: int) -> tuple[Interrupted, str, str, float]:
    """Run ``pelcs ARGS`` as from a terminal and send SIGINT once its progress bar counts
    ``enough`` units; (the run, stdout, stderr, s from the signal to the exit).

    ``enough`` is more than the units two workers can show without finishing a task (twice
    a task's size), so some task has finished and most have not. A task's result can still be
    on its way when the count is reached: where nothing had finished, the command is run
    again with a larger count, up to four times."""
    for _ in range(4):
        run = interrupt_on_progress(args, lambda done, total, enough=enough: done >= enough)
        done = re.search(r"interrupted \(SIGINT\) after (\d+) of", run.err)
        assert done is not None, run.err
        if int(done.group(1)) > 0:
            return run, run.out, run.err, run.seconds_to_exit
        enough = int(enough * 1.5) + 1
    raise AssertionError(f"no count interrupted {args} after its first task")


def _says_interrupted(out: str, err: str, note: str) -> None:
    """The command's summary has ``note`` as a note, and stderr says it and where the
    finished points were written."""
    assert f"note: {note}" in out
    assert note in err and "written to" in err


def test_interrupted_sweep_writes_the_finished_runs(tmp_path):
    # 24 runs of 1.5 million steps (0.2-1 s each) in 8 tasks of 3 on 2 processes
    out_csv = tmp_path / "duty.csv"
    run, out, err, answer = _run_and_interrupt(
        ["sweep", str(BUCK), "--param", "duty=0.2:0.8:24", "--measure", "mean(v(out))",
         "--tstop", "300m", "--workers", "2", "-o", str(out_csv)], enough=7)
    assert run.returncode == 130, err
    assert "Traceback" not in err
    assert answer < 5, answer  # the pool is stopped at once (its workers terminated)
    with open(out_csv, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert 0 < len(rows) < 24
    assert len(rows) % 3 == 0  # whole tasks only
    for row in rows:
        # the finished runs are whole: duty * 24 V (ideal buck in CCM), settled
        assert row["ok"] == "1"
        assert abs(float(row["mean(v(out))"]) - 24 * float(row["duty"])) < 0.2
    _says_interrupted(out, err, f"the sweep was interrupted (SIGINT) after {len(rows)} of 24 runs")


def test_interrupted_bifurcation_writes_the_finished_values(tmp_path):
    # 24 values of 25000 periods of 100 steps (about 1 s each) in 8 tasks of 3 on 2 processes
    out_csv = tmp_path / "d.csv"
    run, out, err, answer = _run_and_interrupt(
        ["bifurcation", str(BUCK), "--period", "ts", "--param", "duty=0.2:0.8:24",
         "--transient", "25000", "--record", "2", "--probe", "v(out)", "--workers", "2",
         "-o", str(out_csv)], enough=7)
    assert run.returncode == 130, err
    assert "Traceback" not in err
    assert answer < 5, answer
    with open(out_csv, newline="") as fh:
        rows = list(csv.DictReader(fh))
    duties = sorted({float(r["duty"]) for r in rows})
    assert 0 < len(duties) < 24 and len(duties) % 3 == 0 and len(rows) == 2 * len(duties)
    for row in rows:  # settled period-1 samples: v(out) near duty * 24 V
        assert abs(float(row["v(out)"]) - 24 * float(row["duty"])) < 0.3
    _says_interrupted(out, err, f"the diagram was interrupted (SIGINT) after {len(duties)} of "
                      "24 parameter values")
    assert f"duty: {len(duties)} values" in out


def test_cells_whose_chain_reaches_a_cell_not_computed_are_unknown():
    import numpy as np

    from lcs.analysis.basins import _unknown_cells, simple_cell_mapping

    # 0 -> 1 -> 2 -> sink; 3 -> 4 -> 3 (a cycle); 5 -> 3; 6 -> 7 (7 not computed: its image
    # is the sink placeholder); 8 -> 6; 9 -> sink
    image = np.array([1, 2, -1, 4, 3, 3, 7, -1, 6, -1])
    computed = np.ones(10, dtype=bool)
    computed[7] = False
    unknown = _unknown_cells(simple_cell_mapping(image), image, computed)
    assert np.flatnonzero(unknown).tolist() == [6, 7, 8]


def test_interrupted_basins_write_the_computed_cells(tmp_path):
    import numpy as np

    # 1600 cells of one period of 40000 steps in 16 blocks of 100 (about 1.5 s each) on
    # 2 processes
    npz = tmp_path / "b.npz"
    run, out, err, answer = _run_and_interrupt(
        ["basins", str(BUCK), "--period", "ts", "--grid", "v(C1)=0:24:40,i(L1)=0:24:40",
         "--step", "0.5n", "--workers", "2", "-o", str(npz), "--plot",
         str(tmp_path / "b.png")], enough=220)
    assert run.returncode == 130, err
    assert "Traceback" not in err
    assert answer < 20, answer  # (the plot: matplotlib's import)
    z = np.load(npz)
    computed, group, image = z["computed"].ravel(), z["group"].ravel(), z["image"].ravel()
    k = int(computed.sum())
    assert 0 < k < 1600 and k % 100 == 0  # whole blocks
    assert (group[~computed] == -1).all()
    # every decided cell's chain runs through computed cells only, to an attractor or out
    for cell in np.flatnonzero(group >= 0):
        c, seen = cell, set()
        while c != -1 and c not in seen:
            assert computed[c]
            seen.add(c)
            c = image[c]
    assert (tmp_path / "b.png").stat().st_size > 0
    _says_interrupted(out, err, f"the basins were interrupted (SIGINT) after {k} of 1600 cells")


def test_interrupted_monte_carlo_keeps_the_statistics_of_the_finished_runs(tmp_path):
    # a Monte Carlo table is grid point by grid point, --runs rows each: the runs not made
    # are rows "not run" (NaN), left out of the statistics
    out_csv = tmp_path / "mc.csv"
    run, out, err, _ = _run_and_interrupt(
        ["sweep", str(BUCK), "--tolerance", "R1=5%", "--runs", "20", "--seed", "1",
         "--measure", "mean(v(out))", "--tstop", "300m", "--workers", "2",
         "-o", str(out_csv)], enough=7)
    assert run.returncode == 130, err
    with open(out_csv, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["run"]) for r in rows] == list(range(20))
    done = [r for r in rows if r["ok"] == "1"]
    assert 0 < len(done) <= 20
    assert all(r["message"] == "not run: the sweep was interrupted" for r in rows
               if r["ok"] != "1")
    for r in done:  # the duty cycle sets v(out) = 12 V whatever R1 (CCM)
        assert abs(float(r["mean(v(out))"]) - 12) < 0.05
    # (21 runs: 20 drawn and the nominal one, made last)
    assert f"after {len(done)} of 21 runs" in err
    stats = next(line for line in out.splitlines() if line.startswith("mean(v(out))"))
    assert stats.split()[1] == "nan"  # the nominal run was not made


def test_interrupted_check_says_nothing_was_compared(ngspice, tmp_path):
    import pytest

    for signum, delay in ((signal.SIGINT, 3.0), (signal.SIGTERM, 5.0)):
        proc = subprocess.Popen(
            [sys.executable, "-m", "pelcs.cli", "check", str(ROOT / "converters" / "netlists"
                                                             / "boost.cir"),
             "--tstop", "1", "--report", str(tmp_path / "report")],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
            env={**os.environ, "PYTHONPATH": str(ROOT)},
                            preexec_fn=as_from_a_terminal)
        time.sleep(delay)
        if proc.poll() is not None:
            pytest.fail(f"the check ended before the signal: {proc.communicate()}")
        t_signal = time.perf_counter()
        proc.send_signal(signum)
        out, err = proc.communicate(timeout=30)
        assert proc.returncode == 130, err
        assert time.perf_counter() - t_signal < 2  # the ngspice worker killed, not awaited
        assert "Traceback" not in err
        assert "interrupted during the ngspice and pelcs runs: nothing was compared and no " \
            "report was written" in err
        assert not (tmp_path / "report").exists()


def _task_that_interrupts(task, report):
    # task 2 sends SIGINT to the process that runs the engine (its parent from a pool
    # worker, which ignores the signal itself); later tasks would take long
    k, parent = task
    if k == 2:
        time.sleep(0.3)  # (the results of tasks 0 and 1 reach the parent first)
        os.kill(parent, signal.SIGINT)
    time.sleep(0.05 if k <= 2 else 5.0)
    return k * k


def test_task_engine_keeps_the_finished_tasks():
    tasks = [(k, os.getpid()) for k in range(6)]
    # (Python's own SIGINT handler, as a terminal leaves it: the tests may run with SIGINT
    # ignored, and pelcs leaves an ignored SIGINT ignored)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        _engine_runs(tasks)
    finally:
        signal.signal(signal.SIGINT, before)


def _engine_runs(tasks):
    from lcs import interrupt
    from lcs.analysis.parallel import task_engine

    for workers in (1, 2):
        with interrupt.deferred_interrupts(), task_engine(workers=workers) as engine:
            t = time.perf_counter()
            got = engine.run(_task_that_interrupts, tasks, partial=True)
            assert interrupt.requested() == signal.SIGINT
        assert time.perf_counter() - t < 3  # the long tasks were dropped, not awaited
        assert got[:2] == [0, 1] and got[3:] == [None] * 3
        # (in this process, the task under way when the signal came is dropped: it may have
        # been cut short; in a pool worker it runs on and may have finished)
        assert got[2] == (None if workers == 1 else got[2]) and got[2] in (None, 4)
