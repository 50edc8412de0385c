"""The states of the source-driven switches at the start of a run from their controls' values
at the start itself, where the operating point takes its sources (a gate source that jumps at
``t_start`` is before its jump there, as in ngspice's operating point)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..model import ModeKey, SwitchedLCS
from .inputs import InputFunction, evaluate_inputs
from .source_switching import _ControlMaps
from .switch_bands import SUB_BAND_OFF, SUB_BAND_ON, initial_sub, initially_on, sub_on

__all__ = ["source_mode_at"]


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
