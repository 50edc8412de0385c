"""What the formulation leaves out of the LCS, and why (decided on the circuit, once, before
any mode is built):

- a capacitor whose terminals independent voltage sources alone join (an input capacitor
  across the supply): its voltage is the sources', so it holds no state, and nothing else
  depends on its current (only the sources' own currents would);
- an ideal diode in parallel with an earlier one of the same orientation: one
  complementarity pair carries both (two would leave the split of their current
  undetermined, a non-unique λ);
- an inductor whose terminals no other branch joins, whatever the switches (one end left
  unconnected, or a part of the circuit hung on it alone): Kirchhoff's current law holds its
  current at zero, as ngspice finds it. It keeps its state name, but the state is pinned at
  zero (the formulation takes it for a 0 V branch, with no dynamics).

:func:`netlist.formulation.formulate` drops them; runs note them, probes of a merged diode are
refused with the name of the diode that carries it.
"""

from __future__ import annotations

from dataclasses import replace

from .circuit import Capacitor, Circuit, Inductor, VoltageSource
from .topology import UnionFind, bridges

__all__ = ["open_inductors", "parallel_diodes", "reduced", "source_capacitors"]


def source_capacitors(circuit: Circuit) -> list[str]:
    """Keys of the capacitors whose terminals independent voltage sources alone join (an
    input capacitor across the supply): their voltage is set by the sources, so they hold no
    state; :func:`formulate` leaves them out (a note says so in a run)."""
    uf = UnionFind()
    for el in circuit.elements:
        if isinstance(el, VoltageSource):
            uf.union(*el.nodes[:2])
    out = []
    for el in circuit.elements:
        if isinstance(el, Capacitor) and el.nodes[0] != el.nodes[1] and \
                uf.find(el.nodes[0]) == uf.find(el.nodes[1]):
            out.append(el.key)
    return out


def parallel_diodes(circuit: Circuit) -> dict[str, str]:
    """Ideal diodes in parallel with an earlier one of the same orientation (same anode and
    cathode nodes): key -> the name of the diode that carries them both."""
    first: dict[tuple[str, str], str] = {}
    out = {}
    for el in circuit.elements:
        if el.kind == "D":
            pair = (el.nodes[0], el.nodes[1])
            if pair in first:
                out[el.key] = first[pair]
            else:
                first[pair] = el.name
    return out


def open_inductors(circuit: Circuit) -> list[str]:
    """Keys of the inductors that no other branch parallels, switches closed or not: each is
    a bridge of the graph of every two-terminal element, so Kirchhoff's current law holds its
    current at zero (a dangling inductor, one end unconnected). Inductors coupled by a K
    element are left out (a coupled winding's voltage is not zero: the formulation refuses
    them as before)."""
    coupled = {str(name).lower() for el in circuit.elements if el.kind == "K"
               for name in el.inductors}
    branches = [el for el in circuit.elements if el.kind != "K" and len(el.nodes) >= 2]
    cut = bridges([tuple(el.nodes[:2]) for el in branches])
    return [el.key for i, el in enumerate(branches)
            if i in cut and isinstance(el, Inductor) and el.key not in coupled]


def reduced(circuit: Circuit) -> Circuit:
    """The circuit without what :func:`netlist.formulation.formulate` leaves out: the
    capacitors of :func:`source_capacitors` and the diodes of :func:`parallel_diodes` (one
    complementarity pair carries each group: two would leave the split of the current
    undetermined, a non-unique λ)."""
    held = set(source_capacitors(circuit)) | set(parallel_diodes(circuit))
    if not held:
        return circuit
    return replace(circuit, elements=[el for el in circuit.elements if el.key not in held])
