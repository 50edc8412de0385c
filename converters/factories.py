"""Converter netlists as Python factories: named parameters in, ngspice-dialect text out.

Every factory returns the text of a complete netlist in the conventions of the bundled ones
(``converters/netlists/*.cir``): the same element and node names (so states, diodes, switches
and inputs carry the same names), the component values as ``.param`` lines (so the text can
be re-parsed with ``parse_string(text, params={...})`` overrides), ideal-element ``.model``
lines that ngspice accepts (pelcs treats every D and S as ideal whatever the model says), and
``.tran TSTEP TSTOP 0 TMAX UIC`` so that ngspice starts from the written initial state as
pelcs does. With default parameters each factory formulates to the same switched LCS as the
bundled netlist of the same converter (checked in ``tests/test_converters.py``).

Units are SI throughout: V, A, Ω, H, F, Hz, s.

| factory | bundled netlist | what |
|---|---|---|
| :func:`buck` | ``buck.cir`` | open-loop PWM buck |
| :func:`boost` | ``boost.cir`` (``boost_dcm.cir`` with ``duty=0.3, lind=20u, rload=50``) | boost |
| :func:`buck_boost` | ``buck_boost.cir`` | inverting buck-boost |
| :func:`cuk` | ``cuk.cir`` | Čuk |
| :func:`prc` | ``prc.cir`` | parallel resonant converter, 4-diode bridge, LC output filter |
| :func:`vm_buck` | ``vm_buck.cir`` | voltage-mode buck (Deane-Hamill chaos benchmark) |
| :func:`boost_smc` | ``boost_smc.cir`` | boost under sliding-mode current control |
| :func:`bridge_rectifier` | ``bridge_rectifier.cir`` | diode bridge with capacitor filter |

The PWM factories take ``gate="pwm"`` (the default), ``"on"`` or ``"off"``: the last two
drive the switch from a DC gate, so the whole run stays in one switch mode (what the GDCM
studies in ``examples/gdcm_studies.py`` need).

:func:`circuit` parses a factory's text into a :class:`~netlist.circuit.Circuit`;
:func:`params_from_design` turns a :class:`~converters.design.ConverterDesign` into factory
keyword arguments.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

from converters.design import ConverterDesign, _check_topology
from netlist.circuit import Circuit
from netlist.parser import parse_string

__all__ = [
    "BUNDLED",
    "DIODE_MODEL",
    "FACTORIES",
    "SWITCH_MODEL",
    "boost",
    "boost_smc",
    "bridge_rectifier",
    "buck",
    "buck_boost",
    "circuit",
    "cuk",
    "netlist_path",
    "params_from_design",
    "prc",
    "vm_buck",
]

#: ngspice's switch model with the threshold at half the 0/1 V gate swing; the on/off
#: resistances only matter to ngspice (pelcs: on = short, off = open).
SWITCH_MODEL = ".model SWIDEAL SW(VT=0.5 VH=0 RON=1m ROFF=1e9)"
#: A near-ideal diode for ngspice (emission coefficient 0.05: about 2.6 mV per decade).
DIODE_MODEL = ".model DIDEAL D(IS=1e-12 N=0.05 RS=1m)"

# Gate and drive edges (s): ngspice needs finite edges; pelcs switches at the 0.5 V crossing,
# which for a 0 -> 1 V edge of 10 ns lies 5 ns after the edge starts, so the on-time is
# exactly duty*ts (PW = duty*ts - 10n, one edge before it, one after).
EDGE = 10e-9

NETLIST_DIR = Path(__file__).resolve().parent / "netlists"


def _num(x: float) -> str:
    """A number as ngspice reads it (12 significant digits, no SPICE suffix ambiguity)."""
    x = float(x)
    if not math.isfinite(x):
        raise ValueError(f"non-finite value {x!r}")
    if x == int(x) and abs(x) < 1e15:
        return str(int(x))
    return f"{x:.12g}"


def _params(**values: float) -> str:
    return ".param " + " ".join(f"{k}={_num(v)}" for k, v in values.items())


def _positive(**values: float) -> None:
    for name, v in values.items():
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be positive and finite, got {v!r}")


def _check_duty(duty: float, fs: float) -> None:
    if not 0 < duty < 1:
        raise ValueError(f"duty must lie in (0, 1), got {duty!r}")
    if duty / fs <= 2 * EDGE or (1 - duty) / fs <= 2 * EDGE:
        raise ValueError(f"duty {duty} at fs = {fs:g} Hz leaves less than two 10 ns gate "
                         "edges for the on or the off time")


def _gate(gate: str) -> str:
    """The gate source of the PWM converters (node ``gate``, ground referenced)."""
    g = gate.lower()
    if g == "pwm":
        return ("* gate drive: 1 V for duty*ts of every period (on at the 0.5 V crossings)\n"
                "Vg gate 0 PULSE(0 1 0 10n 10n {duty*ts-10n} {ts})")
    if g in ("on", "off"):
        return (f"* gate held {g}: the switch stays {'closed' if g == 'on' else 'open'} "
                "for the whole run (one switch mode)\n"
                f"Vg gate 0 DC {1 if g == 'on' else 0}")
    raise ValueError(f"gate must be 'pwm', 'on' or 'off', got {gate!r}")


def _tran(tstep: float, tstop: float) -> str:
    _positive(tstep=tstep, tstop=tstop)
    if tstep > tstop:
        raise ValueError(f"tstep {tstep:g} s exceeds tstop {tstop:g} s")
    return f".tran {_num(tstep)} {_num(tstop)} 0 {_num(tstep)} UIC"


def _ic(x: float) -> str:
    return f" IC={_num(x)}"


def _join(*lines: str) -> str:
    return "\n".join(lines) + "\n"


# -- open-loop PWM converters ----------------------------------------------------------------


def buck(vin: float = 24.0, duty: float = 0.5, fs: float = 50e3, lind: float = 200e-6,
         cout: float = 100e-6, rload: float = 5.0, *, il0: float = 0.0, vc0: float = 0.0,
         gate: str = "pwm", tstop: float = 5e-3, tstep: float | None = None,
         title: str | None = None) -> str:
    """Buck converter, open-loop PWM: ``Vin -- S1 -- sw``, D1 from 0 to sw, L1 sw->out, C1||R1.

    Parameters
    ----------
    vin : float
        Input voltage, V.
    duty : float
        Duty cycle in (0, 1) (switch on for ``duty/fs`` of every period).
    fs : float
        Switching frequency, Hz.
    lind, cout, rload : float
        L1 (H), C1 (F), load R1 (Ω).
    il0, vc0 : float
        Initial i(L1) (A, sw -> out) and v(C1) = v(out) (V).
    gate : str
        ``"pwm"``, or ``"on"``/``"off"`` to hold the switch (DC gate).
    tstop, tstep : float
        ``.tran`` stop time and step (s); the step defaults to 1/100 of the period.
    title : str, optional
        First line of the netlist.

    Returns
    -------
    str
        The netlist (states ``i(L1)``, ``v(C1)``; diode D1; switch S1; inputs Vin, Vg).
    """
    _positive(vin=vin, fs=fs, lind=lind, cout=cout, rload=rload)
    _check_duty(duty, fs)
    return _join(
        title or f"Buck converter, open-loop PWM ({_num(vin)} V, duty {_num(duty)})",
        "* Vin -- S1 (high side) -- sw ; D1 from ground (anode) to sw ; L1 sw -> out ;"
        " C1 || R1 at out",
        _params(vin=vin, duty=duty, fs=fs, rload=rload, lind=lind, cout=cout),
        ".param ts={1/fs}",
        "Vin in 0 DC {vin}",
        "S1 in sw gate 0 SWIDEAL",
        "D1 0 sw DIDEAL",
        "L1 sw out {lind}" + _ic(il0),
        "C1 out 0 {cout}" + _ic(vc0),
        "R1 out 0 {rload}",
        _gate(gate),
        SWITCH_MODEL,
        DIODE_MODEL,
        _tran(tstep or 1 / (100 * fs), tstop),
        ".end",
    )


def boost(vin: float = 12.0, duty: float = 0.5, fs: float = 50e3, lind: float = 100e-6,
          cout: float = 100e-6, rload: float = 20.0, *, il0: float = 0.0, vc0: float = 0.0,
          gate: str = "pwm", tstop: float = 5e-3, tstep: float | None = None,
          title: str | None = None) -> str:
    """Boost converter, open-loop PWM: ``Vin -- L1 -- sw``, S1 sw->0, D1 sw->out, C1||R1.

    Parameters
    ----------
    vin : float
        Input voltage, V.
    duty : float
        Duty cycle in (0, 1).
    fs : float
        Switching frequency, Hz.
    lind, cout, rload : float
        L1 (H), C1 (F), load R1 (Ω). ``duty=0.3, lind=20e-6, rload=50`` is ``boost_dcm.cir``
        (DCM: K = 2 L fs / R = 0.04 < duty (1 - duty)² = 0.147).
    il0, vc0 : float
        Initial i(L1) (A, in -> sw) and v(C1) = v(out) (V).
    gate : str
        ``"pwm"``, or ``"on"``/``"off"`` to hold the switch (DC gate).
    tstop, tstep : float
        ``.tran`` stop time and step (s); the step defaults to 1/100 of the period.
    title : str, optional
        First line of the netlist.

    Returns
    -------
    str
        The netlist (states ``i(L1)``, ``v(C1)``; diode D1; switch S1; inputs Vin, Vg).
    """
    _positive(vin=vin, fs=fs, lind=lind, cout=cout, rload=rload)
    _check_duty(duty, fs)
    return _join(
        title or f"Boost converter, open-loop PWM ({_num(vin)} V, duty {_num(duty)})",
        "* Vin -- L1 -- sw ; S1 from sw to ground ; D1 from sw to out ; C1 || R1 at out",
        _params(vin=vin, duty=duty, fs=fs, rload=rload, lind=lind, cout=cout),
        ".param ts={1/fs}",
        "Vin in 0 DC {vin}",
        "L1 in sw {lind}" + _ic(il0),
        "S1 sw 0 gate 0 SWIDEAL",
        "D1 sw out DIDEAL",
        "C1 out 0 {cout}" + _ic(vc0),
        "R1 out 0 {rload}",
        _gate(gate),
        SWITCH_MODEL,
        DIODE_MODEL,
        _tran(tstep or 1 / (100 * fs), tstop),
        ".end",
    )


def buck_boost(vin: float = 12.0, duty: float = 0.5, fs: float = 50e3, lind: float = 200e-6,
               cout: float = 100e-6, rload: float = 10.0, *, il0: float = 0.0,
               vc0: float = 0.0, gate: str = "pwm", tstop: float = 5e-3,
               tstep: float | None = None, title: str | None = None) -> str:
    """Inverting buck-boost, open-loop PWM: ``Vin -- S1 -- sw``, L1 sw->0, D1 out->sw, C1||R1.

    The output is negative: v(out) = -duty/(1-duty) vin in CCM.

    Parameters
    ----------
    vin : float
        Input voltage, V.
    duty : float
        Duty cycle in (0, 1).
    fs : float
        Switching frequency, Hz.
    lind, cout, rload : float
        L1 (H), C1 (F), load R1 (Ω).
    il0, vc0 : float
        Initial i(L1) (A, sw -> ground) and v(C1) = v(out) (V, negative in operation).
    gate : str
        ``"pwm"``, or ``"on"``/``"off"`` to hold the switch (DC gate).
    tstop, tstep : float
        ``.tran`` stop time and step (s); the step defaults to 1/100 of the period.
    title : str, optional
        First line of the netlist.

    Returns
    -------
    str
        The netlist (states ``i(L1)``, ``v(C1)``; diode D1; switch S1; inputs Vin, Vg).
    """
    _positive(vin=vin, fs=fs, lind=lind, cout=cout, rload=rload)
    _check_duty(duty, fs)
    return _join(
        title or f"Inverting buck-boost converter, open-loop PWM ({_num(vin)} V, "
                 f"duty {_num(duty)})",
        "* Vin -- S1 -- sw ; L1 from sw to ground ; D1 from out (anode) to sw ; C1 || R1 at out",
        _params(vin=vin, duty=duty, fs=fs, rload=rload, lind=lind, cout=cout),
        ".param ts={1/fs}",
        "Vin in 0 DC {vin}",
        "S1 in sw gate 0 SWIDEAL",
        "L1 sw 0 {lind}" + _ic(il0),
        "D1 out sw DIDEAL",
        "C1 out 0 {cout}" + _ic(vc0),
        "R1 out 0 {rload}",
        _gate(gate),
        SWITCH_MODEL,
        DIODE_MODEL,
        _tran(tstep or 1 / (100 * fs), tstop),
        ".end",
    )


def cuk(vin: float = 12.0, duty: float = 0.5, fs: float = 50e3, l1: float = 500e-6,
        c1: float = 10e-6, l2: float = 500e-6, c2: float = 100e-6, rload: float = 20.0, *,
        il1: float = 0.0, vc1: float = 0.0, il2: float = 0.0, vc2: float = 0.0,
        gate: str = "pwm", tstop: float = 10e-3, tstep: float | None = None,
        title: str | None = None) -> str:
    """Čuk converter, open-loop PWM.

    ``Vin -- L1 -- a``; S1 from a to ground; energy-transfer capacitor C1 from a to b; D1
    from b (anode) to ground; L2 from b to out; C2 || R1 at out. v(out) = -duty/(1-duty) vin
    in CCM, v(C1) = v(a) - v(b) = vin - v(out).

    Parameters
    ----------
    vin : float
        Input voltage, V.
    duty : float
        Duty cycle in (0, 1).
    fs : float
        Switching frequency, Hz.
    l1, c1, l2, c2, rload : float
        Input inductor (H), transfer capacitor (F), output inductor (H), output capacitor
        (F), load (Ω).
    il1, vc1, il2, vc2 : float
        Initial i(L1) (A, in -> a), v(C1) (V, a - b), i(L2) (A, b -> out; negative in
        operation) and v(C2) = v(out) (V).
    gate : str
        ``"pwm"``, or ``"on"``/``"off"`` to hold the switch (DC gate).
    tstop, tstep : float
        ``.tran`` stop time and step (s); the step defaults to 1/100 of the period.
    title : str, optional
        First line of the netlist.

    Returns
    -------
    str
        The netlist (states ``i(L1)``, ``v(C1)``, ``i(L2)``, ``v(C2)``; diode D1; switch S1;
        inputs Vin, Vg).
    """
    _positive(vin=vin, fs=fs, l1=l1, c1=c1, l2=l2, c2=c2, rload=rload)
    _check_duty(duty, fs)
    return _join(
        title or f"Cuk converter, open-loop PWM ({_num(vin)} V, duty {_num(duty)})",
        "* Vin -- L1 -- a ; S1 from a to ground ; C1 from a to b ; D1 from b (anode) to ground ;"
        " L2 from b to out ; C2 || R1 at out",
        _params(vin=vin, duty=duty, fs=fs, rload=rload, l1=l1, l2=l2, c1=c1, c2=c2),
        ".param ts={1/fs}",
        "Vin in 0 DC {vin}",
        "L1 in a {l1}" + _ic(il1),
        "S1 a 0 gate 0 SWIDEAL",
        "C1 a b {c1}" + _ic(vc1),
        "D1 b 0 DIDEAL",
        "L2 b out {l2}" + _ic(il2),
        "C2 out 0 {c2}" + _ic(vc2),
        "R1 out 0 {rload}",
        _gate(gate),
        SWITCH_MODEL,
        DIODE_MODEL,
        _tran(tstep or 1 / (100 * fs), tstop),
        ".end",
    )


# -- resonant converter and rectifier --------------------------------------------------------


def prc(vin: float = 50.0, fs: float = 55e3, lr: float = 150e-6, cr: float = 68e-9,
        lf: float = 0.4e-3, cf: float = 2.2e-6, rload: float = 33.0, *, ilr0: float = 0.0,
        vcr0: float = 0.0, ilf0: float = 0.0, vcf0: float = 0.0, tstop: float = 2e-3,
        tstep: float | None = None, title: str | None = None) -> str:
    """Parallel resonant converter with a 4-diode bridge rectifier and an LC output filter.

    A square wave ±vin at fs (it stands for an ideal full bridge of switches) drives Lr into
    node a; Cr from a to ground is in parallel with the AC input of the bridge D1..D4; the
    bridge output p/n feeds Lf -> out, and Cf || R1 sit from out to n. The tank resonates at
    1/(2π sqrt(Lr Cr)) = 49.8 kHz with the defaults.

    Parameters
    ----------
    vin : float
        Amplitude of the square-wave drive, V.
    fs : float
        Drive frequency, Hz.
    lr, cr, lf, cf, rload : float
        Tank inductor (H) and capacitor (F), filter inductor (H) and capacitor (F), load (Ω).
    ilr0, vcr0, ilf0, vcf0 : float
        Initial i(Lr) (A), v(Cr) (V), i(Lf) (A), v(Cf) = v(out, n) (V).
    tstop, tstep : float
        ``.tran`` stop time and step (s); the step defaults to 1/360 of the period (20 ns
        edges of a ±vin swing need a fine step in ngspice; pelcs lands on every edge anyway).
    title : str, optional
        First line of the netlist.

    Returns
    -------
    str
        The netlist (states ``i(Lr)``, ``v(Cr)``, ``i(Lf)``, ``v(Cf)``; diodes D1..D4; input
        Vdrv; no switches).
    """
    _positive(vin=vin, fs=fs, lr=lr, cr=cr, lf=lf, cf=cf, rload=rload)
    if 1 / (2 * fs) <= 2 * EDGE:
        raise ValueError(f"fs = {fs:g} Hz leaves no flat top between the 10 ns drive edges")
    return _join(
        title or f"Parallel resonant converter ({_num(vin)} V square wave at {fs:g} Hz) with "
                 "bridge rectifier and LC filter",
        "* drive +-vin -- Lr -- a ; Cr from a to ground || bridge D1..D4 (a, 0) -> (p, n) ;"
        " Lf p -> out ; Cf || R1 from out to n",
        _params(vin=vin, fs=fs, lr=lr, cr=cr, lf=lf, cf=cf, rload=rload),
        ".param ts={1/fs} tedge=10n",
        "Vdrv drv 0 PULSE({-vin} {vin} 0 {tedge} {tedge} {ts/2-tedge} {ts})",
        "Lr drv a {lr}" + _ic(ilr0),
        "Cr a 0 {cr}" + _ic(vcr0),
        "D1 a p DIDEAL",
        "D2 0 p DIDEAL",
        "D3 n a DIDEAL",
        "D4 n 0 DIDEAL",
        "Lf p out {lf}" + _ic(ilf0),
        "Cf out n {cf}" + _ic(vcf0),
        "R1 out n {rload}",
        DIODE_MODEL,
        _tran(tstep or 1 / (360 * fs), tstop),
        ".end",
    )


def bridge_rectifier(vpk: float = 12.0, f: float = 50.0, cout: float = 1000e-6,
                     rload: float = 100.0, *, vc0: float = 0.0, tstop: float = 100e-3,
                     tstep: float | None = None, title: str | None = None) -> str:
    """Full-wave diode bridge rectifier with a capacitor filter.

    A sine source (peak vpk, frequency f) between ac1 and ground feeds the bridge D1..D4; C1
    || R1 sit between the output rails p and n (the load voltage is v(p, n); n is not ground).

    Parameters
    ----------
    vpk : float
        Peak of the sine source, V.
    f : float
        Line frequency, Hz.
    cout, rload : float
        Filter capacitor (F) and load (Ω).
    vc0 : float
        Initial v(C1) = v(p, n), V.
    tstop, tstep : float
        ``.tran`` stop time and step (s); the step defaults to 1/2000 of the line period.
    title : str, optional
        First line of the netlist.

    Returns
    -------
    str
        The netlist (state ``v(C1)``; diodes D1..D4; input Vs).
    """
    _positive(vpk=vpk, f=f, cout=cout, rload=rload)
    return _join(
        title or f"Full-wave diode bridge rectifier ({_num(vpk)} V peak, {f:g} Hz) with "
                 "capacitor filter",
        "* sine ac1 -> ground ; bridge D1..D4 ; C1 || R1 from p to n",
        _params(vpk=vpk, f=f, cout=cout, rload=rload),
        "Vs ac1 0 SIN(0 {vpk} {f})",
        "D1 ac1 p DIDEAL",
        "D2 0 p DIDEAL",
        "D3 n ac1 DIDEAL",
        "D4 n 0 DIDEAL",
        "C1 p n {cout}" + _ic(vc0),
        "R1 p n {rload}",
        DIODE_MODEL,
        _tran(tstep or 1 / (2000 * f), tstop),
        ".end",
    )


# -- closed-loop converters ------------------------------------------------------------------


def vm_buck(vin: float = 15.0, a: float = 8.4, vref: float = 11.3, vl: float = 3.8,
            vu: float = 8.2, tp: float = 400e-6, lind: float = 20e-3, cout: float = 47e-6,
            rload: float = 22.0, *, il0: float = 0.0, vc0: float = 0.0,
            tstop: float = 40e-3, tstep: float | None = None,
            title: str | None = None) -> str:
    """Voltage-mode controlled buck (Deane and Hamill 1990; chaos benchmark).

    Power stage as :func:`buck`; the control voltage ``v(con) = a (v(out) - vref)`` (a VCVS)
    is compared with a sawtooth from vl to vu of period tp; S1 conducts while the ramp is
    above the control voltage (``S1 in sw ramp con``, VT = VH = 0: the ideal comparator).
    vin is the bifurcation parameter: period 1 at 15 V, period doubling near 24.5 V, chaos
    above about 32 V.

    Parameters
    ----------
    vin : float
        Input voltage E, V.
    a, vref : float
        Error-amplifier gain (V/V) and reference (V).
    vl, vu, tp : float
        Ramp low and high voltage (V) and period (s).
    lind, cout, rload : float
        L1 (H), C1 (F), load R1 (Ω).
    il0, vc0 : float
        Initial i(L1) (A) and v(out) (V).
    tstop, tstep : float
        ``.tran`` stop time and step (s); the step defaults to tp/400.
    title : str, optional
        First line of the netlist.

    Returns
    -------
    str
        The netlist (states ``i(L1)``, ``v(C1)``; diode D1; switch S1 controlled by
        ``v(ramp, con)``; inputs Vin, Vref, Vramp).
    """
    _positive(vin=vin, a=a, tp=tp, lind=lind, cout=cout, rload=rload)
    if not vu > vl:
        raise ValueError(f"the ramp needs vu > vl, got vl={vl}, vu={vu}")
    return _join(
        title or f"Voltage-mode controlled buck converter (Deane-Hamill), E = {_num(vin)} V",
        "* Vin -- S1 -- sw ; D1 from ground to sw ; L1 sw -> out ; C1 || R1 at out ;"
        " S1 on while v(ramp) > v(con) = a (v(out) - vref)",
        _params(vin=vin, a=a, vref=vref, vl=vl, vu=vu, tp=tp, rload=rload, lind=lind,
                cout=cout),
        ".param tfall=10n",
        "Vin in 0 DC {vin}",
        "S1 in sw ramp con SWIDEAL",
        "D1 0 sw DIDEAL",
        "L1 sw out {lind}" + _ic(il0),
        "C1 out 0 {cout}" + _ic(vc0),
        "R1 out 0 {rload}",
        "Vref ref 0 DC {vref}",
        "Econ con 0 out ref {a}",
        "* sawtooth: rise over tp - 2 tfall, stay at vu for tfall, fall in tfall",
        "Vramp ramp 0 PULSE({vl} {vu} 0 {tp-2*tfall} {tfall} {tfall} {tp})",
        ".model SWIDEAL SW(VT=0 VH=0 RON=1m ROFF=1e9)",
        DIODE_MODEL,
        _tran(tstep or tp / 400, tstop),
        ".end",
    )


def boost_smc(vin: float = 12.0, iref: float = 2.0, lind: float = 1e-3, cout: float = 100e-6,
              rload: float = 50.0, vh: float = 50e-3, *, il0: float = 0.0, vc0: float = 0.0,
              tstop: float = 30e-3, tstep: float = 0.2e-6, title: str | None = None) -> str:
    """Boost converter under sliding-mode current control.

    Power stage as :func:`boost` with a 0 V source Vsense in series with L1; the sliding
    surface s = i(L1) - iref appears as v(s) (1 V per A, CCVS Hs on top of v(ref) = -iref);
    S1 is on while ``v(0) - v(s) > 0`` (i.e. s < 0), with hysteresis ±vh (the switching band
    ±vh A of ngspice; the ideal sliding mode has vh = 0). Steady state by power balance:
    v(out) = sqrt(vin iref rload).

    Parameters
    ----------
    vin : float
        Input voltage, V.
    iref : float
        Inductor-current reference, A.
    lind, cout, rload : float
        L1 (H), C1 (F), load R1 (Ω).
    vh : float
        Switch hysteresis VH (V of v(s), i.e. A of i(L1)).
    il0, vc0 : float
        Initial i(L1) (A) and v(out) (V).
    tstop, tstep : float
        ``.tran`` stop time and step (s).
    title : str, optional
        First line of the netlist.

    Returns
    -------
    str
        The netlist (states ``i(L1)``, ``v(C1)``; diode D1; switch S1 controlled by
        ``v(0, s)``; inputs Vin, Vsense, Viref).
    """
    _positive(vin=vin, iref=iref, lind=lind, cout=cout, rload=rload)
    if not (math.isfinite(vh) and vh >= 0):
        raise ValueError(f"vh must be >= 0, got {vh!r}")
    return _join(
        title or f"Boost converter under sliding-mode current control (iref = {_num(iref)} A)",
        "* Vin -- Vsense -- L1 -- sw ; S1 sw -> 0 ; D1 sw -> out ; C1 || R1 at out ;"
        " v(s) = i(L1) - iref ; S1 on while s < 0",
        _params(vin=vin, iref=iref, rload=rload, lind=lind, cout=cout, vh=vh),
        "Vin in 0 DC {vin}",
        "Vsense in ls 0",
        "L1 ls sw {lind}" + _ic(il0),
        "S1 sw 0 0 s SWIDEAL",
        "D1 sw out DIDEAL",
        "C1 out 0 {cout}" + _ic(vc0),
        "R1 out 0 {rload}",
        "Viref ref 0 DC {-iref}",
        "Hs s ref Vsense 1",
        ".model SWIDEAL SW(VT=0 VH={vh} RON=1m ROFF=1e9)",
        DIODE_MODEL,
        _tran(tstep, tstop),
        ".end",
    )


# -- registry and helpers --------------------------------------------------------------------

#: Factory by name.
FACTORIES: dict[str, Callable[..., str]] = {
    "buck": buck,
    "boost": boost,
    "buck-boost": buck_boost,
    "cuk": cuk,
    "prc": prc,
    "vm-buck": vm_buck,
    "boost-smc": boost_smc,
    "bridge-rectifier": bridge_rectifier,
}

#: Bundled netlist file -> (factory name, keyword arguments that reproduce its LCS).
BUNDLED: dict[str, tuple[str, dict[str, float]]] = {
    "buck.cir": ("buck", {}),
    "boost.cir": ("boost", {}),
    "boost_dcm.cir": ("boost", {"duty": 0.3, "lind": 20e-6, "rload": 50.0, "tstop": 20e-3}),
    "buck_boost.cir": ("buck-boost", {}),
    "cuk.cir": ("cuk", {}),
    "prc.cir": ("prc", {}),
    "vm_buck.cir": ("vm-buck", {}),
    "boost_smc.cir": ("boost-smc", {}),
    "bridge_rectifier.cir": ("bridge-rectifier", {}),
}


def _factory(name: str) -> Callable[..., str]:
    key = name.lower().replace("_", "-").replace("č", "c")
    if key == "buckboost":
        key = "buck-boost"
    try:
        return FACTORIES[key]
    except KeyError:
        raise KeyError(f"unknown converter {name!r}; choose one of "
                       f"{', '.join(FACTORIES)}") from None


def circuit(name: str, **params) -> Circuit:
    """Parse the netlist of a factory into a Circuit.

    Parameters
    ----------
    name : str
        Factory name (``"boost"``, ``"buck-boost"``, ``"cuk"``, ``"prc"``, ...).
    **params
        Keyword arguments of the factory.

    Returns
    -------
    Circuit
        Ready for :func:`netlist.formulation.formulate` or
        :func:`netlist.studies.transient.simulate_circuit`.
    """
    return parse_string(_factory(name)(**params), file=f"<{name}>")


def netlist_path(filename: str) -> Path:
    """Path of a bundled netlist, e.g. ``netlist_path("boost.cir")``."""
    return NETLIST_DIR / filename


def params_from_design(d: ConverterDesign) -> dict[str, float]:
    """Keyword arguments of the factory of ``d.topology`` that build the designed converter.

    Parameters
    ----------
    d : ConverterDesign
        From :func:`converters.design.design`.

    Returns
    -------
    dict
        ``vin, duty, fs, rload`` and the topology's inductors and capacitors (``lind,
        cout``; Čuk: ``l1, c1, l2, c2``).
    """
    topology = _check_topology(d.topology)
    kw = {"vin": d.vin, "duty": d.duty, "fs": d.fs, "rload": d.R}
    if topology == "cuk":
        kw.update(l1=d.L, l2=d.L2, c1=d.C1, c2=d.C)
    else:
        kw.update(lind=d.L, cout=d.C)
    return kw
