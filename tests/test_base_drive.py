"""The base current a BJT idealised as a switch can get (netlist.base_drive.BaseDrive):
a transistor whose base resistors cannot supply its collector current over BF is in its
forward-active region, not a closed switch, and the run is refused; one driven hard enough,
or through anything but resistors, runs."""

from __future__ import annotations

import re
import subprocess
import warnings

import numpy as np
import pytest

from lcs.notices import IdealisedDeviceWarning
from netlist.base_drive import VBE_LOW, BaseDrive
from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from tests.netlist_asserts import refused_at

STAGE = """a BJT switching an inductive load from a resistor-fed base
Vcc vcc 0 5
Rc vcc c 100
Rb {drive} b {rb}
Q1 c b 0 QN
L1 c x 1m
R2 x 0 1k
.model QN NPN(BF=100)
.tran 1u 100u
.end
"""


def parse(text: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        return parse_string(text)


def drives(circuit) -> list[BaseDrive]:
    return [k for k in circuit.knees if isinstance(k, BaseDrive)]


def ngspice_vc(deck: str) -> float:
    deck = deck.replace(".end\n", ".control\nrun\nprint v(c)[50]\n.endc\n.end\n")
    out = subprocess.run(["ngspice", "-b"], input=deck, capture_output=True, text=True,
                         timeout=60).stdout
    return float(re.search(r"v\(c\)\[50\]\s*=\s*(\S+)", out).group(1))


def test_a_base_too_weak_to_saturate_the_transistor_is_refused(ngspice):
    deck = STAGE.format(drive="vcc", rb="47k")
    # ngspice: forward-active, BF Ib = 100 (5 - 0.7 V)/47k = 9 mA, v(c) 3.7 V, not 0
    assert ngspice_vc(deck) > 3.0
    with pytest.raises(NetlistError) as err:
        simulate_circuit(parse(deck), probes=["v(c)"])
    d = err.value.diagnostics[0]
    assert d.message.startswith("Q1 (NPN) is on as a switch and carries")
    assert "((v(vcc) - 0.5 V)/47 kΩ)" in d.message and "forward-active" in d.message
    assert d.location.line == 5 and d.elements == ("Q1",)


def test_a_base_driven_hard_enough_runs(ngspice):
    deck = STAGE.format(drive="vcc", rb="4.7k")
    assert ngspice_vc(deck) < 0.2  # saturated: 0.126 V
    res = simulate_circuit(parse(deck), probes=["v(c)"])
    assert abs(res.y[-1, 0]) < 1e-9
    assert not any(n.startswith("Q1: on as a switch") for n in res.notes)


def test_the_bound_is_the_resistors_current_above_vbe_low():
    (k,) = drives(parse(STAGE.format(drive="vcc", rb="47k")))
    assert k.resistors == (("vcc", 47e3),) and k.beta == 100.0
    i_c = np.array([0.0, 0.05, 0.05])
    v_b, v_vcc = np.array([0.0, 5.0, 5.0]), np.array([5.0, 5.0, 5.0])
    q = k.quantity([i_c, v_b, v_vcc])
    most = 100 * (5.0 - VBE_LOW) / 47e3
    assert q[0] == -1.0 and q[1] == pytest.approx(0.05 / most - 1)


def test_a_base_driven_by_a_source_or_through_a_capacitor_is_not_checked():
    source = STAGE.format(drive="vcc", rb="47k").replace("Rb vcc b 47k", "Vb b 0 1")
    assert not drives(parse(source))
    speedup = STAGE.format(drive="vcc", rb="47k").replace(
        "Rb vcc b 47k", "Rb vcc b 47k\nCb vcc b 1n")
    assert not drives(parse(speedup))


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_a_pnp_reads_its_base_current_the_other_way(ngspice):
    deck = """a PNP high side switch with a weak base pull-down
Vcc vcc 0 5
Rb b 0 47k
Q1 c b vcc QP
L1 c x 1m
Rc x 0 100
.model QP PNP(BF=50)
.tran 1u 100u
.end
"""
    (k,) = drives(parse(deck))
    assert k.device == "PNP" and k.resistors == (("0", 47e3),)
    # ngspice: 50 (5 - 0.7)/47k = 4.6 mA into 100 ohm: v(c) 0.46 V, not the switch's 5 V
    assert ngspice_vc(deck.replace("L1 c x 1m\nRc x 0 100", "Rc c 0 100")) < 1.0
    with pytest.raises(NetlistError, match=r"Q1 \(PNP\) is on as a switch"):
        simulate_circuit(parse(deck), probes=["v(c)"])


def test_a_long_streamed_run_leaves_the_base_drive_out_and_says_so(monkeypatch):
    # the check keeps every step: a 2 s NPN boost written to a CSV held 321 MB with it, 87 MB
    # without; past netlist.knee.KNEE_STEPS a streamed run leaves it out with a note, and a
    # run that keeps its steps still refuses
    import netlist.knee as knee

    monkeypatch.setattr(knee, "KNEE_STEPS", 10)
    circuit = parse(STAGE.format(drive="vcc", rb="47k"))
    res = simulate_circuit(circuit, probes=["v(c)"], output_step=1e-6)
    assert any(n.startswith("Q1: not checked for a base drive too weak to saturate it in this "
                            "run of") for n in res.notes)
    with pytest.raises(NetlistError, match="Q1 .NPN. is on as a switch and carries"):
        simulate_circuit(circuit, probes=["v(c)"])


# the two-transistor model of an SCR (as vendors' SCR models are built): the PNP's collector
# is the NPN's base, the NPN's collector the PNP's base
SCR = """scr half-wave rectifier
.subckt scr a g k
Qp 6 4 a QP
Qn 4 6 5 QN
Rg g 6 10
Rk k 5 0.5
Rs 6 5 1meg
.model QP PNP(BF=6)
.model QN NPN(BF=10)
.ends
V1 src 0 SIN(0 100 50)
Vg gate out PULSE(0 1 5m 1u 1u 5m 20m)
X1 src gate out scr
R1 out 0 100
.tran 0.1m 40m
.end
"""


def test_a_two_transistor_thyristor_is_read_as_an_ideal_one_where_it_fits():
    # run with its transistors as switches, it never fired: 0 V where ngspice's rectifier
    # gives its half waves (PySpice power-electronics' SCR examples, Littelfuse's models);
    # netlist.thyristor reads it as an ideal thyristor (tests/test_thyristor.py)
    (r,) = parse(SCR).replacements
    assert r.element == "X1.Qp, X1.Qn" and r.device == "thyristor"
    assert not drives(parse(SCR))
    # its PNP's base driven from the gate as well: not a thyristor netlist.thyristor reads
    refused_at(SCR.replace("Rs 6 5 1meg", "Rs 6 5 1meg\nRag 4 g 1k"), (3, 1),
               ["X1.Qp and X1.Qn form a thyristor", "cannot fire or latch",
                "ideal diode in series with an S switch"])


def test_a_complementary_pair_that_is_not_a_latch_is_kept():
    # a PNP driving an NPN's base (a Sziklai-like pair) with the NPN's collector elsewhere
    deck = SCR.replace("Qn 4 6 5 QN", "Qn a 6 5 QN\nRb a 4 10k")
    parse_string(deck)


def test_a_common_base_npn_into_a_grounded_collector_pnp_follower_is_kept():
    # the NPN's collector is the PNP's base and the PNP's collector the NPN's base, but that
    # node is ground: the bases draw from ground and the supply, there is no latch (ngspice:
    # v(out) follows the NPN's collector, 0.7 V above it)
    deck = """common-base NPN level shifter into a PNP emitter follower
Vcc vcc 0 10
Vm m 0 PULSE(0 -5 1m 1u 1u 1m 2m)
Qn x 0 em QN
Re em m 1k
Rc vcc x 1k
Qp 0 x out QP
Ro vcc out 10k
.model QP PNP(BF=100)
.model QN NPN(BF=100)
.tran 10u 4m
.end
"""
    parse_string(deck)
    # the same pair with its base node held by a source: still no latch
    parse_string(deck.replace("Qn x 0 em QN", "Qn x b em QN\nVb b 0 1").replace(
        "Qp 0 x out QP", "Qp b x out QP"))
