"""Formulating a circuit once for many runs: switched systems kept by the values they hold.

The switched LCS of a circuit (:func:`netlist.formulation.formulate`) depends on its
topology and on the values of its R, L, C, controlled sources, couplings and switch models,
but not on what the independent sources do: they are the inputs ``u``. A design script that
varies a duty cycle, a source amplitude or a load step therefore needs one system for all
its runs, and with it the mode matrices, the passivity and θ screens and the discretised
mode stacks that are kept with a system (:mod:`lcs.theory.screening`,
:mod:`lcs.integrators.moreau.theta_screen`,
:mod:`lcs.integrators.moreau.dense.modes`).

:func:`reused_system` keys the systems of the last :data:`MAX_SYSTEMS` circuits (fewer of
large circuits: :data:`MAX_ELEMENTS`) by
:func:`formulation_key`: every field of every element (each number as a double, and its
source location, which the formulation's messages quote) except the value and
waveform of independent sources, the models, whether the run starts from an operating point
(``.tran`` without UIC) and the file name. Two circuits with the same key get the same
system, which is the system each would have been given by :func:`formulate`: the key holds
everything :func:`formulate` reads. Each thread has its own systems: a run changes the mode
stacks kept with its system as it goes.
"""

from __future__ import annotations

import copy
import math
import threading
import weakref
from collections import OrderedDict
from collections.abc import Callable, Hashable
from dataclasses import fields, replace

from lcs.model import SwitchedLCS

from .circuit import Circuit
from .errors import Location
from .formulation import formulate

__all__ = ["MAX_ELEMENTS", "MAX_SYSTEMS", "clear", "formulation_key", "kept_with",
           "reused_system"]

#: systems kept (least recently used dropped first) ...
MAX_SYSTEMS = 16
#: ... and the elements of their circuits, together: what a system keeps (its modes, their
#: discretised stacks) grows with its circuit, so a large circuit's systems are kept by twos
#: (the newest always)
MAX_ELEMENTS = 1024

_SYSTEMS: OrderedDict[Hashable, tuple[SwitchedLCS, int]] = OrderedDict()
_LOCK = threading.Lock()
_FACTS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
# Independent sources' fields the formulation does not read (they are its inputs).
_INPUT_FIELDS = frozenset({"dc", "waveform"})
_FIELDS: dict[type, tuple[str, ...]] = {}


def formulation_key(circuit: Circuit) -> Hashable:
    """What :func:`~netlist.formulation.formulate` reads of a circuit, as a hashable value.

    Every element field but the key (its lower-case name) and, for V and I sources, ``dc``
    and ``waveform``; the models; ``.tran`` without UIC (the switches' initial state then
    comes from an operating point); the file name. Numbers compare as doubles, -0.0 told
    apart from 0.0 (a NaN never equals itself: its circuit is formulated again).
    """
    parts = []
    for el in circuit.elements:
        names = _FIELDS.get(type(el))
        if names is None:
            skip = {"key"} | (_INPUT_FIELDS if el.kind in "VI" else set())
            names = _FIELDS[type(el)] = tuple(f.name for f in fields(el) if f.name not in skip)
        parts.append((el.kind, *[_plain(getattr(el, n)) for n in names]))
    models = tuple(sorted((k, m.type, tuple((name, _plain(v)) for name, v in
                                            sorted(m.params.items())))
                          for k, m in circuit.models.items()))
    from_op = circuit.tran is not None and not circuit.tran.uic
    key = (circuit.file, from_op, models, tuple(parts))
    try:
        hash(key)
    except TypeError:  # a field holding a list or a dict: its text then
        return repr(key)
    return key


def _plain(value):
    # (a location as a tuple: the dataclass's generated repr, once the key, was ten times
    # slower; -0.0 marked: equal to 0.0 as a float)
    if isinstance(value, Location):
        return (value.file, value.line, value.column, value.text)
    if type(value) is float and value == 0.0 and math.copysign(1.0, value) < 0.0:
        return "-0.0"
    return value


def reused_system(circuit: Circuit) -> SwitchedLCS:
    """The switched LCS of ``circuit``: kept from a circuit with the same
    :func:`formulation_key`, or formulated now (and kept).

    Raises
    ------
    NetlistError
        As :func:`~netlist.formulation.formulate` (a failed formulation is not kept).
    """
    # (per thread: a system keeps its mode stacks, which a run changes as it goes)
    key = (threading.get_ident(), formulation_key(circuit))
    with _LOCK:
        kept = _SYSTEMS.get(key)
        if kept is not None:
            _SYSTEMS.move_to_end(key)
            return kept[0]
    # (from a copy: the system builds its modes when first asked, and must not see a later
    # change to the caller's circuit, which another key then stands for)
    system = formulate(_private_copy(circuit))
    with _LOCK:
        _SYSTEMS[key] = (system, len(circuit.elements))
        while len(_SYSTEMS) > 1 and (len(_SYSTEMS) > MAX_SYSTEMS or sum(
                n for _, n in _SYSTEMS.values()) > MAX_ELEMENTS):
            _SYSTEMS.popitem(last=False)
    return system


def _private_copy(circuit: Circuit) -> Circuit:
    """The circuit with its own elements and models (their fields are immutable values)."""
    return replace(circuit, elements=[copy.copy(el) for el in circuit.elements],
                   models={k: replace(m, params=dict(m.params))
                           for k, m in circuit.models.items()})


def kept_with(system: SwitchedLCS, name: Hashable, compute: Callable[[], object]):
    """``compute()``, kept with ``system`` under ``name``: for what depends only on what the
    system was formulated from (its circuit's topology, the values other than the sources').
    Hand out copies of what callers may change."""
    try:
        facts = _FACTS.setdefault(system, {})
    except TypeError:  # not weak-referenceable: not kept
        return compute()
    if name not in facts:
        facts[name] = compute()
    return facts[name]


def clear() -> None:
    """Forget every kept system (and with them what is cached per system)."""
    with _LOCK:
        _SYSTEMS.clear()
