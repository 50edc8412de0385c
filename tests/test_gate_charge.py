"""An idealised MOSFET's gate-drain capacitance in a pwl run: the chord of its model's
charge over the run's gate-drain swing (netlist.gate_charge), against the charge ngspice's
own device moves with its drain ramped, and a converter against ngspice."""

from __future__ import annotations

import re
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest

from lcs.notices import IdealisedDeviceWarning
from netlist.circuit import Switch
from netlist.gate_charge import GateDrainLaw, chord_capacitance
from netlist.parser import parse_file, parse_string
from netlist.studies.realistic import simulate_devices

#: (ngspice side by side: the full suite and CI run them, not the fast subset)
pytestmark = pytest.mark.slow

DEV = Path(__file__).parent / "netlists" / "devices"
#: a power MOSFET macro-model of MODPEX's structure, values of our own
MACRO = DEV / "modpex_like.lib"


def ngspice_gate_charge(deck: str, cwd: Path) -> float:
    """The charge, C, through the gate source of ``deck`` (ngspice, independent reference)."""
    deck += ".control\nrun\nmeas tran q1 integ i(vg) from=0 to=50u\n.endc\n.end\n"
    out = subprocess.run(["ngspice", "-b"], input=deck, capture_output=True, text=True,
                         timeout=60, cwd=cwd).stdout
    return float(re.search(r"q1\s*=\s*(\S+)", out).group(1))


def test_a_vdmos_law_moves_ngspice_s_charge(ngspice, tmp_path):
    # (ngspice 39: no CGDMAX, no gate-drain charge at all; A defaults to 1, CGDMIN to 0)
    bare = _switch(".model mm vdmos(vto=3 kp=5)")
    assert bare.cgd_law is None
    assert _switch(".model mm vdmos(vto=3 kp=5 cgdmax=0.4n)").cgd_law.params == (0.0, 0.4e-9,
                                                                                  1.0)
    model = ".model mm vdmos(vto=3 kp=5 cgdmin=0.05n cgdmax=0.4n a=0.3 cgs=1n)"
    # gate held at 0 V, drain ramped from -10 to 40 V: vgd from +10 to -40 V
    q = ngspice_gate_charge(f"ramp\nM1 d g 0 mm\n{model}\nVg g 0 0\n"
                            "Vd d 0 PWL(0 -10 50u 40)\n.tran 10n 50u\n", tmp_path)
    law = GateDrainLaw("vdmos", (0.05e-9, 0.4e-9, 0.3), "g", "d")
    assert chord_capacitance(law, -40.0, 10.0) * 50.0 == pytest.approx(q, rel=1e-3)


def _switch(model: str) -> Switch:
    return _macro_switch(f"t\nV1 d 0 1\nVg g 0 0\nM1 d g 0 mm\n{model}\n.tran 1u 10u\n"
                         ".end\n")


def _macro_switch(text: str) -> Switch:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        c = parse_string(text, file=str(DEV / "deck.cir"))
    (sw,) = [el for el in c.elements if isinstance(el, Switch)]
    return sw


def test_a_modpex_macro_s_feedback_is_read_as_its_law_and_moves_ngspice_s_charge(ngspice):
    deck = (f"ramp\n.include {MACRO.name}\nX1 d g 0 pmos_macro\nVg g 0 2.5\n"
            "Vd d 0 PWL(0 0 50u 40)\n.tran 10n 50u\n")
    law = _macro_switch(deck + ".end\n").cgd_law
    assert law.kind == "symmetry" and law.params == (0.8e-9, 0.3e-9, 0.6, 0.5)
    # gate 2.5 V (under its 3 V threshold), drain 0 to 40 V: vgd from 2.5 to -37.5 V
    q = ngspice_gate_charge(deck, DEV)
    # (ngspice's CAP engages over the ~0.3 V its clamp diode takes: 3 % less)
    assert chord_capacitance(law, -37.5, 2.5) * 40.0 == pytest.approx(q, rel=0.05)


def test_a_boost_of_the_macro_agrees_with_ngspice_where_its_largest_cgd_did_not(ngspice):
    # ngspice 39: mean v(out) over 3..6 ms 20.81 V; the constant 0.8 nF gave 21.54 V (3.5 %)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate_devices(parse_file(str(DEV / "boost_modpex_like.cir")), devices="pwl",
                               probes=["v(out)"])
    t, y = np.asarray(res.t), res.y[:, 0]
    keep = t >= 3e-3
    mean = np.trapezoid(y[keep], t[keep]) / (t[keep][-1] - t[keep][0])
    assert mean == pytest.approx(20.81, rel=0.02)
    (note,) = [n for n in res.notes if "gate-drain capacitance" in n]
    assert "the chord of its model's charge" in note


def test_a_vdmos_instance_multiplier_leaves_the_law_as_ngspice_39_does(ngspice, tmp_path):
    # (ngspice 39 scales a VDMOS's current by m but neither CGS nor the CGDMIN..CGDMAX law:
    # the gate charge of m=3 is m=1's, where the law times m gave 3 times it)
    model = ".model mm vdmos(vto=3 kp=5 cgdmin=0.05n cgdmax=0.4n a=0.3)"
    law = _macro_switch(f"t\nV1 d 0 1\nVg g 0 0\nM1 d g 0 mm m=3\n{model}\n.tran 1u 10u\n"
                        ".end\n").cgd_law
    q = ngspice_gate_charge(f"ramp\nM1 d g 0 mm m=3\n{model}\nVg g 0 0\n"
                            "Vd d 0 PWL(0 -10 50u 40)\n.tran 10n 50u\n", tmp_path)
    assert chord_capacitance(law, -40.0, 10.0) * 50.0 == pytest.approx(q, rel=1e-3)


def test_a_p_channel_vdmos_law_moves_ngspice_s_charge(ngspice, tmp_path):
    # (pchan: ngspice's vgd is v(drain) - v(gate); gate 0 V, drain -40 to 10 V)
    model = ".model mm vdmos(pchan vto=-3 kp=5 cgdmin=0.05n cgdmax=0.4n a=0.3)"
    law = _switch(model).cgd_law
    assert law.sign == -1.0
    q = ngspice_gate_charge(f"ramp\nM1 d g 0 mm\n{model}\nVg g 0 0\n"
                            "Vd d 0 PWL(0 -40 50u 10)\n.tran 10n 50u\n", tmp_path)
    vgd = law.sign * (0.0 - np.array([-40.0, 10.0]))
    assert chord_capacitance(law, vgd.min(), vgd.max()) * 50.0 == pytest.approx(abs(q),
                                                                                  rel=1e-3)
