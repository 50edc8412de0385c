"""A resistor whose value switches between two constants on a comparison of the circuit's
voltages or currents: ``R1 a b R = 'v(ctl) > 0.5 ? 100 : 1k'``.

ngspice makes such a resistor a B source ``I = v(a,b)/(expression)`` (``inpcom.c``): its
conductance jumps where the comparison changes. pelcs builds it exactly: the lower value
``R_lo`` from ``a`` to an inner node, and ``R_hi - R_lo`` from there to ``b`` bypassed by an
ideal switch; a comparator B source ``cond ? 1 : 0`` (or ``? 0 : 1``) on that switch's
control is mapped onto it (:func:`netlist.behavioural.resolve_comparators`), so the switch
is on, and the value ``R_lo``, exactly while the comparison gives ``R_lo``. ngspice is given
the line as written (a built group).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

from .behavioural import Comparator, source_name
from .behavioural_expr import BehaviouralError, Step, Tree, circuit_quantity, linearise
from .circuit import GROUND, BuiltGroup, Circuit, Element, Model, Resistor, Switch
from .dialect import node_name
from .rawdeck import RawElement
from .time_value import elaborate_time_resistor
from .units import format_eng, format_number
from .writer import spice_name

__all__ = ["SWITCHED_RESISTOR", "elaborate_resistor", "elaborate_switched_resistor",
           "is_switched_value"]

#: :attr:`netlist.circuit.BuiltGroup.construct` of such a resistor
SWITCHED_RESISTOR = "resistor switched on a comparison"

ACCEPTED = ("pelcs reads a resistor value 'comparison ? R1 : R2' of the circuit's voltages "
            "and currents with constant, positive R1, R2 (e.g. R = 'v(ctl) > 2.5 ? 10 : 1k'), "
            "and a piecewise-constant function of time")


def is_switched_value(tree: Tree) -> bool:
    """Whether an expression is ``comparison ? A : B`` with branches that read nothing of
    the circuit and a comparison that reads it (time excepted: netlist.time_value)."""
    if tree.tag != "?" or any(circuit_quantity(t) is not None for t in tree.args[1:]):
        return False
    found = circuit_quantity(tree.args[0])
    return found is not None and found not in ("time", "temper", "hertz")


def _written(tree: Tree, text: str, mapnode: Callable[[str], str],
             source_name: Callable[[str], str]) -> str:
    """The text of the expression ``tree`` as ngspice is given it: its v() and i() naming the
    flattened nodes and sources of its instance."""
    reads, stack = [], [tree]
    while stack:
        t = stack.pop()
        if t.tag in ("v", "i"):
            reads.append(t)
        stack.extend(x for x in t.args if isinstance(x, Tree))
    out = text[tree.start:tree.end]
    for t in sorted(reads, key=lambda t: -t.start):
        if t.tag == "v":
            nodes = [mapnode(node_name(n)) for n in t.args if n is not None]
            new = f"v({','.join(nodes)})"
        else:
            new = f"i({spice_name(source_name(t.args[0]))})"
        out = out[:t.start - tree.start] + new + out[t.end - tree.start:]
    return out.strip()


def elaborate_resistor(el: RawElement, prefix: str, mapnode: Callable[[str], str],
                       env: Mapping[str, float], circuit: Circuit,
                       error: Callable[..., None]) -> list[Element]:
    """An R line whose value is an expression of the circuit: switched on a comparison
    (here), or stepped in time (:func:`netlist.time_value.elaborate_time_resistor`)."""
    if el.behaviour[0] == "switched":
        return elaborate_switched_resistor(el, prefix, mapnode, env, circuit,
                                           source_name(prefix), error)
    return elaborate_time_resistor(el, prefix, mapnode, env, circuit, error)


def elaborate_switched_resistor(el: RawElement, prefix: str, mapnode: Callable[[str], str],
                                env: Mapping[str, float], circuit: Circuit,
                                source_name: Callable[[str], str],
                                error: Callable[..., None]) -> list[Element]:
    """The elements of such an R line in its instance (module docstring), their switch model
    added to ``circuit.models`` and a note to ``circuit.notes``; nothing after reporting a
    form pelcs does not read with ``error(message, location, hint, elements)``."""
    name = prefix + el.name if prefix else el.name
    _, tree, text, offset = el.behaviour
    a, b = tuple(map(mapnode, el.nodes))
    loc = el.st.loc(0)
    try:
        values = [linearise(t, text, env) for t in tree.args[1:]]
        lo_first = values[0].const <= values[1].const
        one, zero = (Tree("num", (x,), tree.start, tree.start) for x in (1.0, 0.0))
        step = linearise(Tree("?", (tree.args[0], *((one, zero) if lo_first else (zero, one))),
                              tree.start, tree.end), text, env, mapnode, source_name)
    except BehaviouralError as exc:
        error(f"resistor '{name}': {exc.message}", el.st.loc(offset + exc.offset),
              exc.hint or ACCEPTED, (name,))
        return []
    lo, hi = sorted(v.const for v in values)
    if not (lo > 0 and math.isfinite(hi)) or not isinstance(step, Step):
        error(f"resistor '{name}': its value '{text.strip()}' is not a comparison choosing "
              "between two positive resistances", el.st.loc(offset), ACCEPTED, (name,))
        return []
    if lo == hi:
        return [Resistor(name, (a, b), loc, lo)]
    low = name.lower()
    mid, ctl, model = f"{low}#m", f"{low}#c", f"{name}#sw"
    circuit.models[model.lower()] = Model(model, "SW", {"vt": 0.5, "vh": 0.0}, loc)
    out: list[Element] = [
        Resistor(name, (a, mid), loc, lo),
        Resistor(f"{name}#r2", (mid, b), loc, hi - lo),
        Switch(f"{name}#s2", (mid, b), loc, (ctl, GROUND), model)]
    cond = _written(tree.args[0], text, mapnode, source_name)
    line = (f"{spice_name(name)} {a} {b} R='({cond}) ? {format_number(values[0].const)} : "
            f"{format_number(values[1].const)}'")
    circuit.add_built_group(BuiltGroup(name, SWITCHED_RESISTOR, line), out)
    out.append(Comparator(f"{name}#b", (ctl, GROUND), loc, "V", step,
                          f"{text.strip()} (resistor {name})", what="switched resistor"))
    circuit.notes.append(
        f"{name}: resistor value '{text.strip()}' read as {format_eng(lo, 'Ω')} while the "
        f"comparison gives it, {format_eng(hi, 'Ω')} else: {name} = {format_eng(lo, 'Ω')} "
        f"in series with {name}#r2 = {format_eng(hi - lo, 'Ω')}, bypassed by an ideal "
        "switch on the comparison (ngspice's conductance jumps at its first time point past "
        "the crossing)")
    return out
