"""Semantic checks of a flattened circuit: every independent problem, not just the first.

:func:`check_circuit` looks at a :class:`~netlist.circuit.Circuit` alone, so it also serves
circuits built in code; the parser passes the locations of the tokens that name models,
controlling sources, inductors, control nodes and ``.ic`` nodes so that the caret points at
them. :func:`value_problem` is the rule for element values, applied by the parser where the
value's own location is known.

Topology rules:

- a ground node ``0`` must exist;
- a loop made only of voltage sources (V, E, H) is an error naming its elements (a source
  shorted by itself is the one-element case);
- every node needs a path to ground through elements (of any kind: a node reached only
  through capacitors is fine for pelcs). A part of the circuit with no such path is reported
  naming its nodes. The controlling nodes of S, E and G sense a voltage and carry no current,
  so they connect nothing; F and H sense the current of a V source by name.
"""

from __future__ import annotations

from collections import defaultdict, deque
from collections.abc import Mapping

from .circuit import GROUND, Circuit, Coupling, Element
from .errors import Diagnostic, Location

_MAX_LISTED = 12

_VOLTAGE_KINDS = ("V", "E", "H")
_CONTROLLED_BY_NODES = ("S", "E", "G")
_CONTROLLED_BY_SOURCE = ("F", "H")

_QUANTITY = {"R": "resistance", "L": "inductance", "C": "capacitance"}


def value_problem(kind: str, value: float) -> tuple[str, str] | None:
    """Whether an element value is acceptable.

    Parameters
    ----------
    kind : str
        Element letter; ``"K"`` for a coupling coefficient.
    value : float
        Ohm, henry, farad, or the coupling coefficient.

    Returns
    -------
    (str, str) or None
        Message fragment and hint, or ``None`` when the value is fine. A negative resistance
        is accepted here (it is flagged later as not passive).
    """
    if kind == "R" and value == 0:
        return ("resistance is zero",
                "an ideal short is not a resistor: merge the two nodes, or use a 0 V source "
                "(V) if you want to measure the current")
    if kind in ("L", "C") and value <= 0:
        return (f"{_QUANTITY[kind]} must be positive, got {value:g}",
                "an ideal inductor or capacitor has a positive value; a negative one is not "
                "a physical element")
    if kind == "K" and abs(value) > 1:
        return (f"coupling coefficient must satisfy |k| <= 1, got {value:g}",
                "k is the magnetic coupling M / sqrt(L1*L2), between -1 and 1")
    return None


class _UnionFind:
    def __init__(self) -> None:
        self.parent: dict[str, str] = {}

    def find(self, a: str) -> str:
        parent = self.parent
        root = parent.setdefault(a, a)
        while root != parent[root]:
            root = parent[root]
        while a != root:  # path compression
            parent[a], a = root, parent[a]
        return root

    def union(self, a: str, b: str) -> None:
        ra, rb = self.find(a), self.find(b)
        if ra != rb:
            self.parent[ra] = rb


def _listing(names: list[str]) -> str:
    if len(names) <= _MAX_LISTED:
        return ", ".join(names)
    return ", ".join(names[:_MAX_LISTED]) + f" and {len(names) - _MAX_LISTED} more"


def check_circuit(
    circuit: Circuit,
    ref_locations: Mapping[tuple[str, str], Location] | None = None,
    topology: bool = True,
) -> list[Diagnostic]:
    """All semantic problems of a flattened circuit.

    Parameters
    ----------
    circuit : Circuit
        The flattened circuit.
    ref_locations : mapping, optional
        ``(element key, what) -> Location`` with ``what`` one of ``"model"``, ``"source"``,
        ``"inductor0"``, ``"inductor1"``, ``"control"``; and ``("ic", node)`` for ``.ic``.
        Missing entries fall back to the element's own location.
    topology : bool
        Run the connectivity checks (control nodes on the circuit, voltage-source loops,
        parts with no path to ground);
        the parser turns them off when part of the circuit is missing because of an earlier
        error.

    Returns
    -------
    list of Diagnostic
        Empty when the circuit is fine.
    """
    refs = ref_locations or {}
    diags: list[Diagnostic] = []
    if not circuit.elements:
        return [Diagnostic("the netlist has no elements", None,
                           "remember that the first line of a netlist is its title")]

    by_key: dict[str, Element] = {}
    for el in circuit.elements:
        first = by_key.get(el.key)
        if first is not None:
            where = f" (first at line {first.location.line})" if first.location else ""
            diags.append(Diagnostic(f"duplicate element name '{el.name}'{where}", el.location,
                                    "element names must be unique (case does not matter)",
                                    (first.name, el.name)))
        else:
            by_key[el.key] = el

    terminals: set[str] = set()
    for el in circuit.elements:
        terminals.update(el.nodes)

    _check_references(circuit, by_key, refs, diags)

    has_ground = GROUND in terminals
    if not has_ground:
        diags.append(Diagnostic(
            "no ground node: no element is connected to node 0 (or gnd)", None,
            "SPICE measures every voltage from node 0: connect the circuit's reference "
            "node to 0"))

    idealised = {r.element.lower(): r.device for r in circuit.replacements}
    for el in circuit.elements if topology else ():  # (a hole may hold the control node)
        if el.kind in _CONTROLLED_BY_NODES:
            for n in el.control:
                if n != GROUND and n not in terminals:
                    diags.append(Diagnostic(
                        f"control node '{n}' of {el.name} is not connected to any element",
                        refs.get((el.key, "control"), el.location),
                        _floating_control_hint(idealised.get(el.key), el.name, n), (el.name,)))

    for node, value in circuit.initial_conditions.items():
        loc = refs.get(("ic", node))
        if node == GROUND:
            if value != 0:
                diags.append(Diagnostic(".ic sets the ground node to a non-zero voltage", loc,
                                        "node 0 is 0 V by definition"))
        elif node not in terminals:
            diags.append(Diagnostic(f".ic names node '{node}', which is not in the circuit",
                                    loc, "check the node name (nodes in subcircuit instances "
                                    "are named like x1.node)"))

    if topology:
        _check_voltage_loops(circuit, diags)
        if has_ground:
            _check_floating(circuit, diags)
    return diags


def _floating_control_hint(device: str | None, name: str, node: str) -> str:
    """The hint of a control node no element joins: for a transistor pelcs idealised, that
    its base or gate is the switch's control, which senses the node and sets no voltage."""
    if device is None:
        return "a control node must be a node of the circuit; check its spelling"
    pin = "base" if device in ("NPN", "PNP") else "gate"
    article = "an" if device.startswith("N") else "a"
    return (f"{name} is {article} {device} transistor pelcs idealised into a switch, whose "
            f"{pin} only senses the voltage at '{node}'; no other element joins that node, so "
            "nothing "
            f"sets it (ngspice lets the device's own {pin} current or leakage settle it): "
            f"connect '{node}' as the circuit means it (an IC's unused input such as a 555's "
            "RESET to its supply, a gate to its driver) or give it a resistor to a node")


def _check_references(circuit: Circuit, by_key: dict[str, Element],
                      refs: Mapping[tuple[str, str], Location], diags: list[Diagnostic]) -> None:
    models = circuit.models
    for el in circuit.elements:
        kind = el.kind
        if kind in ("D", "S"):
            if getattr(el, "body_of", "") or getattr(el, "device", None) is not None or \
                    el.built_for:
                continue  # an idealised device's part (the device's own model is checked),
                # or an element pelcs built for a line (a limiter's diode, a time-stepped
                # resistor's bypass: their models are pelcs's own)
            want, what = ("D", "diode") if kind == "D" else ("SW", "switch")
            loc = refs.get((el.key, "model"), el.location)
            if not el.model:
                diags.append(Diagnostic(f"{what} {el.name} has no model", loc,
                                        f"add a model name and .model NAME {want}(...)",
                                        (el.name,)))
                continue
            model = models.get(el.model.lower())
            if model is None:
                known = [m.name for m in models.values() if m.type == want]
                hint = f"define it: .model {el.model} {want}(...)"
                if known:
                    hint += f" (known {want} models: {', '.join(known)})"
                diags.append(Diagnostic(f"unknown model '{el.model}' for {what} {el.name}", loc,
                                        hint, (el.name,)))
            elif model.type != want:
                diags.append(Diagnostic(
                    f"{what} {el.name} uses model '{model.name}' of type {model.type}, "
                    f"a {what} needs a {want} model", loc,
                    f"use a .model NAME {want}(...)", (el.name,)))
        elif kind in _CONTROLLED_BY_SOURCE:
            loc = refs.get((el.key, "source"), el.location)
            target = by_key.get(el.source.lower())
            hint = ("F and H elements sense the current of a V source: name one (a 0 V source in "
                    "series measures any branch current)")
            if target is None:
                diags.append(Diagnostic(f"unknown controlling source '{el.source}' for {el.name}",
                                        loc, hint, (el.name,)))
            elif target.kind != "V":
                diags.append(Diagnostic(
                    f"controlling element '{target.name}' of {el.name} is not a voltage source",
                    loc, hint, (el.name, target.name)))
        elif isinstance(el, Coupling):
            names = [n.lower() for n in el.inductors]
            for i, ind in enumerate(el.inductors):
                loc = refs.get((el.key, f"inductor{i}"), el.location)
                target = by_key.get(ind.lower())
                if target is None:
                    diags.append(Diagnostic(f"unknown inductor '{ind}' in coupling {el.name}",
                                            loc, "K couples two inductors (L elements) by name",
                                            (el.name,)))
                elif target.kind != "L":
                    diags.append(Diagnostic(
                        f"coupling {el.name} names '{target.name}', which is not an inductor",
                        loc, "K couples two inductors (L elements) by name",
                        (el.name, target.name)))
            if names[0] == names[1]:
                diags.append(Diagnostic(f"coupling {el.name} couples {el.inductors[0]} with "
                                        "itself", refs.get((el.key, "inductor1"), el.location),
                                        "name two different inductors", (el.name,)))


def _check_voltage_loops(circuit: Circuit, diags: list[Diagnostic]) -> None:
    uf = _UnionFind()
    adj: dict[str, list[tuple[str, str]]] = defaultdict(list)
    for el in circuit.elements:
        if el.kind not in _VOLTAGE_KINDS:
            continue
        a, b = el.nodes
        if a == b:
            diags.append(Diagnostic(
                f"voltage source {el.name} is short-circuited: both terminals on node '{a}'",
                None, "connect its terminals to two different nodes", (el.name,)))
            continue
        if uf.find(a) == uf.find(b):
            loop = _path(adj, a, b) + [el.name]
            diags.append(Diagnostic(
                f"loop of voltage sources: {', '.join(loop)}", None,
                "a loop made only of voltage sources (V, E, H) sets a voltage twice: add a "
                "series resistance or inductance, or remove one of them", tuple(loop)))
            continue
        uf.union(a, b)
        adj[a].append((b, el.name))
        adj[b].append((a, el.name))


def _path(adj: dict[str, list[tuple[str, str]]], a: str, b: str) -> list[str]:
    """Element names along the (unique) path from a to b in a forest of voltage sources."""
    prev: dict[str, tuple[str, str] | None] = {a: None}
    queue = deque([a])
    while queue:
        n = queue.popleft()
        if n == b:
            break
        for m, name in adj[n]:
            if m not in prev:
                prev[m] = (n, name)
                queue.append(m)
    names = []
    n = b
    while prev.get(n) is not None:
        n, name = prev[n]
        names.append(name)
    return names[::-1]


def _check_floating(circuit: Circuit, diags: list[Diagnostic]) -> None:
    uf = _UnionFind()
    for el in circuit.elements:
        nodes = el.nodes
        if nodes:
            first = nodes[0]
            uf.find(first)
            for n in nodes[1:]:
                uf.union(first, n)
    ground = uf.find(GROUND)
    groups: dict[str, list[str]] = {}
    for node in circuit.nodes:
        if node in uf.parent:
            root = uf.find(node)
            if root != ground:
                groups.setdefault(root, []).append(node)
    if not groups:
        return
    members: dict[str, list[str]] = defaultdict(list)
    for el in circuit.elements:
        if el.nodes:
            root = uf.find(el.nodes[0])
            if root in groups:
                members[root].append(el.name)
    for root, nodes in groups.items():
        plural = "s" if len(nodes) > 1 else ""
        # a transistor idealised as a switch reads its base or gate and loads neither: a bias
        # network that reaches the rest only through bases is floating in pelcs only
        bases = [el.name for el in circuit.elements
                 if getattr(el, "device", None) and set(getattr(el, "control", ())) & set(nodes)]
        if bases:
            diags.append(Diagnostic(
                f"node{plural} {_listing(nodes)} reach{'' if plural else 'es'} the rest of the "
                f"circuit only through the base or gate of {_listing(bases)}, which pelcs "
                "idealises as switches that draw no base current: in the circuit those "
                "currents set the nodes (a bias or timing network of transistors in their "
                "active region, as in a transistor-level oscillator or controller)", None,
                "pelcs simulates transistors that switch fully on or off: write the "
                "controller behaviourally (a PULSE source, a comparator B source or S switch) "
                "and keep the power stage's switches",
                tuple(members[root][:_MAX_LISTED]) + tuple(bases[:_MAX_LISTED])))
            continue
        diags.append(Diagnostic(
            f"node{plural} {_listing(nodes)} {'have' if plural else 'has'} no connection to "
            "ground", None,
            "this part of the circuit is connected to node 0 by no element at all: connect it "
            "(a capacitor or a large resistor will do) or remove it",
            tuple(members[root][:_MAX_LISTED])))
