"""The probe syntax shared with ngspice: ``v(NODE)``, ``v(NODE,NODE)``, ``i(ELEMENT)``; the
elements a current is probed through, and a probe's unit.

Read once here for the formulation's output maps (:mod:`netlist.formulation`), the check of a
run's probes (:func:`netlist.studies.transient.check_probes`) and the ngspice runner's vectors
(:mod:`ngspice_checks.runner`).
"""

from __future__ import annotations

import re

__all__ = ["PROBE", "TWO_TERMINAL", "probe_unit"]

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
