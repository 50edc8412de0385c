"""The CLI's cache of generated code (pelcs.code_cache): classes made with it are the classes
``dataclasses`` makes without it, the kernels' argument checks answer as without it, a second
run compiles nothing, and a damaged cache is rebuilt."""

from __future__ import annotations

import dataclasses
import marshal
import re
from dataclasses import dataclass, field

import pytest

from lcs.build import kernels
from pelcs import code_cache
from pelcs.code_cache import cached_code


def _make():
    """A few dataclasses of the kinds pelcs defines (frozen, ordered, slots, defaults)."""

    @dataclass(frozen=True)
    class Point:
        x: float
        y: float = 0.0
        tags: tuple[str, ...] = field(default_factory=tuple)

    @dataclass(order=True)
    class Version:
        major: int
        minor: int = 0

    @dataclass(slots=True, eq=False)
    class Raw:
        name: str
        items: list = field(default_factory=list)

    return Point, Version, Raw


def _behaviour(Point, Version, Raw) -> list:
    p = Point(1.0, tags=("a",))
    out = [repr(p), p == Point(1.0, 0.0, ("a",)), hash(p) == hash(Point(1.0, 0.0, ("a",))),
           Version(1, 2) < Version(1, 3), sorted([Version(2), Version(1, 5)]),
           repr(Raw("r")), Raw("r") == Raw("r"), Point.__match_args__,
           [f.name for f in dataclasses.fields(Point)], Point.__init__.__annotations__,
           Version.__eq__.__qualname__, Raw.__init__.__defaults__]
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.x = 2.0
    with pytest.raises(TypeError):
        Point()
    return [repr(o) for o in out]


def _codes(*classes) -> list[bytes]:
    return [getattr(c, m).__code__.co_code for c in classes
            for m in ("__init__", "__repr__", "__eq__", "__setattr__", "__hash__", "__lt__")
            if getattr(getattr(c, m, None), "__code__", None) is not None]


def test_classes_are_those_dataclasses_makes(tmp_path, monkeypatch):
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    plain = _make()
    with cached_code() as first:
        compiled = _make()
    with cached_code() as second:
        cached = _make()
    assert first.loaded == 0 and first.compiled >= 10
    assert second.loaded >= 10 and second.compiled == 0  # all from the cache
    assert "exec" not in vars(dataclasses)  # (restored after each block)
    assert _behaviour(*plain) == _behaviour(*compiled) == _behaviour(*cached)
    assert _codes(*plain) == _codes(*compiled) == _codes(*cached)


@pytest.mark.parametrize("garbage", [b"", b"not marshal data", b"\x00" * 100],
                         ids=["empty", "text", "zeros"])
def test_a_damaged_cache_is_rebuilt(tmp_path, monkeypatch, garbage):
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    path = code_cache.cache_path()
    path.write_bytes(garbage)
    with cached_code() as use:
        classes = _make()
    assert use.loaded == 0 and use.compiled >= 10
    assert _behaviour(*classes) == _behaviour(*_make())
    with cached_code() as use:
        _make()
    assert use.compiled == 0
    assert [f.name for f in tmp_path.iterdir()] == [path.name]  # no temporary file left


def test_the_cli_leaves_dataclasses_as_it_found_them(tmp_path, monkeypatch, capsys):
    from pelcs.cli import main

    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    with pytest.raises(SystemExit):
        main(["--version"])
    assert "exec" not in vars(dataclasses) and "exec" not in vars(kernels)


def test_the_kernels_argument_checks_come_from_the_cache(tmp_path, monkeypatch):
    # The check of a kernel's arguments, generated as source: compiled once, then served
    # from the cache, answering the same either way.
    import numpy as np

    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    specs = [["array", "float64", 2, "C", True], ["int"], ["bool"], ["float"]]
    monkeypatch.setattr(kernels, "_aot_types", lambda: {"k": specs})
    good = [np.zeros((2, 2)), 3, True, 0.5]
    bad = [[np.zeros((2, 2)).T, 3, True, 0.5], [np.zeros(2), 3, True, 0.5],
           [np.zeros((2, 2), dtype=np.float32), 3, True, 0.5], [np.zeros((2, 2)), 3.5, True, 0.5],
           [np.zeros((2, 2)), 3, True]]
    answers = []
    for _ in range(2):
        kernels._checker.cache_clear()
        with cached_code() as use:
            check = kernels._checker("k")
        answers.append([check(good)] + [check(b) for b in bad])
        compiled = use.compiled
    kernels._checker.cache_clear()
    plain = kernels._checker("k")
    kernels._checker.cache_clear()
    assert compiled == 0  # the second block compiled nothing
    assert answers[0] == answers[1] == [plain(good)] + [plain(b) for b in bad] \
        == [True] + [False] * len(bad)


_PATTERNS = [(r"(?P<name>[a-z_]\w*)\s*=\s*(?P<value>[^\s]+)", 0), (r"^\.tran\b", re.I | re.M),
             (rb"\x00+(?P<tail>.)", 0), (r"[\u00b5u]?(?:meg|mil|[fpnumkgt])", re.I),
             (r"(a)(b)?(?:c|d)*?", re.S | re.X)]


def _fresh(pattern, flags):
    """The pattern compiled by re itself, past re's own per-process cache."""
    re.purge()
    return re.compile(pattern, flags)


def test_regular_expressions_are_those_re_compiles(tmp_path, monkeypatch):
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    plain = [_fresh(p, f) for p, f in _PATTERNS]
    with cached_code() as first:
        compiled = [_fresh(p, f) for p, f in _PATTERNS]
    with cached_code() as second:
        cached = [_fresh(p, f) for p, f in _PATTERNS]
    assert first.compiled >= len(_PATTERNS) and second.compiled == 0  # all from the cache
    for a, b, c in zip(plain, compiled, cached, strict=True):
        # (Pattern.__eq__ compares the flags, the pattern and the compiled program)
        assert a == b == c
        assert a.groups == b.groups == c.groups and a.groupindex == b.groupindex == c.groupindex
    text = "x_1 = 4.7k  .TRAN 1u\n\u00b5meg abdd"
    for a, c in zip(plain, cached, strict=True):
        if isinstance(a.pattern, str):
            assert [m.groupdict() or m.groups() for m in a.finditer(text)] == \
                [m.groupdict() or m.groups() for m in c.finditer(text)]
    re.purge()


def test_a_locale_pattern_is_left_to_re(tmp_path, monkeypatch):
    # (its program depends on the locale at compile time: never taken from the cache)
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    with cached_code() as use:
        _fresh(rb"\w+", re.L)
        _fresh(rb"(?L)\w+", 0)
    assert use.compiled == 0
    re.purge()


def test_each_subcommand_keeps_a_cache_of_its_own(tmp_path, monkeypatch, capsys):
    # (a start reads only what its own command compiled: the whole file is read every time)
    import pelcs.cli
    from pelcs.cli import main

    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    assert code_cache.cache_path("simulate") != code_cache.cache_path("sweep") \
        != code_cache.cache_path()
    with cached_code("simulate") as use:
        _make()
    assert use.compiled and code_cache.cache_path("simulate").is_file()
    assert not code_cache.cache_path().is_file() and not code_cache.cache_path("sweep").is_file()
    # The CLI names the subcommand it runs, and only a known one.
    named = []

    def recording(command=""):
        named.append(command)
        return cached_code(command)

    monkeypatch.setattr(pelcs.cli, "cached_code", recording)
    deck = tmp_path / "rc.cir"
    deck.write_text("rc\nV1 in 0 PULSE(0 5 0 1u 1u 0.5m 1m)\nR1 in out 1k\nD1 out c DMOD\n"
                    "C1 c 0 1u\n.model DMOD D\n.tran 10u 1m\n.end\n")
    assert main(["simulate", str(deck), "--no-progress", "-o", str(tmp_path / "rc.csv")]) == 0
    with pytest.raises(SystemExit):
        main(["simulat", str(deck)])
    assert named == ["simulate", ""]


def test_a_program_the_engine_refuses_is_compiled_again(tmp_path, monkeypatch):
    # A cache file that unmarshals but holds a program this Python's engine rejects
    # ("invalid SRE code"): re compiles the pattern, and the entry is made anew.
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    pattern = r"(?P<n>ab+)c"
    with cached_code():
        _fresh(pattern, 0)
    path = code_cache.cache_path()
    version, cache = marshal.loads(path.read_bytes())
    key = next(k for k in cache if isinstance(k, tuple) and k[2] == pattern)
    flags, _, groups, groupindex, indexgroup = cache[key]
    cache[key] = (flags, [1, 2, 3], groups, groupindex, indexgroup)
    path.write_bytes(marshal.dumps((version, cache)))
    with cached_code() as use:
        compiled = _fresh(pattern, 0)
    assert compiled == _fresh(pattern, 0) and compiled.match("abbc").group("n") == "abb"
    assert use.compiled == 1
    with cached_code() as use:
        _fresh(pattern, 0)
    assert use.compiled == 0
    re.purge()
