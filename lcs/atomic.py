"""Files written whole or not at all: every file pelcs writes goes through :func:`atomic_path`.

A result file is written under a temporary name in its own folder and renamed over the
target once complete (``os.replace``, atomic on POSIX file systems). A write that fails (a
full disk) or is interrupted (Ctrl-C) removes the temporary file and leaves the target as it
was: an earlier good file is never destroyed, and no truncated file looks like a result.

The result files are written by the application (``pelcs.writers``); this primitive stays at
the bottom layer because ``ngspice_checks`` and the netlist parser's cache, which may not
import ``pelcs``, write through it too.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

__all__ = ["atomic_path"]


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path to write ``path``'s new content to; renamed onto ``path`` when the
    ``with`` block completes, removed when it raises (any exception, KeyboardInterrupt
    included, which is then re-raised).

    The temporary name is in the same folder (so that the rename does not copy), hidden, and
    ends with the target's suffix (matplotlib and numpy choose the format by it). It is
    created empty with the permissions a new file would get (umask applied) or, when the
    target exists, the target's. A target that is not a regular file (``/dev/null``,
    ``/dev/full``, a pipe) is written in place; a symbolic link is followed (its target is
    replaced, not the link).

    Parameters
    ----------
    path : str or os.PathLike
        The file to write.

    Yields
    ------
    Path
        Where to write; flushed to disk (``fsync``) before the rename so that a full disk is
        an error here rather than a short file later.

    Examples
    --------
    >>> with atomic_path("out/run.csv") as tmp:            # doctest: +SKIP
    ...     tmp.write_text("time,v(out)\\n")
    """
    target = Path(os.path.realpath(path))
    try:
        st = os.stat(target)
    except FileNotFoundError:
        mode = 0o666
    else:
        if not stat.S_ISREG(st.st_mode):
            yield Path(path)  # a device or a pipe: nothing to replace
            return
        mode = stat.S_IMODE(st.st_mode)
    while True:
        tmp = target.with_name(f".{target.name}.{os.urandom(4).hex()}.part{target.suffix}")
        try:
            fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, mode)
        except FileExistsError:  # pragma: no cover - 32 random bits
            continue
        break
    try:
        if mode != 0o666:
            os.fchmod(fd, mode)  # the existing file's permissions, whatever the umask
    finally:
        os.close(fd)
    try:
        yield tmp
        fd = os.open(tmp, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, target)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
