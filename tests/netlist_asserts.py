"""Assertions on how pelcs refuses a netlist, shared by the tests of several readers."""

from __future__ import annotations

from collections.abc import Iterable

import pytest

from netlist.errors import NetlistError
from netlist.parser import parse_string


def refused_at(deck: str, where: tuple[int, int], words: Iterable[str]) -> str:
    """The error text of ``parse_string(deck)``, which must refuse it, naming the place
    ``<string>:LINE:COLUMN`` (``where``) and holding each of ``words``."""
    with pytest.raises(NetlistError) as exc:
        parse_string(deck)
    text = str(exc.value)
    for w in words:
        assert w in text, text
    line, col = where
    assert f"<string>:{line}:{col}:" in text, text
    return text
