"""The files a command writes, each whole or not at all, and what it says when one fails.

Every writer goes through :func:`lcs.atomic.atomic_path`, so a write that fails (a full
disk, a folder that is not writable) or is interrupted leaves no partial file and an earlier
file of the same name as it was. A command writes its files, prints its summary, then reports
the files that could not be written (exit status 2) with :meth:`Written.exit_status`: the
results of a long run are not hidden behind a full disk.
"""

from __future__ import annotations

import errno
import sys
from collections.abc import Callable, Iterable
from pathlib import Path

from netlist.errors import Diagnostic, NetlistError

__all__ = ["EXIT_INTERRUPTED", "EXIT_NOT_WRITTEN", "Written", "interrupted_status",
           "write_outputs"]

#: Exit status of a command whose output files could not all be written (the CLI's status of
#: errors the user fixes: a path, a permission, disk space).
EXIT_NOT_WRITTEN = 2

#: Exit status of an interrupted command (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130


def interrupted_status(file: str, notes: Iterable[str], prefix: str, written: Written,
                       not_written: int) -> int | None:
    """After the files of a command made of many runs are written: if a SIGINT or SIGTERM
    came (:func:`lcs.interrupt.requested`), say so on stderr (the note starting with
    ``prefix``, which tells how many runs finished, and where they were written) and return
    :data:`EXIT_INTERRUPTED`; else None."""
    from lcs import interrupt

    signum = interrupt.requested()
    if signum is None:
        return None
    # (no such note: the signal came after the runs, while the files were written, and
    # they were completed)
    what = next((n for n in notes if n.startswith(prefix)),
                f"interrupted ({interrupt.signal_name(signum)}) after the runs")
    where = (f"written to {', '.join(written)}" if written else
             "no output file written" if not_written else
             "no output file was requested (-o, --plot)")
    print(f"{file}: {what}\n  {where}", file=sys.stderr)
    return EXIT_INTERRUPTED


class Written(list):
    """The paths written (a list of str), and in :attr:`failed` the errors of those that
    could not be."""

    def __init__(self, command: str):
        super().__init__()
        self.command = command
        self.failed: list[NetlistError] = []

    def exit_status(self) -> int:
        """Print the write errors on stderr; :data:`EXIT_NOT_WRITTEN` if there were any,
        else 0."""
        for exc in self.failed:
            print(exc.format(), file=sys.stderr)
        return EXIT_NOT_WRITTEN if self.failed else 0


def write_outputs(command: str, targets: Iterable[tuple[Path | None, Callable[[Path], object]]]
                  ) -> Written:
    """Write each ``(path, writer)`` whose path is given (``writer(path)`` writes one file,
    through :func:`~lcs.atomic.atomic_path`), making its folder; an OSError is kept in
    ``failed`` and the next file is written.

    Parameters
    ----------
    command : str
        Subcommand name for the error messages.
    targets : iterable of (Path or None, callable)

    Returns
    -------
    Written
        The paths written, and the errors.
    """
    written = Written(command)
    for path, write in targets:
        if path is None:
            continue
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            write(path)
        except OSError as exc:
            written.failed.append(_write_error(command, path, exc))
            continue
        written.append(str(path))
    return written


def _write_error(command: str, path: Path, exc: OSError) -> NetlistError:
    if exc.errno in (errno.ENOSPC, errno.EDQUOT):
        hint = "the disk is full (or over quota): free some space or write elsewhere"
    else:
        hint = "check the folder and its permissions"
    hint += "; an earlier file of that name is left as it was"
    return NetlistError(Diagnostic(message=f"cannot write {path}: {exc.strerror or exc}",
                                   hint=hint), file=f"pelcs {command}")


def interrupt_message(command: str, points: str) -> str:
    """What the first Ctrl-C (or SIGTERM) of a command made of many runs prints: ``points``
    names what is kept ("runs", "parameter values", "cells")."""
    return (f"pelcs {command}: interrupted: the runs under way are dropped and the finished "
            f"{points} are written (Ctrl-C again aborts at once, writing nothing)")
