"""Discrete-time maps of switched LCS: stroboscopic (Poincaré) and event maps.

A periodically driven converter is studied through a map ``x_{k+1} = P(x_k)``:

* :class:`StroboscopicMap` samples the state once per period T of the drive (PWM gate,
  sawtooth ramp): ``P(x) = x(t0 + T)`` from ``x(t0) = x``. The sources must be T-periodic
  from ``t0`` on (a check is made and reported in :attr:`StroboscopicMap.notes`).
* :class:`EventMap` samples at an event: a switch turning on or off, a diode starting or
  ceasing to conduct, a probe crossing a level. Its state is ``(x, phase)`` with ``phase``
  the event time modulo T (s), since the section is crossed at varying instants.
* :class:`FunctionMap` wraps any Python function, so that the analysis cores (orbits,
  continuation, bifurcation sweeps, cell mapping) can be tested on maps with known answers.

Every map is evaluated by :func:`lcs.integrators.moreau.integrator.simulate`; a map is built for one
parameter value (the system is formulated once and its modes are cached by the
:class:`~lcs.model.SwitchedLCS`). Many periods are simulated in one ``simulate`` call with
the instants ``t0 + k T`` as breakpoints and ``save_at`` points, so that exactly the period
samples are stored (no Python work per period). Should a run lack a period sample, it is
repeated storing every step and the samples are picked by time.

The map of a time-stepping scheme is the *discrete* map: its fixed points and multipliers
converge to those of the circuit with the order of the scheme as ``h`` shrinks.

This module gathers the names of the modules that implement them, one concept each:

========================  =================================================================
:mod:`.base`              :class:`Map` (the interface), :class:`MapError`, :class:`Samples`,
                          :class:`FunctionMap`
:mod:`.jacobians`         :func:`central_jacobian`, :func:`section_jacobian`
:mod:`.patterns`          :class:`SwitchingPattern`, :class:`PatternSegment`,
                          :func:`switching_pattern`
:mod:`.lcs_map`           :class:`LcsMapBase` (system, sources, stepper)
:mod:`.stroboscopic`      :class:`StroboscopicMap`
:mod:`.event_map`         :class:`EventMap`, :class:`EventSpec`
========================  =================================================================
"""

from __future__ import annotations

from .base import FunctionMap, Map, MapError, Samples
from .event_map import EventMap, EventSpec
from .jacobians import central_jacobian, section_jacobian
from .lcs_map import LcsMapBase
from .patterns import PatternSegment, SwitchingPattern, switching_pattern
from .stroboscopic import StroboscopicMap

__all__ = [
    "EventMap",
    "EventSpec",
    "FunctionMap",
    "LcsMapBase",
    "Map",
    "MapError",
    "PatternSegment",
    "Samples",
    "StroboscopicMap",
    "SwitchingPattern",
    "central_jacobian",
    "section_jacobian",
    "switching_pattern",
]
