"""The two-transistor model of a thyristor read as an ideal thyristor.

Vendors' SCR models are a PNP and an NPN that drive each other's base (Littelfuse's
EC103xx: ``Qpnp 6 4 1``, ``Qnpn 4 6 5``, a gate resistor from the gate to node 6, a diode
from 6 to the NPN's emitter, breakover diodes and resistors of gigaohms). The loop fires and
latches through the base currents, which transistors idealised as switches do not draw
(:func:`netlist.base_drive.thyristor_pairs` refuses them). Such a pair is read here as an ideal
thyristor from the PNP's emitter (anode) to the NPN's emitter (cathode), built from elements
pelcs simulates exactly:

- the anode path: a 0 V source sensing the anode current, an ideal diode, then a switch
  to the cathode, driven by the sum of the anode and gate currents (two H sources in
  series, as a W switch is read): on once the gate carries :data:`GATE_CURRENT` (fired),
  off once both have fallen below :data:`HOLD_CURRENT` (latched while the anode current
  flows); :data:`OFF_RESISTANCE` from anode to cathode, outside the sensed path;
- the gate junction, from the NPN's base to its emitter: a source of :func:`gate_voltage`
  in series with an ideal diode (the NPN's base-emitter voltage at which the pair's loop
  gain reaches one), the source's current sensing the gate current. Diodes of
  the subcircuit across that junction (the model's ``Dgate``, whose IS is far below the
  NPN's) are part of it: ideal, they would hold the base at the emitter and the gate
  would fire at 0 V, half a millisecond early on a gate pulse rising over 1 ms.

So the thyristor blocks both ways until fired; fires when current enters its gate junction
while the anode stands above the cathode (or the gate is still driven when it does); then
conducts anode to cathode as an ideal diode whatever the gate, and turns off when its
current falls to zero. Not kept: the on-state drop of the junctions (about 1 V), the
holding and latching currents (zero here), the breakover of the blocking junctions, the
device's turn-on and recovery times.

A pair is read so only when it fits: its four nodes distinct, the node between the PNP's
base and the NPN's collector joined by nothing but resistors and diodes to the anode or
the NPN's base (the model's own leakage and breakover parts; an anode gate driven from
outside is another device), and the NPN's base reached by something besides the pair and
the junction's diodes (a gate). Other pairs keep their refusal.
"""

from __future__ import annotations

import math
from dataclasses import replace

from .circuit import (
    GROUND,
    BuiltGroup,
    Ccvs,
    Circuit,
    Diode,
    Element,
    Model,
    Resistor,
    Switch,
    VoltageSource,
    unique_name,
)

__all__ = ["GATE_CURRENT", "HOLD_CURRENT", "IDEAL_THYRISTOR", "JUNCTION_CURRENT",
           "OFF_RESISTANCE", "gate_voltage", "read_thyristors", "two_transistor_pairs"]

#: :attr:`BuiltGroup.construct` of a two-transistor thyristor read as an ideal one
IDEAL_THYRISTOR = "ideal thyristor"

#: the NPN's collector current at which the gate junction is read as conducting where its
#: base joins no resistor (no loop gain to solve for, :func:`gate_voltage`), A
JUNCTION_CURRENT = 1e-3

#: the gate current past which the thyristor fires, A: above the leakage the model's
#: gigaohm resistors pass into the gate node (400 V over 5 GΩ, 80 nA)
GATE_CURRENT = 1e-6

#: the anode current (with the gate's) below which the fired thyristor turns off, A: zero
#: but for rounding
HOLD_CURRENT = 1e-9

#: the resistance from anode to cathode, Ω: the path an inductive load keeps once the
#: switch has opened (pelcs refuses a comparator's switch that leaves an inductor none), a
#: blocking thyristor's leakage, 0.1 uA at 100 V. Far larger ones fall below the rank
#: tolerance of the formulation beside milliohm resistors and are read as open (1e12 Ω
#: beside 0.05 Ω)
OFF_RESISTANCE = 1e9

_K_OVER_Q = 8.617333262e-5  # V/K
_KELVIN = 273.15


def _param(model: Model | None, name: str, default: float) -> float:
    value = (model.params if model is not None else {}).get(name, default)
    return float(value) if isinstance(value, (int, float)) and value >= 0 else default


def gate_voltage(npn: Model | None, pnp: Model | None, conductance: float,
                 temp: float) -> float:
    """The gate junction's voltage, V: the NPN's base-emitter voltage at which the pair's
    loop gain reaches one, the PNP's collector current (``BF_p`` times the NPN's) rising
    faster with it than the base node lets go through its resistors (``conductance``, S,
    their far ends held) and the NPN's base: ``BF_p gm = G + gπ`` with ``gm = Ic/(NF Vt)``,
    ``Ic = IS exp(V/(NF Vt))`` and ``gπ = Ic/(BF NF Vt) + ISE exp(V/(NE Vt))/(NE Vt)`` at
    ``temp`` °C (ngspice's defaults: IS 1e-16 A, BF 100, ISE 0, NF 1, NE 1.5). Past it a
    gate held through those resistors fires: Littelfuse's EC103D1 (9.09 Ω gate resistor, BF
    6.1 and 10, ISE 1e-9 A) 0.517 V, where ngspice fires at 0.510 V of a 1 V gate ramp. With
    no resistor, or no solution below 1.5 V, the voltage of :data:`JUNCTION_CURRENT`."""
    i_s = _param(npn, "is", 1e-16) or 1e-16
    nf = _param(npn, "nf", 1.0) or 1.0
    bf = _param(npn, "bf", 100.0) or 100.0
    ise, ne = _param(npn, "ise", 0.0), _param(npn, "ne", 1.5) or 1.5
    bf_p = _param(pnp, "bf", 100.0)
    vt = _K_OVER_Q * (temp + _KELVIN)

    def excess(v: float) -> float:
        ic = i_s * math.exp(v / (nf * vt))
        return (bf_p - 1.0 / bf) * ic / (nf * vt) - conductance \
            - ise * math.exp(v / (ne * vt)) / (ne * vt)

    lo, hi = 0.0, 1.5
    if conductance > 0 and excess(hi) > 0:
        for _ in range(60):
            mid = (lo + hi) / 2
            lo, hi = (lo, mid) if excess(mid) > 0 else (mid, hi)
        return hi
    return nf * vt * math.log1p(JUNCTION_CURRENT / i_s)


def two_transistor_pairs(circuit: Circuit) -> list[tuple[Switch, Switch]]:
    """Each PNP and NPN idealised as switches that drive each other's base (the PNP's
    collector the NPN's base, the NPN's collector the PNP's base), ``(pnp, npn)``: the
    two-transistor model of a thyristor (Littelfuse's SCR models, for one)."""
    bjts: dict[str, list] = {"NPN": [], "PNP": []}
    types = {r.element: r.device for r in circuit.replacements}
    for el in circuit.elements:
        if isinstance(el, Switch) and el.device and types.get(el.name) in bjts:
            bjts[types[el.name]].append(el)
    if not (bjts["PNP"] and bjts["NPN"]):
        return []
    # (nodes voltage sources hold to ground, ground among them: a base held so draws its
    # current from the source, not from the other transistor, and there is no loop; a
    # common-base NPN driving a PNP follower whose collector is grounded is one such pair)
    held = {GROUND}
    grew = True
    while grew:
        grew = False
        for el in circuit.elements:
            if isinstance(el, VoltageSource) and len(set(el.nodes) & held) == 1:
                held |= set(el.nodes)
                grew = True
    out = []
    for p in bjts["PNP"]:
        cp, bp = p.device[1][0], p.device[1][1]
        for n in bjts["NPN"]:
            cn, bn = n.device[1][0], n.device[1][1]
            if bp == cn and bn == cp and not {bp, bn} & held:
                out.append((p, n))
    return out


def _fits(p: Switch, n: Switch, at: dict[str, list[Element]], junction: list[Diode]) -> bool:
    """Whether the pair ``p``, ``n`` is a thyristor :func:`read_thyristors` reads (the
    module docstring's conditions)."""
    anode, cathode = p.device[1][2], n.device[1][2]
    base_n, base_p = n.device[1][1], p.device[1][1]
    if len({anode, cathode, base_n, base_p}) < 4:
        return False
    pair = {p.key, n.key}
    for el in at.get(base_p, []):
        if el.key in pair:
            continue
        other = set(el.nodes[:2]) - {base_p}
        if not isinstance(el, (Resistor, Diode)) or not other <= {anode, base_n}:
            return False
    skip = pair | {d.key for d in junction}
    return any(el.key not in skip for el in at.get(base_n, []))


def read_thyristors(circuit: Circuit) -> list[tuple[Switch, Switch]]:
    """Replace each pair of :func:`two_transistor_pairs` that fits by an
    ideal thyristor (module docstring): its two switches, their knees and their
    :class:`netlist.devices.Replacement` go, with the diodes across the gate junction; the
    elements built in their place form a :class:`BuiltGroup` that ngspice is given the
    transistors' and diodes' own lines for; a note and a replacement say what the pair
    became. Returns the pairs that do not fit, left as they are (refused by
    :func:`netlist.base_drive.thyristor_pairs`)."""
    from .value_scaling import circuit_temperatures
    from .writer import model_name, spice_name

    pairs = two_transistor_pairs(circuit)
    left: list[tuple[Switch, Switch]] = []
    if not pairs:
        return left
    temp = circuit_temperatures(circuit.options, circuit.ignored)[0]
    at: dict[str, list[Element]] = {}
    for el in circuit.elements:
        for node in dict.fromkeys(el.nodes):
            at.setdefault(node, []).append(el)
    names = {el.key for el in circuit.elements}
    nodes = set(circuit.nodes)
    count: dict[str, int] = {}
    for pair in pairs:
        for t in pair:
            count[t.key] = count.get(t.key, 0) + 1
    for p, n in pairs:
        if count[p.key] > 1 or count[n.key] > 1:
            left.append((p, n))
            continue  # a transistor in two pairs: no one thyristor
        anode, cathode, base_n = p.device[1][2], n.device[1][2], n.device[1][1]
        junction = [el for el in at.get(base_n, []) if isinstance(el, Diode)
                    and el.nodes[:2] == (base_n, cathode)]
        if not _fits(p, n, at, junction):
            left.append((p, n))
            continue
        # (a transistor names its model by its key: subckt:name inside a subcircuit)
        npn = circuit.models.get(n.device[2].lower())
        pm = circuit.models.get(p.device[2].lower())
        npn_name, pnp_name = (m.name if m is not None else t.device[2]
                              for m, t in ((npn, n), (pm, p)))
        conductance = sum(1.0 / el.value for el in at.get(base_n, [])
                          if isinstance(el, Resistor) and el.value > 0
                          and len(set(el.nodes[:2])) == 2)
        vg = gate_voltage(npn, pm, conductance, temp)
        tag = p.name

        def node(suffix: str, key: str = p.key) -> str:
            return unique_name(f"{key}#{suffix}", nodes)

        def name(suffix: str, tag: str = tag) -> str:
            return unique_name(f"{tag}#{suffix}", names)

        a1, a2, g1 = node("a"), node("k"), node("g")
        ctl, mid = node("i"), node("ig")
        sense_a, sense_g = name("ia"), name("vg")
        sw = f"pelcs_thy_{p.key.replace('.', '_')}"
        loc = p.location
        # on above GATE_CURRENT, off below HOLD_CURRENT (SW: VT ± VH)
        circuit.models[sw] = Model(sw, "SW", {"vt": (GATE_CURRENT + HOLD_CURRENT) / 2,
                                              "vh": (GATE_CURRENT - HOLD_CURRENT) / 2}, loc)
        built: list[Element] = [
            VoltageSource(sense_a, (anode, a1), loc, 0.0),
            Diode(name("d"), (a1, a2), loc, ideal=True),
            Switch(name("on"), (a2, cathode), loc, (ctl, GROUND), sw),
            Ccvs(name("hia"), (ctl, mid), loc, sense_a, 1.0),
            VoltageSource(sense_g, (base_n, g1), loc, vg),
            Diode(name("dg"), (g1, cathode), loc, ideal=True),
            Ccvs(name("hig"), (mid, GROUND), loc, sense_g, 1.0),
            Resistor(name("roff"), (anode, cathode), loc, OFF_RESISTANCE),
        ]
        lines = [f"{spice_name(t.name, 'Q')} {' '.join(t.device[1])} "
                 f"{model_name(circuit, t.device[2])}" for t in (p, n)]
        lines += [f"{spice_name(d.name, 'D')} {' '.join(d.nodes)} "
                  f"{model_name(circuit, d.model)}" for d in junction]
        circuit.add_built_group(BuiltGroup(tag, IDEAL_THYRISTOR, "\n".join(lines)), built)
        gone = {p.key, n.key} | {d.key for d in junction}
        out: list[Element] = []
        for el in circuit.elements:
            if el.key == p.key:
                out.extend(built)
            elif el.key not in gone:
                out.append(el)
        circuit.elements[:] = out
        for t in (p, n):
            circuit.models.pop(t.model.lower(), None)
        circuit.knees[:] = [k for k in circuit.knees
                            if str(getattr(k, "name", "")).lower() not in (p.key, n.key)]
        diodes = ", ".join(d.name for d in junction)
        absorbed = (f"; {diodes} across the gate junction read as part of it"
                    if junction else "")
        became = (f"ideal thyristor, anode {anode} -> cathode {cathode}, gate junction "
                  f"v({base_n},{cathode}) = {vg:.3g} V (where the loop gain of {pnp_name} and "
                  f"{npn_name} reaches one): fires when the gate carries more than "
                  f"{GATE_CURRENT * 1e6:g} uA with the anode above the cathode, then conducts "
                  f"as an ideal diode, latched until its current falls to zero{absorbed}")
        olds = [r for r in circuit.replacements if r.element in (p.name, n.name)]
        first = circuit.replacements.index(olds[0])  # (the pairs are found by them)
        circuit.replacements[:] = [r for r in circuit.replacements if r not in olds]
        # (a netlist.devices.Replacement, of the PNP's: devices imports base_drive, which
        # imports this module)
        circuit.replacements.insert(first, replace(
            olds[0], element=f"{p.name}, {n.name}", model=f"{pnp_name}/{npn_name}",
            device="thyristor", became=became, threshold=vg,
            source="the pair's loop gain", body_diode=None,
            dropped=("on-state drop", "holding current", "breakover", "switching times")))
        circuit.notes.append(f"{p.name}, {n.name}: thyristor (two-transistor model) read as "
                             f"an {became} (the base currents that fire and latch the pair "
                             "are not drawn by transistors idealised as switches)")
    return left
