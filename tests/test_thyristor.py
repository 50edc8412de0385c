"""The two-transistor model of a thyristor read as an ideal thyristor (netlist.thyristor):
it fires when its gate drives current into the gate junction with the anode positive,
conducts as a diode and stays on while its current flows, whatever the gate. Checked
against the controlled rectifier's analytic waveforms and against ngspice's transistors."""

from __future__ import annotations

import math
import re
import subprocess
import warnings

import numpy as np
import pytest

from lcs.notices import IdealisedDeviceWarning
from netlist.circuit import Switch
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from netlist.thyristor import IDEAL_THYRISTOR, gate_voltage
from netlist.writer import write_circuit
from tests.netlist_asserts import refused_at

# a thyristor as two transistors that drive each other's base, with a gate resistor, a
# resistor across the gate junction, a diode across it and a leakage resistor
SUBCKT = """.subckt tscr an gt ct
Qa nb pb an qa
Qb pb nb kk qb
Rgate gt nb 47
Rbe nb kk 4.7k
Rcath ct kk 0.05
Dbe nb kk dgk
Rleak an pb 2G{extra}
.model qa pnp(bf=5 is=2e-14 cje=5p cjc=2p tf=0.3u)
.model qb npn(bf=25 is=5e-14 cje=20p cjc=2p tf=0.3u)
.model dgk d(is=1e-15)
.ends
"""

VM, F = 100.0, 50.0


def rectifier(fire: float, load: str, extra: str = "", tstop: str = "60m") -> str:
    """A half-wave controlled rectifier: the gate pulsed (5 V through 100 Ω, 1 ms) at
    ``fire`` s of each period."""
    return (f"half-wave rectifier with a two-transistor SCR\n{SUBCKT.format(extra=extra)}"
            f"V1 src 0 SIN(0 {VM:g} {F:g})\n"
            f"Vg drv out PULSE(0 5 {fire!r} 1u 1u 1m 20m)\n"
            "Rg drv gate 100\n"
            "X1 src gate out tscr\n"
            f"{load}\n"
            f".tran 10u {tstop}\n.end\n")


R_LOAD = "R1 out 0 100"


def parse(text: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        return parse_string(text)


def run(deck: str, probes: list[str]):
    return simulate_circuit(parse(deck), probes=probes)


def test_the_pair_becomes_an_ideal_thyristor_and_says_so():
    c = parse(rectifier(3.333e-3, R_LOAD))
    assert not any(el.name in ("X1.Qa", "X1.Qb", "X1.Dbe") for el in c.elements)
    assert not any(isinstance(el, Switch) and el.device for el in c.elements)
    (group,) = c.built_groups.values()
    assert group.construct == IDEAL_THYRISTOR
    assert group.line.splitlines() == ["Q.X1.Qa x1.nb x1.pb src qa",
                                       "Q.X1.Qb x1.pb x1.nb x1.kk qb",
                                       "D.X1.Dbe x1.nb x1.kk dgk"]
    (r,) = c.replacements
    assert r.element == "X1.Qa, X1.Qb" and r.device == "thyristor"
    assert not [k for k in c.knees if getattr(k, "name", "") in ("X1.Qa", "X1.Qb")]
    (note,) = [n for n in c.notes if "thyristor" in n]
    assert note.startswith("X1.Qa, X1.Qb: thyristor (two-transistor model) read as an ideal "
                           "thyristor")
    # the gate junction: where the loop gain is one, BF_p gm = G + gm/BF_n (no ISE), so
    # Ic = Vt G / (BF_p - 1/BF_n) with G = 1/47 + 1/4.7k, at 27 °C
    vt = 8.617333262e-5 * 300.15
    ic = vt * (1 / 47 + 1 / 4.7e3) / (5 - 1 / 25)
    vg = vt * math.log(ic / 5e-14)
    assert gate_voltage(c.models["tscr:qb"], c.models["tscr:qa"], 1 / 47 + 1 / 4.7e3,
                        27.0) == pytest.approx(vg, abs=1e-9)
    assert f"= {vg:.3g} V" in note
    # ngspice is given the transistors and the diode, with their models
    text = write_circuit(c)
    assert "Q.X1.Qa x1.nb x1.pb src qa" in text and "D.X1.Dbe x1.nb x1.kk dgk" in text
    assert "#" not in text and "pelcs_thy" not in text and "pelcs_sw" not in text
    assert ".model qb NPN(" in text


@pytest.mark.parametrize("degrees", [30.0, 60.0, 120.0])
def test_an_r_load_conducts_from_the_firing_angle_to_the_voltage_zero(degrees):
    alpha = math.radians(degrees)
    fire = alpha / (2 * math.pi * F)
    res = run(rectifier(fire, R_LOAD, tstop="40m"), ["v(out)", "v(src)"])
    t, out, src = res.t, res.y[:, 0], res.y[:, 1]
    second = t >= 20e-3
    on = second & (out > 1e-3)
    # fired at the gate's edge (the gate junction's 0.77 V reached within the 1 us rise),
    # off at the source's zero
    assert t[on][0] == pytest.approx(20e-3 + fire, abs=1.5e-5)
    assert t[on][-1] == pytest.approx(30e-3, abs=1.5e-5)
    # conducting, the load takes the source over the 100.05 ohm path (and the gate's 29 mA
    # through the 0.05 ohm while the pulse lasts: 1.5 mV); blocked, nothing
    assert np.allclose(out[on], src[on] * 100 / 100.05, atol=2e-3)
    # (blocked: the 1 GΩ leakage, 10 uV at the 100 V peak)
    assert np.all(np.abs(out[second & ~on]) < 1e-3)
    mean = np.trapezoid(out[second], t[second]) / 20e-3
    expected = VM / (2 * math.pi) * (1 + math.cos(alpha)) * 100 / 100.05
    assert mean == pytest.approx(expected, rel=3e-3)


def _extinction(alpha: float, phi: float) -> float:
    """The angle at which a half-wave controlled rectifier's RL load current,
    ``sin(θ - φ) - sin(α - φ) exp(-(θ - α)/tan φ)`` over Vm/Z, falls to zero past π."""
    def i(th):
        return math.sin(th - phi) - math.sin(alpha - phi) * math.exp(-(th - alpha) / math.tan(phi))

    lo, hi = math.pi, 2 * math.pi
    assert i(lo) > 0 > i(hi)
    for _ in range(80):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if i(mid) > 0 else (lo, mid)
    return lo


def test_an_rl_load_keeps_it_on_past_the_voltage_zero():
    alpha, r, ind = math.radians(60), 10.0, 30e-3
    w = 2 * math.pi * F
    fire = alpha / w
    res = run(rectifier(fire, f"R1 out mid {r:g}\nL1 mid 0 {ind!r}", tstop="40m"),
              ["v(out)", "i(L1)"])
    t, out, il = res.t, res.y[:, 0], res.y[:, 1]
    second = t >= 20e-3
    on = second & (il > 1e-4)
    beta = _extinction(alpha, math.atan(w * ind / (r + 0.05)))
    assert beta > math.pi + 0.5  # well past the voltage zero
    assert t[on][0] == pytest.approx(20e-3 + fire, abs=1.5e-5)
    assert t[on][-1] == pytest.approx(20e-3 + beta / w, abs=2e-5)
    # past the zero the latched thyristor puts the negative source on the load
    assert out[on & (t > 31e-3)].min() < -30.0
    # the current against the analytic one
    z = math.hypot(r + 0.05, w * ind)
    phi = math.atan(w * ind / (r + 0.05))
    th = w * (t[on] - 20e-3)
    analytic = VM / z * (np.sin(th - phi) - math.sin(alpha - phi)
                         * np.exp(-(th - alpha) / math.tan(phi)))
    assert np.max(np.abs(il[on] - analytic)) < 5e-3 * VM / z


def test_a_gate_below_its_junction_voltage_never_fires():
    # 0.5 V through 100 ohm never lifts the gate junction to its 0.557 V
    deck = rectifier(3.333e-3, R_LOAD).replace("PULSE(0 5 ", "PULSE(0 0.5 ")
    res = run(deck, ["v(out)"])
    assert np.max(np.abs(res.y[:, 0])) < 1e-3


def test_a_pair_with_its_anode_gate_driven_from_outside_is_refused():
    # the PNP's base reached from the gate: a thyristor with an anode gate, not read
    deck = rectifier(3.333e-3, R_LOAD, extra="\nRag pb gt 10k")
    refused_at(deck, (3, 1), ["X1.Qa and X1.Qb form a thyristor", "cannot fire or latch",
                              "ideal diode in series with an S switch"])


def test_a_pair_without_a_gate_is_refused():
    deck = rectifier(3.333e-3, R_LOAD).replace("Rgate gt nb 47", "Rgate gt kk 47").replace(
        "Rbe nb kk 4.7k\n", "").replace("Dbe nb kk dgk\n", "")
    refused_at(deck, (3, 1), ["X1.Qa and X1.Qb form a thyristor"])


def _ngspice_mean(deck: str, t0: float, t1: float) -> float:
    deck = deck.replace(".end\n", f".control\nrun\nmeas tran avg avg v(out) from={t0!r} "
                                  f"to={t1!r}\n.endc\n.end\n")
    out = subprocess.run(["ngspice", "-b"], input=deck, capture_output=True, text=True,
                         timeout=120).stdout
    return float(re.search(r"^avg\s*=\s*(\S+)", out, re.M).group(1))


@pytest.mark.slow
@pytest.mark.parametrize("load", [R_LOAD, "R1 out mid 10\nL1 mid 0 30m"])
def test_the_rectifier_agrees_with_ngspice_transistors(ngspice, load):
    deck = rectifier(3.333e-3, load)
    res = run(deck, ["v(out)"])
    t, out = res.t, res.y[:, 0]
    window = t >= 20e-3
    ours = np.trapezoid(out[window], t[window]) / (t[-1] - 20e-3)
    theirs = _ngspice_mean(deck, 20e-3, 60e-3)
    # ngspice's SCR drops about 1 V of the 100 V peak where it conducts
    assert ours == pytest.approx(theirs, rel=0.05)
    # the deck pelcs writes gives ngspice the same transistors
    written = write_circuit(parse(deck))
    assert _ngspice_mean(written, 20e-3, 60e-3) == pytest.approx(theirs, rel=1e-3)


def test_two_subcircuits_models_of_one_name_stay_two_in_the_written_deck():
    # Littelfuse's library defines a Pfor in each SCR's subcircuit, of BF 6.1 in one and
    # 2.2 in another: the flattened deck keeps each, named by its subcircuit, where one
    # '.model Pfor' per definition would give ngspice one of them for every instance
    other = SUBCKT.format(extra="").replace(".subckt tscr ", ".subckt tscr2 ").replace(
        "bf=25", "bf=40")
    deck = rectifier(3.333e-3, R_LOAD).replace(".subckt tscr ", other + ".subckt tscr ")
    deck = deck.replace("R1 out 0 100", "R1 out 0 100\nX2 src gate out2 tscr2\nR2 out2 0 100")
    text = write_circuit(parse(deck))
    assert "Q.X1.Qb x1.pb x1.nb x1.kk tscr_qb" in text
    assert "Q.X2.Qb x2.pb x2.nb x2.kk tscr2_qb" in text
    assert "D.X2.Dbe x2.nb x2.kk tscr2_dgk" in text
    assert ".model tscr_qb NPN(bf=25 is=50f " in text
    assert ".model tscr2_qb NPN(bf=40 is=50f " in text
    assert "\n.model qb " not in text


@pytest.mark.slow
def test_a_slow_gate_ramp_fires_it_where_ngspice_fires_the_transistors(ngspice):
    # the gate held by a source through the subcircuit's 47 ohm, rising 1 V over 1 ms at
    # 3 ms: ngspice's pair fires near where the loop gain reaches one, the ideal gate
    # junction's voltage
    deck = re.sub(r"Vg drv .*\nRg drv gate 100", "Vg gate out PULSE(0 1 3m 1m 1m 5m 20m)",
                  rectifier(3e-3, R_LOAD))
    assert "PULSE(0 1 3m" in deck
    res = run(deck, ["v(out)"])
    ours = res.t[np.argmax(res.y[:, 0] > 5.0)]
    out = subprocess.run(["ngspice", "-b"], input=deck.replace(
        ".end\n", ".control\nrun\nmeas tran tf when v(out)=5 rise=1\n.endc\n.end\n"),
        capture_output=True, text=True, timeout=120).stdout
    theirs = float(re.search(r"^tf\s*=\s*(\S+)", out, re.M).group(1))
    assert 3.5e-3 < theirs < 3.6e-3  # ngspice: 3.546 ms, 0.546 V of gate
    # pelcs: 0.557 V across the junction, 0.5625 V of gate with Rbe's 118 uA through the
    # 47 ohm, seen at the next 10 us sample; the NPN's VBE at 1 mA (0.614 V) would be 68 us
    # late
    assert ours == pytest.approx(theirs, abs=25e-6)
