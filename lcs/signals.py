"""Independent-source waveforms with ngspice's semantics: DC, PULSE, SIN, PWL, EXP, SFFM, AM.

Fields that ngspice fills from the ``.tran`` line when they are omitted are ``None`` here and
are filled by :func:`resolve` (``resolve(sig, tstep, tstop)``). Every waveform evaluates on
arrays of times (s) and lists its breakpoints (the instants where it is not smooth), so that a
time stepper can land exactly on them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .arrays import unique_sorted

_EPS = float(np.finfo(float).eps)
# Instants of a PULSE's evaluation kept for the next (a run's few hundred breakpoints; a
# long array is not kept)
_MEMO_MAX = 4096
_NAN1 = np.array([np.nan])


@dataclass(frozen=True)
class Dc:
    """Constant value (V or A)."""

    value: float

    piecewise_linear = True

    def __call__(self, t):
        return np.full_like(np.asarray(t, dtype=float), self.value)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        return np.empty(0)


@dataclass(frozen=True)
class Pulse:
    """``PULSE(V1 V2 TD TR TF PW PER [NP])``.

    As in ngspice, TR and TF default to TSTEP, PW and PER to TSTOP (an explicit 0 is replaced
    the same way: a "triangle" written with PW = 0 has a flat top TSTOP long in ngspice, and
    here), NP (number of pulses) to unlimited (0 too).

    Each period, from ``TD + k PER``, the waveform is V1 at its start, rises to V2 over TR,
    stays there PW, falls over TF and is V1 again; ngspice cuts the period at PER whatever its
    edges, so a pulse with ``TR + PW + TF > PER`` (a duty cycle of 1) jumps back to V1 at every
    period start (from V2, or from where its fall had got to). After NP periods it is V1.
    """

    v1: float
    v2: float
    td: float = 0.0
    tr: float | None = None
    tf: float | None = None
    pw: float | None = None
    per: float | None = None
    np_: float | None = None

    piecewise_linear = True

    def _require_resolved(self) -> None:
        if None in (self.tr, self.tf, self.pw, self.per):
            raise ValueError("PULSE defaults not resolved: call lcs.signals.resolve first")

    @property
    def jumps(self) -> bool:
        """Whether the waveform may jump: at period starts when ``TR + PW + TF > PER``, and at
        the end of a fractional number of pulses."""
        # (asked for every evaluation of the inputs: kept)
        known = self.__dict__.get("_last_jumps")
        if known is not None:
            return known
        self._require_resolved()
        cut = self.tr + self.pw + self.tf > self.per
        known = self.per > 0 and (cut or bool(self.np_ and self.np_ != math.floor(self.np_)))
        object.__setattr__(self, "_last_jumps", known)
        return known

    def __call__(self, t, side: int = 0):
        """Values at the times ``t`` (s); ``side`` +1 / -1: right / left limits (they differ
        only at the jumps of a pulse whose edges outlast its period)."""
        self._require_resolved()
        t = np.asarray(t, dtype=float)
        if t.size == 1 and math.isfinite(t.flat[0]):
            # One instant (an initial value, a step's input): the same arithmetic on a
            # Python float, without some thirty numpy calls on one-element arrays.
            return np.full(t.shape, self._at(float(t.flat[0]), side))
        if t.ndim != 1 or t.size > _MEMO_MAX:
            return self._values(t, side)
        # A run asks for the same instants again (its segments' starts, their ends, its input
        # table): each value depends on its instant alone, so those known serve. The known
        # instants are sorted, and end with a NaN that no instant equals (no index past the
        # end to clip).
        memo = self.__dict__.get("_last_values")
        if memo is not None and memo[0] == side:
            known_t, known_v = memo[1], memo[2]
            idx = known_t.searchsorted(t)
            hit = known_t.take(idx) == t
            out = known_v.take(idx)
            if hit.all():
                return out
            miss = ~hit
            new_t = t[miss]
            new_v = (np.array([self._at(float(new_t[0]), side)]) if new_t.size == 1
                     and math.isfinite(new_t[0]) else self._values(new_t, side))
            out[miss] = new_v
            if known_t.size + new_t.size <= _MEMO_MAX:
                # (kept with those already known: the next call may ask for either)
                new_t = np.concatenate((known_t, new_t))
                new_v = np.concatenate((known_v, new_v))
            else:
                new_t, new_v = np.concatenate((t, _NAN1)), np.concatenate((out, _NAN1))
        else:
            # (with the ends of the run whose breakpoints were asked for: a run evaluates its
            # segments' starts, then their ends, the last of which is its end)
            last = self.__dict__.get("_last_breakpoints")
            ends = np.array([last[0], last[1], np.nan]) if last is not None and math.isfinite(
                last[0]) and math.isfinite(last[1]) else _NAN1
            new_t = np.concatenate((t, ends))
            new_v = np.empty_like(new_t)
            new_v[-1] = np.nan
            new_v[:-1] = self._values(new_t[:-1], side)
            out = new_v[:t.size].copy()
        order = new_t.argsort(kind="stable")  # (the NaN last)
        object.__setattr__(self, "_last_values", (side, new_t.take(order), new_v.take(order)))
        return out

    def __getstate__(self) -> dict:
        # (pickled without what it keeps of its evaluations: not part of the value)
        return {k: v for k, v in self.__dict__.items() if not k.startswith("_last_")}

    def _values(self, t: np.ndarray, side: int) -> np.ndarray:
        # (the arithmetic of _at, array-wise; in place where it can be: a run evaluates a
        # few hundred instants, and each numpy call costs more than its arithmetic)
        if t.ndim != 1:
            return self._values(np.ravel(t), side).reshape(t.shape)
        tau = t - self.td
        per = self.per
        after = None
        if per > 0:
            # the period an instant belongs to: [k PER, (k+1) PER), or (k PER, (k+1) PER] for
            # a left limit; a period start within round-off is one (9.8e-4 / 2e-5 exceeds 49
            # by an ulp, which would take the end of period 48 for the start of period 49)
            q = tau / per
            near = np.rint(q)  # (np.round's half to even)
            off = q - near
            np.abs(off, out=off)
            scale = np.abs(q)
            np.maximum(scale, 1.0, out=scale)
            scale *= 64 * _EPS
            np.copyto(q, near, where=off <= scale)
            if side < 0:
                k = np.ceil(q)
                k -= 1.0
            else:
                k = np.floor(q)
            np.maximum(k, 0.0, out=k)
            if self.np_:
                # ngspice: V1 once TD + NP PER is past
                tmax = self.np_ * per
                after = tau >= tmax if side > 0 else tau > tmax
            k *= per
            tau -= k
        tr, tf, pw = self.tr, self.tf, self.pw
        # An instant within round-off of an edge is on it: the levels at the corners are then
        # exactly V1 and V2 (2.1e-3 - 1e-3 exceeds 1e-4 + 1e-3 by an ulp, which would put the
        # end of a flat top on its fall, 2e-15 V below V2, where a switch threshold may sit).
        tol = 16 * _EPS * (np.abs(t) + abs(self.td) + max(per, 0.0))
        edges = (0.0, tr, tr + pw, tr + pw + tf, per)
        _snap_to_edges(tau, edges, tol)
        v1, v2 = self.v1, self.v2
        out = np.empty_like(tau)
        out.fill(v1)
        top = tr + pw
        # (the three parts are disjoint; an instant on none of them is at V1)
        high = (tau >= tr) & (tau <= top)
        out[high] = v2
        rising = (tau > 0) & (tau < tr)
        if rising.any():
            out[rising] = v1 + (v2 - v1) * tau[rising] / tr
        falling = (tau > top) & (tau < top + tf)
        if falling.any():
            out[falling] = v2 + (v1 - v2) * (tau[falling] - tr - pw) / tf
        if after is not None:
            out[after] = v1
        return out

    def value_at(self, t: float, side: int = 0) -> float:
        """The value at one finite instant ``t`` (s): what :meth:`__call__` gives for it,
        without the array."""
        self._require_resolved()
        return self._at(t, side)

    def _at(self, t: float, side: int) -> float:
        """:meth:`__call__` at one finite instant, operation for operation (IEEE doubles:
        the same bits)."""
        tau = t - self.td
        per = self.per
        after = False
        if per > 0:
            q = tau / per
            near = float(round(q))  # (half to even, as np.round)
            if abs(q - near) <= 64 * _EPS * max(1.0, abs(q)):
                q = near
            k = float(math.ceil(q) - 1 if side < 0 else math.floor(q))
            k = max(k, 0.0)
            if self.np_:
                tmax = self.np_ * per
                after = tau >= tmax if side > 0 else tau > tmax
            tau = tau - k * per
        tr, tf, pw = self.tr, self.tf, self.pw
        tol = 16 * _EPS * (abs(t) + abs(self.td) + max(per, 0.0))
        for edge in (0.0, tr, tr + pw, tr + pw + tf, per):
            if abs(tau - edge) <= tol:
                tau = edge
        v1, v2 = self.v1, self.v2
        if after:
            return float(v1)
        if tau >= tr and tau <= tr + pw:
            return float(v2)
        if tau > tr + pw and tau < tr + pw + tf:
            return v2 + (v1 - v2) * (tau - tr - pw) / tf
        if tau > 0 and tau < tr:
            return v1 + (v2 - v1) * tau / tr
        return float(v1)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        """The instants in ``[t0, t1]`` where the waveform has a corner or a jump, s: every
        period's start and the edges that come before its end."""
        # (a run asks twice, for its plan and its input table: the last answer is kept)
        last = self.__dict__.get("_last_breakpoints")
        if last is not None and last[0] == t0 and last[1] == t1:
            return last[2].copy()
        pts = self._breakpoints(t0, t1)
        object.__setattr__(self, "_last_breakpoints", (t0, t1, pts))
        return pts.copy()

    def _breakpoints(self, t0: float, t1: float) -> np.ndarray:
        self._require_resolved()
        edges = (0.0, self.tr, self.tr + self.pw, self.tr + self.pw + self.tf)
        if self.per <= 0:
            pts = self.td + np.array(edges)
        else:
            edges = np.array([e for e in edges if e < self.per])
            k0 = max(0, math.floor((t0 - self.td) / self.per) - 1)
            k1 = math.ceil((t1 - self.td) / self.per) + 1
            if self.np_:
                k1 = min(k1, int(math.ceil(self.np_)) - 1)
            last = max(k1, k0)
            ks = np.arange(k0, last + 1)
            pts = (self.td + ks[:, None] * self.per + edges[None, :]).ravel()
            # the end of the last period (where a cut pulse jumps back to V1)
            end = [self.td + (last + 1) * self.per]
            if self.np_:
                pts = pts[pts <= self.td + self.np_ * self.per]
                end.append(self.td + self.np_ * self.per)
            pts = np.concatenate((pts, end))
        pts = unique_sorted(pts)
        # (sorted, no NaN: the instants in [t0, t1] are a slice)
        return pts[pts.searchsorted(t0, "left"):pts.searchsorted(t1, "right")]


def _snap_to_edges(tau: np.ndarray, edges: tuple[float, ...], tol: np.ndarray) -> None:
    """Set to each edge in turn the entries of ``tau`` within ``tol`` of it (in place).

    Where the edges are more than four tolerances apart, an entry is within tolerance of
    one edge at most, and the edge it then takes is no nearer another: one comparison of
    every entry with every edge gives what the edges in turn give."""
    order = sorted(edges)
    gap = min(b - a for a, b in zip(order[:-1], order[1:], strict=True))
    if gap > 4.0 * tol.max(initial=0.0):
        e = np.array(edges)
        dist = tau[:, None] - e
        np.abs(dist, out=dist)
        # (the first edge within tolerance, or edge 0 where none is, which then is not)
        edge = e.take((dist <= tol[:, None]).argmax(axis=1))
        dist = tau - edge
        np.abs(dist, out=dist)
        np.copyto(tau, edge, where=dist <= tol)
        return
    for edge in edges:
        dist = tau - edge
        np.abs(dist, out=dist)
        np.copyto(tau, edge, where=dist <= tol)


@dataclass(frozen=True)
class Sin:
    """``SIN(VO VA FREQ TD THETA PHASE)``; FREQ defaults to 1/TSTOP, PHASE in degrees."""

    vo: float
    va: float
    freq: float | None = None
    td: float = 0.0
    theta: float = 0.0
    phase: float = 0.0

    piecewise_linear = False

    def __call__(self, t):
        if self.freq is None:
            raise ValueError("SIN defaults not resolved: call lcs.signals.resolve first")
        t = np.asarray(t, dtype=float)
        ph = self.phase * math.pi / 180.0
        tau = np.maximum(t - self.td, 0.0)
        return self.vo + self.va * np.exp(-tau * self.theta) * np.sin(
            2 * math.pi * self.freq * tau + ph
        )

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        return np.array([self.td]) if t0 <= self.td <= t1 and self.td > 0 else np.empty(0)


@dataclass(frozen=True)
class Pwl:
    """``PWL(T1 V1 T2 V2 ...) [r=R] [td=TD]``: linear between points, V1 before the first
    point, the last value after the last one; as in ngspice, ``r=R`` (the time of one of the
    points, before the last) repeats the part from R to the last point for ever, and ``td``
    delays the whole waveform (s). Two points at one time make a jump, and so does a repeated
    part whose last value is not its first.
    """

    times: tuple[float, ...]
    values: tuple[float, ...]
    repeat: float | None = None
    delay: float = 0.0

    piecewise_linear = True

    @property
    def jumps(self) -> bool:
        """Whether the waveform jumps (two points at one time, or at the repetitions)."""
        if np.any(np.diff(np.asarray(self.times, dtype=float)) == 0):
            return True
        return self.repeat is not None and self._value_at(self.repeat) != self.values[-1]

    def _value_at(self, t: float) -> float:
        return float(self.values[list(self.times).index(t)])

    def _fold(self, t: np.ndarray, side: int) -> np.ndarray:
        """Time in the written waveform: delay removed, repetitions folded onto [R, last]."""
        t = t - self.delay
        if self.repeat is None:
            return t
        end, r = float(self.times[-1]), float(self.repeat)
        per = end - r
        # repetition k >= 1 covers (end + (k-1) per, end + k per]; a left limit at its end
        # stays in it, a right limit at its start goes to the next one
        q = (t - end) / per
        # a repetition boundary within round-off is on it ((5e-6 - 3e-6) / 2e-6 < 1)
        q = np.where(np.abs(q - np.round(q)) <= 1e-9, np.round(q), q)
        k = np.ceil(q) if side < 0 else np.floor(q) + 1
        return np.where(q > 0 if side < 0 else q >= 0, t - k * per, t)

    def __call__(self, t, side: int = 0):
        """Values at the times ``t`` (s); ``side`` +1 / -1: right / left limits (they differ
        only at jumps)."""
        t = np.asarray(t, dtype=float)
        if self.repeat is not None and side == 0:
            side = 1  # ngspice: at a repetition's start, the first value of the part
        t = self._fold(t, side)
        if side == 0:
            # (at a time two points share, the first's value, as ngspice's PWL: a PWL from
            # (0, 0) to (0, 5) is 0 at t = 0)
            times = np.asarray(self.times, dtype=float)
            at = np.minimum(np.searchsorted(times, t, side="left"), len(times) - 1)
            return np.where(times[at] == t, np.asarray(self.values, dtype=float)[at],
                            np.interp(t, times, self.values))
        times = np.asarray(self.times, dtype=float)
        values = np.asarray(self.values, dtype=float)
        idx = np.searchsorted(times, t, side="right" if side > 0 else "left")
        lo = np.clip(idx - 1, 0, len(times) - 1)
        hi = np.clip(idx, 0, len(times) - 1)
        t_lo, t_hi = times[lo], times[hi]
        span = np.where(t_hi > t_lo, t_hi - t_lo, 1.0)
        frac = np.clip((t - t_lo) / span, 0.0, 1.0)
        out = values[lo] + (values[hi] - values[lo]) * np.where(t_hi > t_lo, frac, 0.0)
        out = np.where(idx == 0, values[0], out)
        return np.where(idx >= len(times), values[-1], out)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        pts = np.asarray(self.times, dtype=float) + self.delay
        if self.repeat is not None:
            times = np.asarray(self.times, dtype=float)
            part = times[times >= self.repeat] - self.repeat  # from 0 to per
            end, per = times[-1] + self.delay, times[-1] - self.repeat
            k0 = max(0, math.floor((t0 - end) / per))
            k1 = max(k0, math.ceil((t1 - end) / per))
            ks = np.arange(k0, k1 + 1)
            pts = np.concatenate([pts, (end + ks[:, None] * per + part[None, :]).ravel()])
            pts = unique_sorted(pts)
        return pts[(pts >= t0) & (pts <= t1)]


@dataclass(frozen=True)
class Exp:
    """``EXP(V1 V2 TD1 TAU1 TD2 TAU2)``; TAU1, TAU2 default TSTEP, TD2 defaults TD1 + TSTEP."""

    v1: float
    v2: float
    td1: float = 0.0
    tau1: float | None = None
    td2: float | None = None
    tau2: float | None = None

    piecewise_linear = False

    def __call__(self, t):
        if None in (self.tau1, self.td2, self.tau2):
            raise ValueError("EXP defaults not resolved: call lcs.signals.resolve first")
        t = np.asarray(t, dtype=float)
        dv = self.v2 - self.v1
        rise = dv * (1 - np.exp(-np.maximum(t - self.td1, 0.0) / self.tau1))
        fall = -dv * (1 - np.exp(-np.maximum(t - self.td2, 0.0) / self.tau2))
        return self.v1 + np.where(t > self.td1, rise, 0.0) + np.where(t > self.td2, fall, 0.0)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        pts = np.array([self.td1, self.td2 if self.td2 is not None else self.td1])
        return unique_sorted(pts[(pts >= t0) & (pts <= t1)])


@dataclass(frozen=True)
class Sffm:
    """``SFFM(VO VA FC MDI FS [PHASEC PHASES])``: ``VO + VA sin(2π FC t + PHASEC + MDI
    sin(2π FS t + PHASES))`` (phases in degrees), as ngspice 39 computes it (vsrcload.c,
    checked point by point); FC and FS default (0 or omitted) to 1/TSTOP, MDI to 0."""

    vo: float
    va: float
    fc: float | None = None
    mdi: float = 0.0
    fs: float | None = None
    phasec: float = 0.0
    phases: float = 0.0

    piecewise_linear = False

    def __call__(self, t):
        if self.fc is None or self.fs is None:
            raise ValueError("SFFM defaults not resolved: call lcs.signals.resolve first")
        t = np.asarray(t, dtype=float)
        mod = self.mdi * np.sin(2 * math.pi * self.fs * t + self.phases * math.pi / 180.0)
        return self.vo + self.va * np.sin(2 * math.pi * self.fc * t
                                          + self.phasec * math.pi / 180.0 + mod)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        return np.empty(0)

    def top_frequency(self) -> float | None:
        """The highest instantaneous frequency written, FC + |MDI| FS, Hz (None: a default)."""
        if not self.fc or not self.fs:
            return None
        return abs(self.fc) + abs(self.mdi * self.fs)


@dataclass(frozen=True)
class Am:
    """``AM(VA VO MF FC TD [PHASEC PHASES])``: 0 until TD, then ``VA (VO + sin(2π MF τ +
    PHASES)) sin(2π FC τ + PHASES)``, τ = t - TD, as ngspice 39 computes it (vsrcload.c,
    checked point by point: PHASES sets the carrier's phase too, PHASEC is read and unused);
    MF defaults (0 or omitted) to 1/TSTOP, FC and TD to 0."""

    va: float
    vo: float
    mf: float | None = None
    fc: float = 0.0
    td: float = 0.0
    phasec: float = 0.0
    phases: float = 0.0

    piecewise_linear = False

    @property
    def jumps(self) -> bool:
        """Whether it jumps at TD: with a phase, its value just after TD is not 0."""
        ph = self.phases * math.pi / 180.0
        return self.va * (self.vo + math.sin(ph)) * math.sin(ph) != 0.0

    def __call__(self, t, side: int = 0):
        """The value at the times ``t`` (s); ``side`` +1 / -1: the right / left limit (they
        differ at TD only, where the value jumps with a phase)."""
        if self.mf is None:
            raise ValueError("AM defaults not resolved: call lcs.signals.resolve first")
        tau = np.asarray(t, dtype=float) - self.td
        ph = self.phases * math.pi / 180.0
        value = self.va * (self.vo + np.sin(2 * math.pi * self.mf * tau + ph)) * np.sin(
            2 * math.pi * self.fc * tau + ph)
        return np.where(tau < 0.0 if side > 0 else tau <= 0.0, 0.0, value)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        # (a corner at TD where the value leaves 0, or a jump with a phase)
        return np.array([self.td]) if t0 <= self.td <= t1 and self.td > 0 else np.empty(0)

    def top_frequency(self) -> float | None:
        """The highest frequency written, FC + MF, Hz (None: MF left to its default)."""
        return abs(self.fc) + abs(self.mf) if self.mf else None


def modulated(kind: str, values: list[float]) -> Sffm | Am:
    """The ``sffm`` or ``am`` waveform of its arguments as written."""
    if kind == "sffm":
        return Sffm(*values)
    if kind == "am":
        return Am(*values)
    raise AssertionError(f"waveform {kind}")


Signal = Dc | Pulse | Sin | Pwl | Exp | Sffm | Am


def resolve(sig: Signal, tstep: float, tstop: float) -> Signal:
    """Fill the fields that ngspice takes from ``.tran TSTEP TSTOP`` when omitted.

    Parameters
    ----------
    sig : Signal
        A waveform as parsed.
    tstep, tstop : float
        The ``.tran`` step and stop time, s.
    """
    if isinstance(sig, Pulse):
        if sig.tr and sig.tf and sig.pw and sig.per:
            return sig  # (nothing to fill; and what it keeps of its evaluations serves)
        return replace(
            sig,
            tr=sig.tr if sig.tr else tstep,
            tf=sig.tf if sig.tf else tstep,
            pw=sig.pw if sig.pw else tstop,
            per=sig.per if sig.per else tstop,
        )
    if isinstance(sig, Sin):
        return replace(sig, freq=sig.freq if sig.freq else 1.0 / tstop)
    if isinstance(sig, Sffm):
        return replace(sig, fc=sig.fc if sig.fc else 1.0 / tstop,
                       fs=sig.fs if sig.fs else 1.0 / tstop)
    if isinstance(sig, Am):
        return replace(sig, mf=sig.mf if sig.mf else 1.0 / tstop)
    if isinstance(sig, Exp):
        return replace(
            sig,
            tau1=sig.tau1 if sig.tau1 else tstep,
            td2=sig.td2 if sig.td2 is not None else sig.td1 + tstep,
            tau2=sig.tau2 if sig.tau2 else tstep,
        )
    return sig
