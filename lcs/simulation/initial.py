"""The initial mode and the initial multipliers of a run, and what is done with an initial state
the diodes cannot accept.

The initial mode starts from the switches' guessed states (netlist ``ON``/``OFF``) with the
source-driven ones set from their controls at ``t_start``; comparators then take the state
their control says at ``(x0, λ0)`` (a fixed point, at most k + 2 rounds), and the Python
controllers give their first commands. λ0 solves the instantaneous LCP
``w = C x0 + D λ + F u(t_start)``; when it has none, the state is inconsistent and either the
caller's ``on_inconsistent`` handler replaces it (a state jump) or the first step absorbs the
jump.
"""

from __future__ import annotations

import threading
import weakref
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..lcp import LcpOptions, solve_lcp
from ..model import LCS, OPERATING_POINT_OPTION, ModeKey
from .held_point import AuxiliaryPoint, mode_point
from .problem import Problem, mode_tuple
from .schedule import Controllers
from .switch_bands import RULE_OFF, RULE_TOGGLE, band_rule
from .switches import SW_SCHEDULED, SWF_LATCH, SwitchPlan, switch_option

InconsistentHandler = Callable[[LCS, np.ndarray, np.ndarray], object]


@dataclass
class InitialState:
    """Where a run starts.

    Attributes
    ----------
    key : int
        Switch key of the initial mode (bit i: switch i on).
    mode : ModeKey
    x : ndarray, shape (n,)
        Initial state (after a jump, if the handler made one).
    lam : ndarray, shape (m,)
        Initial multipliers (zeros when the LCP has no solution).
    active : int
        Bitmask of the pairs whose λ is basic in the LCP solution (0 when none).
    """

    key: int
    mode: ModeKey
    x: np.ndarray
    lam: np.ndarray
    active: int


# Per problem, the consistent initial states of its last runs without controllers, by what
# they depend on (a design loop starts every run from the same state and inputs).
_KEPT: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
_KEPT_PER_PROBLEM = 16
_LOCK = threading.Lock()


#: how the note on a DC operating point that the comparators do not settle at begins; the
#: comparators follow in parentheses (:func:`unsettled_in_note` reads them back)
UNSETTLED_NOTE = "no DC operating point: the comparators"


def unsettled_comparators(keys: list[int]) -> list[int]:
    """The comparators (bit indices) that change within the last cycle of switch keys the
    operating point's rounds visited (every one that changed, where the rounds end before
    a key repeats)."""
    last = keys[-1]
    start = next((i for i in range(len(keys) - 2, -1, -1) if keys[i] == last), 0)
    changed = 0
    for a, b in zip(keys[start:], keys[start + 1:], strict=False):
        changed |= a ^ b
    return [i for i in range(changed.bit_length()) if (changed >> i) & 1]


def unsettled_in_note(notes: list[str]) -> list[str]:
    """The comparators a run's note on its unsettled DC operating point names ([] where the
    run has no such note)."""
    for note in notes:
        if note.startswith(UNSETTLED_NOTE + " ("):
            inside = note[len(UNSETTLED_NOTE) + 2:].split(")", 1)[0]
            return [n.strip() for n in inside.split(",") if n.strip()]
    return []


def initial_state(problem: Problem, plan: SwitchPlan, mode_src: ModeKey, src_maps: dict,
                  base: ModeKey, x0: np.ndarray, u0: np.ndarray, t_start: float,
                  controllers: Controllers, on_inconsistent: InconsistentHandler | None,
                  lcp: LcpOptions, notes: list[str],
                  operating_point: bool | AuxiliaryPoint = False
                  ) -> InitialState:
    """The initial mode, state and multipliers (see the module docstring); notes about an
    inconsistent initial state are appended to ``notes``. With ``operating_point``, the state
    is the DC operating point of the mode (which the comparators then read, to a fixed point
    of both), ``x0`` only giving the states that no DC equation sets; an
    :class:`~lcs.simulation.held_point.AuxiliaryPoint` takes it from its auxiliary system's
    (a circuit's ``.ic`` nodes held during it).

    ``mode_src``, ``src_maps`` and ``base`` (the guessed switch states) come from the run's
    :class:`~lcs.simulation.schedule.RunPlan` (see :meth:`Problem.control_rows`).
    """
    if controllers or plan.surface:
        return _initial_state(problem, plan, mode_src, src_maps, base, x0, u0, t_start,
                              controllers, on_inconsistent, lcp, notes, operating_point)
    # (without controllers the result is a function of these values: the problem's mode
    # arrays and control rows are its system's, kept with it)
    x = np.asarray(x0, dtype=float)
    u = np.asarray(u0, dtype=float)
    key = (tuple(mode_src), tuple(base), plan.kind.tobytes(), plan.flags.tobytes(),
           plan.vt.tobytes(), plan.vh.tobytes(), tuple(plan.source), x.shape, x.tobytes(),
           u.shape, u.tobytes(), lcp, operating_point)
    try:
        kept = _KEPT.setdefault(problem, {})
    except TypeError:  # not weak-referenceable: not kept
        kept = None
    found = None if kept is None else kept.get(key)
    if found is None:
        n_notes = len(notes)
        found = _initial_state(problem, plan, mode_src, src_maps, base, x, u, t_start,
                               controllers, on_inconsistent, lcp, notes, operating_point)
        if kept is None or len(notes) != n_notes:
            return found  # (notes: said again every run)
        with _LOCK:
            while len(kept) >= _KEPT_PER_PROBLEM:
                kept.pop(next(iter(kept)))
            kept[key] = found
    # (copies: a run changes its state where a mode pins it)
    return InitialState(found.key, found.mode, found.x.copy(), found.lam.copy(), found.active)


def _initial_state(problem: Problem, plan: SwitchPlan, mode_src: ModeKey, src_maps: dict,
                   base: ModeKey, x0: np.ndarray, u0: np.ndarray, t_start: float,
                   controllers: Controllers, on_inconsistent: InconsistentHandler | None,
                   lcp: LcpOptions, notes: list[str],
                   operating_point: bool | AuxiliaryPoint = False
                   ) -> InitialState:
    k = problem.k
    m = len(problem.system.diodes)
    key = sum(1 << i for i, on in enumerate(mode_src) if on)
    x = np.array(x0, dtype=float)
    point = None

    def dc(key):
        """The operating point of a mode, or None (x0 kept) where it has none."""
        nonlocal x, point
        mode = mode_tuple(key, k)
        if isinstance(operating_point, AuxiliaryPoint):
            point = operating_point(mode, u0, x0, lcp)
        else:
            point = mode_point(problem, mode, u0, x0, lcp)
        x = point.x.copy() if point.ok else np.array(x0, dtype=float)

    def initial_lcp(key):
        if not m:
            return None
        _, _, Cm, Dm, _, Fm = problem.mode_arrays(mode_tuple(key, k))
        return solve_lcp(Dm, Cm @ x + Fm @ u0, lcp)

    comparators = [i for i in range(k) if plan.kind[i] != SW_SCHEDULED]
    switches = problem.system.switches
    settled = not comparators
    res0 = None
    lam = np.zeros(m)
    keys = [key]  # (the keys the rounds visit: an unsettled one ends in a cycle of them)
    for _ in range(k + 2):
        mode = mode_tuple(key, k)
        Cc, Dc, Fc = problem.control_rows(mode, plan, src_maps, base)
        if operating_point:
            dc(key)
        res0 = initial_lcp(key)
        lam = res0.z.copy() if (res0 is not None and res0.ok) else np.zeros(m)
        if not comparators:
            break
        c = Cc @ x + Dc @ lam + Fc @ u0
        new = key
        for i in comparators:
            on = bool((key >> i) & 1)
            if plan.flags[i] & SWF_LATCH:
                on = c[i] >= plan.vt[i] - plan.vh[i]
            elif c[i] > plan.vt[i] + plan.vh[i]:
                on = True
            elif c[i] < plan.vt[i] - plan.vh[i]:
                on = False
            elif i not in plan.surface:
                # inside the band, ngspice's rule at the start (switch_bands.initial_sub):
                # a VH <= 0 switch of a run from the operating point on, an idealised
                # transistor off, a VH > 0 switch as it is
                rule = band_rule(switches[i])[2]
                if rule == RULE_OFF:
                    on = False
                elif rule == RULE_TOGGLE and switch_option(switches[i].options,
                                                           OPERATING_POINT_OPTION):
                    on = True
            new = (new | (1 << i)) if on else (new & ~(1 << i))
        if new == key:
            settled = True
            break
        key = new
        keys.append(key)
    if operating_point and not settled:
        # each mode's operating point turns the comparators to another (a closed loop that
        # regulates has no DC point with ideal comparators): the start without it
        names = ", ".join(switches[i].name for i in unsettled_comparators(keys))
        notes.append(f"{UNSETTLED_NOTE} ({names}) have no consistent state there "
                     "(each mode's operating point turns them to another, as in a closed loop "
                     "that regulates): the run starts from the initial conditions, as ngspice "
                     "with UIC")
        return _initial_state(problem, plan, mode_src, src_maps, base, x0, u0, t_start,
                              controllers, on_inconsistent, lcp, notes)
    if controllers:
        key = controllers.commands(controllers.ctrls, t_start, key, x, lam, u0, -1, 0.0)
        problem.control_rows(mode_tuple(key, k), plan, src_maps, base)
        if operating_point:
            dc(key)
        res0 = initial_lcp(key)
        lam = res0.z.copy() if (res0 is not None and res0.ok) else np.zeros(m)
    mode = mode_tuple(key, k)
    if point is not None and not point.ok:
        states = problem.system.states
        free = ", ".join(states[i] for i in np.flatnonzero(point.free))
        # (where the reason proves nothing, the note says only that pelcs found none: a
        # capacitor that only diodes reach, whose leakage ngspice balances)
        found = "no DC operating point" if point.proved else "pelcs finds no DC operating point"
        notes.append(f"{found} ({point.reason}"
                     + (f"; the states the DC equations leave free: {free}" if free else "")
                     + "): the run starts from the initial conditions, as ngspice with UIC")
    elif point is not None and point.free.any():
        # (a state the mode holds at zero, an inductor an open switch leaves with no path,
        # is zero in ngspice too, through ROFF: not said)
        free = point.free.copy()
        if problem.system.pinnable:
            free[list(problem.system.pinned(mode))] = False
        if free.any():
            notes.append(_free_note(problem, free, x))
    if res0 is not None and not res0.ok:
        if on_inconsistent is not None:
            handled = on_inconsistent(problem.lcs(mode), x.copy(), u0.copy())
            note = None
            if isinstance(handled, tuple):  # (x_plus, note): the handler explains itself
                handled, note = handled
            x_new = np.asarray(handled, dtype=float)
            if x_new.shape != x.shape or not np.all(np.isfinite(x_new)):
                raise ValueError(
                    f"on_inconsistent returned {x_new!r}; expected a finite state of shape "
                    f"{x.shape}"
                )
            notes.append(note or (
                f"initial state {np.array2string(x, precision=6)} is inconsistent (the LCP "
                f"w = C x + D λ + F u at t = {t_start:g} s has no solution); replaced by "
                f"{np.array2string(x_new, precision=6)} (on_inconsistent)"
            ))
            x = x_new
            res0 = initial_lcp(key)
        if not res0.ok:
            notes.append(
                f"initial state is inconsistent (the LCP w = C x + D λ + F u at "
                f"t = {t_start:g} s has no solution): λ(t0) is reported as 0 and the first "
                "step absorbs the state jump"
            )
    lam = res0.z.copy() if (res0 is not None and res0.ok) else np.zeros(m)
    active = 0
    if res0 is not None and res0.ok and res0.basis is not None:
        active = int(sum(1 << int(i) for i in np.flatnonzero(res0.basis)))
    return InitialState(key, mode, x, lam, active)


def _free_note(problem: Problem, free: np.ndarray, x: np.ndarray) -> str:
    """What the start does with the states no DC equation of the initial mode sets (and no
    open switch's ROFF reaches)."""
    states = problem.system.states
    named = ", ".join(f"{states[i]} = {x[i]:.6g}" for i in np.flatnonzero(free))
    return (f"DC operating point: the DC equations of the initial mode leave free (a "
            "combination of) the states reached only through capacitors, inductors or "
            f"blocking diodes, here {named}: they keep the charges and fluxes of the initial "
            "conditions. ngspice's operating point finds its matrix singular there (or sets "
            "them through the diodes' leakage), so the runs may differ: UIC on the .tran line "
            "starts both from the initial conditions")
