"""The stroboscopic map of a switched LCS computed exactly, with its exact Jacobian.

``P(x) = x(t0 + T)`` follows one period with :class:`~.events.Follower` (exact flows, events
to round-off); ``jacobian`` composes the segments' transition matrices with the saltation
matrix of every event (:func:`~.saltation.affine_period`), so Newton shooting
(:func:`lcs.analysis.orbits.find_orbit`) converges quadratically and the Floquet multipliers
carry no finite-difference error. Every analysis that takes a :class:`~lcs.analysis.base.Map`
(orbits, continuation, bifurcation diagrams, basins) takes this one.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..integrators.exact.events import ExactError, Follower, one_blas_thread
from ..model import ModeKey, SwitchedLCS
from .base import Map, MapError, Samples
from .patterns import PatternSegment, SwitchingPattern
from .saltation import affine_period

__all__ = ["ExactStroboscopicMap"]


class ExactStroboscopicMap(Map):
    """``P(x) = x(t0 + T)`` by the exact event-driven flow.

    Parameters
    ----------
    system : SwitchedLCS
    signals : sequence
        One resolved piecewise-linear waveform per input.
    period : float
        T, s.
    t0 : float
        Sampling phase, s.
    key0 : tuple of bool, optional
        Switch states at ``t0`` for comparators inside their hysteresis band (default: the
        netlist's ``ON``/``OFF``); comparators without hysteresis take the state their
        control voltage gives at ``t0``.
    param, param_name : optional
    scale : array_like (n,), optional
        Typical state magnitudes.
    diode_probes : sequence of str
        One probe per diode, positive while it conducts (``"i(D1)"``): the pattern's diode
        states.
    """

    method = "exact"

    def __init__(self, system: SwitchedLCS, signals: Sequence, period: float, *,
                 t0: float = 0.0, key0: ModeKey | None = None, param: float | None = None,
                 param_name: str | None = None, scale=None, diode_probes=()):
        self.system = system
        self.signals = list(signals)
        self.period = float(period)
        self.t0 = float(t0)
        self.state_names = tuple(system.states)
        self.param, self.param_name = param, param_name
        self._scale = None if scale is None else np.asarray(scale, dtype=float)
        self.notes: list[str] = []
        self.diode_probes = tuple(diode_probes)
        try:
            self._follower = Follower(system, self.signals, self.t0, self.period)
        except ExactError as exc:
            raise MapError(str(exc)) from None
        k = len(system.switches)
        self.key0 = tuple(key0) if key0 is not None else tuple(False for _ in range(k))
        self._last: tuple | None = None

    def natural_scale(self) -> np.ndarray | None:
        return self._scale

    # --- one period ------------------------------------------------------------------------
    def start_key(self, x: np.ndarray) -> ModeKey:
        """Switch states at t0: comparators without hysteresis from their control voltage."""
        f = self._follower
        key = list(self.key0)
        if not f.rules:
            return ()
        tb = f.fixed[1]
        try:
            flow = f.select(tuple(key), (), x, f.t0, tb, "start of the period")
        except ExactError:
            return tuple(key)
        piece = f.inputs_on(f.t0, tb)
        u0, du = piece.u(0.0), piece.du(0.0)
        for j, r in enumerate(f.rules):
            if r.vh == 0.0 and r.latch_period is None:
                key[j] = f.control_value(tuple(key), flow, j, x, u0, du) > r.vt
        return tuple(key)

    def follow(self, x):
        """Segments, events and end state of one period from ``x`` (cached for the last x)."""
        x = np.asarray(x, dtype=float)
        if self._last is not None and np.array_equal(self._last[0], x):
            return self._last[1]
        try:
            with one_blas_thread():  # tiny matrices (see Follower.follow)
                out = self._follower.follow(x, self.start_key(x))
        except ExactError as exc:
            raise MapError(str(exc)) from None
        self._last = (x.copy(), out)
        return out

    def __call__(self, x) -> np.ndarray:
        return self.follow(x)[2].copy()

    def sample(self, x, skip: int, record: int, probes: Sequence[str] | None = None
               ) -> Samples:
        """Probes at the period instants ``t0 + j T``, j = skip+1 .. skip+record.

        ``probes`` may name any probe the system knows (``v(out)``, ``i(D1)``, states), as the
        Moreau map's: each is evaluated just before the period instant, in the mode of the
        period's last stretch (a sliding stretch: the modes' values weighted by the
        equivalent duty). Never raises for a failing run: ``ok`` is False, the message says
        why and the rows not reached are NaN.
        """
        names = tuple(probes) if probes else self.state_names
        values = np.full((int(record), len(names)), np.nan)
        y = np.asarray(x, dtype=float)
        try:
            y = self.power(y, int(skip))
            for j in range(int(record)):
                segs, _, y_next = self.follow(y)
                values[j] = self.probe_values(segs[-1], y_next, names)
                y = y_next.copy()
        except MapError as exc:
            return Samples(names, values, np.full(self.dim, np.nan), False, str(exc))
        return Samples(names, values, y, True)

    def probe_values(self, seg, x: np.ndarray, names: Sequence[str]) -> np.ndarray:
        """Probes ``names`` at the end of the stretch ``seg``, whose end state is ``x``."""
        s = seg.t_end - getattr(seg, "t_piece", seg.t_start)
        u, du = seg.piece.u(s), seg.piece.du(s)
        if hasattr(seg, "flow"):
            parts = [(1.0, seg.key, seg.flow)]
        else:  # sliding: the Filippov combination of the off and on modes
            d = seg.duty(seg.t_end, x)
            parts = [(1.0 - d, tuple(False if i == seg.switch else v
                                     for i, v in enumerate(seg.key)), seg.flows[0]),
                     (d, tuple(True if i == seg.switch else v
                               for i, v in enumerate(seg.key)), seg.flows[1])]
        y = np.zeros(len(names))
        for weight, key, f in parts:
            lam = f.Lx @ x + f.Lu @ u + f.Ld @ du
            free = np.ones(lam.size, dtype=bool)
            free[list(f.held)] = False
            lam[free] = 0.0
            try:
                om = self.system.outputs(key, list(names))
            except (KeyError, ValueError) as exc:
                raise MapError(f"probe: {exc}") from None
            y += weight * (om.Cy @ x + om.Dy @ lam + om.Fy @ u)
        return y

    def jacobian(self, x, k: int, scale: np.ndarray | None = None,
                 rel_step: float = 1e-5) -> np.ndarray:
        """Exact Jacobian of ``P^k`` at ``x`` (transition and saltation matrices).

        Through a sliding motion (a Filippov stretch, integrated numerically) the saltation
        composition does not apply: the Jacobian is then the central difference of the exact
        map (steps ``rel_step * scale``), and the map's notes say so.
        """
        y = np.asarray(x, dtype=float)
        J = np.eye(y.size)
        p = len(self.system.inputs)
        for _ in range(int(k)):
            segs, events, y_next = self.follow(y)
            if any(not hasattr(seg, "flow") for seg in segs):
                note = ("the Jacobian through a sliding motion is a central difference of "
                        "the exact map (no saltation composition for Filippov stretches)")
                if note not in self.notes:
                    self.notes.append(note)
                sc = (np.asarray(scale, dtype=float) if scale is not None else
                      np.maximum(np.abs(np.asarray(x, dtype=float)), 1e-9))
                return super().jacobian(x, k, sc, rel_step)
            try:
                with one_blas_thread():
                    J = affine_period(segs, events, 0.0, np.zeros(p)).P.real @ J
            except ZeroDivisionError as exc:  # a grazing event: no saltation
                raise MapError(str(exc)) from None
            y = y_next
        return J

    def pattern(self, x, k: int = 1) -> SwitchingPattern | None:
        """Switch and diode configurations over k periods from ``x``: one per stretch
        (a diode conducts when its current, ``diode_probes``, is positive at the stretch's
        midpoint). Continuation compares them to detect border collisions; with exact
        stretches the instants are exact too."""
        if not self.diode_probes and not self.system.switches:
            return None
        y = np.asarray(x, dtype=float)
        segs_all, t_shift = [], 0.0
        for _ in range(int(k)):
            segs, _, y = self.follow(y)
            segs_all += [(seg, t_shift) for seg in segs]
            t_shift += self.period
        out: list[PatternSegment] = []
        for seg, shift in segs_all:
            if seg.duration <= 0.0:
                continue
            sw = tuple(bool(v) for v in seg.key)
            dio = self._conducting(seg)
            start = seg.t_start - self.t0 + shift
            if out and out[-1].switches == sw and out[-1].diodes == dio:
                last = out[-1]
                out[-1] = PatternSegment(last.start, start + seg.duration - last.start, sw,
                                         dio)
            else:
                out.append(PatternSegment(start, seg.duration, sw, dio))
        return SwitchingPattern(tuple(s.name for s in self.system.switches),
                                tuple(self.system.diodes), tuple(out),
                                int(k) * self.period)

    def _conducting(self, seg) -> tuple:
        if not self.diode_probes:
            return tuple(False for _ in self.system.diodes)
        s = 0.5 * seg.duration
        if hasattr(seg, "flow"):
            from scipy.linalg import expm

            from ..integrators.exact.flow import flow_matrix

            G = flow_matrix(seg.flow, seg.piece)
            xm = (expm(G * s) @ np.concatenate([seg.x_start, seg.piece.z0]))[:seg.x_start.size]
            f, key = seg.flow, seg.key
        else:  # sliding: the on mode's view
            xm = np.asarray(seg.sol(seg.t_start + s), dtype=float)
            f, key = seg.flows[1], seg.key
        u, du = seg.piece.u(s), seg.piece.du(s)
        lam = f.Lx @ xm + f.Lu @ u + f.Ld @ du
        free = np.ones(lam.size, dtype=bool)
        free[list(f.held)] = False
        lam[free] = 0.0
        om = self.system.outputs(key, list(self.diode_probes))
        cur = om.Cy @ xm + om.Dy @ lam + om.Fy @ u
        scale = max(float(np.max(np.abs(cur), initial=0.0)), 1e-12)
        return tuple(bool(c > 1e-9 * scale + 1e-12) for c in cur)
