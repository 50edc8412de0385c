"""Circuits built with PySpice: PySpice's own buck example, as its
``examples/switched-power-supplies/buck-converter.py`` builds it, and its rectifiers
(``examples/diode/rectification.py``: half-wave and bridge, with NXP's 1N4148), for tests and
examples."""

from __future__ import annotations

from pathlib import Path

__all__ = ["pyspice_buck", "pyspice_rectifier"]

VENDOR = Path(__file__).resolve().parents[1] / "tests" / "netlists" / "devices" / "vendor"


def pyspice_buck(vendor=None):
    """PySpice's buck example (examples/switched-power-supplies/buck-converter.py), built the
    same way with the PySpice API and its two vendor libraries (``vendor``: default
    tests/netlists/devices/vendor, origin in ORIGIN.md there): 12 V -> 5 V, 2 A, 400 kHz.
    Needs PySpice."""
    from PySpice.Spice.Netlist import Circuit
    from PySpice.Unit import u_A, u_F, u_H, u_kHz, u_V, u_Ω

    vendor = Path(vendor) if vendor is not None else VENDOR
    c = Circuit("Buck Converter")
    c.include(str(vendor / "1N5822.lib"))
    c.include(str(vendor / "irf150.lib"))
    vin, vout, iload = 12 @ u_V, 5 @ u_V, 2 @ u_A
    rload = vout / (.8 * iload)
    period = (400 @ u_kHz).period
    duty = vout / vin * period
    ripple_i = .3 * iload
    L = (vin - vout) * duty / ripple_i
    esr = 30e-3
    cout = (ripple_i * duty) / (50e-3 - ripple_i * esr)
    cin = duty / (.2 / (iload / 2) - .12)
    c.V("in", "in", c.gnd, vin)
    c.C("in", "in", c.gnd, float(cin) @ u_F)
    c.X("Q", "irf150", "in", "gate", "source")
    c.R("gate", "gate", "clock", 1 @ u_Ω)
    c.PulseVoltageSource("pulse", "clock", c.gnd, 0 @ u_V, 2. * vin, duty, period)
    c.X("D", "1N5822", c.gnd, "source")
    c.L(1, "source", 1, float(L) @ u_H)
    c.R("L", 1, "out", 37e-3 @ u_Ω)
    c.C(1, "out", c.gnd, float(cout) @ u_F)
    c.R("load", "out", c.gnd, rload)
    return c


def pyspice_rectifier(kind: str = "half", capacitor: bool = False, vendor=None):
    """PySpice's rectifiers (examples/diode/rectification.py), built the same way: a 10 V,
    50 Hz sine through NXP's 1N4148 (a subcircuit: the diode and a 5.8 GΩ leakage resistor)
    into 100 Ω, ``kind`` ``"half"`` (one diode) or ``"bridge"`` (four), with ``capacitor`` a
    1 mF filter across the load; two periods, PySpice's step of a 200th of a period. Needs
    PySpice."""
    from PySpice.Spice.Netlist import Circuit
    from PySpice.Unit import u_Hz, u_mF, u_V, u_Ω

    if kind not in ("half", "bridge"):
        raise ValueError(f"kind must be 'half' or 'bridge', got {kind!r}")
    vendor = Path(vendor) if vendor is not None else VENDOR
    c = Circuit(f"{kind}-wave rectification" if kind == "half" else "full-wave rectification")
    c.include(str(vendor / "1N4148.lib"))
    src = c.SinusoidalVoltageSource("input", "in", c.gnd, amplitude=10 @ u_V,
                                    frequency=50 @ u_Hz)
    if kind == "half":
        c.X("D1", "1N4148", "in", "output")
        c.R("load", "output", c.gnd, 100 @ u_Ω)
        top, bottom = "output", c.gnd
    else:
        c.X("D1", "1N4148", "in", "output_plus")
        c.R("load", "output_plus", "output_minus", 100 @ u_Ω)
        c.X("D2", "1N4148", "output_minus", c.gnd)
        c.X("D3", "1N4148", c.gnd, "output_plus")
        c.X("D4", "1N4148", "output_minus", "in")
        top, bottom = "output_plus", "output_minus"
    if capacitor:
        c.C("1", top, bottom, 1 @ u_mF)
    period = float(src.period)
    c.raw_spice = f".tran {period / 200:g} {2 * period:g}"
    return c
