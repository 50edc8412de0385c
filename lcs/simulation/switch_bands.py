"""The band rule of a switch's control (ngspice's SW model, ``swload.c``): where the control
is relative to the band ``[VT - |VH|, VT + |VH|]``, and the switch's sub-state (off or on, and
whether inside the band) as the control moves. Shared by the source-driven planner's compiled
path (:mod:`lcs.simulation.source_switching`, whose kernel writes the same values) and its
general path (:mod:`lcs.simulation.source_general`).
"""

from __future__ import annotations

from ..model import IDEALISED_OPTION, OPERATING_POINT_OPTION

__all__ = ["ABOVE", "BELOW", "IN", "RULE_KEEP", "RULE_OFF", "RULE_TOGGLE", "SUB_BAND_OFF",
           "SUB_BAND_ON", "SUB_OFF", "SUB_ON", "band_rule", "enter", "initial_sub",
           "initially_on", "region_of", "sub_on"]


def initially_on(options) -> bool:
    """The netlist's ``ON``/``OFF`` of a switch (``options["initial"]``, or ``options["on"]``),
    off by default as in ngspice."""
    if not isinstance(options, dict):
        return False
    val = options.get("initial", options.get("on"))
    return bool(val) if val is not None else False


# Where a control is, relative to a switch's band [lo, hi] (see band_rule).
BELOW, IN, ABOVE = 0, 1, 2


def region_of(c: float, lo: float, hi: float) -> int:
    """:data:`BELOW`, :data:`IN` or :data:`ABOVE` the band ``[lo, hi]`` (V)."""
    return BELOW if c < lo else (ABOVE if c > hi else IN)


def enter(sub: int, region: int, rule: int) -> int:
    """The sub-state (``SUB_*``) of a switch whose control enters ``region``."""
    if region == ABOVE:
        return SUB_ON
    if region == BELOW:
        return SUB_OFF
    if sub >= SUB_BAND_OFF:
        return sub
    if rule == RULE_KEEP:
        return sub + 2
    if rule == RULE_TOGGLE:
        return 3 - sub
    return SUB_BAND_OFF


def sub_on(sub: int) -> bool:
    """Whether the switch of sub-state ``sub`` is on."""
    return sub == SUB_ON or sub == SUB_BAND_ON


# How a switch behaves inside its band (see band_rule), and its sub-states: off below the band,
# on above it, off or on inside it. The compiled source_switching._linear_switch_events writes
# these values.
RULE_KEEP, RULE_TOGGLE, RULE_OFF = 0, 1, 2
SUB_OFF, SUB_ON, SUB_BAND_OFF, SUB_BAND_ON = 0, 1, 2, 3


def band_rule(sw) -> tuple[float, float, int]:
    """The band ``[lo, hi]`` (V) of a switch's control and what the switch does inside it, as
    ngspice's SW model (``swload.c``) decides at every time point:

    * above ``hi`` it is on, below ``lo`` off;
    * ``VH > 0``: ``lo, hi = VT - VH, VT + VH``, and inside the band it keeps its state
      (:data:`RULE_KEEP`);
    * ``VH <= 0`` (ngspice's default ``VH = 0`` included): ``lo, hi = VT - |VH|, VT + |VH|``,
      and a control entering the band from below turns the switch on, from above off; it then
      keeps that state while the control stays in the band (:data:`RULE_TOGGLE`). So with
      ``VH = 0`` a gate falling to exactly ``VT`` (``PULSE(0 1 ...)`` and ``VT = 0``) turns the
      switch off, and a gate rising to exactly ``VT`` turns it on;
    * an idealised transistor (option :data:`IDEALISED_OPTION`): on only while the control
      exceeds ``VT`` (:data:`RULE_OFF`, ``lo = hi = VT``), as the device it stands for.
    """
    vt, vh = float(sw.vt), float(sw.vh)
    opts = sw.options if isinstance(sw.options, dict) else {}
    if opts.get(IDEALISED_OPTION):
        return vt, vt, RULE_OFF
    if vh > 0:
        return vt - vh, vt + vh, RULE_KEEP
    return vt - abs(vh), vt + abs(vh), RULE_TOGGLE


def initial_sub(c: float, sw) -> int:
    """The sub-state of a switch whose control is ``c`` (V) at the start of a run: on above the
    band, off below it; inside it, the netlist's ``ON``/``OFF`` (default off), except that an
    idealised transistor is off, and a ``VH <= 0`` switch of a run from ngspice's operating
    point (option :data:`OPERATING_POINT_OPTION`) is on: ngspice's operating point takes the
    switch's state before the analysis as off and its control as entering the band from
    below."""
    lo, hi, rule = band_rule(sw)
    region = region_of(c, lo, hi)
    if region != IN:
        return SUB_ON if region == ABOVE else SUB_OFF
    opts = sw.options if isinstance(sw.options, dict) else {}
    if rule == RULE_OFF:
        return SUB_BAND_OFF
    if rule == RULE_TOGGLE and opts.get(OPERATING_POINT_OPTION):
        return SUB_BAND_ON
    return SUB_BAND_ON if initially_on(opts) else SUB_BAND_OFF
