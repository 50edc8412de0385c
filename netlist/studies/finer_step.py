"""A run whose comparators chatter at the deck's step, taken again on finer grids until two
of them agree.

ngspice adapts its step to what the circuit does; pelcs steps on a fixed grid and locates
the switchings inside each step. A control that moves faster than the grid resolves (a ring
of switch inverters whose RC is a fraction of ngspice's step bound) makes a comparator switch
more than ``max_switchings`` times inside one step, and the run stops with that error
(:func:`lcs.simulation.failures.chattering`). Where the step is the deck's, not one the user
chose, the run is taken again at a tenth of it, a hundredth, a thousandth (while the grid
stays within :data:`STEP_BUDGET` steps). A grid on which the comparators no longer chatter
is not yet evidence of an answer, so the result is the first run that agrees with the run on
a grid ten times coarser (each probe's mean over the second half of the run within
:data:`AGREEMENT` of the probe's range there), the finer of the two; the note says which
steps ran and that they agree. Where no two agree within the budget, the result is the first
run, stopped by its error, and the note says that no finer grid converged. ngspice's ring of
switch inverters (``.tran 10n 80n 50p``: a 1.6 ns step, eight times the inverters' RC) runs
at 0.16 ns and 16 ps, means 1.526 V and 1.514 V over the second half (ngspice 1.528 V).

The command's run of ideal devices that streams its rows to a file as it goes
(``pelcs simulate -o``) is not retried: it keeps the error, which says to take a smaller step.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from lcs.results import SimulationResult

__all__ = ["AGREEMENT", "REFINEMENT", "STEP_BUDGET", "finer_on_chattering"]

#: each retry's step is the previous one over this
REFINEMENT = 10
#: the most steps a retry may take
STEP_BUDGET = 1_000_000
#: two runs agree when each probe's mean over the second half differs by at most this
#: fraction of the probe's range there (the larger of the two runs')
AGREEMENT = 0.02


def _chatters(res: SimulationResult) -> bool:
    return res.error is not None and res.error.kind == "chattering"


def _means(res: SimulationResult) -> tuple[np.ndarray, np.ndarray]:
    """Each probe's mean over the second half of the run and its range there."""
    t = np.asarray(res.t, dtype=float)
    y = np.asarray(res.y, dtype=float).reshape(len(t), -1)
    keep = t >= (t[0] + t[-1]) / 2
    tk, yk = t[keep], y[keep]
    span = tk[-1] - tk[0] if len(tk) > 1 else 0.0
    mean = (np.trapezoid(yk, tk, axis=0) / span) if span > 0 else yk.mean(axis=0)
    return mean, np.ptp(yk, axis=0)


def _agree(a: SimulationResult, b: SimulationResult) -> float | None:
    """The largest difference of the probes' second-half means of ``a`` and ``b`` as a
    fraction of their ranges; None when they do not cover the same run."""
    if a.error is not None or b.error is not None or a.names != b.names or not len(a.t):
        return None
    (ma, ra), (mb, rb) = _means(a), _means(b)
    scale = np.maximum(np.maximum(ra, rb), 1e-12 * np.maximum(np.abs(ma), np.abs(mb)))
    scale = np.where(scale > 0, scale, 1.0)
    return float(np.max(np.abs(ma - mb) / scale)) if ma.size else 0.0


def finer_on_chattering(run: Callable[[float | None], SimulationResult], h: float,
                        span: float) -> SimulationResult:
    """``run(None)`` at the deck's step ``h`` (s); where a comparator chatters on it,
    ``run(h / REFINEMENT**k)``, k = 1, 2, ..., while the grid over ``span`` (s) stays within
    :data:`STEP_BUDGET` steps, until a run's probes agree with those of the run ten times
    coarser (:data:`AGREEMENT`); that run, with a note."""
    res = run(None)
    if not _chatters(res):
        return res
    first = res.error
    why = (f"switch {first.switch} chattered at the deck's step {h:.4g} s (t = "
           f"{first.t_prev:.6g} s: its control moves faster than that grid resolves)")
    tried: list[tuple[float, SimulationResult]] = []
    k = 1
    while span / (h / REFINEMENT**k) <= STEP_BUDGET:
        step = h / REFINEMENT**k
        tried.append((step, run(step)))
        k += 1
        if len(tried) >= 2:
            (h_a, a), (h_b, b) = tried[-2], tried[-1]
            gap = _agree(a, b)
            if gap is not None and gap <= AGREEMENT:
                b.notes.insert(0, (
                    f"{why}: the run was taken again on finer grids; the runs at {h_a:.4g} s "
                    f"and {h_b:.4g} s agree (each probe's mean over the second half within "
                    f"{gap:.2%} of its range), and the result is the run at {h_b:.4g} s"))
                return b
    if tried:
        # (no answer established: the first run, with its error, is the result)
        steps = ", ".join(f"{s:.4g} s" for s, _ in tried)
        res.notes.insert(0, (
            f"{why}: the run was taken again at {steps}; no two of those runs agree (within "
            f"{AGREEMENT:.0%} of each probe's range) within {STEP_BUDGET:,} steps: NOT "
            "CONVERGED, the run stops where it chattered (choose a step with --step)"))
    return res
