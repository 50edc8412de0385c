"""Interrupts that stop a run and keep what it computed.

Inside :func:`deferred_interrupts`, once a run has results to keep (it calls
:func:`keeping` when its stepping starts), the first SIGINT (Ctrl-C) or SIGTERM only records a
request: the run checks :func:`requested` between chunks of steps (a compiled kernel cannot be
stopped inside a call) and stops there with the results computed so far, as a failed run does
(:class:`~lcs.results.SimulationError` of kind ``"interrupted"``). A second signal, or a first
one before there is anything to keep (parsing, planning), raises KeyboardInterrupt at once.
Outside the context, and in threads other than the main one, signals behave as Python's
defaults (KeyboardInterrupt at the first Ctrl-C).
"""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["deferred_interrupts", "keeping", "requested", "signal_name"]

_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# The pending request (a signal number), or None; set by the handler, read by runs.
_pending: list[int] = []
_active: list[bool] = []
_keeping: list[bool] = []


def keeping() -> None:
    """A run has results worth keeping from now on: inside :func:`deferred_interrupts`, the
    first signal becomes a stop request instead of a KeyboardInterrupt."""
    if _active and not _keeping:
        _keeping.append(True)


def requested() -> int | None:
    """The signal number of a pending stop request, or None."""
    return _pending[-1] if _pending else None


def signal_name(signum: int) -> str:
    """``"SIGINT"``, ``"SIGTERM"``..."""
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


@contextmanager
def deferred_interrupts(message: str = "") -> Iterator[None]:
    """Within the block, the first SIGINT or SIGTERM is a stop request (module docstring) and
    the second raises KeyboardInterrupt.

    Parameters
    ----------
    message : str
        Written to stderr at the first signal (e.g. what happens now and how to abort).
    """
    if threading.current_thread() is not threading.main_thread() or _active:
        yield
        return

    def handler(signum, frame):
        if _pending or not _keeping:
            raise KeyboardInterrupt
        _pending.append(signum)
        if message:
            # os.write: a handler may run in the middle of a print to stderr
            os.write(2, (message.rstrip("\n") + "\n").encode())

    # A signal the process was started ignoring stays ignored (as Python itself leaves an
    # ignored SIGINT alone): a job started in the background by a non-interactive shell must
    # not start answering the terminal's Ctrl-C.
    previous = {s: signal.signal(s, handler) for s in _SIGNALS
                if signal.getsignal(s) is not signal.SIG_IGN}
    _active.append(True)
    try:
        yield
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
        _pending.clear()
        _active.clear()
        _keeping.clear()
