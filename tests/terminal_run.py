"""A pelcs command run as from a terminal and interrupted once its progress bar says enough is
done: the tests of interrupts signal on progress, neither too early (nothing done yet) nor
after the whole run."""

from __future__ import annotations

import contextlib
import fcntl
import os
import pty
import re
import select
import signal
import struct
import subprocess
import sys
import termios
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from conftest import as_from_a_terminal

ROOT = Path(__file__).resolve().parents[1]

# tqdm's count, "12/24" or with unit_scale "1.25M/5.00M" (the last one drawn is the latest)
_COUNT = re.compile(rb"([\d.]+)([kMG]?)/([\d.]+)([kMG]?) \[")
_SCALE = {b"": 1, b"k": 1e3, b"M": 1e6, b"G": 1e9}


@dataclass
class Interrupted:
    """What the interrupted command did.

    Attributes
    ----------
    returncode : int
        Its exit code.
    out : str
        Its stdout.
    err : str
        Its stderr: the terminal's text, progress bar included, lines ending in CR LF.
    seconds_to_exit : float
        From the signal to its exit, s.
    count : int
        The progress count shown when the signal was sent.
    """

    returncode: int
    out: str
    err: str
    seconds_to_exit: float
    count: int


def interrupt_on_progress(args: list[str], ready: Callable[[int, int], bool],
                          signum: int = signal.SIGINT, timeout: float = 120.0) -> Interrupted:
    """Run ``pelcs ARGS`` with stderr on a pseudo-terminal of 100 columns (so its progress
    bar is drawn) and send ``signum`` once ``ready(done, total)`` holds for the bar's count.

    Parameters
    ----------
    args : list of str
        The command line after ``pelcs``.
    ready : callable
        ``ready(done, total)``, units of the bar, True when the signal is to be sent.
    signum : int
        The signal.
    timeout : float
        Seconds to wait for ``ready``, s.

    Returns
    -------
    Interrupted

    Fails when the command ends before its count is ready, or it is not ready in time. The
    command runs in a session of its own, so that whatever is left of it (its pool's
    workers) is killed with it."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "pelcs.cli", *args],
                            stdout=subprocess.PIPE, stderr=slave, stdin=subprocess.DEVNULL,
                            text=True, env={**os.environ, "PYTHONPATH": str(ROOT)},
                            preexec_fn=as_from_a_terminal, start_new_session=True)
    os.close(slave)
    chunks: list[bytes] = []
    stop = threading.Event()

    def drain() -> None:  # (until the terminal's other end is closed, EIO, or told to stop)
        while not stop.is_set():
            if not select.select([master], [], [], 0.05)[0]:
                continue
            try:
                chunk = os.read(master, 65536)
            except OSError:
                return
            if not chunk:
                return
            chunks.append(chunk)

    reader = threading.Thread(target=drain, daemon=True)
    reader.start()
    stdout: list[str] = []
    out_reader = threading.Thread(target=lambda: stdout.append(proc.stdout.read()), daemon=True)
    out_reader.start()
    deadline = time.monotonic() + timeout
    count = -1
    failure = None
    try:
        while proc.poll() is None:
            counts = _COUNT.findall(b"".join(chunks[-4:]))
            if counts:
                done, done_unit, total, total_unit = counts[-1]
                count = round(float(done) * _SCALE[done_unit])
                if ready(count, round(float(total) * _SCALE[total_unit])):
                    break
            if time.monotonic() > deadline:
                failure = f"no progress enough to interrupt {args} in {timeout} s"
                break
            time.sleep(0.01)
        else:
            failure = f"{args} ended before its progress was enough (last count {count})"
        seconds = float("nan")
        if failure is None:
            t_signal = time.perf_counter()
            proc.send_signal(signum)
            proc.wait(timeout=60)
            seconds = time.perf_counter() - t_signal
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)  # (its pool's workers, if any are left)
        out_reader.join(timeout=10)
        reader.join(timeout=10)
        stop.set()
        reader.join()
        os.close(master)
    err = b"".join(chunks).decode(errors="replace")
    if failure is not None:
        raise AssertionError(f"{failure}: {err}")
    return Interrupted(proc.returncode, "".join(stdout), err, seconds, count)
