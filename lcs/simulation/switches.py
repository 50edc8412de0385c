"""How each switch of a run is driven (``docs/switching.md``): by sources, by a Python
controller, or by its comparator (implicit, hysteresis, explicit or latched)."""

from __future__ import annotations

import weakref
from dataclasses import dataclass, field

import numpy as np

from ..model import ModeKey, SwitchedLCS

# Switch kinds (what drives it) and flags.
from .codes import (  # noqa: F401  (kernel codes)
    SW_LOCATED,
    SW_SAMPLED,
    SW_SCHEDULED,
    SWF_LATCH,
    SWF_RELAY,
)

SWITCHING_METHODS = ("auto", "implicit", "hysteresis", "explicit")


def initially_on(options) -> bool:
    """A switch's netlist ``ON``/``OFF`` (``options["initial"]`` or ``options["on"]``)."""
    val = switch_option(options, "initial", switch_option(options, "on"))
    return bool(val) if val is not None else False


def switch_option(options, name: str, default=None):
    """A switch option (its ``.model`` parameter) by case-insensitive name."""
    if not isinstance(options, dict):
        return default
    for key, val in options.items():
        if str(key).lower() == name:
            return val
    return default


@dataclass
class SwitchPlan:
    """How each switch of a run is driven (see ``docs/switching.md``)."""

    names: tuple[str, ...]
    kind: np.ndarray  # int64 (k,): SW_*
    flags: np.ndarray  # int64 (k,): SWF_*
    vt: np.ndarray  # (k,)
    vh: np.ndarray  # (k,)
    method: list[str]  # per switch: source, controller, implicit, hysteresis, explicit, latched
    source: list[int] = field(default_factory=list)
    scheduled_by: dict = field(default_factory=dict)  # switch index -> schedule controller
    surface: dict = field(default_factory=dict)  # switch index -> surface controller
    latch: dict = field(default_factory=dict)  # switch index -> (period, phase)

    @property
    def source_mask(self) -> int:
        return sum(1 << i for i in self.source)

    def copy(self) -> SwitchPlan:
        """A plan with its own arrays, lists and dicts (the controllers shared)."""
        return SwitchPlan(self.names, self.kind.copy(), self.flags.copy(), self.vt.copy(),
                          self.vh.copy(), list(self.method), list(self.source),
                          dict(self.scheduled_by), dict(self.surface), dict(self.latch))


# Per system, the plans without controllers and their notes, by method and guess: a system's
# switches and output maps do not change, and a design loop asks for the same plan every run.
_PLANS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def classify_switches(system: SwitchedLCS, controllers, method: str, guess: ModeKey,
                      notes: list[str]) -> SwitchPlan:
    """Kind, flags, thresholds and method of every switch.

    Parameters
    ----------
    system : SwitchedLCS
    controllers : sequence
        Python controllers (:mod:`lcs.controllers`): schedule controllers drive the switches
        they name, surface controllers define a switch's comparator.
    method : str
        One of :data:`SWITCHING_METHODS`, for the comparators without a method of their own.
    guess : ModeKey
        The initial switch states, in which a control's dependence on the state is judged.
    notes : list of str
        Receives what the user should know (an ignored hysteresis).
    """
    if method not in SWITCHING_METHODS:
        raise ValueError(f"switching must be one of {', '.join(SWITCHING_METHODS)}, got "
                         f"{method!r}")
    if controllers:
        return _classify(system, controllers, method, guess, notes)
    try:
        per_system = _PLANS.setdefault(system, {})
    except TypeError:  # not weak-referenceable: not kept
        return _classify(system, controllers, method, guess, notes)
    key = (method, tuple(bool(on) for on in guess))
    kept = per_system.get(key)
    if kept is None:
        kept_notes: list[str] = []
        plan = _classify(system, (), method, guess, kept_notes)
        kept = per_system[key] = (plan, tuple(kept_notes))
    notes.extend(kept[1])
    return kept[0].copy()


def _classify(system: SwitchedLCS, controllers, method: str, guess: ModeKey,
              notes: list[str]) -> SwitchPlan:
    sw = system.switches
    k = len(sw)
    lower = {s.name.lower(): i for i, s in enumerate(sw)}
    out = SwitchPlan(tuple(s.name for s in sw), np.zeros(k, np.int64), np.zeros(k, np.int64),
                    np.array([float(s.vt) for s in sw]),
                    np.array([abs(float(s.vh)) for s in sw]), [""] * k)
    for ctrl in controllers:
        names = [ctrl.switch] if getattr(ctrl, "kind", "schedule") == "surface" \
            else list(ctrl.switches)
        for nm in names:
            if nm.lower() not in lower:
                raise KeyError(f"controller {type(ctrl).__name__}: no switch {nm!r} (switches: "
                               f"{', '.join(s.name for s in sw) or 'none'})")
            i = lower[nm.lower()]
            if i in out.scheduled_by or i in out.surface:
                raise ValueError(f"switch {sw[i].name} is driven by two controllers")
            if getattr(ctrl, "kind", "schedule") == "surface":
                out.surface[i] = ctrl
            else:
                out.scheduled_by[i] = ctrl
    by_sources = _driven_by_sources(system, guess, out)
    for i, s in enumerate(sw):
        if i in out.scheduled_by:
            out.kind[i] = SW_SCHEDULED
            out.method[i] = "controller"
            continue
        if i in out.surface:
            ctrl = out.surface[i]
            out.vt[i] = -float(getattr(ctrl, "constant", 0.0))
            out.vh[i] = abs(float(getattr(ctrl, "vh", 0.0)))
            sw_method = getattr(ctrl, "method", None) or method
            explicit_flag = sw_method == "explicit"
            latch = None
        else:
            if i in by_sources:
                out.kind[i] = SW_SCHEDULED
                out.method[i] = "source"
                out.source.append(i)
                continue
            sw_method = method
            explicit_flag = bool(switch_option(s.options, "explicit", 0))
            latch = switch_option(s.options, "latch", 0)
        if latch:
            period = float(switch_option(s.options, "period", 0.0) or 0.0)
            if not period > 0:
                raise ValueError(f"switch {s.name}: LATCH=1 needs PERIOD=<the clock period> "
                                 "on its .model line")
            phase = float(switch_option(s.options, "phase", 0.0) or 0.0)
            out.latch[i] = (period, phase)
            out.kind[i] = SW_LOCATED
            out.flags[i] = SWF_LATCH
            out.method[i] = "latched"
            continue
        if sw_method == "auto":
            if explicit_flag:
                sw_method = "explicit"
            elif out.vh[i] > 0:
                sw_method = "hysteresis"
            else:
                sw_method = "implicit"
        if sw_method == "explicit":
            out.kind[i] = SW_SAMPLED
        elif sw_method == "hysteresis":
            out.kind[i] = SW_LOCATED
        else:  # implicit
            out.kind[i] = SW_LOCATED
            out.flags[i] = SWF_RELAY
            if out.vh[i] > 0:
                notes.append(f"switch {s.name}: switching='implicit' ignores its hysteresis "
                             f"(VH = {out.vh[i]:g})")
                out.vh[i] = 0.0
        out.method[i] = sw_method
    return out


def _driven_by_sources(system: SwitchedLCS, guess: ModeKey, plan: SwitchPlan) -> set[int]:
    """The switches whose instants can be computed from the sources before stepping: their
    control does not depend on the state in ``guess``, nor on the state of a switch that is
    not itself driven by sources.

    A gate that a comparator drives through a resistor (a B source's output into a gate
    resistor and a pull-down) reads no state, but its value changes when that comparator
    switches: it is not known before stepping. Such a switch is a comparator of its own (its
    control is located like any other, and jumps with the mode), here found by flipping each
    switch not driven by sources in ``guess`` and comparing the control's rows (repeated until
    no more switch leaves the set, since a gate may in turn depend on such a switch). Rows that
    change only with combinations of several switches are caught when the run checks the
    rows in each mode it enters (an error there, not a wrong instant).
    """
    sw = system.switches
    k = len(sw)
    candidates = set()
    for i, s in enumerate(sw):
        if i in plan.scheduled_by or i in plan.surface:
            continue
        if not reads_state(system.outputs(guess, [s.control])).any():
            candidates.add(i)
    changed = True
    while changed:
        changed = False
        drivers = [j for j in range(k) if j not in candidates]
        for i in sorted(candidates):
            if _gate_moves_with(system, guess, sw[i].control, drivers):
                candidates.discard(i)
                changed = True
    return candidates


def _gate_moves_with(system: SwitchedLCS, guess: ModeKey, control: str,
                     drivers: list[int]) -> bool:
    """Whether ``control``'s rows in ``guess`` change when one of ``drivers`` is flipped (or
    read the state there). A flipped configuration the circuit cannot be in (its formulation
    fails) tells nothing."""
    ref = np.asarray(system.outputs(guess, [control]).Fy, dtype=float)
    for j in drivers:
        mode = tuple(not on if q == j else on for q, on in enumerate(guess))
        try:
            om = system.outputs(mode, [control])
        except Exception:  # noqa: BLE001  (an impossible configuration: no information)
            continue
        if reads_state(om).any() or not same_input_rows(np.asarray(om.Fy, dtype=float),
                                                        ref).all():
            return True
    return False


def reads_state(om) -> np.ndarray:
    """Per row of an output map: whether it reads the state (``Cy`` or ``Dy`` not zero)."""
    return (np.any(np.asarray(om.Cy) != 0, axis=-1) | np.any(np.asarray(om.Dy) != 0, axis=-1))


def same_input_rows(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Per row, whether two blocks of input rows (shape (q, p) or (p,)) are equal to
    round-off (each mode's rows come from its own solve: relative 1e-12, zeros exact), a
    missing trailing input column read as zero (a mode's output map may omit inputs that only
    other modes use)."""
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    w = max(a.shape[1], b.shape[1])
    a = np.pad(a, ((0, 0), (0, w - a.shape[1])))
    b = np.pad(b, ((0, 0), (0, w - b.shape[1])))
    if np.array_equal(a, b):  # (the usual case; isclose was 0.3 ms a mode)
        return np.ones(a.shape[0], bool)
    return np.isclose(a, b, rtol=1e-12, atol=0.0).all(axis=1)
