"""Interrupts: the first SIGINT/SIGTERM of a run stops it between kernel calls and keeps the
results (files written, a note, exit 130); a second aborts at once (a KeyboardInterrupt: a
file being written is then removed and an earlier one kept, tests/test_atomic_outputs.py)."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import as_from_a_terminal
from terminal_run import interrupt_on_progress

from lcs import interrupt

# (the slow part of the suite: outside the fast subset that `-m 'not slow'` selects)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
BOOST = ROOT / "converters" / "netlists" / "boost.cir"
# s of the boost at h = 2 ns: 250 million steps (50 s at the best 0.2 µs a step), stopped
# after a few seconds; the planning before the stepping grows with TSTOP (1-4 s here)
TSTOP = 0.5


def test_deferred_interrupts_request_then_abort():
    # (CI may start the tests with SIGINT ignored, as a shell starts a background job, and an
    # ignored SIGINT stays ignored: see the next test; here Python's own handler is set)
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        got = []
        with interrupt.deferred_interrupts():
            with pytest.raises(KeyboardInterrupt):  # nothing to keep yet: abort at once
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(1)
            interrupt.keeping()
            assert interrupt.requested() is None
            os.kill(os.getpid(), signal.SIGTERM)
            got.append(interrupt.requested())  # recorded, nothing raised
            with pytest.raises(KeyboardInterrupt):
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(1)  # (the handler runs at the next bytecode)
        assert got == [signal.SIGTERM]
        assert interrupt.requested() is None  # cleared on leaving
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, before)


def test_a_signal_ignored_on_entry_stays_ignored():
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with interrupt.deferred_interrupts():
            assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.2)
            assert interrupt.requested() is None
            assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL  # still deferred
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, before)


def _interrupt(proc: subprocess.Popen, signum: int, delay: float = 6.0):
    # the stepping under way: it starts after 1-4 s (imports, planning), and a signal
    # before it aborts (nothing to keep yet)
    time.sleep(delay)
    assert proc.poll() is None, proc.communicate()
    t_signal = time.perf_counter()
    proc.send_signal(signum)
    out, err = proc.communicate(timeout=20)
    return out, err, time.perf_counter() - t_signal


@pytest.mark.parametrize("signum, plot", [(signal.SIGINT, True), (signal.SIGTERM, False)])
def test_interrupted_run_writes_what_it_computed(tmp_path, signum, plot):
    # signalled from 2 % of the steps on (its progress bar, on a terminal): mid-stepping
    run = interrupt_on_progress(
        ["simulate", str(BOOST), "--tstop", str(TSTOP), "--step", "2n", "--every", "10000",
         "-o", str(tmp_path / "boost.csv"),
         *(["--plot", str(tmp_path / "boost.png")] if plot else [])],
        lambda done, total: done >= 0.02 * total, signum=signum)
    out, err, answer = run.out, run.err, run.seconds_to_exit
    assert run.returncode == 130, err
    assert "Traceback" not in err
    # the run stopped at its next kernel call (17 ms of steps), then wrote the files: 0.6 s
    # measured without the plot, whose matplotlib import alone took 7 s on a loaded machine
    assert answer < (30 if plot else 10)
    with open(tmp_path / "boost.csv", newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["time", "i(L1)", "v(C1)"]
    times = [float(r[0]) for r in rows[1:]]
    assert len(times) > 10 and 0 < times[-1] < TSTOP
    assert times == sorted(times)
    assert not plot or (tmp_path / "boost.png").stat().st_size > 0
    name = signal.Signals(signum).name
    assert f"interrupted ({name}) at t = " in err
    assert "note: the run was interrupted at t = " in out
    assert "written to" in err and "boost.csv" in err


def test_interrupted_exact_run_keeps_the_stretches_it_followed(tmp_path):
    # 1 s of the buck, event by event (minutes): the signal comes while it follows the flow
    out_csv = tmp_path / "buck.csv"
    proc = subprocess.Popen(
        [sys.executable, "-m", "pelcs.cli", "simulate", str(ROOT / "converters" / "netlists" /
                                                            "buck.cir"),
         "--method", "exact", "--tstop", "1", "-o", str(out_csv)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env={**os.environ, "PYTHONPATH": str(ROOT)}, preexec_fn=as_from_a_terminal)
    out, err, answer = _interrupt(proc, signal.SIGINT, delay=5.0)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert answer < 30  # (the stretches followed are written out point by point)
    with open(out_csv, newline="") as fh:
        rows = list(csv.reader(fh))
    times = [float(r[0]) for r in rows[1:]]
    assert len(times) > 100 and 0 < times[-1] < 1.0
    assert times == sorted(times)
    assert "interrupted (SIGINT) at t = " in err
    assert "note: the run was interrupted at t = " in out
