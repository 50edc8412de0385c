"""A part of a circuit that only diodes join to the rest (a bridge rectifier's floating
source, a three-phase star point behind a miswired bridge): while they all block, no equation
sets its potential, and pelcs says so in a note (netlist.free_potential). The physics is
checked in ngspice: a leakage of 1 GOhm from the source to ground, or to the output instead,
leaves the output as it is and moves the source's potential across the whole window in which
the diodes block (the output voltage less the source's)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.parser import parse_string

BRIDGE = """bridge rectifier, floating source
V1 a b SIN(0 10 50)
D1 a out dm
D2 b out dm
D3 0 a dm
D4 0 b dm
C1 out 0 100u
R1 out 0 1k
.model dm D
.tran 20u 60m
.end
"""


def _notes(text):
    return [n for n in parse_string(text).notes if "only the diode" in n]


def test_the_floating_source_is_noted():
    (note,) = _notes(BRIDGE)
    assert note.startswith("a, b: only the diodes D1, D2, D3, D4 join these nodes")
    assert "(the voltages between these nodes are determined)" in note


@pytest.mark.parametrize("extra", [
    "Rg b 0 1meg",  # a resistor holds the part
    "Ig 0 b DC 0",  # a current source joins it to the rest (no claim)
    "E1 e 0 a 0 1\nRe e 0 1k",  # its potential is read outside
    "S1 x 0 a 0 sm\nRx x 0 1\n.model sm SW(VT=1)",  # a switch control reads it
])
def test_no_note_where_the_potential_is_held_or_matters(extra):
    assert _notes(BRIDGE.replace(".model dm D", f".model dm D\n{extra}")) == []


def test_a_dead_end_node():
    notes = _notes(BRIDGE.replace("R1 out 0 1k", "R1 out 0 1k\nD5 out z dm"))
    assert any(n.startswith("z: only the diode D5 joins this node") for n in notes)


def test_ngspice_leaves_the_potential_to_the_leakage(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    runs = []
    for to in ("0", "out"):
        deck = tmp_path / f"leak_{to}.cir"
        deck.write_text(BRIDGE.replace(".model dm D", f".model dm D\nRleak a {to} 1G"))
        runs.append(ngspice_wrdata(deck, ["v(a)", "v(out)", "v(a,b)"], tmp_path, timeout=60,
                                   before=["linearize"]))
    t, va_low, vout, vab = runs[0][:, [0, 1, 3, 5]].T
    va_high, vout_high = runs[1][:, 1], runs[1][:, 3]
    late = t > 0.03
    # the output does not notice where the leakage sits ...
    assert abs(np.mean(vout[late]) - np.mean(vout_high[late])) < 0.01
    # ... while the source's potential goes from the bottom of the window in which all the
    # diodes block to its top: a span of about v(out) - |v(a,b)|
    blocked = late & (np.abs(vab) < 0.8 * np.mean(vout[late]))
    window = vout[blocked] - np.abs(vab[blocked])
    assert blocked.sum() > 10
    assert np.median((va_high[blocked] - va_low[blocked]) / window) > 0.8


@pytest.mark.filterwarnings("ignore::lcs.notices.IdealisedDeviceWarning")
def test_the_three_phase_star_point_is_noted():
    from pathlib import Path

    from netlist.parser import parse_file

    path = (Path(__file__).parent / "corpus" / "pess" / "simulations" / "rectifiers" /
            "3Phase" / "rectifier_3P.cir")
    notes = [n for n in parse_file(path).notes if "only the diode" in n]
    star = next(n for n in notes if ", n," in n or n.startswith("n,"))
    assert "XD3" in star and "XD4" in star and "XD6" in star
