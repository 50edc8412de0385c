"""ngspice's current-controlled switch, ``Wname n+ n- Vcontrol model [ON|OFF]`` with a
``.model name CSW(IT= IH= RON= ROFF=)``, as an ideal switch driven by a voltage.

ngspice's CSW is its voltage-controlled SW with the current of ``Vcontrol`` in place of the
control voltage (``cswload.c`` mirrors ``swload.c``: on above ``IT + IH``, off below
``IT - IH``, its state kept in between). So pelcs reads ``W1`` as an H source
``W1#i`` of 1 Ohm on an inner node ``w1#i`` (``v = i(Vcontrol)``, the current flowing into
``Vcontrol``'s first node, as ngspice counts it) and an S switch ``W1`` that this voltage
drives, with a SW model of ``VT = IT``, ``VH = IH`` and the same ``RON``, ``ROFF``.
"""

from __future__ import annotations

import re
from collections.abc import Callable

from .circuit import GROUND, Ccvs, Circuit, Element, Model, Switch

__all__ = ["CswError", "elaborate", "read_line"]

_LINE = re.compile(r"(?is)(\S+)\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)(?:\s+(on|off))?\s*$")
USAGE = "Wname n+ n- Vcontrol model [ON|OFF]"
# ngspice's CSW defaults (cswmpar.c, cswsetup.c: ROFF is 1/gmin)
_DEFAULTS = {"it": 0.0, "ih": 0.0, "ron": 1.0, "roff": 1e12}


class CswError(Exception):
    """A malformed W line: message, offset in the statement, hint."""

    def __init__(self, message: str, offset: int, hint: str = ""):
        super().__init__(message)
        self.message, self.offset, self.hint = message, offset, hint


def read_line(text: str) -> tuple[str, tuple[str, str], tuple[str, int], tuple[str, int],
                                   bool | None]:
    """``(name, (n+, n-), (Vcontrol, offset), (model, offset), ON/OFF or None)``.

    Raises
    ------
    CswError
        Not ``Wname n+ n- Vcontrol model [ON|OFF]``.
    """
    m = _LINE.match(text)
    if m is None:
        words = text.split()
        at = text.find(words[-1]) if len(words) > 5 else len(text)
        raise CswError(f"current-controlled switch '{words[0]}' needs two nodes, a "
                       "controlling voltage source and a CSW model", at, f"syntax: {USAGE}")
    state = None if m.group(6) is None else m.group(6).lower() == "on"
    return (m.group(1), (m.group(2), m.group(3)), (m.group(4), m.start(4)),
            (m.group(5), m.start(5)), state)


def elaborate(name: str, nodes: tuple[str, str], aux: str, vcontrol: str, model_key: str,
              state: bool | None, loc, circuit: Circuit,
              error: Callable[[str, str], None]) -> list[Element]:
    """The H source and the switch that a W element is (module docstring), its SW model added
    to ``circuit.models``; ``[]`` after ``error(message, hint)`` when the model is not CSW.

    Parameters
    ----------
    name : str
        The W element's (hierarchical) name.
    nodes, aux : the switch's nodes, and the inner node of the sensing H source.
    vcontrol : str
        The controlling voltage source's (hierarchical) name.
    model_key : str
        The CSW model's key in ``circuit.models``.
    """
    model = circuit.models.get(model_key.lower())
    if model is None or model.type != "CSW":
        what = "unknown model" if model is None else f"a {model.type} model, not CSW"
        error(f"{name}: {what} '{model_key}'",
              f"define it with .model {model_key} CSW(IT=... IH=... RON=... ROFF=...)")
        return []
    p = {**_DEFAULTS, **{k.lower(): float(v) for k, v in model.params.items()}}
    sw = f"pelcs_csw_{name.lower().replace('.', '_')}"
    circuit.models[sw] = Model(sw, "SW", {"vt": p["it"], "vh": p["ih"], "ron": p["ron"],
                                          "roff": p["roff"]}, loc)
    return [Ccvs(f"{name}#i", (aux, GROUND), loc, vcontrol, 1.0),
            Switch(name, nodes, loc, (aux, GROUND), sw, state)]
