"""The CLI's cache of dataclasses' compiled methods (pelcs.dataclass_code): classes made with
it are the classes ``dataclasses`` makes without it, a second run compiles nothing, and a
damaged cache is rebuilt."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import pytest

from pelcs import dataclass_code
from pelcs.dataclass_code import cached_dataclass_code


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
    with cached_dataclass_code() as first:
        compiled = _make()
    with cached_dataclass_code() as second:
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
    path = dataclass_code.cache_path()
    path.write_bytes(garbage)
    with cached_dataclass_code() as use:
        classes = _make()
    assert use.loaded == 0 and use.compiled >= 10
    assert _behaviour(*classes) == _behaviour(*_make())
    with cached_dataclass_code() as use:
        _make()
    assert use.compiled == 0
    assert [f.name for f in tmp_path.iterdir()] == [path.name]  # no temporary file left


def test_the_cli_leaves_dataclasses_as_it_found_them(tmp_path, monkeypatch, capsys):
    from pelcs.cli import main

    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    with pytest.raises(SystemExit):
        main(["--version"])
    assert "exec" not in vars(dataclasses)
