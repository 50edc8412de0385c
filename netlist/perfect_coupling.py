"""Inductors coupled with |k| = 1, read as an ideal transformer and its magnetizing
inductance.

pelcs's inductor currents are states, ``Lmat di/dt = v``; with ``K1 L1 L2 1`` the matrix
``[[L1, M], [M, L2]]``, ``M = k sqrt(L1 L2)``, is singular: one flux, two currents, and the
currents are not both states. ngspice runs such a pair (LTspice-style flybacks write
``K1 Lp Ls 1``). Exactly, with ``n = k sqrt(L2 / L1)``:

    v2 = M di1/dt + L2 di2/dt = n (L1 di1/dt + M di2/dt) = n v1,
    v1 = L1 d(i1 + n i2)/dt,

so the pair is the magnetizing inductance L1 carrying ``im = i1 + n i2`` across the primary,
and an ideal transformer of ratio ``n``: an E source ``v2 = n v1`` on the secondary and an
F source drawing ``-n i2`` across the primary. Built as

    VL1    p1 q      0 V   (the primary's current i1)
    L1_m   q  p2     L1    (im; IC = IC(L1) + n IC(L2))
    FL2    q  p2     VL2   -n
    EL2    s1 r      q p2   n
    VL2    r  s2     0 V   (the secondary's current i2)

``i(VL1)`` and ``i(VL2)`` are the winding currents, which ngspice calls ``i(L1)``, ``i(L2)``:
those probes read them (the group's :attr:`~netlist.circuit.BuiltGroup.currents`), and
``i(L1_m)`` is the magnetizing current. The elements are a group built for the K line
(:class:`~netlist.circuit.BuiltGroup`, construct :data:`IDEAL_TRANSFORMER`): a deck written
for ngspice gets the windings' and the K lines back.

More windings on one core (a centre-tapped secondary: ``K1 L1 L2 1``, ``K2 L2 L3 1``,
``K3 L1 L3 1``) are the same with an E, F and sense source per winding beyond the first,
``n_j = s_j sqrt(L_j / L1)``, ``im = sum n_j i_j``, provided every pair is coupled with
|k| = 1 and the signs agree (``k_ij = s_i s_j``). A winding also coupled with |k| < 1 keeps
its group as it is (the formulation refuses the singular matrix, with its hint).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace

from .circuit import (
    BuiltGroup,
    Cccs,
    Circuit,
    Coupling,
    Element,
    Inductor,
    Vcvs,
    VoltageSource,
    substituted,
    unique_name,
)
from .errors import Location
from .writer import element_line

__all__ = ["IDEAL_TRANSFORMER", "build_transformer", "ideal_transformers",
           "transformer_sources"]

#: :attr:`netlist.circuit.BuiltGroup.construct` of windings coupled with |k| = 1
IDEAL_TRANSFORMER = "ideal transformer"

#: |k| within this of 1 is a perfect coupling (the formulation's singularity test is 1e-9)
UNITY = 1e-9


def _groups(circuit: Circuit) -> list[tuple[list[Inductor], list[float], list[Coupling]]]:
    """The windings coupled with |k| = 1, by groups: ``(windings, signs of k from the first,
    K elements)`` for each group whose windings are all coupled pairwise with |k| = 1, the
    signs consistent (``k_ij = s_i s_j``), and to nothing else."""
    inductors = {el.key: el for el in circuit.elements if isinstance(el, Inductor)}
    couplings = [el for el in circuit.elements if isinstance(el, Coupling)]
    unity: dict[frozenset, Coupling] = {}
    partial: set[str] = set()  # inductors in a coupling of |k| < 1, or an invalid one
    for kel in couplings:
        names = [str(n).lower() for n in kel.inductors]
        if len(names) == 2 and all(n in inductors for n in names) and names[0] != names[1] \
                and math.isfinite(kel.k) and abs(abs(kel.k) - 1.0) <= UNITY \
                and frozenset(names) not in unity:
            unity[frozenset(names)] = kel
        else:
            partial.update(names)
    adjacent: dict[str, set[str]] = {}
    for pair in unity:
        a, b = tuple(pair)
        adjacent.setdefault(a, set()).add(b)
        adjacent.setdefault(b, set()).add(a)
    order = [el.key for el in circuit.elements if el.key in adjacent]
    seen: set[str] = set()
    out = []
    for first in order:
        if first in seen:
            continue
        group, stack = [], [first]
        seen.add(first)
        while stack:
            node = stack.pop()
            group.append(node)
            for nxt in adjacent[node]:
                if nxt not in seen:
                    seen.add(nxt)
                    stack.append(nxt)
        group.sort(key=order.index)
        if partial & set(group) or any(not inductors[n].value > 0 for n in group):
            continue  # (the formulation refuses it, or reports the value)
        signs = [1.0] + [math.copysign(1.0, unity[frozenset((group[0], n))].k)
                         if frozenset((group[0], n)) in unity else 0.0 for n in group[1:]]
        if 0.0 in signs or any(
                frozenset((a, b)) not in unity
                or math.copysign(1.0, unity[frozenset((a, b))].k) != signs[i] * signs[j]
                for i, a in enumerate(group) for j, b in enumerate(group) if i < j):
            continue
        ks = [unity[frozenset((a, b))] for i, a in enumerate(group) for b in group[i + 1:]]
        out.append(([inductors[n] for n in group], signs, ks))
    return out


def ideal_transformers(circuit: Circuit) -> Circuit:
    """The circuit with each group of inductors that K elements couple with |k| = 1 (all
    pairwise, and to nothing else) replaced by the first one's inductance as the magnetizing
    inductance and an ideal transformer (see the module docstring), a note for each; the
    circuit itself if there is none."""
    groups = _groups(circuit)
    if not groups:
        return circuit
    used = {el.key for el in circuit.elements}
    nodes = {n.lower() for el in circuit.elements for n in el.nodes}
    new: dict[str, list[Element]] = {}
    gone: set[str] = set()
    notes = list(circuit.notes)
    # (a new circuit: the one given may be a parse cached for reuse)
    out = replace(circuit, built_groups=dict(circuit.built_groups))
    for windings, signs, ks in groups:
        la = windings[0]
        lm, vp, names = build_transformer(
            out, windings, signs, ks[0].name, IDEAL_TRANSFORMER, ks[0].location,
            "\n".join(element_line(el, circuit) for el in (*windings, *ks)), used, nodes, new)
        gone.update(k.key for k in ks)
        ratios = ", ".join(f"{name} {n:.6g}" for name, _, n in names)
        notes.append(
            f"{', '.join(k.name for k in ks)}: |k| = 1 couples "
            f"{', '.join(lw.name for lw in windings)} without leakage (one flux: their "
            f"currents cannot all be states), read exactly as an ideal transformer (turns "
            f"ratios to {la.name}: {ratios}) with {la.name}'s inductance, {lm}, across "
            f"{la.name}'s terminals: i({la.name}), "
            + ", ".join(f"i({name})" for name, _, _ in names)
            + f" probe the winding currents (the 0 V sources {vp}, "
            + ", ".join(vs for _, vs, _ in names)
            + f"), i({lm}) the magnetizing current, the turns-weighted sum of those")
    return replace(out, elements=substituted(circuit.elements, new, gone), notes=notes)


def build_transformer(out: Circuit, windings: Sequence[Inductor], signs: Sequence[float],
                      group: str, construct: str, location: Location | None, line: str,
                      used: set[str], nodes: set[str], new: dict[str, list[Element]]
                      ) -> tuple[str, str, list[tuple[str, str, float]]]:
    """The elements of one group of perfectly coupled windings (the module docstring), put
    in ``new`` by winding key and recorded in ``out`` as the built group ``group``.

    Parameters
    ----------
    out : Circuit
        Gets the :class:`~netlist.circuit.BuiltGroup` (``construct``, ``line`` written for
        ngspice in the group's place).
    windings : sequence of Inductor
        The windings, the first one's inductance the magnetizing inductance (H).
    signs : sequence of float
        ±1 per winding: the sign of its coupling to the first.
    location : Location or None
        Where the built sources point in messages.
    used, nodes : set of str
        The circuit's element and node names (lower case), extended by those added.

    Returns
    -------
    magnetizing : str
        The name of the magnetizing inductor (its current is the turns-weighted sum of the
        winding currents).
    sense : str
        The 0 V source that carries the first winding's current.
    secondaries : list of (str, str, float)
        ``(winding, its sense source, its turns ratio to the first)`` beyond the first.
    """
    la = windings[0]
    ns = [sign * math.sqrt(lw.value / la.value) for lw, sign in zip(windings, signs,
                                                                     strict=True)]
    p1, p2 = la.nodes[:2]
    q = unique_name(f"{la.name.lower()}_q", nodes)
    vp = unique_name(f"V{la.name}", used)
    lm = unique_name(f"{la.name}_m", used)
    ic = None
    if any(lw.ic is not None for lw in windings):
        ic = sum(n * (lw.ic or 0.0) for n, lw in zip(ns, windings, strict=True))
    primary: list[Element] = [VoltageSource(vp, (p1, q), la.location, 0.0),
                              Inductor(lm, (q, p2), la.location, value=la.value, ic=ic)]
    names = []
    built: list[Element] = []
    for lw, n in zip(windings[1:], ns[1:], strict=True):
        s1, s2 = lw.nodes[:2]
        r = unique_name(f"{lw.name.lower()}_r", nodes)
        vs = unique_name(f"V{lw.name}", used)
        primary.append(Cccs(unique_name(f"F{lw.name}", used), (q, p2), location,
                            source=vs, gain=-n))
        new[lw.key] = [
            Vcvs(unique_name(f"E{lw.name}", used), (s1, r), location,
                 control=(q, p2), gain=n),
            VoltageSource(vs, (r, s2), lw.location, 0.0)]
        built += new[lw.key]
        names.append((lw.name, vs, n))
    new[la.key] = primary
    out.add_built_group(BuiltGroup(
        group, construct, line,
        currents=((la.name, vp), *((name, vs) for name, vs, _ in names))), primary + built)
    return lm, vp, names


def transformer_sources(circuit: Circuit) -> frozenset[str]:
    """Keys of the E and F sources of the ideal transformers pelcs built (``EL2``, ``FL2``).

    Their voltage and current are the magnetizing inductance's voltage and the secondary's
    current times the ratio, neither of which the circuit imposes: a diode in a loop with an
    ``E`` may still have either λ type, and an ``F`` with an inductor is no cutset of imposed
    currents (a flyback's primary switch open: the magnetizing current goes over to the
    secondary). The topological rules that read E as voltage-defined and F as
    current-defined branches leave them out; the MNA decides (:mod:`netlist.formulation`).
    """
    return frozenset(el.key for el in circuit.elements if el.kind in "EF" and el.built_for
                     and circuit.built_groups[el.built_for.lower()].construct
                     == IDEAL_TRANSFORMER)
