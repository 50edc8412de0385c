"""Independent-source waveforms with ngspice's semantics: DC, PULSE, SIN, PWL, EXP.

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

    As in ngspice, TR and TF default to TSTEP (an explicit 0 is also replaced by TSTEP), PW
    and PER default to TSTOP, NP (number of pulses) to unlimited.
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

    def __call__(self, t):
        self._require_resolved()
        t = np.asarray(t, dtype=float)
        tau = t - self.td
        per = self.per
        if per > 0:
            k = np.floor(tau / per)
            if self.np_ is not None:
                k = np.minimum(k, self.np_ - 1)
            k = np.maximum(k, 0.0)
            tau = tau - k * per
        tr, tf, pw = self.tr, self.tf, self.pw
        v1, v2 = self.v1, self.v2
        out = np.full_like(tau, v1)
        rising = (tau > 0) & (tau < tr)
        high = (tau >= tr) & (tau <= tr + pw)
        falling = (tau > tr + pw) & (tau < tr + pw + tf)
        out = np.where(rising, v1 + (v2 - v1) * tau / tr, out)
        out = np.where(high, v2, out)
        out = np.where(falling, v2 + (v1 - v2) * (tau - tr - pw) / tf, out)
        return out

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        self._require_resolved()
        edges = np.array([0.0, self.tr, self.tr + self.pw, self.tr + self.pw + self.tf])
        if self.per <= 0:
            pts = self.td + edges
        else:
            k0 = max(0, math.floor((t0 - self.td) / self.per) - 1)
            k1 = math.ceil((t1 - self.td) / self.per) + 1
            if self.np_ is not None:
                k1 = min(k1, int(self.np_) - 1)
            ks = np.arange(k0, max(k1, k0) + 1)
            pts = (self.td + ks[:, None] * self.per + edges[None, :]).ravel()
        pts = unique_sorted(pts)
        return pts[(pts >= t0) & (pts <= t1)]


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
    """``PWL(T1 V1 T2 V2 ...)``: linear between points, constant outside them."""

    times: tuple[float, ...]
    values: tuple[float, ...]

    piecewise_linear = True

    def __call__(self, t):
        return np.interp(np.asarray(t, dtype=float), self.times, self.values)

    def breakpoints(self, t0: float, t1: float) -> np.ndarray:
        pts = np.asarray(self.times, dtype=float)
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


Signal = Dc | Pulse | Sin | Pwl | Exp


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
        return replace(
            sig,
            tr=sig.tr if sig.tr else tstep,
            tf=sig.tf if sig.tf else tstep,
            pw=sig.pw if sig.pw is not None else tstop,
            per=sig.per if sig.per else tstop,
        )
    if isinstance(sig, Sin):
        return replace(sig, freq=sig.freq if sig.freq else 1.0 / tstop)
    if isinstance(sig, Exp):
        return replace(
            sig,
            tau1=sig.tau1 if sig.tau1 else tstep,
            td2=sig.td2 if sig.td2 is not None else sig.td1 + tstep,
            tau2=sig.tau2 if sig.tau2 else tstep,
        )
    return sig
