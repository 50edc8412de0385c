"""What a command compiles from source text at every start, compiled once per machine for the CLI.

Three kinds of it are compiled on each start of a command:

- for every dataclass, ``dataclasses`` writes the source of ``__init__``, ``__repr__``,
  ``__eq__`` (and for a frozen one ``__hash__``, ``__setattr__``, ``__delattr__``) and
  compiles it with ``exec``: some 220 small functions when ``pelcs simulate`` starts, 15-20 %
  of the CPU time of a 100-step command (Python's parser and compiler, not running code);
- :mod:`lcs.build.kernels` writes the argument check of each ahead-of-time kernel a run
  calls (one expression over its hundred-odd arguments), 7 ms of compiling;
- ``re`` compiles the regular expressions of the netlist reader, lark's lexer, numpy and the
  standard library into programs for its engine, 13 ms.

While :func:`cached_code` is active, the ``exec`` that the first two call takes the code
object compiled from the same source text, and ``re`` the program of the same pattern and
flags, from a cache kept in ``$PELCS_CACHE_DIR`` (else ``pelcs/__pycache__``, one file per
subcommand) by an earlier run: the functions and patterns are those that compiling would
give, without compiling.

The cache is only a speed-up: it is keyed by the exact source text or pattern, for this
Python, its regular expression engine and its ``-O`` only, and a missing, unreadable or
foreign file is ignored (the run compiles, and writes a new one). Only the CLI uses it, for
the duration of a command.
"""

from __future__ import annotations

import builtins
import marshal
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

#: A cache holding more entries (dataclass definitions and patterns that changed over time,
#: or a command's rarer paths) starts anew with the entries of the run that finds it so: the
#: whole file is read at every start (1,000 entries, some 1.5 MB: 8-18 ms).
MAX_ENTRIES = 1000


class CacheUse:
    """What a command did with the cache: ``loaded`` entries, ``compiled`` new ones (code
    objects and regular expressions' programs)."""

    def __init__(self, loaded: int) -> None:
        self.loaded = loaded
        self.compiled = 0


def cache_path(command: str = "") -> Path | None:
    """The cache file of ``command`` (a subcommand's name, or "" for none: each reads only
    what its own runs compiled) for this Python, or None when its directory is not
    writable."""
    root = Path(os.environ.get("PELCS_CACHE_DIR") or Path(__file__).with_name("__pycache__"))
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    if not os.access(root, os.W_OK):
        return None
    name = "".join(c for c in command if c.isalnum() or c in "-_")
    return root / f"code-cache.{name + '.' if name else ''}{sys.implementation.cache_tag}"


def _version() -> tuple:
    """What the cached code depends on besides its source: the interpreter, its regular
    expression engine, and ``-O`` (which drops asserts from compiled code)."""
    import _sre

    return (sys.version, _sre.MAGIC, sys.flags.optimize)


def _load(path: Path | None) -> dict:
    if path is None:
        return {}
    try:
        version, cache = marshal.loads(path.read_bytes())
    except (OSError, ValueError, EOFError, TypeError):
        return {}  # missing, or not a cache of this format
    if version != _version() or not isinstance(cache, dict):
        return {}
    return cache


def _save(path: Path, cache: dict) -> None:
    from lcs.atomic import atomic_path

    try:
        with atomic_path(path) as tmp:  # (whole or not at all, also for a concurrent reader)
            tmp.write_bytes(marshal.dumps((_version(), cache)))
    except (OSError, ValueError):
        pass  # not cached: compiled again by the next command


def _regex_entry(module, pattern: str | bytes, flags: int) -> tuple | None:
    """What ``_sre.compile`` takes after the pattern, computed as re's compiler ``module``
    computes it (its parse and its code); None where it cannot be told (a Python whose
    compiler differs) or depends on the locale."""
    import re
    import warnings

    parser = getattr(module, "_parser", None) or getattr(module, "sre_parse", None)
    try:
        with warnings.catch_warnings():  # (re's own parse of the pattern gave them)
            warnings.simplefilter("ignore")
            parsed = parser.parse(pattern, flags)
        # (plain ints: the compiler's opcodes are an int subclass, which marshal refuses)
        code = [int(word) for word in module._code(parsed, flags)]
        groupindex = {name: int(index) for name, index in parsed.state.groupdict.items()}
        indexgroup = [None] * parsed.state.groups
        for name, index in groupindex.items():
            indexgroup[index] = name
        entry = (int(flags | parsed.state.flags), code, parsed.state.groups - 1, groupindex,
                 tuple(indexgroup))
    except (AttributeError, TypeError, ValueError, re.error):
        return None
    if entry[0] & re.LOCALE:
        return None
    try:
        marshal.dumps(entry)
    except ValueError:  # (an object of this Python's compiler that the cache cannot keep)
        return None
    return entry


@contextmanager
def cached_code(command: str = "") -> Iterator[CacheUse]:
    """Within the block, the code that ``dataclasses`` and :mod:`lcs.build.kernels` generate,
    and the programs of the regular expressions compiled, come from the cache where it has
    their source text; new ones are compiled and the cache written when the block ends.

    A regular expression's program (what ``re`` compiles a pattern to: 13 ms for the
    hundred-odd patterns of the netlist reader, lark's lexer, numpy and the standard library
    at a start) is kept only when the pattern compiled from it equals the one ``re``
    compiled (``Pattern.__eq__`` compares the programs), so a Python whose compiler differs
    is served by ``re`` itself.

    Each ``command`` (the CLI's subcommand) has a file of its own, so that a start reads what
    that command compiled, not what every other one did."""
    import _sre
    import dataclasses
    import re

    from lcs.build import kernels

    compiler = getattr(re, "_compiler", None) or getattr(re, "sre_compile", None)
    users = [m for m in (dataclasses, kernels) if "exec" not in vars(m)]
    if len(users) < 2 or compiler is None:  # (already active: nested, or another tool's)
        yield CacheUse(0)
        return
    path = cache_path(command)
    if path is None:  # (nowhere to keep it: compiling twice to check a program would be waste)
        yield CacheUse(0)
        return
    cache = _load(path)
    use = CacheUse(len(cache))
    used: dict = {}

    def cached_exec(source, globals=None, locals=None, /):
        if type(source) is str:  # (marshal keeps no subclass of str)
            code = cache.get(source)
            if code is None:
                # What exec(source) compiles: file name "<string>", and no __future__ flag
                # of the caller (dataclasses has none; the kernels' checks hold no
                # annotation, the only thing their module's flag would change).
                code = cache[source] = compile(source, "<string>", "exec", dont_inherit=True)
                use.compiled += 1
            used[source] = code
            source = code
        return builtins.exec(source, globals, locals)

    re_compile = compiler.compile

    def cached_re_compile(pattern, flags=0):
        # (exactly str or bytes: marshal keeps no subclass; the type in the key keeps "a"
        # and b"a", equal hashes, from being compared)
        if type(pattern) not in (str, bytes) or flags & re.DEBUG:
            return re_compile(pattern, flags)
        key = ("re", type(pattern) is bytes, pattern, int(flags))
        entry = cache.get(key)
        if entry is not None:
            try:
                compiled = _sre.compile(pattern, *entry)
            except (TypeError, ValueError, RuntimeError):  # (RuntimeError: invalid SRE code)
                del cache[key]  # not this Python's program: compiled by re below
            else:
                used[key] = entry
                return compiled
        compiled = re_compile(pattern, flags)
        entry = _regex_entry(compiler, pattern, int(flags))
        if entry is not None:
            try:
                candidate = _sre.compile(pattern, *entry)
            except (TypeError, ValueError, RuntimeError):
                candidate = None
            # (Pattern.__eq__ compares flags, pattern and program, not the group names)
            if (candidate == compiled and candidate.groups == compiled.groups
                    and candidate.groupindex == compiled.groupindex):
                cache[key] = used[key] = entry
                use.compiled += 1
        return compiled

    for module in users:
        module.exec = cached_exec
    compiler.compile = cached_re_compile
    try:
        yield use
    finally:
        for module in users:
            del module.exec
        compiler.compile = re_compile
        if use.compiled:
            _save(path, cache if len(cache) <= MAX_ENTRIES else used)
