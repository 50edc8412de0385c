"""Sensitivity of a state-driven run: how far a pointwise comparison with ngspice decides.

Used by :func:`ngspice_checks.compare.compare`.

Sensitive runs (state-driven switching)
---------------------------------------
When a switch follows the state (a comparator, anything not ``"source"``-driven), an instant
moved by one step moves the rest of the run, and in an ill-conditioned start-up or on a
chaotic orbit two correct simulations part. pelcs then runs twice more
(:func:`_perturbed_runs`; cheap next to ngspice): at half its step, and, when its comparators
are ideal (``"implicit"``) and never slide, with them sampled at the end of each step
(``switching="explicit"``: the instants land on the grid, as ngspice's land on its time steps:
an error of ngspice's kind). Per probe, the largest RMS change those runs make on the common
grid (same guard), relative to the scale, over the transient (before the steady-state window)
and over the window, is held against *half* the probe's NRMS tolerance; per switch the
largest move of its instants in the window against their tolerance (which already allows
ngspice's steps):

- all within: pelcs is converged, everything is compared as for source-driven switching
  (:mod:`ngspice_checks.compare`; every state-driven netlist of the agreement sweep);
- the **window** parts (a probe, or the instants): the run there is sensitive (a chaotic
  orbit, the phase of a subharmonic one, a transient not settled yet). A pointwise metric
  that agrees still counts; one that differs is reported, not judged
  (``ProbeComparison.pointwise``, ``SwitchingComparison.inconclusive``), and the verdict is
  then *inconclusive* (``Comparison.sensitivity`` says why). The means and ripples are
  judged with their tolerances widened by twice the largest change of each (a window of a
  chaotic orbit is a sample of its statistics: pelcs' runs are samples, ngspice's another);
- only the **transient** parts: the NRMS is judged over the steady-state window
  (``nrms_over = "steady state"``, as the comparator instants already are); the transient's
  NRMS is reported and fails only past the NRMS tolerance + 4 × pelcs' change there (pelcs'
  error up to twice its change, first order, and ngspice's as large). Passing that wide
  bound shows nothing; ``Comparison.transient`` says so.

When something in the window still fails, pelcs restarts from ngspice's state at the window's
start (every inductor current and capacitor voltage, :func:`_restart_check`) and runs over
the window. If that run follows ngspice within the NRMS, mean and instants' tolerances, both
simulators have the same dynamics and the runs' start-ups chose different coexisting orbits
(or phases): the failing window metrics are set aside (``ProbeComparison.unjudged``), the
verdict is *inconclusive* and ``Comparison.orbit`` says why. A transient NRMS, and a
whole-run NRMS of a converged run, stay judged. A wrong element value or a shifted timing
makes the restart part from ngspice too, and the comparison fails.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from lcs.results import SimulationResult
from netlist.circuit import Circuit, Switch
from netlist.errors import NetlistError
from netlist.units import format_eng

from .comparison import ProbeComparison, SwitchingComparison, Tolerances
from .measures import (
    _hausdorff,
    _in_window,
    _mean,
    _ngspice_instants,
    _pelcs_instants,
    _strictly_increasing,
)
from .runner import NgspiceResult


def _nrms(d: np.ndarray, sel: np.ndarray) -> float:
    """RMS of ``d`` over the selected points (NaN when none is)."""
    return float(np.sqrt(np.mean(d[sel] ** 2))) if sel.any() else math.nan


def run_theta(result: SimulationResult) -> float:
    """The θ a compared run used (``result.theta``; 1/2 where it records none): the runs
    that check its sensitivity or restart it use the same."""
    theta = getattr(result, "theta", None)
    return float(theta) if theta is not None else 0.5


def _perturbed_runs(circuit: Circuit, result: SimulationResult, theta: float,
                    probes: Sequence[str], switches: Sequence[Switch], notes: list[str]
                    ) -> list[SimulationResult]:
    """pelcs once more, perturbed, when some switch follows the state (a comparator: not
    ``"source"``-driven); else no run. At half its step; and, when every state-driven switch
    is an ideal comparator (``"implicit"``) that never slides, with its comparators sampled
    at the end of each step (``switching="explicit"``: the instants land on the grid, as
    ngspice's land on its time steps). Their differences from the compared run measure
    what pelcs' own step, and an error of ngspice's kind, can do to the run. A failed run
    is noted and left out."""
    from netlist.studies.transient import simulate_circuit

    kinds = {result.switching.get(sw.name, "source") for sw in switches}
    if kinds <= {"source"}:
        return []
    t = np.asarray(result.t, dtype=float)
    h = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    if not h > 0:
        return []
    runs = [("half the step", {"step": h / 2})]
    if kinds - {"source"} == {"implicit"} and not result.sliding:
        runs.append(("sampled comparators", {"switching": "explicit"}))
    out = []
    for label, kw in runs:
        run = simulate_circuit(circuit, theta=theta, probes=list(probes), **kw)
        if run.error is not None:
            notes.append(f"pelcs with {label} failed at t = {run.error.time:.6g} s "
                         f"({run.error.message}): left out of its sensitivity")
            continue
        out.append(run)
    return out


def _sensitivity(probes: list[ProbeComparison], switches: list[SwitchingComparison],
                 selfs: list[tuple[str, float, float, float]],
                 spreads: list[tuple[float, float]], steady_nrms: list[float],
                 window: tuple[float, float], tol: Tolerances) -> tuple[str, str]:
    """Apply the rules for state-driven switching (module docstring, "Sensitive runs") to
    the records in place; return (``Comparison.transient``, ``Comparison.sensitivity``).

    ``selfs``: per probe (name, transient, window, NRMS tolerance), the largest RMS change
    of a perturbed pelcs run / scale; ``spreads``: per probe the largest change of its
    window mean and ripple (absolute)."""
    if not selfs:  # no perturbed run: source-driven switching, compared over the whole run
        for p in probes:
            p.transient_nrms = math.nan
        return "", ""
    half_tol = 0.5  # pelcs' own change may take up to half of a tolerance
    parted = [f"{name} by {100 * w:.3g} % RMS (tolerance {100 * t:.3g} %)"
              for name, _, w, t in selfs if w > half_tol * t]
    # (the instants' tolerance already allows ngspice's steps, which the sampled comparators
    # reproduce: their change is held to the whole tolerance)
    parted += [f"{s.switch}'s instants by {format_eng(s.self_offset, 's')} (tolerance "
               f"{format_eng(s.tol, 's')})"
               for s in switches if s.method == "instants" and s.self_offset > s.tol]
    if parted:
        for p, (dm, dr) in zip(probes, spreads, strict=True):
            p.transient_nrms = math.nan
            if not p.nrms <= p.nrms_tol:  # a pass is agreement all the same
                p.pointwise = "sensitive orbit"
            # a window of a chaotic orbit is a sample of its statistics: pelcs' runs are
            # samples, ngspice's another; it may lie about twice their spread away
            p.mean_tol += 2.0 * dm
            p.ripple_tol += 2.0 * dr
        for s in switches:
            if s.method == "instants" and math.isfinite(s.self_offset) and not s.ok:
                s.inconclusive = "sensitive orbit"
        return "", ("pelcs' own perturbed runs (half the step; comparators sampled on the "
                    "grid, as ngspice's land on its steps) part in the steady-state window ("
                    + "; ".join(parted) + "): the run there is sensitive to perturbations "
                    "(a chaotic orbit, the phase of a subharmonic one, or a transient not "
                    "settled yet)")
    unsettled = [(name, tr, t) for name, tr, _, t in selfs if tr > half_tol * t]
    if not unsettled:
        for p in probes:
            p.transient_nrms = math.nan
        return "", ""
    for p, (_, tr, w, _t), nw in zip(probes, selfs, steady_nrms, strict=True):
        p.nrms_over, p.nrms, p.self_nrms = "steady state", nw, w
        # the transient can still fail: by more than pelcs' own error (up to twice its
        # change, first order) and ngspice's (the sampled comparators' change is one of
        # its kind), as large on the same start-up
        p.transient_tol = p.nrms_tol + 4.0 * tr
    name, tr, t = max(unsettled, key=lambda u: u[1] / u[2])
    return (f"the transient before {format_eng(window[0], 's')} is not compared point by "
            f"point: pelcs' own perturbed runs differ there by up to {100 * tr:.3g} % RMS "
            f"({name}), over half the {100 * t:.3g} % tolerance (the start-up of "
            "state-driven switching is ill-conditioned); NRMS over the steady-state window, "
            "the transient only fails past the tolerance + 4 × that difference", "")


def _restart_check(circuit: Circuit, ng_name: Callable[[str], str], result: SimulationResult,
                   ng: NgspiceResult,
                   probes: Sequence[str], records: list[ProbeComparison],
                   switches: list[SwitchingComparison], reading: list[tuple],
                   grid: np.ndarray, sel: np.ndarray, window: tuple[float, float],
                   notes: list[str]) -> str:
    """pelcs restarted from ngspice's state at the window's start, against ngspice over the
    window (module docstring, "Sensitive runs"). When it follows ngspice within the NRMS,
    mean and instants' tolerances, both simulators have the same dynamics and the runs'
    difference is the orbit their start-ups chose: the failing window metrics are set aside
    (``unjudged``, ``inconclusive``) and the reason returned; else nothing changes and
    ``""`` is returned. ``ng_name`` spells a state as ngspice measured it;
    ``reading``: per switch (name, control probe, VT, half band, initial
    state, instants from pelcs' events?, ngspice's instants)."""
    from lcs.integrators.moreau.integrator import simulate
    from netlist.studies.transient import transient_setup

    t_n = np.asarray(ng.time, dtype=float)
    h = float(np.median(np.diff(np.asarray(result.t, dtype=float))))
    try:
        setup = transient_setup(circuit, step=h)
        x0 = np.array([np.interp(window[0], t_n, ng.signals[ng_name(st)])
                       for st in setup.system.states])
    except (KeyError, NetlistError):  # a state ngspice does not show (a pwl gate's RC)
        return ""
    controls = [r[1] for r in reading]
    theta = run_theta(result)
    try:
        restart = simulate(setup.system, setup.signals, x0, setup.t_stop, setup.h,
                           theta=theta, t_start=window[0],
                           probes=list(dict.fromkeys([*probes, *controls])))
    except (ValueError, RuntimeError, KeyError) as exc:  # the failures stay judged
        notes.append(f"pelcs could not restart from ngspice's state at "
                     f"{format_eng(window[0], 's')}: {exc}")
        return ""
    if restart.error is not None:
        return ""
    # its instants, read as the compared run's were, against ngspice's in the window
    events = _pelcs_instants(restart, [r[0] for r in reading])
    t_r = np.asarray(restart.t, dtype=float)
    ends = (window[0], float(min(t_r[-1], t_n[-1])))
    by_name = {w.switch: w for w in switches}
    for name, ctrl, vt, band, initial, from_events, ni in reading:
        w = by_name[name]
        if w.method != "instants":
            continue
        ri = events[name] if from_events else _ngspice_instants(t_r, restart[ctrl], vt, band,
                                                                initial)
        off = max(_hausdorff(x, y, *ends, ends, w.tol) for x, y in ((ri.on, ni.on),
                                                                      (ri.off, ni.off)))
        if not off <= w.tol:
            notes.append(f"pelcs restarted from ngspice's state at "
                         f"{format_eng(window[0], 's')} does not follow it either ({name}'s "
                         f"instants {format_eng(off, 's')} apart, tolerance "
                         f"{format_eng(w.tol, 's')})")
            return ""
    tr = np.asarray(restart.t, dtype=float)
    rows = []
    for p in records:
        tri, yri = _strictly_increasing(tr, np.asarray(restart[p.probe], float))
        tni, yni = _strictly_increasing(t_n, np.asarray(ng.signals[p.ngspice_probe], float))
        d = np.interp(grid, tni, yni) - np.interp(grid, tri, yri)
        nrms = _nrms(d, sel) / p.scale
        mean = _mean(*_in_window(tni, yni, *window)) - _mean(*_in_window(tri, yri, *window))
        rows.append((p, nrms, mean))
    if not all(n <= p.nrms_tol and abs(m) <= p.mean_tol for p, n, m in rows):
        worst = max(rows, key=lambda r: r[1] / r[0].nrms_tol)
        notes.append(f"pelcs restarted from ngspice's state at {format_eng(window[0], 's')} "
                     f"does not follow it either ({worst[0].probe}: {100 * worst[1]:.3g} % "
                     f"RMS over the window, tolerance {100 * worst[0].nrms_tol:.3g} %)")
        return ""
    for p, n, m in rows:
        p.restart_nrms, p.restart_mean_error = n, m
        window_fails = set(p.failures) - {"transient nrms"} - (
            {"nrms"} if p.nrms_over == "run" else set())
        if window_fails:
            p.unjudged = "another orbit"
    for w in switches:
        if not w.ok:
            w.inconclusive = "another orbit"
    if not any(p.unjudged for p in records) and not any(
            w.inconclusive == "another orbit" for w in switches):
        return ""  # what fails is not in the window (a transient): nothing set aside
    worst = max(rows, key=lambda r: r[1] / r[0].nrms_tol)
    return (f"pelcs and ngspice end on different orbits (or phases of one), but pelcs "
            f"restarted from ngspice's state at {format_eng(window[0], 's')} follows ngspice "
            f"over the window ({worst[0].probe}: {100 * worst[1]:.3g} % RMS, tolerance "
            f"{100 * worst[0].nrms_tol:.3g} %; means within theirs): the same dynamics, and "
            "the start-up of state-driven switching chooses among coexisting orbits")
