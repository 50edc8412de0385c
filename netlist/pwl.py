"""Piecewise-linear devices (``--devices pwl``): diodes with a forward voltage and
an on-resistance, switches with an on-resistance, still a linear complementarity system.

A diode becomes an ideal diode in series with a source ``Vf`` and a resistor ``Ron`` (so
``v = Vf + Ron i`` while it conducts): ``Ron`` enters the LCS's D, which also makes the
LCP's solution unique, and ``Vf`` enters F. The pair is **fitted** to the diode's model,
``v(i) = N Vt ln(1 + i/IS) + RS i`` (Vt = 25.85 mV at 27 °C; ngspice's defaults IS = 1e-14 A,
N = 1, RS = 0), by least squares on 50 currents log-spaced over ``[I/20, I]``, I the largest
current the diode carries in an ideal run of the same circuit (the current range the circuit
carries); a diode that carries nothing keeps ``Vf`` at 1 mA and no resistance. Diodes merged
in parallel are fitted together (their total current). ``Vf`` and ``Ron`` may also be given
per element or model (``--pwl NAME=VF:RON``), then used as they are.

A switch is ``Ron`` when on: ``RON`` of its SW model (ngspice's default 1 Ω), or for an
idealised MOSFET the channel resistance at its gate drive from the model, ``RD + RS +
1/(KP (Vgs - VTO))`` (the triode region at small drain-source voltage), Vgs the largest
control voltage of the ideal run; for a BJT ``RC + RE`` and a saturation drop of 0.2 V (as a
source in series, like a diode's Vf).

The added elements are named ``<element>#vf`` and ``<element>#ron`` on internal nodes
``<element>#a``/``#b``; they belong to pelcs' model only (ngspice keeps the real devices).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .circuit import Circuit, Diode, Resistor, Switch, VoltageSource
from .reductions import parallel_diodes

__all__ = ["PwlFit", "VT_THERMAL", "diode_fit", "parallel_fit", "pwl_circuit",
           "switch_resistance"]

#: thermal voltage at ngspice's nominal 27 °C, V
VT_THERMAL = 0.025852

_DIODE_DEFAULTS = {"is": 1e-14, "n": 1.0, "rs": 0.0}


@dataclass(frozen=True)
class PwlFit:
    """What a device became with ``--devices pwl``: ``v = vf + ron i`` while on.

    Attributes
    ----------
    element : str
    vf, ron : float
        V and Ω.
    how : str
        Where the numbers come from (fit range, model parameters).
    """

    element: str
    vf: float
    ron: float
    how: str

    def line(self) -> str:
        return f"{self.element}: Vf = {self.vf:.4g} V, Ron = {self.ron:.4g} Ω ({self.how})"


def diode_fit(is_: float, n: float, rs: float, i_max: float) -> tuple[float, float]:
    """Least-squares ``(Vf, Ron)`` of ``N Vt ln(1 + i/IS) + RS i`` over ``[i_max/20, i_max]``
    (50 log-spaced currents), V and Ω."""
    if not (i_max > 1e-9 and math.isfinite(i_max)):  # it carries nothing worth a fit
        return n * VT_THERMAL * math.log1p(1e-3 / is_), rs
    i = np.logspace(np.log10(i_max / 20.0), np.log10(i_max), 50)
    v = n * VT_THERMAL * np.log1p(i / is_) + rs * i
    ron, vf = np.polyfit(i, v, 1)
    return float(vf), float(max(ron, 0.0))


def _branch_current(v: np.ndarray, is_: float, n: float, rs: float) -> np.ndarray:
    """Current of one diode branch at voltage v: solve v = n Vt ln(1 + i/IS) + RS i."""
    i = is_ * np.expm1(np.minimum(v / (n * VT_THERMAL), 700.0))
    if rs <= 0:
        return i
    lo, hi = np.zeros_like(v), np.minimum(i, np.maximum(v, 0) / rs)
    for _ in range(200):  # bisection: monotone in i
        mid = 0.5 * (lo + hi)
        f = n * VT_THERMAL * np.log1p(mid / is_) + rs * mid - v
        lo, hi = np.where(f < 0, mid, lo), np.where(f < 0, hi, mid)
    return 0.5 * (lo + hi)


def parallel_fit(params: list[dict], i_max: float) -> tuple[float, float]:
    """:func:`diode_fit` of diodes in parallel (a Schottky macro's junction and guard ring):
    the total current's characteristic, inverted on a fine voltage grid."""
    if len(params) == 1:
        p = params[0]
        return diode_fit(p["is"], p["n"], p["rs"], i_max)
    if not (i_max > 1e-9 and math.isfinite(i_max)):
        i_max = 1e-3
    v = np.linspace(0.0, 3.0, 6001)
    total = sum(_branch_current(v, p["is"], p["n"], p["rs"]) for p in params)
    i = np.logspace(np.log10(i_max / 20.0), np.log10(i_max), 50)
    vi = np.interp(i, total, v)
    ron, vf = np.polyfit(i, vi, 1)
    return float(vf), float(max(ron, 0.0))


def switch_resistance(circuit: Circuit, sw: Switch, drive: float | None) -> tuple[float, float,
                                                                                   str]:
    """``(Ron, Vdrop, how)`` of a switch when on (Ω, V)."""
    device = getattr(sw, "device", None)
    if device is None:
        m = circuit.models.get(sw.model.lower())
        ron = float(m.params.get("ron", 1.0)) if m is not None else 1.0
        return ron, 0.0, "RON of its SW model" if m and "ron" in m.params else \
            "ngspice's default RON = 1 Ω"
    letter, _, model_name = device[:3]
    extra = 0.0
    if letter == "X":  # a macro-model: its transistor's model, and its series resistors
        model_name, extra = device[3], float(device[4])
    m = circuit.models.get(str(model_name).lower())
    p = {k.lower(): float(v) for k, v in (m.params.items() if m else ())}
    if m is not None and m.type in ("NPN", "PNP"):
        return p.get("rc", 0.0) + p.get("re", 0.0) + extra, 0.2, "RC + RE, 0.2 V saturation"
    vt = abs(p.get("vto", p.get("vth", 0.0)))
    kp = p.get("kp", 0.0)
    vgs = drive if drive is not None else vt + 5.0
    r_ch = 1.0 / (kp * max(vgs - vt, 0.1)) if kp > 0 else 0.0
    how = (f"RD + RS + 1/(KP (Vgs - VTO)) at Vgs = {vgs:.3g} V" if kp > 0
           else "RD + RS (no KP)")
    if extra:
        how += f" + the macro's series resistors {extra:.3g} Ω"
    return p.get("rd", 0.0) + p.get("rs", 0.0) + r_ch + extra, 0.0, how


def pwl_circuit(circuit: Circuit, i_max: dict[str, float], drives: dict[str, float],
                explicit: dict | None = None) -> tuple[Circuit, list[PwlFit]]:
    """The circuit with every diode and switch made piecewise linear (see the module
    docstring); ``i_max`` (A) and ``drives`` (V) by element name, from an ideal run;
    ``explicit``: ``{element or model name: (vf, ron)}`` given by the user (V, Ω), used as
    they are instead of a fit."""
    merged = parallel_diodes(circuit)
    given = {str(k).lower(): v for k, v in (explicit or {}).items()}
    out, fits = [], []
    for el in circuit.elements:
        if el.key in merged:
            continue  # carried by the diode it is in parallel with (one pair)
        model = str(getattr(el, "model", "") or "").lower()
        key = el.key if el.key in given else model if model in given else None
        if key is not None and isinstance(el, (Diode, Switch)):
            vf, ron = (float(v) for v in given[key])
            fits.append(PwlFit(el.name, vf, ron, "given"))
            out.extend(_series(el, vf, ron))
            continue
        if isinstance(el, Diode):
            names = [el.model] if el.model else []
            series = 0.0
            if el.device is not None and len(el.device) > 4:  # a diode macro-model
                names, series = list(el.device[3]), float(el.device[4])
            names += [e.model for e in circuit.elements
                      if merged.get(e.key) == el.name and getattr(e, "model", "")]
            params = []
            for nm in names:
                m = circuit.models.get(str(nm).lower())
                p = dict(_DIODE_DEFAULTS)
                if m is not None:
                    p.update({k.lower(): float(v) for k, v in m.params.items()
                              if k.lower() in p})
                params.append(p)
            if not params:
                params = [dict(_DIODE_DEFAULTS)]
            imax = i_max.get(el.name, 0.0)
            vf, ron = parallel_fit(params, imax)
            ron += series
            what = " || ".join(f"IS={p['is']:.3g} N={p['n']:.3g} RS={p['rs']:.3g}"
                               for p in params)
            fits.append(PwlFit(el.name, vf, ron, f"fit of {what} over {imax / 20:.3g}.."
                                                 f"{imax:.3g} A"))
            out.extend(_series(el, vf, ron))
        elif isinstance(el, Switch):
            ron, vdrop, how = switch_resistance(circuit, el, drives.get(el.name))
            fits.append(PwlFit(el.name, vdrop, ron, how))
            out.extend(_series(el, vdrop, ron))
        else:
            out.append(el)
    return replace(circuit, elements=out), fits


def _series(el, vf: float, ron: float) -> list:
    """``el`` between its first node and an internal node, then Vf and Ron to its second."""
    a, b = el.nodes[0], el.nodes[1]
    if vf == 0.0 and ron == 0.0:
        return [el]
    key = el.name.lower()
    parts = []
    node = f"{key}#a"
    parts.append(replace(el, nodes=(a, node)))
    if vf != 0.0:
        nxt = f"{key}#b" if ron > 0 else b
        parts.append(VoltageSource(f"{el.name}#vf", (node, nxt), el.location, vf))
        node = nxt
    if ron > 0:
        parts.append(Resistor(f"{el.name}#ron", (node, b), el.location, ron))
    return parts
