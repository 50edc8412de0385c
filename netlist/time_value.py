"""Resistors whose value is a piecewise-constant function of ``time``.

ngspice accepts a resistor value that reads ``time`` (its front end makes the line a B source
``I = v(n+,n-) / (expression)``, inpcom.c), as in its own example ``vdmos/dcdc.sp``::

    R4 out2 OUT R = (time<12ms ? {Rload} : time<20ms ? {Rload/2} : {2*Rload})

pelcs reads such a value when ``time`` appears only in comparisons of an affine function of
``time`` with constants (``<``, ``>``, ``<=``, ``>=``, and ``u()`` of an affine function of
``time``), combined by ``? :``, ``&&``, ``||``, ``!`` and arithmetic with constants,
parameters and ``{...}``: the value is then constant between the instants where a comparison
turns, a :class:`TimeValue`. At most :data:`MAX_INTERVALS` intervals, every value positive.

The resistor becomes elements pelcs simulates exactly (:func:`elaborate_time_resistor`): with
``u_1 < u_2 < ... < u_p`` the distinct values it takes, ``R(t) = u_1 + Σ_j (u_j - u_{j-1})
[R(t) >= u_j]``, so

- the element keeps its name and the least value, ``R4 = u_1`` (``i(R4)`` is the resistor's
  current), in series with one resistor ``R4#r<j>`` of ``u_j - u_{j-1}`` per larger value, on
  inner nodes ``r4#m<j>``;
- each ``R4#r<j>`` is bypassed by an ideal switch ``R4#s<j>`` (model ``R4#sw``, ``VT = 0``),
  on while ``R(t) < u_j``, driven by a PWL voltage source ``R4#v<j>`` (node ``r4#c<j>``) that
  is ±1 V between the instants and passes through 0 V exactly at the instants where that
  switch turns (a breakpoint of the source: ngspice's switch rule turns it there,
  ``docs/switching.md``).

The switches are driven by sources alone, so the run computes their instants before stepping
and steps to each of them. At an instant several switches may turn at once; a bypassed
segment is never an open circuit, so the order cannot break the resistor's path. The elements
are a group built for the R line (:class:`~netlist.circuit.BuiltGroup`, construct
:data:`~netlist.circuit.TIME_STEPPED_RESISTOR`; each carries the resistor's name in
``built_for``): ``--devices pwl`` leaves the switches ideal, losses give them none and count
the segments' power as the resistor's, and the writer writes the resistor back as its
expression (:func:`time_resistor_line`).

ngspice evaluates the expression at its own time points and puts no breakpoint at the
instants: the new value holds from its first time point past the instant, over the whole
step that ends there, so the change lands inside the step that straddles it (measured in
ngspice 39 on an RC, 1 kΩ to 2 kΩ at 1 ms, 1 µF: the response after it is that of a change
at 1.0046 ms with its 10 µs steps (time points 0.9996 and 1.0096 ms, trapezoidal), at
1.05 ms (trapezoidal) or 1.10 ms (Gear) with ``TMAX = 200 µs`` (time points 0.937 and
1.137 ms), at 1.0005 ms with ``TMAX = 1 µs``). pelcs changes the value at the instant itself,
ngspice's limit as its step shrinks.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import replace

from lcs.signals import Pwl

from .behavioural_expr import Affine, BehaviouralError, Step, Tree, linearise
from .circuit import (
    GROUND,
    TIME_STEPPED_RESISTOR,
    BuiltGroup,
    Circuit,
    Element,
    Model,
    Resistor,
    Switch,
    VoltageSource,
)
from .rawdeck import RawElement
from .time_function import TimeValue
from .units import format_eng
from .writer import spice_name

__all__ = ["ACCEPTED", "MAX_INTERVALS", "NotAffineInTime", "TimeValue", "elaborate_time_resistor",
           "frozen_at", "internal_nodes", "other_quantity", "reads_time_only",
           "time_in_comparisons", "time_resistor_line", "time_resistor_nodes",
           "time_resistor_part", "time_resistor_segments", "time_value"]

#: the most intervals of constant value pelcs expands a resistor into
MAX_INTERVALS = 8

#: the form pelcs reads, for the hints of its refusals
ACCEPTED = ("pelcs reads a resistor value that is a piecewise-constant function of time: "
            "comparisons of an affine function of time with constants (<, >, <=, >=, u()), "
            "combined by ? :, &&, ||, ! and arithmetic with constants, parameters and {...}, "
            f"at most {MAX_INTERVALS} intervals, every value positive, e.g. "
            "R = 'time < 12ms ? {Rload} : {2*Rload}'")

_COMPARISONS = ("<", ">", "<=", ">=", "==", "!=")
_TIME = "#time"  # the pseudo node that stands for time in a comparison's affine form


def _has_time(tree: Tree) -> bool:
    return any(t.tag == "var" and t.args[0] == "time" for t in tree.walk())


def other_quantity(tree: Tree) -> str | None:
    """The first circuit quantity other than ``time`` an expression reads (``v(a,b)``,
    ``i(V1)``, ``temper``, ``hertz``), as written, or None."""
    for t in sorted(tree.walk(), key=lambda t: t.start):
        if t.tag == "v":
            return f"v({t.args[0]})" if t.args[1] is None else f"v({t.args[0]},{t.args[1]})"
        if t.tag == "i":
            return f"i({t.args[0]})"
        if t.tag == "var" and t.args[0] in ("temper", "hertz"):
            return t.args[0]
    return None


def reads_time_only(tree: Tree) -> bool:
    """Whether an expression reads ``time`` and no other circuit quantity (``v()``, ``i()``,
    ``temper``, ``hertz``)."""
    return other_quantity(tree) is None and _has_time(tree)


def _is_comparison(t: Tree) -> bool:
    """A comparison, or ``u()`` (the unit step of its argument)."""
    return t.tag in _COMPARISONS or (t.tag == "call" and t.args[0] == "u" and len(t.args) == 2)


def time_in_comparisons(tree: Tree) -> bool:
    """Whether every ``time`` an expression reads stands inside a comparison (or ``u()``):
    the shape of a piecewise-constant function of time (the comparisons' own form is checked
    with the parameters' values, :func:`time_value`)."""
    stack = [tree]
    while stack:
        t = stack.pop()
        if _is_comparison(t):
            continue
        if t.tag == "var" and t.args[0] == "time":
            return False
        stack.extend(a for a in t.args if isinstance(a, Tree))
    return True


def _with_time_node(tree: Tree) -> Tree:
    """``tree`` with ``time`` read as the voltage of a pseudo node (so that the comparison's
    affine form in it comes from :func:`netlist.behavioural_expr.linearise`)."""
    if tree.tag == "var" and tree.args[0] == "time":
        return Tree("v", (_TIME, None), tree.start, tree.end)
    args = tuple(_with_time_node(a) if isinstance(a, Tree) else a for a in tree.args)
    return Tree(tree.tag, args, tree.start, tree.end)


class NotAffineInTime(BehaviouralError):
    """A comparison of time that is not of an affine function of time with constants, or an
    equality of time: no :class:`TimeValue`, though :mod:`netlist.time_expression` reads it
    in a B source (``time == 0``, true at the operating point, as in ngspice)."""


def _threshold(cmp: Tree, text: str, env: Mapping[str, float]) -> float | None:
    """The instant where a comparison of time (or ``u()`` of an affine function of time)
    turns, None if it does not depend on time after all (``time - time < 1``)."""
    part = text[cmp.start:cmp.end].strip()
    if cmp.tag in ("==", "!="):
        raise NotAffineInTime(f"'{part}' is an equality of time: true for an instant only",
                              cmp.start, ACCEPTED)
    try:
        form = linearise(_with_time_node(cmp), text, env, lambda n: n, lambda s: s)
    except BehaviouralError as exc:
        if exc.message.startswith(("unknown parameter", "division by zero")):
            raise
        raise NotAffineInTime(f"'{part}' does not compare an affine function of time with "
                              "constants", cmp.start, ACCEPTED) from None
    if isinstance(form, Affine):
        return None
    if not isinstance(form, Step) or {q for q, _ in form.diff.terms} != {("v", _TIME)}:
        raise NotAffineInTime(f"'{part}' does not compare an affine function of time with "
                              "constants", cmp.start, ACCEPTED)
    (_, slope), = form.diff.terms
    return -form.diff.const / slope


def _instants(tree: Tree, text: str, env: Mapping[str, float]) -> set[float]:
    """The instants where the comparisons of time in ``tree`` turn; a refusal of ``time``
    anywhere else."""
    found: set[float] = set()
    stack = [tree]
    while stack:
        t = stack.pop()
        if _is_comparison(t) and _has_time(t):
            if t.tag == "call":  # u(x): x > 0 (u(0) = 0.5 lasts an instant)
                t = Tree(">", (t.args[1], Tree("num", (0.0,), t.start, t.start)), t.start,
                         t.end)
            at = _threshold(t, text, env)
            if at is not None:
                found.add(at)
            continue
        if t.tag == "var" and t.args[0] == "time":
            raise BehaviouralError("'time' outside a comparison: a value that varies "
                                   "continuously with time", t.start, ACCEPTED)
        stack.extend(a for a in t.args if isinstance(a, Tree))
    return found


def _value(tree: Tree, text: str, env: Mapping[str, float], t: float) -> float:
    """The expression's value at time ``t`` (s)."""
    form = linearise(tree, text, {**env, "time": t})
    if not (isinstance(form, Affine) and form.constant):  # (time read as a number)
        raise BehaviouralError(f"'{text.strip()}' has no value at t = {t:g} s", 0, ACCEPTED)
    return form.const


def time_value(tree: Tree, text: str, env: Mapping[str, float]) -> TimeValue:
    """The piecewise-constant function of time that an expression is.

    Parameters
    ----------
    tree, text : Tree, str
        From :func:`netlist.behavioural_expr.parse_behavioural`, and its text.
    env : mapping of str to float
        Parameter values (lower-case names).

    Returns
    -------
    TimeValue
        Its value on each interval between the instants (s) where it changes, for t > 0
        (comparisons that turn at t <= 0 are constant over a run).

    Raises
    ------
    BehaviouralError
        ``time`` outside a comparison, a comparison that is not of an affine function of
        time with constants, an unknown parameter, with its offset in ``text``.
    """
    instants: list[float] = []
    for x in sorted(x for x in _instants(tree, text, env) if x > 0 and math.isfinite(x)):
        if instants and x - instants[-1] <= 1e-12 * x:
            continue  # (one instant written two ways, apart by round-off: 0.3 and 0.1*3)
        instants.append(x)
    # the value between the instants, read at the middle of each interval (the last: past it
    # by as much again)
    ends = [0.0, *instants, 2.0 * instants[-1] if instants else 1.0]
    values = [_value(tree, text, env, 0.5 * (a + b)) for a, b in zip(ends, ends[1:],
                                                                       strict=False)]
    times: list[float] = []
    kept = [values[0]]
    for at, v in zip(instants, values[1:], strict=True):
        if v != kept[-1]:  # (an instant where no comparison changes the value)
            times.append(at)
            kept.append(v)
    return TimeValue(tuple(times), tuple(kept))


# ------------------------------------------------------------------------------ elements


def time_resistor_nodes(circuit: Circuit, el: Resistor) -> tuple[str, str]:
    """The two nodes of the resistor stepped in time that ``el`` (the element that keeps its
    name, :func:`elaborate_time_resistor`) stands for: its first node and the far end of its
    last segment."""
    segments = time_resistor_segments(circuit, el)
    return el.nodes[0], (segments[-1].nodes[1] if segments else el.nodes[1])


def time_resistor_segments(circuit: Circuit, el: Resistor) -> list[Resistor]:
    """The series segments ``<name>#r<j>`` of the resistor stepped in time that ``el`` (the
    element that keeps its name) stands for, in order."""
    return [p for p in circuit.elements if isinstance(p, Resistor) and p.time_value is None
            and p.built_for and p.built_for == el.built_for]


def time_resistor_line(name: str, nodes: tuple[str, str], tv: TimeValue) -> str:
    """The R line ngspice is given for a resistor stepped in time: its value as an
    expression of ``time`` (:meth:`TimeValue.expression`) between its two nodes."""
    return f"{spice_name(name, 'R')} {nodes[0]} {nodes[1]} R = '{tv.expression()}'"


def _control(tv: TimeValue, on: list[bool]) -> tuple[float, Pwl]:
    """The DC value and PWL of a bypass switch's control: +1 V on the intervals where it is
    on (``on[k]``), -1 V where it is off, through 0 V exactly at the instants where it turns
    (linear in between)."""
    times, values = [0.0], [1.0 if on[0] else -1.0]
    ends = [*tv.times, 2.0 * tv.times[-1]]
    for k, at in enumerate(tv.times):
        level = 1.0 if on[k + 1] else -1.0
        times += [at, 0.5 * (at + ends[k + 1])]
        values += [0.0 if on[k + 1] != on[k] else level, level]
    return values[0], Pwl(tuple(times), tuple(values))


def internal_nodes(circuit: Circuit) -> set[str]:
    """The nodes pelcs adds for its resistors stepped in time (their segments' and controls'
    nodes): not in the netlist ngspice runs (:meth:`TimeValue.expression` is written)."""
    ends: set[str] = {GROUND}
    inner: set[str] = set()
    for el in circuit.elements:
        if isinstance(el, Resistor) and el.time_value is not None:
            ends.update(time_resistor_nodes(circuit, el))
            inner.add(el.nodes[1])
        elif time_resistor_part(circuit, el):
            inner.update(el.nodes)
            inner.update(getattr(el, "control", ()))
    return inner - ends


def time_resistor_part(circuit: Circuit, el: Element) -> bool:
    """Whether ``el`` is one of the elements that stand for a resistor stepped in time."""
    group = circuit.built_group(el)
    return group is not None and group.construct == TIME_STEPPED_RESISTOR


def elaborate_time_resistor(el: RawElement, prefix: str, mapnode: Callable[[str], str],
                            env: Mapping[str, float], circuit: Circuit,
                            error: Callable[..., None]) -> list[Element]:
    """The elements of an R line whose value is a piecewise-constant function of time (the
    module docstring), with their switch model added to ``circuit.models`` and a note to
    ``circuit.notes``; nothing after reporting a form pelcs does not read with
    ``error(message, location, hint, elements)``."""
    name = prefix + el.name if prefix else el.name
    _, tree, text, offset = el.behaviour
    a, b = nodes = tuple(map(mapnode, el.nodes))
    loc = el.st.loc(0)
    try:
        tv = time_value(tree, text, env)
    except BehaviouralError as exc:
        error(f"resistor '{name}': {exc.message}", el.st.loc(offset + exc.offset),
              exc.hint or ACCEPTED, (name,))
        return []
    where = el.st.loc(offset)
    if len(tv.values) > MAX_INTERVALS:
        error(f"resistor '{name}': its value '{text.strip()}' changes {len(tv.times)} times "
              f"over t > 0 ({len(tv.values)} intervals): more than pelcs expands (each "
              "interval is a switched branch)", where, ACCEPTED, (name,))
        return []
    bad = [k for k, v in enumerate(tv.values) if not (v > 0 and math.isfinite(v))]
    if bad:
        k = bad[0]
        since = "from t = 0" if k == 0 else f"from {format_eng(tv.times[k - 1], 's')}"
        until = f" to {format_eng(tv.times[k], 's')}" if k < len(tv.times) else " on"
        error(f"resistor '{name}': its value '{text.strip()}' is "
              f"{format_eng(tv.values[k], 'Ω')} {since}"
              f"{until}: a resistance must be positive", where, ACCEPTED, (name,))
        return []
    levels = sorted(set(tv.values))
    if len(levels) == 1:
        circuit.notes.append(f"{name}: resistor value '{text.strip()}' is "
                             f"{format_eng(levels[0], 'Ω')} "
                             "at every t > 0 (its comparisons of time turn at t <= 0): a "
                             "constant resistor")
        return [Resistor(name, nodes, loc, levels[0])]
    low = name.lower()
    model = f"{name}#sw"
    circuit.models[model.lower()] = Model(model, "SW", {"vt": 0.0, "vh": 0.0}, loc)
    inner = [f"{low}#m{j}" for j in range(1, len(levels))] + [b]
    out: list[Element] = [Resistor(name, (a, inner[0]), loc, levels[0], time_value=tv)]
    parts = []
    for j in range(1, len(levels)):
        seg = (inner[j - 1], inner[j])
        ctl = f"{low}#c{j + 1}"
        on = [v < levels[j] for v in tv.values]
        dc, wave = _control(tv, on)
        out += [Resistor(f"{name}#r{j + 1}", seg, loc, levels[j] - levels[j - 1]),
                Switch(f"{name}#s{j + 1}", seg, loc, (ctl, GROUND), model),
                VoltageSource(f"{name}#v{j + 1}", (ctl, GROUND), loc, dc, wave)]
        parts.append(f"{name}#r{j + 1} = {format_eng(levels[j] - levels[j - 1], 'Ω')}")
    circuit.add_built_group(
        BuiltGroup(name, TIME_STEPPED_RESISTOR, time_resistor_line(name, nodes, tv)), out)
    circuit.notes.append(
        f"{name}: resistor value '{text.strip()}' read as a piecewise-constant function of "
        f"time: {tv.describe('Ω')}; pelcs changes it at exactly those instants ({name} = "
        f"{format_eng(levels[0], 'Ω')} in series with {', '.join(parts)}, "
        f"{'each ' if len(parts) > 1 else ''}bypassed by an ideal switch that a PWL source "
        "turns at the instants). ngspice evaluates the expression at its own time points, "
        "with no breakpoint at the instants: its new value holds from its first time point "
        "past an instant, over the whole step that ends there, so the change lands inside "
        "that step, not at the instant; the two agree as ngspice's step there shrinks "
        "(TMAX)")
    return out


def frozen_at(circuit: Circuit, t0: float) -> tuple[Circuit, list[str]]:
    """The circuit with each resistor stepped in time made the constant resistor of its value
    at ``t0`` (s), and a note per resistor; ``circuit`` itself when it has none.

    A periodic steady state (a stroboscopic map's orbit, the small-signal response around
    it) has one value of every resistor: the map over a period from ``t0`` sees the value
    at ``t0`` (the others would make the map depend on the period's index).
    """
    stepped = [el for el in circuit.elements
               if isinstance(el, Resistor) and el.time_value is not None]
    if not stepped:
        return circuit, []
    notes = []
    parts = {el.name for el in stepped}
    elements: list[Element] = []
    for el in circuit.elements:
        if el.built_for in parts and el not in stepped:
            continue
        if el in stepped:
            value = el.time_value.at(t0)
            elements.append(Resistor(el.name, time_resistor_nodes(circuit, el), el.location,
                                     value))
            notes.append(f"{el.name} is stepped in time ({el.time_value.describe('Ω')}): a "
                         f"periodic steady state has one value, {el.name} = "
                         f"{format_eng(value, 'Ω')} here (its value at t0 = "
                         f"{format_eng(t0, 's')}, where the map's periods start)")
            continue
        elements.append(el)
    # (the note of reading the resistor describes the steps this circuit no longer has)
    kept = [n for n in circuit.notes if not any(
        isinstance(n, str) and n.startswith(f"{name}: resistor value") for name in parts)]
    # (the constant resistors are the netlist's own now, written as such)
    groups = {k: g for k, g in circuit.built_groups.items() if g.name not in parts}
    return replace(circuit, elements=elements, notes=kept, built_groups=groups), notes
