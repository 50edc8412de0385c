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
  their values. pelcs does not: it starts from the ``.ic`` values (as with ``UIC``) and a
  note says so.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..circuit import GROUND, Capacitor, Circuit, Inductor

__all__ = ["initial_state", "start_state"]


def start_state(circuit: Circuit, states: Sequence[str], notes: list[str]
                ) -> tuple[np.ndarray, bool]:
    """The initial state and whether the run starts from the DC operating point instead
    (module docstring); ``notes`` receives what the user should know.

    Returns
    -------
    x0 : ndarray, shape (len(states),)
        A for inductor currents, V for capacitor voltages (with the operating point, the
        values of the states that no DC equation sets: where ngspice's matrix would be
        singular, the IC= value or zero).
    operating_point : bool
    """
    tran = circuit.tran
    x0 = initial_state(circuit, states, notes)
    operating_point = tran is not None and not tran.uic and not circuit.initial_conditions
    if operating_point:
        given = [el.name for el in circuit.elements if getattr(el, "ic", None) is not None]
        if given:
            notes.append(f"IC= of {', '.join(given)} ignored where the DC operating point sets "
                         "the state: without UIC ngspice starts from that point, and so does "
                         "pelcs (UIC on the .tran line starts from the IC= values)")
    elif tran is not None and not tran.uic:
        notes.append("pelcs starts from the .ic values (as ngspice with UIC); without UIC "
                     "ngspice computes a DC operating point with the .ic nodes held at them")
    return x0, operating_point


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
