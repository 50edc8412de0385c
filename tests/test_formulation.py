"""Formulation (circuit -> switched LCS) against hand-derived LCS.

Every expected matrix below is derived on paper in the comments, from Kirchhoff's laws and the
conventions of docs/architecture.md:

- states i(L) (n+ -> n- through L) and v(C) = v(n+) - v(n-), netlist order;
- a diode with λ = current has λ = i(D) (anode -> cathode) and w = v(cathode) - v(anode);
  with λ = voltage, λ = v(cathode) - v(anode) and w = i(D);
- i(X) flows from n+ through X to n- (SPICE), so i(Vin) of a source that delivers power is
  negative.

Besides the matrices themselves, the tests compare invariants that do not depend on sign or
ordering choices: the eigenvalues of A, the transfer function C (sI - A)^-1 B + D at a few
points and the λ type chosen per diode.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import netlist.formulation as fm
from lcs.model import LAMBDA_CURRENT as CUR
from lcs.model import LAMBDA_VOLTAGE as VOL
from lcs.signals import Sin
from netlist.circuit import (
    Capacitor,
    Cccs,
    Ccvs,
    Circuit,
    Coupling,
    CurrentSource,
    Diode,
    Inductor,
    Model,
    Resistor,
    Switch,
    Vccs,
    Vcvs,
    VoltageSource,
)
from netlist.errors import NetlistError
from netlist.formulation import formulate, storage_matrix

# ----------------------------------------------------------------------------------------
# helpers


def circuit(*elements, models=None) -> Circuit:
    return Circuit(title="test", elements=list(elements), models=models or {})


SW_MODEL = {"swideal": Model("SWIDEAL", "SW", {"vt": 0.5, "vh": 0.1})}


def gate_switch(name, a, b):
    return Switch(name, (a, b), control=("gate", "0"), model="SWIDEAL")


def close(actual, expected, rtol=1e-9):
    actual = np.asarray(actual, dtype=float)
    expected = np.asarray(expected, dtype=float)
    assert actual.shape == expected.shape, (actual.shape, expected.shape)
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    np.testing.assert_allclose(actual, expected, rtol=rtol, atol=rtol * scale)


def transfer(A, B, C, D, s):
    """C (sI - A)^-1 B + D at one complex s."""
    A = np.asarray(A, dtype=float)
    n = A.shape[0]
    return np.asarray(C) @ np.linalg.solve(s * np.eye(n) - A, np.asarray(B)) + np.asarray(D)


def check_lcs(lcs, A, B, C, D, E, F, kinds):
    """Compare one mode with hand matrices: invariants first, then every entry."""
    assert [p.lam for p in lcs.pairs] == list(kinds)
    eig = np.sort_complex(np.linalg.eigvals(np.asarray(A, dtype=float)))
    got = np.sort_complex(np.linalg.eigvals(lcs.A))
    np.testing.assert_allclose(got, eig, rtol=1e-8, atol=1e-8 * max(1, np.abs(eig).max()))
    if lcs.m and lcs.n:
        for s in (1e3j, 3.7e4 + 2e4j, 1e6):
            close(transfer(lcs.A, lcs.B, lcs.C, lcs.D, s).real,
                  transfer(A, B, C, D, s).real, 1e-7)
            close(transfer(lcs.A, lcs.B, lcs.C, lcs.D, s).imag,
                  transfer(A, B, C, D, s).imag, 1e-7)
    for name, want in zip("ABCDEF", (A, B, C, D, E, F), strict=True):
        got = getattr(lcs, name)
        close(got, np.asarray(want, dtype=float).reshape(got.shape))


# ----------------------------------------------------------------------------------------
# DC-DC converters with an ideal switch S1 (gate from Vg) and an ideal diode D1


def boost(L=100e-6, C=100e-6, R=20.0):
    # Vin -- L1 -- sw ; S1 sw-0 ; D1 sw -> out ; C1 || R1 at out
    return circuit(
        VoltageSource("Vin", ("in", "0"), dc=12.0),
        Inductor("L1", ("in", "sw"), value=L),
        gate_switch("S1", "sw", "0"),
        Diode("D1", ("sw", "out")),
        Capacitor("C1", ("out", "0"), value=C),
        Resistor("R1", ("out", "0"), value=R),
        VoltageSource("Vg", ("gate", "0"), dc=0.0),
        models=SW_MODEL,
    )


def test_boost_names_and_switches():
    sys = formulate(boost())
    assert sys.states == ("i(L1)", "v(C1)")
    assert sys.inputs == ("Vin", "Vg")
    assert sys.diodes == ("D1",)
    (sw,) = sys.switches
    assert (sw.name, sw.control, sw.vt, sw.vh) == ("S1", "v(gate,0)", 0.5, 0.1)


def test_boost_switch_off():
    # S1 open: node sw holds only L1 and D1, a cutset, so D1 must carry a voltage-type λ:
    #   λ = v(out) - v(sw)  ->  v(sw) = x2 - λ              (x = (iL, vC), u = (Vin, Vg))
    #   L diL/dt = Vin - v(sw) = Vin - vC + λ
    #   C dvC/dt = i(D1) - vC/R,  i(D1) = iL (KCL at sw)
    #   w = i(D1) = iL
    L, C, R = 100e-6, 100e-6, 20.0
    lcs = formulate(boost(L, C, R)).mode({"S1": False})
    check_lcs(
        lcs,
        A=[[0, -1 / L], [1 / C, -1 / (R * C)]],
        B=[[1 / L], [0]],
        C=[[1, 0]], D=[[0]],
        E=[[1 / L, 0], [0, 0]], F=[[0, 0]],
        kinds=[VOL],
    )


def test_boost_switch_on():
    # S1 closed: v(sw) = 0; D1 current-type (λ = i(D1), nothing forces otherwise):
    #   L diL/dt = Vin
    #   C dvC/dt = λ - vC/R
    #   w = v(out) - v(sw) = vC
    L, C, R = 100e-6, 100e-6, 20.0
    lcs = formulate(boost(L, C, R)).mode({"S1": True})
    check_lcs(
        lcs,
        A=[[0, 0], [0, -1 / (R * C)]],
        B=[[0], [1 / C]],
        C=[[0, 1]], D=[[0]],
        E=[[1 / L, 0], [0, 0]], F=[[0, 0]],
        kinds=[CUR],
    )


def buck(L=50e-6, C=47e-6, R=5.0):
    # Vin -- S1 -- sw ; D1 0 -> sw (freewheeling) ; L1 sw-out ; C1 || R1 at out
    return circuit(
        VoltageSource("Vin", ("in", "0"), dc=24.0),
        gate_switch("S1", "in", "sw"),
        Diode("D1", ("0", "sw")),
        Inductor("L1", ("sw", "out"), value=L),
        Capacitor("C1", ("out", "0"), value=C),
        Resistor("R1", ("out", "0"), value=R),
        VoltageSource("Vg", ("gate", "0"), dc=0.0),
        models=SW_MODEL,
    )


def test_buck_switch_on():
    # S1 closed: v(sw) = Vin; D1 current-type, w = v(sw) - v(0) = Vin (F column of Vin):
    #   L diL/dt = Vin - vC
    #   C dvC/dt = iL - vC/R
    L, C, R = 50e-6, 47e-6, 5.0
    lcs = formulate(buck(L, C, R)).mode({"S1": True})
    check_lcs(
        lcs,
        A=[[0, -1 / L], [1 / C, -1 / (R * C)]],
        B=[[0], [0]],
        C=[[0, 0]], D=[[0]],
        E=[[1 / L, 0], [0, 0]], F=[[1, 0]],
        kinds=[CUR],
    )


def test_buck_switch_off():
    # S1 open: node sw holds D1 and L1 only (cutset) -> D1 voltage-type,
    #   λ = v(sw) - v(0)  ->  v(sw) = λ
    #   L diL/dt = λ - vC ;  C dvC/dt = iL - vC/R
    #   w = i(D1) (0 -> sw) = iL (KCL at sw)
    L, C, R = 50e-6, 47e-6, 5.0
    lcs = formulate(buck(L, C, R)).mode({"S1": False})
    check_lcs(
        lcs,
        A=[[0, -1 / L], [1 / C, -1 / (R * C)]],
        B=[[1 / L], [0]],
        C=[[1, 0]], D=[[0]],
        E=[[0, 0], [0, 0]], F=[[0, 0]],
        kinds=[VOL],
    )


def buck_boost(L=80e-6, C=100e-6, R=12.0):
    # inverting buck-boost: Vin -- S1 -- sw ; L1 sw-0 ; D1 out -> sw ; C1 || R1 at out
    return circuit(
        VoltageSource("Vin", ("in", "0"), dc=12.0),
        gate_switch("S1", "in", "sw"),
        Inductor("L1", ("sw", "0"), value=L),
        Diode("D1", ("out", "sw")),
        Capacitor("C1", ("out", "0"), value=C),
        Resistor("R1", ("out", "0"), value=R),
        VoltageSource("Vg", ("gate", "0"), dc=0.0),
        models=SW_MODEL,
    )


def test_buck_boost_switch_on():
    # S1 closed: v(sw) = Vin, L diL/dt = Vin.
    # D1 current-type: λ = i(D1) leaves node out, so C dvC/dt = -vC/R - λ;
    # w = v(sw) - v(out) = Vin - vC.
    L, C, R = 80e-6, 100e-6, 12.0
    lcs = formulate(buck_boost(L, C, R)).mode({"S1": True})
    check_lcs(
        lcs,
        A=[[0, 0], [0, -1 / (R * C)]],
        B=[[0], [-1 / C]],
        C=[[0, -1]], D=[[0]],
        E=[[1 / L, 0], [0, 0]], F=[[1, 0]],
        kinds=[CUR],
    )


def test_buck_boost_switch_off():
    # S1 open: node sw holds L1 and D1 (cutset) -> D1 voltage-type,
    #   λ = v(sw) - v(out)  ->  v(sw) = vC + λ
    #   L diL/dt = v(sw) = vC + λ
    #   i(D1) = iL (KCL at sw), C dvC/dt = -vC/R - iL;  w = iL
    L, C, R = 80e-6, 100e-6, 12.0
    lcs = formulate(buck_boost(L, C, R)).mode({"S1": False})
    check_lcs(
        lcs,
        A=[[0, 1 / L], [-1 / C, -1 / (R * C)]],
        B=[[1 / L], [0]],
        C=[[1, 0]], D=[[0]],
        E=[[0, 0], [0, 0]], F=[[0, 0]],
        kinds=[VOL],
    )


def cuk(L1=100e-6, C1=10e-6, L2=200e-6, C2=47e-6, R=10.0):
    # Vin -- L1 -- a ; S1 a-0 ; C1 a-b ; D1 b -> 0 ; L2 b-out ; C2 || R1 at out
    return circuit(
        VoltageSource("Vin", ("in", "0"), dc=12.0),
        Inductor("L1", ("in", "a"), value=L1),
        gate_switch("S1", "a", "0"),
        Capacitor("C1", ("a", "b"), value=C1),
        Diode("D1", ("b", "0")),
        Inductor("L2", ("b", "out"), value=L2),
        Capacitor("C2", ("out", "0"), value=C2),
        Resistor("R1", ("out", "0"), value=R),
        VoltageSource("Vg", ("gate", "0"), dc=0.0),
        models=SW_MODEL,
    )


CUK = dict(L1=100e-6, C1=10e-6, L2=200e-6, C2=47e-6, R=10.0)


def test_cuk_switch_on():
    # x = (i1, v1, i2, v2) = (i(L1), v(C1), i(L2), v(C2)).
    # S1 closed: v(a) = 0, v(b) = -v1. D1 current-type (λ = i(D1), b -> 0):
    #   L1 di1/dt = Vin
    #   KCL at b: i(C1) = λ + i2        -> C1 dv1/dt = λ + i2
    #   L2 di2/dt = v(b) - v(out) = -v1 - v2
    #   C2 dv2/dt = i2 - v2/R
    #   w = v(0) - v(b) = v1
    p = CUK
    lcs = formulate(cuk(**p)).mode({"S1": True})
    check_lcs(
        lcs,
        A=[[0, 0, 0, 0],
           [0, 0, 1 / p["C1"], 0],
           [0, -1 / p["L2"], 0, -1 / p["L2"]],
           [0, 0, 1 / p["C2"], -1 / (p["R"] * p["C2"])]],
        B=[[0], [1 / p["C1"]], [0], [0]],
        C=[[0, 1, 0, 0]], D=[[0]],
        E=[[1 / p["L1"], 0], [0, 0], [0, 0], [0, 0]], F=[[0, 0]],
        kinds=[CUR],
    )


def test_cuk_switch_off():
    # S1 open: C1 joins a and b, which meet the rest only through L1, D1, L2 -> D1 must be
    # voltage-type: λ = v(0) - v(b), v(b) = -λ, v(a) = v1 - λ.
    #   L1 di1/dt = Vin - v(a) = Vin - v1 + λ
    #   C1 dv1/dt = i(C1) = i1 (KCL at a)
    #   L2 di2/dt = v(b) - v(out) = -λ - v2
    #   C2 dv2/dt = i2 - v2/R
    #   w = i(D1) = i(C1) - i2 = i1 - i2 (KCL at b)
    p = CUK
    lcs = formulate(cuk(**p)).mode({"S1": False})
    check_lcs(
        lcs,
        A=[[0, -1 / p["L1"], 0, 0],
           [1 / p["C1"], 0, 0, 0],
           [0, 0, 0, -1 / p["L2"]],
           [0, 0, 1 / p["C2"], -1 / (p["R"] * p["C2"])]],
        B=[[1 / p["L1"]], [0], [-1 / p["L2"]], [0]],
        C=[[1, 0, -1, 0]], D=[[0]],
        E=[[1 / p["L1"], 0], [0, 0], [0, 0], [0, 0]], F=[[0, 0]],
        kinds=[VOL],
    )


# ----------------------------------------------------------------------------------------
# Diode bridges


def bridge_tank(L=1e-3, C=1e-6, R=50.0):
    # I1 injects into a; L1 and C1 in parallel from a to b; bridge D1 a->p, D2 b->p,
    # D3 0->a, D4 0->b; R1 from p to 0 (DC side, its negative rail is ground).
    return circuit(
        CurrentSource("I1", ("b", "a"), dc=0.0),
        Inductor("L1", ("a", "b"), value=L),
        Capacitor("C1", ("a", "b"), value=C),
        Diode("D1", ("a", "p")),
        Diode("D2", ("b", "p")),
        Diode("D3", ("0", "a")),
        Diode("D4", ("0", "b")),
        Resistor("R1", ("p", "0"), value=R),
    )


def test_bridge_across_lc_tank():
    # All four current-type is impossible: the tank {a, b} meets the DC side only through the
    # diodes (their currents would be tied by KCL, the tank's potential undetermined). The
    # first single voltage-type diode in netlist order, D1, works:
    #   λ1 = v(p) - v(a); λ2, λ3, λ4 currents; x = (i, v) = (i(L1), v(C1)); u = I1.
    # KCL at p:  i(D1) + λ2 = v(p)/R
    # KCL at a:  i(C1) = u - i - i(D1) + λ3
    # KCL at b:  i + i(C1) + λ4 = u + λ2  -> with the line above: i(D1) = λ3 + λ4 - λ2
    # so v(p) = R (λ3 + λ4), v(a) = v(p) - λ1, v(b) = v(a) - v.
    #   di/dt = v / L
    #   C dv/dt = i(C1) = u - i + λ2 - λ4
    #   w1 = i(D1)       = -λ2 + λ3 + λ4
    #   w2 = v(p) - v(b) = λ1 + v
    #   w3 = v(a) - 0    = -λ1 + R λ3 + R λ4
    #   w4 = v(b) - 0    = -λ1 + R λ3 + R λ4 - v
    L, C, R = 1e-3, 1e-6, 50.0
    sys = formulate(bridge_tank(L, C, R))
    assert sys.switches == ()
    lcs = sys.mode()
    check_lcs(
        lcs,
        A=[[0, 1 / L], [-1 / C, 0]],
        B=[[0, 0, 0, 0], [0, 1 / C, 0, -1 / C]],
        C=[[0, 0], [0, 1], [0, 0], [0, -1]],
        D=[[0, -1, 1, 1], [1, 0, 0, 0], [-1, 0, R, R], [-1, 0, R, R]],
        E=[[0], [1 / C]], F=[[0], [0], [0], [0]],
        kinds=[VOL, CUR, CUR, CUR],
    )
    # The lossless tank: eigenvalues ±j/sqrt(LC).
    close(np.sort(np.linalg.eigvals(lcs.A).imag), [-1 / math.sqrt(L * C), 1 / math.sqrt(L * C)])


PRC = dict(Lr=150e-6, Cr=68e-9, Lf=0.4e-3, Cf=2.2e-6, R=33.0)


def parallel_resonant(Lr, Cr, Lf, Cf, R):
    # Vs (square wave) from s to b; Lr s->a; Cr a-b (the rectifier sits across Cr);
    # bridge D1 a->p, D2 b->p, D3 0->a, D4 0->b; Lf p->o; Cf || R from o to 0.
    return circuit(
        VoltageSource("Vs", ("s", "b"), dc=0.0),
        Inductor("Lr", ("s", "a"), value=Lr),
        Capacitor("Cr", ("a", "b"), value=Cr),
        Diode("D1", ("a", "p")),
        Diode("D2", ("b", "p")),
        Diode("D3", ("0", "a")),
        Diode("D4", ("0", "b")),
        Inductor("Lf", ("p", "o"), value=Lf),
        Capacitor("Cf", ("o", "0"), value=Cf),
        Resistor("R", ("o", "0"), value=R),
    )


def test_parallel_resonant_converter():
    # Which λ types: with one voltage-type diode either p stays in the cutset {D1, D2, Lf}
    # (D3 or D4 alone) or the tank side {s, a, b, p} meets ground only through D3, D4, Lf
    # (D1 or D2 alone); {D1, D2} closes the loop D1-D2-Cr. So the first working assignment is
    # {D1, D3} voltage-type:
    #   λ1 = v(p) - v(a), λ3 = v(a) - 0, λ2 = i(D2), λ4 = i(D4).
    # x = (ir, vr, if, vf) = (i(Lr), v(Cr), i(Lf), v(Cf)), u = Vs = v(s) - v(b).
    # Potentials: v(a) = λ3, v(p) = λ1 + λ3, v(b) = λ3 - vr, v(s) = λ3 - vr + u, v(o) = vf.
    #   Lr dir/dt = v(s) - v(a) = -vr + u
    #   Lf dif/dt = v(p) - v(o) = λ1 + λ3 - vf
    #   Cf dvf/dt = if - vf/R
    # KCL at p: i(D1) + λ2 = if.   i(Vs) = -ir (KCL at s).
    # KCL at b: i(Cr) + λ4 + i(Vs) = λ2  -> i(Cr) = ir + λ2 - λ4 -> Cr dvr/dt = ir + λ2 - λ4
    # KCL at a: ir + i(D3) = i(Cr) + i(D1) -> i(D3) = if - λ4
    #   w1 = i(D1) = if - λ2;  w2 = v(p) - v(b) = λ1 + vr
    #   w3 = i(D3) = if - λ4;  w4 = v(b) - 0 = λ3 - vr
    p = PRC
    Lr, Cr, Lf, Cf, R = p["Lr"], p["Cr"], p["Lf"], p["Cf"], p["R"]
    lcs = formulate(parallel_resonant(**p)).mode()
    assert lcs.states == ("i(Lr)", "v(Cr)", "i(Lf)", "v(Cf)")
    assert lcs.inputs == ("Vs",)
    check_lcs(
        lcs,
        A=[[0, -1 / Lr, 0, 0],
           [1 / Cr, 0, 0, 0],
           [0, 0, 0, -1 / Lf],
           [0, 0, 1 / Cf, -1 / (R * Cf)]],
        B=[[0, 0, 0, 0],
           [0, 1 / Cr, 0, -1 / Cr],
           [1 / Lf, 0, 1 / Lf, 0],
           [0, 0, 0, 0]],
        C=[[0, 0, 1, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0]],
        D=[[0, -1, 0, 0], [1, 0, 0, 0], [0, 0, 0, -1], [0, 0, 1, 0]],
        E=[[1 / Lr], [0], [0], [0]],
        F=[[0], [0], [0], [0]],
        kinds=[VOL, CUR, VOL, CUR],
    )
    # Resonance of the tank: ±j/sqrt(Lr Cr) = ±j 314 153 rad/s among the eigenvalues.
    eig = np.linalg.eigvals(lcs.A)
    w0 = 1 / math.sqrt(Lr * Cr)
    assert np.min(np.abs(eig - 1j * w0)) < 1e-6 * w0
    # The lossless bridge makes D skew-symmetric.
    close(lcs.D + lcs.D.T, np.zeros((4, 4)))
    # Probes: the rectifier output and the source current.
    out = formulate(parallel_resonant(**p)).outputs((), ["v(p)", "i(Vs)", "v(o)", "i(D2)"])
    close(out.Cy, [[0, 0, 0, 0], [-1, 0, 0, 0], [0, 0, 0, 1], [0, 0, 0, 0]])
    close(out.Dy, [[1, 0, 1, 0], [0, 0, 0, 0], [0, 0, 0, 0], [0, 1, 0, 0]])
    close(out.Fy, np.zeros((4, 1)))


# ----------------------------------------------------------------------------------------
# Linear circuits: RC, RLC, coupled inductors, controlled sources


def test_rc_low_pass():
    # V1 -- R1 -- out ; C1 out-0.   C dv/dt = (V1 - v)/R.
    R, C = 1e3, 1e-6
    sys = formulate(circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Resistor("R1", ("in", "out"), value=R),
        Capacitor("C1", ("out", "0"), value=C),
    ))
    lcs = sys.mode()
    assert (lcs.states, lcs.inputs, lcs.pairs) == (("v(C1)",), ("V1",), ())
    close(lcs.A, [[-1 / (R * C)]])
    close(lcs.E, [[1 / (R * C)]])
    assert lcs.B.shape == (1, 0) and lcs.C.shape == (0, 1) and lcs.F.shape == (0, 1)
    out = sys.outputs((), ["v(out)", "v(in,out)", "i(R1)", "i(C1)", "i(V1)", "v(C1)"])
    close(out.Cy, [[1], [-1], [-1 / R], [-1 / R], [1 / R], [1]])
    close(out.Fy, [[0], [1], [1 / R], [1 / R], [-1 / R], [0]])
    assert out.Dy.shape == (6, 0)
    assert out.names == ("v(out)", "v(in,out)", "i(R1)", "i(C1)", "i(V1)", "v(C1)")


def rlc_with_sources(R=2.0, L=1e-3, C=1e-6):
    # V1 -- R1 -- a -- L1 -- out ; C1 out-0 ; I1 injects into out ; D1 out -> k ; V2 k-0.
    return circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Resistor("R1", ("in", "a"), value=R),
        Inductor("L1", ("a", "out"), value=L),
        Capacitor("C1", ("out", "0"), value=C),
        CurrentSource("I1", ("0", "out"), dc=0.0),
        Diode("D1", ("out", "k")),
        VoltageSource("V2", ("k", "0"), dc=5.0),
    )


def test_rlc_with_sources_and_clamp_diode():
    # D1 closes the loop C1 - D1 - V2, so it is current-type (also the preferred type).
    # x = (i, v), u = (V1, I1, V2), λ = i(D1):
    #   L di/dt = v(a) - v(out) = V1 - R i - v
    #   C dv/dt = i + I1 - λ
    #   w = v(k) - v(out) = V2 - v
    R, L, C = 2.0, 1e-3, 1e-6
    sys = formulate(rlc_with_sources(R, L, C))
    assert sys.inputs == ("V1", "I1", "V2")
    check_lcs(
        sys.mode(),
        A=[[-R / L, -1 / L], [1 / C, 0]],
        B=[[0], [-1 / C]],
        C=[[0, -1]], D=[[0]],
        E=[[1 / L, 0, 0], [0, 1 / C, 0]],
        F=[[0, 0, 1]],
        kinds=[CUR],
    )
    # Probes of every element kind here: i(L1) = i; i(I1) = I1; i(D1) = λ; i(V2): current
    # from k through V2 to 0 = λ (the diode current returns through V2); v(a) = V1 - R i.
    out = sys.outputs((), ["i(L1)", "i(I1)", "i(D1)", "i(V2)", "v(a)", "i(R1)", "i(V1)"])
    close(out.Cy, [[1, 0], [0, 0], [0, 0], [0, 0], [-R, 0], [1, 0], [-1, 0]])
    close(out.Dy, [[0], [0], [1], [1], [0], [0], [0]])
    close(out.Fy, [[0, 0, 0], [0, 1, 0], [0, 0, 0], [0, 0, 0], [1, 0, 0], [0, 0, 0],
                   [0, 0, 0]])


def transformer(L1=1e-3, L2=4e-3, k=0.5, R1=1.0, R2=10.0):
    # V1 -- R1 -- a ; L1 a-0 ; L2 b-0 ; R2 b-0 ; K1 couples L1, L2 (dots at a and b).
    return circuit(
        VoltageSource("V1", ("p", "0"), dc=1.0),
        Resistor("R1", ("p", "a"), value=R1),
        Inductor("L1", ("a", "0"), value=L1),
        Inductor("L2", ("b", "0"), value=L2),
        Resistor("R2", ("b", "0"), value=R2),
        Coupling("K1", (), inductors=("L1", "L2"), k=k),
    )


def test_coupled_inductors():
    # v(L1) = v(a) = V1 - R1 i1 ; v(L2) = v(b) = -R2 i2 (KCL at b).
    # [L1 M; M L2] di/dt = v_L with M = k sqrt(L1 L2) = 0.5 * 2 mH = 1 mH,
    # det = L1 L2 - M^2 = 4e-6 - 1e-6 = 3e-6, inverse = [L2 -M; -M L1] / det:
    #   A = [[-R1 L2, M R2], [M R1, -L1 R2]] / det = [[-4e-3, 1e-2], [1e-3, -1e-2]] / 3e-6
    #   E = [[L2], [-M]] / det = [[4e-3], [-1e-3]] / 3e-6
    lcs = formulate(transformer()).mode()
    assert lcs.states == ("i(L1)", "i(L2)")
    close(lcs.A, np.array([[-4e-3, 1e-2], [1e-3, -1e-2]]) / 3e-6)
    close(lcs.E, np.array([[4e-3], [-1e-3]]) / 3e-6)


def test_floating_transformer_secondary_is_fine():
    # The secondary (L2 || R2 between b and c) has no path to ground: its node voltages are
    # undetermined but its branch voltage is not, so the mode builds and equals the grounded
    # case; probing an absolute secondary voltage is an error, v(b,c) is fine.
    c = transformer()
    c.elements[3] = Inductor("L2", ("b", "c"), value=4e-3)
    c.elements[4] = Resistor("R2", ("b", "c"), value=10.0)
    sys = formulate(c)
    close(sys.mode().A, np.array([[-4e-3, 1e-2], [1e-3, -1e-2]]) / 3e-6)
    out = sys.outputs((), ["v(b,c)"])
    close(out.Cy, [[0, -10.0]])
    with pytest.raises(NetlistError, match="not determined"):
        sys.outputs((), ["v(b)"])


def test_vcvs_inverting_amplifier_driving_rc():
    # V1 -- R1 -- m ; R2 m-o ; E1: v(o) = A0 (v(0) - v(m)) ; Rl o-x ; C1 x-0.
    # KCL at m: (V1 - vm)/R1 = (vm - vo)/R2 with vo = -A0 vm
    #   -> vm = V1 R2 / (R2 + (1 + A0) R1),  vo = g V1,  g = -A0 R2 / (R2 + (1 + A0) R1)
    #   C dv/dt = (vo - v)/Rl
    R1, R2, Rl, C, A0 = 1e3, 10e3, 100.0, 1e-6, 1e5
    g = -A0 * R2 / (R2 + (1 + A0) * R1)
    sys = formulate(circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Resistor("R1", ("in", "m"), value=R1),
        Resistor("R2", ("m", "o"), value=R2),
        Vcvs("E1", ("o", "0"), control=("0", "m"), gain=A0),
        Resistor("Rl", ("o", "x"), value=Rl),
        Capacitor("C1", ("x", "0"), value=C),
    ))
    lcs = sys.mode()
    close(lcs.A, [[-1 / (Rl * C)]])
    close(lcs.E, [[g / (Rl * C)]])
    # i(E1) flows from o through E1 to 0: minus what E1 delivers into R2 and Rl.
    vm = R2 / (R2 + (1 + A0) * R1)  # per volt of V1
    out = sys.outputs((), ["v(o)", "v(m)", "i(E1)"])
    close(out.Cy, [[0], [0], [1 / Rl]])
    close(out.Fy, [[g], [vm], [-(g - vm) / R2 - g / Rl]])


def test_vccs_drives_rc():
    # G1: gm v(in) flows from 0 through G1 into x;  C dv/dt = gm V1 - v/R2.
    gm, R2, C = 2e-3, 1e3, 1e-6
    sys = formulate(circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Resistor("R1", ("in", "0"), value=1e3),
        Vccs("G1", ("0", "x"), control=("in", "0"), gain=gm),
        Capacitor("C1", ("x", "0"), value=C),
        Resistor("R2", ("x", "0"), value=R2),
    ))
    lcs = sys.mode()
    close(lcs.A, [[-1 / (R2 * C)]])
    close(lcs.E, [[gm / C]])
    out = sys.outputs((), ["i(G1)", "i(R2)"])
    close(out.Fy, [[gm], [0]])
    close(out.Cy, [[0], [1 / R2]])


def test_cccs_senses_a_zero_volt_source():
    # Vs (sense, 0 V nominal but an input) carries i(Vs) = (V1 - Vs)/R1 from a to 0;
    # F1: beta i(Vs) flows from 0 through F1 into x;  C dv/dt = beta (V1 - Vs)/R1 - v/R2.
    beta, R1, R2, C = 3.0, 1e3, 2e3, 1e-6
    sys = formulate(circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Resistor("R1", ("in", "a"), value=R1),
        VoltageSource("Vs", ("a", "0"), dc=0.0),
        Cccs("F1", ("0", "x"), source="Vs", gain=beta),
        Capacitor("C1", ("x", "0"), value=C),
        Resistor("R2", ("x", "0"), value=R2),
    ))
    lcs = sys.mode()
    close(lcs.A, [[-1 / (R2 * C)]])
    close(lcs.E, [[beta / (R1 * C), -beta / (R1 * C)]])
    out = sys.outputs((), ["i(F1)", "i(Vs)"])
    close(out.Fy, [[beta / R1, -beta / R1], [1 / R1, -1 / R1]])


def test_ccvs_drives_rc():
    # H1: v(y) = rm i(Vs), i(Vs) = (V1 - Vs)/R1;  C dv/dt = (v(y) - v)/R2.
    # i(H1) from y through H1 to 0 = -(v(y) - v)/R2.
    rm, R1, R2, C = 50.0, 1e3, 2e3, 1e-6
    sys = formulate(circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Resistor("R1", ("in", "a"), value=R1),
        VoltageSource("Vs", ("a", "0"), dc=0.0),
        Ccvs("H1", ("y", "0"), source="Vs", gain=rm),
        Resistor("R2", ("y", "x"), value=R2),
        Capacitor("C1", ("x", "0"), value=C),
    ))
    lcs = sys.mode()
    close(lcs.A, [[-1 / (R2 * C)]])
    close(lcs.E, [[rm / (R1 * R2 * C), -rm / (R1 * R2 * C)]])
    out = sys.outputs((), ["v(y)", "i(H1)"])
    close(out.Fy, [[rm / R1, -rm / R1], [-rm / (R1 * R2), rm / (R1 * R2)]])
    close(out.Cy, [[0], [1 / R2]])


# ----------------------------------------------------------------------------------------
# Degenerate topologies


def diag_of(exc: pytest.ExceptionInfo) -> tuple:
    (d,) = exc.value.diagnostics
    return d


def test_capacitor_voltage_source_loop_rejected():
    # two capacitors in series across a varying source: their split is not set by the
    # source, and the loop's charge constraint would need the source's derivative
    c = circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0, waveform=Sin(0.0, 1.0, 1e3)),
        Resistor("R1", ("in", "0"), value=10.0),
        Capacitor("C1", ("in", "mid"), value=1e-6),
        Capacitor("C2", ("mid", "0"), value=1e-6),
    )
    sys = formulate(c)  # lazy: nothing is checked per mode yet
    with pytest.raises(NetlistError) as exc:
        sys.mode()
    d = diag_of(exc)
    assert set(d.elements) == {"V1", "C1", "C2"}
    assert "loop" in d.message and "resistance" in d.hint


def test_capacitor_across_a_voltage_source_holds_no_state():
    """An input capacitor straight across the supply (PySpice's buck example): its voltage
    is the source's, so it is no state and nothing else depends on it."""
    from netlist.reductions import source_capacitors

    c = circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Capacitor("Cin", ("in", "0"), value=1e-6),
        Resistor("R1", ("in", "out"), value=10.0),
        Capacitor("C1", ("out", "0"), value=1e-6),
    )
    assert source_capacitors(c) == ["cin"]
    sys = formulate(c)
    assert sys.states == ("v(C1)",)
    lcs = sys.mode()
    assert lcs.A[0, 0] == pytest.approx(-1 / (10.0 * 1e-6))


def test_switch_shorting_a_capacitor_rejected_only_when_on():
    # Boost with C1 across the switch (at sw) instead of the output: S1=on shorts C1.
    c = boost()
    c.elements.insert(3, Capacitor("Csw", ("sw", "0"), value=1e-9))
    sys = formulate(c)
    sys.mode({"S1": False})  # fine
    with pytest.raises(NetlistError) as exc:
        sys.mode({"S1": True})
    d = diag_of(exc)
    assert set(d.elements) == {"S1", "Csw"}
    assert "S1=on" in d.message


def test_inductor_current_source_cutset_rejected():
    c = circuit(
        CurrentSource("I1", ("0", "a"), dc=1.0),
        Inductor("L1", ("a", "b"), value=1e-3),
        Resistor("R1", ("b", "0"), value=10.0),
    )
    with pytest.raises(NetlistError) as exc:
        formulate(c).mode()
    d = diag_of(exc)
    assert set(d.elements) == {"I1", "L1"}
    assert "cutset" in d.message


def test_inductor_opened_by_switch_pinned_in_that_mode():
    c = circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Inductor("L1", ("in", "a"), value=1e-3),
        gate_switch("S1", "a", "0"),
        VoltageSource("Vg", ("gate", "0"), dc=0.0),
        models=SW_MODEL,
    )
    sys = formulate(c)
    assert sys.pinnable == (0,)
    lcs = sys.mode({"S1": True})
    close(lcs.E, [[1e3, 0]])  # L di/dt = V1
    assert sys.pinned({"S1": True}) == {}
    # S1 open: no path for i(L1): held at zero (no dynamics), its energy coefficient L
    lcs = sys.mode({"S1": False})
    close(lcs.A, [[0]])
    close(lcs.E, [[0, 0]])
    assert sys.pinned({"S1": False}) == {0: 1e-3}
    out = sys.outputs({"S1": False}, ["i(L1)", "v(a)"])
    close(out.Cy, [[0], [0]])
    close(out.Fy, [[0, 0], [1, 0]])  # v(a) = V1: L di/dt = 0


def test_coupled_inductor_opened_by_switch_rejected_with_mode():
    c = circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Inductor("L1", ("in", "a"), value=1e-3),
        gate_switch("S1", "a", "0"),
        VoltageSource("Vg", ("gate", "0"), dc=0.0),
        Inductor("L2", ("b", "0"), value=1e-3),
        Resistor("R2", ("b", "0"), value=1.0),
        Coupling("K1", (), inductors=("L1", "L2"), k=0.9),
        models=SW_MODEL,
    )
    sys = formulate(c)
    assert sys.pinnable == ()
    with pytest.raises(NetlistError) as exc:
        sys.mode({"S1": False})
    d = diag_of(exc)
    assert d.elements == ("L1",)
    assert "S1=off" in d.message and "flux lost" in d.hint


def test_unit_coupling_rejected():
    with pytest.raises(NetlistError) as exc:
        formulate(transformer(k=1.0))
    d = diag_of(exc)
    assert {"L1", "L2"} <= set(d.elements) or "L1, L2" in d.message
    assert "K1" in d.message and "leakage" in d.hint


def test_voltage_sources_in_parallel_rejected():
    c = circuit(
        VoltageSource("V1", ("a", "0"), dc=1.0),
        Vcvs("E1", ("a", "0"), control=("a", "0"), gain=1.0),
        Resistor("R1", ("a", "0"), value=1.0),
    )
    with pytest.raises(NetlistError) as exc:
        formulate(c).mode()
    assert set(diag_of(exc).elements) == {"V1", "E1"}


# ----------------------------------------------------------------------------------------
# Probes, floating parts, names


def test_boost_probes_both_modes():
    L, C, R = 100e-6, 100e-6, 20.0
    sys = formulate(boost(L, C, R))
    probes = ["v(gate,0)", "i(S1)", "i(D1)", "v(sw)", "i(Vin)", "i(R1)", "i(C1)", "V(OUT)",
              "I(l1)"]
    # S1 off (D1 voltage-type, λ = v(out) - v(sw)): i(S1) = 0, i(D1) = iL, v(sw) = vC - λ,
    # i(Vin) = -iL, i(R1) = vC/R, i(C1) = iL - vC/R.
    off = sys.outputs({"S1": False}, probes)
    close(off.Cy, [[0, 0], [0, 0], [1, 0], [0, 1], [-1, 0], [0, 1 / R], [1, -1 / R], [0, 1],
                   [1, 0]])
    close(off.Dy, [[0], [0], [0], [-1], [0], [0], [0], [0], [0]])
    close(off.Fy, [[0, 1]] + [[0, 0]] * 8)
    # S1 on (D1 current-type): i(S1) = iL - λ, i(D1) = λ, v(sw) = 0, i(C1) = λ - vC/R.
    on = sys.outputs({"S1": True}, probes)
    close(on.Cy, [[0, 0], [1, 0], [0, 0], [0, 0], [-1, 0], [0, 1 / R], [0, -1 / R], [0, 1],
                  [1, 0]])
    close(on.Dy, [[0], [-1], [1], [0], [0], [0], [1], [0], [0]])


def test_switch_control_probe_available_in_every_mode():
    sys = formulate(boost())
    for key in sys.all_keys():
        out = sys.outputs(key, [sys.switches[0].control])
        close(out.Fy, [[0, 1]])


def test_unknown_probe_lists_valid_names():
    sys = formulate(boost())
    with pytest.raises(NetlistError) as exc:
        sys.outputs((False,), ["v(nowhere)"])
    d = diag_of(exc)
    assert "v(nowhere)" in d.message
    assert "sw" in d.hint and "L1" in d.hint
    with pytest.raises(NetlistError):
        sys.outputs((False,), ["i(K9)"])
    with pytest.raises(NetlistError):
        sys.outputs((False,), ["q(out)"])


def test_floating_node_behind_open_switch():
    # Boost plus S2 from sw to y and R9 from y to z: with S2 open, y and z float. The LCS
    # does not depend on them, so the mode builds (and equals the plain boost); probing v(y)
    # is an error; with S2 closed v(y) = v(z) = v(sw).
    c = boost()
    c.elements += [gate_switch("S2", "sw", "y"), Resistor("R9", ("y", "z"), value=1e3)]
    sys = formulate(c)
    plain = formulate(boost())
    for s1 in (False, True):
        got, want = sys.mode({"S1": s1, "S2": False}), plain.mode({"S1": s1})
        for name in "ABCDEF":
            close(getattr(got, name), getattr(want, name))
        with pytest.raises(NetlistError, match="not determined"):
            sys.outputs({"S1": s1, "S2": False}, ["v(y)"])
        close(sys.outputs({"S1": s1, "S2": False}, ["i(S2)", "i(R9)"]).Cy, np.zeros((2, 2)))
    on = sys.outputs({"S1": False, "S2": True}, ["v(y)", "v(z)"])
    close(on.Cy, [[0, 1], [0, 1]])
    close(on.Dy, [[-1], [-1]])


def test_hierarchical_names_and_case():
    c = circuit(
        VoltageSource("Vin", ("in", "0"), dc=1.0),
        Resistor("X1.R1", ("in", "x1.n1"), value=10.0),
        Inductor("X1.L1", ("x1.n1", "0"), value=1e-3),
    )
    sys = formulate(c)
    assert sys.states == ("i(X1.L1)",)
    lcs = sys.mode()
    close(lcs.A, [[-1e4]])  # L di/dt = Vin - R i
    out = sys.outputs((), ["v(X1.N1)", "i(x1.l1)"])
    close(out.Cy, [[-10.0], [1.0]])


def test_switch_without_model_defaults_to_zero_thresholds():
    c = boost()
    c.elements[2] = Switch("S1", ("sw", "0"), control=("gate", "0"))
    (sw,) = formulate(c).switches
    assert (sw.vt, sw.vh) == (0.0, 0.0)


def test_formulate_is_lazy():
    calls = []
    sys = formulate(boost())
    original = sys._builder

    def counting(key):
        calls.append(key)
        return original(key)

    sys._builder = counting
    sys.mode((True,))
    sys.mode((True,))
    sys.outputs((True,), ["v(out)"])
    assert calls == [(True,)]



def test_a_rejected_mode_is_not_formulated_again():
    # The error of a degenerate mode is kept: the passivity screen and the θ screen each ask
    # for the all-on mode of a half-bridge, whose shoot-through is a loop.
    c = circuit(
        VoltageSource("V1", ("in", "0"), dc=1.0),
        Switch("S1", ("in", "mid"), control=("g1", "0")),
        Switch("S2", ("mid", "0"), control=("g2", "0")),
        Resistor("R1", ("mid", "0"), value=10.0),
        VoltageSource("Vg1", ("g1", "0"), dc=1.0),
        VoltageSource("Vg2", ("g2", "0"), dc=0.0),
    )
    calls = []
    sys = formulate(c)
    original = sys._builder

    def counting(key):
        calls.append(key)
        return original(key)

    sys._builder = counting
    messages, depths = [], []
    for _ in range(4):
        with pytest.raises(NetlistError) as exc:
            sys.mode((True, True))
        messages.append(str(exc.value))
        tb, depth = exc.value.__traceback__, 0
        while tb is not None:
            tb, depth = tb.tb_next, depth + 1
        depths.append(depth)
    assert calls == [(True, True)]
    assert len(set(messages)) == 1 and "loop" in messages[0]
    # the kept error is raised afresh: its traceback does not grow by a frame per raise
    assert depths[1] == depths[2] == depths[3]
    sys.mode((True, False))
    assert calls == [(True, True), (True, False)]

def test_bad_element_values_rejected():
    with pytest.raises(NetlistError, match="R1"):
        formulate(circuit(VoltageSource("V1", ("a", "0")), Resistor("R1", ("a", "0"), value=0)))
    with pytest.raises(NetlistError, match="L1"):
        formulate(circuit(VoltageSource("V1", ("a", "0")), Inductor("L1", ("a", "0"), value=-1)))
    with pytest.raises(NetlistError, match="Vx"):
        formulate(circuit(
            VoltageSource("V1", ("a", "0")), Resistor("R1", ("a", "0"), value=1.0),
            Cccs("F1", ("a", "0"), source="Vx", gain=1.0)))


# ----------------------------------------------------------------------------------------
# The λ-type search: pruning by topology, the normal-tree path for many diodes


ALL_CIRCUITS = [boost(), buck(), buck_boost(), cuk(), bridge_tank(), parallel_resonant(**PRC),
                rlc_with_sources()]


def kinds_per_mode(c):
    sys = formulate(c)
    return {key: [p.lam for p in sys.mode(key).pairs] for key in sys.all_keys()}


def test_topological_pruning_does_not_change_the_choice(monkeypatch):
    pruned = [kinds_per_mode(c) for c in ALL_CIRCUITS]
    monkeypatch.setattr(fm._Formulator, "_forced_types", lambda self, on: (set(), set()))
    assert [kinds_per_mode(c) for c in ALL_CIRCUITS] == pruned


def test_normal_tree_path_and_greedy_repair(monkeypatch):
    exhaustive = [kinds_per_mode(c) for c in ALL_CIRCUITS]
    monkeypatch.setattr(fm, "EXHAUSTIVE_DIODE_LIMIT", 0)
    assert [kinds_per_mode(c) for c in ALL_CIRCUITS] == exhaustive
    # Greedy repair from a useless start (all current-type, no topological pruning).
    monkeypatch.setattr(fm._Formulator, "_forced_types", lambda self, on: (set(), set()))
    monkeypatch.setattr(fm._Formulator, "_tree_assignment", lambda self, on: frozenset())
    lcs = formulate(parallel_resonant(**PRC)).mode()
    assert [p.lam for p in lcs.pairs] == [VOL, CUR, VOL, CUR]


def test_many_diodes_each_behind_an_inductor():
    # Twelve diodes, each in series with its own inductor: all must be voltage-type. The
    # topology decides this directly (no 2**12 search): w_i = i(L_i), λ_i = v(b_i) - v(a)
    # (cathode minus anode), so v(b_i) = V1 + λ_i.
    elements = [VoltageSource("V1", ("a", "0"), dc=1.0)]
    for i in range(12):
        elements += [Diode(f"D{i}", ("a", f"b{i}")),
                     Inductor(f"L{i}", (f"b{i}", f"c{i}"), value=1e-3),
                     Resistor(f"R{i}", (f"c{i}", "0"), value=1.0)]
    lcs = formulate(circuit(*elements)).mode()
    assert {p.lam for p in lcs.pairs} == {VOL}
    # L di/dt = v(b) - v(c) = V1 + λ - R i
    close(lcs.A, -1e3 * np.eye(12))
    close(lcs.B, 1e3 * np.eye(12))
    close(lcs.E, 1e3 * np.ones((12, 1)))
    close(lcs.C, np.eye(12))


# ----------------------------------------------------------------------------------------
# The same, from netlist text (netlist.parser)

def parsed(text: str):
    from netlist.parser import parse_string

    return formulate(parse_string(text, file="<test>"))


def test_parsed_bridge_with_subcircuit_tank():
    # The bridge of test_bridge_across_lc_tank with the tank in a subcircuit: the states are
    # the hierarchical names, the matrices the same hand result.
    L, C, R = 1e-3, 1e-6, 50.0
    sys = parsed("""bridge on a tank
.subckt tank a b
L1 a b 1m
C1 a b 1u
.ends
I1 b a DC 0
X1 a b tank
D1 a p DI
D2 b p DI
D3 0 a DI
D4 0 b DI
R1 p 0 50
.model DI D
.end
""")
    assert sys.states == ("i(X1.L1)", "v(X1.C1)")
    check_lcs(
        sys.mode(),
        A=[[0, 1 / L], [-1 / C, 0]],
        B=[[0, 0, 0, 0], [0, 1 / C, 0, -1 / C]],
        C=[[0, 0], [0, 1], [0, 0], [0, -1]],
        D=[[0, -1, 1, 1], [1, 0, 0, 0], [-1, 0, R, R], [-1, 0, R, R]],
        E=[[0], [1 / C]], F=[[0], [0], [0], [0]],
        kinds=[VOL, CUR, CUR, CUR],
    )


def test_parsed_prc_matches_dataclass_version():
    text = """parallel resonant converter
Vs s b PULSE(-50 50 0 10n 10n 9u 18u)
Lr s a 150u
Cr a b 68n
D1 a p DI
D2 b p DI
D3 0 a DI
D4 0 b DI
Lf p o 0.4m
Cf o 0 2.2u
R o 0 33
.model DI D
.end
"""
    got = parsed(text).mode()
    want = formulate(parallel_resonant(**PRC)).mode()
    for name in "ABCDEF":
        close(getattr(got, name), getattr(want, name))
    assert got.pairs == want.pairs


def test_parsed_controlled_source_probes():
    # u = V1, x = i(L2) (q -> 0).  Hand values:
    #   di/dt = u / L = 1000 u
    #   i(V1): KCL at q, i(V1) + u/R1 + x = 0           -> -u/2 - x
    #   E1: v(e) = 2u, i(E1) = -v(e)/Re                  -> -2u
    #   F1: i(F1) = 3 i(V1), v(f) = -i(F1) Rf            -> i(F1) = -1.5u - 3x, v(f) = 1.5u + 3x
    #   H1: v(h) = 4 i(V1) = -2u - 4x, i(H1) = -v(h)/Rh  -> 2u + 4x
    #   G1: i(G1) = 5 v(q) = 5u, v(g) = -5u
    sys = parsed("""controlled sources
V1 q 0 1
R1 q 0 2
L2 q 0 1m
E1 e 0 q 0 2
Re e 0 1
F1 f 0 V1 3
Rf f 0 1
H1 h 0 V1 4
Rh h 0 1
G1 g 0 q 0 5
Rg g 0 1
.end
""")
    lcs = sys.mode()
    close(lcs.A, [[0]])
    close(lcs.E, [[1000]])
    probes = ["i(V1)", "v(e)", "i(E1)", "i(F1)", "v(f)", "v(h)", "i(H1)", "i(G1)", "v(g)",
              "i(L2)"]
    out = sys.outputs((), probes)
    close(out.Cy, [[-1], [0], [0], [-3], [3], [-4], [4], [0], [0], [1]])
    close(out.Fy, [[-0.5], [2], [-2], [-1.5], [1.5], [-2], [2], [5], [-5], [0]])


def test_switch_initial_state_reaches_the_switch_control():
    from netlist.parser import parse_string

    text = """initial state
V1 in 0 DC 1
S1 in out ctl 0 SWM ON
S2 in out2 ctl 0 SWM
R1 out 0 1
R2 out2 0 1
Vc ctl 0 DC 0
.model SWM SW(VT=0.5 VH=0.1)
.end
"""
    sw1, sw2 = formulate(parse_string(text)).switches
    assert sw1.options["initial"] is True and sw1.vt == 0.5 and sw1.vh == 0.1
    assert "initial" not in sw2.options


def test_resistor_on_one_node_changes_nothing():
    # A resistor whose two terminals are one node carries no current: the LCS is the one
    # without it, entry for entry (its stamps are skipped, not added and cancelled).
    from netlist.parser import parse_string

    base = """rl with a diode
V1 in 0 DC 10
R1 in a 2
L1 a k 1m
D1 k out DI
C1 out 0 10u
R2 out 0 5
.model DI D
"""
    a = formulate(parse_string(base + ".end\n")).mode()
    b = formulate(parse_string(base + "R9 a a 1k\n.end\n")).mode()
    for name in "ABCDEF":
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


def _random_diode_network(rng, nodes=5, elements=9):
    """A random connected network of R, L, C, diodes and a source on ``nodes`` nodes."""
    names = ["0"] + [f"n{k}" for k in range(1, nodes)]
    els = [VoltageSource("V1", ("n1", "0"), dc=5.0)]
    # (a spanning chain first, so that every node is connected)
    kinds = ["R", "L", "C", "D", "D"]
    for k in range(1, elements + 1):
        if k < nodes - 1:
            a, b = names[k], names[k + 1]
        else:
            a, b = rng.choice(names, 2, replace=False)
        kind = kinds[rng.integers(len(kinds))]
        if kind == "R":
            els.append(Resistor(f"R{k}", (a, b), value=float(rng.uniform(1, 100))))
        elif kind == "L":
            els.append(Inductor(f"L{k}", (a, b), value=float(rng.uniform(1e-4, 1e-3))))
        elif kind == "C":
            els.append(Capacitor(f"C{k}", (a, b), value=float(rng.uniform(1e-6, 1e-5))))
        else:
            els.append(Diode(f"D{k}", (a, b)))
    return circuit(*els)


def _outcome(c):
    try:
        lcs = formulate(c).mode()
    except NetlistError as exc:
        return ("error", str(exc))
    return ("lcs", [p.lam for p in lcs.pairs], *(getattr(lcs, k) for k in "ABCDEF"))


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_skipping_too_small_assignments_picks_the_same_one(monkeypatch):
    # The λ-type search skips assignments with fewer voltage-type diodes than a normal tree
    # has (they cannot be usable): on random networks it picks what the full search picks,
    # and fails with the same message where the full search fails.
    rng = np.random.default_rng(11)
    skipped = 0
    for trial in range(150):
        c = _random_diode_network(rng, nodes=int(rng.integers(3, 7)),
                                  elements=int(rng.integers(4, 12)))
        with_skip = _outcome(c)
        f = fm._Formulator(c)
        if with_skip[0] == "lcs" and f.diodes:
            skipped += len(f._tree_assignment(frozenset())) > 0
        monkeypatch.setattr(fm._Formulator, "_min_voltage_diodes", lambda self, on: 0)
        full = _outcome(c)
        monkeypatch.undo()
        assert with_skip[0] == full[0], (trial, with_skip[:2], full[:2])
        if full[0] == "error":
            assert with_skip[1] == full[1]
        else:
            assert with_skip[1] == full[1]
            for got, want in zip(with_skip[2:], full[2:], strict=True):
                assert np.array_equal(got, want)
    assert skipped > 10  # (the bound was above zero on many of them)


def test_mode_keys_take_booleans_or_on_off_and_name_every_switch():
    sys = formulate(boost())
    on, off = sys.mode({"S1": True}), sys.mode({"S1": False})
    assert not np.array_equal(on.A, off.A)
    for state, want in (("on", on), ("ON", on), ("off", off), (" Off ", off),
                        (np.True_, on), (np.False_, off)):
        close(sys.mode({"s1": state}).A, want.A)
    close(sys.mode(("off",)).A, off.A)
    # Truthiness would read each of these as on: refused instead.
    for state in ("false", "0", "no", 0, 1, 2, 0.5, None):
        with pytest.raises(ValueError, match="neither a boolean nor 'on'/'off'"):
            sys.mode({"S1": state})
    with pytest.raises(KeyError, match="no state given for switch"):
        formulate(two_switch_boost_for_keys()).mode({"S1": True})
    with pytest.raises(KeyError, match="unknown switch"):
        sys.mode({"S1": True, "S9": False})
    assert sys.describe_mode(("on",)) == {"S1": "on"}


def two_switch_boost_for_keys():
    c = boost()
    c.elements.append(gate_switch("S2", "out", "x"))
    c.elements.append(Resistor("R9", ("x", "0"), value=100.0))
    return c


def test_storage_matrix_leaves_out_a_capacitor_across_the_source():
    # An input capacitor straight across the supply holds no state (netlist.reductions): the
    # energy matrix has the LCS's states only (it was 3x3 for 2 states, and `pelcs lcs`
    # stopped with a traceback).
    c = boost(L=100e-6, C=47e-6)
    c.elements.insert(1, Capacitor("Cin", ("in", "0"), value=10e-6))
    sys = formulate(c)
    assert sys.states == ("i(L1)", "v(C1)")
    close(storage_matrix(c), np.diag([100e-6, 47e-6]))
