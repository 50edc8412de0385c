"""Transistors idealised as switches (issue #11): what an M or Q element becomes, and the
report of every replacement.

A MOSFET (``M``, models NMOS/PMOS/VDMOS) becomes an ideal switch between drain and source,
on while its gate–source voltage is past the threshold: ``VTO`` of its model (ngspice's
default 0 V when the model has none; for a P-channel device the switch is on while
``v(source, gate) > -VTO``). A VDMOS model has a body diode in ngspice; pelcs keeps it as an
ideal diode from source to drain (drain to source for P-channel). A BJT (``Q``, NPN/PNP)
becomes a switch between collector and emitter, on while ``v(base, emitter)`` (``v(emitter,
base)`` for PNP) exceeds :data:`BJT_THRESHOLD`. A threshold given by the user (``--threshold
NAME=V``, per element or per model) overrides both. Gate and junction capacitances, on
resistances and the bulk/substrate terminal are dropped: the report says so.

ngspice still runs the device with its real model (the writer writes the original line).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["BJT_THRESHOLD", "DEVICE_TYPES", "Replacement", "threshold"]

#: base–emitter voltage at which an idealised BJT switch turns on, V
BJT_THRESHOLD = 0.7

#: model types idealised as switches, and the device each is
DEVICE_TYPES = {"NMOS": "MOSFET", "PMOS": "MOSFET", "VDMOS": "MOSFET", "NPN": "BJT",
                "PNP": "BJT"}


@dataclass(frozen=True)
class Replacement:
    """What an idealised device became.

    Attributes
    ----------
    element : str
        The device's (hierarchical) name, e.g. ``"M1"`` or ``"X1.M1"``.
    model, device : str
        Its model name and type (``"NMOS"``, ``"VDMOS"``, ``"NPN"``...).
    became : str
        One line: the switch, its terminals and its control.
    threshold : float
        Switch threshold, V, and where it came from (``source``: ``"VTO"``, ``"default"``,
        ``"--threshold"``).
    source : str
    body_diode : str or None
        The name of the ideal body diode, if one was kept.
    dropped : tuple of str
        What of the device pelcs does not simulate.
    """

    element: str
    model: str
    device: str
    became: str
    threshold: float
    source: str
    body_diode: str | None
    dropped: tuple[str, ...]

    def line(self) -> str:
        body = f", body diode {self.body_diode}" if self.body_diode else ", no body diode"
        return (f"{self.element} ({self.device} {self.model}) -> {self.became}, threshold "
                f"{self.threshold:g} V ({self.source}){body}; dropped: "
                f"{', '.join(self.dropped)}")


def threshold(name: str, model: str, mtype: str, params: Mapping[str, float],
              overrides: Mapping[str, float]) -> tuple[float, str]:
    """The switch threshold of a device, V (as a positive control voltage), and its source.

    ``overrides`` (case-insensitive keys) name an element or a model.
    """
    low = {k.lower(): v for k, v in overrides.items()}
    for key in (name.lower(), name.split(".")[-1].lower(), model.lower()):
        if key in low:
            return float(low[key]), "--threshold"
    if mtype in ("NPN", "PNP"):
        return BJT_THRESHOLD, "default for a BJT"
    vto = params.get("vto", params.get("vth"))
    if vto is None:
        return 0.0, "ngspice's default VTO = 0"
    vto = float(vto)
    return (-vto if mtype == "PMOS" or (mtype == "VDMOS" and params.get("pchan")) else vto,
            "VTO of the model")
