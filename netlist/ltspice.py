"""LTspice constructs in netlists exported from LTspice schematics.

- ``Rser=``, ``Lser=`` (in series) and ``Rpar=``, ``Cpar=`` (across) on L, C and V lines
  become explicit elements named ``R_<element>_ser``, ``C_<element>_par``... on an internal
  node ``<element>_rser`` / ``_lser``, with a note;
- ``.tran 0 TSTOP ...`` (no print step) takes TMAX (else TSTOP/1000) as TSTEP, with a note
  (:mod:`netlist.flatten`);
- ``.backanno`` is accepted and ignored; ``.lib FILE`` with one argument is LTspice's include,
  and ``.lib standard.*`` (LTspice's own device libraries) is ignored with a note
  (:mod:`netlist.reader`).
"""

from __future__ import annotations

from .rawdeck import RawElement, Statement

__all__ = ["PARASITICS", "explicit_parasitics"]

#: LTspice parasitics accepted on element lines, by element letter
PARASITICS = {"L": ("rser", "rpar", "cpar"), "C": ("rser", "lser", "rpar", "cpar"),
              "V": ("rser", "cpar")}


def explicit_parasitics(elements: list, notes: list, letter: str, name: str, a: str, b: str,
                        found: dict, st: Statement) -> str:
    """Append the parasitics ``found`` (``{key: (Value, token)}``) of element ``name``
    between nodes ``a``, ``b`` to ``elements`` and a note to ``notes``; returns the node the
    element itself now ends at (series parts go between it and ``b``)."""
    if not found:
        return b
    made = []
    end = b
    for key, kind in (("lser", "L"), ("rser", "R")):
        if key in found:
            value, _ = found[key]
            node = f"{name.lower()}_{key}"
            elements.append(RawElement(kind, f"{kind}_{name}_{key[1:]}", st, (node, end),
                                       value=value))
            made.append(f"{kind}_{name}_{key[1:]} ({key.capitalize()}) in series")
            end = node
    for key, kind in (("rpar", "R"), ("cpar", "C")):
        if key in found:
            value, _ = found[key]
            elements.append(RawElement(kind, f"{kind}_{name}_{key[1:]}", st, (a, b),
                                       value=value))
            made.append(f"{kind}_{name}_{key[1:]} ({key.capitalize()}) across")
    notes.append(f"{name}: LTspice parasitics made explicit: " + ", ".join(made))
    return end
