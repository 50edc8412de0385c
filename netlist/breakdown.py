"""Reverse breakdown of diodes (a model's ``BV``) with ``--devices pwl``.

ngspice's diode conducts in reverse past its breakdown voltage: with ``vd`` its voltage
(anode to cathode), below ``-BV`` its current is ``-IS exp(-(vd + xbv) / (NBV Vt))``
(dioload.c), ``xbv`` set so that the current at ``vd = -BV`` is ``IBV`` (diotemp.c:
``IS (exp((BV - xbv) / (NBV Vt)) - 1 + xbv / Vt) = IBV``; ``xbv = BV`` when ``IBV`` is below
``IS BV / Vt``). Defaults: ``IBV`` 1 mA, ``NBV`` the model's ``N``. So in breakdown the
reverse voltage at a reverse current ``I`` is ``xbv + NBV Vt ln(I / IS) + RS I``: a diode's
characteristic (:func:`netlist.pwl.diode_voltage`) with the saturation current
``IS exp(-xbv / (NBV Vt))``, emission coefficient ``NBV`` and ``RS``.

The piecewise-linear diode of :mod:`netlist.pwl` blocks any reverse voltage. Where a run
takes a diode past its ``BV`` (the ideal run that sizes the fits, or the piecewise-linear
run itself), :func:`netlist.studies.realistic.simulate_devices` gives it a reversed branch in
parallel (:func:`breakdown_elements`): an ideal diode from its cathode, a source and a
resistor to its anode, the line fitted to the breakdown characteristic over ``[IBV/20,
IBV]`` (the current the model states its ``BV`` at), or, where the run takes it well outside
that range, over ``[I/20, I]`` with ``I`` the current it carries there (one more run). A note
says so.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .circuit import Circuit, Diode, Resistor, VoltageSource
from .pwl import VT_THERMAL, diode_fit, diode_params

__all__ = ["Breakdown", "breakdown_elements", "breakdowns"]


@dataclass(frozen=True)
class Breakdown:
    """A diode's reverse breakdown: its ``name``, terminals ``anode``, ``cathode``, and its
    model's ``bv`` (V), ``ibv`` (A), ``nbv``, ``is_`` (A, area included) and ``rs`` (Ω)."""

    name: str
    anode: str
    cathode: str
    bv: float
    ibv: float
    nbv: float
    is_: float
    rs: float

    @property
    def probe(self) -> str:
        """The reverse voltage's probe, cathode to anode."""
        return f"v({self.cathode},{self.anode})"

    @property
    def xbv(self) -> float:
        """ngspice's ``xbv`` (V): the breakdown line's offset (module docstring)."""
        vt = VT_THERMAL
        if self.ibv < self.is_ * self.bv / vt:
            return self.bv
        x = self.bv - self.nbv * vt * math.log1p(self.ibv / self.is_)
        for _ in range(25):
            x = self.bv - self.nbv * vt * math.log(self.ibv / self.is_ + 1.0 - x / vt)
        return x

    def fit(self, top: float | None = None) -> tuple[float, float]:
        """``(vf, ron)`` of the reversed branch (V, Ω): :func:`netlist.pwl.diode_fit` of the
        breakdown characteristic over ``[top/20, top]`` (A; default ``IBV``)."""
        is_bv = self.is_ * math.exp(-self.xbv / (self.nbv * VT_THERMAL))
        return diode_fit(is_bv, self.nbv, self.rs, self.ibv if top is None else top)


def breakdowns(circuit: Circuit) -> dict[str, Breakdown]:
    """The diodes whose model gives a breakdown voltage ``BV > 0``, by name (plain diode
    elements: a macro-model's junctions are not theirs alone)."""
    out = {}
    for el in circuit.elements:
        if not isinstance(el, Diode) or not el.model or \
                (el.device is not None and len(el.device) > 4):
            continue
        m = circuit.models.get(str(el.model).lower())
        if m is None:
            continue
        p = {k.lower(): float(v) for k, v in m.params.items()}
        bv = abs(p.get("bv", 0.0))
        if not (bv > 0 and math.isfinite(bv)):
            continue
        (params,), _ = diode_params(circuit, el, {})
        out[el.name] = Breakdown(el.name, el.nodes[0], el.nodes[1], bv,
                                 abs(p.get("ibv", 1e-3)) * float(el.area or 1.0),
                                 p.get("nbv", params["n"]), params["is"], params["rs"])
    return out


def breakdown_elements(bd: Breakdown, top: float | None = None) -> tuple[list, str]:
    """The reversed branch of a diode in breakdown (``<name>#bv``, ``#vbv``, ``#rbv``, on
    nodes ``<name>#z``, ``#zr``), its line fitted over ``[top/20, top]`` (A; default
    ``IBV``, else the current a run took it to), and the line for its note."""
    vf, ron = bd.fit(top)
    hi = bd.ibv if top is None else top
    sized = "" if top is None else ", the current its run takes it to"
    key = bd.name.lower()
    z, zr = f"{key}#z", f"{key}#zr"
    parts: list = [Diode(f"{bd.name}#bv", (bd.cathode, z), None),
                   VoltageSource(f"{bd.name}#vbv", (z, zr), None, vf)]
    if ron > 0:
        parts.append(Resistor(f"{bd.name}#rbv", (zr, bd.anode), None, ron))
    else:
        parts[-1] = VoltageSource(f"{bd.name}#vbv", (z, bd.anode), None, vf)
    line = (f"{bd.name}: reverse breakdown past BV = {bd.bv:.4g} V (its run takes it there): "
            f"a reversed branch in parallel, Vf = {vf:.4g} V, Ron = {ron:.4g} Ω (fit of "
            f"BV={bd.bv:.4g} IBV={bd.ibv:.3g} NBV={bd.nbv:.3g} RS={bd.rs:.3g} over "
            f"{hi / 20:.3g}..{hi:.3g} A{sized})")
    return parts, line
