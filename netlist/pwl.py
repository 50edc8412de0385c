"""Piecewise-linear devices (``--devices pwl``): diodes with a forward voltage and
an on-resistance, switches with an on-resistance, still a linear complementarity system.

A diode becomes an ideal diode in series with a source ``Vf`` and a resistor ``Ron`` (so
``v = Vf + Ron i`` while it conducts): ``Ron`` enters the LCS's D, which also makes the
LCP's solution unique, and ``Vf`` enters F. The pair is **fitted** to the diode's model,
``v(i) = N Vt ln(1 + i/IS) + RS i`` (Vt = 25.85 mV at 27 °C; ngspice's defaults IS = 1e-14 A,
N = 1, RS = 0), by least squares on 50 currents log-spaced over ``[I/20, I]``, I the current
the diode carries in an ideal run of the same circuit (:func:`carried_current`: the current
it stays below for 99 % of its conduction time, so that an inrush lasting a step or two, which
in an ideal circuit only the time step limits, does not set the range); a diode that carries
nothing keeps ``Vf`` at 1 mA and no resistance. The fit is **bounded** to physical values:
``0 <= Vf <= v(I)`` and ``RS <= Ron <= dv/di`` at ``I/20`` (the line's slope lies between the
diode's slopes at both ends of the range). Diodes merged in parallel are fitted together
(their total current). ``Vf`` and ``Ron`` may also be given per element or model (``--pwl
NAME=VF:RON``), then used as they are.

A switch is ``Ron`` when on: ``RON`` of its SW model (ngspice's default 1 Ω), or for an
idealised MOSFET the channel resistance at its gate drive from the model, ``RD + RS +
1/(KP (Vgs - VTO))`` (the triode region at small drain-source voltage), Vgs the largest
control voltage of the ideal run; for a BJT ``RC + RE`` and a saturation drop of 0.2 V (as a
source in series, like a diode's Vf). A MOSFET keeps what sets its switching instants: its
gate as a linear RC (``Switch.gate_rc``, from ``netlist.flatten``: the model's gate
resistance, its gate-source capacitance to the source and its gate-drain capacitance to the
drain, at a fixed bias), and the switch turns when the gate-source voltage behind the gate
resistance crosses the threshold, as the channel does.
The added elements are named ``<element>#vf`` and ``<element>#ron`` on internal nodes
``<element>#a``/``#b``; they belong to pelcs' model only (ngspice keeps the real devices).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .circuit import Capacitor, Circuit, Diode, Resistor, Switch, VoltageSource
from .reductions import parallel_diodes

__all__ = ["PwlFit", "VT_THERMAL", "carried_current", "diode_fit", "diode_params",
           "diode_residual", "diode_voltage", "parallel_fit", "parallel_voltage",
           "pwl_circuit", "switch_residual", "switch_resistance"]

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


def carried_current(t: np.ndarray, i: np.ndarray, quantile: float = 0.99) -> float:
    """The current a device carries, A: the level ``|i|`` stays below for ``quantile`` of
    the time it conducts (samples weighted by their time step), so that a spike of a step or
    two (an ideal diode charging a capacitor from a step, limited only by the time step)
    does not count. 0 when it never conducts."""
    t, a = np.asarray(t, float), np.abs(np.asarray(i, float))
    if len(a) < 2 or not np.any(a > 0):
        return 0.0
    dt = np.diff(t)
    mid = np.maximum(a[:-1], a[1:])  # each interval at its larger end
    on = (mid > 1e-6 * mid.max()) & (dt > 0)
    if not on.any():
        return float(a.max())
    x, w = mid[on], dt[on]
    order = np.argsort(x)
    cum = np.cumsum(w[order])
    k = int(np.searchsorted(cum, quantile * cum[-1]))
    return float(x[order][min(k, len(x) - 1)])


def diode_voltage(i: np.ndarray, is_: float, n: float, rs: float) -> np.ndarray:
    """Shockley's equation with series resistance, ``N Vt ln(1 + i/IS) + RS i`` (V)."""
    i = np.asarray(i, float)
    return n * VT_THERMAL * np.log1p(i / is_) + rs * i


def _bounded_line(i: np.ndarray, v: np.ndarray, ron_lo: float, ron_hi: float,
                  v_hi: float) -> tuple[float, float]:
    """Least-squares ``v = vf + ron i`` with ``ron`` in [ron_lo, ron_hi] and ``vf`` in
    [0, v_hi] (the least squares in one variable once the other is held at a bound)."""
    ron, vf = np.polyfit(i, v, 1)
    ron = min(max(float(ron), ron_lo), ron_hi)
    vf = float(np.mean(v - ron * i))  # best offset for the bounded slope
    if not 0.0 <= vf <= v_hi:
        vf = min(max(vf, 0.0), v_hi)
        ron = float(np.dot(i, v - vf) / np.dot(i, i))
        ron = min(max(ron, ron_lo), ron_hi)
    return vf, ron


def diode_fit(is_: float, n: float, rs: float, i_max: float) -> tuple[float, float]:
    """Least-squares ``(Vf, Ron)`` of :func:`diode_voltage` over ``[i_max/20, i_max]``
    (50 log-spaced currents, A), bounded as the module docstring says; V and Ω."""
    if not (i_max > 1e-9 and math.isfinite(i_max)):  # it carries nothing worth a fit
        return n * VT_THERMAL * math.log1p(1e-3 / is_), rs
    i = np.logspace(np.log10(i_max / 20.0), np.log10(i_max), 50)
    v = diode_voltage(i, is_, n, rs)
    slope_lo = n * VT_THERMAL / (is_ + i[0]) + rs  # dv/di at the low end: the steepest
    return _bounded_line(i, v, rs, slope_lo, float(v[-1]))


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


def parallel_voltage(params: list[dict], i: np.ndarray) -> np.ndarray:
    """Voltage of diodes in parallel carrying a total current ``i`` (A), V: their total
    current's characteristic inverted on a fine voltage grid (0.5 mV)."""
    v = np.linspace(0.0, 3.0, 6001)
    total = sum(_branch_current(v, p["is"], p["n"], p["rs"]) for p in params)
    return np.interp(np.asarray(i, float), total, v)


def parallel_fit(params: list[dict], i_max: float) -> tuple[float, float]:
    """:func:`diode_fit` of diodes in parallel (a Schottky macro's junction and guard ring):
    the total current's characteristic (:func:`parallel_voltage`)."""
    if len(params) == 1:
        p = params[0]
        return diode_fit(p["is"], p["n"], p["rs"], i_max)
    if not (i_max > 1e-9 and math.isfinite(i_max)):
        i_max = 1e-3
    i = np.logspace(np.log10(i_max / 20.0), np.log10(i_max), 50)
    vi = parallel_voltage(params, i)
    slope_lo = float(np.gradient(vi, i)[0])
    # no line flatter than the series resistances in parallel
    rs_min = (1.0 / sum(1.0 / p["rs"] for p in params)
              if all(p["rs"] > 0 for p in params) else 0.0)
    return _bounded_line(i, vi, min(rs_min, slope_lo), max(slope_lo, rs_min), float(vi[-1]))


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
            params, series = diode_params(circuit, el, merged)
            imax = i_max.get(el.name, 0.0)
            vf, ron = parallel_fit(params, imax)
            ron += series
            what = " || ".join(f"IS={p['is']:.3g} N={p['n']:.3g} RS={p['rs']:.3g}"
                               for p in params)
            span = (f"over {imax / 20:.3g}..{imax:.3g} A" if imax > 1e-9
                    else "at 1 mA: it carries no current in the ideal run")
            fits.append(PwlFit(el.name, vf, ron, f"fit of {what} {span}"))
            out.extend(_series(el, vf, ron))
        elif isinstance(el, Switch):
            ron, vdrop, how = switch_resistance(circuit, el, drives.get(el.name))
            gate = getattr(el, "gate_rc", None)
            if gate is not None:
                el, gate_parts = _gate(el, *gate)
                out.extend(gate_parts)
                how += (f"; gate {gate[0]:.3g} Ω (inside the device), Cgs {gate[1]:.3g} F, "
                        f"Cgd {gate[2]:.3g} F")
            fits.append(PwlFit(el.name, vdrop, ron, how))
            out.extend(_series(el, vdrop, ron))
        else:
            out.append(el)
    return replace(circuit, elements=out), fits


def diode_params(circuit: Circuit, el: Diode, merged: dict | None = None
                 ) -> tuple[list[dict], float]:
    """The junction models of a diode element (``{"is", "n", "rs"}`` each, ngspice's
    defaults filled in; several for a macro-model's or merged parallel diodes) and the
    series resistance of its macro-model (Ω)."""
    merged = parallel_diodes(circuit) if merged is None else merged
    # (model, area): ngspice scales IS by the area and RS by its inverse
    names = [(el.model, el.area)] if el.model else []
    series = 0.0
    if el.device is not None and len(el.device) > 4:  # a diode macro-model
        names, series = [(nm, 1.0) for nm in el.device[3]], float(el.device[4])
    names += [(e.model, getattr(e, "area", 1.0)) for e in circuit.elements
              if merged.get(e.key) == el.name and getattr(e, "model", "")]
    params = []
    for nm, area in names:
        m = circuit.models.get(str(nm).lower())
        p = dict(_DIODE_DEFAULTS)
        if m is not None:
            p.update({k.lower(): float(v) for k, v in m.params.items() if k.lower() in p})
        p["is"] *= area
        p["rs"] /= area
        params.append(p)
    return params or [dict(_DIODE_DEFAULTS)], series


def diode_residual(circuit: Circuit, el: Diode, vf: float, ron: float, i_lo: float,
                   i_hi: float) -> float:
    """Largest ``|vf + ron i - v(i)|`` over ``[i_lo, i_hi]`` (A), V: how far a diode's
    piecewise-linear line is from its model (:func:`diode_voltage` of its junctions in
    parallel, plus its macro-model's series resistance) over the currents it carries."""
    if not (i_hi > 0 and math.isfinite(i_hi)):
        return 0.0
    params, series = diode_params(circuit, el)
    i = np.logspace(np.log10(max(min(i_lo, i_hi), 1e-12)), np.log10(i_hi), 200)
    if len(params) == 1:
        p = params[0]
        v = diode_voltage(i, p["is"], p["n"], p["rs"])
    else:
        v = parallel_voltage(params, i)
    return float(np.max(np.abs(vf + ron * i - (v + series * i))))


def switch_residual(circuit: Circuit, sw: Switch, ron: float, i_max: float,
                    drive: float | None) -> float:
    """How far an idealised transistor's ``Ron`` (or BJT drop) is from its model at the
    current it carries, V: for a MOSFET the triode region's curvature, ``Vds - Ron_ch I`` with
    ``I = KP ((Vgs - VTO) Vds - Vds²/2)`` (the whole channel drop once it saturates); for a
    BJT the 0.2 V saturation drop itself (its model's drop is not computed); 0 for a SW
    switch, whose RON is exact."""
    device = getattr(sw, "device", None)
    if device is None or not i_max > 0:
        return 0.0
    letter, _, model_name = device[:3]
    if letter == "X":
        model_name = device[3]
    m = circuit.models.get(str(model_name).lower())
    if m is not None and m.type in ("NPN", "PNP"):
        return 0.2
    p = {k.lower(): float(v) for k, v in (m.params.items() if m else ())}
    kp, vt = p.get("kp", 0.0), abs(p.get("vto", p.get("vth", 0.0)))
    if kp <= 0:
        return 0.0
    vov = max((drive if drive is not None else vt + 5.0) - vt, 0.1)
    lin = i_max / (kp * vov)
    disc = vov * vov - 2.0 * i_max / kp
    return float(vov - math.sqrt(disc) - lin) if disc > 0 else float(max(vov, lin))


def _gate(sw: Switch, rg: float, cgs: float, cgd: float) -> tuple[Switch, list]:
    """A MOSFET switch's gate as a linear RC: ``rg`` from its gate terminal to an internal
    gate node, ``cgs`` from there to its source terminal and ``cgd`` to its drain; the
    switch is then controlled by the internal node (it turns when the gate-source voltage
    there crosses the threshold)."""
    drain, src = sw.nodes[0], sw.nodes[1]
    n_chan = sw.control[1] == src  # (gate, source); a P-channel's is (source, gate)
    g = sw.control[0] if n_chan else sw.control[1]
    inner = f"{sw.name.lower()}#g" if rg > 0 else g
    parts: list = []
    if rg > 0:
        parts.append(Resistor(f"{sw.name}#rg", (g, inner), sw.location, rg))
    if cgs > 0:
        parts.append(Capacitor(f"{sw.name}#cgs", (inner, src), sw.location, cgs))
    if cgd > 0:
        parts.append(Capacitor(f"{sw.name}#cgd", (inner, drain), sw.location, cgd))
    control = (inner, sw.control[1]) if n_chan else (sw.control[0], inner)
    return replace(sw, control=control), parts


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
