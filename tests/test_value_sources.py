"""``Ename n+ n- VALUE={expr}`` and ``Gname n+ n- VALUE={expr}`` (also spelled ``vol=``,
``cur=``) as ngspice reads them: its front end turns each into a B source ``V={expr}``
(``I={expr}``) between the same nodes (inpcom.c), so pelcs reads them as B sources
(netlist.behavioural): linear expressions, and comparators that drive switch controls; POLY
sources with affine polynomials, and control pairs written in parentheses. Each
deck is run side by side with ngspice."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.errors import NetlistError
from pelcs.api import simulate

# E doubles the input, G turns it into a current through 1 kOhm: v(e) = 2 v(in),
# v(g) = v(in) (G's current flows from n+ through the source to n-)
LINEAR = """value sources
V1 in 0 SIN(0 1 1k)
E1 e 0 VALUE={2*V(in)}
Re e 0 1k
G1 0 g VALUE = {V(in)/1k}
Rg g 0 1k
.tran 10u 2m
.end
"""

# a buck whose PWM comparator is an E VALUE: duty 0.4 of 12 V
BUCK = """buck, E VALUE comparator
Vin in 0 DC 12
Vramp ramp 0 PULSE(0 1 0 9.99u 10n 0 10u)
Vref ref 0 DC 0.4
E1 g 0 VALUE={V(ref) > V(ramp) ? 5 : 0}
S1 in sw g 0 sm
.model sm SW(VT=2.5 VH=0 RON=10m ROFF=1meg)
D1 0 sw dm
.model dm D(IS=1e-14 RS=10m)
L1 sw out 100u
C1 out 0 100u
R1 out 0 5
.tran 0.1u 2m
.end
"""


def test_linear_value_sources(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    res = simulate(LINEAR, probes=["v(in)", "v(e)", "v(g)"])
    assert np.allclose(res.y[:, 1], 2 * res.y[:, 0], atol=1e-9)
    assert np.allclose(res.y[:, 2], res.y[:, 0], atol=1e-9)
    ng = ngspice_wrdata(LINEAR, ["v(in)", "v(e)", "v(g)"], tmp_path)
    assert np.allclose(ng[:, 3], 2 * ng[:, 1], atol=1e-6)
    assert np.allclose(ng[:, 5], ng[:, 1], atol=1e-6)


def test_a_value_comparator_drives_a_buck(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    ng = ngspice_wrdata(BUCK, ["v(out)"], tmp_path)
    t0 = ng[-1, 0] / 2
    keep = ng[:, 0] >= t0
    want = np.trapezoid(ng[keep, 1], ng[keep, 0]) / (ng[-1, 0] - t0)
    res = simulate(BUCK, probes=["v(out)"], devices="pwl")
    keep = res.t >= t0
    got = np.trapezoid(res.y[keep, 0], res.t[keep]) / (res.t[-1] - t0)
    assert abs(got - want) <= 0.02 * want, (got, want)


def test_value_needs_braces_as_in_ngspice():
    # (ngspice stops at a VALUE expression without its '{': "mal formed E source")
    with pytest.raises(NetlistError, match="nonlinear or behavioural E source"):
        simulate(LINEAR.replace("VALUE={2*V(in)}", "VALUE=2*V(in)"))


# SPICE2 POLY sources with affine polynomials: ngspice hands the coefficients to its
# spice2poly code model as written, p0 first (so POLY(1) a 0 2 is 2 V, a constant)
POLYS = """poly sources
Va a 0 DC 1.5
Vc c 0 DC 0.25
Vs a s DC 0
Rs s 0 1k
E1 e1 0 POLY(1) a 0 2
Re1 e1 0 1k
E2 e2 0 POLY(2) a 0 (c,0) 0.5 2 3
Re2 e2 0 1k
G1 0 g1 POLY(2) a 0 c 0 0 1m 2m
Rg1 g1 0 1k
H1 h1 0 POLY(1) Vs 0 1k
Rh1 h1 0 1k
F1 0 f1 POLY(1) Vs 1m 2
Rf1 f1 0 1k
.tran 1u 10u
.end
"""
POLY_PROBES = ["v(e1)", "v(e2)", "v(g1)", "v(h1)", "v(f1)"]


def test_affine_poly_sources(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    want = [2.0, 0.5 + 2 * 1.5 + 3 * 0.25, 1e-3 * 1.5e3 + 2e-3 * 0.25e3, 1.5, 1.0 + 2 * 1.5]
    res = simulate(POLYS, probes=POLY_PROBES)
    assert np.allclose(res.y[-1], want, rtol=1e-9)
    ng = ngspice_wrdata(POLYS, POLY_PROBES, tmp_path)
    assert np.allclose(ng[-1, 1::2], want, rtol=1e-6)


def test_a_nonlinear_poly_is_refused_at_its_coefficient():
    with pytest.raises(NetlistError, match=r"nonlinear POLY\(1\): coefficient '0.1'") as info:
        simulate(POLYS.replace("E1 e1 0 POLY(1) a 0 2", "E1 e1 0 POLY(1) a 0 0 2 0.1"))
    (d,) = info.value.diagnostics
    assert (d.location.line, d.location.column) == (6, 25)


# a control pair in parentheses, as ngspice reads it
PAREN = """control pairs in parentheses
V1 in 0 SIN(0 1 1k)
E1 e 0 (in,0) 2
Re e 0 1k
G1 0 g (in 0) 1m
Rg g 0 1k
.tran 10u 2m
.end
"""


def test_control_pairs_in_parentheses(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    res = simulate(PAREN, probes=["v(in)", "v(e)", "v(g)"])
    assert np.allclose(res.y[:, 1], 2 * res.y[:, 0], atol=1e-12)
    assert np.allclose(res.y[:, 2], res.y[:, 0], atol=1e-12)
    ng = ngspice_wrdata(PAREN, ["v(in)", "v(e)", "v(g)"], tmp_path)
    assert np.allclose(ng[:, 3], 2 * ng[:, 1], atol=1e-6)
    assert np.allclose(ng[:, 5], ng[:, 1], atol=1e-6)


# a clamped error amplifier driving the switch itself: its band (VT 2.5 V) inside the clamp's
# 0..5 V, so the switch turns where the linear expression crosses 2.5 V
CLAMP_BUCK = BUCK.replace("E1 g 0 VALUE={V(ref) > V(ramp) ? 5 : 0}",
                          "B1 g 0 V={max(0, min(5, 2500*(V(ref)-V(ramp))+2.5))}")


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_a_clamp_driving_a_switch_agrees_with_ngspice(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    ng = ngspice_wrdata(CLAMP_BUCK, ["v(out)"], tmp_path)
    t0 = ng[-1, 0] / 2
    keep = ng[:, 0] >= t0
    want = np.trapezoid(ng[keep, 1], ng[keep, 0]) / (ng[-1, 0] - t0)
    res = simulate(CLAMP_BUCK, probes=["v(out)"], devices="pwl")
    assert any("B1: clamp" in n and "the output node g is gone" in n for n in res.notes)
    keep = res.t >= t0
    got = np.trapezoid(res.y[keep, 0], res.t[keep]) / (res.t[-1] - t0)
    assert abs(got - want) <= 0.02 * want, (got, want)


def test_a_clamp_that_decides_the_switch_is_a_limiter():
    # the clamp's 5 V never reaches VT = 6 V: the limiter keeps S1 off, as in ngspice
    res = simulate(CLAMP_BUCK.replace("SW(VT=2.5", "SW(VT=6"), probes=["v(out)", "v(g)"])
    assert any("B1: clamp" in n and "built as an ideal limiter (switch S1 reads at VT 6 V"
               in n for n in res.notes)
    assert np.abs(res.y[:, 0]).max() < 1e-12 and res.y[:, 1].max() == pytest.approx(5, abs=1e-9)
