"""The probe syntax (:mod:`netlist.probes`), read once for the formulation, the check of a
run's probes and the ngspice runner."""

from __future__ import annotations

import pytest

from netlist.probes import PROBE, probe_unit


@pytest.mark.parametrize("text, groups", [
    ("v(out)", ("v", "out", None)),
    (" V( a , b ) ", ("V", "a", "b")),
    ("i(R1)", ("i", "R1", None)),
    ("I(x1.L1)", ("I", "x1.L1", None)),
])
def test_probe_syntax(text, groups):
    assert PROBE.match(text).groups() == groups


@pytest.mark.parametrize("text", ["v()", "v(a,b,c)", "x(a)", "v(a", "d(S1)", "v(a)b"])
def test_not_a_probe(text):
    assert PROBE.match(text) is None


def test_probe_unit():
    assert probe_unit("v(out)") == "V" and probe_unit(" I(L1)") == "A"
    assert probe_unit("d(S1)") == "" and probe_unit("mean(v(out))") == ""


# two RCs: the node c1 is the second's capacitor C2, while C1 is the first's capacitor
SHADOW = """node named like a capacitor
V1 a 0 DC 1
R1 a b 1k
C1 b 0 1u
V2 d 0 DC 3
R2 d c1 1k
C2 c1 0 1u
.tran 10u 2m uic
.end
"""


@pytest.mark.parametrize("method", ["moreau", "exact"])
def test_v_of_a_node_named_like_a_capacitor_is_the_node(method):
    import numpy as np

    from netlist.parser import parse_string
    from netlist.studies.transient import simulate_circuit

    res = simulate_circuit(parse_string(SHADOW), probes=["v(c1)", "v(b)", "V(C1)", "V(c2)"],
                           method=method)
    t = res.t
    # as in SPICE, v(c1) is the node c1 (the 3 V RC), not the capacitor C1 (the 1 V RC)
    charge = 1 - np.exp(-t / 1e-3)
    assert res.y[:, 0] == pytest.approx(3 * charge, abs=2e-3)
    assert res.y[:, 1] == pytest.approx(charge, abs=2e-3)
    # in any other spelling but the state's; C2's state in another case is the state
    assert res.y[:, 2] == pytest.approx(res.y[:, 0], abs=1e-12)
    assert res.y[:, 3] == pytest.approx(res.y[:, 0], abs=1e-12)


def test_the_states_spelling_of_a_node_named_like_a_capacitor_is_an_error():
    # ngspice reads v(C1) as the node c1 (names ignore case); pelcs's state of C1 is spelled
    # so too: refused, with both spellings that say which
    from netlist.errors import NetlistError
    from netlist.parser import parse_string
    from netlist.studies.transient import simulate_circuit

    with pytest.raises(NetlistError) as err:
        simulate_circuit(parse_string(SHADOW), probes=["v(C1)"])
    text = str(err.value)
    assert "ambiguous" in text and "v(c1) for the node's voltage" in text
    assert "v(b) for C1's" in text
    lower = SHADOW.replace("C1 b 0", "c1 b 0")  # (a capacitor spelled c1: V(c1) is the node)
    with pytest.raises(NetlistError, match=r"V\(c1\) for the node's voltage"):
        simulate_circuit(parse_string(lower), probes=["v(c1)"])


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_v_of_a_node_named_like_a_capacitor_agrees_with_ngspice(ngspice):
    from netlist.parser import parse_string
    from ngspice_checks.compare import compare, default_probes

    cmp = compare(SHADOW, probes=["v(c1)", "V(C1)", "V(C2)", "v(b)"], timeout=120)
    assert cmp.ok, cmp.failures
    # the default probes (every state) read C1's by its nodes: v(C1) is the node c1
    assert default_probes(parse_string(SHADOW)) == ["v(b)", "v(C2)"]
    assert compare(SHADOW, timeout=120).ok
