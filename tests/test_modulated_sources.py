"""SFFM and AM independent sources (lcs.signals.Sffm, Am), compared with ngspice 39 point by
point: the waveforms at ngspice's own instants (its defaults, its phases, AM's carrier phase
taken from PHASES), a run's rows against the waveform, and an RC filter driven by each."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from lcs.signals import Am, Sffm, resolve
from netlist.parser import parse_string
from netlist.writer import write_circuit

SOURCES = """sffm am
V1 n1 0 SFFM(0.5 2 10k 3 1k 30 45)
R1 n1 0 1
V2 n2 0 AM(2 0.5 1k 10k 50u 30 45)
R2 n2 0 1
V3 n3 0 SFFM(0.5 2 10k 3 1k)
R3 n3 0 1
V4 n4 0 AM(2 0.5 1k 10k 50u)
R4 n4 0 1
V5 n5 0 SFFM(0.5 2)
R5 n5 0 1
I6 0 n6 AM(2 0.5 2k 20k)
R6 n6 0 1
.tran 1u 1m
.end
"""

RC = """sffm am through RC
V1 n1 0 SFFM(0.5 2 10k 3 1k 30 45)
R1 n1 a 100
C1 a 0 100n
V2 n2 0 AM(2 0.5 1k 10k 50u)
R2 n2 b 100
C2 b 0 100n
.tran 1u 1m
.end
"""


def _ngspice(tmp_path, deck: str, probes: list[str]) -> np.ndarray:
    """ngspice's run of ``deck``: the columns time, then each probe."""
    data = ngspice_wrdata(deck, probes, tmp_path, before=["set numdgt=15"])
    return np.column_stack([data[:, 0], data[:, 1::2]])


def test_the_waveforms():
    c = parse_string(SOURCES)
    waves = [el.waveform for el in c.elements if el.kind in "VI"]
    assert waves[0] == Sffm(0.5, 2, 10e3, 3, 1e3, 30, 45)
    assert waves[1] == Am(2, 0.5, 1e3, 10e3, 50e-6, 30, 45)
    # defaults from .tran: FC = FS = 1/TSTOP, AM's MF likewise; AM's FC and TD are 0
    assert resolve(waves[4], 1e-6, 1e-3) == Sffm(0.5, 2, 1e3, 0.0, 1e3)
    assert resolve(Am(2, 0.5), 1e-6, 1e-3) == Am(2, 0.5, 1e3, 0.0, 0.0)
    # values by hand: SFFM at 0 is VO + VA sin(PHASEC + MDI sin(PHASES))
    assert waves[0](0.0) == pytest.approx(0.5 + 2 * np.sin(np.pi / 6 + 3 * np.sin(np.pi / 4)))
    # AM is 0 until TD, and jumps there with a phase (PHASES sets the carrier's phase too)
    am = waves[1]
    assert am.jumps and not waves[3].jumps
    assert am(50e-6, side=-1) == 0.0
    assert am(50e-6, side=1) == pytest.approx(2 * (0.5 + np.sin(np.pi / 4)) * np.sin(np.pi / 4))


def test_waveforms_against_ngspice_point_by_point(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    ng = _ngspice(tmp_path, SOURCES, [f"v(n{k})" for k in range(1, 7)])
    c = parse_string(SOURCES)
    waves = [resolve(el.waveform, 1e-6, 1e-3) for el in c.elements if el.kind in "VI"]
    for k, w in enumerate(waves):
        # (I6 from 0 into n6 across 1 ohm: v(n6) is its current)
        err = np.abs(w(ng[:, 0]) - ng[:, k + 1]).max()
        assert err <= 1e-12 * max(1.0, np.abs(ng[:, k + 1]).max()), (k, err)


def test_a_run_follows_the_waveforms():
    from pelcs.api import simulate

    res = simulate(SOURCES, probes=[f"v(n{k})" for k in range(1, 7)])
    c = parse_string(SOURCES)
    waves = [resolve(el.waveform, 1e-6, 1e-3) for el in c.elements if el.kind in "VI"]
    for k, w in enumerate(waves):
        assert np.abs(res.y[:, k] - w(res.t)).max() <= 1e-12, k
    # the step resolves the highest frequency written: I6's FC + MF = 22 kHz (V1's
    # FC + MDI FS is 13 kHz)
    assert any("AM source I6" in n for n in res.notes), res.notes
    assert res.t[1] == pytest.approx(1 / 22e3 / 100)


def test_an_rc_filter_driven_by_each(tmp_path, ngspice):
    from pelcs.api import simulate

    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    ng = _ngspice(tmp_path, RC, ["v(a)", "v(b)"])
    res = simulate(RC, probes=["v(a)", "v(b)"])
    for k in range(2):
        want = np.interp(res.t, ng[:, 0], ng[:, k + 1])
        # (ngspice's rows 1 us apart, interpolated: 1.4 mV of 2.3 V measured)
        assert np.abs(res.y[:, k] - want).max() < 3e-3, k


def test_the_writer_writes_them_back():
    c = parse_string(SOURCES)
    text = write_circuit(c)
    assert "SFFM(0.5 2 10k 3 1k 30 45)" in text and "AM(2 0.5 1k 10k 50u 30 45)" in text
    again = parse_string(text)
    for a, b in zip(c.elements, again.elements, strict=True):
        if a.kind in "VI":
            assert a.waveform == b.waveform


def test_values_past_the_last_are_ignored_as_ngspice_ignores_them():
    # ngspice 39: SFFM(0 1 1k 1 100 0 0 9) is SFFM(0 1 1k 1 100 0 0) at every point
    c = parse_string("t\nV1 a 0 SFFM(0 1 1k 1 1k 0 0 9)\nR1 a 0 1\n.tran 1u 1m\n.end\n")
    d = parse_string("t\nV1 a 0 SFFM(0 1 1k 1 1k 0 0)\nR1 a 0 1\n.tran 1u 1m\n.end\n")
    assert c.element("V1").waveform == d.element("V1").waveform
    assert any("SFFM takes at most 7 values; the 1 after them ignored" in n for n in c.notes)
