"""The stroboscopic map of a periodically driven switched LCS: ``P(x) = x(t0 + T)``.

The sources must be T-periodic from ``t0`` on (a check is made and reported in
:attr:`StroboscopicMap.notes`). Many periods are simulated in one
:func:`~lcs.integrators.moreau.integrator.simulate` call with the instants ``t0 + k T`` as
breakpoints and ``save_at`` points, so that exactly the period samples are stored (no Python work
per period). Should a run lack a period sample, it is repeated storing every step and the
samples are picked by time.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..results import SimulationResult
from .base import MapError, Samples
from .lcs_map import _EVERY_NONE, _TIME_MATCH, LcsMapBase
from .patterns import SwitchingPattern

__all__ = ["StroboscopicMap"]


class StroboscopicMap(LcsMapBase):
    """``P(x) = x(t0 + T)`` from ``x(t0) = x`` for a T-periodically driven switched LCS.

    Parameters
    ----------
    system : SwitchedLCS
    signals : sequence of Signal
        Resolved source waveforms, one per input (:func:`lcs.signals.resolve`).
    period : float
        Sampling period T, s (the period of the drive or ramp).
    h : float
        Time step, s. Choose T/h an integer so that every period has the same grid.
    theta : float
        Moreau θ.
    t0 : float
        Sampling phase, s.
    param, param_name : optional
        The parameter value this map was built for (bookkeeping only).
    on_inconsistent : callable, optional
        Passed to :func:`~lcs.integrators.moreau.integrator.simulate` (state jump of an inconsistent
        start).
    options : MoreauOptions, optional
    diode_probes : sequence of str
        One probe per diode (in ``system.diodes`` order) that is positive while the diode
        conducts, e.g. ``"i(D1)"``; used for the switching pattern.
    scale : array_like, shape (n,), optional
        Typical state magnitudes (A, V).
    """

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        # False once a run lacked a period sample (then every step is stored and the
        # samples are picked by time); save_at makes that a safety net only.
        self._save_at_ok = True

    def __call__(self, x) -> np.ndarray:
        return self.power(x, 1)

    def power(self, x, k: int) -> np.ndarray:
        """``P^k(x)`` by one simulation over k periods (only the end state is kept)."""
        k = int(k)
        x = np.asarray(x, dtype=float)
        if k == 0:
            return x.copy()
        t_end = self.t0 + k * self.period
        bps = self.t0 + self.period * np.arange(1, k + 1)
        res = self._simulate(x, self.t0, t_end, every=_EVERY_NONE, breakpoints=bps)
        if not res.ok:
            raise self._fail(res, x)
        return res.x_final.copy()

    def _run_sampled(self, x, n: int, probes: Sequence[str] | None
                     ) -> tuple[np.ndarray, np.ndarray, SimulationResult]:
        """Simulate n periods in one call; return (instants reached, values (n+1, q), result).

        The period instants are ``save_at`` points of the run (stored whatever ``every``
        says, and step boundaries). Rows of ``values`` at instants not reached (failed run)
        are NaN.
        """
        t_end = self.t0 + n * self.period
        targets = self.t0 + self.period * np.arange(n + 1)
        bps = targets[1:]
        tol = _TIME_MATCH * self.h
        attempts = [_EVERY_NONE, 1] if self._save_at_ok else [1]
        for every in attempts:
            res = self._simulate(x, self.t0, t_end, every=every, breakpoints=bps,
                                 probes=probes, save_at=bps)
            t = res.t
            pos = np.clip(np.searchsorted(t, targets - tol), 0, len(t) - 1)
            hit = np.abs(t[pos] - targets) <= tol
            t_ok = t[-1] if len(t) else self.t0
            reached = targets <= t_ok + tol
            if np.all(hit[reached]) or every == 1:
                values = np.full((n + 1, res.y.shape[1]), np.nan)
                good = reached & hit
                values[good] = res.y[pos[good]]
                return good, values, res
            self._save_at_ok = False
        raise AssertionError("unreachable")  # pragma: no cover

    def iterate(self, x, n: int) -> np.ndarray:
        """``x, P(x), ..., P^n(x)``, shape (n + 1, n_states), from one simulation."""
        n = int(n)
        good, values, res = self._run_sampled(x, n, None)
        if not res.ok or not np.all(good):
            raise self._fail(res, x)
        values[0] = np.asarray(x, dtype=float)
        return values

    def sample(self, x, skip: int, record: int, probes: Sequence[str] | None = None
               ) -> Samples:
        """Probes at the period instants ``t0 + k T``, k = skip+1 .. skip+record (one run).

        ``probes`` may name any probe the system knows (``v(out)``, ``i(D1)``, states);
        default: the states. A probe is evaluated at the end of the step landing on the
        period instant.
        """
        skip, record = int(skip), int(record)
        names = tuple(probes) if probes else self.state_names
        x = np.asarray(x, dtype=float)
        try:
            good, values, res = self._run_sampled(x, skip + record, list(names))
        except MapError as exc:  # calibration run failed
            return Samples(names, np.full((record, len(names)), np.nan),
                           np.full(self.dim, np.nan), False, str(exc))
        rows = values[skip + 1:]
        if not res.ok:
            return Samples(names, rows, np.full(self.dim, np.nan), False,
                           str(self._fail(res, x)))
        return Samples(names, rows, res.x_final.copy(), True)

    def trajectory(self, x, k: int = 1, probes: Sequence[str] | None = None
                   ) -> SimulationResult:
        """The full run over k periods from ``x`` (every step stored)."""
        k = int(k)
        bps = self.t0 + self.period * np.arange(1, k + 1)
        res = self._simulate(x, self.t0, self.t0 + k * self.period, every=1, breakpoints=bps,
                             probes=probes)
        if not res.ok:
            raise self._fail(res, x)
        return res

    def pattern(self, x, k: int = 1) -> SwitchingPattern:
        """Switch and diode configurations over k periods from ``x``."""
        probes = list(self.state_names) + list(self.diode_probes)
        res = self.trajectory(x, k, probes)
        return self._pattern_from(res, self.t0, self.t0 + int(k) * self.period)
