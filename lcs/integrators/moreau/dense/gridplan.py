"""The Moreau integrator's time grid: uniform steps ``h`` between the boundaries (breakpoints,
known switching instants, save instants), each segment ending with one shortened step."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lcs.jit import jitted
from lcs.simulation.inputs import MERGE_FRACTION, SNAP_FRACTION


@dataclass(frozen=True)
class GridPlan:
    """The step sequence over consecutive segments ``bounds[i] .. bounds[i+1]``.

    Each segment starts its own uniform grid ``sa + j h`` (j = 1..n_regular) and ends with
    one shortened ("odd") step of length ``last`` onto ``sb`` when the segment is not a whole
    number of steps. A remainder shorter than ``SNAP_FRACTION * h`` is merged into the last
    regular step (one slightly longer odd step) so that no needlessly tiny step is taken.

    Attributes
    ----------
    bounds : ndarray, shape (S + 1,)
        Segment boundaries, s.
    n_regular : ndarray of int64, shape (S,)
    last : ndarray, shape (S,)
        Length of the final odd step, s (0: none, the grid lands on ``sb``).
    start : ndarray of int64, shape (S + 1,)
        Global index of each segment's first step (``start[-1]`` = total steps).
    """

    bounds: np.ndarray
    h: float
    n_regular: np.ndarray
    last: np.ndarray
    start: np.ndarray

    @property
    def total(self) -> int:
        return int(self.start[-1])


@jitted
def _plan_nb(bounds, h, merge, snap_frac, n_reg, last, start):
    nseg = bounds.shape[0] - 1
    start[0] = 0
    for i in range(nseg):
        L = bounds[i + 1] - bounds[i]
        r = L / h
        N = np.rint(r)
        aligned = N >= 1 and abs(L - N * h) <= merge * h * max(1.0, r)
        if aligned:
            n_reg[i] = int(N)
            last[i] = 0.0
        else:
            Nf = np.floor(r)
            rem = L - Nf * h
            if rem <= 0.0:  # floor round-off
                Nf -= 1
                rem = L - Nf * h
            if Nf >= 1 and rem < snap_frac * h:
                n_reg[i] = int(Nf) - 1
                last[i] = h + rem
            else:
                n_reg[i] = int(Nf)
                last[i] = rem
        start[i + 1] = start[i] + n_reg[i] + (1 if last[i] > 0 else 0)


def plan_grid(bounds: np.ndarray, h: float) -> GridPlan:
    """Step counts of every segment (compiled loop over the segments)."""
    bounds = np.ascontiguousarray(bounds, dtype=float)
    nseg = len(bounds) - 1
    n_reg = np.empty(nseg, np.int64)
    last = np.empty(nseg)
    start = np.empty(nseg + 1, np.int64)
    _plan_nb(bounds, float(h), MERGE_FRACTION, SNAP_FRACTION, n_reg, last, start)
    return GridPlan(bounds, float(h), n_reg, last, start)


@jitted
def _fill_grid(bounds, n_regular, last, start, h, g0, g1, t_prev, t, odd, seg_out):
    """Step ends ``t[1:]``, odd flags and segment indices of global steps ``g0 .. g1-1``."""
    t[0] = t_prev
    seg = 0
    while start[seg + 1] <= g0:
        seg += 1
    for g in range(g0, g1):
        while g >= start[seg + 1]:
            seg += 1
        jj = g - start[seg]
        nreg = n_regular[seg]
        sa = bounds[seg]
        sb = bounds[seg + 1]
        o = jj >= nreg
        if o:
            te = sb
        elif jj == nreg - 1 and last[seg] == 0.0:
            # A segment that is a whole number of steps ends exactly on its boundary.
            te = sb
        else:
            te = sa + (jj + 1) * h
        t[g - g0 + 1] = te
        odd[g - g0] = o
        seg_out[g - g0] = seg


def grid_chunks(plan: GridPlan, chunk: int):
    """Yield ``(t, odd, seg)`` for consecutive pieces of at most ``chunk`` steps.

    ``t`` (k + 1,) are step boundaries (the first is the end of the previous piece), ``odd``
    (k,) flags shortened steps and ``seg`` (k,) gives each step's segment index.
    """
    total = plan.total
    t_prev = float(plan.bounds[0])
    bounds = np.ascontiguousarray(plan.bounds, dtype=float)
    n_reg = np.ascontiguousarray(plan.n_regular, dtype=np.int64)
    last = np.ascontiguousarray(plan.last, dtype=float)
    start = np.ascontiguousarray(plan.start, dtype=np.int64)
    for g0 in range(0, total, chunk):
        g1 = min(total, g0 + chunk)
        t = np.empty(g1 - g0 + 1)
        odd = np.empty(g1 - g0, np.bool_)
        seg = np.empty(g1 - g0, np.int64)
        _fill_grid(bounds, n_reg, last, start, float(plan.h), g0, g1, t_prev, t, odd, seg)
        t_prev = float(t[-1])
        yield t, odd, seg
