"""ngspice's B sources (``Bname n+ n- V=expr`` or ``I=expr``) as ideal linear elements.

An ngspice B source computes its value from an arbitrary expression of node voltages
``v(a)``, ``v(a,b)``, source currents ``i(Vx)``, ``time`` and parameters. pelcs simulates
linear complementarity systems, so it reads the two forms that have an exact ideal
equivalent, and refuses the others with the expression's place and the accepted forms:

- **linear**: the expression is affine in ``v()`` and ``i()`` (constants, ``.param`` values
  and ``{...}`` allowed). A ``V=`` source becomes a series chain of E (voltage terms) and H
  (current terms) sources and, for a constant term, a DC source; an ``I=`` source the same
  terms in parallel as G, F and a DC current source. The first element keeps the B's name,
  so that ``i(Bname)`` of a ``V=`` source is still its current. A gyrator ``V=-N*i(Vs)``
  becomes one H source.
- **comparator**: ``cond ? A : B``, ``u(x)`` or ``A*(x > y)`` (and sums and constant
  multiples of these) where ``cond`` compares two affine expressions (``>``, ``<``, ``>=``,
  ``<=``, ``!``) and the values ``A``, ``B`` are constants. Its output switches between two
  constants, so the S switches it controls are on exactly while the comparison is true (or
  false, depending on the values and the switch's ``VT``/``VH``): :func:`resolve_comparators`
  gives those switches the comparison itself as their control and removes the B source.
  Whether the run then computes the switching instants from the sources before stepping or
  locates them as comparator crossings follows from that control, as for any S switch
  (``docs/switching.md``).

The expressions themselves (grammar, linear and comparator forms) are
:mod:`netlist.behavioural_expr`.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import ClassVar

from .behavioural_expr import ACCEPTED, Affine, BehaviouralError, Step, linearise
from .circuit import (
    GROUND,
    Cccs,
    Ccvs,
    Circuit,
    CurrentSource,
    Element,
    Model,
    Switch,
    Vccs,
    Vcvs,
    VoltageSource,
)
from .dialect import hierarchical_name
from .errors import Diagnostic, Location
from .knee import elaborate_knee
from .rawdeck import RawElement

__all__ = ["Comparator", "elaborate", "linear_elements", "resolve_comparators"]


# ------------------------------------------------------------------------------ elements


@dataclass
class Comparator(Element):
    """A B source whose value switches between two constants (before
    :func:`resolve_comparators` maps it onto the switches it drives; never formulated).
    ``kind_out`` is ``"V"`` or ``"I"``; ``step`` the comparison and the two values; ``text``
    the expression as written."""

    kind_out: str = "V"
    step: Step | None = None
    text: str = ""
    what: str = "comparator B source"  # what it is, for messages
    kind: ClassVar[str] = "B"


def _pairs(terms: tuple) -> list[tuple[str, tuple, float]]:
    """The terms of an affine form as controlled-source pieces: ``("v", (a, b), gain)`` for a
    voltage (two opposite node terms make one pair) and ``("i", source, gain)``."""
    volts = [(q[1], c) for q, c in terms if q[0] == "v"]
    out: list[tuple[str, tuple, float]] = []
    if len(volts) == 2 and volts[0][1] == -volts[1][1]:
        out.append(("v", (volts[0][0], volts[1][0]), volts[0][1]))
    else:
        out.extend(("v", (n, GROUND), c) for n, c in volts)
    out.extend(("i", q[1], c) for q, c in terms if q[0] == "i")
    return out


def linear_elements(name: str, kind_out: str, nodes: tuple[str, str], form: Affine,
                    loc: Location | None) -> list[Element]:
    """The E/H/V chain (``V=``) or the G/F/I parallel set (``I=``) equal to a linear B.

    The first element is named ``name``; the others ``name#2``, ``name#3``... and the chain's
    inner nodes ``name#n1``, ``name#n2``... (lower case).
    """
    pieces = _pairs(form.terms)
    p, n = nodes
    names = [name] + [f"{name}#{k}" for k in range(2, len(pieces) + 2)]
    out: list[Element] = []
    if kind_out == "V":
        count = len(pieces) + (1 if form.const != 0 or not pieces else 0)
        ends = [p] + [f"{name.lower()}#n{k}" for k in range(1, count)] + [n]
        for k, (what, ref, gain) in enumerate(pieces):
            a, b = ends[k], ends[k + 1]
            if what == "v":
                out.append(Vcvs(names[k], (a, b), loc, ref, gain))
            else:
                out.append(Ccvs(names[k], (a, b), loc, ref, gain))
        if len(out) < count:
            out.append(VoltageSource(names[len(out)], (ends[-2], n), loc, form.const))
        return out
    for k, (what, ref, gain) in enumerate(pieces):
        if what == "v":
            out.append(Vccs(names[k], (p, n), loc, ref, gain))
        else:
            out.append(Cccs(names[k], (p, n), loc, ref, gain))
    if form.const != 0 or not pieces:
        out.append(CurrentSource(names[len(out)], (p, n), loc, form.const))
    return out


def source_name(prefix: str) -> Callable[[str], str]:
    """``i(Vx)`` inside a subcircuit instance names the instance's ``Vx``."""
    return lambda s: prefix + hierarchical_name(s)


def elaborate(el: RawElement, prefix: str, mapnode: Callable[[str], str],
              env: Mapping[str, float], failed: set[str], error: Callable[..., None]
              ) -> list[Element]:
    """A B source of the raw deck in its instance: its linear equivalent, or a
    :class:`Comparator` that :func:`resolve_comparators` maps onto the switches it drives;
    nothing after reporting a problem with ``error(message, location, hint, elements,
    dependent=...)`` (``dependent``: an unknown parameter, which a statement the reader could
    not read may define)."""
    if el.kind == "C":  # a capacitor constant below a knee of its voltage
        return elaborate_knee(el, prefix, mapnode, env, source_name(prefix), error)
    name = prefix + el.name if prefix else el.name
    out_kind, tree, text, offset = el.behaviour
    loc = el.st.loc(0)
    nodes = tuple(map(mapnode, el.nodes))
    try:
        form = linearise(tree, text, env, mapnode, source_name(prefix))
    except BehaviouralError as exc:
        unknown = exc.message.startswith("unknown parameter")
        if not (unknown and exc.message.split("'")[1] in failed):  # (else reported already)
            error(f"{name}: {exc.message}", el.st.loc(offset + exc.offset), exc.hint, (name,),
                  dependent=unknown)
        return []
    if isinstance(form, Step):
        return [Comparator(name, nodes, loc, out_kind, form, text)]
    return linear_elements(name, out_kind, nodes, form, loc)


# ------------------------------------------------------------------------------ comparators


@dataclass
class _Use:
    switch: Switch
    sign: float  # the switch's control is sign * (the B's output)


def _state(x: float, vt: float, vh: float) -> str | None:
    """``"on"``/``"off"`` for a control held at ``x``, ``None`` inside the band."""
    if x > vt + abs(vh):
        return "on"
    if x < vt - abs(vh):
        return "off"
    return None


def _describe(step: Step) -> str:
    parts = []
    for (kind, ref), c in step.diff.terms:
        q = f"v({ref})" if kind == "v" else f"i({ref})"
        parts.append(f"{'-' if c < 0 else '+'} {'' if abs(c) == 1 else f'{abs(c):g}*'}{q}")
    if step.diff.const:
        parts.append(f"{'-' if step.diff.const < 0 else '+'} {abs(step.diff.const):g}")
    text = " ".join(parts).lstrip("+ ")
    if text.startswith("- "):
        text = "-" + text[2:]
    return f"{text} {'>' if step.strict else '>='} 0"


def resolve_comparators(circuit: Circuit) -> list[Diagnostic]:
    """Map every :class:`Comparator` onto the S switches its output controls, and remove it.

    A switch whose control is ``±`` the B's output is on while its control is above its
    band ``VT ± |VH|`` and off below it (ngspice's SW). The B's two values decide, per
    switch, whether it is on while the comparison is true or while it is false (or always):
    the switch then gets the comparison's difference as its control, threshold 0, and no
    hysteresis (a model ``pelcs_sw_<switch>`` with the original's other parameters). A
    strict comparison (``>``) keeps the switch off at equality, as the B source does. A
    difference of two node voltages is the control pair itself; a longer one is built on
    inner nodes by E and H sources (``<B>#c1``...), each free of load.

    Returns
    -------
    list of Diagnostic
        A B output that feeds anything but switch controls, a switch whose control is not
        across the output, a value inside a switch's band, an ``I=`` comparator.
    """
    diags: list[Diagnostic] = []
    comps = [el for el in circuit.elements if isinstance(el, Comparator)]
    if not comps:
        return diags
    keep = [el for el in circuit.elements if not isinstance(el, Comparator)]
    op_start = circuit.tran is not None and not circuit.tran.uic
    added: list[Element] = []
    for b in comps:
        p, n = b.nodes
        label = f"{b.what} {b.name} ({b.text.strip()})"
        if b.kind_out != "V":
            diags.append(Diagnostic(
                f"{label} is a current source switching between constants", b.location,
                "pelcs maps comparator B sources of the V= form onto the S switches they "
                "control; " + ACCEPTED, (b.name,)))
            continue
        uses: list[_Use] = []
        bad: list[str] = []
        for el in keep:
            if p in el.nodes or (n != GROUND and n in el.nodes):
                bad.append(el.name)
                continue
            ctl = tuple(getattr(el, "control", ()))
            if not ({p, n} - {GROUND}) & set(ctl):
                continue
            if isinstance(el, Switch) and el.device is None and ctl in ((p, n), (n, p)):
                uses.append(_Use(el, 1.0 if ctl == (p, n) else -1.0))
            else:
                bad.append(el.name)
        outs = {p, n} - {GROUND}
        bad += [o.name for o in comps if o is not b and (outs & set(o.nodes) or any(
            q == ("v", x) for q, _ in o.step.diff.terms for x in outs))]
        if bad:
            diags.append(Diagnostic(
                f"the output of {label} feeds {', '.join(bad)}", b.location,
                "pelcs maps a comparator B source onto the S switches whose control "
                f"(nc+ nc-) is its output ({p} {n}); the output must drive nothing else. "
                + ACCEPTED, (b.name, *bad)))
            continue
        step = b.step
        for use in uses:
            sw = use.switch
            model = circuit.models.get(sw.model.lower())
            params = dict(model.params) if model is not None else {}
            vt, vh = float(params.get("vt", 0.0)), float(params.get("vh", 0.0))
            hi = _state(use.sign * step.hi, vt, vh)
            lo = _state(use.sign * step.lo, vt, vh)
            if hi is None and lo is None or (vh > 0 and (hi is None or lo is None)):
                diags.append(Diagnostic(
                    f"{label}: its values {step.hi:g} and {step.lo:g} sit in the band "
                    f"{vt:g} ± {abs(vh):g} V of switch {sw.name}'s control, where the switch's "
                    "state depends on its history", b.location,
                    "give the B source values on either side of the switch's VT ± VH",
                    (b.name, sw.name)))
                continue
            # a value inside a VH <= 0 band is entered from the other value's side: the
            # switch takes the state of that side's opposite (ngspice's swload)
            banded = [(v, "off" if o == "on" else "on") for v, x, o in (
                (step.hi, hi, lo), (step.lo, lo, hi)) if x is None]
            if hi is None:
                hi = "off" if lo == "on" else "on"
            if lo is None:
                lo = "off" if hi == "on" else "on"
            if banded:
                # ... except at the start: ngspice's operating point (no UIC) takes a control
                # inside the band as entered from below (on), UIC the netlist's ON/OFF
                value, state = banded[0]
                start = "on" if op_start else ("on" if sw.initial else "off")
                if start != state:
                    truth = "true" if value == step.hi else "false"
                    how = "its operating point" if op_start else "UIC"
                    circuit.notes.append(
                        f"{sw.name}: if the comparison of {b.name} is {truth} at t = 0, "
                        f"ngspice holds the switch {start} until the comparison changes (the "
                        f"output {value:g} starts inside the switch's band {vt:g} ± "
                        f"{abs(vh):g} V, from {how}); pelcs follows the comparison from t = 0")
            diff, strict = step.diff, step.strict
            if hi == lo:
                diff, strict = Affine((), 1.0 if hi == "on" else -1.0), True
            elif hi == "off":
                # on while the comparison is false: the opposite difference, and the
                # opposite strictness (not (d > 0) is -d >= 0)
                diff, strict = diff.scaled(-1.0), not strict
            control, vt_new, more = _control(sw.name, diff, sw.location)
            added.extend(more)
            key = f"pelcs_sw_{sw.name.lower().replace('.', '_')}"
            params.update({"vt": vt_new, "vh": 0.0})
            circuit.models[key] = Model(key, "SW", params, sw.location)
            sw.control = control
            sw.model = key
            sw.strict = strict
            on_while = _describe(Step(diff, strict, 1.0, 0.0))
            circuit.notes.append(f"{b.name}: {b.what} ({b.text.strip()}) mapped "
                                 f"onto switch {sw.name}: on while {on_while} (its output "
                                 f"node {p} is gone; d({sw.name}) is the switch's state)")
        if not uses:
            circuit.notes.append(f"{b.name}: {b.what} ({b.text.strip()}) controls "
                                 "no switch: left out")
    circuit.elements[:] = keep + added
    return diags


def _control(name: str, diff: Affine, loc: Location | None
             ) -> tuple[tuple[str, str], float, list[Element]]:
    """A control pair and threshold whose ``v(pair) > threshold`` is ``diff > 0``, and the
    elements that build it (none for a difference of two node voltages)."""
    volts = {q[1]: c for q, c in diff.terms if q[0] == "v"}
    currents = [(q[1], c) for q, c in diff.terms if q[0] == "i"]
    if not currents and len(volts) <= 2:
        items = list(volts.items())
        if not items:
            return (GROUND, GROUND), 0.0 - diff.const, []
        if len(items) == 1:
            (a, c), = items
            pair = (a, GROUND) if c > 0 else (GROUND, a)
            return pair, 0.0 - diff.const / abs(c), []
        if len(items) == 2 and items[0][1] == -items[1][1]:
            (a, c), (b, _) = items
            if c < 0:
                a, b, c = b, a, -c
            return (a, b), 0.0 - diff.const / c, []
    # the difference on an inner node: a chain of E (voltages) and H (currents) sources
    pieces = _pairs(diff.terms)
    base = f"{name.lower()}#c"
    ends = [GROUND] + [f"{base}{k}" for k in range(1, len(pieces) + 1)]
    out: list[Element] = []
    for k, (what, ref, gain) in enumerate(pieces):
        el_name = f"{name}#c{k + 1}"
        a, b = ends[k + 1], ends[k]
        if what == "v":
            out.append(Vcvs(el_name, (a, b), loc, ref, gain))
        else:
            out.append(Ccvs(el_name, (a, b), loc, ref, gain))
    return (ends[-1], GROUND), 0.0 - diff.const, out

