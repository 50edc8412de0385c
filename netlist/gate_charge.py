"""An idealised MOSFET's gate-drain capacitance as the chord of its model's charge over the
swing a run puts across it.

With ``--devices pwl`` a MOSFET keeps its gate as a linear RC (:mod:`netlist.pwl`): the
switch turns where the gate–source voltage behind the gate resistance crosses the threshold,
and the gate-drain capacitance carries the drain's swing back into the gate (the Miller
charge that lengthens each edge). In the device that capacitance depends on the gate-drain
voltage, by a factor of ten or more between the on state (gate above drain) and the off
state (drain tens of volts above the gate):

* ngspice's VDMOS (``devsup.c``, ``DevCapVDMOS``): ``Cgd = s tanh(a vgd) + y`` for ``vgd > 0``,
  ``s atan(a vgd) + y`` below, ``s = (CGDMAX - CGDMIN)/(1 + π/2)``, ``y = CGDMAX - s``: from
  CGDMAX with the gate above the drain to CGDMIN far below;
* Symmetry's power MOS macro-model (MODPEX: a VCVS of the drain-gate voltage whose branch
  currents are mirrored into the gate): a capacitor ``CAP`` while the drain is below the
  gate, a diode's depletion capacitance ``CJO (1 + vdg/VJ)^-M`` while above.

A constant at its largest value (what the gate RC held before) moves three times the charge
of an edge: a SEPIC of an IRF520N macro at 60 kHz gave 18.5 V where ngspice gives 13.3 V.
The capacitance that moves the model's charge between the ends of the swing the ideal run
puts across the gate and drain (the chord, as a diode's depletion charge in
:mod:`netlist.junction_charge`) gives 13.4 V.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from .circuit import GROUND, Circuit, Switch

__all__ = ["GateDrainLaw", "chord_capacitance", "gate_drain_chords", "gate_law",
           "macro_gate_drain", "vdmos_law"]


@dataclass(frozen=True)
class GateDrainLaw:
    """The gate-drain capacitance of a MOSFET as a function of its gate-drain voltage.

    Attributes
    ----------
    kind : str
        ``"vdmos"`` (``params`` = CGDMIN, CGDMAX, A, F, F, 1/V) or ``"symmetry"`` (``params``
        = CAP, CJO, VJ, M: F, F, V, 1).
    params : tuple of float
    gate, drain : str
        The (flattened) nodes of its gate and drain terminals.
    sign : float
        +1 for an N-channel device, -1 for a P-channel one: ``vgd = sign (v(gate) -
        v(drain))``, ngspice's oriented gate-drain voltage.
    """

    kind: str
    params: tuple[float, ...]
    gate: str
    drain: str
    sign: float = 1.0

    def capacitance(self, vgd: np.ndarray) -> np.ndarray:
        """Cgd, F, at oriented gate-drain voltages ``vgd``, V."""
        v = np.asarray(vgd, dtype=float)
        if self.kind == "vdmos":
            cmin, cmax, a = self.params
            s = (cmax - cmin) / (1 + math.pi / 2)
            y = cmax - s
            return np.where(v > 0, s * np.tanh(a * v) + y, s * np.arctan(a * v) + y)
        cap, cjo, vj, m = self.params
        vdg = np.maximum(-v, 0.0)
        return np.where(v > 0, cap, cjo * (1 + vdg / vj) ** (-m))


def chord_capacitance(law: GateDrainLaw, lo: float, hi: float) -> float:
    """The capacitance, F, that moves ``law``'s charge between ``lo`` and ``hi`` (oriented
    gate-drain voltages, V): ``∫ C dv / (hi - lo)``; C at the point where they meet."""
    if not hi - lo > 1e-9:
        return float(law.capacitance(np.array([0.5 * (lo + hi)]))[0])
    v = np.linspace(lo, hi, 4001)
    return float(np.trapezoid(law.capacitance(v), v) / (hi - lo))


def vdmos_law(model, mult: float, gate: str, drain: str) -> GateDrainLaw | None:
    """A VDMOS model's :class:`GateDrainLaw` (ngspice 39's defaults CGDMIN 0, CGDMAX 0, A 1
    where not given: measured); None where a value is not a number or CGDMAX is 0 (no
    gate-drain capacitance). ``mult``, the instance's m, only has to be positive: ngspice 39
    scales a VDMOS's current by m but not its capacitances (the gate charge of m = 3 is
    m = 1's, as :func:`netlist.devices.gate_rc` takes CGS and CGDMAX)."""
    p = {k.lower(): v for k, v in model.params.items()}
    vals = [p.get("cgdmin", 0.0), p.get("cgdmax", 0.0), p.get("a", 1.0)]
    if not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals):
        return None
    cmin, cmax, a = (float(v) for v in vals)
    if not (cmax >= cmin >= 0 and cmax > 0 and a > 0 and mult > 0):
        return None
    sign = -1.0 if p.get("pchan") else 1.0
    return GateDrainLaw("vdmos", (cmin, cmax, a), gate, drain, sign)


def gate_law(el, model, gate: str, drain: str, scope=None) -> GateDrainLaw | None:
    """The :class:`GateDrainLaw` of an M element ``el`` of a VDMOS ``model`` (its m read as
    :func:`netlist.devices.instance_geometry` reads it on ``scope``), else None."""
    if getattr(el, "kind", "") != "M" or model.type != "VDMOS":
        return None
    from .devices import instance_geometry

    mult = instance_geometry(el, *scope)[2] if scope is not None else 1.0
    return vdmos_law(model, mult, gate, drain) if math.isfinite(mult) else None


def macro_gate_drain(sub, dev, value: Callable[[object], float],
                     model_of: Callable[[str], object]) -> tuple[float, tuple | None]:
    """A macro-model's gate-drain feedback (Symmetry's power MOS: a capacitor on the output
    of a VCVS of the drain-gate voltage, its current mirrored into the gate, and a diode's
    depletion charge on the same output behind a resistor): the capacitors' sum, F (the
    constant the gate RC took), and the law's (kind, params) where the structure is that
    one exactly (one capacitor, one diode with CJO), else None.

    ``value(element)``: an element's value (Ω, F); ``model_of(ref)``: a diode's model."""
    els = sub.body.elements
    d, g = dev.nodes[0].lower(), dev.nodes[1].lower()
    feedback = {n.lower() for e in els if e.kind == "E"
                and {c.lower() for c in e.control} == {d, g} for n in e.nodes[:2]} - {"0"}
    caps = [e for e in els if e.kind == "C" and {n.lower() for n in e.nodes[:2]} & feedback]
    total = sum(value(e) for e in caps)
    beside = {n.lower() for e in els if e.kind == "R"
              and {n.lower() for n in e.nodes[:2]} & feedback for n in e.nodes[:2]}
    junctions = [e for e in els if e.kind == "D" and {n.lower() for n in e.nodes[:2]}
                 & (beside - feedback)]
    models = [model_of(e.ref) for e in junctions]
    cjo = [float(m.params.get("cjo", 0.0)) if m is not None else 0.0 for m in models]
    if len(caps) != 1 or len([c for c in cjo if c > 0]) != 1 or not total > 0:
        return total, None
    m = models[[i for i, c in enumerate(cjo) if c > 0][0]]
    vj, mexp = float(m.params.get("vj", 1.0)), float(m.params.get("m", 0.5))
    return total, ("symmetry", (total, max(cjo), vj, mexp))


def gate_drain_chords(circuit: Circuit, voltage: Callable[[str], np.ndarray]
                      ) -> tuple[Circuit, list[str]]:
    """``circuit`` with each idealised MOSFET's gate RC taking the chord of its gate-drain
    law over the oriented gate-drain voltages of a run (``voltage(node)``: its node
    voltages, V; ground 0), and a note for each."""
    out, notes = [], []
    for el in circuit.elements:
        law = getattr(el, "cgd_law", None)
        if isinstance(el, Switch) and law is not None and el.gate_rc is not None:
            vg = voltage(law.gate) if law.gate != GROUND else 0.0
            vd = voltage(law.drain) if law.drain != GROUND else 0.0
            vgd = law.sign * (np.asarray(vg, dtype=float) - np.asarray(vd, dtype=float))
            lo, hi = float(np.min(vgd)), float(np.max(vgd))
            cgd = chord_capacitance(law, lo, hi)
            rg, cgs, before = el.gate_rc
            el = replace(el, gate_rc=(rg, cgs, cgd))
            what = ("VDMOS CGDMIN..CGDMAX" if law.kind == "vdmos" else
                    "the macro-model's CAP with the drain below the gate, its diode's "
                    "depletion above")
            notes.append(f"{el.name}: gate-drain capacitance {cgd:.4g} F, the chord of "
                         f"its model's charge ({what}) "
                         f"over the {lo:.4g}..{hi:.4g} V of gate-drain voltage the ideal run "
                         f"puts across it (its largest value, {before:.4g} F, moves more "
                         "charge at each edge than the device does)")
        out.append(el)
    return replace(circuit, elements=out), notes
