"""Re-binding parameter values: the circuit of a kept deck for new ``.param`` overrides,
evaluating again only what the changed parameters reach.

A design loop changes one or two parameters (a duty cycle, a load) of a netlist read once
(:mod:`netlist.deck_cache`). :func:`rebound_circuit` keeps, per deck, the circuit of its first
evaluation and what each element's values depend on (the global parameters named in its
value, initial condition and waveform) and an order to evaluate its global parameters in. For
new overrides it evaluates the global parameters in that order (as
:meth:`netlist.flatten._Builder.scope` would), finds those whose value changed, evaluates again the
elements that use one of them (with the flattener's own :meth:`~netlist.flatten._Builder.
element`) and copies the others: the circuit :func:`netlist.flatten.build_circuit` would build,
field for field, without evaluating the rest or checking the unchanged topology again.

It applies to a deck without subcircuit instances or transistors whose models, ``.tran``,
``.ic`` and ``.step`` lines use none of the changed parameters; any other case, and any
problem (an unknown override, a value an element refuses), goes through
:func:`~netlist.flatten.build_circuit`, which reports it.
"""

from __future__ import annotations

import copy
import math
import threading
import weakref
from collections.abc import Mapping
from dataclasses import dataclass

from .circuit import Circuit
from .expressions import ExpressionError
from .flatten import _Builder, build_circuit
from .rawdeck import Deck, RawElement, RawParam, Value

__all__ = ["rebound_circuit"]


@dataclass(frozen=True)
class _Base:
    circuit: Circuit  # the first evaluation (never handed out)
    uses: tuple[frozenset[str], ...]  # per element, the parameter names its values use
    fixed_uses: frozenset[str]  # the names models, .tran, .ic and .step use
    # the global parameters, each after those it uses (None: defined twice or in a cycle,
    # which _Builder.scope reports)
    order: tuple[RawParam, ...] | None


_BASES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_LOCK = threading.Lock()


def rebound_circuit(deck: Deck, overrides: Mapping[str, float] | None,
                    thresholds: Mapping[str, float] | None = None) -> Circuit:
    """:func:`~netlist.flatten.build_circuit` of ``deck`` with ``overrides``, re-binding
    the kept evaluation of the deck where it can (module docstring).

    Raises
    ------
    NetlistError
        As :func:`~netlist.flatten.build_circuit`.
    """
    overrides = dict(overrides or {})
    if thresholds or not _eligible(deck):
        return build_circuit(deck, overrides, thresholds)
    with _LOCK:
        base = _BASES.get(deck)
    if base is None:
        circuit = build_circuit(deck, overrides)
        with _LOCK:
            _BASES[deck] = _Base(copy.deepcopy(circuit), *_uses(deck), _order(deck))
        return circuit
    return _rebind(deck, base, overrides) or build_circuit(deck, overrides)


def _eligible(deck: Deck) -> bool:
    # (an instance, a transistor, a B source, a W switch or a value read from an expression
    # (a knee capacitor, a resistor stepped in time) makes elements of other kinds, names
    # and numbers)
    return all(el.kind not in "XMQBW" and el.behaviour is None for el in deck.top.elements)


def _names(values) -> frozenset[str]:
    out: set[str] = set()
    for v in values:
        if isinstance(v, Value) and v.expr is not None:
            out |= v.expr.names
    return frozenset(out)


def _uses(deck: Deck) -> tuple[tuple[frozenset[str], ...], frozenset[str]]:
    per_element = []
    for el in deck.top.elements:
        per_element.append(_names(_element_values(el)))
    fixed = [p.value for m in deck.models for p in m.params]
    fixed += [v for t in deck.trans for v in t.values]
    fixed += [ic.value for ic in deck.top.ics]
    fixed += [v for s in deck.steps for v in s.values]
    return tuple(per_element), _names(fixed)


def _order(deck: Deck) -> tuple[RawParam, ...] | None:
    """The global parameters in an order where each comes after those it uses (depth first,
    without recursion: a generated netlist may chain thousands); None for a parameter
    defined twice or a cycle."""
    table: dict[str, RawParam] = {}
    for p in deck.top.params:
        if p.name in table:
            return None
        table[p.name] = p

    def deps(name: str):
        expr = table[name].value.expr
        return iter(() if expr is None else sorted(n for n in expr.names if n in table))

    order: list[RawParam] = []
    state: dict[str, int] = {}  # 1 on the path, 2 done
    for root in table:
        if root in state:
            continue
        state[root] = 1
        stack = [(root, deps(root))]
        while stack:
            name, pending = stack[-1]
            for dep in pending:
                if state.get(dep) == 2:
                    continue
                if dep in state:
                    return None
                state[dep] = 1
                stack.append((dep, deps(dep)))
                break
            else:
                stack.pop()
                state[name] = 2
                order.append(table[name])
    return tuple(order)


def _scope(deck: Deck, order: tuple[RawParam, ...], fixed: dict[str, float]
           ) -> dict[str, float] | None:
    """The global parameters' values with the overrides ``fixed``, as
    :meth:`~netlist.flatten._Builder.scope` gives them (in the order of their definitions),
    or None for a value it would report (a division by zero, an unknown name...)."""
    values: dict[str, float] = dict(fixed)
    for p in order:
        if p.name in values:
            continue
        v = p.value.number
        if v is None:
            try:
                v = p.value.expr.evaluate(values)
            except ExpressionError:
                return None
        values[p.name] = v
    return {p.name: values[p.name] for p in deck.top.params}


def _element_values(el: RawElement) -> list:
    values = [el.value, el.ic, *(p.value for p in el.params),
              *(p.value for p in el.temperature)]
    if el.wave is not None:
        _, args, _, extras = el.wave
        values += list(args) + [val for val, _ in extras.values()]
    return values


def _same(a: float | None, b: float | None) -> bool:
    """The same double (a sign of zero told apart)."""
    return a is not None and b is not None and a == b and \
        math.copysign(1.0, a) == math.copysign(1.0, b)


def _rebind(deck: Deck, base: _Base, overrides: dict) -> Circuit | None:
    """The circuit for ``overrides``, or None where only a full evaluation can tell."""
    defined = {p.name for p in deck.top.params}
    fixed: dict[str, float] = {}
    for name, value in overrides.items():
        key = name.lower()
        try:
            number = float(value)
        except (TypeError, ValueError):
            return None
        if key not in defined or not math.isfinite(number):
            return None  # (the full evaluation reports it)
        fixed[key] = number
    builder = _Builder(deck)
    if base.order is not None:
        env, failed = _scope(deck, base.order, fixed), set()
        if env is None:
            return None
    else:
        env, failed = builder.scope(deck.top.params, fixed, {}, set())
    old = base.circuit.params
    if failed or builder.diags or env.keys() != old.keys():
        return None
    changed = {n for n, v in env.items() if not _same(v, old[n])}
    if changed & base.fixed_uses:
        return None
    elements = []
    for el, raw, uses in zip(base.circuit.elements, deck.top.elements, base.uses, strict=True):
        if uses & changed:
            el = builder.element(raw, "", _same_node, env, failed)
            if builder.diags:
                return None
        elements.append(_shallow(el))
    c = base.circuit
    # (what dataclasses.replace(c, ...) gives, field for field: Circuit has no __post_init__)
    out = _shallow(c)
    out.elements = elements
    out.params = dict(env)
    out.models = {k: _with_params(m) for k, m in c.models.items()}
    out.initial_conditions = dict(c.initial_conditions)
    out.tran = None if c.tran is None else _shallow(c.tran)
    out.options = dict(c.options)
    out.ignored = list(c.ignored)
    out.replacements = list(c.replacements)
    out.notes = list(c.notes)
    out.subckt_texts = dict(c.subckt_texts)
    out.steps = list(c.steps)
    return out


def _shallow(obj):
    """``copy.copy`` of a plain dataclass instance (its attributes in a new instance of its
    class) without ``copy``'s protocol: 0.5 us instead of 2.5 us an element, and a design
    loop copies every element of the circuit each run."""
    if not hasattr(obj, "__dict__") or hasattr(obj, "__copy__"):
        return copy.copy(obj)
    new = object.__new__(type(obj))
    new.__dict__.update(obj.__dict__)
    return new


def _with_params(model):
    """A copy of a model with its own parameter dict."""
    new = _shallow(model)
    new.params = dict(model.params)
    return new


def _same_node(node: str) -> str:
    return node
