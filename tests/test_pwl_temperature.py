"""``--devices pwl`` fits its diodes to ngspice's characteristic at 27 °C of their models as
given: a deck that sets another temperature (``.temp``, ``.options temp=``/``tnom=``, a
model's ``TNOM``) runs ngspice elsewhere on the characteristic (a rectifier at 100 °C
averages 2.41 V in ngspice, 2.35 V at 27 °C), which a note says; at 27 °C, none."""

from __future__ import annotations

import pytest

import pelcs

DECK = """rectifier{title}
V1 in 0 SIN(0 5 1k)
D1 in out DA area=2 m=3
R1 out 0 50
C1 out 0 10u
.model DA D(IS=1e-15 N=1.2 RS=0.5 ISR=1e-10 NR=2 IKF=0.05)
{line}
.tran 1u 2m
.end
"""


def _notes(line: str) -> list[str]:
    res = pelcs.simulate(DECK.format(title=f" {line}", line=line), devices="pwl",
                         probes=["v(out)"])
    return [n for n in res.notes if "°C" in n]


@pytest.mark.parametrize("line, said", [(".temp 100", "100 °C"),
                                        (".options temp=100", "100 °C"),
                                        (".options tnom=50", "TNOM = 50 °C")])
def test_a_temperature_the_fit_does_not_follow_is_noted(line, said):
    notes = _notes(line)
    assert len(notes) == 1 and said in notes[0] and "27 °C" in notes[0], notes


@pytest.mark.parametrize("line", ["", ".temp 27", ".options temp=27 tnom=27"])
def test_none_at_the_nominal_temperature(line):
    assert _notes(line) == []


def test_a_models_nominal_temperature_is_noted_its_own_first():
    deck = DECK.replace("NR=2 IKF=0.05)", "NR=2 IKF=0.05 TNOM=-50)")
    res = pelcs.simulate(deck.format(title="", line=".options tnom=27"), devices="pwl",
                         probes=["v(out)"])
    notes = [n for n in res.notes if "°C" in n]
    assert len(notes) == 1 and "TNOM = -50 °C" in notes[0], notes
    deck = DECK.replace("NR=2 IKF=0.05)", "NR=2 IKF=0.05 TNOM=27)")
    res = pelcs.simulate(deck.format(title="", line=".options tnom=50"), devices="pwl",
                         probes=["v(out)"])
    assert [n for n in res.notes if "°C" in n] == []
