"""The methods Python's ``dataclasses`` generates, compiled once per machine for the CLI.

For every dataclass, ``dataclasses`` writes the source of ``__init__``, ``__repr__``,
``__eq__`` (and for a frozen one ``__hash__``, ``__setattr__``, ``__delattr__``) and compiles
it with ``exec``: some 220 small functions when ``pelcs simulate`` starts, 15-20 % of the CPU
time of a 100-step command (Python's parser and compiler, not running code). While
:func:`cached_dataclass_code` is active, the ``exec`` that ``dataclasses`` calls takes the code
object compiled from the same source text from a cache kept in ``$PELCS_CACHE_DIR`` (else
``pelcs/__pycache__``) by an earlier run, so the functions are those ``exec`` would compile
from that text, without compiling it.

The cache is only a speed-up: it holds code objects keyed by their exact source text, for
this Python version only, and a missing, unreadable or foreign file is ignored (the run
compiles, and writes a new one). Only the CLI uses it, for the duration of a command.
"""

from __future__ import annotations

import builtins
import marshal
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import CodeType

#: A cache holding more entries (dataclass definitions that changed over time) starts anew
#: with the entries of the run that finds it so.
MAX_ENTRIES = 2000


class CacheUse:
    """What a command did with the cache: ``loaded`` entries, ``compiled`` sources."""

    def __init__(self, loaded: int) -> None:
        self.loaded = loaded
        self.compiled = 0


def cache_path() -> Path | None:
    """The cache file for this Python, or None when its directory is not writable."""
    root = Path(os.environ.get("PELCS_CACHE_DIR") or Path(__file__).with_name("__pycache__"))
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    if not os.access(root, os.W_OK):
        return None
    return root / f"dataclass-code.{sys.implementation.cache_tag}"


def _load(path: Path | None) -> dict[str, CodeType]:
    if path is None:
        return {}
    try:
        version, cache = marshal.loads(path.read_bytes())
    except (OSError, ValueError, EOFError, TypeError):
        return {}  # missing, or not a cache of this format
    if version != sys.version or not isinstance(cache, dict):
        return {}
    return cache


def _save(path: Path, cache: dict[str, CodeType]) -> None:
    from lcs.atomic import atomic_path

    try:
        with atomic_path(path) as tmp:  # (whole or not at all, also for a concurrent reader)
            tmp.write_bytes(marshal.dumps((sys.version, cache)))
    except (OSError, ValueError):
        pass  # not cached: compiled again by the next command


@contextmanager
def cached_dataclass_code() -> Iterator[CacheUse]:
    """Within the block, dataclasses' generated methods come from the cache where it has
    their source text; new ones are compiled and the cache written when the block ends."""
    import dataclasses

    if "exec" in vars(dataclasses):  # (already active: nested, or another tool's)
        yield CacheUse(0)
        return
    path = cache_path()
    cache = _load(path)
    use = CacheUse(len(cache))
    used: dict[str, CodeType] = {}

    def cached_exec(source, globals=None, locals=None, /):
        if isinstance(source, str):
            code = cache.get(source)
            if code is None:
                # What exec(source) compiles: file name "<string>", and no __future__ flag
                # of the caller (dataclasses.py has none).
                code = cache[source] = compile(source, "<string>", "exec", dont_inherit=True)
                use.compiled += 1
            used[source] = code
            source = code
        return builtins.exec(source, globals, locals)

    dataclasses.exec = cached_exec
    try:
        yield use
    finally:
        del dataclasses.exec
        if use.compiled and path is not None:
            _save(path, cache if len(cache) <= MAX_ENTRIES else used)
