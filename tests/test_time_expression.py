"""A B source whose expression is a smooth function of ``time`` alone, read as the independent
source of that waveform (netlist.time_expression), compared with ngspice 39 point by point."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.circuit import CurrentSource, VoltageSource
from netlist.parser import parse_string
from netlist.writer import write_circuit
from tests.netlist_asserts import refused_at

DECK = """b of time
.param f=1k amp=5
B1 n1 0 V=amp*sin(2*pi*f*time) + 0.5*cos(2*pi*3*f*time)
R1 n1 0 1
B2 n2 0 V=1k*time
R2 n2 0 1
B3 0 n3 I=2m*exp(-time/200u)*(-2)^2
R3 n3 0 1k
B4 n4 0 V=pwr(sin(2*pi*f*time), 3)
R4 n4 a 100
C4 a 0 1u
.tran 1u 2m
.end
"""
PROBES = ["v(n1)", "v(n2)", "v(n3)", "v(a)"]


def _ngspice(tmp_path, deck: str) -> np.ndarray:
    data = ngspice_wrdata(deck, PROBES, tmp_path, before=["set numdgt=15"])
    return np.column_stack([data[:, 0], data[:, 1::2]])


def test_the_sources_and_their_values():
    c = parse_string(DECK)
    b1, b2, b3 = (c.element(n) for n in ("B1", "B2", "B3"))
    assert isinstance(b1, VoltageSource) and isinstance(b3, CurrentSource)
    assert b1.dc == pytest.approx(0.5)
    t = np.array([0.1e-3, 0.25e-3])
    assert b1.waveform(t) == pytest.approx(5 * np.sin(2 * np.pi * 1e3 * t)
                                           + 0.5 * np.cos(2 * np.pi * 3e3 * t), rel=1e-14)
    assert b2.waveform(t) == pytest.approx(1e3 * t, rel=1e-15)
    # ngspice's B-source power: (-2)^2 = |-2|^2 = 4
    assert b3.waveform(0.0) == pytest.approx(8e-3)
    assert b1.waveform.top_frequency() == pytest.approx(3e3)
    assert b2.waveform.top_frequency() is None


def test_against_ngspice(tmp_path, ngspice):
    from pelcs.api import simulate

    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    ng = _ngspice(tmp_path, DECK)
    c = parse_string(DECK)
    # the waveforms at ngspice's own instants: within 2.5e-14 V (B3: its current into 1k)
    for k, (name, scale) in enumerate((("B1", 1.0), ("B2", 1.0), ("B3", 1e3))):
        err = np.abs(scale * c.element(name).waveform(ng[:, 0]) - ng[:, k + 1]).max()
        assert err <= 1e-12, (name, err)
    # a run, ngspice's rows (1 us apart) interpolated onto pelcs's: 1e-5 V measured
    res = simulate(DECK, probes=PROBES)
    for k in range(4):
        want = np.interp(res.t, ng[:, 0], ng[:, k + 1])
        assert np.abs(res.y[:, k] - want).max() < 5e-5, PROBES[k]


def test_the_writer_writes_a_b_line_back():
    c = parse_string(DECK)
    text = write_circuit(c)
    assert "B1 n1 0 V=" in text and "B3 0 n3 I=" in text
    again = parse_string(text)
    t = np.linspace(0, 2e-3, 7)
    for name in ("B1", "B2", "B3", "B4"):
        assert again.element(name).waveform(t) == pytest.approx(c.element(name).waveform(t),
                                                                rel=1e-12, abs=1e-15)


def test_the_step_resolves_its_frequency():
    from pelcs.api import simulate

    res = simulate(DECK.replace(".tran 1u 2m", ".tran 10u 2m"), probes=["v(n1)"])
    assert res.t[1] == pytest.approx(1 / 3e3 / 100)
    assert any("1/100" in n for n in res.notes), res.notes


@pytest.mark.parametrize(("expr", "part"), [
    ("abs(sin(time))", "abs(sin(time))"), ("time > 1m ? sin(time) : 0", "time > 1m ?"),
    ("u(time-1m)*time", "u(time-1m)")])
def test_a_function_of_time_that_is_not_smooth_is_refused(expr, part):
    refused_at(f"t\nB1 n1 0 V={expr}\nR1 n1 0 1\n.tran 1u 2m\n.end\n", (2, 11),
               [part, "not smooth in time"])
