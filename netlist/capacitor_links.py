"""Capacitors that close loops of capacitors and DC sources (*links*): what
:mod:`netlist.reductions` says of them, found here (:func:`capacitor_links`), with what the
formulation and a run make of them: the tree capacitors' capacitance matrix and the map of
their rows of ``x'`` (:func:`link_matrices`), the rows a link's current is read from, the
notes, the probes pelcs refuses and the initial voltages it checks.

A link's voltage is ``v_l = Σ a_lk v_k + c`` (``v_k`` the loop's tree capacitors, ``c`` its
DC sources); its current ``C_l dv_l/dt`` circulates around the loop, so with the links left
open the tree capacitors' currents ``i`` give ``(D + Aᵀ C_L A) v' = i`` exactly.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from lcs.model import ModeKey, ModeModel, OutputMap

from .circuit import GROUND, Capacitor, Circuit, VoltageSource
from .errors import Diagnostic, NetlistError
from .mna import coalesce
from .mna_solve import clean
from .probes import PROBE
from .reductions import HeldCapacitor, path_between
from .topology import UnionFind

__all__ = ["LinkCapacitor", "capacitor_links", "check_link_initial", "link_matrices",
           "link_note", "link_probe", "linked_builder"]


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


def capacitor_links(circuit: Circuit, held: dict[str, HeldCapacitor]
                    ) -> dict[str, LinkCapacitor]:
    """The link capacitors of the circuit by key (module docstring), in netlist order: each
    plain capacitor, other than those of :func:`held_capacitors` (``held``), whose terminals
    the DC sources and the earlier capacitors already join. V sources whose current an F or
    H source senses are not used (their current would then include the link's)."""
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
        for i in path_between(adjacent, a, b):
            branch = edges[i]
            sign = 1.0 if branch.nodes[0] == node else -1.0
            node = branch.nodes[1] if sign > 0 else branch.nodes[0]
            if isinstance(branch, Capacitor):
                terms.append((branch.key, sign))
            else:
                const += sign * float(branch.dc)
        if not terms:
            continue  # (sources alone: a held capacitor, not a link)
        path = [edges[i] for i in path_between(adjacent, a, b)]
        out[el.key] = LinkCapacitor(
            el.name, (a, b), float(el.value), tuple(terms), const,
            tuple(e.name for e in path),
            tuple(e.name for e in path if not isinstance(e, Capacitor)))
    return out


def link_matrices(links: dict[str, LinkCapacitor], capacitance: dict[str, float]
                  ) -> tuple[list[str], np.ndarray, np.ndarray]:
    """The keys of the tree capacitors of the loops, in order, their capacitance matrix
    ``M = D + Aᵀ C_L A`` (F) and the map ``P = M⁻¹ D`` of their rows of ``x'`` from the
    network without the links (``capacitance``: F by key)."""
    keys = list(dict.fromkeys(k for link in links.values() for k, _ in link.terms))
    col = {k: j for j, k in enumerate(keys)}
    a = np.zeros((len(links), len(keys)))
    for i, link in enumerate(links.values()):
        for k, sign in link.terms:
            a[i, col[k]] += sign
    d = np.diag([capacitance[k] for k in keys])
    cl = np.array([link.value for link in links.values()])
    m = d + a.T @ (cl[:, None] * a)
    return keys, m, np.linalg.solve(m, d)


def link_note(links: dict) -> list[str]:
    """The notes of the link capacitors (:func:`netlist.reductions.capacitor_links`)."""
    notes = []
    for link in links.values():
        loop = ", ".join(link.path)
        notes.append(
            f"{link.name}: closes a loop of capacitors and DC sources ({loop}), so it holds "
            "no state: its voltage is theirs, and its current C dv/dt circulates through "
            "them (their capacitance matrix holds it: the charge constraint)"
            + (f"; i() of {', '.join(link.sources)} are not computed (refused as probes)"
               if link.sources else ""))
    return notes


def link_probe(probe: str, key: str, links: dict) -> Diagnostic | None:
    """The error of ``i(V)`` of a DC source that a link capacitor's current flows through
    (pelcs does not compute that current in it); None for any other element."""
    for link in links.values():
        name = next((n for n in link.sources if n.lower() == key), None)
        if name is not None:
            return Diagnostic(
                message=f"probe {probe.strip()!r}: the current of {name} includes that of "
                        f"{link.name}, which closes a loop of capacitors and DC sources "
                        f"({', '.join(link.path)}) and holds no state: pelcs does not "
                        "compute it there",
                hint=f"probe i({link.name}) or the capacitors' currents, or give {link.name} "
                     "a series resistance (its ESR) to make it a state")
    return None


def check_link_initial(circuit: Circuit, links: dict, states: Sequence[str], x0: np.ndarray
                  ) -> None:
    """Refuse a link capacitor whose given initial voltage does not fit its loop's (pelcs
    starts the loop from its tree capacitors' and the sources' voltages)."""
    index = {name[2:-1].lower(): k for k, name in enumerate(states)}
    ics = circuit.initial_conditions
    for link in links.values():
        el = circuit.element(link.name)
        a, b = link.nodes
        if el.ic is not None:
            given = float(el.ic)
        elif a in ics or b in ics:
            given = (0.0 if a == GROUND else ics.get(a, 0.0)) - \
                (0.0 if b == GROUND else ics.get(b, 0.0))
        else:
            given = 0.0
        loop = link.const + sum(sign * x0[index[k]] for k, sign in link.terms)
        if abs(given - loop) > 1e-9 * max(1.0, abs(given), abs(loop)):
            raise NetlistError(Diagnostic(
                message=f"{link.name} starts at {given:.6g} V, but the loop it closes with "
                        f"{', '.join(link.path)} puts it at {loop:.6g} V",
                location=el.location,
                hint="a capacitor of a loop of capacitors and sources holds no state of its "
                     "own: give initial voltages (IC=, .ic) that fit the loop, or a series "
                     "resistance to the capacitor",
                elements=(link.name,)), file=circuit.file)


def linked_builder(build: Callable[[ModeKey], ModeModel], links: dict[str, LinkCapacitor],
                   state_index: dict[str, int], by_key: dict, n: int
                   ) -> Callable[[ModeKey], ModeModel]:
    """The mode builder of a circuit with links (``build`` its builder without them; itself
    when there are none): each mode's tree capacitor rows of ``x'``, of its network
    realisation and of the probes ``i(C)`` of the loops' capacitors mapped by ``P``, and
    ``builder.storage(K)`` the links' energy added to a stored-energy matrix ``K``."""
    if not links:
        return build
    keys, m, p = link_matrices(links, {k: float(by_key[k].value) for link in links.values()
                                       for k, _ in link.terms})
    rows = [state_index[k] for k in keys]
    t = np.eye(n)
    t[np.ix_(rows, rows)] = p  # x' = T x'(without the links)
    order = np.argsort(rows)
    rows_sorted = [rows[i] for i in order]
    p_sorted = p[np.ix_(order, order)]

    def builder(key: ModeKey) -> ModeModel:
        model = build(key)
        lcs = model.lcs
        k, q = lcs.A.shape[0], lcs.B.shape[1]
        dx = clean(t @ np.hstack([lcs.A, lcs.B, lcs.E]))
        inner = model.output

        def output(probes: Sequence[str]) -> OutputMap:
            names = tuple(probes)
            own = {probe: _loop_current(probe, links, rows, state_index, by_key, dx)
                   for probe in names}
            plain = [probe for probe in names if own[probe] is None]
            rest = inner(plain) if plain else None
            y = np.zeros((len(names), dx.shape[1]))
            for r, probe in enumerate(names):
                if own[probe] is not None:
                    y[r] = own[probe]
                else:
                    j = plain.index(probe)
                    y[r] = np.concatenate([rest.Cy[j], rest.Dy[j], rest.Fy[j]])
            return OutputMap(names=names, Cy=y[:, :k], Dy=y[:, k:k + q], Fy=y[:, k + q:])

        network = model.network
        if network is not None:
            def network(net=network):
                net = net() if callable(net) else net
                r, c, v = net.Rx
                block = np.zeros((len(rows), net.nz))  # the tree rows, mapped by P
                mine = np.isin(r, rows)
                np.add.at(block, (np.searchsorted(rows_sorted, r[mine]), c[mine]), v[mine])
                mixed = p_sorted @ block
                mr, mc = np.nonzero(mixed)
                return replace(net, Rx=coalesce(
                    np.concatenate([r[~mine], np.asarray(rows_sorted)[mr]]),
                    np.concatenate([c[~mine], mc]),
                    np.concatenate([v[~mine], mixed[mr, mc]]), net.nz))
        return replace(model, lcs=replace(lcs, A=dx[:, :k], B=dx[:, k:k + q],
                                          E=dx[:, k + q:]),
                       output=output, network=network)

    def storage(energy: np.ndarray) -> np.ndarray:
        # the links' energy, ½ C_l v_l², in the tree capacitors' voltages (its terms in the
        # DC sources' voltages are not quadratic: left out, as a source's own)
        energy[np.ix_(rows, rows)] = m
        return energy

    builder.storage = storage
    return builder


def _loop_current(probe: str, links: dict[str, LinkCapacitor], rows: list[int],
                  state_index: dict[str, int], by_key: dict, dx: np.ndarray
                  ) -> np.ndarray | None:
    """The row over ``(x, λ, u)`` of ``i(C)`` for a capacitor of a loop with links (a tree
    capacitor: ``C x'_k``; a link: ``C_l Σ a_lk x'_k``), or None for any other probe."""
    match = PROBE.match(probe)
    if not match or match.group(1).lower() != "i" or match.group(3) is not None:
        return None
    key = match.group(2).lower()
    if key in links:
        row = np.zeros(dx.shape[1])
        for k, a in links[key].terms:
            row += a * dx[state_index[k]]
        return links[key].value * row
    if state_index.get(key, -1) in rows and by_key[key].kind == "C":
        return float(by_key[key].value) * dx[state_index[key]]
    return None
