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
  (``docs/switching.md``). A comparator whose output drives more than switch controls (a
  load, a gate resistor, another comparator), and an ``I=`` one, is its value
  ``lo + (hi - lo) s``, ``s`` the state of an ideal switch on the comparison
  (:func:`_driving`).

- **clamp**: ``max(lo, min(hi, e))`` (or ``min``/``max`` alone) of an affine ``e``. A ``V=``
  source to ground whose output only comparator B sources read, comparing it with known
  waveforms (DC, PULSE, PWL sources) that stay within the clamp's range, is folded into
  them: there ``clamp(e) > r`` is ``e > r`` at every instant (:func:`fold_clamps`); so is one
  that only S switches read with their band inside the range. Any other is built as an ideal
  limiter (:mod:`netlist.limiter`: ideal diodes hold an inner node at the bounds). Both are
  exact.

- **sigmoid**: a ``tanh``, logistic or ``atan`` of an affine form, scaled and shifted by
  constants (``5*(1+tanh(1000*(v(ctl)-v(tri))))/2``): the ideal comparator it approximates
  (:mod:`netlist.sigmoid`), read as the comparators above; the run checks that its input
  spends no more than a tenth of it in the sigmoid's transition band.

- **stepped in time**: an expression of ``time`` alone, read only inside comparisons of an
  affine function of time with constants (:func:`netlist.time_value.time_value`): the
  independent source of its piecewise-constant waveform, a PWL that jumps at the instants.

The expressions themselves (grammar, linear and comparator forms) are
:mod:`netlist.behavioural_expr`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import ClassVar

from lcs.signals import Dc, Pulse, Pwl

from .behavioural_expr import (
    Affine,
    BehaviouralError,
    Clamp,
    ClampInSum,
    Select,
    Step,
    Tree,
    linearise,
)
from .circuit import (
    GROUND,
    Cccs,
    Ccvs,
    Circuit,
    CurrentSource,
    Element,
    Model,
    Resistor,
    Switch,
    Vccs,
    Vcvs,
    VoltageSource,
)
from .dialect import hierarchical_name
from .errors import Diagnostic, Location
from .knee import elaborate_knee
from .rawdeck import RawElement
from .sigmoid import SoftStep, record, sigmoid_step, switch_band
from .time_expression import time_expression
from .time_value import NotAffineInTime, reads_time_only, time_in_comparisons, time_value
from .writer import element_line

__all__ = ["ClampSource", "Comparator", "elaborate", "fold_clamps", "linear_elements",
           "gone_probe", "resolve_comparators"]


# ------------------------------------------------------------------------------ elements


@dataclass
class Comparator(Element):
    """A B source whose value switches between two constants (before
    :func:`resolve_comparators` maps it onto the switches it drives; never formulated).
    ``kind_out`` is ``"V"`` or ``"I"``; ``step`` the comparison and the two values; ``text``
    the expression as written."""

    kind_out: str = "V"
    step: Step | Select | None = None
    text: str = ""
    what: str = "comparator B source"  # what it is, for messages
    kind: ClassVar[str] = "B"


@dataclass
class ClampSource(Element):
    """A ``V=`` B source whose value is a :class:`~netlist.behavioural_expr.Clamp` of an
    affine form (before :func:`fold_clamps` folds it into the comparators that read it;
    never formulated). ``text``: the expression as written."""

    clamp: Clamp | None = None
    text: str = ""
    kind_out: str = "V"
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


def _keep(inner: list[ClampSource], mapnode: Callable[[str], str]) -> Callable[[str], str]:
    """``mapnode`` that leaves the hoisted clamps' nodes as they are."""
    mine = {c.nodes[0] for c in inner}
    return lambda n: n if n in mine else mapnode(n)


def _hoist_clamps(tree: Tree, text: str, env: Mapping[str, float],
                  mapnode: Callable[[str], str], source: Callable[[str], str], name: str,
                  loc: Location | None) -> tuple[Tree, list[ClampSource]]:
    """The expression with each ``min``/``max`` that is a clamp of an affine form replaced by
    ``v()`` of a node of its own, and the :class:`ClampSource` of each on its node
    (``<name>#k1``, ``#k2``... to ground): a B source that adds a clamped PI output to linear
    terms is then linear in that node, which :func:`fold_clamps` builds as an exact limiter."""
    inner: list[ClampSource] = []

    def visit(t: Tree) -> Tree:
        if t.tag == "call" and t.args[0] in ("min", "max"):
            try:
                form = linearise(t, text, env, mapnode, source, clamps=True)
            except BehaviouralError:
                form = None
            if isinstance(form, Clamp) and not form.form.constant:
                node = f"{name.lower()}#k{len(inner) + 1}"
                inner.append(ClampSource(f"{name}#k{len(inner) + 1}", (node, GROUND), loc,
                                         form, text[t.start:t.end], "V"))
                return Tree("v", (node, None), t.start, t.end)
            if form is not None:  # (a constant: min(0, max(1, v(b))) is 0, nothing to hoist)
                return t
        args = tuple(visit(a) if isinstance(a, Tree) else a for a in t.args)
        return Tree(t.tag, args, t.start, t.end)

    return visit(tree), inner


def _stepped(tree, text: str, env: Mapping[str, float]):
    """The piecewise-constant function of time an expression is (:func:`time_value`), or None
    where its comparisons are not of affine functions of time (a sawtooth's ``floor``):
    :func:`time_expression` reads those."""
    try:
        return time_value(tree, text, env)
    except NotAffineInTime:
        return None


def _stepped_wave(tv, tree: Tree, text: str, env: Mapping[str, float]) -> Pwl | None:
    """The PWL of a piecewise-constant function of time, from its value at t = 0 itself
    where that differs from the one just after (``time > 0 ? 5 : 0`` is 0 there, ``u(time)``
    0.5): ngspice's operating point takes it, and the source jumps in the first step."""
    form = linearise(tree, text, {**env, "time": 0.0})
    at0 = form.const if isinstance(form, Affine) and form.constant else tv.values[0]
    if at0 == tv.values[0]:
        return tv.pwl() if tv.times else None
    wave = tv.pwl()
    return Pwl((0.0, *wave.times), (at0, *wave.values))


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
        if reads_time_only(tree):
            cls = VoltageSource if out_kind == "V" else CurrentSource
            if time_in_comparisons(tree) and (tv := _stepped(tree, text, env)) is not None:
                # a piecewise-constant function of time: an independent source stepping at
                # its instants (netlist.time_value), as ngspice's value between them
                return [cls(name, nodes, loc, tv.values[0], _stepped_wave(tv, tree, text, env))]
            # any other function of time: the source of that waveform, stepped to where it
            # jumps or kinks (netlist.time_expression)
            sig = time_expression(tree, text, env, el.st.loc(offset))
            return [cls(name, nodes, loc, float(sig(0.0, side=1)), sig)]
        try:
            form = linearise(tree, text, env, mapnode, source_name(prefix), clamps=True)
        except ClampInSum:
            # the clamps summed with other terms, each on a node of its own
            hoisted, inner = _hoist_clamps(tree, text, env, mapnode, source_name(prefix),
                                           name, el.st.loc(offset))
            form = linearise(hoisted, text, env, _keep(inner, mapnode), source_name(prefix),
                             clamps=True)
            if isinstance(form, Affine):
                return [*inner, *linear_elements(name, out_kind, nodes, form, loc)]
            raise
    except BehaviouralError as exc:
        # a smooth comparator (tanh, atan, a logistic of an affine form): its ideal one
        soft = sigmoid_step(tree, text, env, mapnode, source_name(prefix))
        if isinstance(soft, SoftStep):
            return [Comparator(name, nodes, loc, out_kind, soft, text,
                               what="sigmoid B source")]
        if soft is not None:
            return linear_elements(name, out_kind, nodes, soft, loc)
        unknown = exc.message.startswith("unknown parameter")
        if not (unknown and exc.message.split("'")[1] in failed):  # (else reported already)
            error(f"{name}: {exc.message}", el.st.loc(offset + exc.offset), exc.hint, (name,),
                  dependent=unknown)
        return []
    if isinstance(form, Step | Select):
        return [Comparator(name, nodes, loc, out_kind, form, text)]
    if isinstance(form, Clamp):
        return [ClampSource(name, nodes, el.st.loc(offset), form, text, out_kind)]
    return linear_elements(name, out_kind, nodes, form, loc)


# ------------------------------------------------------------------------------ clamps


def _source_range(circuit: Circuit, node: str) -> tuple[float, float] | None:
    """The range of ``v(node)`` when an independent voltage source to ground sets it (DC,
    PULSE or PWL: their values stay between their extreme points), else None."""
    for el in circuit.elements:
        if isinstance(el, VoltageSource) and node in el.nodes and GROUND in el.nodes:
            sig = el.waveform
            if sig is None or isinstance(sig, Dc):
                values = [el.dc if sig is None else sig.value]
            elif isinstance(sig, Pulse):
                values = [sig.v1, sig.v2]
            elif isinstance(sig, Pwl):
                values = list(sig.values)
            else:
                return None
            sign = 1.0 if el.nodes[0] == node else -1.0
            return min(sign * v for v in values), max(sign * v for v in values)
    return None


def _fold_one(circuit: Circuit, b: ClampSource, comp: Comparator, dry: bool = False
              ) -> str | None:
    """Put ``b``'s affine form into ``comp``'s comparison, where that is exact (only check,
    if ``dry``); else why not."""
    assert b.clamp is not None and comp.step is not None
    p = b.nodes[0]
    step, clamp = comp.step, b.clamp
    a = dict(step.diff.terms)[("v", p)]
    rest = Affine(tuple((q, c) for q, c in step.diff.terms if q != ("v", p)), step.diff.const)
    # the comparison is a*clamp + rest > 0 (or >= 0): clamp against r = -rest/a, a known
    # waveform when rest reads only independent sources
    lo_r = hi_r = -rest.const / a
    for q, c in rest.terms:
        rng = _source_range(circuit, q[1]) if q[0] == "v" else None
        if rng is None:
            what = f"{q[0]}({q[1]})"
            return f"its other side reads {what}, which is not a DC, PULSE or PWL source"
        ends = (-c * rng[0] / a, -c * rng[1] / a)
        lo_r, hi_r = lo_r + min(ends), hi_r + max(ends)
    # clamp(e) > r is e > r while lo < r < hi; at r = lo (or hi) the clamp's flat piece
    # equals r and the comparison holds the flat piece's truth: the same as e's only on one
    # side of each bound
    up = a > 0
    lo_ok = clamp.lo < lo_r or (clamp.lo == lo_r and step.strict == up)
    hi_ok = hi_r < clamp.hi or (hi_r == clamp.hi and step.strict != up)
    if not (lo_ok and hi_ok):
        return (f"the level it is compared with spans {lo_r:g} to {hi_r:g} V, beyond the "
                f"clamp's range {clamp.lo:g} to {clamp.hi:g} V, where the clamp decides the "
                "comparison")
    if not dry:
        comp.step = replace(step, diff=rest.plus(clamp.form.scaled(a)))
    return None


def fold_clamps(circuit: Circuit) -> None:
    """Fold every :class:`ClampSource` into the comparator B sources or the switches that
    read its output, or else build it as an exact limiter; remove it.

    ``max(lo, min(hi, e))`` compared with a level ``r`` is ``e`` compared with ``r`` while
    ``lo < r < hi`` (and at one of the two bounds, by the comparison's direction and
    strictness); so when the other side of every comparison reading the clamp is a known
    waveform (independent DC, PULSE or PWL sources) within that range, the comparison of
    ``e`` is exact at every instant, whether or not the clamp is active. A clamp that
    anything else reads (a capacitor, a resistor, another B source, a transistor's gate
    network) becomes the ideal-diode limiter of :mod:`netlist.limiter`, also exact.
    """
    clamps = [el for el in circuit.elements if isinstance(el, ClampSource)]
    if not clamps:
        return
    circuit.elements[:] = [el for el in circuit.elements if not isinstance(el, ClampSource)]
    for b in clamps:
        p = b.nodes[0]
        readers: list[Comparator] = []
        bad: list[str] = []
        for el in circuit.elements + [c for c in clamps if c is not b]:
            reads = isinstance(el, Comparator) and p not in el.nodes and any(
                q == ("v", p) for q, _ in el.step.diff.terms)
            # (a sigmoid's B line, which ngspice is given, reads the clamp's output: the
            # clamp stays, an exact limiter written as its own line)
            if reads and not isinstance(el.step, SoftStep):
                readers.append(el)
            elif reads or p in el.nodes or p in tuple(getattr(el, "control", ())) or (
                    isinstance(el, ClampSource) and ("v", p) in dict(el.clamp.form.terms)):
                bad.append(el.name)
        gated = [el for el in circuit.elements if isinstance(el, Switch)
                 and p in el.control and p not in el.nodes]
        why = "its output is read by nothing"
        if b.kind_out != "V" or b.nodes[1] != GROUND:
            why = "it is a current" if b.kind_out != "V" else "it is not a voltage to ground"
        elif gated and not readers and set(bad) == {sw.name for sw in gated}:
            why = _gate_switches(circuit, b, gated)
            if why is None:
                continue
            why = "switch " + why
        elif readers and not bad:
            whys = [_fold_one(circuit, b, comp, dry=True) for comp in readers]
            if all(w is None for w in whys):
                for comp in readers:
                    _fold_one(circuit, b, comp)
                    circuit.notes.append(
                        f"{b.name}: clamp ({b.text.strip()}) folded into comparator "
                        f"{comp.name}: the level it is compared with stays within the clamp's "
                        f"range {b.clamp.lo:g} to {b.clamp.hi:g} V, where comparing the clamp "
                        f"is comparing its linear expression (exact; its output node {p} is "
                        "gone)")
                continue
            why = next(f"comparator {comp.name} reads it, and {w}"
                       for comp, w in zip(readers, whys, strict=True) if w is not None)
        elif bad:
            why = f"it feeds {', '.join(bad)}"
        _limiter(circuit, b, why)


def _bounds_text(lo: float, hi: float, unit: str) -> str:
    """``within 0 to 5 V``, ``at or above 0 V``, ``at or below 5 V``."""
    if math.isinf(hi):
        return f"at or above {lo:g} {unit}"
    if math.isinf(lo):
        return f"at or below {hi:g} {unit}"
    return f"within {lo:g} to {hi:g} {unit}"


def _limiter(circuit: Circuit, b: ClampSource, why: str) -> None:
    """Build ``b`` as the exact ideal-diode limiter of :mod:`netlist.limiter`, with a note
    saying why it was not folded (``why``)."""
    from .limiter import LIMITER_OHMS, limiter_elements  # (only where a clamp is a limiter)

    unit = "V" if b.kind_out == "V" else "A (as volts)"

    assert b.clamp is not None
    e_node = f"{b.name.lower()}#e"
    chain = linear_elements(f"{b.name}#e", "V", (e_node, GROUND), b.clamp.form, b.location)
    circuit.elements.extend(limiter_elements(circuit, b.name, b.kind_out, b.nodes, b.clamp,
                                             b.location, chain))
    circuit.notes.append(
        f"{b.name}: clamp ({b.text.strip()}) built as an ideal limiter ({why}): ideal diodes "
        f"hold its linear expression {_bounds_text(b.clamp.lo, b.clamp.hi, unit)} on node "
        f"{b.name.lower()}#c (through {LIMITER_OHMS:g} Ω from {e_node}), which drives the "
        "output; exact")


def _gate_switches(circuit: Circuit, b: ClampSource, gated: list[Switch]) -> str | None:
    """Drive the switches that read ``b``'s output with its linear expression instead, where
    that is exact; else why not (the switch named first).

    A switch whose control is ``±v(p)`` turns on above ``VT + |VH|`` and off below
    ``VT - |VH|``; while that band lies inside the clamp's range ``(lo, hi)``, the clamp is
    above (below) the band exactly when its expression is, so the switch turns at the same
    instants reading the expression (on an inner node ``<b>#e``; the output node is gone).
    """
    assert b.clamp is not None
    p, clamp = b.nodes[0], b.clamp
    for sw in gated:
        if set(sw.control) != {p, GROUND}:
            return f"{sw.name} compares with another node"
        if sw.gate_rc is not None:
            # with --devices pwl the clamp charges the device's gate capacitances, which the
            # unclamped expression would drive far beyond the clamp's range
            return f"{sw.name} is a transistor whose gate network it drives"
        model = circuit.models.get(sw.model.lower())
        params = model.params if model is not None else {}
        vt, vh = float(params.get("vt", 0.0)), abs(float(params.get("vh", 0.0)))
        sign = 1.0 if sw.control[0] == p else -1.0
        lo, hi = sorted((sign * (vt - vh), sign * (vt + vh)))
        if not (clamp.lo < lo and hi < clamp.hi):
            return (f"{sw.name} reads at VT {vt:g} V, VH {vh:g} V, beyond the clamp's range "
                    f"{clamp.lo:g} to {clamp.hi:g} V, where the clamp decides it")
    q = f"{b.name.lower()}#e"
    circuit.elements.extend(linear_elements(b.name, "V", (q, GROUND), clamp.form, b.location))
    for k, el in enumerate(circuit.elements):
        if any(el is sw for sw in gated):
            circuit.elements[k] = replace(el, control=tuple(q if c == p else c
                                                            for c in el.control))
    circuit.notes.append(
        f"{b.name}: clamp ({b.text.strip()}) read only by the switch"
        f"{'es' if len(gated) > 1 else ''} {', '.join(sw.name for sw in gated)}, whose band "
        f"VT ± VH lies inside the clamp's range {clamp.lo:g} to {clamp.hi:g} V: "
        f"{'they turn' if len(gated) > 1 else 'it turns'} at the same instants on the "
        f"linear expression, which drives {'them' if len(gated) > 1 else 'it'} instead (exact; "
        f"the output node {p} is gone)")
    return None


# ------------------------------------------------------------------------------ comparators


@dataclass
class _Use:
    switch: Switch
    sign: float  # the switch's control is sign * (the B's output)


def _band_of(circuit: Circuit, sw: Switch) -> tuple[float, float]:
    """A switch's ``VT`` and ``VH`` (V)."""
    model = circuit.models.get(sw.model.lower())
    params = model.params if model is not None else {}
    return float(params.get("vt", 0.0)), float(params.get("vh", 0.0))


def _state(x: float, vt: float, vh: float) -> str | None:
    """``"on"``/``"off"`` for a control held at ``x``, ``None`` inside the band."""
    if x > vt + abs(vh):
        return "on"
    if x < vt - abs(vh):
        return "off"
    return None


def _text(form: Affine) -> str:
    """An affine form as text (``2*v(out) - v(ramp) + 0.4``)."""
    parts = []
    for (kind, ref), c in form.terms:
        q = f"v({ref})" if kind == "v" else f"i({ref})"
        parts.append(f"{'-' if c < 0 else '+'} {'' if abs(c) == 1 else f'{abs(c):g}*'}{q}")
    if form.const or not parts:
        parts.append(f"{'-' if form.const < 0 else '+'} {abs(form.const):g}")
    text = " ".join(parts).lstrip("+ ")
    return "-" + text[2:] if text.startswith("- ") else text


def _describe(step: Step | Select) -> str:
    return f"{_text(step.diff)} {'>' if step.strict else '>='} 0"


def resolve_comparators(circuit: Circuit) -> list[Diagnostic]:
    """Map every :class:`Comparator` onto the S switches its output controls, and remove it
    (after :func:`fold_clamps`).

    A switch whose control is ``±`` the B's output is on while its control is above its
    band ``VT ± |VH|`` and off below it (ngspice's SW). The B's two values decide, per
    switch, whether it is on while the comparison is true or while it is false (or always):
    the switch then gets the comparison's difference as its control, threshold 0, and no
    hysteresis (a model ``pelcs_sw_<switch>`` with the original's other parameters). A
    strict comparison (``>``) keeps the switch off at equality, as the B source does. A
    difference of two node voltages is the control pair itself; a longer one is built on
    inner nodes by E and H sources (``<B>#c1``...), each free of load.

    A comparator whose output drives anything but switch controls across it (a load, a gate
    resistor, another comparator's comparison) or nothing at all (an output only probed),
    and an ``I=`` comparator, becomes its value instead (:func:`_driving`); the switches
    across its output then read that value.

    Returns
    -------
    list of Diagnostic
        A value inside the ``VH > 0`` band of a switch the output drives alone.
    """
    fold_clamps(circuit)
    diags: list[Diagnostic] = []
    comps = [el for el in circuit.elements if isinstance(el, Comparator)]
    if not comps:
        return diags
    keep = [el for el in circuit.elements if not isinstance(el, Comparator)]
    op_start = circuit.tran is not None and not circuit.tran.uic
    added: list[Element] = []
    # (a sigmoid's switches as the netlist has them: their lines, for the deck written for
    # ngspice, and the levels of its output where they turn, for its check)
    before = {el.key: (el.name, element_line(el, circuit), el.control, _band_of(circuit, el))
              for el in keep if isinstance(el, Switch)} \
        if any(isinstance(b.step, SoftStep) for b in comps) else {}
    spans = []  # where each comparator's elements start in added
    exact: set[str] = set()  # (sigmoids whose switches turn where the sigmoid crosses VT ± VH)
    for b in comps:
        spans.append(len(added))
        p, n = b.nodes
        label = f"{b.what} {b.name} ({b.text.strip()})"
        if b.kind_out != "V" or isinstance(b.step, Select):
            added.extend(_driving(circuit, b))
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
        if bad or not uses:
            # (a load, a transistor's gate, another comparator: the output itself, and the
            # switches above read it as the circuit sets it; an output that drives nothing
            # is kept too, so that it can be probed: a PWM written only to be plotted)
            added.extend(_driving(circuit, b, "drives more than switch controls" if bad
                                  else "drives nothing (kept, so that it can be probed)"))
            continue
        step = b.step
        if isinstance(step, SoftStep):
            exact.add(b.name)
        for use in uses:
            sw = use.switch
            model = circuit.models.get(sw.model.lower())
            params = dict(model.params) if model is not None else {}
            vt, vh = float(params.get("vt", 0.0)), float(params.get("vh", 0.0))
            hi = _state(use.sign * step.hi, vt, vh)
            lo = _state(use.sign * step.lo, vt, vh)
            if hi is None and lo is None or (vh > 0 and (hi is None or lo is None)):
                inside = [f"{v:g}" for v, st in ((step.hi, hi), (step.lo, lo)) if st is None]
                diags.append(Diagnostic(
                    f"{label}: its value{'s' if len(inside) > 1 else ''} "
                    f"{' and '.join(inside)} sit{'' if len(inside) > 1 else 's'} in the band "
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
            band = switch_band(step, use.sign, vt, abs(vh)) if (
                isinstance(step, SoftStep) and hi != lo and vh >= 0) else None
            if isinstance(step, SoftStep) and hi != lo and band is None:
                exact.discard(b.name)
            if band is not None:  # (the argument's band where the sigmoid crosses VT ± VH)
                diff = diff.plus(Affine((), -band[0]))
            control, vt_new, more = _control(sw.name, diff, sw.location)
            added.extend(more)
            key = f"pelcs_sw_{sw.name.lower().replace('.', '_')}"
            params.update({"vt": vt_new, "vh": 0.0 if band is None else band[1] / _scale(diff)})
            circuit.models[key] = Model(key, "SW", params, sw.location)
            sw.control = control
            sw.model = key
            # (a strict switch is an idealised one, turning at VT alone: where the sigmoid's
            # crossings of VT ± VH are a band of width, the switch keeps its hysteresis)
            sw.strict = strict and not (band is not None and band[1] > 0)
            gone = circuit.gone_nodes.setdefault(p, (b.name, []))
            gone[1].append(sw.name)
            on_while = _describe(Step(diff, strict, 1.0, 0.0)) if not band or not band[1] \
                else f"{_text(diff)} > {band[1]:.4g}, off once below {-band[1]:.4g},"
            circuit.notes.append(f"{b.name}: {b.what} ({b.text.strip()}) mapped "
                                 f"onto switch {sw.name}: on while {on_while} (its output "
                                 f"node {p} is gone; d({sw.name}) is the switch's state)")
    circuit.elements[:] = keep + added
    for b, start, end in zip(comps, spans, [*spans[1:], len(added)], strict=True):
        if isinstance(b.step, SoftStep):
            gone = circuit.gone_nodes.get(b.nodes[0])
            mapped = [before[sw.lower()] for sw in (
                gone[1] if gone is not None and gone[0] == b.name else [])]
            levels = [(1.0 if ctl == b.nodes else -1.0) * (vt + d * abs(vh))
                      for _, _, ctl, (vt, vh) in mapped for d in (-1.0, 1.0)]
            record(circuit, b.name, b.text, b.step, b.nodes, b.kind_out, added[start:end],
                   [(name, line) for name, line, _, _ in mapped], levels, _text,
                   b.location, b.name in exact and bool(mapped))
    return diags


def _driving(circuit: Circuit, b: Comparator,
             why: str = "drives more than switch controls") -> list[Element]:
    """The exact elements of a comparator B source whose output drives more than switch
    controls: ``lo + (hi - lo) s`` (a ``V=`` source; an ``I=`` source the same current), ``s``
    the state of an ideal switch ``<B>#s`` on exactly while the comparison is true.

    The switch connects a 1 V source (``<B>#u``) to a node ``<b>#c`` held at 0 by ``<B>#r``
    (1 MΩ) while it is off, so ``v(<b>#c)`` is 1 while the comparison is true and 0 else;
    the output is then the linear B ``lo + (hi - lo) v(<b>#c)`` (:func:`linear_elements`: an
    E or G source named ``<B>``, and the constant ``lo``). The switch turns on the comparison
    (a strict one keeps it off at equality, as the B's output is then ``lo``). It has
    ngspice's default RON (1 Ω, against 1 MΩ: ``--devices pwl`` and ngspice itself are
    exact to 1e-6; a smaller one would only add round-off to the other controls' rows).

    A :class:`~netlist.behavioural_expr.Select` (linear branches): the branches are set on
    nodes ``<b>#h`` and ``<b>#l`` (E chains; ground for a branch 0), the switch connects the
    first to ``<b>#m``, which the resistor holds at the second while the switch is off (no
    current flows: the output source only reads ``v(<b>#m)``), and the output is
    ``v(<b>#m)``.
    """
    assert b.step is not None
    step, name, loc = b.step, b.name, b.location
    key = name.lower()
    unit, node = f"{key}#u", f"{key}#c"
    control, vt, more = _control(f"{name}#s", step.diff, loc)
    model = f"pelcs_sw_{key.replace('.', '_').replace('#', '_')}_s"
    circuit.models[model] = Model(model, "SW", {"vt": vt, "vh": 0.0}, loc)
    # at equality a >= comparison is true (on); UIC then starts it from its ON
    sw = Switch(f"{name}#s", (unit, node), loc, control=control, model=model,
                initial=None if step.strict else True, strict=step.strict)
    cond = _describe(step)
    unit_of = " V" if b.kind_out == "V" else " A"
    if isinstance(step, Select):
        # the branches on nodes <b>#h and <b>#l (E chains, or ground), the switch from the
        # first to <b>#m, which the resistor holds at the second while it is off
        ends = []
        for tag, form in (("h", step.hi), ("l", step.lo)):
            if form.constant and form.const == 0:
                ends.append(GROUND)
                continue
            ends.append(f"{key}#{tag}")
            more.extend(linear_elements(f"{name}#{tag}", "V", (ends[-1], GROUND), form, loc))
        mid = f"{key}#m"
        sw = replace(sw, nodes=(ends[0], mid))
        out = [sw, Resistor(f"{name}#r", (mid, ends[1]), loc, 1e6), *more]
        out.extend(linear_elements(name, b.kind_out, b.nodes, Affine(((("v", mid), 1.0),)),
                                   loc))
        circuit.notes.append(
            f"{name}: {b.text.strip()}: its output is {_text(step.hi)}{unit_of} while {cond}, "
            f"{_text(step.lo)}{unit_of} else, through an ideal switch {name}#s (exact)")
        return out
    out = [VoltageSource(f"{name}#u", (unit, GROUND), loc, 1.0), sw,
           Resistor(f"{name}#r", (node, GROUND), loc, 1e6), *more]
    form = Affine(((("v", node), step.hi - step.lo),) if step.hi != step.lo else (), step.lo)
    out.extend(linear_elements(name, b.kind_out, b.nodes, form, loc))
    circuit.notes.append(
        f"{name}: {b.what} ({b.text.strip()}) {why}: its output "
        f"is {step.lo:g} + {step.hi - step.lo:g}*d({name}#s){unit_of}, d({name}#s) the state "
        f"of an ideal switch on while {cond}"
        + ("" if isinstance(step, SoftStep) else " (exact)"))  # (a sigmoid: netlist.sigmoid)
    return out


def _scale(diff: Affine) -> float:
    """The factor :func:`_control` divides ``diff`` by: its control is ``diff / factor``."""
    volts = [c for q, c in diff.terms if q[0] == "v"]
    if len(volts) == len(diff.terms) and (len(volts) == 1 or (
            len(volts) == 2 and volts[0] == -volts[1])):
        return abs(volts[0])
    return 1.0


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

def gone_probe(circuit: Circuit, probe: str, node: str) -> Diagnostic:
    """The diagnostic of a probe of a comparator's output node that pelcs mapped onto the
    switches the comparator drives (:func:`resolve_comparators`)."""
    comparator, switches = circuit.gone_nodes[node]
    names = ", ".join(switches)
    return Diagnostic(
        message=f"probe {probe.strip()!r}: node {node} was the output of comparator "
                f"{comparator}, mapped onto the switch{'es' if len(switches) > 1 else ''} it "
                f"drives ({names}): the node is gone",
        hint=f"probe d({switches[0]}), the state of {switches[0]} (1 while on), or give "
             f"{comparator}'s output a load (a resistor to ground keeps the node)")
