"""Compiled kernel of the Moreau θ time-stepping of a switched LCS (numba).

One call of :func:`run_grid` advances the state over a chunk of the time grid, through any
number of switch-mode changes, without returning to Python except when it needs a mode whose
matrices are not built yet (``STEP_NEED_MODE``), when an output buffer is full
(``STEP_FULL``), or on failure. The Moreau integrator (:mod:`lcs.integrators.moreau.integrator`)
builds the grid, the inputs on it, the schedule of known switching instants, and the per-mode
matrices, stacked by mode id (:class:`~lcs.integrators.moreau.dense.layout.ModeStack`).

One concept per module:

========================  ==================================================================
:mod:`.layout`            return codes, the ``ivars``/``fvars`` layouts, the typed containers
:mod:`.discretise`        θ discretisation: stored matrices of the regular step, free state of
                          a step of any length
:mod:`.step`              one θ step of one mode: free state, the step's LCP
                          (:mod:`lcs.lcp.compiled`), impulse
:mod:`.sliding`           the Filippov relay of a sliding switch (two modes per step)
:mod:`.comparators`       switch controls and crossing functions
:mod:`.locate`            the switching instant inside a step
:mod:`.store`             probe rows and event records
:mod:`.grid`              :func:`run_grid`, the loop over a grid chunk
========================  ==================================================================

Switches (``SwitchArrays.kind``):

* ``SW_SCHEDULED`` -- driven by independent sources or by a Python controller: their instants
  are known in advance and come as a schedule of grid indices (the grid lands on them).
* ``SW_LOCATED`` -- comparators ``c = Cc x + Dc λ + Fc u`` evaluated after each step; a
  crossing of the threshold (``vt + vh`` upwards for an off switch, ``vt - vh`` downwards for
  an on switch) inside the step is located (:mod:`.locate`), the step is split there, the mode
  changes and the rest of the step is taken in the new mode. With ``SWF_LATCH`` an off switch
  does not turn on (only the schedule's period starts re-arm it). With ``SWF_RELAY``, a switch
  that toggles without progress (the trajectory is on an attractive switching surface) enters
  sliding mode (:mod:`.sliding`) until the on-fraction saturates at 0 or 1 with the surface
  left.
* ``SW_SAMPLED`` -- comparators sampled at the end of each grid step (explicit method); the
  new state applies from that instant.
"""

from __future__ import annotations

from .discretise import Discretisation, discretise, discretise_nb
from .grid import run_grid
from .layout import (
    Chunk,
    Limits,
    ModeArrays,
    ModeStack,
    Schedule,
    State,
    Store,
    SwitchArrays,
)

__all__ = [
    "Chunk",
    "Discretisation",
    "Limits",
    "ModeArrays",
    "ModeStack",
    "Schedule",
    "State",
    "Store",
    "SwitchArrays",
    "discretise",
    "discretise_nb",
    "run_grid",
]
