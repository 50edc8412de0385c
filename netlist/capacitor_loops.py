"""Loops of capacitors and independent voltage sources, reduced exactly to one state each.

The loop reduced is a *capacitor star*: two or more capacitors from one node ``m`` to nodes
``a_k`` that independent voltage sources alone join, ``m`` not among them (the half
bridge's two input capacitors in series across the supply, ``m`` their midpoint).
Kirchhoff's voltage law ties their voltages (they differ by source voltages), so of their
states one is left: the charge at ``m``. With ``v_k = v(m) - v(a_k)`` (each capacitor's
voltage seen from ``m``) the current that leaves ``m`` into the capacitors is

    Σ C_k dv_k/dt = Ceq d(v(m) - v(n))/dt,     Ceq = Σ C_k,   v(n) = Σ C_k v(a_k) / Ceq,

exactly. So the capacitors become one capacitor ``Ceq`` from ``m`` to a new node ``n``,
held at ``Σ C_k v(a_k) / Ceq`` by E sources (one per capacitor but the first, in series,
``(C_k / Ceq) (v(a_k) - v(a_0))`` each) on the source-held nodes. Its voltage, the state,
is ``Σ C_k v_k / Ceq``: the capacitance-weighted mean of the capacitors' voltages, ``1/Ceq``
times the charge at ``m``. The form needs no derivative of a source (a state ``v_k`` itself
would: ``v_k - v_j`` is a source voltage), and every node voltage is exact.

What it does not keep: the split of the capacitors' currents among the nodes ``a_k`` (the
sum goes into ``a_0``). They are nodes the sources hold, so only the currents of those
sources differ (as for a capacitor straight across a source,
:func:`netlist.reductions.source_capacitors`); the note says so.

Initial conditions: the charge at ``m`` is kept, ``Ceq x0 = Σ C_k v_k(0)`` with each
``v_k(0)`` its ``IC=`` (else from ``.ic`` node voltages, else 0), which is what ngspice does
with UIC: where those voltages do not fit the sources, the capacitors' voltages jump at
t = 0 to the ones the loop allows with that charge (measured: 1 µF from a 10 V source to
``m`` with IC=2, 3 µF from ``m`` to ground with IC=3: ngspice starts at v(m) = 4.25 V, the
charge kept, ``(1 µF (v(m) - 10) + 3 µF v(m)) = 1 µF (-2) + 3 µF 3``).

Other loops (a chain of capacitors with a node between them that does not reach the
sources, loops through closed switches or E/H sources) stay refused by
:func:`netlist.degenerate.check_topology`.
"""

from __future__ import annotations

from dataclasses import replace

from .circuit import (
    GROUND,
    Capacitor,
    Circuit,
    Element,
    Vcvs,
    VoltageSource,
    substituted,
    unique_name,
)
from .errors import Diagnostic
from .topology import UnionFind, find_loop

__all__ = ["reduce_capacitor_loops", "reduced_probe"]


def _initial_voltage(el: Capacitor, ics: dict[str, float]) -> float:
    """The capacitor's initial voltage (V) as :func:`netlist.studies.transient.initial_state` takes
    it: ``IC=``, else its nodes' ``.ic`` values (0 V for a node without one), else 0."""
    if el.ic is not None:
        return float(el.ic)
    a, b = el.nodes[:2]
    if a not in ics and b not in ics:
        return 0.0
    va = 0.0 if a == GROUND else ics.get(a, 0.0)
    vb = 0.0 if b == GROUND else ics.get(b, 0.0)
    return float(va - vb)


def _stars(circuit: Circuit) -> list[tuple[str, list[tuple[Capacitor, str]]]]:
    """The capacitor stars to reduce: (node m, [(capacitor, its other node)]), in netlist
    order of their first capacitor."""
    if sum(type(el) is Capacitor for el in circuit.elements) < 2:
        return []  # (a star has two capacitors or more: most circuits end here, every run)
    uf = UnionFind()
    for el in circuit.elements:
        if isinstance(el, VoltageSource):
            uf.union(*el.nodes[:2])
    held = {n for el in circuit.elements if isinstance(el, VoltageSource) for n in el.nodes[:2]}
    groups: dict[tuple[str, str], list[tuple[Capacitor, str]]] = {}
    for el in circuit.elements:
        # plain capacitors only (a knee capacitor's value depends on its own voltage)
        if type(el) is not Capacitor or el.nodes[0] == el.nodes[1]:
            continue
        for m, a in (el.nodes[:2], el.nodes[1::-1]):
            if a in held and uf.find(m) != uf.find(a):
                groups.setdefault((m, uf.find(a)), []).append((el, a))
    out = []
    for (m, _), caps in groups.items():
        # two or more capacitors to two or more source-held nodes: a loop (to one node only
        # they are in parallel, no source in the loop)
        if len(caps) >= 2 and len({a for _, a in caps}) >= 2:
            out.append((m, caps))
    taken: set[str] = set()
    stars = []
    for m, caps in out:
        if any(el.key in taken for el, _ in caps):
            continue  # (a capacitor between two floating nodes is in one star at most)
        taken.update(el.key for el, _ in caps)
        stars.append((m, caps))
    return stars


def reduce_capacitor_loops(circuit: Circuit) -> Circuit:
    """The circuit with each capacitor star (module docstring) replaced by one capacitor
    ``Ceq`` (named after its capacitors, ``C1_C2``) to a node the E sources hold; a note
    per star. The circuit itself when it has none.

    Parameters
    ----------
    circuit : Circuit
        A flattened circuit.

    Returns
    -------
    Circuit
    """
    stars = _stars(circuit)
    if not stars:
        return circuit
    from .units import format_eng

    used = {el.key for el in circuit.elements}
    nodes_used = set(circuit.nodes)
    gone: set[str] = set()
    new: dict[str, list[Element]] = {}  # key of the star's first capacitor -> its elements
    notes = list(circuit.notes)
    loop_capacitors = dict(circuit.loop_capacitors)
    for m, caps in stars:
        ceq = sum(float(el.value) for el, _ in caps)
        names = [el.name for el, _ in caps]
        name = unique_name("_".join(names), used)
        node = unique_name(f"{name.lower()}_n", nodes_used)
        # each capacitor's voltage seen from m (the sign of its own for m its first node)
        q = sum(float(el.value) * (1.0 if el.nodes[0] == m else -1.0)
                * _initial_voltage(el, circuit.initial_conditions) for el, _ in caps)
        a0 = caps[0][1]
        first = caps[0][0]
        elements: list[Element] = [Capacitor(name, (m, node), location=first.location,
                                             value=ceq, ic=q / ceq)]
        top = node
        rest = [(el, a) for el, a in caps[1:] if a != a0]
        for i, (el, a) in enumerate(rest):
            bottom = a0 if i == len(rest) - 1 else unique_name(f"{name.lower()}_n{i + 1}",
                                                           nodes_used)
            elements.append(Vcvs(unique_name(f"E{name}_{i + 1}", used), (top, bottom),
                                 location=el.location, control=(a, a0),
                                 gain=float(el.value) / ceq))
            top = bottom
        gone.update(el.key for el, _ in caps)
        loop_capacitors.update({el.key: (el.name, tuple(el.nodes[:2]), name)
                                for el, _ in caps})
        new[first.key] = elements
        loop = find_loop([(el.name, *el.nodes[:2]) for el, _ in caps[:2]]
                         + [(s.name, *s.nodes[:2]) for s in circuit.elements
                            if isinstance(s, VoltageSource)]) or []
        sources = [n for n in loop if n not in names]
        given = any(el.ic is not None for el, _ in caps) or m in circuit.initial_conditions
        notes.append(
            f"{', '.join(names)}: in a loop with the voltage source"
            f"{'s' if len(sources) > 1 else ''} {', '.join(sources)} (all from node {m}): "
            f"Kirchhoff's voltage law leaves them one state, v({name}), "
            "the capacitance-weighted mean of their voltages seen from "
            f"{m} (their charge at {m} over {format_eng(ceq, 'F')}); one capacitor "
            f"{name} = {format_eng(ceq, 'F')} from {m} to a node E sources hold at that "
            "mean of their other nodes' voltages stands for them: node voltages are exact, "
            f"i({names[0]}) ... are not probed, and the currents of the sources leave out "
            "their split"
            + (f"; it starts at v({name}) = {format_eng(q / ceq, 'V')}, their charge at "
               f"{m} from their initial voltages: where those do not fit the sources, the "
               "capacitor voltages jump at t = 0 to the ones the loop allows with that "
               "charge, as ngspice does with UIC" if given else ""))
    return replace(circuit, elements=substituted(circuit.elements, new, gone), notes=notes,
                   loop_capacitors=loop_capacitors)


def reduced_probe(circuit: Circuit, probe: str, kind: str, key: str) -> Diagnostic:
    """The error of a probe ``v(C1)`` or ``i(C1)`` (``kind`` "v" or "i") of a capacitor
    ``key`` that :func:`reduce_capacitor_loops` reduced: what to probe instead."""
    name, (n1, n2), into = circuit.loop_capacitors[key]
    hint = f"probe v({n1},{n2}), the voltage of {name}"
    if kind != "v":
        hint += (f" (its own current is not kept; i({into}) is their current out of node "
                 f"{circuit.element(into).nodes[0]}, summed)")
    return Diagnostic(message=f"probe {probe.strip()!r}: {name} is in a loop with voltage "
                              f"sources, reduced with the others to one capacitor, {into}",
                      hint=hint)
