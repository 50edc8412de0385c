"""Idealised transistors biased in their active region are refused, not run as switches:
those with no consistent on/off state at the DC operating point
(netlist.devices.active_at_operating_point) and those that slide on their threshold, partly
on, for more than netlist.devices.ACTIVE_SHARE of the run."""

from __future__ import annotations

import contextlib
import io

import pytest
from ngspice_helpers import ngspice_print

from lcs.simulation.initial import unsettled_comparators, unsettled_in_note
from netlist.devices import Replacement, active_at_operating_point, refuse_active_transistors
from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from pelcs.cli import main

# a common-gate stage (the MOSFET's source fed through RS and, for the signal, Cin; its gate
# held at 2.5 V). As a switch: on, RD + RS carry (5 - 1.6)/60k and v(ns) = 2.17 V, so
# v(ng,ns) = 0.33 V < VTO, off; off, v(ns) = 1.6 V and v(ng,ns) = 0.9 V > VTO, on
COMMON_GATE = """common-gate stage
.model ntype NMOS(KP=100e-6 VTO=0.5 LAMBDA=0.05)
VDD ndd 0 DC 5
VIN ndc 0 DC 1.6
VG ng 0 DC 2.5
RD ndd nd 50k
RS ndc ns 10k
M1 nd ng ns 0 ntype W=1u L=200n
vsig nsig 0 SIN(0 0.01 10k)
Cin nsig ns 10u
Cout nd nout 10u
RL nout 0 10Meg
.tran 1u 1m
.end
"""


def _cli(path, *extra) -> tuple[int, str]:
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        code = main(["simulate", str(path), "--no-progress", "-o",
                     str(path.with_suffix(".csv")), *extra])
    return code, buf.getvalue()


@pytest.mark.filterwarnings("ignore::lcs.notices.IdealisedDeviceWarning")
@pytest.mark.parametrize("devices", ["ideal", "pwl"])
def test_an_amplifier_transistor_is_refused_with_its_line(tmp_path, devices):
    path = tmp_path / "cg.cir"
    path.write_text(COMMON_GATE)
    code, out = _cli(path, "--devices", devices)
    assert code != 0
    assert "cg.cir:8:1: error: no DC operating point with M1 as a switch" in out, out
    assert "active region" in out and "UIC" in out
    assert "Traceback" not in out


@pytest.mark.filterwarnings("ignore::lcs.notices.IdealisedDeviceWarning")
def test_the_api_raises_the_same_error():
    with pytest.raises(NetlistError, match="no DC operating point with M1 as a switch"):
        simulate_circuit(parse_string(COMMON_GATE), probes=["v(nout)"])


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_ngspice_biases_that_transistor_in_its_active_region(tmp_path, ngspice):
    # the claim the error makes, checked against ngspice's operating point: M1 conducts
    # (v(ng,ns) > VTO) and is current-limited, v(nd,ns) > v(ng,ns) - VTO (saturation)
    deck = COMMON_GATE.replace(".tran 1u 1m", ".op")
    v = ngspice_print(deck, ["v(ng)-v(ns)", "v(nd)-v(ns)"], tmp_path)
    vov = v["v(ng)-v(ns)"] - 0.5
    assert 0 < vov < v["v(nd)-v(ns)"]


@pytest.mark.filterwarnings("ignore::lcs.notices.IdealisedDeviceWarning")
def test_with_uic_the_user_chose_the_start_and_it_runs():
    res = simulate_circuit(parse_string(COMMON_GATE.replace(".tran 1u 1m", ".tran 1u 1m uic")),
                           probes=["v(nout)"])
    assert res.error is None and len(res.t) > 1


def test_the_unsettled_comparators_are_those_of_the_last_cycle():
    # bit 0 settles after the first round, bits 1 and 2 alternate
    assert unsettled_comparators([0b000, 0b001, 0b011, 0b101, 0b011, 0b101]) == [1, 2]
    # no key repeats within the rounds: every comparator that changed
    assert unsettled_comparators([0b000, 0b001, 0b011]) == [0, 1]
    note = ("no DC operating point: the comparators (Q1, X1.M2) have no consistent state "
            "there (...)")
    assert unsettled_in_note(["other", note]) == ["Q1", "X1.M2"]
    assert unsettled_in_note(["other"]) == []


def test_only_idealised_transistors_are_refused():
    def rep(name, device):
        return Replacement(name, "m", device, "switch", 0.7, "default", None, ())

    reps = [rep("Q1", "NPN"), rep("X1.M2", "NMOS"), rep("XD", "diode macro-model")]
    found = active_at_operating_point(reps, ["q1", "S1", "XD"])
    assert [r.element for r in found] == ["Q1"]
    # a switch of the netlist's own (S) regulating at DC is not a transistor: no refusal
    assert active_at_operating_point(reps, ["S1"]) == []


# an emitter follower at its bias, from UIC: Q1 on charges CE through RC until v(b,e) falls
# to the 0.7 V threshold, where the ideal switch slides, held partly on (ngspice: forward
# active, v(c,e) 10.6 V)
FOLLOWER = """emitter follower
VCC vcc 0 12
VB b 0 DC 2.1
RC vcc c 100
Q1 c b e qn
.model qn NPN(BF=100)
RE e 0 1k
CE e 0 1u
.tran 1u 5m uic
.end
"""


@pytest.mark.filterwarnings("ignore::lcs.notices.IdealisedDeviceWarning")
def test_a_transistor_held_on_its_threshold_is_refused(tmp_path):
    path = tmp_path / "ef.cir"
    path.write_text(FOLLOWER)
    code, out = _cli(path)
    assert code != 0
    assert "ef.cir:5:1: error: Q1 slid on its threshold from t = " in out, out
    assert "active region" in out and "Traceback" not in out


def test_ngspice_has_the_follower_in_its_active_region(tmp_path, ngspice):
    deck = FOLLOWER.replace(".tran 1u 5m uic", ".op")
    v = ngspice_print(deck, ["v(c)-v(e)", "@q1[ic]"], tmp_path)
    assert v["v(c)-v(e)"] > 1.0 and v["@q1[ic]"] > 1e-4


def test_a_switching_edge_slides_too_briefly_to_be_refused():
    rep = Replacement("M1", "irf510", "VDMOS", "switch", 3.6, "VTO of the model", None, ())
    # ngspice's dcdc.sp with --devices pwl: a Miller plateau of 16 ns in a 0.2 ms run
    refuse_active_transistors([rep], [], "", [("M1", 1.085e-4, 1.085e-4 + 16e-9)], 2e-4)
    with pytest.raises(NetlistError, match="M1 slid on its threshold"):
        refuse_active_transistors([rep], [], "", [("M1", 1e-4, None)], 2e-4)
