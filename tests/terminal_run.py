"""A pelcs command run as from a terminal and interrupted once its progress bar says enough is
done: the tests of interrupts signal on progress instead of after a fixed sleep (which had to
cover a loaded machine's start-up, so the command's processes computed for seconds more)."""

from __future__ import annotations

import fcntl
import os
import pty
import re
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
    """What the interrupted command did: its exit code, stdout, stderr (the terminal's text,
    progress bar included, lines ending in CR LF), the seconds from the signal to its exit,
    and the progress count shown when the signal was sent."""

    returncode: int
    out: str
    err: str
    answer: float
    count: int


def interrupt_on_progress(args: list[str], ready: Callable[[int, int], bool],
                          signum: int = signal.SIGINT, timeout: float = 120.0) -> Interrupted:
    """Run ``pelcs ARGS`` with stderr on a pseudo-terminal of 100 columns (so its progress
    bar is drawn) and send ``signum`` once ``ready(done, total)`` holds for the bar's count.

    Fails when the command ends before (a progress bar that never said enough)."""
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    proc = subprocess.Popen([sys.executable, "-m", "pelcs.cli", *args],
                            stdout=subprocess.PIPE, stderr=slave, stdin=subprocess.DEVNULL,
                            text=True, env={**os.environ, "PYTHONPATH": str(ROOT)},
                            preexec_fn=as_from_a_terminal)
    os.close(slave)
    chunks: list[bytes] = []

    def drain() -> None:  # (until the child's end of the terminal is closed: EIO)
        while True:
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
    try:
        while proc.poll() is None:
            counts = _COUNT.findall(b"".join(chunks[-4:]))
            if counts:
                done, done_unit, total, total_unit = counts[-1]
                count = round(float(done) * _SCALE[done_unit])
                if ready(count, round(float(total) * _SCALE[total_unit])):
                    break
            if time.monotonic() > deadline:
                raise AssertionError(f"no progress enough to interrupt {args} in {timeout} s")
            time.sleep(0.01)
        else:
            raise AssertionError(f"{args} ended before its progress was enough (last count "
                                 f"{count}): {b''.join(chunks).decode(errors='replace')}")
        t_signal = time.perf_counter()
        proc.send_signal(signum)
        proc.wait(timeout=60)
        answer = time.perf_counter() - t_signal
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        out_reader.join(timeout=10)
        reader.join(timeout=10)
        os.close(master)
    return Interrupted(proc.returncode, "".join(stdout),
                       b"".join(chunks).decode(errors="replace"), answer, count)
