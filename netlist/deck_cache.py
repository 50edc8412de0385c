"""Reading a netlist once for many runs: its deck kept by content.

Reading (splitting, the LALR parse of every statement) does not depend on the ``.param``
values; evaluating does (:func:`netlist.flatten.build_circuit`). A design script that
simulates the same netlist with other parameter values therefore needs the
:class:`~netlist.rawdeck.Deck` once: :func:`cached_deck` keeps the decks of the last
:data:`MAX_DECKS` netlists (fewer long ones: :data:`MAX_CHARS`), keyed by the exact text of
the top-level netlist (with its file name and the working directory that relative includes
start from), and hands one back only when every file it included still holds the bytes it
was read from. A file edited on disk is therefore read again, whatever its modification time
says (the caller reads the top-level file's text every time).

A deck with problems is not kept (the error is raised as without the cache), and a deck is
never changed by evaluation, so one deck serves any number of circuits.
"""

from __future__ import annotations

import os
import stat
import threading
from collections import OrderedDict
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from .flatten import independent_problems
from .rawdeck import Deck
from .reader import _Reader

__all__ = ["MAX_CHARS", "MAX_DECKS", "cached_deck", "clear"]

#: decks kept (least recently used dropped first) ...
MAX_DECKS = 32
#: ... and the characters of their texts, together (the newest always kept)
MAX_CHARS = 16_000_000


@dataclass(frozen=True)
class _Entry:
    deck: Deck
    included: tuple[tuple[str, bytes], ...]  # (display path, the bytes read)


_DECKS: OrderedDict[tuple, _Entry] = OrderedDict()
_LOCK = threading.Lock()


def cached_deck(text: str, file: str, path: str | Path | None,
                params: Mapping[str, float] | None) -> Deck:
    """The deck of netlist ``text``, read now or kept from an earlier call.

    Parameters
    ----------
    text : str
        The top-level netlist, decoded (its first line is the title).
    file : str
        Its name as the user gave it (messages, and the directory relative includes start
        from), ``"<string>"`` for text.
    path : str or Path, optional
        The file (resolved when it is read, for include cycles), None for text.
    params : mapping, optional
        The overrides of this run: they only complete the report of a netlist with syntax
        problems (:meth:`netlist.reader._Reader.raise_problems`).

    Returns
    -------
    Deck
        Shared between calls: to be evaluated, never changed.

    Raises
    ------
    NetlistError
        Every problem of the netlist, as :func:`netlist.parser.parse_file` raises it.
    """
    # (the working directory: relative includes, and a relative ``file``, start there)
    key = (file, os.getcwd(), path is None, text)
    with _LOCK:
        entry = _DECKS.get(key)
    if entry is not None and all(_unchanged(p, data) for p, data in entry.included):
        with _LOCK:
            if key in _DECKS:
                _DECKS.move_to_end(key)
        return entry.deck
    reader = _Reader(file)
    reader.read_top(text, file, None if path is None else _resolved(Path(path)))
    reader.raise_problems(dict(params or {}), independent_problems)
    with _LOCK:
        _DECKS[key] = _Entry(reader.deck, tuple(reader.included))
        _DECKS.move_to_end(key)
        while len(_DECKS) > 1 and (len(_DECKS) > MAX_DECKS or sum(
                len(k[3]) for k in _DECKS) > MAX_CHARS):
            _DECKS.popitem(last=False)
    return reader.deck


def clear() -> None:
    """Forget every kept deck."""
    with _LOCK:
        _DECKS.clear()


def _resolved(path: Path) -> Path:
    try:
        return path.resolve()
    except (OSError, RuntimeError):
        return path


def _unchanged(display: str, data: bytes) -> bool:
    """Whether the file still holds ``data`` (a file gone, or no longer a regular file, has
    changed: reading it again gives the error)."""
    try:
        if not stat.S_ISREG(os.stat(display).st_mode):
            return False
        with open(display, "rb") as fh:
            return fh.read(len(data) + 1) == data
    except OSError:
        return False
