"""A switch's off resistance, where the circuit's resistances make its leakage matter.

pelcs's switch is open when off: no current at all, where ngspice's SW (and CSW, XSPICE's
``aswitch``) conducts ``v / ROFF``. In a power converter that leakage is nothing (ROFF of
1 MΩ or more against loads of ohms); in a circuit whose own resistances come near ROFF it is
a current the open switch leaves out. ngspice's manual has such a switch test: ROFF = 10 kΩ
against 10 kΩ loads, the off switch holds its node at half the supply, the open one at all of
it (``tests/corpus/ngspice/examples/probe/switches-manual-p92.cir``).

So a switch whose ROFF is within :data:`LEAKAGE_RATIO` times the largest resistance at its
terminals (ground aside) gets a resistor ROFF across it, the pelcs-built element of its
group: off, the two ends are joined by ROFF as in ngspice; on, the ideal switch shorts it (with
``--devices pwl`` it parallels RON: RON ROFF / (RON + ROFF), RON less its fraction RON/ROFF;
the manual's CSW, RON = 1 kΩ and ROFF = 10 kΩ, is 9 % low when on).
A resistance R beside a switch of ROFF at least LEAKAGE_RATIO R moves the voltages by less
than R / ROFF, 0.1 %, below what the ideal devices themselves change: such switches stay
open. A terminal with no path for direct current to ground but through the switch itself
(a hold capacitor, a switched capacitor) has its voltage set by ROFF alone when the switch is
off, whatever the resistances elsewhere: ROFF is modelled there too, where ROFF times the
part's capacitance is within LEAKAGE_RATIO times the run (a slower decay moves it by less
than 0.1 % over the run). ngspice is given the
switch line alone (its own ROFF), not the resistor.
"""

from __future__ import annotations

import math
from dataclasses import replace

from .circuit import (
    GROUND,
    BuiltGroup,
    Capacitor,
    Ccvs,
    Circuit,
    Inductor,
    Resistor,
    Switch,
    Vcvs,
    VoltageSource,
    unique_name,
)
from .topology import UnionFind
from .units import format_eng

__all__ = ["LEAKAGE_RATIO", "OFF_RESISTANCE", "model_off_resistances"]

#: a switch's ROFF is modelled when below this many times the circuit's largest resistance
LEAKAGE_RATIO = 1e3

#: :attr:`netlist.circuit.BuiltGroup.construct` of a switch's off resistor
OFF_RESISTANCE = "switch off resistance"


def _dc_floating(circuit: Circuit, sw: Switch, roff: float) -> str | None:
    """A terminal of ``sw`` (a node name) that has no path for direct current to ground but
    through ``sw``: through resistors, inductors, voltage sources, E and H sources and the
    other switches (taken as conducting, on or through their own leakage); None if both
    have one, or if a path beside ``sw`` joins its terminals (a part floating as a whole),
    or if ``roff`` (Ω) times the capacitance of that terminal's part exceeds
    :data:`LEAKAGE_RATIO` times the run's TSTOP (it moves the part's voltage by less than
    0.1 % over the run; the operating point still sets it through ROFF, as ngspice's)."""
    paths = UnionFind()  # (the nodes joined by paths for direct current beside sw)
    for el in circuit.elements:
        if el is sw or not isinstance(
                el, (Resistor, Inductor, VoltageSource, Vcvs, Ccvs, Switch)):
            continue
        if isinstance(el, Resistor) and not (math.isfinite(el.value) and el.value > 0):
            continue
        paths.union(el.nodes[0], el.nodes[1])
    root = paths.find
    ends = [root(n) for n in sw.nodes[:2]]
    if ends[0] == ends[1]:  # (a path beside the switch: ROFF only parallels it)
        return None
    ground = root(GROUND)
    node = next((n for n, e in zip(sw.nodes[:2], ends, strict=True) if e != ground), None)
    if node is None or circuit.tran is None:
        return None
    part = root(node)
    cap = sum(float(el.value) for el in circuit.elements if isinstance(el, Capacitor)
              and part in (root(el.nodes[0]), root(el.nodes[1])) and math.isfinite(el.value))
    # (no capacitance: no charge for ROFF to move, the part's potential only, which
    # netlist.free_potential reports)
    return node if 0 < roff * cap <= LEAKAGE_RATIO * circuit.tran.tstop else None


def model_off_resistances(circuit: Circuit) -> Circuit:
    """The circuit with a resistor ROFF across each switch whose ROFF is within
    :data:`LEAKAGE_RATIO` times the largest resistance at its terminals other than ground
    (Ω), or that is a terminal's only path for direct current, and a note for each; the
    circuit itself if there is none. Transistors idealised as
    switches have no ROFF (their off state is the device's, left out)."""
    # the resistors at each node (pelcs's own, built for other lines, left out)
    at: dict[str, list[float]] = {}
    for el in circuit.elements:
        if isinstance(el, Resistor) and not el.built_for and math.isfinite(el.value) \
                and el.value > 0:
            for node in el.nodes[:2]:
                at.setdefault(node, []).append(float(el.value))
    leaky = []
    for el in circuit.elements:
        if not isinstance(el, Switch) or el.device is not None or el.built_for:
            continue
        model = circuit.models.get(el.model.lower())
        roff = float(model.params.get("roff", math.inf)) if model is not None else math.inf
        near = [r for node in el.nodes[:2] if node != GROUND for r in at.get(node, ())]
        if not (math.isfinite(roff) and roff > 0):
            continue
        if near and roff < LEAKAGE_RATIO * max(near):
            leaky.append((el, roff, max(near), None))
        elif (node := _dc_floating(circuit, el, roff)) is not None:
            leaky.append((el, roff, None, node))
    if not leaky:
        return circuit
    used = {e.key for e in circuit.elements}
    elements, notes = list(circuit.elements), list(circuit.notes)
    # (a new circuit: the one given may be a parse cached for reuse)
    out = replace(circuit, built_groups=dict(circuit.built_groups))
    for sw, roff, r_max, floating in leaky:
        r = Resistor(unique_name(f"R{sw.name}_off", used), tuple(sw.nodes[:2]),
                     location=sw.location, value=roff)
        elements.insert(elements.index(sw) + 1, r)
        # (a comment in ngspice's deck: the switch line itself carries its ROFF there)
        out.add_built_group(BuiltGroup(
            r.name, OFF_RESISTANCE, f"* {r.name}: {sw.name}'s ROFF, in its own line"), [r])
        why = (f"is within {LEAKAGE_RATIO:g} times the resistances at its terminals (up to "
               f"{format_eng(r_max, 'Ω')})" if floating is None else
               f"is node {floating}'s only path for direct current when the switch is off")
        notes.append(
            f"{sw.name}: its off resistance ROFF = {format_eng(roff, 'Ω')} {why}, so its "
            f"leakage when off matters: modelled as a resistor {r.name} across it (ngspice's "
            "switch conducts 1/ROFF when off, pelcs's is open)")
    return replace(out, elements=elements, notes=notes)
