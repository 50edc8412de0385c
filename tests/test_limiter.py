"""B sources that clamp a linear expression, ``max(lo, min(hi, e))``, where the clamp cannot
be folded into what reads it: the ideal-diode limiter of netlist.limiter. Checked against the
clamp computed from the run's own inputs (exact at every point), an analytic integrator,
ngspice side by side, and the deck written back for ngspice."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from netlist.writer import write_circuit

# a clamped amplifier driving an RC load: its output is loaded, so it cannot be folded
RC_LOAD = """clamped amplifier into an RC
V1 in 0 SIN(0 1 1k)
B1 out 0 V = max(-1, min(2, 3*v(in) + 0.5))
R1 out cap 1k
C1 cap 0 100n
.tran 1u 3m uic
.end
"""


def _clamp(x, lo, hi):
    return np.minimum(hi, np.maximum(lo, x))


def test_the_limiter_is_the_clamp_at_every_point():
    c = parse_string(RC_LOAD)
    assert any("B1: clamp" in n and "built as an ideal limiter (it feeds R1)" in n
               for n in c.notes)
    res = simulate_circuit(c, probes=["v(in)", "v(out)", "i(B1)", "i(R1)"])
    res.raise_if_error()
    want = _clamp(3 * res["v(in)"] + 0.5, -1, 2)
    assert np.abs(res["v(out)"] - want).max() <= 1e-9
    assert np.isclose(res["v(out)"], 2).any() and np.isclose(res["v(out)"], -1).any()
    # the B's current is the load's (i(B1) flows from n+ through the source to n-)
    assert np.allclose(res["i(B1)"], -res["i(R1)"], atol=1e-12)


def test_the_limiter_against_ngspice_and_written_back(tmp_path, ngspice):
    c = parse_string(RC_LOAD)
    res = simulate_circuit(c, probes=["v(out)", "v(cap)"])
    res.raise_if_error()
    ng = ngspice_wrdata(RC_LOAD, ["v(out)", "v(cap)"], tmp_path)
    t = ng[:, 0]
    for col, probe in ((1, "v(out)"), (3, "v(cap)")):
        assert np.interp(t, res.t, res[probe]) == pytest.approx(ng[:, col], abs=5e-3)
    # ngspice is given the B source, once, in place of the limiter's elements
    deck = write_circuit(c)
    b_lines = [ln for ln in deck.splitlines() if ln.lower().startswith("b1 ")]
    assert len(b_lines) == 1 and "max(-1.0, min(2.0, 3.0*v(in) + 0.5))" in b_lines[0]
    assert "#" not in deck.replace("* written by pelcs", "")
    again = ngspice_wrdata(deck, ["v(cap)"], tmp_path)
    assert np.interp(t, again[:, 0], again[:, 1]) == pytest.approx(ng[:, 3], abs=1e-6)


# ngspice's examples/vdmos/dcdc.sp error amplifier: gain 10k clamped to 0..5 V, integrating
# through C2; 1 V in against 2.5 V: the output ramps at (2.5 - 1)/(R3 C2) = 3000 V/s until it
# clamps at 5 V (1.667 ms)
INTEGRATOR = """clamped integrator
V1 in 0 1
V2 ref 0 2.5
R3 in x 10k
C2 err x 50n
B1 err 0 V = max(0, min(5, V(ref,x)*10k))
.tran 10u 3m uic
.end
"""


def test_the_clamped_integrator_against_the_analytic_ramp_and_ngspice(tmp_path, ngspice):
    res = simulate_circuit(parse_string(INTEGRATOR), probes=["v(err)", "v(x)"])
    res.raise_if_error()
    # with the gain's finite 10k the ramp starts from err = 2.5 * 10k/(1 + 10k) and its slope
    # is 3000 V/s (x held at 2.5 V - err/10k)
    e0 = 2.5 * 1e4 / (1 + 1e4)
    want = np.minimum(5.0, e0 + 3000.0 * res.t)
    assert np.abs(res["v(err)"] - want).max() <= 2e-3
    ng = ngspice_wrdata(INTEGRATOR, ["v(err)"], tmp_path)
    assert np.interp(ng[:, 0], res.t, res["v(err)"]) == pytest.approx(ng[:, 1], abs=2e-3)


def test_a_current_clamp_and_a_clamp_between_nodes():
    deck = """current and floating clamps
V1 in 0 SIN(0 2 1k)
B1 0 a I = max(0, v(in)*1m)
Ra a 0 1k
V2 ref 0 1
B2 b ref V = min(0.5, v(in))
Rb b 0 1k
.tran 1u 2m
.end
"""
    res = simulate_circuit(parse_string(deck), probes=["v(in)", "v(a)", "v(b)"])
    res.raise_if_error()
    assert np.abs(res["v(a)"] - np.maximum(0, res["v(in)"])).max() <= 1e-9
    assert np.abs(res["v(b)"] - (1 + np.minimum(0.5, res["v(in)"]))).max() <= 1e-9


def test_pwl_devices_keep_the_limiter_ideal():
    deck = RC_LOAD.replace("R1 out cap 1k", "R1 out cap 1k\nD1 cap k dm\nRk k 0 1k\n"
                                             ".model dm D(IS=1e-14)")
    from netlist.studies.realistic import simulate_devices

    res = simulate_devices(parse_string(deck), devices="pwl", probes=["v(in)", "v(out)"])
    res.raise_if_error()
    fitted = " ".join(n for n in res.notes if n.startswith("pwl:"))
    assert "D1:" in fitted and "B1#" not in fitted
    want = _clamp(3 * res["v(in)"] + 0.5, -1, 2)
    assert np.abs(res["v(out)"] - want).max() <= 1e-9


def test_losses_leave_the_limiter_out():
    # a sine clamped to ±0.5 V into a 1 kΩ load: the load takes mean(clamp(sin)²)/1 kΩ =
    # (1/3 - √3/(4π)) mW; the limiter's inner resistor and diodes are pelcs's construction
    # of an ideal source, not parts that lose power
    deck = """clamped sine into a load
V1 in 0 SIN(0 1 1k)
R2 in 0 1k
B1 out 0 V = max(-0.5, min(0.5, v(in)))
Rl out 0 1k
.tran 1u 5m
.end
"""
    from netlist.studies.realistic import simulate_devices

    res = simulate_devices(parse_string(deck), losses=True, load="Rl", probes=["v(out)"])
    res.raise_if_error()
    rep = res.losses
    assert not any("#" in k for k in (*rep.devices, *rep.resistors)), rep.to_dict()
    assert rep.load == "Rl"
    assert rep.p_out == pytest.approx((1 / 3 - np.sqrt(3) / (4 * np.pi)) * 1e-3, rel=1e-3)


def test_check_does_not_take_the_limiter_for_devices(ngspice):
    # RC_LOAD has no device at all: its only source peaks at 1 V (the limiter's 2 V rail is
    # no source of the circuit), no drop widens the tolerances, and nothing calls for
    # piecewise-linear devices (the limiter's ideal diodes are not ngspice's: it runs the B
    # source)
    from ngspice_checks.compare import compare

    cmp = compare(RC_LOAD, timeout=60)
    assert cmp.ok
    assert cmp.nonideal.v_ref == pytest.approx(1.0)
    assert not cmp.nonideal.diode_drops and cmp.devices == "ideal"


# a clamp summed with linear terms (a PI output clamped, then added to an armature's
# back-EMF and IR drop): the clamp on a node of its own, the sum a linear source reading it
SUMMED = """a clamp summed with linear terms
V1 in 0 SIN(0 3 1k)
B1 out 0 V = min(2, max(-1, v(in))) + 0.5*v(in) - 0.25
R1 out 0 1k
B2 0 iout I = 1m*(max(0, 2*v(in) - 1) - v(in))
R2 iout 0 1k
.tran 1u 2m
.end
"""


def test_a_clamp_summed_with_linear_terms_is_a_limiter_on_a_node_of_its_own():
    c = parse_string(SUMMED)
    for name in ("B1#k1", "B2#k1"):
        assert any(f"{name}: clamp" in n and "built as an ideal limiter" in n
                   for n in c.notes), c.notes
    res = simulate_circuit(c, probes=["v(in)", "v(out)", "v(iout)"])
    res.raise_if_error()
    vin = res["v(in)"]
    assert np.abs(res["v(out)"] - (_clamp(vin, -1, 2) + 0.5 * vin - 0.25)).max() <= 1e-9
    # I = 1 mA/V * (...) into 1 kOhm: the volts of the expression
    assert np.abs(res["v(iout)"] - (np.maximum(0, 2 * vin - 1) - vin)).max() <= 1e-9
    assert (vin > 2).any() and (vin < -1).any()


@pytest.mark.parametrize("expr", ["min(2, v(in)) * v(in) + v(in)",
                                  "min(2, v(in)*v(in)) + v(in)"])
def test_a_clamp_in_a_nonlinear_sum_is_still_refused(expr):
    from netlist.errors import NetlistError

    with pytest.raises(NetlistError, match="B1"):
        parse_string(SUMMED.replace("min(2, max(-1, v(in))) + 0.5*v(in) - 0.25", expr))


def test_a_clamp_of_constant_value_beside_one_summed_is_its_constant():
    # min(0, max(1, x)) is 0 whatever x: a constant, with nothing inside it to build a
    # limiter for (its max(1, v(in)) was built as one, and the sum refused)
    c = parse_string(SUMMED.replace("- 0.25", "+ min(0, max(1, v(in))) - 0.25"))
    res = simulate_circuit(c, probes=["v(in)", "v(out)"])
    res.raise_if_error()
    vin = res["v(in)"]
    assert np.abs(res["v(out)"] - (_clamp(vin, -1, 2) + 0.5 * vin - 0.25)).max() <= 1e-9
