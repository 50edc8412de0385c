"""The :class:`~lcs.results.SimulationError` of a run that cannot continue, with the instant,
the switch mode and the diodes or the switch involved, whichever integrator met it."""

from __future__ import annotations

from collections.abc import Sequence

from ..model import LCS
from ..results import SimulationError
from .problem import fmt_mode, pair_names


def _where(t0: float, t1: float, desc: dict[str, str]) -> str:
    return f"t = {t1:.9g} s (step from {t0:.9g} s), mode: {fmt_mode(desc)}"


def no_solution(t0: float, t1: float, desc: dict[str, str], lcs: LCS, mask: int,
                how: str, cause: str | None = None) -> SimulationError:
    """The LCP of a step has no solution (``mask``: the pairs with ``w < 0`` at ``λ = 0``;
    ``how``: what established it; ``cause``: why, when known, e.g. :func:`theta_cause`)."""
    pairs = pair_names(lcs, mask)
    msg = (
        f"{_where(t0, t1, desc)}: the complementarity problem of the time step has no solution "
        f"({how}). Diodes involved: {', '.join(pairs) or '(none with negative w at λ = 0)'} "
        "(with every diode off they would be forward-biased, or carry a reverse current, "
        "and no combination of conducting diodes satisfies the circuit). "
        + (cause or "The circuit is probably ill-posed in this mode: not passive (a negative "
           "resistance, an active controlled source), or a loop of diodes and voltage "
           "sources, or a cut-set of diodes and current sources.")
    )
    return SimulationError(msg, kind="no_solution", time=t1, t_prev=t0, mode=desc, pairs=pairs)


def non_unique(t0: float, t1: float, desc: dict[str, str], lcs: LCS,
               mask: int, cause: str | None = None) -> SimulationError:
    """Several LCP solutions give different next states (``mask``: the pairs whose λ
    differ; ``cause``: why, when known, e.g. :func:`theta_cause`)."""
    pairs = pair_names(lcs, mask)
    msg = (
        f"{_where(t0, t1, desc)}: the complementarity problem of the time step has several "
        f"solutions giving different next states; diodes involved: {', '.join(pairs)}. "
        + (cause or "The circuit is not well posed in this mode (check passivity / the diode "
           "orientation).")
    )
    return SimulationError(msg, kind="non_unique", time=t1, t_prev=t0, mode=desc, pairs=pairs)


def theta_cause(theta: float, h: float, longest: float) -> str:
    """Why a step of a passive mode is ill-posed: θ < 1 with a step ``h`` (s) longer than the
    ``longest`` (s) whose next state is unique
    (:func:`lcs.theory.step_uniqueness.longest_unique_step`)."""
    return (
        f"The circuit is passive in this mode (its stored energy is a storage function), so "
        f"its trajectory is unique; its θ = {theta:g} step of {h:.4g} s is not: a decay in it "
        f"is too fast for θ < 1 at that step (steps below {longest:.3g} s have one next "
        "state, which is not yet to say an accurate one). Use θ = 1 (--theta 1)."
    )


def non_finite(t0: float, t1: float, desc: dict[str, str],
               inputs: Sequence[str] = ()) -> SimulationError:
    """The state overflowed; ``inputs``: those that are not finite numbers at the step's
    ends (a B source's sqrt(500u - time) past 500 us)."""
    if inputs:
        msg = (f"{_where(t0, t1, desc)}: the input {', '.join(inputs)} is not a finite number "
               "there (a function of time out of its domain, as ngspice's 'out of range')")
    else:
        msg = (f"{_where(t0, t1, desc)}: the state became NaN or infinite (overflow: an "
               "unstable mode, or non-finite inputs).")
    return SimulationError(msg, kind="non_finite", time=t1, t_prev=t0, mode=desc)


def chattering(t0: float, t1: float, desc: dict[str, str], switch: str,
               limit: int) -> SimulationError:
    """More than ``limit`` comparator switchings inside one step."""
    msg = (
        f"switch {switch} at t = {t0:.9g} s (mode: {fmt_mode(desc)}): more than {limit} "
        f"comparator switchings inside one step of the grid (up to {t1:.9g} s): the "
        "comparator chatters. Check its control and threshold, add hysteresis (VH > 0), take "
        "a smaller step (a control that moves faster than the grid resolves: pelcs simulate "
        "--step) or raise MoreauOptions.max_switchings."
    )
    return SimulationError(msg, kind="chattering", time=t1, t_prev=t0, mode=desc, switch=switch)


def sliding(t0: float, desc: dict[str, str], switch: str, method: str,
            other: str | None) -> SimulationError:
    """A comparator toggles without progress and may not slide (``other``: a switch already
    sliding)."""
    if other is not None:
        why = (f"switch {other} is already sliding; pelcs handles one sliding switch at a "
               "time")
    else:
        why = (f"its method is {method!r}, which has no sliding mode; use "
               "switching='implicit' (the Filippov solution), a hysteresis band VH > 0, or "
               "switching='explicit'")
    msg = (
        f"switch {switch} toggles without progress at t = {t0:.9g} s (mode: "
        f"{fmt_mode(desc)}): the trajectory is on an attractive switching surface of its "
        f"comparator (a sliding mode); {why}."
    )
    return SimulationError(msg, kind="sliding", time=t0, t_prev=t0, mode=desc, switch=switch)


def interrupted(t: float, desc: dict[str, str], signum: int) -> SimulationError:
    """The run was stopped by a signal (:mod:`lcs.interrupt`) at ``t``, the end of its last
    completed step."""
    from ..interrupt import signal_name

    msg = (f"interrupted ({signal_name(signum)}) at t = {t:.9g} s (mode: {fmt_mode(desc)}); "
           "the results up to then are kept")
    return SimulationError(msg, kind="interrupted", time=t, t_prev=t, mode=desc)
