"""Controllers in Python that drive named switches of a switched LCS without editing the netlist.

Pass them to :func:`lcs.integrators.moreau.integrator.simulate` (``controllers=[...]``); a switch
driven by a controller ignores its control nodes in the netlist. Two kinds (``controller.kind``):

``"schedule"`` -- the controller decides switching instants. Protocol (duck-typed)::

    switches : tuple[str, ...]            # the switches it drives
    probes : tuple[str, ...]              # what it measures (any probe name of simulate)
    reset(t0, t1) -> None                 # start of a run over [t0, t1] (s)
    sample_times(t0, t1) -> ndarray       # its sampling instants (s); t0 is always one
    decide(t, values) -> [(time, {switch: on}), ...]

  At each sampling instant ``t`` the driver stops, measures ``values = {probe: value}`` in the
  state reached at ``t`` and calls ``decide``; the commands it returns (instants ``>= t``, s)
  become exact step boundaries and switch the named switches there. A command may lie beyond
  the next sampling instant (open-loop PWM returns the whole run from ``t0``). This is a
  digital controller: sampled once per ``sample_times`` instant, with zero computational
  delay unless the controller adds one (``delay`` below).

``"surface"`` -- the controller gives the switch a comparator on a sliding surface, a linear
combination of probes: ``s = Σ c_k probe_k + offset``; the switch is on while ``s < 0``
(``on_when="negative"``) or ``s > 0``. The surface is evaluated inside the kernel like a
netlist comparator (instants located, Filippov relay on the surface, explicit sampling or
hysteresis: ``method``, ``hysteresis``). Attributes read by the driver: ``switch``,
``terms`` (``{probe: coefficient}`` of the comparator input ``c``, on while ``c > 0``),
``constant``, ``vh``, ``method``.

Classes: :class:`OpenLoopPWM` (frequency, duty, dead time, complementary switch),
:class:`PIPWM` (PI on an output probe sampled once per period, duty clamped, anti-windup),
:class:`SlidingSurface` (sliding-mode control from coefficients). See ``docs/switching.md``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

__all__ = ["OpenLoopPWM", "PIPWM", "SlidingSurface", "measured_probes", "pwm_commands"]


def pwm_commands(t0: float, period: float, duty: float, switch: str,
                 complement: str | None = None, dead_time: float = 0.0):
    """Commands of one PWM period starting at ``t0`` (s).

    The main switch is on over ``[t0, t0 + duty·period)``; the complementary switch, if any,
    over ``[t0 + duty·period + dead_time, t0 + period - dead_time)`` (when that interval is
    not empty). A duty of 0 or 1 gives no edge inside the period for the main switch.

    Returns
    -------
    list of (float, dict[str, bool])
    """
    d = float(np.clip(duty, 0.0, 1.0))
    t_off = t0 + d * period
    cmds = [(t0, {switch: d > 0.0})]
    if 0.0 < d < 1.0:
        cmds.append((t_off, {switch: False}))
    if complement is not None:
        lo_on, lo_off = t_off + dead_time, t0 + period - dead_time
        if lo_off > lo_on:
            cmds.append((t0, {complement: False}))
            cmds.append((lo_on, {complement: True}))
            cmds.append((lo_off, {complement: False}))
        else:
            cmds.append((t0, {complement: False}))
    cmds.sort(key=lambda c: c[0])
    return cmds


def measured_probes(controllers) -> list[str]:
    """The probe names ``controllers`` measure, each once: a schedule controller's
    ``probes``, a surface controller's ``terms``."""
    names = [name for c in controllers for name in
             (c.terms if getattr(c, "kind", None) == "surface" else getattr(c, "probes", ()))]
    return list(dict.fromkeys(names))


@dataclass
class OpenLoopPWM:
    """Fixed-frequency, fixed-duty PWM.

    Parameters
    ----------
    switch : str
        The main (high-side) switch, on at the start of every period.
    frequency : float
        Switching frequency, Hz.
    duty : float
        On fraction of the main switch, in [0, 1].
    complement : str, optional
        A switch driven complementarily (low side of a synchronous stage).
    dead_time : float
        Both switches off for this long after each edge of the main switch, s.
    phase : float
        Start of the first period, s (periods start at ``phase + k / frequency``).
    """

    switch: str
    frequency: float
    duty: float
    complement: str | None = None
    dead_time: float = 0.0
    phase: float = 0.0
    kind: str = field(default="schedule", init=False)
    probes: tuple = field(default=(), init=False)

    def __post_init__(self):
        if not self.frequency > 0:
            raise ValueError(f"frequency must be positive, got {self.frequency}")
        if not 0.0 <= self.duty <= 1.0:
            raise ValueError(f"duty must be in [0, 1], got {self.duty}")
        if self.dead_time < 0 or 2 * self.dead_time >= 1 / self.frequency:
            raise ValueError("dead_time must be in [0, period/2)")
        self._t1 = None

    @property
    def switches(self) -> tuple[str, ...]:
        return (self.switch,) if self.complement is None else (self.switch, self.complement)

    @property
    def period(self) -> float:
        return 1.0 / self.frequency

    def reset(self, t0: float, t1: float) -> None:
        self._t1 = t1

    def sample_times(self, t0: float, t1: float) -> np.ndarray:
        return np.empty(0)  # open loop: every command is known at t0

    def decide(self, t: float, values: Mapping[str, float]):
        T = self.period
        t1 = self._t1 if self._t1 is not None else t + T
        state = {s: False for s in self.switches}  # off before the first period
        later = []
        k = max(0, int(np.floor((t - self.phase) / T)))
        while self.phase + k * T < t1:
            for tc, st in pwm_commands(self.phase + k * T, T, self.duty, self.switch,
                                       self.complement, self.dead_time):
                if tc <= t:
                    state.update(st)
                else:
                    later.append((tc, st))
            k += 1
        return [(t, state)] + later


@dataclass
class PIPWM:
    """Digital PI control of a PWM duty, sampled once per switching period.

    At each period start ``t_j`` the probe is measured, ``e = reference - y(t_j)``, the
    integral advances ``I += ki·e·T`` and the duty of period ``j`` (or ``j + delay``) is
    ``d = clip(d0 + kp·e + I, duty_min, duty_max)``; the integral is clamped so that the
    unclamped duty stays within the limits (anti-windup).

    Parameters
    ----------
    switch : str
        The switch (on at every period start for ``d`` of the period).
    probe : str
        The measured output, e.g. ``"v(out)"``.
    reference : float
        Set point (units of the probe).
    kp, ki : float
        Proportional gain (1/unit) and integral gain (1/(unit·s)).
    frequency : float
        Switching (and sampling) frequency, Hz.
    d0 : float
        Duty feed-forward (the duty at zero error and zero integral).
    duty_min, duty_max : float
        Duty limits.
    complement, dead_time, phase :
        As in :class:`OpenLoopPWM`.
    delay : int
        Periods between a sample and the period whose duty it sets (0: the same period).

    Attributes
    ----------
    history : list of (float, float, float)
        ``(t_j, y(t_j), duty)`` of every sample.
    """

    switch: str
    probe: str
    reference: float
    kp: float
    ki: float
    frequency: float
    d0: float = 0.5
    duty_min: float = 0.0
    duty_max: float = 0.95
    complement: str | None = None
    dead_time: float = 0.0
    phase: float = 0.0
    delay: int = 0
    kind: str = field(default="schedule", init=False)

    def __post_init__(self):
        if not self.frequency > 0:
            raise ValueError(f"frequency must be positive, got {self.frequency}")
        if not 0.0 <= self.duty_min <= self.duty_max <= 1.0:
            raise ValueError("need 0 <= duty_min <= duty_max <= 1")
        self.reset(0.0, 0.0)

    @property
    def switches(self) -> tuple[str, ...]:
        return (self.switch,) if self.complement is None else (self.switch, self.complement)

    @property
    def probes(self) -> tuple[str, ...]:
        return (self.probe,)

    @property
    def period(self) -> float:
        return 1.0 / self.frequency

    def reset(self, t0: float, t1: float) -> None:
        self.integral = 0.0
        self.history: list[tuple[float, float, float]] = []
        self._queue = [float(np.clip(self.d0, self.duty_min, self.duty_max))] * self.delay

    def sample_times(self, t0: float, t1: float) -> np.ndarray:
        T = self.period
        k0 = int(np.ceil((t0 - self.phase) / T))
        k1 = int(np.floor((t1 - self.phase) / T))
        return self.phase + T * np.arange(max(k0, 0), k1 + 1)

    def decide(self, t: float, values: Mapping[str, float]):
        T = self.period
        if t < self.phase - 1e-12 * T:  # before the first period
            return [(t, {s: False for s in self.switches})]
        y = float(values[self.probe])
        e = self.reference - y
        integral = self.integral + self.ki * e * T
        # Anti-windup: keep d0 + kp e + I within the limits.
        lo = self.duty_min - self.d0 - self.kp * e
        hi = self.duty_max - self.d0 - self.kp * e
        self.integral = float(np.clip(integral, min(lo, hi), max(lo, hi)))
        d = float(np.clip(self.d0 + self.kp * e + self.integral, self.duty_min, self.duty_max))
        self._queue.append(d)
        d_now = self._queue.pop(0)
        self.history.append((t, y, d_now))
        return pwm_commands(t, T, d_now, self.switch, self.complement, self.dead_time)


@dataclass
class SlidingSurface:
    """Sliding-mode control of one switch from the coefficients of its surface.

    ``s = Σ coefficients[probe] · probe + offset``; the switch is on while ``s < 0``
    (``on_when="negative"``, e.g. ``s = i(L1) - Iref`` for a boost current loop) or while
    ``s > 0`` (``"positive"``).

    Parameters
    ----------
    switch : str
    coefficients : mapping of probe name to float
        E.g. ``{"i(L1)": 1.0}`` or ``{"i(L1)": 1.0, "v(out)": 0.05}``.
    offset : float
        Constant term of s (e.g. ``-Iref``).
    on_when : str
        ``"negative"`` or ``"positive"``.
    hysteresis : float
        Half-width of the band around s = 0 (units of s); 0 for the ideal relay.
    method : str, optional
        ``"implicit"``, ``"explicit"``, ``"hysteresis"`` or None (the run's ``switching``:
        with ``"auto"``, hysteresis when the band is nonzero, else implicit).
    """

    switch: str
    coefficients: Mapping[str, float]
    offset: float = 0.0
    on_when: str = "negative"
    hysteresis: float = 0.0
    method: str | None = None
    kind: str = field(default="surface", init=False)

    def __post_init__(self):
        if self.on_when not in ("negative", "positive"):
            raise ValueError(f"on_when must be 'negative' or 'positive', got {self.on_when!r}")
        if not self.coefficients:
            raise ValueError("a sliding surface needs at least one coefficient")

    @property
    def switches(self) -> tuple[str, ...]:
        return (self.switch,)

    @property
    def _sign(self) -> float:
        return -1.0 if self.on_when == "negative" else 1.0

    @property
    def terms(self) -> dict[str, float]:
        """Coefficients of the comparator input ``c`` (the switch is on while c > 0)."""
        return {k: self._sign * float(v) for k, v in self.coefficients.items()}

    @property
    def constant(self) -> float:
        return self._sign * float(self.offset)

    @property
    def vh(self) -> float:
        return abs(float(self.hysteresis))
