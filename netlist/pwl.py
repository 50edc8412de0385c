"""Piecewise-linear devices (``--devices pwl``): diodes with a forward voltage and
an on-resistance, switches with an on-resistance, still a linear complementarity system.

A diode becomes an ideal diode in series with a source ``Vf`` and a resistor ``Ron`` (so
``v = Vf + Ron i`` while it conducts): ``Ron`` enters the LCS's D, which also makes the
LCP's solution unique, and ``Vf`` enters F. The pair is **fitted** to the diode's model,
ngspice's static characteristic at 27 °C (:mod:`netlist.diode_dc`: ``v(i) = N Vt ln(1 +
i/IS) + RS i``, Vt = 25.86 mV, ngspice's defaults IS = 1e-14 A, N = 1, RS = 0; with the
recombination current of ``ISR``, ``NR`` and the high injection of ``IKF`` where the model
gives them), by least squares on 50 currents log-spaced over ``[I/20, I]``, I the current
the diode carries in an ideal run of the same circuit (:func:`carried_current`: the current
it stays below for 99 % of its conduction time, so that an inrush lasting a step or two, which
in an ideal circuit only the time step limits, does not set the range); a diode that carries
nothing keeps ``Vf`` at 1 mA and no resistance. The fit is **bounded** to physical values:
``0 <= Vf <= v(I)`` and ``RS <= Ron <= dv/di`` at ``I/20`` (the line's slope lies between the
diode's slopes at both ends of the range). Diodes merged in parallel are fitted together
(their total current). ``Vf`` and ``Ron`` may also be given per element or model (``--pwl
NAME=VF:RON``), then used as they are.

Where that line misses the model by more than :data:`SEGMENT_TOLERANCE` (20 mV) down to
:data:`LOW_FRACTION` (1e-3) of the current, the diode gets two or three **segments**
(:func:`segment_fit`): the line stays the segment of the largest currents, and chords of the
model below it carry the fit down to ``I/1000``, where a capacitor charged through the
diode (a clamp, a doubler) leaves its current decaying. ``v(i)`` is concave, so the segments
are a convex characteristic, still an LCS: ideal diodes in parallel, each behind its own
source and resistor (``<element>#d<k>``, ``#vf<k>``, ``#ron<k>``; one complementarity pair
more per segment), the element itself in series with them all, carrying the total current.
The segments' knots are those of least largest error (:func:`_knots`, dynamic programming).
Where even three segments miss, the line itself misses the model over its own range (the
exponential outweighs ``RS`` there: a mixer's diode at microamps, 29 mV off over a decade and a
half); the fit is then two to five chords of the model over the whole range (as few as come
within :data:`CHORD_TOLERANCE`, 5 mV: in the exponential region a voltage error is a current
error, ``exp(error/(N Vt))``), the top one ending at the carried current.
The ideal run overstates the current of a diode driven near its own drop (a mixer's diode at
a few tenths of a volt: 0.45 mA ideal, 1.9 µA real); where the piecewise-linear run then
finds a diode well below its fit's range, ``netlist.studies.realistic`` fits it again over
the current it carries there (the larger of its own and its model's at the voltages that
run puts across it, :func:`model_current`) and runs once more.
``netlist.studies.realistic`` keeps one segment for a diode whose segments would cancel a
stiff part of the dynamics (an inductor's current through it), which θ = 1/2 integrates
explicitly (:mod:`lcs.integrators.moreau.theta_screen`).

A switch is ``Ron`` when on: ``RON`` of its SW model (ngspice's default 1 Ω), or for an
idealised MOSFET the channel resistance at its gate drive from the model, ``RD + RS +
1/(KP (Vgs - VTO))`` (the triode region at small drain-source voltage), Vgs the largest
control voltage of the ideal run; for a BJT ``RC + RE`` and a saturation drop of 0.2 V (as a
source in series, like a diode's Vf). A MOSFET keeps what sets its switching instants: its
gate as a linear RC (``Switch.gate_rc``, from ``netlist.flatten``: the model's gate
resistance, its gate-source capacitance to the source and its gate-drain capacitance to the
drain, at a fixed bias), and the switch turns when the gate-source voltage behind the gate
resistance crosses the threshold, as the channel does.
The bypass switches of a resistor stepped in time (``built_for``, :mod:`netlist.time_value`)
are pelcs' model of that resistor, not devices: they stay ideal.
The added elements are named ``<element>#vf`` and ``<element>#ron`` on internal nodes
``<element>#a``/``#b``; they belong to pelcs' model only (ngspice keeps the real devices).
A diode's depletion charge is added to this circuit by :mod:`netlist.junction_charge`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Collection, Sequence
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from .circuit import Capacitor, Circuit, Diode, Resistor, Switch, VoltageSource
from .diode_dc import VT_THERMAL, describe, ignored, junction_params
from .diode_dc import diode_voltage as junction_diode_voltage
from .reductions import parallel_diodes

__all__ = ["CHORD_TOLERANCE", "LOW_FRACTION", "MAX_SEGMENTS", "PwlFit", "SEGMENT_TOLERANCE",
           "VT_THERMAL", "carried_current",
           "diode_fit", "diode_ignored", "diode_params", "diode_residual", "diode_voltage",
           "model_current", "model_voltage", "parallel_fit", "parallel_voltage", "pwl_circuit",
           "pwl_voltage", "segment_fit", "segments_of", "switch_residual", "switch_resistance",
           "vf_offsets"]



@dataclass(frozen=True)
class PwlFit:
    """What a device became with ``--devices pwl``: ``v = vf + ron i`` while on.

    Attributes
    ----------
    element : str
    vf, ron : float
        V and Ω.
    how : str
        Where the numbers come from (fit range, model parameters).
    """

    element: str
    vf: float
    ron: float
    how: str
    #: a diode of several segments: the other branches' ``(vf, ron)`` (V, Ω), each an
    #: ideal diode in series with its source and resistor, in parallel with the first
    branches: tuple[tuple[float, float], ...] = ()
    #: the largest distance from the model over the fit's range (V), where it was fitted
    error: float | None = None

    def voltage(self, i: np.ndarray) -> np.ndarray:
        """The device's voltage while it carries ``i >= 0`` (A), V: :func:`pwl_voltage`."""
        return pwl_voltage(self.vf, self.ron, self.branches, i)

    @property
    def top(self) -> tuple[float, float]:
        """``(vf, ron)`` of the segment of the largest currents (V, Ω): the one-segment fit
        over the currents the device carries (every branch conducting)."""
        if not self.branches:
            return self.vf, self.ron
        segs = ((self.vf, self.ron), *self.branches)
        g = sum(1.0 / r for _, r in segs)
        return sum(v / r for v, r in segs) / g, 1.0 / g

    def line(self) -> str:
        first = f"{self.element}: Vf = {self.vf:.4g} V, Ron = {self.ron:.4g} Ω"
        if not self.branches:
            return f"{first} ({self.how})"
        return (first + "".join(f", in parallel with Vf = {vf:.4g} V, Ron = {r:.4g} Ω"
                                for vf, r in self.branches)
                + f" ({1 + len(self.branches)} segments: {self.how})")


def carried_current(t: np.ndarray, i: np.ndarray, quantile: float = 0.99) -> float:
    """The current a device carries, A: the level ``|i|`` stays below for ``quantile`` of
    the time it conducts (samples weighted by their time step), so that a spike of a step or
    two (an ideal diode charging a capacitor from a step, limited only by the time step)
    does not count. 0 when it never conducts."""
    t, a = np.asarray(t, float), np.abs(np.asarray(i, float))
    if len(a) < 2 or not np.any(a > 0):
        return 0.0
    dt = np.diff(t)
    mid = np.maximum(a[:-1], a[1:])  # each interval at its larger end
    on = (mid > 1e-6 * mid.max()) & (dt > 0)
    if not on.any():
        return float(a.max())
    x, w = mid[on], dt[on]
    order = np.argsort(x)
    cum = np.cumsum(w[order])
    k = int(np.searchsorted(cum, quantile * cum[-1]))
    return float(x[order][min(k, len(x) - 1)])


def diode_voltage(i: np.ndarray, is_: float, n: float, rs: float) -> np.ndarray:
    """Shockley's equation with series resistance, ``N Vt ln(1 + i/IS) + RS i`` (V)."""
    i = np.asarray(i, float)
    return n * VT_THERMAL * np.log1p(i / is_) + rs * i


def _bounded_line(i: np.ndarray, v: np.ndarray, ron_lo: float, ron_hi: float,
                  v_hi: float) -> tuple[float, float]:
    """Least-squares ``v = vf + ron i`` with ``ron`` in [ron_lo, ron_hi] and ``vf`` in
    [0, v_hi] (the least squares in one variable once the other is held at a bound)."""
    ron, vf = np.polyfit(i, v, 1)
    ron = min(max(float(ron), ron_lo), ron_hi)
    vf = float(np.mean(v - ron * i))  # best offset for the bounded slope
    if not 0.0 <= vf <= v_hi:
        vf = min(max(vf, 0.0), v_hi)
        ron = float(np.dot(i, v - vf) / np.dot(i, i))
        ron = min(max(ron, ron_lo), ron_hi)
    return vf, ron


def diode_fit(is_: float, n: float, rs: float, i_max: float) -> tuple[float, float]:
    """Least-squares ``(Vf, Ron)`` of :func:`diode_voltage` over ``[i_max/20, i_max]``
    (50 log-spaced currents, A), bounded as the module docstring says; V and Ω."""
    if not (i_max > 1e-9 and math.isfinite(i_max)):  # it carries nothing worth a fit
        return n * VT_THERMAL * math.log1p(1e-3 / is_), rs
    i = np.logspace(np.log10(i_max / 20.0), np.log10(i_max), 50)
    v = diode_voltage(i, is_, n, rs)
    slope_lo = n * VT_THERMAL / (is_ + i[0]) + rs  # dv/di at the low end: the steepest
    return _bounded_line(i, v, rs, slope_lo, float(v[-1]))


def _plain(p: dict) -> bool:
    """Whether a junction is Shockley's equation alone (no ISR, no IKF)."""
    return "isr" not in p and "ikf" not in p


def _key(p: dict) -> tuple:
    return tuple(sorted((k, float(v)) for k, v in p.items()))


@lru_cache(maxsize=64)
def _parallel_table(junctions: tuple[tuple, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Total current (A) of junctions (each :func:`_key` of its parameters) in parallel, at
    the voltages (V) where each of them carries one of 100 currents a decade from 1e-18 A to
    1 kA (:func:`netlist.diode_dc.diode_voltage`, RS included), each junction's current
    between them interpolated in its logarithm (exact where the exponential dominates,
    within 1e-5 of it elsewhere). The voltages reach where the junctions carry 1 kA whatever
    their drop (a stack's model, N = 10: volts). Computed once per set: a fit evaluates it
    at several sets of currents."""
    i = np.logspace(-18.0, 3.0, 2101)
    log_i = np.log(i)
    curves = [np.asarray(junction_diode_voltage(i, dict(j)), float) for j in junctions]
    v = np.unique(np.concatenate([[0.0], *curves]))
    # (below a junction's voltage at 1e-18 A it carries nothing)
    total = sum(np.exp(np.interp(v, vk, log_i, left=-np.inf)) for vk in curves)
    v.flags.writeable = False
    total.flags.writeable = False
    return v, total


def parallel_voltage(params: list[dict], i: np.ndarray) -> np.ndarray:
    """Voltage of diodes in parallel carrying a total current ``i`` (A; up to 1 kA), V:
    their total current's characteristic (:func:`_parallel_table`) inverted."""
    v, total = _parallel_table(tuple(_key(p) for p in params))
    return np.interp(np.asarray(i, float), total, v)


def parallel_fit(params: list[dict], i_max: float) -> tuple[float, float]:
    """:func:`diode_fit` of a diode's junctions (:func:`model_voltage`): one of Shockley's
    equation alone, or several in parallel (a Schottky macro's junction and guard ring), or
    one with ngspice's recombination current or high injection."""
    if len(params) == 1 and _plain(params[0]):
        p = params[0]
        return diode_fit(p["is"], p["n"], p["rs"], i_max)
    if not (i_max > 1e-9 and math.isfinite(i_max)):
        i_max = 1e-3
    i = np.logspace(np.log10(i_max / 20.0), np.log10(i_max), 50)
    vi = model_voltage(params, i)
    if len(params) == 1:  # the slope at the low end from the characteristic itself
        h = 1e-4
        slope_lo = float((model_voltage(params, i[0] * (1 + h))[()]
                          - model_voltage(params, i[0] * (1 - h))[()]) / (2 * h * i[0]))
    else:
        slope_lo = float(np.gradient(vi, i)[0])
    # no line flatter than the series resistances in parallel
    rs_min = (1.0 / sum(1.0 / p["rs"] for p in params)
              if all(p["rs"] > 0 for p in params) else 0.0)
    return _bounded_line(i, vi, min(rs_min, slope_lo), max(slope_lo, rs_min), float(vi[-1]))


#: a diode's fit must hold from this fraction of the current it carries up to that current
#: (a clamp's or a doubler's current decays through decades while it conducts)
LOW_FRACTION = 1e-3
#: the largest distance from the model (V) one segment may leave over that range before two
#: (then three) are fitted
SEGMENT_TOLERANCE = 0.02
#: the segments of a fit that keeps the one-segment line as its top segment
LINE_SEGMENTS = 3
#: the segments of a fit of chords over the whole range (where the line itself misses)
MAX_SEGMENTS = 5
#: the largest distance from the model (V) a fit of chords over the whole range stops at: such
#: a diode works in its exponential region, where a voltage error is a current error of
#: exp(error / (N Vt)) (20 mV: 55 % at N = 1.75; 5 mV: 12 %). The corpus's diode mixer: its
#: mean output 0.1455 / 0.1343 / 0.1301 mV with three, four, five chords (11.7, 6.9, 4.4 mV),
#: ngspice's 0.1293 mV (both without the junction's charge)
CHORD_TOLERANCE = 0.005


def pwl_voltage(vf: float, ron: float, branches: tuple = (), i: np.ndarray | float = 0.0
                ) -> np.ndarray:
    """Voltage (V) of ``vf + ron i`` in parallel with ``branches`` (each ``(vf, ron)``
    behind its own ideal diode, V and Ω) carrying a total current ``i >= 0`` (A): with
    branches ``1..k`` conducting, ``i = sum_j (v - vf_j)/ron_j``; the voltage is the least of
    these lines over ``k`` (the branch current is convex in ``v``, so ``v(i)`` is concave)."""
    i = np.asarray(i, float)
    if not branches:
        return vf + ron * i
    g = gv = 0.0
    out = None
    for vk, rk in ((vf, ron), *branches):
        g, gv = g + 1.0 / rk, gv + vk / rk
        line = (i + gv) / g
        out = line if out is None else np.minimum(out, line)
    return out


def _chord_errors(i: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``E[a, b]``: the largest ``v - chord`` over ``i[a..b]`` of the chord from point ``a``
    to point ``b`` (V; >= 0 for a concave ``v``)."""
    n = len(i)
    err = np.full((n, n), np.inf)
    idx = np.arange(n)
    for a in range(n - 1):
        b = idx[a + 1:]
        slope = (v[b] - v[a]) / (i[b] - i[a])
        dev = v[None, a:] - (v[a] + slope[:, None] * (i[None, a:] - i[a]))
        dev = np.where(idx[None, a:] <= b[:, None], dev, -np.inf)
        err[a, a + 1:] = dev.max(axis=1)
    return err


def _knots(err: np.ndarray, k: int) -> tuple[list[int], float]:
    """Grid indices of the ``k + 1`` knots (the first and last points among them) whose
    chords' largest error is least, and it: dynamic programming over the knots, ``worst[j,
    m]`` the least largest error of ``j`` chords from point 0 to point ``m``."""
    n = err.shape[0]
    worst = np.full((k + 1, n), np.inf)
    prev = np.zeros((k + 1, n), dtype=int)
    worst[0, 0] = 0.0
    for j in range(1, k + 1):
        # (a chord from each a < m: the larger of the best j - 1 chords to a and its own)
        cand = np.maximum(worst[j - 1][:, None], err)
        prev[j] = np.argmin(cand, axis=0)
        worst[j] = cand[prev[j], np.arange(n)]
    knots, m = [n - 1], n - 1
    for j in range(k, 0, -1):
        m = int(prev[j, m])
        knots.append(m)
    return knots[::-1], float(worst[k, n - 1])


def model_voltage(params: list[dict], i: np.ndarray, series: float = 0.0) -> np.ndarray:
    """Voltage (V) of a diode's junctions (:func:`netlist.diode_dc.diode_voltage` of one, or
    :func:`parallel_voltage` of several) and its series resistance (Ω) at ``i`` (A)."""
    i = np.asarray(i, float)
    if len(params) == 1:
        return junction_diode_voltage(i, params[0]) + series * i
    return parallel_voltage(params, i) + series * i


def model_current(params: list[dict], v: np.ndarray, series: float = 0.0) -> np.ndarray:
    """The current (A) a diode's model (:func:`model_voltage`) carries at the voltage ``v``
    (V; 0 at and below 0 V): the characteristic inverted on 40 currents a decade from 1 fA
    to 100 A."""
    grid = np.logspace(-15, 2, 681)
    vg = model_voltage(params, grid, series)
    v = np.asarray(v, float)
    return np.where(v > 0, np.interp(v, vg, grid, left=0.0), 0.0)


def segment_lines(vf: float, ron: float, branches: tuple = ()) -> list[tuple[float, float]]:
    """The lines ``v = a + b i`` (V, Ω) of a fit's segments, steepest first: the inverse of
    :func:`lines_fit` (segment ``k`` is branches ``1..k`` conducting, :func:`pwl_voltage`)."""
    g = gv = 0.0
    out = []
    for vk, rk in ((vf, ron), *branches):
        g, gv = g + 1.0 / rk, gv + vk / rk
        out.append((gv / g, 1.0 / g))
    return out


def lines_fit(lines: list[tuple[float, float]]) -> tuple[float, float, tuple] | None:
    """A convex characteristic's lines (steepest first) as a fit ``(vf, ron, branches)``,
    or None where they are not convex (:func:`_branches`)."""
    return _branches(lines)


def diode_chain(el: Diode, vf: float, ron: float, branches: tuple = ()) -> list:
    """The elements of a fitted diode (module docstring) between its two nodes."""
    return _series(el, vf, ron, branches)


def _branches(lines: list[tuple[float, float]]) -> tuple[float, float, tuple] | None:
    """Lines ``v = a + b i`` (V, Ω), steepest first, as :func:`pwl_voltage`'s first segment
    and branches: branch ``k`` opens at the voltage where line ``k`` meets line ``k - 1`` and
    adds the conductance ``1/b_k - 1/b_{k-1}``. None unless the slopes fall and the knees
    rise (a convex characteristic)."""
    out, knee = [lines[0]], -math.inf
    for (a0, b0), (a1, b1) in zip(lines[:-1], lines[1:], strict=True):
        if not (b1 < b0 and b1 > 0):
            return None
        i_x = (a1 - a0) / (b0 - b1)  # where they meet, A
        v_x = a0 + b0 * i_x
        if not (i_x > 0 and v_x > knee):
            return None
        knee = v_x
        out.append((float(v_x), float(1.0 / (1.0 / b1 - 1.0 / b0))))
    return out[0][0], out[0][1], tuple(out[1:])


def segment_fit(params: list[dict], i_max: float, series: float = 0.0, segments: bool = True
                ) -> tuple[float, float, tuple[tuple[float, float], ...], float]:
    """A diode's piecewise-linear fit, ``(vf, ron, branches, error)`` (V, Ω, the other
    segments' branches as :func:`pwl_voltage` takes them, and the largest distance from the
    model, V, over ``[LOW_FRACTION i_max, i_max]``, A): :func:`segments_of` without saying
    which kind of fit it is."""
    return segments_of(params, i_max, series, segments)[:4]


def segments_of(params: list[dict], i_max: float, series: float = 0.0, segments: bool = True
                ) -> tuple[float, float, tuple[tuple[float, float], ...], float, float | None]:
    """A diode's piecewise-linear fit: :func:`segment_fit`'s four values and, for a fit of
    chords over the whole range, the largest distance (V) from the model over ``[i_max/20,
    i_max]`` of the one line it replaces (None otherwise).

    The line of :func:`parallel_fit` (plus ``series``) over ``[i_max/20, i_max]``, alone when
    it stays within :data:`SEGMENT_TOLERANCE` of the model down to ``LOW_FRACTION i_max`` or
    ``segments`` is false. Else, below it, one or two more (as few as reach the tolerance):
    chords of the model's ``v(i)`` over ``[LOW_FRACTION i_max, i_max/20]`` between knots
    chosen on a log grid (20 a decade) for the least largest error, moved up by half of it.
    The model's ``v(i)`` is concave, so the lines are a convex piecewise-linear
    characteristic (:func:`_branches`); above the first knee the line is the one-segment
    fit itself, so the currents a converter's diode carries see the same diode.

    Where those three segments still miss the tolerance, the line itself misses the model
    over its own range: the exponential outweighs ``RS`` there (a mixer's diode at
    microamps), and no line follows it over a decade and more. Its fit is then chords of the model
    over the whole range, ``2..MAX_SEGMENTS`` of them (as few as reach
    :data:`CHORD_TOLERANCE`, or the most), the top one ending at ``i_max``."""
    vf, ron = parallel_fit(params, i_max)
    ron += series
    if not (i_max > 1e-9 and math.isfinite(i_max)):
        return vf, ron, (), 0.0, None
    fine = np.logspace(np.log10(LOW_FRACTION * i_max), np.log10(i_max), 400)
    v_fine = model_voltage(params, fine, series)
    error = float(np.max(np.abs(vf + ron * fine - v_fine)))
    if error <= SEGMENT_TOLERANCE or not segments:
        return vf, ron, (), error, None
    best = (vf, ron, (), error)
    for _k, fit in _chord_fits(params, series, LOW_FRACTION * i_max, i_max / 20.0,
                              LINE_SEGMENTS - 1, (vf, ron)):
        got = float(np.max(np.abs(pwl_voltage(*fit, fine) - v_fine)))
        if got < best[3]:
            best = (*fit, got)
        if got <= SEGMENT_TOLERANCE:
            return (*best, None)
    top = fine >= i_max / 20.0
    line_error = float(np.max(np.abs(vf + ron * fine[top] - v_fine[top])))
    whole = None
    for k, fit in _chord_fits(params, series, LOW_FRACTION * i_max, i_max, MAX_SEGMENTS):
        if k < 2:
            continue
        got = float(np.max(np.abs(pwl_voltage(*fit, fine) - v_fine)))
        if got < (whole or best)[3]:
            whole = (*fit, got)
        if got <= CHORD_TOLERANCE:
            break
    if whole is None:
        return (*best, None)
    return (*whole, line_error)


def _chord_fits(params: list[dict], series: float, lo: float, hi: float, most: int,
                line: tuple[float, float] | None = None):
    """``(k, (vf, ron, branches))`` for ``k = 1..most`` chords of the model over ``[lo,
    hi]`` (A), knots on a log grid (20 a decade) of least largest error, each moved up by half
    of it, followed by ``line`` (V, Ω) where given; until one is not convex."""
    grid = np.logspace(np.log10(lo), np.log10(hi), int(round(20 * math.log10(hi / lo))) + 1)
    v = model_voltage(params, grid, series)
    err = _chord_errors(grid, v)
    for k in range(1, min(most, len(grid) - 1) + 1):
        knots, e = _knots(err, k)
        c, vc = grid[knots], v[knots]
        slopes = np.diff(vc) / np.diff(c)
        lines = [(float(vc[j] - slopes[j] * c[j] + e / 2), float(slopes[j])) for j in range(k)]
        fit = _branches(lines + ([line] if line is not None else []))
        if fit is None:
            return  # not convex: no more segments to gain
        yield k, fit


def _channel(circuit: Circuit, sw: Switch, params: dict) -> tuple[float, float, str]:
    """An idealised MOSFET's channel: the factor of its triode conductance ``KP W/Leff m``
    (A/V²), its threshold as a positive control voltage (V, signed: a depletion device's is
    negative) and the factor's name, from its :class:`netlist.devices.ChannelLimit` (W, L
    and m as ngspice reads them); without one (a model other than level 1 or VDMOS), KP
    and ``|VTO|`` of the model ``params``."""
    from .devices import ChannelLimit

    for k in circuit.knees:
        if isinstance(k, ChannelLimit) and k.name == sw.name:
            return k.beta, k.vto, "KP" if k.device == "VDMOS" else "KP W/L"
    return params.get("kp", 0.0), abs(params.get("vto", params.get("vth", 0.0))), "KP"


def switch_resistance(circuit: Circuit, sw: Switch, drive: float | None) -> tuple[float, float,
                                                                                   str]:
    """``(Ron, Vdrop, how)`` of a switch when on (Ω, V)."""
    device = getattr(sw, "device", None)
    if device is None:
        m = circuit.models.get(sw.model.lower())
        ron = float(m.params.get("ron", 1.0)) if m is not None else 1.0
        return ron, 0.0, "RON of its SW model" if m and "ron" in m.params else \
            "ngspice's default RON = 1 Ω"
    letter, _, model_name = device[:3]
    extra = 0.0
    if letter == "X":  # a macro-model: its transistor's model, and its series resistors
        model_name, extra = device[3], float(device[4])
    m = circuit.models.get(str(model_name).lower())
    p = {k.lower(): float(v) for k, v in (m.params.items() if m else ())}
    if m is not None and m.type in ("NPN", "PNP"):
        return p.get("rc", 0.0) + p.get("re", 0.0) + extra, 0.2, "RC + RE, 0.2 V saturation"
    kp, vt, what = _channel(circuit, sw, p)
    vgs = drive if drive is not None else vt + 5.0
    r_ch = 1.0 / (kp * max(vgs - vt, 0.1)) if kp > 0 else 0.0
    how = (f"RD + RS + 1/({what} (Vgs - VTO)) at Vgs = {vgs:.3g} V" if kp > 0
           else "RD + RS (no KP)")
    if extra:
        how += f" + the macro's series resistors {extra:.3g} Ω"
    return p.get("rd", 0.0) + p.get("rs", 0.0) + r_ch + extra, 0.0, how


def pwl_circuit(circuit: Circuit, i_max: dict[str, float], drives: dict[str, float],
                explicit: dict | None = None, single: Collection[str] = (),
                charged: Collection[str] = ()) -> tuple[Circuit, list[PwlFit]]:
    """The circuit with every diode and switch made piecewise linear (see the module
    docstring); ``i_max`` (A) and ``drives`` (V) by element name, from an ideal run;
    ``explicit``: ``{element or model name: (vf, ron)}`` given by the user (V, Ω), used as
    they are instead of a fit; ``single``: diodes (by name) kept at one segment (the others
    get two or three where one misses their model: :func:`segment_fit`); ``charged``: the
    diodes whose depletion charge the run models (:mod:`netlist.junction_charge`), which
    their lines say."""
    merged = parallel_diodes(circuit)
    given = {str(k).lower(): v for k, v in (explicit or {}).items()}
    out, fits = [], []
    gated: dict[str, tuple[str, str]] = {}  # switch -> its control behind its gate RC
    for el in circuit.elements:
        if el.key in merged:
            continue  # carried by the diode it is in parallel with (one pair)
        if isinstance(el, Switch) and el.built_for:
            out.append(el)  # a time-valued resistor's bypass (netlist.time_value): no device
            continue
        model = str(getattr(el, "model", "") or "").lower()
        key = el.key if el.key in given else model if model in given else None
        if key is not None and isinstance(el, (Diode, Switch)):
            vf, ron = (float(v) for v in given[key])
            fits.append(PwlFit(el.name, vf, ron, "given"))
            out.extend(_series(el, vf, ron))
            continue
        if isinstance(el, Diode) and el.ideal:
            out.append(el)  # pelcs's own (a limiter's): no device to fit
            continue
        if isinstance(el, Diode):
            params, series = diode_params(circuit, el, merged)
            imax = i_max.get(el.name, 0.0)
            vf, ron, branches, error, line_error = segments_of(params, imax, series,
                                                               el.name not in single)
            what = " || ".join(describe(p) for p in params)
            if imax <= 1e-9:
                span = "at 1 mA: it carries no current in the ideal run"
            elif line_error is not None:
                span = (f"over {LOW_FRACTION * imax:.3g}..{imax:.3g} A, chords of the model "
                        f"within {1e3 * error:.3g} mV, the top one ending at {imax:.3g} A "
                        f"(one line over {imax / 20:.3g}..{imax:.3g} A misses it by "
                        f"{1e3 * line_error:.3g} mV)")
            elif branches:
                span = (f"over {LOW_FRACTION * imax:.3g}..{imax:.3g} A (the top segment "
                        f"over {imax / 20:.3g}..{imax:.3g} A), within {1e3 * error:.3g} mV")
            else:
                span = (f"over {imax / 20:.3g}..{imax:.3g} A, within {1e3 * error:.3g} mV "
                        f"down to {LOW_FRACTION * imax:.3g} A")
                if el.name in single and error > SEGMENT_TOLERANCE:
                    span += ("; one segment: an inductor's current runs through it, and "
                             "segments would make θ = 1/2 unreliable")
            left = diode_ignored(circuit, el, merged, el.name in charged)
            if left:
                span += f"; {left}"
            fits.append(PwlFit(el.name, vf, ron, f"fit of {what} {span}", branches,
                               error if imax > 1e-9 else None))
            out.extend(_series(el, vf, ron, branches))
        elif isinstance(el, Switch):
            ron, vdrop, how = switch_resistance(circuit, el, drives.get(el.name))
            gate = getattr(el, "gate_rc", None)
            if gate is not None:
                el, gate_parts = _gate(el, *gate)
                out.extend(gate_parts)
                gated[el.name] = el.control
                how += (f"; gate {gate[0]:.3g} Ω (inside the device), Cgs {gate[1]:.3g} F, "
                        f"Cgd {gate[2]:.3g} F")
            fits.append(PwlFit(el.name, vdrop, ron, how))
            out.extend(_series(el, vdrop, ron))
        else:
            out.append(el)
    return replace(circuit, elements=out, knees=_gated_knees(circuit.knees, gated)), fits


def _gated_knees(knees: list, gated: dict[str, tuple[str, str]]) -> list:
    """``knees`` with a MOSFET's channel checks (:mod:`netlist.devices`) reading the control
    its switch turns on in the pwl circuit, ``gated`` by switch name: behind its gate
    resistance, where the channel's gate is (the terminal's voltage leads it by the RC's
    delay, and read there the checks missed the slow edges a gate resistor makes)."""
    from .devices import ChannelLimit, ReverseChannel

    out = []
    for k in knees:
        control = gated.get(getattr(k, "name", None))
        if control is not None and isinstance(k, ChannelLimit):
            k = replace(k, control=control)
        elif control is not None and isinstance(k, ReverseChannel):
            drain = k.reverse[1] if k.device == "NMOS" else k.reverse[0]
            k = ReverseChannel.of(k.name, k.device, control, drain, k.threshold, k.location)
        out.append(k)
    return out


def junction_models(circuit: Circuit, el: Diode, merged: dict
                    ) -> tuple[list[tuple[dict, float]], float]:
    """A diode element's junctions as ``(model parameters, area)`` (a macro-model's or
    merged parallel diodes' several) and its macro-model's series resistance (Ω)."""
    names = [(el.model, el.area)] if el.model else []
    series = 0.0
    if el.device is not None and len(el.device) > 4:  # a diode macro-model
        names, series = [(nm, 1.0) for nm in el.device[3]], float(el.device[4])
    names += [(e.model, getattr(e, "area", 1.0)) for e in circuit.elements
              if merged.get(e.key) == el.name and getattr(e, "model", "")]
    out = []
    for nm, area in names:
        m = circuit.models.get(str(nm).lower())
        out.append((dict(m.params) if m is not None else {},
                    float(area) if area is not None else 1.0))
    return out, series


def diode_params(circuit: Circuit, el: Diode, merged: dict | None = None
                 ) -> tuple[list[dict], float]:
    """The junctions of a diode element (:func:`netlist.diode_dc.junction_params` each,
    ngspice's defaults filled in and the area applied; several for a macro-model's or merged
    parallel diodes) and the series resistance of its macro-model (Ω)."""
    merged = parallel_diodes(circuit) if merged is None else merged
    models, series = junction_models(circuit, el, merged)
    params = [junction_params(m, area) for m, area in models]
    return params or [junction_params({})], series


def diode_ignored(circuit: Circuit, el: Diode, merged: dict | None = None,
                  depletion: bool = False) -> str:
    """What of a diode's models its piecewise-linear fit does not follow, as its report line
    says it (:func:`netlist.diode_dc.ignored`), or ""; ``depletion``: the run models its
    depletion charge (``CJO``, ``VJ``, ``M``, ``FC``: :mod:`netlist.junction_charge`)."""
    merged = parallel_diodes(circuit) if merged is None else merged
    models, _ = junction_models(circuit, el, merged)
    modelled = ("CJO", "CJ0", "CJ", "VJ", "M", "FC") if depletion else ()
    charge = list(dict.fromkeys(k for m, _ in models for k in ignored(m)[0]
                                if k not in modelled))
    static = list(dict.fromkeys(k for m, _ in models for k in ignored(m)[1]))
    parts = []
    if charge:
        parts.append(f"its charge ({', '.join(charge)}) not modelled")
    if static:
        parts.append(f"{', '.join(static)} not modelled")
    return "; ".join(parts)


def diode_residual(circuit: Circuit, el: Diode, vf: float, ron: float, i_lo: float,
                   i_hi: float, branches: tuple = ()) -> float:
    """Largest ``|vf + ron i - v(i)|`` over ``[i_lo, i_hi]`` (A), V: how far a diode's
    piecewise-linear line (with ``branches``, its segments: :func:`pwl_voltage`) is from its
    model (:func:`model_voltage` of its junctions, plus its macro-model's series
    resistance) over the currents it carries."""
    if not (i_hi > 0 and math.isfinite(i_hi)):
        return 0.0
    params, series = diode_params(circuit, el)
    i = np.logspace(np.log10(max(min(i_lo, i_hi), 1e-12)), np.log10(i_hi), 200)
    v = model_voltage(params, i, series)
    return float(np.max(np.abs(pwl_voltage(vf, ron, branches, i) - v)))


def switch_residual(circuit: Circuit, sw: Switch, ron: float, i_max: float,
                    drive: float | None) -> float:
    """How far an idealised transistor's ``Ron`` (or BJT drop) is from its model at the
    current it carries, V: for a MOSFET the triode region's curvature, ``Vds - Ron_ch I`` with
    ``I = KP ((Vgs - VTO) Vds - Vds²/2)`` (the whole channel drop once it saturates); for a
    BJT the 0.2 V saturation drop itself (its model's drop is not computed); 0 for a SW
    switch, whose RON is exact."""
    device = getattr(sw, "device", None)
    if device is None or not i_max > 0:
        return 0.0
    letter, _, model_name = device[:3]
    if letter == "X":
        model_name = device[3]
    m = circuit.models.get(str(model_name).lower())
    if m is not None and m.type in ("NPN", "PNP"):
        return 0.2
    p = {k.lower(): float(v) for k, v in (m.params.items() if m else ())}
    kp, vt, _ = _channel(circuit, sw, p)
    if kp <= 0:
        return 0.0
    vov = max((drive if drive is not None else vt + 5.0) - vt, 0.1)
    lin = i_max / (kp * vov)
    disc = vov * vov - 2.0 * i_max / kp
    return float(vov - math.sqrt(disc) - lin) if disc > 0 else float(max(vov, lin))


def _gate(sw: Switch, rg: float, cgs: float, cgd: float) -> tuple[Switch, list]:
    """A MOSFET switch's gate as a linear RC: ``rg`` from its gate terminal to an internal
    gate node, ``cgs`` from there to its source terminal and ``cgd`` to its drain; the
    switch is then controlled by the internal node (it turns when the gate-source voltage
    there crosses the threshold)."""
    drain, src = sw.nodes[0], sw.nodes[1]
    n_chan = sw.control[1] == src  # (gate, source); a P-channel's is (source, gate)
    g = sw.control[0] if n_chan else sw.control[1]
    inner = f"{sw.name.lower()}#g" if rg > 0 else g
    parts: list = []
    if rg > 0:
        parts.append(Resistor(f"{sw.name}#rg", (g, inner), sw.location, rg))
    if cgs > 0:
        parts.append(Capacitor(f"{sw.name}#cgs", (inner, src), sw.location, cgs))
    if cgd > 0:
        parts.append(Capacitor(f"{sw.name}#cgd", (inner, drain), sw.location, cgd))
    control = (inner, sw.control[1]) if n_chan else (sw.control[0], inner)
    return replace(sw, control=control), parts


def _series(el, vf: float, ron: float, branches: tuple = ()) -> list:
    """``el`` between its first node and an internal node, then Vf and Ron to its second;
    each of ``branches`` from that internal node to the second through its own ideal diode
    ``<element>#d<k>``, source and resistor (so ``el`` carries the total current)."""
    a, b = el.nodes[0], el.nodes[1]
    if vf == 0.0 and ron == 0.0 and not branches:
        return [el]
    key = el.name.lower()
    parts = []
    node = f"{key}#a"
    parts.append(replace(el, nodes=(a, node)))
    if vf != 0.0:
        nxt = f"{key}#b" if ron > 0 else b
        parts.append(VoltageSource(f"{el.name}#vf", (node, nxt), el.location, vf))
        node = nxt
    if ron > 0:
        parts.append(Resistor(f"{el.name}#ron", (node, b), el.location, ron))
    for k, (vk, rk) in enumerate(branches, start=2):
        inner, mid = f"{key}#a{k}", f"{key}#b{k}"
        parts.append(Diode(f"{el.name}#d{k}", (f"{key}#a", inner), el.location))
        parts.append(VoltageSource(f"{el.name}#vf{k}", (inner, mid), el.location, vk))
        parts.append(Resistor(f"{el.name}#ron{k}", (mid, b), el.location, rk))
    return parts


def vf_offsets(diodes: Sequence, inputs: Sequence[str]) -> np.ndarray | None:
    """For each of the pairs ``diodes`` (elements named ``<element>`` or ``<element>#d<k>``),
    the inputs that are its own pwl diode's ``Vf`` sources (``<element>#vf``, ``#vf<k>``):
    :class:`~lcs.model.SwitchedLCS`'s ``offsets``, shape (m, p); None without any."""
    own = [re.match(r"(.*)#vf\d*$", name) for name in inputs]
    if not any(own):
        return None
    elements = [re.sub(r"#d\d+$", "", d.name).lower() for d in diodes]
    return np.array([[m is not None and m.group(1).lower() == e for m in own]
                     for e in elements], dtype=bool).reshape(len(diodes), len(inputs))
