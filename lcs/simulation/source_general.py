"""The source-driven planner's general path: switching instants of switches driven by sources
whose control rows depend on the switch states (a gate fed through another switch, a B
comparator's output that drives a load), or whose sources are not piecewise linear.

Per segment between two source breakpoints, each switch's control is a known function of time
in the current mode; the planner moves, one instant at a time, the switches whose control
leaves the region (below, inside or above its band, :mod:`lcs.simulation.switch_bands`) their
sub-state says, which changes the mode and so the other controls. A control that *jumps* over
its band (a source's jump at a breakpoint: a PULSE edge, a PWL step, a sawtooth's reset; or a
mode change: the gate's source switched in) moves its switch to the side of its value just
after the jump (its right limit), and the crossings inside the segment are then located as
usual: so a control that jumps over the threshold and crosses back within the segment gives
both switchings.

Termination: at one instant the planner's state (mode, sub-states, the switches just moved)
never repeats (a repetition is a loop of switches that switch each other in zero time,
refused by name), and the iterations within a merge tolerance of one instant are bounded.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from .switch_bands import (
    ABOVE,
    BELOW,
    IN,
    SUB_OFF,
    SUB_ON,
    band_rule,
    enter,
    sub_on,
)

__all__ = ["check_start", "first_crossing", "general_events"]

# A control is taken to have jumped over its band only when it lies beyond the band's far
# edge by more than this fraction of its magnitude (round-off is no jump). A switch that has
# moved at the current instant sits on its threshold up to round-off, on either side, however
# small its control's magnitude there (a sine at its zero): its control can jump only when the
# mode changes its rows (see general_events).
JUMP_MARGIN = 1e-9


def first_crossing(fun, sa: float, sb: float, ca: float, cb: float, thr: float, up: bool,
                   linear: bool, h: float, skip_start: bool = False) -> float | None:
    """First t in [sa, sb] where c(t) > thr (``up``) or c(t) < thr (not ``up``).

    ``ca``/``cb`` are the right/left limits of c at sa/sb; ``fun`` evaluates c on arrays.
    ``skip_start`` is set for a switch that flipped at ``sa``: its control sits on the other
    threshold there (up to round-off), which must not count as a new crossing.
    """
    def beyond(v):
        return v > thr if up else v < thr

    if beyond(ca) and not skip_start:
        return sa
    if linear:
        if not beyond(cb):
            return None
        if skip_start and (cb > ca if up else cb < ca) and beyond(ca):
            # beyond at sa and moving further beyond: not round-off on the threshold but
            # the control's value after the move (a switch whose move changed its own
            # control, as a comparator reading its own output): it moves again at once
            return sa
        if cb == ca:
            return None
        # c is linear on [sa, sb]: exact crossing of the threshold.
        t = sa + (thr - ca) / (cb - ca) * (sb - sa)
        if skip_start and t <= sa:
            return None
        return min(max(t, sa), sb)
    # Smooth but not linear: sample (at most h apart, so no crossing longer than a step is
    # missed) and refine the first sign change with brentq.
    nseg = int(max(8, min(1e6, np.ceil((sb - sa) / h))))
    ts = np.linspace(sa, sb, nseg + 1)
    cs = fun(ts)
    cs[0], cs[-1] = ca, cb
    hit = np.flatnonzero(cs > thr if up else cs < thr)
    if skip_start:
        if hit.size > 1 and hit[0] == 0 and hit[1] == 1:
            # beyond at sa and still beyond a sample later: the control's value after the
            # move, not round-off on the threshold (see the linear case); there is no sign
            # change to refine between the two
            return sa
        hit = hit[hit > 0]
    if hit.size == 0:
        return None
    i = int(hit[0])
    if i == 0:
        return sa

    def g(tt):
        return float(fun(np.array([tt]))[0]) - thr

    if g(ts[i - 1]) == 0.0:
        lo = ts[i - 1]
    else:
        from scipy.optimize import brentq  # (only for sources that are not piecewise linear)

        lo = brentq(g, ts[i - 1], ts[i], xtol=1e-300, rtol=1e-15)
    # brentq returns a root; the switch acts just after it.
    return float(lo)


def _jumped(sub: int, ca: float, cb: float, lo: float, hi: float) -> int | None:
    """The region (:data:`ABOVE`/:data:`BELOW`) a control ``ca`` (V, right limit) has jumped
    to, over the band ``[lo, hi]`` of a switch in sub-state ``sub`` (off below the band, on
    above it); None when it has not (``cb``: the control at the segment's end, for its
    magnitude)."""
    if sub != SUB_OFF and sub != SUB_ON:
        return None
    margin = JUMP_MARGIN * max(abs(ca), abs(cb), abs(lo), abs(hi))
    if sub == SUB_OFF and ca > hi + margin:
        return ABOVE
    if sub == SUB_ON and ca < lo - margin:
        return BELOW
    return None


def _next_moves(sw, active, rows, lin, bands, subs, sa, sb, ca, cb, controls, mode, h, tol,
                just_moved, steady):
    """The earliest instant in [sa, sb] where a switch's control leaves the region its
    sub-state says, and the moves ``(switch, region entered)`` there (within ``tol``); None
    and no moves when no control does before ``sb``. ``steady``: the switches that moved at
    ``sa`` and whose control has not jumped since (it sits on their threshold there, up to
    round-off, on either side: no new crossing, and no jump)."""
    best = None
    moves: list[tuple[int, int]] = []
    for i in range(len(sw)):
        # (a row of zeros is a control held at 0 in this mode, as a gate that a resistor
        # holds at 0 while its enable is off: it moves its switch as any other value)
        if i not in active:
            continue
        lo, hi, _ = bands[i]

        def fun(tt, i=i, mode=mode):
            return controls(mode, tt, 0)[:, i]

        args = (fun, sa, sb, ca[i], cb[i])
        skip = i in just_moved or i in steady

        def first(thr, up, args=args, li=lin[i], skip=skip):
            return first_crossing(*args, thr, up, li, h, skip_start=skip)

        sub = subs[i]
        jump = None if i in steady else _jumped(sub, ca[i], cb[i], lo, hi)
        if jump is not None:
            # over the band at sa (a source's jump at a breakpoint, or a mode change that
            # switched its gate): the side of its value just after sa
            tc, region = sa, jump
        elif sub == SUB_OFF:
            # below the band: the first instant at or above lo (c >= lo is
            # c > the float before lo)
            tc, region = first(np.nextafter(lo, -np.inf), True), IN
            if tc is not None and lo == hi and not (lin[i] and cb[i] <= hi):
                region = ABOVE
        elif sub == SUB_ON:
            tc, region = first(np.nextafter(hi, np.inf), False), IN
            if tc is not None and lo == hi and not (lin[i] and cb[i] >= lo):
                region = BELOW
        else:
            t_up, t_dn = first(hi, True), first(lo, False)
            tc, region = ((t_up, ABOVE) if t_dn is None or (
                t_up is not None and t_up <= t_dn) else (t_dn, BELOW))
        if tc is None:
            continue
        if best is None or tc < best - tol:
            best, moves = tc, [(i, region)]
        elif abs(tc - best) <= tol:
            moves.append((i, region))
    return best, moves


def _no_settling(sw, modes, t: float) -> NotImplementedError:
    """The error of switches that keep switching each other at one instant ``t`` (s):
    ``modes`` are the modes met there."""
    names = [sw[i].name for i in range(len(sw)) if len({m[i] for m in modes}) > 1]
    if len(names) == 1:
        return NotImplementedError(
            f"switch {names[0]} switches itself at t = {t:.9g} s without settling: its "
            "control, driven by sources through its own state, has no consistent state there "
            "(a comparator reading its own output with no delay oscillates in zero time); "
            "put a delay (an RC) or hysteresis (VH > 0) in the loop")
    return NotImplementedError(
        f"switches {', '.join(names)} switch each other at "
        f"t = {t:.9g} s without settling: their controls, driven by sources through each "
        "other's states, move them back and forth in zero time (a loop of ideal switches "
        "with no delay that has no consistent state there, or whose consistent states the "
        "switches moving together do not reach); put a delay (an RC) or hysteresis (VH > 0) "
        "in the loop")


def check_start(sw: Sequence, active, rows: np.ndarray, u_at: np.ndarray, u_after: np.ndarray,
                mode: tuple, t: float) -> None:
    """Refuse a start whose source-driven switch states disagree with their own controls.

    The planner starts from the states its controls give in the initial states, iterated to
    a fixed point; switches that switch each other with no delay reach none (each pass
    changes another), and the states of the last pass would then be run as they are, each
    contradicting a control (a switch on whose control is below its band).

    Parameters
    ----------
    sw : sequence of SwitchControl
    active : iterable of int
        The source-driven switches.
    rows : ndarray, shape (k, p)
        The controls' rows in ``mode``.
    u_at, u_after : ndarray, shape (p,)
        The inputs at ``t`` (right limits) and a merge tolerance later: a switch that the
        planner moves within that tolerance of the start is taken in its moved state.
    mode : tuple of bool
    t : float
        The start, s.

    Raises
    ------
    NotImplementedError
        Naming the switches whose state contradicts their control at ``t`` and after.
    """
    def against(i: int, c: float) -> bool:
        lo, hi, _ = band_rule(sw[i])
        margin = JUMP_MARGIN * max(abs(c), abs(lo), abs(hi))
        return bool(mode[i] and c < lo - margin or not mode[i] and c > hi + margin)

    c_at, c_after = rows @ u_at, rows @ u_after
    bad = [i for i in sorted(active)
           if against(i, float(c_at[i])) and against(i, float(c_after[i]))]
    if bad:
        names = ", ".join(sw[i].name for i in bad)
        its = "their" if len(bad) > 1 else "its"
        raise NotImplementedError(
            f"switch{'es' if len(bad) > 1 else ''} {names}: the start does not settle "
            f"(t = {t:.9g} s): the source-driven switches, whose controls depend on each "
            "other's states with no delay, do not settle from their initial states, and "
            f"{names} would be run against {its} control (a loop of ideal switches or "
            "comparators with no delay); put a delay (an RC) or hysteresis (VH > 0) in the "
            "loop, or give its switches initial states (ON/OFF) that agree")


def general_events(sw: Sequence, active: frozenset, rows_of: Callable, inputs: Sequence,
                   linear_inputs: bool, bands: Sequence, subs: list, mode0: tuple,
                   bounds: np.ndarray, u_start: np.ndarray, u_end: np.ndarray, h: float,
                   tol: float, t0: float, controls: Callable
                   ) -> tuple[tuple[bool, ...], list[tuple[float, tuple[bool, ...]]]]:
    """Switch states at ``bounds[0]`` and switching instants after it, by moving the switches
    one instant at a time (see the module docstring).

    Parameters
    ----------
    sw : sequence of SwitchControl
        The system's switches.
    active : frozenset of int
        The source-driven switches (the others keep their state in ``mode0``).
    rows_of : callable
        ``rows_of(mode)``: the controls' rows ``Fy`` (k, p) in a mode.
    inputs : sequence of callables
        The source waveforms (``piecewise_linear`` read per input).
    linear_inputs : bool
        Whether every input is piecewise linear.
    bands : sequence of (float, float, int)
        Per switch, :func:`~lcs.simulation.switch_bands.band_rule`.
    subs : list of int
        Per switch, its sub-state at ``bounds[0]`` (updated in place).
    mode0 : tuple of bool
        The mode at ``bounds[0]``.
    bounds : ndarray
        The segment ends, s: the run's start, the source breakpoints, its end.
    u_start, u_end : ndarray
        The inputs at each segment's start (right limits) and end (left limits).
    h : float
        Step, s (sampling resolution for controls that are not piecewise linear).
    tol : float
        Instants closer than this (s) are one.
    t0 : float
        The run's start, s (moves there change ``mode0``).
    controls : callable
        ``controls(mode, t, side)``: the controls (n, k) at the times ``t`` (s).

    Returns
    -------
    mode0 : tuple of bool
    events : list of (float, tuple of bool)
        Instants (s) and the modes after them, each a change.

    Raises
    ------
    NotImplementedError
        Switches that switch each other at one instant without settling.
    """
    k = len(sw)
    lin_cache: dict = {}

    def linear_rows(mode) -> list[bool]:
        if mode not in lin_cache:
            rows = rows_of(mode)
            lin_cache[mode] = [
                linear_inputs or all(getattr(inputs[j], "piecewise_linear", False)
                                     for j in np.flatnonzero(rows[i]))
                for i in range(k)
            ]
        return lin_cache[mode]

    # (a cascade at one instant moves each switch a few times: into and out of its band, and
    # back after a round-off crossing)
    max_here = 8 * (len(active) + 2)
    events: list[tuple[float, tuple[bool, ...]]] = []
    mode = mode0
    here_t, here_modes, here_n = -np.inf, set(), 0
    for s_idx in range(len(bounds) - 1):
        sa0 = sa = float(bounds[s_idx])
        sb = float(bounds[s_idx + 1])
        just_moved: list[int] = []
        # the mode in which each switch moved at the current instant (within tol), in this
        # segment: its control has jumped since only if the mode changed its rows
        moved_in: dict[int, tuple] = {}
        seen: set = set()  # the planner's states met at the instant sa
        while sa < sb:
            if sa > here_t + tol:  # (a segment's start past the last instant of moves)
                here_t, here_modes, here_n = sa, set(), 0
            here_modes.add(mode)
            here_n += 1
            state = (mode, tuple(subs), tuple(just_moved), tuple(sorted(moved_in.items())))
            if state in seen or here_n > max_here:
                raise _no_settling(sw, here_modes, sa)
            seen.add(state)
            rows = rows_of(mode)
            steady = {i for i, m in moved_in.items() if np.array_equal(rows_of(m)[i], rows[i])}
            lin = linear_rows(mode)
            ca0 = rows @ u_start[s_idx]
            cb = rows @ u_end[s_idx]
            if sa > sa0:
                # After an event inside the segment: the control there, by interpolation
                # where it is linear, by evaluation otherwise.
                frac = (sa - sa0) / (sb - sa0)
                c_at = controls(mode, sa, 0)[0] if not all(lin) else None
                ca = np.array([ca0[i] + (cb[i] - ca0[i]) * frac if lin[i] else c_at[i]
                               for i in range(k)])
            else:
                ca = ca0
            best, moves = _next_moves(sw, active, rows, lin, bands, subs, sa, sb, ca, cb,
                                      controls, mode, h, tol, just_moved, steady)
            if best is None:
                break
            if best > here_t + tol:
                # a new instant (the moves before it are no longer on their thresholds)
                here_t, here_modes, here_n = best, {mode}, 1
                moved_in.clear()
            for i, region in moves:
                subs[i] = enter(subs[i], region, bands[i][2])
                moved_in[i] = mode
            mode = tuple(sub_on(subs[i]) if i in active else on for i, on in enumerate(mode))
            if events and abs(events[-1][0] - best) <= tol:
                events[-1] = (events[-1][0], mode)
            elif best <= t0 + tol:
                mode0 = mode
            else:
                events.append((best, mode))
            if best >= sb:
                break
            if best > sa:
                seen.clear()
            sa = best
            just_moved = [i for i, _ in moves]
            if len(events) > 10_000_000:
                raise RuntimeError("more than 1e7 switching events: chattering gate?")
    # Drop events that do not change the mode (e.g. a flip and flip-back at the same instant).
    out = []
    prev = mode0
    for t, md in events:
        if md != prev:
            out.append((t, md))
            prev = md
    return mode0, out
