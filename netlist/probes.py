"""The probe syntax shared with ngspice: ``v(NODE)``, ``v(NODE,NODE)``, ``i(ELEMENT)``; the
elements a current is probed through, and a probe's unit.

Read once here for the formulation's output maps (:mod:`netlist.formulation`), the check of a
run's probes (:func:`netlist.studies.transient.check_probes`) and the ngspice runner's vectors
(:mod:`ngspice_checks.runner`).
"""

from __future__ import annotations

import re

from .circuit import GROUND
from .errors import Diagnostic

__all__ = ["PROBE", "TWO_TERMINAL", "probe_unit", "shadowed_probe", "voltage_probe"]

#: ``v(a)``, ``v(a,b)`` or ``i(X)``, blanks allowed, any case: groups (``v`` or ``i``, the
#: first name, the second node or None).
PROBE = re.compile(r"^\s*([vi])\s*\(\s*([^,()\s]+)\s*(?:,\s*([^,()\s]+)\s*)?\)\s*$", re.I)

#: Element kinds with two terminals, whose current ``i(X)`` (from n+ through X to n-) is a
#: probe.
TWO_TERMINAL = frozenset("RLCVIDSEFGH")


def probe_unit(name: str) -> str:
    """SI unit of a probe: ``"V"`` for ``v(...)``, ``"A"`` for ``i(...)``, else ``""``."""
    head = name.strip()[:2].lower()
    return {"v(": "V", "i(": "A"}.get(head, "")


def voltage_probe(a: str, b: str) -> str:
    """The probe of the voltage from node ``a`` to node ``b``: ``v(a)``, or ``v(a,b)`` where
    ``b`` is not ground."""
    return f"v({a})" if b == GROUND else f"v({a},{b})"


def shadowed_probe(probe: str, capacitor) -> Diagnostic:
    """The error of a probe spelled as a capacitor's state, ``v(C1)``, beside a node ``c1``:
    ngspice reads the node (its names ignore case), pelcs's state is the capacitor's."""
    across = voltage_probe(*capacitor.nodes[:2])
    node = capacitor.name.lower()
    # (any other spelling of the node's name reads the node)
    spelled = f"v({node})" if node != capacitor.name else f"V({node})"
    return Diagnostic(
        message=f"probe {probe.strip()!r} is ambiguous: ngspice reads it as the node {node}, "
                f"and it is also the state of capacitor {capacitor.name}",
        hint=f"write {spelled} for the node's voltage or {across} for {capacitor.name}'s")
