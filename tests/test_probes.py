"""The probe syntax (:mod:`netlist.probes`), read once for the formulation, the check of a
run's probes and the ngspice runner."""

from __future__ import annotations

import pytest

from netlist.probes import PROBE, probe_unit


@pytest.mark.parametrize("text, groups", [
    ("v(out)", ("v", "out", None)),
    (" V( a , b ) ", ("V", "a", "b")),
    ("i(R1)", ("i", "R1", None)),
    ("I(x1.L1)", ("I", "x1.L1", None)),
])
def test_probe_syntax(text, groups):
    assert PROBE.match(text).groups() == groups


@pytest.mark.parametrize("text", ["v()", "v(a,b,c)", "x(a)", "v(a", "d(S1)", "v(a)b"])
def test_not_a_probe(text):
    assert PROBE.match(text) is None


def test_probe_unit():
    assert probe_unit("v(out)") == "V" and probe_unit(" I(L1)") == "A"
    assert probe_unit("d(S1)") == "" and probe_unit("mean(v(out))") == ""
