"""Parts of a circuit whose potential only diodes bound: a note says so.

A set of nodes that meets the rest of the circuit (the part with ground) through diodes alone
has, while all those diodes block, no equation that sets its common potential: Kirchhoff's
laws and the elements inside fix the voltages between its nodes, and any common shift at
which every boundary diode still blocks is a solution as good as another. An ideal-diode
model (an LCP) then returns one of them, where a real circuit is held by the diodes' leakage
and capacitance (a three-phase source's star point behind a miswired bridge, a node that only
a diode reaches). The note names the nodes and the diodes, so that a printed voltage there is
not read as determined.

The parts are found on the circuit's graph: every element joins its nodes, except the diodes,
which are the boundary. No claim is made for a part that a current source (I, F, G) joins to
the rest, or whose potential against the rest a controlled source or a switch reads (it would
matter there): that part is left out. A switch joins its nodes whatever its state, so a part
is only reported when diodes separate it in every switch configuration.
"""

from __future__ import annotations

from .circuit import GROUND, Circuit
from .topology import UnionFind

__all__ = ["free_potential_notes"]

# listed in a note at most
_MAX_NODES = 12


def free_potential_notes(circuit: Circuit) -> list[str]:
    """A note for each part of ``circuit`` that only diodes join to the rest (module
    docstring)."""
    diodes = [el for el in circuit.elements if el.kind == "D"]
    if not diodes:
        return []
    uf = UnionFind()
    uf.find(GROUND)
    spans: list[tuple[str, ...]] = []  # node sets that must not straddle a reported part
    for el in circuit.elements:
        nodes = tuple(el.nodes)
        if el.kind == "D" or not nodes:
            continue
        if el.kind in "IFG":
            spans.append(nodes[:2])  # (a current source's ends: a KCL tie, not a potential)
        else:
            for n in nodes[1:]:
                uf.union(nodes[0], n)
        control = getattr(el, "control", None)
        if control:  # (an E, G or switch reading a voltage: it must not read the part's)
            spans.append(tuple(control))
    ground = uf.find(GROUND)
    parts: dict[str, list[str]] = {}
    for d in diodes:
        for n in d.nodes[:2]:
            root = uf.find(n)
            if root != ground:
                parts.setdefault(root, [])
    if not parts:
        return []
    nodes_of: dict[str, list[str]] = {root: [] for root in parts}
    for n in circuit.nodes:
        root = uf.find(n)
        if root in nodes_of and "#" not in n:
            nodes_of[root].append(n)
    tainted = {uf.find(n) for span in spans if len({uf.find(m) for m in span}) > 1
               for n in span}
    notes = []
    for root in parts:
        if root in tainted:
            continue
        boundary = [d.name for d in diodes
                    if root in {uf.find(n) for n in d.nodes[:2]}]
        shown = nodes_of[root][:_MAX_NODES]
        more = len(nodes_of[root]) - len(shown)
        listing = ", ".join(shown) + (f" and {more} more" if more else "")
        one, many = len(boundary) == 1, len(nodes_of[root]) > 1
        notes.append(
            f"{listing}: only the diode{'' if one else 's'} {', '.join(boundary)} "
            f"join{'s' if one else ''} {'these nodes' if many else 'this node'} to the rest of "
            f"the circuit; while {'it blocks' if one else 'they all block'}, no equation sets "
            f"the potential there (any value at which {'it' if one else 'they'} still "
            f"block{'s' if one else ''} is a solution), so a voltage printed there is one such "
            "value"
            + (" (the voltages between these nodes are determined)" if many else ""))
    return notes
