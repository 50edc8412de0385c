"""Continuation of a periodic orbit in a parameter and location of its bifurcations.

Natural-parameter continuation: the parameter goes from ``start`` to ``stop`` in equal steps;
at each value the period-k orbit is found by Newton shooting from a secant prediction of the
previous two orbits (the step is halved, up to ``max_halvings`` times, when Newton fails).
Between two consecutive orbits a bifurcation is detected when

* the number of real multipliers below -1 changes: period doubling (``"flip"``);
* the number of real multipliers above +1 changes: ``"fold"`` (on a branch that continues
  through it, e.g. a saddle becoming a repeller; a turning point stops the natural
  continuation, which is reported in the notes);
* the number of complex multipliers outside the unit circle changes: ``"neimark-sacker"``;
* the switching pattern (sequence of switch and diode configurations in the period) changes:
  ``"border"`` -- a border collision, e.g. a skipped cycle (the switch no longer turns on
  within a period), a diode entering discontinuous conduction, a switching instant reaching
  the period boundary.

Each crossing is then located by bisection in the parameter to the requested tolerance (the
orbit is re-solved at every midpoint, from the interpolated orbit). A multiplier crossing at
the same place as a pattern change is a *nonsmooth* bifurcation (the multipliers jump across
the unit circle at the border collision): it is reported once, as ``"border"``, with the
multiplier event in ``detail``.

:func:`continue_orbits` runs :func:`continue_orbit` from many starting states at once (one
task each, on the engine of :mod:`.parallel`: local processes or a Dask cluster), to find and
follow coexisting orbits; :func:`same_orbit` tells which starts found the same orbit.

Limitations: a multiplier that crosses and crosses back within one step is missed (use more
steps); natural continuation cannot turn around a fold (pseudo-arclength is not
implemented).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .maps import Map, MapError
from .orbits import NOT_AN_ORBIT, PeriodicOrbit, find_orbit, multiplier_counts, state_scale
from .parallel import portable, progress_bar, task_engine

__all__ = ["Bifurcation", "ContinuationResult", "continue_orbit", "continue_orbits",
           "locate_bifurcation", "same_orbit"]

MapFactory = Callable[[float], Map]
KINDS = ("flip", "fold", "neimark-sacker")


@dataclass
class Bifurcation:
    """A located bifurcation of the continued orbit.

    Attributes
    ----------
    type : str
        ``"flip"``, ``"fold"``, ``"neimark-sacker"`` or ``"border"``.
    param : float
        Location (middle of the final bracket).
    bracket : tuple[float, float]
        Parameter values on either side (first: the side the continuation came from).
    before, after : PeriodicOrbit
        The orbits at the bracket ends.
    detail : str
        What changed (multipliers, pattern).
    located : bool
        The bracket was narrowed to the tolerance (False if Newton failed inside it).
    """

    type: str
    param: float
    bracket: tuple[float, float]
    before: PeriodicOrbit
    after: PeriodicOrbit
    detail: str = ""
    located: bool = True

    def to_dict(self) -> dict:
        return {
            "type": self.type,
            "param": float(self.param),
            "bracket": [float(self.bracket[0]), float(self.bracket[1])],
            "located": bool(self.located),
            "detail": self.detail,
            "multipliers_before": [[float(m.real), float(m.imag)]
                                   for m in self.before.multipliers],
            "multipliers_after": [[float(m.real), float(m.imag)]
                                  for m in self.after.multipliers],
            "pattern_before": str(self.before.pattern) if self.before.pattern else None,
            "pattern_after": str(self.after.pattern) if self.after.pattern else None,
        }


@dataclass
class ContinuationResult:
    """Orbits along the parameter and the bifurcations found.

    Attributes
    ----------
    param_name : str
    orbits : list of PeriodicOrbit
        In continuation order (``orbit.param`` is the parameter value).
    bifurcations : list of Bifurcation
        In continuation order.
    complete : bool
        The continuation reached ``stop``.
    notes : list of str
    wall_time : float
    """

    param_name: str
    orbits: list[PeriodicOrbit]
    bifurcations: list[Bifurcation]
    complete: bool = True
    notes: list[str] = field(default_factory=list)
    wall_time: float = 0.0

    @property
    def params(self) -> np.ndarray:
        return np.array([o.param for o in self.orbits], dtype=float)

    def to_dict(self) -> dict:
        return {
            "param_name": self.param_name,
            "complete": self.complete,
            "bifurcations": [b.to_dict() for b in self.bifurcations],
            "branch": [{
                "param": float(o.param) if o.param is not None else None,
                "point": [float(v) for v in o.x],
                # a point Newton did not converge to has no multipliers of its own
                "multipliers": [[float(m.real), float(m.imag)] for m in o.multipliers]
                if o.converged else None,
                "stability": o.stability if o.converged else NOT_AN_ORBIT,
                "pattern": [list(map(list, s)) for s in o.pattern.signature]
                if o.pattern is not None else None,
            } for o in self.orbits],
            "states": list(self.orbits[0].state_names) if self.orbits else [],
            "notes": list(self.notes),
            "wall_time": self.wall_time,
        }


def _indicator(o: PeriodicOrbit, kind: str):
    if kind == "border":
        return o.pattern.signature if o.pattern is not None else None
    return multiplier_counts(o.multipliers)[kind]


def _describe_pattern_change(a: PeriodicOrbit, b: PeriodicOrbit) -> str:
    if a.pattern is None or b.pattern is None:
        return ""
    sa, sb = a.pattern.signature, b.pattern.signature

    def switch_events(sig):
        seq = [s[0] for s in sig]
        return sum(1 for i in range(len(seq)) if seq[i] != seq[i - 1]) if len(seq) > 1 else 0

    def all_off(sig):
        return sum(1 for s in sig if s[1] and not any(s[1]) and not any(s[0]))

    notes = []
    if switch_events(sb) < switch_events(sa):
        notes.append("fewer switch transitions per orbit (skipped cycle)")
    elif switch_events(sb) > switch_events(sa):
        notes.append("more switch transitions per orbit")
    if all_off(sb) > all_off(sa):
        notes.append("an interval with every switch and diode off appears "
                     "(discontinuous conduction)")
    elif all_off(sb) < all_off(sa):
        notes.append("the interval with everything off disappears (continuous conduction)")
    if not notes:
        notes.append("switching sequence changes")
    return f"{'; '.join(notes)}: {a.pattern} => {b.pattern}"


def _describe_multipliers(kind: str, a: PeriodicOrbit, b: PeriodicOrbit) -> str:
    def fmt(o):
        return ", ".join(f"{m.real:.4g}{m.imag:+.4g}j" if abs(m.imag) > 0 else f"{m.real:.4g}"
                         for m in o.multipliers)

    return f"{kind}: multipliers {fmt(a)} -> {fmt(b)}"


def _solve(factory: MapFactory, p: float, guess, order: int, newton: dict
           ) -> PeriodicOrbit | None:
    try:
        # no restart from a transient: it would leave the branch for the attractor
        o = find_orbit(factory(float(p)), guess, order, restarts=(), **newton)
    except MapError:
        return None
    return o if o.converged else None


def _leaves_a_knee(factory: MapFactory, o: PeriodicOrbit, order: int) -> str | None:
    """Why orbit ``o`` is not its circuit's (a map with ``check_attractor``: a quantity of
    the circuit leaves the side of a knee its model holds on, over the orbit's periods), or
    None."""
    check = getattr(factory(float(o.param)), "check_attractor", None)
    return check(np.asarray(o.points[0], dtype=float), order) if check is not None else None


def locate_bifurcation(factory: MapFactory, kind: str, a: PeriodicOrbit, b: PeriodicOrbit,
                       tol: float, order: int = 1, newton: dict | None = None
                       ) -> Bifurcation:
    """Bisection between two orbits whose ``kind`` indicator differs.

    Parameters
    ----------
    factory : callable
        ``factory(p) -> Map``.
    kind : str
        ``"flip"``, ``"fold"``, ``"neimark-sacker"`` (multiplier counts) or ``"border"``
        (switching pattern).
    a, b : PeriodicOrbit
        Orbits at the bracket ends (``a`` on the continuation's starting side).
    tol : float
        Bracket width to reach (parameter units).

    Returns
    -------
    Bifurcation
    """
    newton = dict(newton or {})
    ia = _indicator(a, kind)
    lo, hi = a, b
    located = True
    while abs(float(hi.param) - float(lo.param)) > tol:
        pm = 0.5 * (float(lo.param) + float(hi.param))
        guess = 0.5 * (lo.x + hi.x)
        om = _solve(factory, pm, guess, order, newton) or _solve(factory, pm, lo.x, order,
                                                                    newton)
        if om is None:
            located = False
            break
        if _indicator(om, kind) == ia:
            lo = om
        else:
            hi = om
    if kind == "border":
        detail = _describe_pattern_change(lo, hi)
    else:
        detail = _describe_multipliers(kind, lo, hi)
    return Bifurcation(kind, 0.5 * (float(lo.param) + float(hi.param)),
                       (float(lo.param), float(hi.param)), lo, hi, detail, located)


def _collapsed(o: PeriodicOrbit) -> int:
    """The true period of a period-k orbit whose points repeat (k if they do not)."""
    k = o.order
    pts = o.points
    sc = state_scale(pts[0])
    for j in range(1, k):
        if k % j == 0 and np.max(np.abs(pts[j] - pts[0]) / sc) < 1e-6:
            return j
    return k


def continue_orbit(
    factory: MapFactory,
    start: float,
    stop: float,
    *,
    steps: int = 40,
    order: int = 1,
    x0=None,
    transient: int = 100,
    tol: float | None = None,
    max_halvings: int = 6,
    newton_tol: float = 1e-10,
    rel_step: float = 1e-5,
    locate: bool = True,
    progress: bool = False,
    param_name: str = "p",
    report: Callable[[float], None] | None = None,
) -> ContinuationResult:
    """Follow a period-``order`` orbit from ``start`` to ``stop`` and locate bifurcations.

    Parameters
    ----------
    factory : callable
        ``factory(p) -> Map`` (e.g. :class:`netlist.studies.sweep.CircuitMapFactory`).
    start, stop : float
        Parameter range (either order).
    steps : int
        Continuation steps (``steps + 1`` values, before any halving).
    order : int
        Period k of the orbit (in map iterates).
    x0 : array_like, optional
        Initial guess at ``start``; default the map's ``x0`` (circuit initial state) or
        zeros, iterated ``transient`` times.
    transient : int
        Iterates of ``P^k`` from ``x0`` before the first Newton solve.
    tol : float, optional
        Bisection tolerance in the parameter; default ``|stop - start| * 1e-4``.
    max_halvings : int
        Step halvings when Newton fails before the continuation stops.
    newton_tol, rel_step : float
        Passed to :func:`~.orbits.find_orbit`.
    locate : bool
        Bisect each detected bifurcation (else report the step bracket).
    progress : bool
        tqdm bar on a terminal.
    param_name : str
    report : callable, optional
        ``report(fraction_of_a_step)`` after each accepted step (progress of a task run by
        :func:`continue_orbits`; ``steps`` units in all).

    Returns
    -------
    ContinuationResult
    """
    t_wall = time.perf_counter()
    start, stop = float(start), float(stop)
    if steps < 1:
        raise ValueError("steps must be >= 1")
    if tol is None:
        tol = abs(stop - start) * 1e-4
    newton = {"tol": newton_tol, "rel_step": rel_step}
    notes: list[str] = []
    m = factory(start)
    if x0 is None:
        x0 = getattr(m, "x0", None)
        if x0 is None:
            x0 = np.zeros(m.dim)
    first = find_orbit(m, np.asarray(x0, dtype=float), order, transient=transient, **newton)
    if not first.converged:
        return ContinuationResult(param_name, [first], [], False,
                                  [f"no period-{order} orbit found at {param_name} = {start:g} "
                                   f"({'; '.join(first.notes)})"], time.perf_counter() - t_wall)
    problem = _leaves_a_knee(factory, first, order)
    if problem:
        return ContinuationResult(param_name, [], [], False,
                                  [f"the period-{order} orbit at {param_name} = {start:g} is "
                                   f"not the circuit's: {problem}"], time.perf_counter() - t_wall)
    orbits = [first]
    bifs: list[Bifurcation] = []
    dp_full = (stop - start) / steps
    dp = dp_full
    p = start
    complete = True
    bar = progress_bar(progress, steps, "continuation", "step")
    try:
        while (stop - p) * np.sign(dp_full) > 1e-12 * max(1.0, abs(stop)):
            p_next = p + dp
            if (stop - p_next) * np.sign(dp_full) < 0:
                p_next = stop
            prev = orbits[-1]
            if len(orbits) >= 2:
                pp, p2 = float(orbits[-2].param), float(prev.param)
                guess = prev.x + (prev.x - orbits[-2].x) * (p_next - p2) / (p2 - pp)
            else:
                guess = prev.x
            o = _solve(factory, p_next, guess, order, newton)
            if o is None and len(orbits) >= 2:
                o = _solve(factory, p_next, prev.x, order, newton)
            if o is None:
                if abs(dp) > abs(dp_full) / 2**max_halvings:
                    dp *= 0.5
                    continue
                complete = False
                notes.append(f"Newton failed at {param_name} = {p_next:g}: the orbit is lost "
                             "(a fold turning point, or the map is not smooth there); "
                             f"continuation stopped at {p:g}")
                break
            if order > 1 and _collapsed(o) < order:
                complete = False
                notes.append(f"the period-{order} orbit collapsed to period {_collapsed(o)} at "
                             f"{param_name} = {p_next:g} (the period-doubling point is "
                             "passed); continuation stopped")
                break
            problem = _leaves_a_knee(factory, o, order)
            if problem:
                complete = False
                notes.append(f"the orbit at {param_name} = {p_next:g} is not the circuit's: "
                             f"{problem}; continuation stopped at {p:g}")
                break
            found = [k for k in (*KINDS, "border") if _indicator(o, k) != _indicator(prev, k)]
            located = []
            for kind in found:
                if locate:
                    located.append(locate_bifurcation(factory, kind, prev, o, tol, order,
                                                      newton))
                else:
                    detail = (_describe_pattern_change(prev, o) if kind == "border"
                              else _describe_multipliers(kind, prev, o))
                    located.append(Bifurcation(kind, 0.5 * (float(prev.param) + p_next),
                                               (float(prev.param), p_next), prev, o, detail,
                                               False))
            bifs.extend(_merge_nonsmooth(located, tol, np.sign(dp_full)))
            orbits.append(o)
            done = abs(p_next - p) / abs(dp_full)
            if bar is not None:
                bar.update(done)
            if report is not None:
                report(done)
            p = p_next
            # Grow the step back after a success with a halved one.
            if abs(dp) < abs(dp_full):
                dp *= 2.0
    finally:
        if bar is not None:
            bar.close()
    return ContinuationResult(param_name, orbits, bifs, complete, notes,
                              time.perf_counter() - t_wall)


def _merge_nonsmooth(found: list[Bifurcation], tol: float, direction: float
                     ) -> list[Bifurcation]:
    """A multiplier event at a border collision is the border collision's doing."""
    borders = [b for b in found if b.type == "border"]
    out = []
    for b in found:
        if b.type != "border" and any(abs(b.param - c.param) <= 2 * tol + 1e-15
                                      for c in borders):
            for c in borders:
                if abs(b.param - c.param) <= 2 * tol + 1e-15:
                    c.detail = f"nonsmooth {b.type} (multipliers jump at the border " \
                               f"collision); {b.detail}; {c.detail}"
            continue
        out.append(b)
    return sorted(out, key=lambda b: direction * b.param)


def _continue_task(task, report) -> ContinuationResult:
    """Worker: one continuation from one starting state (a failing map: no orbit)."""
    factory, start, stop, x0, raise_errors, kwargs = task
    try:
        return continue_orbit(factory, start, stop, x0=x0, report=report, **kwargs)
    except MapError as exc:
        if raise_errors:
            raise
        return ContinuationResult(kwargs.get("param_name", "p"), [], [], False,
                                  [f"the map failed from this start: {exc}"])


def continue_orbits(
    factory: MapFactory,
    start: float,
    stop: float,
    starts: Sequence,
    *,
    workers: int | None = None,
    scheduler=None,
    progress: bool = False,
    start_method: str | None = None,
    raise_errors: bool = False,
    **kwargs,
) -> list[ContinuationResult]:
    """:func:`continue_orbit` from each of many starting states, in parallel.

    Parameters
    ----------
    factory : callable
        ``factory(p) -> Map``; picklable (e.g. :class:`netlist.studies.sweep.CircuitMapFactory`).
    start, stop : float
        Parameter range.
    starts : sequence of array_like, each shape (n,)
        Starting states (each iterated ``transient`` times at ``start`` before Newton).
    workers : int, optional
        Local processes (default all cores).
    scheduler : None, str or distributed.Client, optional
        Where the continuations run (:func:`~.parallel.task_engine`).
    progress : bool
        One bar over all continuations (``steps`` units each).
    start_method : str, optional
    raise_errors : bool
        Re-raise a :class:`~.maps.MapError` of a continuation (default: that continuation
        has no orbit, ``complete`` False and the error in its notes).
    **kwargs
        Passed to :func:`continue_orbit` (``steps``, ``order``, ``transient``, ``tol``,
        ``locate``, ``param_name``, ...).

    Returns
    -------
    list of ContinuationResult
        One per start, in the order of ``starts``; identical whatever runs them.
    """
    starts = [np.asarray(x, dtype=float) for x in starts]
    if not starts:
        raise ValueError("no starting state")
    kwargs.pop("x0", None)
    kwargs.pop("report", None)
    steps = int(kwargs.get("steps", 40))
    with task_engine(scheduler, workers, start_method=start_method) as engine:
        f = portable(factory) if engine.distributed else factory
        tasks = [(f, float(start), float(stop), x, bool(raise_errors),
                  dict(kwargs, progress=False)) for x in starts]
        return engine.run(_continue_task, tasks, progress=progress,
                          total=steps * len(starts), desc="continuation", unit="step")


def same_orbit(a: PeriodicOrbit, b: PeriodicOrbit, rtol: float = 1e-6) -> bool:
    """Whether two orbits of the same map are one orbit (up to a cyclic shift of points).

    Points are compared state by state relative to :func:`~.orbits.state_scale` of the
    first orbit's first point.
    """
    if a.order != b.order or a.points.shape != b.points.shape:
        return False
    if a.param != b.param:
        return False
    sc = state_scale(a.points[0])
    for shift in range(b.order):
        if np.max(np.abs(a.points - np.roll(b.points, -shift, axis=0)) / sc) <= rtol:
            return True
    return False
