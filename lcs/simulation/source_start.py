"""The states of the source-driven switches at the start of a run from their controls' values
at the start itself, where the operating point takes its sources (a gate source that jumps at
``t_start`` is before its jump there, as in ngspice's operating point)."""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import contextmanager

import numpy as np

from ..model import OPERATING_POINT_OPTION, ModeKey, SwitchedLCS
from .inputs import InputFunction, evaluate_inputs
from .source_switching import _ControlMaps
from .switch_bands import (
    BELOW,
    IN,
    RULE_OFF,
    RULE_TOGGLE,
    SUB_BAND_OFF,
    SUB_BAND_ON,
    band_rule,
    initial_sub,
    initially_on,
    region_of,
    sub_on,
)

__all__ = ["kept_in_band", "source_mode_at"]


def source_mode_at(system: SwitchedLCS, inputs: Sequence[InputFunction], t: float,
                   which: Sequence[int], base: ModeKey, maps_out: dict,
                   side: int = 0) -> ModeKey:
    """The states of the source-driven switches ``which`` at ``t`` from their controls there
    (``side`` 0: the values at ``t`` itself; +1: just after, as
    :func:`~lcs.simulation.source_switching.source_switch_events` takes them), the others
    as in ``base``; ``maps_out`` receives the control rows of the modes visited."""
    sw = system.switches
    active = frozenset(which)
    maps = _ControlMaps(system, maps_out, active)
    u = evaluate_inputs(inputs, np.array([t]), side)[0]
    mode = tuple(initially_on(s.options) if i in active else bool(base[i])
                 for i, s in enumerate(sw))
    subs = [SUB_BAND_ON if on else SUB_BAND_OFF for on in mode]
    # (mode-dependent control maps: to a fixed point, as source_switch_events does)
    for _ in range(len(sw) + 1):
        c = maps.rows(mode) @ u
        subs = [initial_sub(float(c[i]), sw[i]) if i in active else subs[i]
                for i in range(len(sw))]
        new = tuple(sub_on(subs[i]) if i in active else mode[i] for i in range(len(sw)))
        if new == mode:
            break
        mode = new
    return mode


@contextmanager
def kept_in_band(system: SwitchedLCS, inputs: Sequence[InputFunction], t: float,
                 which: Sequence[int], mode_op: ModeKey):
    """While open: each source-driven switch of ``which`` whose control just after ``t`` is
    inside its band starts there in the state the operating point ``mode_op`` leads it to
    (its netlist ``ON``/``OFF`` set to it), not in its netlist's.

    A band keeps the state the switch had before it (``VH > 0``): a gate at 5 V at the
    operating point, 3 V just after, of a switch at VT 2.5 V, VH 1 V, is on and stays on
    (ngspice 39), where the netlist's default would have it off from the first step. With
    ``VH < 0`` the band turns the switch off when its control enters it from above, on from
    below: the same gate with VH -1 V turns it off at once (ngspice 39), where a control
    inside the band at the start is otherwise taken as entered from below.
    """
    sw = system.switches
    u_op, u = (evaluate_inputs(inputs, np.array([t]), side)[0] for side in (0, +1))
    maps = _ControlMaps(system, {}, frozenset(which)).rows(tuple(mode_op))
    c_op, c = maps @ u_op, maps @ u
    saved = []
    for i in which:
        lo, hi, rule = band_rule(sw[i])
        opts = sw[i].options
        if (rule == RULE_OFF or not isinstance(opts, dict)
                or region_of(float(c[i]), lo, hi) != IN):
            continue
        state, before = bool(mode_op[i]), region_of(float(c_op[i]), lo, hi)
        if rule == RULE_TOGGLE and before != IN:
            state = before == BELOW
        saved.append((opts, dict(opts)))
        opts.pop(OPERATING_POINT_OPTION, None)
        opts["initial"] = state
    try:
        yield
    finally:
        for opts, old in reversed(saved):
            opts.clear()
            opts.update(old)
