"""What the formulation leaves out of the LCS, and why (decided on the circuit, once, before
any mode is built):

- a capacitor whose terminals voltage sources alone join (V, E and H sources, in every
  mode: an input capacitor across the supply, a load capacitor across an E source's output,
  a regulator model's output capacitor across a B source fed from the supply): its voltage
  is the sources', so it holds no state. Its current ``C dv/dt`` flows around the loop it
  closes with them and nowhere else: a loop current through voltage-defined branches
  changes no node voltage and no other branch current (Kirchhoff's current law holds with it
  at every node of the loop), so leaving it out is exact for everything but the currents of
  those sources, which :func:`held_capacitors` names (probes of them are refused unless the
  sources are DC, where the capacitor carries no current). Not when an F or H source senses
  the current of one of those V sources (then it matters: the loop stays, refused);
- a capacitor that closes a loop of capacitors and DC voltage sources (a *link*: the
  junction capacitances of a multiplier's diodes with its pump capacitors and 0 V sense
  sources; a triangle of capacitors): its voltage is that of the loop's other capacitors
  (the *tree* ones, which stay states) and sources, ``v_l = Σ a_lk v_k + c``, so it is no
  state, and its current ``C_l dv_l/dt`` circulates around the loop through them. With the
  links left open the network gives the tree capacitors' currents ``i``; with them,
  ``(D + Aᵀ C_L A) v' = i`` exactly (``D`` the tree capacitances, ``A`` the ``a_lk``,
  ``C_L`` the links'): the charge constraint, :func:`capacitor_links` finds them and
  :mod:`netlist.formulation` applies ``(D + Aᵀ C_L A)⁻¹ D`` to the tree rows. Only DC
  sources on the loop (a source's derivative would enter); others stay refused;
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

from collections import deque
from dataclasses import dataclass, replace

from .circuit import Capacitor, Ccvs, Circuit, Inductor, Vcvs, VoltageSource
from .errors import Diagnostic
from .topology import UnionFind, bridges

__all__ = ["HeldCapacitor", "held_capacitors", "held_note", "held_probe", "open_inductors",
           "parallel_diodes", "reduced", "source_capacitors"]


@dataclass(frozen=True)
class HeldCapacitor:
    """A capacitor whose terminals voltage sources alone join (module docstring).

    Attributes
    ----------
    name : str
        The capacitor's name.
    nodes : tuple of str
        Its terminals (n+, n-).
    path : tuple of str
        The names of the V, E and H sources that join them, from n+ to n-: its current
        ``C dv/dt`` flows through them.
    constant : bool
        Every source of the path is an independent DC source: the capacitor's voltage is
        constant, its current zero, and the sources' currents exact.
    """

    name: str
    nodes: tuple[str, str]
    path: tuple[str, ...]
    constant: bool


def held_capacitors(circuit: Circuit) -> dict[str, HeldCapacitor]:
    """The capacitors whose terminals V, E and H sources alone join, by key, in netlist
    order: their voltage is set by the sources, so they hold no state; :func:`formulate`
    leaves them out (a note says so in a run). V sources whose current an F or H source
    senses are not used to join them (that current would then depend on the capacitor's)."""
    sensed = {str(el.source).lower() for el in circuit.elements if el.kind in "FH"
              and getattr(el, "source", None)}
    sources = [el for el in circuit.elements
               if isinstance(el, VoltageSource | Vcvs | Ccvs) and el.key not in sensed
               and len(el.nodes) >= 2 and el.nodes[0] != el.nodes[1]]
    if not sources:
        return {}
    uf = UnionFind()
    for el in sources:
        uf.union(*el.nodes[:2])
    caps = [el for el in circuit.elements if isinstance(el, Capacitor)
            and el.nodes[0] != el.nodes[1] and uf.find(el.nodes[0]) == uf.find(el.nodes[1])]
    if not caps:
        return {}
    adjacent: dict[str, list[tuple[str, int]]] = {}
    for i, el in enumerate(sources):
        a, b = el.nodes[:2]
        adjacent.setdefault(a, []).append((b, i))
        adjacent.setdefault(b, []).append((a, i))
    out = {}
    for el in caps:
        path = path_between(adjacent, *el.nodes[:2])
        members = [sources[i] for i in path]
        constant = all(type(s) is VoltageSource and s.waveform is None for s in members)
        out[el.key] = HeldCapacitor(el.name, (el.nodes[0], el.nodes[1]),
                                    tuple(s.name for s in members), constant)
    return out


def path_between(adjacent: dict[str, list[tuple[str, int]]], a: str, b: str) -> list[int]:
    """Indices of the branches of a path from node ``a`` to node ``b`` (breadth first: the
    sources form a forest where the mode is regular, so the path is the only one)."""
    came: dict[str, tuple[str, int] | None] = {a: None}
    queue = deque([a])
    while queue:
        node = queue.popleft()
        if node == b:
            break
        for nxt, i in adjacent.get(node, ()):
            if nxt not in came:
                came[nxt] = (node, i)
                queue.append(nxt)
    path = []
    node = b
    while came[node] is not None:
        node, i = came[node]
        path.append(i)
    return path[::-1]


def held_note(held: dict) -> list[str]:
    """The notes of the capacitors that voltage sources alone join
    (:func:`netlist.reductions.held_capacitors`), one per group on the same sources."""
    groups: dict[tuple[str, ...], list] = {}
    for h in held.values():
        groups.setdefault(h.path, []).append(h)
    notes = []
    for path, caps in groups.items():
        names = ", ".join(h.name for h in caps)
        one = len(caps) == 1
        sources = ", ".join(path)
        text = (f"{names}: {'its terminals are' if one else 'their terminals are each'} "
                f"joined by voltage sources alone ({sources}), so "
                f"{'it holds' if one else 'they hold'} no state: the sources set "
                f"{'its' if one else 'their'} voltage, and {'its' if one else 'their'} "
                f"current flows only through {sources}")
        if caps[0].constant:
            text += (" (DC: it is zero, and the sources' currents are exact)" if one else
                     " (DC: they are zero, and the sources' currents are exact)")
        else:
            text += (f"; i() of {sources} and of {'it' if one else 'them'} are not "
                     "computed (refused as probes)")
        notes.append(text)
    return notes


def held_probe(probe: str, key: str, held: dict, path_currents: bool = False
               ) -> Diagnostic | None:
    """The error of a probe ``i(X)`` that pelcs does not compute because of a capacitor that
    voltage sources alone join: ``X`` that capacitor, or (unless they are DC) a source it is
    across; None for any other element. ``path_currents``: the sources' currents without
    the capacitor's are asked for knowingly (:mod:`netlist.studies.losses` adds its power)."""
    if key in held:
        h = held[key]
        return Diagnostic(
            message=f"probe {probe.strip()!r}: {h.name} is joined by voltage sources alone "
                    f"({', '.join(h.path)}), so it holds no state and its current is not "
                    "computed",
            hint=f"its voltage is v({h.nodes[0]},{h.nodes[1]}) (probe v({h.name})), and "
                 + ("its current zero (the sources are DC)" if h.constant else
                    "its current C times the derivative of that voltage")
                 + "; to make it a state, give it a series resistance (its ESR)")
    for h in held.values():
        if h.constant or path_currents:
            continue
        name = next((n for n in h.path if n.lower() == key), None)
        if name is not None:
            return Diagnostic(
                message=f"probe {probe.strip()!r}: the current of {name} includes the "
                        f"charging current of {h.name}, which voltage sources alone join "
                        f"({', '.join(h.path)}): pelcs keeps no state for it and does not "
                        "compute that current",
                hint=f"probe the current of the branches {name} feeds other than "
                     f"{h.name}, or give {h.name} a series resistance (its ESR) to make it a "
                     "state")
    return None


def source_capacitors(circuit: Circuit) -> list[str]:
    """Keys of the capacitors of :func:`held_capacitors` (no state), in netlist order."""
    return list(held_capacitors(circuit))


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


def reduced(circuit: Circuit, capacitors: dict[str, HeldCapacitor], links: dict) -> Circuit:
    """The circuit without what :func:`netlist.formulation.formulate` leaves out: the
    capacitors of :func:`held_capacitors` (``capacitors``) and of
    :func:`netlist.capacitor_links.capacitor_links` (``links``), and the diodes of
    :func:`parallel_diodes` (one complementarity pair carries each group: two would leave the
    split of the current undetermined, a non-unique λ)."""
    held = set(capacitors) | set(links) | set(parallel_diodes(circuit))
    if not held:
        return circuit
    return replace(circuit, elements=[el for el in circuit.elements if el.key not in held])
