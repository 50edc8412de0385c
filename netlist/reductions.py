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
from .topology import UnionFind, bridges

__all__ = ["HeldCapacitor", "LinkCapacitor", "capacitor_links", "held_capacitors",
           "open_inductors", "parallel_diodes", "reduced", "source_capacitors"]


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
        path = _path(adjacent, *el.nodes[:2])
        members = [sources[i] for i in path]
        constant = all(type(s) is VoltageSource and s.waveform is None for s in members)
        out[el.key] = HeldCapacitor(el.name, (el.nodes[0], el.nodes[1]),
                                    tuple(s.name for s in members), constant)
    return out


def _path(adjacent: dict[str, list[tuple[str, int]]], a: str, b: str) -> list[int]:
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


@dataclass(frozen=True)
class LinkCapacitor:
    """A capacitor that closes a loop of capacitors and DC sources (module docstring).

    Attributes
    ----------
    name : str
    nodes : tuple of str
        Its terminals (n+, n-).
    value : float
        Its capacitance, F.
    terms : tuple of (str, float)
        ``(key, a)`` of the tree capacitors on its loop: ``v_l = Σ a v_key + const``.
    const : float
        The DC sources' voltage on the loop, V.
    path : tuple of str
        Names of the loop's other branches, from n+ to n-.
    sources : tuple of str
        The DC sources among them (they carry its current).
    """

    name: str
    nodes: tuple[str, str]
    value: float
    terms: tuple[tuple[str, float], ...]
    const: float
    path: tuple[str, ...]
    sources: tuple[str, ...]


def capacitor_links(circuit: Circuit, held: dict[str, HeldCapacitor] | None = None
                    ) -> dict[str, LinkCapacitor]:
    """The link capacitors of the circuit by key (module docstring), in netlist order: each
    plain capacitor, other than those of :func:`held_capacitors` (``held``), whose terminals
    the DC sources and the earlier capacitors already join. V sources whose current an F or
    H source senses are not used (their current would then include the link's)."""
    if held is None:
        held = held_capacitors(circuit)
    caps = [el for el in circuit.elements if type(el) is Capacitor and el.key not in held
            and el.nodes[0] != el.nodes[1]]
    if len(caps) < 2:
        return {}  # (a loop of one capacitor and sources is held: most circuits end here)
    sensed = {str(el.source).lower() for el in circuit.elements if el.kind in "FH"
              and getattr(el, "source", None)}
    uf = UnionFind()
    edges: list = []  # the forest's branches
    adjacent: dict[str, list[tuple[str, int]]] = {}

    def add(el) -> None:
        a, b = el.nodes[:2]
        uf.union(a, b)
        edges.append(el)
        adjacent.setdefault(a, []).append((b, len(edges) - 1))
        adjacent.setdefault(b, []).append((a, len(edges) - 1))

    for el in circuit.elements:
        if type(el) is VoltageSource and el.waveform is None and el.key not in sensed \
                and el.nodes[0] != el.nodes[1] and uf.find(el.nodes[0]) != uf.find(el.nodes[1]):
            add(el)
    out = {}
    for el in caps:
        a, b = el.nodes[:2]
        if uf.find(a) != uf.find(b):
            add(el)
            continue
        terms: list[tuple[str, float]] = []
        const = 0.0
        node = a
        for i in _path(adjacent, a, b):
            branch = edges[i]
            sign = 1.0 if branch.nodes[0] == node else -1.0
            node = branch.nodes[1] if sign > 0 else branch.nodes[0]
            if isinstance(branch, Capacitor):
                terms.append((branch.key, sign))
            else:
                const += sign * float(branch.dc)
        if not terms:
            continue  # (sources alone: a held capacitor, not a link)
        path = [edges[i] for i in _path(adjacent, a, b)]
        out[el.key] = LinkCapacitor(
            el.name, (a, b), float(el.value), tuple(terms), const,
            tuple(e.name for e in path),
            tuple(e.name for e in path if not isinstance(e, Capacitor)))
    return out


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


def reduced(circuit: Circuit, capacitors: dict[str, HeldCapacitor] | None = None,
            links: dict[str, LinkCapacitor] | None = None) -> Circuit:
    """The circuit without what :func:`netlist.formulation.formulate` leaves out: the
    capacitors of :func:`held_capacitors` (``capacitors``) and :func:`capacitor_links`
    (``links``), each found when not given, and the diodes of :func:`parallel_diodes` (one
    complementarity pair carries each group: two would leave the split of the current
    undetermined, a non-unique λ)."""
    if capacitors is None:
        capacitors = held_capacitors(circuit)
    if links is None:
        links = capacitor_links(circuit, capacitors)
    held = set(capacitors) | set(links) | set(parallel_diodes(circuit))
    if not held:
        return circuit
    return replace(circuit, elements=[el for el in circuit.elements if el.key not in held])
