"""The run: everything between the arguments of ``simulate`` and its result, for any
integrator (:mod:`lcs.simulation.integrator`).

1. how each switch is driven (:func:`~lcs.simulation.switches.classify_switches`);
2. breakpoints, source-driven switching instants, latch re-arms
   (:func:`~lcs.simulation.schedule.plan_run`), a stretch of the run at a time when it is
   long;
3. the initial mode, state and multipliers (:func:`~lcs.simulation.initial.initial_state`);
4. windows between the Python controllers' sampling instants: at each, the controllers' new
   commands become known switchings, and the integrator advances through the window;
5. the last state saved, the events collected, the result assembled (with the error that
   stopped the run, if any: the result then ends at the last completed step). An interrupt
   (:mod:`lcs.interrupt`) stops the run the same way, between windows or between the
   integrator's own pieces.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Sequence
from typing import Protocol

import numpy as np

from .. import interrupt
from ..bits import words
from ..lcp import LcpOptions
from ..results import SimulationError, SimulationResult, SimulationStats, resample_arrays
from . import failures
from .initial import InconsistentHandler, initial_state
from .inputs import MERGE_FRACTION, InputTable, evaluate_inputs
from .integrator import Integrator, Run, Window
from .pinned import PinnedJumps, key_after
from .problem import Problem, mode_tuple
from .recorder import Recorder
from .regrid import Passthrough, Regrid
from .schedule import Controllers, plan_run
from .source_start import kept_in_band, source_mode_at
from .switches import classify_switches, initially_on


def _progress_bar(show: bool, total: int, name: str):
    if not show:
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None
    return tqdm(total=total, unit="step", unit_scale=True, desc=name, leave=False)


def check_args(system, signals, x0, t_start, t_stop, every) -> None:
    """Argument checks common to every integrator (ValueError)."""
    if not t_stop > t_start:
        raise ValueError(f"t_stop ({t_stop}) must exceed t_start ({t_start})")
    if int(every) != every or every < 1:
        raise ValueError(f"every must be a positive integer, got {every}")
    if len(signals) != len(system.inputs):
        raise ValueError(
            f"{len(system.inputs)} input(s) ({', '.join(system.inputs)}) but "
            f"{len(signals)} signal(s) given"
        )
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (len(system.states),):
        raise ValueError(f"x0 must have shape ({len(system.states)},), got {x0.shape}")
    if not np.all(np.isfinite(x0)):
        raise ValueError("x0 contains NaN or infinity")


class RowStream(Protocol):
    """Where a streamed run's output rows go as it makes them (a file written as the run
    goes): :meth:`open` once with the probe names, then :meth:`write` with consecutive
    blocks of times (s, shape (N,)) and rows (shape (N, q)), whose arrays may be reused
    after the call."""

    def open(self, names: tuple[str, ...]) -> None: ...

    def write(self, t: np.ndarray, y: np.ndarray) -> None: ...


def run(problem: Problem, inputs: Sequence, x0: np.ndarray, t_start: float, t_stop: float,
        integrator: Integrator, *, every: int = 1, breakpoints: Sequence[float] = (),
        save_at: Sequence[float] = (), progress: bool = False,
        on_inconsistent: InconsistentHandler | None = None, switching: str = "auto",
        controllers: Sequence = (), lcp: LcpOptions | None = None,
        t_wall: float | None = None, output_step: float | None = None,
        output_from: float = -np.inf, keep_events: int | None = None,
        rows_to: RowStream | None = None, operating_point: bool = False) -> SimulationResult:
    """Simulate ``problem`` from ``x0`` over ``[t_start, t_stop]`` with ``integrator``.

    Arguments as in :func:`lcs.integrators.moreau.integrator.simulate` (``switching`` is the
    comparator method, ``lcp`` the options of the initial LCP). Returns the result, with ``error``
    set when the run stopped early. With ``operating_point``, the run starts from the DC
    operating point of its initial mode (:mod:`lcs.theory.operating_point`; ``x0`` gives the
    states that no DC equation sets), as ngspice's ``.tran`` without ``UIC``.

    With ``output_step`` (s), the result is :func:`lcs.results.resample` of the stored rows
    at or after ``output_from`` (s), the same numbers, interpolated as the run goes
    (:mod:`.regrid`). Every row is kept and resampled at the end instead where a mode of the
    system pins a state (a jump found after the run may cut its end) or where the integrator
    does not write until the buffer is full
    (:attr:`~.integrator.Integrator.writes_until_full`).

    With ``keep_events``, ``result.events`` holds the last ``keep_events`` switchings and
    counts the earlier ones (all are kept where a mode pins a state: the check of the pinned
    jumps reads them).

    With ``rows_to``, the output rows (on the ``output_step`` grid, or the stored rows
    themselves) from ``output_from`` on go to it as the run makes them, and the result holds
    the last one only (``stats.points_streamed`` counts them), so that the run's memory does
    not depend on its length. Only where every row is final as it is made: not where a mode
    pins a state or the integrator does not write until its buffer is full (the result then
    holds the rows, and ``points_streamed`` is -1).
    """
    t_wall = time.perf_counter() if t_wall is None else t_wall
    inputs = list(inputs)
    notes: list[str] = []
    system = problem.system
    k = problem.k
    guess = tuple(initially_on(s.options) for s in system.switches)
    plan = classify_switches(system, controllers, switching, guess, notes)
    h = integrator.h
    tol = 2 * MERGE_FRACTION * h
    stretches = plan_run(system, inputs, plan, t_start, t_stop, h, MERGE_FRACTION * h,
                         breakpoints, save_at, guess)
    # (a source-driven switch whose gate is inside its hysteresis band just after t_start
    # keeps the state the operating point gives it, as the band keeps any earlier state)
    if operating_point and plan.source:
        with kept_in_band(system, inputs, t_start, plan.source,
                          source_mode_at(system, inputs, t_start, plan.source, guess, {})):
            sched = next(stretches)
    else:
        sched = next(stretches)
    out0 = problem.output(sched.mode_src if k else ())
    ctrls = Controllers(system, plan, t_start, t_stop, tol)
    # (the operating point is ngspice's: the sources' values at t_start itself, not just
    # after it: u(time) is 0.5 there, a PWL from (0, 0) to (0, 5) is 0; a source that jumps
    # at t_start then does so in the first step)
    u0 = evaluate_inputs(inputs, np.array([t_start]), 0 if operating_point else +1)[0]
    # (... and the switches those sources drive take their state there too: a switch whose
    # gate source jumps at t_start is in the operating point as before the jump, and turns
    # in the first step, the state carried over)
    mode_op = source_mode_at(system, inputs, t_start, plan.source, sched.mode_src,
                             sched.src_maps) if operating_point and plan.source else None
    if mode_op is not None and mode_op != tuple(sched.mode_src):
        start = initial_state(problem, plan, mode_op, sched.src_maps, guess, x0, u0, t_start,
                              ctrls, on_inconsistent, lcp or LcpOptions(), notes,
                              operating_point)
        x0, u0 = start.x, evaluate_inputs(inputs, np.array([t_start]), +1)[0]
        operating_point = False
    init = initial_state(problem, plan, sched.mode_src, sched.src_maps, guess, x0, u0, t_start,
                         ctrls, on_inconsistent, lcp or LcpOptions(), notes, operating_point)
    # States some modes hold at zero (an inductor an open switch leaves with no path): set
    # to zero where such a mode starts, at t_start and at every known switching instant.
    pins = PinnedJumps(system, k, tuple(i for i, m in enumerate(plan.method) if m in (
        "implicit", "hysteresis", "explicit"))) if system.pinnable else None
    if pins is not None:
        pins.apply(init.mode, init.x, t_start)
    split = pins is not None and integrator.can_set_state
    sink = None
    # (rows final as they are made: no pinned jump found later cuts them)
    final_rows = pins is None and integrator.writes_until_full
    streamed = rows_to is not None and final_rows
    if streamed:
        rows_to.open(tuple(out0.names))
        sink = (Regrid(output_step, len(out0.names), output_from, emit=rows_to.write)
                if output_step is not None else
                Passthrough(rows_to.write, len(out0.names), output_from))
    elif output_step is not None and final_rows:
        sink = Regrid(output_step, len(out0.names), output_from)
    recorder = Recorder(out0.names, 64, 64, out0.duty, words(k), sink,
                        keep_events=keep_events if pins is None else None)
    recorder.append(t_start, problem.output(init.mode).row(init.key, -1, 0.0, init.x, init.lam,
                                                           u0))
    table = InputTable(inputs, t_start, sched.t1)
    the_run = Run(problem, plan, sched, inputs, table, t_start, t_stop, int(every), tol,
                  recorder, init, guess, notes)
    integrator.prepare(the_run)

    windows = ctrls.windows(t_start, t_stop)
    units, seconds = integrator.expected_cost(the_run)
    bar = _progress_bar(bool(progress) and sys.stderr.isatty() and seconds > 1.0, units,
                        integrator.name)
    error: SimulationError | None = None
    interrupt.keeping()  # (from here an interrupt stops the run and keeps its results)
    try:
        while True:
            # The windows of this stretch of the run: its ends and the sampling instants in it.
            s0, s1 = sched.t0, sched.t1
            edges = np.concatenate(([s0], windows[(windows > s0) & (windows < s1)], [s1]))
            bps = sched.breakpoints
            for ws, we in zip(edges[:-1].tolist(), edges[1:].tolist(), strict=True):
                due = ctrls.due(ws) if ws > t_start and ctrls else ()
                if due:
                    snap = integrator.snapshot()
                    u_ws = the_run.table(np.array([ws]), +1)[0]
                    ctrls.commands(due, ws, snap.key, snap.x, snap.lam, u_ws, snap.slide,
                                   snap.duty, apply=False)
                known = sched.known.window(ws, we, tol, ctrls.take_pending(we))
                if split:
                    error = _advance_pinned(integrator, pins, known, ws, we, bps, tol, k)
                else:
                    error = integrator.advance(Window(ws, we, known,
                                                      bps[(bps > ws) & (bps < we)]))
                if bar is not None:
                    bar.update(integrator.progress())
                signum = interrupt.requested()
                if error is None and signum is not None and we < t_stop:
                    # (an integrator that does not check between its own pieces stops here)
                    snap = integrator.snapshot()
                    error = failures.interrupted(snap.t,
                                                 problem.describe(mode_tuple(snap.key, k)),
                                                 signum)
                if error is not None:
                    break
            if error is not None or s1 >= t_stop:
                break
            # The next stretch: its plan and input table replace this one's.
            sched = next(stretches)
            the_run.schedule = sched
            the_run.table = InputTable(inputs, sched.t0, sched.t1)
    finally:
        if bar is not None:
            bar.close()

    snap = integrator.snapshot()
    t_last = snap.t
    if recorder.last_time() != t_last:
        # Always keep the last completed step.
        u_last = evaluate_inputs(inputs, np.array([t_last]), -1)[0]
        recorder.append(t_last, problem.output(mode_tuple(snap.key, k)).row(
            snap.key, snap.slide, snap.duty, snap.x, snap.lam, u_last))
    events, sliding, visited = recorder.events(plan.names, init.mode, t_last)
    t_res, y_res = recorder.arrays()
    if pins is not None:
        notes.extend(pins.notes())
        if error is None:
            error = pins.unhandled(init.mode, events, tol, sliding)
            if error is not None:
                # (what follows may carry the current the switch cut: not kept)
                t_res, y_res, events = _cut_at(t_res, y_res, events, error.time, True)
    if error is None and recorder.non_finite is not None:
        error = _non_finite_rows(problem, inputs, init.mode, events, *recorder.non_finite)
        t_res, y_res, events = _cut_at(t_res, y_res, events, error.time, False)
    stored = sink.kept if sink is not None else len(t_res)
    if output_step is not None and sink is None:
        keep = t_res >= output_from
        t_res, y_res = t_res[keep], y_res[keep]
        stored = len(t_res)
        if len(t_res):
            t_res, y_res = resample_arrays(t_res, y_res, output_step)
    stats = SimulationStats(**integrator.stats(), intervals=events.count + 1,
                            wall_time=time.perf_counter() - t_wall, points_stored=stored,
                            peak_rows=recorder.peak_rows,
                            points_streamed=sink.written if streamed else -1)
    result = SimulationResult(
        t=t_res,
        names=tuple(recorder.names),
        y=y_res,
        x_final=snap.x.copy(),
        lambda_final=snap.lam.copy(),
        modes_visited=visited,
        events=events,
        stats=stats,
        notes=notes,
        error=error,
        sliding=sliding,
        switching={nm: md for nm, md in zip(plan.names, plan.method, strict=True)},
    )
    if error is not None:
        error.result = result
    return result


def _advance_pinned(integrator: Integrator, pins: PinnedJumps, known, ws: float, we: float,
                    bps: np.ndarray, tol: float, k: int) -> SimulationError | None:
    """Advance through ``[ws, we)`` in parts cut at the known switching instants, setting to
    zero, where each part starts, the states its mode pins (:mod:`.pinned`)."""
    cuts = known.t[(known.t > ws + tol) & (known.t < we - tol)]
    edges = np.concatenate(([ws], np.unique(cuts), [we]))
    for a, b in zip(edges[:-1], edges[1:], strict=True):
        part = known.window(a, b, tol) if len(edges) > 2 else known
        snap = integrator.snapshot()
        key = key_after(snap.key, part, a, tol)
        x = np.array(snap.x, dtype=float)
        error = pins.carried(mode_tuple(key, k), x, a)
        if error is not None:
            return error
        if pins.apply(mode_tuple(key, k), x, a):
            integrator.set_state(x)
        error = integrator.advance(Window(a, b, part, bps[(bps > a) & (bps < b)]))
        if error is not None:
            return error
    return None


def _cut_at(t_res: np.ndarray, y_res: np.ndarray, events, t: float, row_at_t: bool):
    """The results of a run stopped by an error at ``t`` (s): the rows before ``t`` (and the
    row at ``t`` when ``row_at_t``) and the events up to ``t``."""
    keep = t_res <= t if row_at_t else t_res < t
    return t_res[keep], y_res[keep], events[:int(np.searchsorted(events.t, t, side="right"))]


def _non_finite_rows(problem: Problem, inputs, mode0, events, t_prev: float,
                     t_bad: float) -> SimulationError:
    """The error of a run whose recorded outputs are not finite numbers at ``t_bad`` (s)
    where its state was: a circuit with no state, whose outputs are its inputs' (a B
    source's sqrt(sin(...)) out of its domain). The kernel stops a run whose state is not
    finite; this is the outputs' counterpart."""
    with np.errstate(all="ignore"):
        u = evaluate_inputs(inputs, np.array([t_bad]), -1)[0]
    names = [problem.system.inputs[j] for j in np.flatnonzero(~np.isfinite(u))]
    mode = mode0
    for te, md in events:
        if te > t_bad:
            break
        mode = md
    t0 = t_prev if np.isfinite(t_prev) else t_bad
    return failures.non_finite(t0, t_bad, problem.describe(tuple(mode)), names)
