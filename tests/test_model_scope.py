"""A ``.model`` card inside a ``.subckt`` definition is local to it, as in ngspice: the
subcircuit's elements use it, the rest of the netlist keeps a global model of the same name,
and the two are not "defined twice". eSim's SCR subcircuit ``.include``s the diode library
that its top-level netlist includes as well (tests/corpus/esim/.../FullwaveRectifier_SCR)."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.errors import NetlistError
from pelcs.api import simulate

# Two 1 V dividers, each a closed switch into 1 Ohm: the top-level one through the global
# model sm (RON 1 Ohm: v(b) = 0.5 V), the subcircuit's through its own sm (RON 3 Ohm:
# v(x1.b) = 0.25 V). Were models global, both would be one model (or an error).
DECK = """model scope
V1 a 0 DC 1
Vc c 0 DC 2
S1 a b c 0 sm
R1 b 0 1
X1 a c half
.subckt half in ctl
S2 in b ctl 0 sm
R2 b 0 1
.model sm SW(VT=1 VH=0 RON=3 ROFF=1G)
.ends half
.model sm SW(VT=1 VH=0 RON=1 ROFF=1G)
.tran 1u 10u
.end
"""


def test_a_model_inside_a_subcircuit_is_local_to_it():
    res = simulate(DECK, probes=["v(b)", "v(x1.b)"], devices="pwl")
    assert np.allclose(res.y[-1], [0.5, 0.25], atol=1e-9)


def test_a_subcircuit_model_used_only_elsewhere_is_still_found():
    # (pelcs's reading before local models: a model written inside a subcircuit and named
    # nowhere else stays visible; ngspice would not find it at the top level)
    deck = DECK.replace(".model sm SW(VT=1 VH=0 RON=1 ROFF=1G)\n", "")
    res = simulate(deck, probes=["v(b)", "v(x1.b)"], devices="pwl")
    assert np.allclose(res.y[-1], [0.25, 0.25], atol=1e-9)


def test_a_model_twice_in_one_subcircuit_is_refused():
    deck = DECK.replace(".ends half", ".model SM SW(VT=1)\n.ends half")
    with pytest.raises(NetlistError) as info:
        simulate(deck)
    assert "model 'SM' is defined twice (first at line 10)" in str(info.value)


def test_ngspice_scopes_the_subcircuit_model(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    data = ngspice_wrdata(DECK, ["v(b)", "v(x1.b)"], tmp_path, timeout=60)
    assert np.allclose(data[-1, [1, 3]], [0.5, 0.25], atol=1e-6)
