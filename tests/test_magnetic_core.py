"""ngspice's XSPICE magnetic core and its lcouple windings (netlist.magnetic_core): the
inductances from the B-H table by hand, the winding senses from the loop, the run side by
side with ngspice (as written, and the deck pelcs writes back), the field checked against
the table's straight segment, and the refusals with their place."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.circuit import Vcvs
from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit

# 100 and 50 turns on a core of 1 cm² and 10 cm whose B-H table is straight (1.2 mT per A/m)
# within 1000 A/m of zero; the secondary's mmf port is in the loop the other way round
CORE = """transformer on an XSPICE core
V1 a 0 SIN(0 10 1k)
R1 a in 10
R2 out 0 100
a1 (in 0) (m1 0) prim
a2 (out 0) (m2 0) sec
a3 (m1 m2) iron
.model prim lcouple(num_turns=100)
.model sec lcouple(num_turns=50)
.model iron core(H_array=[-2000 -1000 0 1000 2000] B_array=[-1.6 -1.2 0 1.2 1.6]
+ area=1e-4 length=0.1)
.tran 1u 4m
.end
"""


def test_inductances_and_senses_by_hand():
    c = parse_string(CORE)
    # mu = 1.2 / 1000 H/m; L = N^2 mu A / l: 100^2 * 1.2e-3 * 1e-4 / 0.1 = 12 mH for a1
    assert c.element("a1_m").value == pytest.approx(12e-3, rel=1e-12)
    # the loop runs a3 (m1 -> m2), then a2 from its + node m2 to 0: flux into a2's + node,
    # v2 = -N2 dPhi/dt; then a1 from 0 (its -) to m1: v1 = +N1 dPhi/dt. So v2 = -v1/2
    e = c.element("Ea2")
    assert isinstance(e, Vcvs) and e.gain == pytest.approx(-0.5, rel=1e-12)
    assert any("a3: XSPICE core read as linear, dB/dH 0.0012 H/m" in n
               and "a2 (50 turns, 0.003 H, opposite sense)" in n for n in c.notes)
    # the mmf port the other way round: the same sense as a1
    # (the loop now enters a2 at its - node: +N2)
    same = parse_string(CORE.replace("(m2 0) sec", "(0 m2) sec"))
    assert same.element("Ea2").gain == pytest.approx(0.5, rel=1e-12)


def test_against_ngspice(tmp_path, ngspice):
    """v(out) on every step of ngspice's (its step bound: TSTEP = 1 us), within 0.5 % of the
    amplitude (measured: 0.05 %; ngspice's winding voltage is a backward difference)."""
    res = simulate_circuit(parse_string(CORE), probes=["v(out)", "v(in)"])
    res.raise_if_error()
    assert any("a3: core read as linear" in n and "the run stayed there" in n
               for n in res.notes)
    ng = ngspice_wrdata(CORE, ["v(out)", "v(in)"], tmp_path)
    for k, probe in enumerate(["v(out)", "v(in)"]):
        mine = np.interp(ng[:, 0], res.t, res[probe])
        amp = np.abs(ng[:, 2 * k + 1]).max()
        assert amp > 1.0
        assert np.abs(mine - ng[:, 2 * k + 1]).max() <= 5e-3 * amp


def test_written_deck_runs_in_ngspice(tmp_path, ngspice):
    c = parse_string(CORE)
    deck = write_circuit(c)
    assert ("pelcs_core_a3 core(H_array=[-2000 -1000 0 1000 2000] "
            "B_array=[-1.6 -1.2 0 1.2 1.6] area=0.0001 length=0.1") in deck
    assert "a2 (out 0) (m2 0) pelcs_lcouple_a2" in deck
    assert "Ea2" not in deck and "a1_m" not in deck
    (tmp_path / "w").mkdir()
    written = ngspice_wrdata(deck, ["v(out)"], tmp_path / "w")
    original = ngspice_wrdata(CORE, ["v(out)"], tmp_path)
    assert np.abs(written[:, 1] - np.interp(written[:, 0], original[:, 0],
                                            original[:, 1])).max() < 1e-9


def test_saturation_is_an_error_at_its_instant():
    # 20 V at 50 Hz: the magnetizing current (about 1.9 A, 1900 A/m) reaches the table's
    # bend, and the error names the instant the field leaves the segment
    deck = CORE.replace("SIN(0 10 1k)", "SIN(0 20 50)").replace(".tran 1u 4m", ".tran 20u 40m")
    res = None
    with pytest.raises(NetlistError) as exc:
        res = simulate_circuit(parse_string(deck))
        res.raise_if_error()
    assert res is None
    text = str(exc.value)
    assert "core 'a3' is linear (dB/dH 0.0012 H/m) only while -990 < H < 990 A/m" in text
    assert "<string>:7:1:" in text


@pytest.mark.parametrize("edit, where, words", [
    # hysteresis mode
    (("length=0.1)", "length=0.1 mode=2)"), (11, 24), ["hysteresis mode (mode=2)"]),
    # a corner at H = 0: the slopes differ on either side
    (("B_array=[-1.6 -1.2 0 1.2 1.6]", "B_array=[-1.6 -0.6 0 1.2 1.6]"), (7, 1),
     ["H = 0 is at a corner of the B-H table"]),
    # a winding with no core
    (("a3 (m1 m2) iron", "a3 (m1 m2) iron\na4 (x 0) (m3 m4) sec\nR3 x 0 1"), (8, 1),
     ["lcouple winding 'a4' is in no loop with a core"]),
    # two ports at one magnetic node
    (("a2 (out 0) (m2 0) sec", "a2 (out 0) (m2 0) sec\na5 (out 0) (m2 0) sec"), (8, 1),
     ["magnetic node 'm2' joins 3 mmf ports"]),
    # a magnetic node that is also an electrical one
    (("R2 out 0 100", "R2 out m1 100"), (7, 1), ["node 'm1' is also a node of 'R2'"]),
    # the core's length missing
    (("area=1e-4 length=0.1", "area=1e-4"), (10, 1), ["needs 'length'"]),
])
def test_refusals_name_the_place(edit, where, words):
    deck = CORE.replace(*edit)
    assert deck != CORE
    with pytest.raises(NetlistError) as exc:
        parse_string(deck)
    text = str(exc.value)
    for w in words:
        assert w in text, text
    line, col = where
    assert f"<string>:{line}:{col}:" in text, text
