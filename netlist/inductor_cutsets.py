"""Cutsets of inductors at a floating group of voltage sources (a three-phase source's
star point with a line inductor on each phase), made regular exactly.

The group ``S`` is a set of nodes that independent voltage sources alone join, not ground,
whose every connection to the rest of the circuit is an (uncoupled) inductor ``L_k`` from
``a_k`` in ``S`` to ``b_k`` outside. Kirchhoff's current law ties their currents,
``Σ i_k = 0``, and leaves the potential of ``S`` to the inductors: with
``u_k = v(a_k) - v(a_0)`` (source voltages) and ``L_k di_k/dt = v(a_k) - v(b_k)``,
``Σ di_k/dt = 0`` gives

    v(a_0) = Σ w_k (v(b_k) - u_k),        w_k = (1/L_k) / Σ_j (1/L_j),

a weighted mean of the inductors' outer nodes. E sources in series from ``a_0`` to ``b_0``
hold ``v(a_0)`` there (gains ``w_k`` on ``v(b_k) - v(b_0)`` and ``-w_k`` on
``v(a_k) - v(a_0)``, ``k ≥ 1``). Then every inductor keeps its state ``i(L_k)`` and its
exact voltage, and ``Σ di_k/dt = 0`` holds identically, so ``Σ i_k`` stays at its initial
zero; the E sources carry ``-Σ i_k``, zero. ngspice finds the same potential (its gmin
conductances, 1e-12 S, barely pull on it).

Initial currents that do not sum to zero cannot be: the common node's voltage impulse that
Kirchhoff's law forces changes each ``L_k i_k`` by the same flux, so the currents start at
``i_k - c / L_k`` with ``c = Σ i_k / Σ (1/L_j)``; a note gives them.
"""

from __future__ import annotations

from dataclasses import replace

from .circuit import GROUND, Circuit, Element, Inductor, Vcvs, VoltageSource, unique_name
from .topology import UnionFind

__all__ = ["regularise_inductor_cutsets"]


def _groups(circuit: Circuit) -> list[list[tuple[Inductor, str, str]]]:
    """Per floating group of sources, its inductors as (inductor, node in S, node out)."""
    if sum(type(el) is Inductor for el in circuit.elements) < 2:
        return []  # (a group has two inductors or more: most circuits end here, every run)
    uf = UnionFind()
    held: set[str] = set()
    for el in circuit.elements:
        if isinstance(el, VoltageSource):
            uf.union(*el.nodes[:2])
            held.update(el.nodes[:2])
    coupled = {str(name).lower() for el in circuit.elements if el.kind == "K"
               for name in el.inductors}
    ground = uf.find(GROUND)
    out: dict[str, list[tuple[Inductor, str, str]]] = {}
    bad: set[str] = set()
    for el in circuit.elements:
        if el.kind == "K" or len(el.nodes) < 2:
            continue
        for i, n in enumerate(el.nodes):
            if n not in held or uf.find(n) == ground:
                continue
            root = uf.find(n)
            if all(uf.find(m) == root for m in el.nodes):
                continue  # inside the group
            if (type(el) is Inductor and len(el.nodes) == 2 and el.key not in coupled):
                out.setdefault(root, []).append((el, n, el.nodes[1 - i]))
            else:
                bad.add(root)
    return [ind for root, ind in out.items() if root not in bad and len(ind) >= 2
            and len({el.key for el, _, _ in ind}) == len(ind)]


def regularise_inductor_cutsets(circuit: Circuit) -> Circuit:
    """The circuit with E sources holding each floating group's potential (module
    docstring), initial currents made to sum to zero, a note per group; the circuit itself
    when it has none."""
    from .units import format_eng

    groups = _groups(circuit)
    if not groups:
        return circuit
    uf = UnionFind()
    for el in circuit.elements:
        if isinstance(el, VoltageSource):
            uf.union(*el.nodes[:2])
    roots = uf.roots()
    used = {el.key for el in circuit.elements}
    nodes_used = set(circuit.nodes)
    notes = list(circuit.notes)
    added: list[Element] = []
    ics: dict[str, float] = {}
    for ind in groups:
        names = [el.name for el, _, _ in ind]
        g = [1.0 / float(el.value) for el, _, _ in ind]
        w = [x / sum(g) for x in g]
        (_, a0, b0) = ind[0]
        terms = []
        for k, (el, a, b) in enumerate(ind[1:], start=1):
            if b != b0:
                terms.append((w[k], (b, b0), el))
            if a != a0:
                terms.append((-w[k], (a, a0), el))
        top = a0
        base = "_".join(names)
        for i, (gain, control, el) in enumerate(terms):
            bottom = b0 if i == len(terms) - 1 else unique_name(f"{base.lower()}_s{i + 1}",
                                                           nodes_used)
            added.append(Vcvs(unique_name(f"E{base}_{i + 1}", used), (top, bottom),
                              location=el.location, control=control, gain=gain))
            top = bottom
        if not terms:  # every inductor from a0 to b0: in parallel, v(a0) = v(b0)
            added.append(Vcvs(unique_name(f"E{base}_1", used), (a0, b0),
                              location=ind[0][0].location, control=(b0, b0), gain=0.0))
        group = sorted(n for n, r in roots.items() if r == roots[ind[0][1]])
        text = (f"{', '.join(names)}: the only branches from the voltage sources' floating "
                f"nodes {', '.join(group[:8])}{', ...' if len(group) > 8 else ''}: "
                "Kirchhoff's current law makes "
                "their currents sum to zero and sets those nodes' potential (the "
                "1/L-weighted mean that keeps the sum's derivative at zero), held there by "
                "E sources that carry no current")
        i0 = [float(el.ic or 0.0) for el, _, _ in ind]
        total = sum(i0)
        if total != 0.0:
            c = total / sum(g)
            new = [i - c * gk for i, gk in zip(i0, g, strict=True)]
            ics.update({el.key: v for (el, _, _), v in zip(ind, new, strict=True)})
            text += ("; their initial currents sum to " + format_eng(total, "A")
                     + ", which Kirchhoff's law does not allow: the same flux change of each "
                     "(a voltage impulse at the common node) makes them "
                     + ", ".join(f"{el.name} = {format_eng(v, 'A')}"
                                 for (el, _, _), v in zip(ind, new, strict=True)) + " at t = 0")
        notes.append(text)
    elements = [replace(el, ic=ics[el.key]) if el.key in ics else el
                for el in circuit.elements] + added
    return replace(circuit, elements=elements, notes=notes)
