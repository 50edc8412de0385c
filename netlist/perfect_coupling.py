"""Two inductors coupled with |k| = 1, read as an ideal transformer and its magnetizing
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
    FK1    q  p2     VL2   -n
    EK1    s1 r      q p2   n
    VL2    r  s2     0 V   (the secondary's current i2)

A note names them: ``i(VL1)`` and ``i(VL2)`` are the winding currents ngspice calls
``i(L1)``, ``i(L2)``; ``i(L1)``, ``i(L2)`` are no longer elements, so probing them is an error
rather than another current under their name. An inductor in another coupling as well keeps
the pair as it is (the formulation refuses the singular matrix, with its hint).
"""

from __future__ import annotations

import math
from dataclasses import replace

from .circuit import Cccs, Circuit, Coupling, Element, Inductor, Vcvs, VoltageSource, unique_name

__all__ = ["ideal_transformers"]

#: |k| within this of 1 is a perfect coupling (the formulation's singularity test is 1e-9)
UNITY = 1e-9


def ideal_transformers(circuit: Circuit) -> Circuit:
    """The circuit with each pair of inductors that a K element couples with |k| = 1 (and no
    other K) replaced by its magnetizing inductance and an ideal transformer (see the module
    docstring), a note for each; the circuit itself if there is none."""
    couplings = [el for el in circuit.elements if isinstance(el, Coupling)]
    if not couplings:
        return circuit
    count: dict[str, int] = {}
    for kel in couplings:
        for name in kel.inductors:
            count[str(name).lower()] = count.get(str(name).lower(), 0) + 1
    inductors = {el.key: el for el in circuit.elements if isinstance(el, Inductor)}
    pairs = []
    for kel in couplings:
        names = [str(n).lower() for n in kel.inductors]
        if len(names) != 2 or not math.isfinite(kel.k) or abs(abs(kel.k) - 1.0) > UNITY:
            continue
        la, lb = (inductors.get(n) for n in names)
        if la is None or lb is None or la is lb or any(count[n] != 1 for n in names):
            continue
        if not (la.value > 0 and lb.value > 0):
            continue  # (the formulation reports the value)
        pairs.append((kel, la, lb))
    if not pairs:
        return circuit
    used = {el.key for el in circuit.elements}
    nodes = {n.lower() for el in circuit.elements for n in el.nodes}
    new: dict[str, list[Element]] = {}
    gone: set[str] = set()
    notes = list(circuit.notes)
    for kel, la, lb in pairs:
        n = math.copysign(math.sqrt(lb.value / la.value), kel.k)
        p1, p2 = la.nodes[:2]
        s1, s2 = lb.nodes[:2]
        q = unique_name(f"{la.name.lower()}_q", nodes)
        r = unique_name(f"{lb.name.lower()}_r", nodes)
        vp = unique_name(f"V{la.name}", used)
        vs = unique_name(f"V{lb.name}", used)
        lm = unique_name(f"{la.name}_m", used)
        ic = None
        if la.ic is not None or lb.ic is not None:
            ic = (la.ic or 0.0) + n * (lb.ic or 0.0)
        new[la.key] = [
            VoltageSource(vp, (p1, q), la.location, 0.0),
            Inductor(lm, (q, p2), la.location, value=la.value, ic=ic),
            Cccs(unique_name(f"F{kel.name}", used), (q, p2), kel.location, source=vs,
                 gain=-n)]
        new[lb.key] = [
            Vcvs(unique_name(f"E{kel.name}", used), (s1, r), kel.location, control=(q, p2),
                 gain=n),
            VoltageSource(vs, (r, s2), lb.location, 0.0)]
        gone.add(kel.key)
        notes.append(
            f"{kel.name}: k = {kel.k:g} couples {la.name} and {lb.name} without leakage (one "
            f"flux: their currents cannot both be states), read exactly as an ideal "
            f"transformer of ratio {n:.6g} with {la.name}'s inductance, {lm}, across "
            f"{la.name}'s terminals: probe i({vp}) and i({vs}), the currents ngspice calls "
            f"i({la.name}) and i({lb.name}); i({lm}) is the magnetizing current, i({la.name}) "
            f"+ {n:.6g} i({lb.name})")
    elements: list[Element] = []
    for el in circuit.elements:
        if el.key in new:
            elements.extend(new[el.key])
        elif el.key not in gone:
            elements.append(el)
    return replace(circuit, elements=elements, notes=notes)
