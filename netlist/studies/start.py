"""Where a transient run starts, as ngspice decides it from ``.tran``'s ``UIC``, element
``IC=`` values and ``.ic`` lines.

- With ``UIC`` (or without a ``.tran`` line): from the initial conditions, an element's
  ``IC=`` first; otherwise a capacitor gets ``v(n+) - v(n-)`` from ``.ic v(node)=...`` lines
  (ground is 0 V; a node missing from ``.ic`` counts as 0 V only if the other node is given);
  everything else starts at zero.
- Without ``UIC``: from the DC operating point (capacitors open, inductors shorted, the
  sources at their ``t = 0`` values; :mod:`lcs.theory.operating_point`), computed by the run
  in its initial mode. ngspice ignores element ``IC=`` values then (checked: an RC at 5 V
  DC with ``IC=2`` starts at 5 V), and so does pelcs, with a note. Where the comparators
  have no consistent state at that point (a closed loop that regulates: each state's
  operating point turns them the other way), or there is no point at all, the run starts
  from the initial conditions and a note says why.
- ``.ic`` lines without ``UIC``: ngspice computes the operating point with those nodes held at
  their values (its matrix row of each such node replaced by ``v = value``, or by a 1e10 S
  conductance to the value where a source's or inductor's current enters the node: its KCL
  is dropped, as a voltage source to ground would have it), then releases them for the
  transient; element ``IC=`` values are ignored there too (checked: an RC's ``.ic v(out)=2``
  starts at 2 V and relaxes to the 5 V source, an inductor feeding the held node starts at
  its DC current with the node held). pelcs does the same: the operating point of the
  circuit with a voltage source on each ``.ic`` node (:func:`held_start`). A node that
  voltage sources already tie to ground keeps the sources' value (ngspice's source equation
  holds, its row only sets the source's current), with a note.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from lcs.model import SwitchedLCS
from lcs.simulation.held_point import AuxiliaryPoint, auxiliary_indices
from lcs.simulation.problem import Problem

from ..circuit import GROUND, Capacitor, Circuit, Inductor, VoltageSource, unique_name
from ..errors import NetlistError
from ..formulation import formulate
from ..topology import UnionFind

__all__ = ["held_start", "initial_state", "start_state"]


def start_state(circuit: Circuit, system: SwitchedLCS, notes: list[str]
                ) -> tuple[np.ndarray, bool | AuxiliaryPoint]:
    """The initial state and whether the run starts from the DC operating point instead
    (module docstring); ``notes`` receives what the user should know.

    Returns
    -------
    x0 : ndarray, shape (len(states),)
        A for inductor currents, V for capacitor voltages (with the operating point, the
        values of the states that no DC equation sets: where ngspice's matrix would be
        singular, the IC= value or zero).
    operating_point : bool or AuxiliaryPoint
        True for the operating point of the circuit itself; with ``.ic`` lines, the one of
        the circuit with those nodes held (:func:`held_start`); False for none.
    """
    tran = circuit.tran
    operating_point: bool | AuxiliaryPoint = tran is not None and not tran.uic
    if operating_point and circuit.initial_conditions:
        operating_point = held_start(circuit, system, notes)
    # (with the operating point, the .ic values give only the states no DC equation sets:
    # no note on a node they miss)
    x0 = initial_state(circuit, system.states,
                       None if operating_point and circuit.initial_conditions else notes)
    # (a capacitor that stands for a loop's capacitors carries their initial charge as its
    # IC=, which no one wrote)
    merged = {name.lower() for _, _, name in circuit.loop_capacitors.values()}
    given = [el.name for el in circuit.elements
             if getattr(el, "ic", None) is not None and el.key not in merged]
    if operating_point and given:
        notes.append(f"IC= of {', '.join(given)} ignored where the DC operating point sets "
                     "the state: without UIC ngspice starts from that point, and so does "
                     "pelcs (UIC on the .tran line starts from the IC= values)")
    return x0, operating_point


def held_start(circuit: Circuit, system: SwitchedLCS, notes: list[str]
               ) -> AuxiliaryPoint | bool:
    """ngspice's operating point of a ``.tran`` without ``UIC`` where ``.ic`` lines hold
    nodes (module docstring): that of ``circuit`` with a voltage source from each held node
    to ground, read back into ``system``'s states; True (the circuit's own operating point)
    where voltage sources fix every ``.ic`` node, False (the ``.ic`` values, as with
    ``UIC``) where the circuit with the held nodes cannot be formulated. ``notes`` receives
    what the start is.
    """
    holds, tied, joined = _holds(circuit)
    for node, others in joined.items():
        notes.append(f".ic on {', '.join([node, *others])}: voltage sources join these nodes; "
                     f"pelcs holds v({node}) alone in the operating point, where ngspice holds "
                     "none of them exactly (it shares the differences from their .ic values "
                     "out equally), so the runs differ: UIC on the .tran line starts both "
                     "from the .ic values")
    if tied:
        nodes = ", ".join(tied)
        notes.append(f".ic on {nodes}: voltage sources tie {'it' if len(tied) == 1 else 'them'}"
                     " to ground, and their values hold there in the operating point (as in "
                     "ngspice, whose source equations hold: its .ic row sets only the "
                     "source's current)")
    if not holds:
        return True
    used = {el.key for el in circuit.elements}
    sources = [VoltageSource(unique_name(f"Vic_{node}", used), (node, GROUND), dc=value)
               for node, value in holds.items()]
    held = ", ".join(f"v({node}) = {value:g} V" for node, value in holds.items())
    try:
        aux = formulate(replace(circuit, elements=[*circuit.elements, *sources]))
        probes = tuple(_state_probe(circuit, name) for name in system.states)
        same = ([s.name for s in aux.switches] == [s.name for s in system.switches]
                and list(aux.diodes) == list(system.diodes))
        why = "" if same else "its switches or diodes differ"
    except NetlistError as exc:
        why = exc.message
    if why:
        notes.append(f"pelcs starts from the .ic values (as ngspice with UIC): without UIC "
                     f"ngspice computes the operating point with the .ic nodes held ({held}), "
                     f"and pelcs cannot formulate the circuit with them held ({why})")
        return False
    notes.append(f"DC operating point taken with the .ic nodes held ({held}), as ngspice's "
                 ".tran without UIC takes it: the run starts there with the nodes released, "
                 "unless a note says there is no such point (UIC on the .tran line starts "
                 "from the .ic values)")
    inputs = auxiliary_indices(aux.inputs, system.inputs)
    values = np.zeros(len(aux.inputs))
    for j, name in enumerate(aux.inputs):
        if inputs[j] < 0:
            values[j] = next(s.dc for s in sources if s.name == name)
    return AuxiliaryPoint(Problem(aux, None), inputs, values,
                          auxiliary_indices(aux.states, system.states), probes)


def _holds(circuit: Circuit) -> tuple[dict[str, float], list[str], dict[str, list[str]]]:
    """The ``.ic`` nodes held during the operating point; those voltage sources (V, E, H:
    ngspice's branch equations) tie to ground, which keep the sources' values; and, for a
    held node, the other ``.ic`` nodes voltage sources tie to it (not held: one source
    each would close a loop of sources)."""
    sources = UnionFind()
    for el in circuit.elements:
        if el.kind in ("V", "E", "H"):
            sources.union(el.nodes[0], el.nodes[1])
    root = sources.find
    holds: dict[str, float] = {}
    tied: list[str] = []
    joined: dict[str, list[str]] = {}  # the first held node of a group -> the others
    first: dict[str, str] = {}
    for node, value in circuit.initial_conditions.items():
        r = root(node)
        if r == root(GROUND):
            tied.append(node)
        elif r in first:
            joined[first[r]].append(node)
        else:
            first[r] = node
            joined[node] = []
            holds[node] = value
    return holds, tied, {k: v for k, v in joined.items() if v}


def _state_probe(circuit: Circuit, state: str) -> str:
    """The probe that reads a state (``i(L)``, ``v(C)``) on any circuit with its elements:
    an inductor's current, a capacitor's ``v(n+, n-)``."""
    el = circuit.element(state[2:-1])
    if isinstance(el, Capacitor):
        return f"v({el.nodes[0]},{el.nodes[1]})"
    return state


def initial_state(circuit: Circuit, states: Sequence[str], notes: list[str] | None = None
                  ) -> np.ndarray:
    """Initial state from element ``IC=`` values and ``.ic`` node voltages.

    Parameters
    ----------
    circuit : Circuit
    states : sequence of str
        State names ``i(L1)`` / ``v(C1)`` in the order wanted.
    notes : list of str, optional
        Receives a note for every capacitor whose ``.ic`` names only one of its nodes.

    Returns
    -------
    ndarray, shape (len(states),)
        A for inductor currents, V for capacitor voltages.
    """
    ics = circuit.initial_conditions
    x0 = np.zeros(len(states))
    for k, name in enumerate(states):
        el = circuit.element(name[2:-1])
        if isinstance(el, Inductor):
            x0[k] = el.ic or 0.0
        elif isinstance(el, Capacitor):
            if el.ic is not None:
                x0[k] = el.ic
                continue
            a, b = el.nodes
            if a not in ics and b not in ics:
                continue  # no .ic on either node (ground is never in .ic): starts at 0 V
            va = 0.0 if a == GROUND else ics.get(a)
            vb = 0.0 if b == GROUND else ics.get(b)
            if (va is None or vb is None) and notes is not None:
                missing = a if va is None else b
                notes.append(f"{el.name}: node {missing} has no .ic; taken as 0 V")
            x0[k] = (va or 0.0) - (vb or 0.0)
    return x0
