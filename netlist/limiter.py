"""A clamp ``max(lo, min(hi, e))`` of an affine ``e`` as an exact ideal-diode limiter.

Where :func:`netlist.behavioural.fold_clamps` cannot fold a clamping B source into what reads
its output (a capacitor, a resistor, another B source, the gate network of a device), pelcs
builds the clamp from elements it simulates exactly::

    e: E/H chain -> <B>#e --R-- <B>#c --> E (gain 1) or G (1 S): the B's output
                                 |
                  <B>#lo diode: lo -> c      <B>#hi diode: c -> hi

The diodes are ideal (complementarity pairs) whatever ``--devices`` says: nothing loads the
inner node ``c`` but the buffer, so while ``lo < e < hi`` no current flows in ``R`` and
``v(c) = e``; beyond a bound its diode conducts ``(e - hi)/R`` (or ``(lo - e)/R``) and holds
``c`` at the bound. ``v(c)`` is therefore ``clamp(e)`` at every instant, in every mode, and
``R``'s value changes nothing but the size of the diodes' currents (1 Ω: amperes per volt of
overshoot). A missing bound (``min`` or ``max`` alone) has no diode.

The elements are a group built for the B line (:class:`netlist.circuit.BuiltGroup`, construct
:data:`~netlist.circuit.LIMITER`): for ngspice (:func:`netlist.writer.write_circuit`) they are
written back as the one B source they stand for.
"""

from __future__ import annotations

import math

from .behavioural_expr import Clamp
from .circuit import (
    GROUND,
    LIMITER,
    BuiltGroup,
    Circuit,
    Diode,
    Element,
    Resistor,
    Vccs,
    Vcvs,
    VoltageSource,
)
from .errors import Location
from .writer import spice_name

__all__ = ["LIMITER_OHMS", "limiter_elements"]

#: the limiter's inner resistor, Ω (any positive value gives the same node voltages)
LIMITER_OHMS = 1.0


def _rail(name: str, value: float, loc: Location | None) -> tuple[str, list[Element]]:
    """The node at ``value`` volts: ground for 0, else a DC source's node."""
    if value == 0.0:
        return GROUND, []
    node = name.lower()
    return node, [VoltageSource(f"{name}#v", (node, GROUND), loc, value)]


def _number(x: float) -> str:
    return repr(float(x))


def limiter_elements(circuit: Circuit, name: str, kind_out: str, nodes: tuple[str, str],
                     clamp: Clamp, loc: Location | None,
                     chain: list[Element]) -> list[Element]:
    """The elements of the limiter of a clamping B source (module docstring).

    Parameters
    ----------
    circuit : Circuit
        Receives the elements' group, with the B line that ngspice is given in their place.
    name : str
        The B source's name: the output buffer keeps it (``i(B1)`` of a ``V=`` source is
        its current), the others are ``<name>#...``.
    kind_out : str
        ``"V"`` or ``"I"``.
    nodes : tuple of str
        The B source's output nodes.
    clamp : Clamp
        The bounds (V; ``-inf``/``inf`` for a missing one, ``lo < hi``) and the affine form.
    loc : Location
        The B line's location.
    chain : list of Element
        The E/H/V chain that sets ``<name>#e`` to the affine form
        (:func:`netlist.behavioural.linear_elements` with output ``(<name>#e, 0)``).
    """
    key = name.lower()
    e_node, c_node = f"{key}#e", f"{key}#c"
    out: list[Element] = list(chain)
    out.append(Resistor(f"{name}#r", (e_node, c_node), loc, LIMITER_OHMS))
    if math.isfinite(clamp.lo):
        node, rail = _rail(f"{name}#lo", clamp.lo, loc)
        out.extend(rail)
        out.append(Diode(f"{name}#dlo", (node, c_node), loc, ideal=True))
    if math.isfinite(clamp.hi):
        node, rail = _rail(f"{name}#hi", clamp.hi, loc)
        out.extend(rail)
        out.append(Diode(f"{name}#dhi", (c_node, node), loc, ideal=True))
    buffer = (Vcvs if kind_out == "V" else Vccs)(name, tuple(nodes), loc, (c_node, GROUND), 1.0)
    out.append(buffer)
    # ngspice is given the B source itself
    terms = [f"{_number(c)}*" + (f"v({q[1]})" if q[0] == "v" else f"i({spice_name(q[1])})")
             for q, c in clamp.form.terms]
    value = " + ".join(terms + [_number(clamp.form.const)])
    if math.isfinite(clamp.hi):
        value = f"min({_number(clamp.hi)}, {value})"
    if math.isfinite(clamp.lo):
        value = f"max({_number(clamp.lo)}, {value})"
    line = f"{spice_name(name, 'B')} {nodes[0]} {nodes[1]} {kind_out} = {value}"
    circuit.add_built_group(BuiltGroup(name, LIMITER, line), out)
    return out
