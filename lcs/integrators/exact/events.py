"""Event-driven following of a switched LCS with exact flows between events.

Between events a mode (switch configuration, pairs held at ``w = 0``) is an affine ODE whose
flow over an interval of linear inputs is one matrix exponential (:mod:`.flow`). From a state
at ``t0`` the span ``[t0, t1]`` is followed mode by mode: every interval between fixed
instants (source breakpoints, latch clocks, the span's end) is sampled (one matrix
exponential, repeated; the spacing also resolves the mode's fastest oscillation and decay),
the first sign change of an event function (a switch's comparator margin, a held pair's λ, a
free pair's w) is refined by Brent's method on the exact flow, and the next mode is the
consistent one nearest the current (:meth:`Follower.select`).

Scope: sources DC, PULSE, PWL and SIN; switches driven by comparators (with hysteresis) or
latched PWM; no Python controllers. A comparator without hysteresis whose surface both modes
cross back slides (:mod:`.sliding`: Filippov's equivalent dynamics); other accumulations of
events at one instant stop with :class:`ExactError` naming the element.
"""

from __future__ import annotations

import contextlib
import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm
from scipy.optimize import brentq

from ...model import ModeKey, SwitchedLCS
from .flow import InputPiece, ModeFlow, ModeFlowError, flow_matrix, linear_piece, mode_flow

__all__ = ["Event", "ExactError", "Follower", "Segment", "SwitchRule", "switch_rules"]

# Samples per interval between fixed instants when looking for an event (at least).
_SAMPLES = 24
# Sample spacing: at most this fraction of a radian of the mode's fastest oscillation.
_PHASE_STEP = 0.25
# Most samples per interval (a very long interval is cut in pieces of this many samples).
_MAX_SAMPLES = 4096
# Events in a row at one instant before the run is declared stuck (sliding, chattering).
_MAX_SAME_INSTANT = 12


def _is_sin(signal) -> bool:
    """A resolved SIN source (a damped sinusoid after its delay)."""
    return (type(signal).__name__ == "Sin" and getattr(signal, "freq", None) is not None
            and hasattr(signal, "theta"))


_CONTROLLER: list = []


def one_blas_thread():
    """Context manager: the BLAS libraries on one thread (threadpoolctl; a no-op without
    it)."""
    if not _CONTROLLER:
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:  # pragma: no cover - a dependency; only a broken install lacks it
            _CONTROLLER.append(None)
        else:
            _CONTROLLER.append(ThreadpoolController())
    ctl = _CONTROLLER[0]
    return ctl.limit(limits=1, user_api="blas") if ctl is not None else \
        contextlib.nullcontext()


class ExactError(RuntimeError):
    """The exact flow could not be followed (the message says why and names the elements
    involved)."""


class FollowStopped(ExactError):
    """Following stopped because the caller asked (its ``stop`` callable said so, e.g. an
    interrupt): ``segments`` and ``events`` hold what was done."""


@dataclass(frozen=True)
class SwitchRule:
    """A switch's comparator: on while ``control > vt + vh``, off while ``< vt - vh``; a
    latched switch turns on only at ``phase + k period``."""

    name: str
    control: str
    vt: float
    vh: float
    latch_period: float | None = None
    latch_phase: float = 0.0


def switch_rules(system: SwitchedLCS) -> list[SwitchRule]:
    """The comparator of every switch of ``system`` (``LATCH``, ``PERIOD``, ``PHASE`` model
    options make it latched, see ``docs/switching.md``)."""
    rules = []
    for s in system.switches:
        opts = {str(k).lower(): v for k, v in (s.options or {}).items()}
        latch = bool(opts.get("latch", 0))
        period = float(opts["period"]) if latch and opts.get("period") else None
        rules.append(SwitchRule(s.name, s.control, float(s.vt), float(s.vh), period,
                                float(opts.get("phase", 0.0) or 0.0)))
    return rules


@dataclass
class Segment:
    """An interval of one mode and its inputs (:class:`~.flow.InputPiece`, s from
    ``t_start``).

    Attributes
    ----------
    t_start, t_end : float
        s.
    key : ModeKey
        Switch states.
    flow : ModeFlow
        Dynamics (held pairs ``flow.held``).
    piece : InputPiece
        The inputs over the interval.
    x_start : ndarray (n,)
        State at ``t_start``.
    """

    t_start: float
    t_end: float
    key: ModeKey
    flow: ModeFlow
    piece: InputPiece
    x_start: np.ndarray

    @property
    def duration(self) -> float:
        return self.t_end - self.t_start

    @property
    def u0(self) -> np.ndarray:
        """Inputs at ``t_start``."""
        return self.piece.u(0.0)


@dataclass
class Event:
    """The boundary between segment ``index`` and ``index + 1``.

    Attributes
    ----------
    t : float
        s.
    kind : str
        ``"switch"`` or ``"pair"`` (state-dependent instants), ``"clock"`` (latch re-arm) or
        ``"breakpoint"`` (a source corner): fixed instants.
    name : str
        Switch or diode name ("" for a breakpoint).
    index : int
        Segment before the event.
    hx, hu, hd : ndarray (n,), (p,), (p,) or None
        The event function ``h = hx x + hu u + hd u' (+ const)`` of a state-dependent
        instant, in the mode before.
    hdot : float
        dh/dt just before the event.
    jump : bool
        The state jumped at the event (impulsive diode currents, :mod:`lcs.theory.wellposed`):
        the next segment starts from the state after the jump.
    """

    t: float
    kind: str
    name: str
    index: int
    hx: np.ndarray | None = None
    hu: np.ndarray | None = None
    hd: np.ndarray | None = None
    hdot: float = 0.0
    jump: bool = False

    @property
    def moves(self) -> bool:
        """Whether the instant moves with the state and the inputs."""
        return self.hx is not None


class Follower:
    """Follows ``[t0, t0 + period]`` (a switching period, or any span): the system, the
    sources, the switch rules and the caches of mode flows."""

    def __init__(self, system: SwitchedLCS, signals: Sequence, t0: float, period: float,
                 jump=None, stop=None):
        bad = [name for name, s in zip(system.inputs, signals, strict=True)
               if not (getattr(s, "piecewise_linear", False) or _is_sin(s))]
        if bad:
            raise ExactError(
                f"the exact method needs piecewise-linear or SIN sources (DC, PULSE, PWL, "
                f"SIN); {', '.join(bad)} {'is' if len(bad) == 1 else 'are'} not: use a "
                "time-stepping method (Moreau; for pelcs ac the sweep method)")
        self.system = system
        # on_inconsistent(lcs, x, u) -> x_plus (or (x_plus, note)): the state jump when an
        # event leaves no consistent continuation (a switch closing a diode onto a charged
        # capacitor); None: such an event stops the run
        self.jump = jump
        # stop() -> bool, asked before each segment: True ends the span with FollowStopped
        # (the exact integrator's answer to an interrupt; None: never)
        self.stop = stop
        self.signals = list(signals)
        self.omega_in = max((2 * np.pi * s.freq for s in self.signals if _is_sin(s)),
                            default=0.0)
        self.t0 = float(t0)
        self.T = float(period)
        self.rules = switch_rules(system)
        self.n, self.m, self.p = len(system.states), len(system.diodes), len(system.inputs)
        self._flows: dict = {}
        self._controls: dict = {}
        self._rate_cache: dict = {}
        t1 = self.t0 + self.T
        fixed = [self.t0, t1]
        for s in self.signals:
            fixed.extend(float(v) for v in s.breakpoints(self.t0, t1))
        self.clocks: list[tuple[float, int]] = []
        for j, r in enumerate(self.rules):
            if r.latch_period:
                k0 = int(np.ceil((self.t0 - r.latch_phase) / r.latch_period - 1e-9))
                tc = r.latch_phase + k0 * r.latch_period
                while tc < t1 - 1e-12 * self.T:
                    self.clocks.append((tc, j))
                    fixed.append(tc)
                    tc += r.latch_period
        fixed = np.unique(np.clip(np.asarray(fixed, dtype=float), self.t0, t1))
        keep = [fixed[0]]
        for v in fixed[1:]:
            if v - keep[-1] > 1e-12 * self.T:
                keep.append(v)
        keep[-1] = t1
        self.fixed = np.asarray(keep)

    # --- modes -----------------------------------------------------------------------------
    def flow(self, key: ModeKey, held: tuple[int, ...]) -> ModeFlow:
        ck = (key, held)
        if ck not in self._flows:
            self._flows[ck] = mode_flow(self.system.mode(key), held)
        return self._flows[ck]

    def controls(self, key: ModeKey):
        if key not in self._controls:
            names = [r.control for r in self.rules]
            self._controls[key] = self.system.outputs(key, names) if names else None
        return self._controls[key]

    def inputs_on(self, ta: float, tb: float) -> InputPiece:
        """The inputs on ``[ta, tb]`` (a stretch inside one piece of every source: sampled
        inside it, so that a corner at an end does not count)."""
        d = tb - ta
        s1, s2 = ta + 0.25 * d, ta + 0.75 * d
        u0 = np.zeros(self.p)
        u1 = np.zeros(self.p)
        osc = []
        for k, sig in enumerate(self.signals):
            if getattr(sig, "piecewise_linear", False):
                v1 = float(np.asarray(sig(np.array([s1])))[0])
                v2 = float(np.asarray(sig(np.array([s2])))[0])
                u1[k] = (v2 - v1) / (s2 - s1) if d > 0 else 0.0
                u0[k] = v1 - 0.25 * d * u1[k]
            elif ta < sig.td - 1e-12 * self.T:  # before its delay: a constant
                u0[k] = sig.vo + sig.va * np.sin(sig.phase * np.pi / 180.0)
            else:
                osc.append(k)
        if not osc:
            return linear_piece(u0, u1)
        q = 2 + 2 * len(osc)
        U = np.zeros((self.p, q))
        U[:, 0], U[:, 1] = u0, u1
        M = np.zeros((q, q))
        M[1, 0] = 1.0
        z0 = np.zeros(q)
        z0[0] = 1.0
        for r, k in enumerate(osc):
            sig = self.signals[k]
            w = 2 * np.pi * sig.freq
            age = max(ta - sig.td, 0.0)
            alpha = w * age + sig.phase * np.pi / 180.0
            amp = sig.va * np.exp(-sig.theta * age)
            a, b = 2 + 2 * r, 3 + 2 * r  # e^{-θs} sin ωs, e^{-θs} cos ωs
            U[k, 0] = sig.vo
            U[k, a], U[k, b] = amp * np.cos(alpha), amp * np.sin(alpha)
            M[a, a], M[a, b] = -sig.theta, w
            M[b, a], M[b, b] = -w, -sig.theta
            z0[b] = 1.0
        return InputPiece(U, M, z0)

    def guards(self, key: ModeKey, flow: ModeFlow):
        """Event functions of a mode, each ``>= 0`` while the mode lasts: rows
        ``(gx, gu, gd, g0)`` and their labels ``(kind, name, index)``."""
        gx, gu, gd, g0, labels = [], [], [], [], []
        for i in range(self.m):
            if i in flow.held:
                gx.append(flow.Lx[i]), gu.append(flow.Lu[i]), gd.append(flow.Ld[i])
            else:
                gx.append(flow.Wx[i]), gu.append(flow.Wu[i]), gd.append(flow.Wd[i])
            g0.append(0.0)
            labels.append(("pair", self.system.diodes[i], i))
        ctl = self.controls(key)
        if ctl is not None:
            cx, cu, cd = flow.affine(ctl.Cy, ctl.Dy, ctl.Fy)
            for j, r in enumerate(self.rules):
                if key[j]:
                    gx.append(cx[j]), gu.append(cu[j]), gd.append(cd[j])
                    g0.append(-(r.vt - r.vh))
                elif r.latch_period is None:
                    gx.append(-cx[j]), gu.append(-cu[j]), gd.append(-cd[j])
                    g0.append(r.vt + r.vh)
                else:
                    continue
                labels.append(("switch", r.name, j))
        # explicit row counts: with no states (n = 0) or no sources (p = 0) a -1 would be
        # ambiguous for an empty array
        k = len(g0)
        return (np.array(gx, dtype=float).reshape(k, self.n),
                np.array(gu, dtype=float).reshape(k, self.p),
                np.array(gd, dtype=float).reshape(k, self.p), np.array(g0, dtype=float), labels)

    def control_value(self, key: ModeKey, flow: ModeFlow, j: int, x, u, du) -> float:
        """Switch j's control voltage at state x, inputs u and their rates du."""
        ctl = self.controls(key)
        cx, cu, cd = flow.affine(ctl.Cy, ctl.Dy, ctl.Fy)
        return float(cx[j] @ x + cu[j] @ u + cd[j] @ du)

    # --- mode selection --------------------------------------------------------------------
    def _consistent(self, key, held, x, ta, tb) -> ModeFlow | None:
        try:
            flow = self.flow(key, held)
        except ModeFlowError:
            return None
        piece = self.inputs_on(ta, tb)
        u0, u1 = piece.u(0.0), piece.du(0.0)
        if flow.Kx.shape[0]:
            res = flow.Kx @ x + flow.Ku @ u0
            # relative to the whole state's size: at an event the constraint is zero only to
            # the root's accuracy, and its own terms may all be near zero (i(L) = 1e-13 A)
            scale = (np.abs(flow.Kx) @ np.abs(x) + np.abs(flow.Ku) @ np.abs(u0)
                     + np.abs(flow.Kx).sum(axis=1) * np.max(np.abs(x), initial=0.0) + 1e-300)
            if np.any(np.abs(res) > 1e-8 * scale + 1e-14):
                return None
        gx, gu, gd, g0, labels = self.guards(key, flow)
        pairs = [k for k, lab in enumerate(labels) if lab[0] == "pair"]
        if not pairs:
            return flow
        gx, gu, gd, g0 = gx[pairs], gu[pairs], gd[pairs], g0[pairs]
        tol = 1e-9 * (np.abs(gx) @ np.abs(x) + np.abs(gu) @ np.abs(u0)
                      + np.abs(gd) @ np.abs(u1)) + 1e-13
        g = gx @ x + gu @ u0 + gd @ u1 + g0
        if np.any(g < -tol):
            return None
        # Pairs at zero must not go negative right away.
        delta = min(1e-6 * self.T, 0.25 * (tb - ta))
        G = flow_matrix(flow, piece)
        z = expm(G * delta) @ np.concatenate([x, piece.z0])
        gz = self._event_rows(gx, gu, gd, g0, piece)
        g2 = gz @ z
        if np.any((np.abs(g) <= tol) & (g2 < -tol)):
            return None
        return flow

    def enter(self, key, prefer, x, t, tb, why: str, events) -> tuple[ModeFlow, np.ndarray]:
        """The mode after an event and the state in it: :meth:`select`, and when no held set
        is consistent, the state jump of ``self.jump`` (marked on the last event)."""
        try:
            flow = self.select(key, prefer, x, t, tb, why)
        except ExactError as exc:
            if self.jump is None:
                raise
            u0 = self.inputs_on(t, tb).u(0.0)
            try:
                out = self.jump(self.system.mode(key), np.asarray(x, dtype=float).copy(), u0)
            except (RuntimeError, ValueError):
                # no jump rule either (the jump's LCP has no solution): the mode itself is
                # ill-posed, which the configuration error already says
                raise exc from None
            x_plus = np.asarray(out[0] if isinstance(out, tuple) else out, dtype=float)
            if np.allclose(x_plus, x, rtol=1e-12, atol=0.0):
                raise
            flow = self.select(key, prefer, x_plus, t, tb, why + ", after a state jump")
            if events:
                events[-1].jump = True
            x = x_plus
        return flow, self.project(flow, x, t)

    def project(self, flow: ModeFlow, x: np.ndarray, t: float) -> np.ndarray:
        """``x`` moved onto the held set's state constraints ``Kx x + Ku u = 0`` (by the
        least change), which it satisfies up to an event's round-off."""
        if not flow.Kx.shape[0]:
            return x
        u0 = self.inputs_on(t, t + 1e-9 * self.T).u(0.0)
        res = flow.Kx @ x + flow.Ku @ u0
        return x - np.linalg.lstsq(flow.Kx, res, rcond=None)[0]

    def select(self, key, prefer: tuple[int, ...], x, ta, tb, why: str) -> ModeFlow:
        """The consistent held set nearest ``prefer`` in the switch configuration ``key``."""
        flow = self._consistent(key, prefer, x, ta, tb)
        if flow is not None:
            return flow
        pref = set(prefer)
        others = range(self.m)
        max_flip = self.m if self.m <= 12 else 2
        for k in range(1, max_flip + 1):
            for flip in itertools.combinations(others, k):
                held = tuple(sorted(pref.symmetric_difference(flip)))
                flow = self._consistent(key, held, x, ta, tb)
                if flow is not None:
                    return flow
        sw = ", ".join(f"{r.name} {'on' if on else 'off'}" for r, on in
                       zip(self.rules, key, strict=True)) or "no switches"
        raise ExactError(f"no consistent diode configuration at t = {ta:.9g} s ({why}; "
                            f"{sw}): the exact method cannot continue; use a time-stepping method "
                         "(Moreau; for pelcs ac the sweep method)")

    # --- one period ------------------------------------------------------------------------
    def follow(self, x0, key0: ModeKey, held0: tuple[int, ...] = ()
               ) -> tuple[list[Segment], list[Event], np.ndarray]:
        """Segments and events over the span from ``x0`` at t0 with switch states ``key0``.

        ``held0`` is the preferred held set at the start (the consistent one nearest it is
        taken). While it runs, ``self.segments`` and ``self.events`` hold what is done, so
        that a caller catching :class:`ExactError` keeps the partial result.
        """
        # The matrices are tiny (states + inputs): a multithreaded BLAS only adds thread
        # hand-offs, and on a loaded machine its spinning threads made each exponential 15
        # to 20 times slower (the Deane-Hamill buck: 150-225 ms a period against 10 ms).
        with one_blas_thread():
            return self._follow(x0, key0, held0)

    def _follow(self, x0, key0: ModeKey, held0: tuple[int, ...]
                ) -> tuple[list[Segment], list[Event], np.ndarray]:
        x = np.asarray(x0, dtype=float).copy()
        t = self.t0
        key = tuple(key0)
        key = self._apply_clocks(key, t, x, None)
        fi = 1  # index of the next fixed instant
        flow = self.select(key, tuple(held0), x, t, self.fixed[1], "start of the span")
        x = self.project(flow, x, t)
        segs: list[Segment] = []
        events: list[Event] = []
        self.segments, self.events, self.x = segs, events, x
        self.sliding: int | None = None
        same_instant = 0
        while True:
            if self.stop is not None and segs and self.stop():
                raise FollowStopped(f"stopped at t = {t:.9g} s")
            tb = self.fixed[fi]
            # a long interval is searched in pieces (each a whole number of samples)
            tc = min(tb, t + self.search_span(flow))
            if tb - tc <= 1e-12 * self.T:
                tc = tb
            piece = self.inputs_on(t, tb)
            G = flow_matrix(flow, piece)
            hit = self._first_event(key, flow, G, x, piece, t, tc)
            if hit is None:
                z = expm(G * (tc - t)) @ np.concatenate([x, piece.z0])
                segs.append(Segment(t, tc, key, flow, piece, x))
                x = z[:self.n]
                self.x = x
                if tc < tb:  # a piece of a long interval: same mode, no event
                    events.append(Event(tc, "breakpoint", "", len(segs) - 1))
                    t = tc
                    continue
                if fi == len(self.fixed) - 1:
                    return segs, events, x
                kind, name = "breakpoint", ""
                new_key = self._apply_clocks(key, tb, x, flow)
                if new_key != key:
                    kind = "clock"
                    name = ", ".join(r.name for r, a, b in zip(self.rules, key, new_key,
                                                                strict=True) if a != b)
                events.append(Event(tb, kind, name, len(segs) - 1))
                t, key = tb, new_key
                fi += 1
                nb = self.fixed[fi]
                flow, x = self.enter(key, flow.held, x, t, nb, f"{kind} at {t:.9g} s",
                                     events)
                same_instant = 0
                continue
            s, row, (kind, name, idx), hrow = hit
            z = expm(G * s) @ np.concatenate([x, piece.z0])
            segs.append(Segment(t, t + s, key, flow, piece, x))
            x = z[:self.n]
            self.x = x
            gx, gu, gd = hrow
            du = piece.du(s)
            f_minus = flow.Af @ x + flow.Ef @ piece.u(s) + flow.Ed @ du
            hdot = float(gx @ f_minus + gu @ du + gd @ piece.d2u(s))
            events.append(Event(t + s, kind, name, len(segs) - 1, gx.copy(), gu.copy(),
                                gd.copy(), hdot))
            same_instant = same_instant + 1 if s <= 1e-12 * self.T else 0
            if same_instant > _MAX_SAME_INSTANT:
                raise ExactError(
                    f"{name} changes state again and again at t = {t:.9g} s (a sliding mode "
                    "or chattering): the exact method does not handle it; use a time-stepping "
                    "method (Moreau; for pelcs ac the sweep method)")
            t = t + s
            if kind == "switch":
                slid = self._slide(idx, key, flow, x, t, fi, segs, events)
                if slid is not None:
                    done, t, fi, key, flow, x = slid
                    if done:
                        return segs, events, x
                    same_instant = 0
                    continue
                key = tuple((not v) if j == idx else v for j, v in enumerate(key))
                prefer = flow.held
            else:
                prefer = tuple(sorted(set(flow.held).symmetric_difference({idx})))
            flow, x = self.enter(key, prefer, x, t, tb, f"{kind} {name} at {t:.9g} s", events)

    # --- sliding ---------------------------------------------------------------------------
    def _slide(self, j: int, key: ModeKey, flow: ModeFlow, x, t: float, fi: int, segs, events):
        """Switch j has reached its surface at t: if both modes drive the state back across
        it, follow the Filippov sliding motion (:mod:`.sliding`) until it ends. Returns None
        when there is no sliding, else ``(done, t, fi, key, flow, x)`` after it (``done``:
        the span ended while sliding)."""
        from .sliding import slide

        r = self.rules[j]
        if r.vh != 0.0 or r.latch_period is not None:
            return None
        k_off = tuple(False if i == j else v for i, v in enumerate(key))
        k_on = tuple(True if i == j else v for i, v in enumerate(key))
        tb = self.fixed[fi]
        f_off = self._consistent(k_off, flow.held, x, t, tb)
        f_on = self._consistent(k_on, flow.held, x, t, tb)
        if f_off is None or f_on is None:
            return None
        rows = []
        for k_m, f_m in ((k_off, f_off), (k_on, f_on)):
            ctl = self.controls(k_m)
            cx, cu, cd = f_m.affine(ctl.Cy, ctl.Dy, ctl.Fy)
            rows.append((cx[j], cu[j], cd[j]))
        piece = self.inputs_on(t, tb)

        def rate(row, f):
            du = piece.du(0.0)
            fx = f.Af @ x + f.Ef @ piece.u(0.0) + f.Ed @ du
            return float(row[0] @ fx + row[1] @ du + row[2] @ piece.d2u(0.0))

        c_off, c_on = rate(rows[0], f_off), rate(rows[1], f_on)
        tol = 1e-9 * (abs(c_off) + abs(c_on)) + 1e-300
        if not (c_on < -tol and c_off > tol):
            return None
        if events:
            events[-1].kind = "slide"  # the crossing starts a sliding motion
        scale = float(np.max(np.abs(x), initial=0.0)) or 1.0
        name = r.name
        while True:
            piece = self.inputs_on(t, tb)
            seg, x, exit_ = slide(j, k_on, (f_off, f_on), tuple(rows), piece, t, x, t, tb,
                                  scale)
            segs.append(seg)
            self.x = x
            if exit_ is None:  # reached the fixed instant tb, still sliding
                if fi == len(self.fixed) - 1:
                    self.sliding = j
                    return True, tb, fi, k_on, f_on, x
                events.append(Event(tb, "breakpoint", "", len(segs) - 1))
                t, fi = tb, fi + 1
                tb = self.fixed[fi]
                continue
            t = seg.t_end
            events.append(Event(t, "slide-end", name, len(segs) - 1))
            key = k_on if exit_ == 1 else k_off
            flow = self.select(key, flow.held, x, t, tb, f"end of {name}'s sliding at {t:.9g} s")
            return False, t, fi, key, flow, self.project(flow, x, t)

    # --- event search ----------------------------------------------------------------------
    def _rates(self, flow: ModeFlow) -> tuple[float, np.ndarray]:
        """The mode's fastest oscillation (rad/s) and its fast decay rates (1/s)."""
        ck = id(flow)  # flows live in self._flows as long as self: ids stay unique
        if ck not in self._rate_cache:
            ev = np.linalg.eigvals(flow.Af) if flow.Af.size else np.zeros(0)
            omega = float(np.max(np.abs(ev.imag))) if ev.size else 0.0
            decay = np.unique(-ev.real[ev.real < 0]) if ev.size else np.zeros(0)
            self._rate_cache[ck] = (omega, decay)
        return self._rate_cache[ck]

    def search_span(self, flow: ModeFlow) -> float:
        """Longest interval searched in one piece: ``_MAX_SAMPLES`` samples that resolve the
        mode's fastest oscillation (a quarter radian apart)."""
        omega = max(self._rates(flow)[0], self.omega_in)
        if omega <= 0.0:
            return np.inf
        return _MAX_SAMPLES * _PHASE_STEP / omega

    def _samples(self, flow: ModeFlow, d: float, omega_in: float = 0.0
                 ) -> tuple[int, np.ndarray]:
        """Uniform sample count over ``[0, d]`` and extra early instants for fast decays
        (a sign change inside a fast transient would fall between uniform samples).
        ``omega_in``: the inputs' fastest oscillation, rad/s."""
        omega, decay = self._rates(flow)
        omega = max(omega, omega_in)
        n = max(_SAMPLES, int(np.ceil(d * omega / _PHASE_STEP)) if omega > 0 else 0)
        n = min(n, _MAX_SAMPLES)
        spacing = d / n
        extra = []
        for rate in decay:
            tau = 1.0 / rate
            if tau < 0.5 * spacing:
                extra.extend(v for v in (0.1 * tau, 0.3 * tau, tau, 3.0 * tau, 10.0 * tau)
                             if v < spacing)
        return n, np.unique(np.asarray(extra, dtype=float))

    def _apply_clocks(self, key, t, x, flow) -> ModeKey:
        """Latched switches turn on at their clock instants unless their comparator demands
        off."""
        out = list(key)
        for tc, j in self.clocks:
            if abs(tc - t) <= 1e-12 * self.T and not out[j]:
                r = self.rules[j]
                if flow is None:
                    out[j] = True  # at t0: the comparator is checked by the first segment
                    continue
                piece = self.inputs_on(t, t + 1e-9 * self.T)
                c = self.control_value(tuple(out), flow, j, x, piece.u(0.0), piece.du(0.0))
                out[j] = c >= r.vt - r.vh
        return tuple(out)

    @staticmethod
    def _event_rows(gx, gu, gd, g0, piece: InputPiece) -> np.ndarray:
        """Event functions as rows on ``[x; z]``: ``gx x + gu U z + gd U M z + g0 z[0]``."""
        rows = np.column_stack([gx, gu @ piece.U + gd @ (piece.U @ piece.M)])
        rows[:, gx.shape[1]] += g0
        return rows

    def _first_event(self, key, flow, G, x, piece: InputPiece, ta, tb):
        gx, gu, gd, g0, labels = self.guards(key, flow)
        if not labels:
            return None
        gz = self._event_rows(gx, gu, gd, g0, piece)
        z0 = np.concatenate([x, piece.z0])
        d = tb - ta
        count, extra = self._samples(flow, d, piece.omega)
        step = expm(G * (d / count))
        zs = [z0]
        for _ in range(count):
            zs.append(step @ zs[-1])
        times = np.arange(count + 1) * (d / count)
        if extra.size:
            times = np.concatenate([times, extra])
            zs.extend(expm(G * s) @ z0 for s in extra)
            order = np.argsort(times, kind="stable")
            times = times[order]
            zs = [zs[i] for i in order]
        Z = np.array(zs)
        g = Z @ gz.T  # (samples, rows)
        scale = np.abs(Z) @ np.abs(gz).T
        tol = 1e-9 * scale + 1e-13
        best = None
        for r in range(g.shape[1]):
            neg = np.nonzero(g[1:, r] < -tol[1:, r])[0]
            if not neg.size:
                continue
            k = int(neg[0]) + 1
            sa, sb = float(times[k - 1]), float(times[k])
            def fn(s, r=r):
                return float(gz[r] @ (expm(G * s) @ z0))

            # the samples came by repeated products, fn by one exponential: their round-off
            # differs, so the bracket is checked on fn itself
            if g[k - 1, r] <= 0.0 or fn(sa) <= 0.0:
                root = sa
            elif fn(sb) >= 0.0:
                root = sb
            else:
                root = brentq(fn, sa, sb, xtol=1e-16 * self.T, rtol=1e-15)
            if best is None or root < best[0]:
                best = (root, r)
        if best is None:
            return None
        root, r = best
        return root, r, labels[r], (gx[r], gu[r], gd[r])



