"""What :mod:`ngspice_checks.compare` measures on both runs: the steady-state period and
window, means and scales, switching instants (and their Hausdorff distance), and the
relative drop of ngspice's diode and switch models against the ideal ones (which sets the
tolerances, see the module docstring of :mod:`.compare`)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from lcs.results import SimulationResult
from lcs.signals import Pulse, Sin
from netlist.circuit import (
    Circuit,
    Diode,
    Switch,
    VoltageSource,
)
from netlist.pwl import LOW_FRACTION, diode_residual
from netlist.studies.measure import steady_state_period, steady_state_window

from .runner import NgspiceSettings

#: thermal voltage kT/q at ngspice's nominal 27 °C (V)
VT_THERMAL = 0.025852

# ngspice defaults of the model parameters the drop estimate uses
_DIODE_DEFAULTS = {"is": 1e-14, "n": 1.0, "rs": 0.0}
_SWITCH_DEFAULTS = {"vt": 0.0, "vh": 0.0, "ron": 1.0, "roff": 1e12}



@dataclass
class NonIdeality:
    """The drops of ngspice's diode and switch models, estimated from the pelcs currents.

    Attributes
    ----------
    diode_drops : dict
        Diode -> forward drop at its largest current (V).
    switch_drops : dict
        Switch -> RON·I at its largest current (V).
    v_ref : float
        Largest independent source voltage (V).
    delta : float
        (sum of the drops) / v_ref, dimensionless.
    """

    diode_drops: dict[str, float]
    switch_drops: dict[str, float]
    v_ref: float
    delta: float


# ------------------------------------------------------------------------------------------
# the period


def detect_period(
    circuit: Circuit, result: SimulationResult | None = None, period: float | None = None
) -> tuple[float | None, str]:
    """The period of the steady state (s) and a phrase for the report, e.g. ``"PULSE period
    of Vg (control of S1)"``: :func:`netlist.studies.measure.steady_state_period`, the one rule
    ``pelcs sweep`` and ``--losses`` use too (``result``: the pelcs run, for free-running
    converters; ``period``: given by the user)."""
    per, why = steady_state_period(circuit, result, period)
    return per, why.replace("mode (free-running)", "mode in the pelcs run (free-running)")


def _window(span: tuple[float, float], period: float | None) -> tuple[tuple[float, float], int]:
    """:func:`netlist.studies.measure.steady_state_window`."""
    return steady_state_window(span, period)


# ------------------------------------------------------------------------------------------
# signal helpers


def _in_window(t: np.ndarray, y: np.ndarray, a: float, b: float) -> tuple[np.ndarray, np.ndarray]:
    """Samples inside [a, b] with the end points interpolated in (exact window ends)."""
    sel = (t > a) & (t < b)
    tt = np.concatenate([[a], t[sel], [b]])
    yy = np.concatenate([[np.interp(a, t, y)], y[sel], [np.interp(b, t, y)]])
    return tt, yy


def _mean(t: np.ndarray, y: np.ndarray) -> float:
    return float(np.trapezoid(y, t) / (t[-1] - t[0]))


def _scale(y: np.ndarray) -> float:
    y = np.asarray(y, dtype=float)
    rms = float(np.sqrt(np.mean(y * y))) if len(y) else 0.0
    return max(rms, 0.5 * float(np.ptp(y)) if len(y) else 0.0, 1e-12)


def _strictly_increasing(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop repeated time points (keep the last value, after a jump) for interpolation."""
    keep = np.append(np.diff(t) > 0, True)
    return t[keep], y[keep]


# ------------------------------------------------------------------------------------------
# switching instants


@dataclass
class _Instants:
    on: np.ndarray
    off: np.ndarray


def _pelcs_instants(result: SimulationResult, switches: Sequence[str]) -> dict[str, _Instants]:
    """Turn-on and turn-off instants of each switch from ``result.events``."""
    ons: dict[str, list[float]] = {s: [] for s in switches}
    offs: dict[str, list[float]] = {s: [] for s in switches}
    prev = result.modes_visited[0] if result.modes_visited else (False,) * len(switches)
    for t, mode in result.events:
        for k, name in enumerate(switches):
            if mode[k] != prev[k]:
                (ons if mode[k] else offs)[name].append(float(t))
        prev = mode
    return {s: _Instants(np.array(ons[s]), np.array(offs[s])) for s in switches}


def _ngspice_instants(
    t: np.ndarray, c: np.ndarray, vt: float, vh: float, initial: bool | None
) -> _Instants:
    """Instants at which ngspice's SW model changes state, from its control voltage.

    ngspice's rule: on above VT + VH, off below VT - VH, unchanged in between (in the band at
    t = 0: the ON/OFF flag, default off). The crossing of the threshold is interpolated
    linearly between the two time points around it.
    """
    hi, lo = vt + vh, vt - vh
    # ngspice lands some switchings exactly on a band edge (c = VT - VH to 1e-10): compare
    # with a margin of round-off size; a sample within it of both edges (VH = 0) decides
    # nothing
    eps = 1e-6 * max(float(np.max(np.abs(c))) if len(c) else 0.0, abs(vt) + vh, 1e-3)
    above, below = c >= hi - eps, c <= lo + eps
    above, below = above & ~below, below & ~above
    decided = above | below
    idx = np.where(decided, np.arange(len(c)), -1)
    np.maximum.accumulate(idx, out=idx)
    state = np.where(idx >= 0, above[np.maximum(idx, 0)], bool(initial))
    change = np.flatnonzero(state[1:] != state[:-1]) + 1
    on, off = [], []
    for k in change:
        level = hi if state[k] else lo
        c0, c1 = c[k - 1], c[k]
        frac = (level - c0) / (c1 - c0) if c1 != c0 else 1.0
        tk = t[k - 1] + min(max(frac, 0.0), 1.0) * (t[k] - t[k - 1])
        (on if state[k] else off).append(float(tk))
    return _Instants(np.array(on), np.array(off))


def _unpaired_at_ends(
    x: np.ndarray, y: np.ndarray, ends: tuple[float, float], margin: float
) -> np.ndarray:
    """Which instants of ``x`` lie within ``margin`` of an end of the common run ``ends``
    with no instant of ``y`` within ``margin``: their partner may lie past that end, where
    the other simulator recorded nothing (pelcs records no event at its last time point,
    and ngspice interpolates a switching at the last point a fraction of a step early)."""
    near_end = (x > ends[1] - margin) | (x < ends[0] + margin)
    if not near_end.any():
        return near_end
    if len(y) == 0:
        return near_end
    y = np.sort(y)
    k = np.clip(np.searchsorted(y, x), 0, len(y) - 1)
    d = np.minimum(np.abs(x - y[k]), np.abs(x - y[np.maximum(k - 1, 0)]))
    return near_end & (d > margin)


def _hausdorff(a: np.ndarray, b: np.ndarray, lo: float, hi: float,
               ends: tuple[float, float] | None = None, margin: float = 0.0) -> float:
    """Largest distance from an instant in [lo, hi] of one set to the nearest of the other (s).

    The partner may lie outside [lo, hi] (an instant just inside the window can have its
    partner just outside). An instant without any partner counts as ``hi - lo`` (the
    comparison fails). With ``ends`` (the common time span of both runs) and ``margin``
    (the tolerance), an instant within ``margin`` of an end whose partner would lie past it
    (:func:`_unpaired_at_ends`) is left out: neither run can show that partner, and its
    distance to the previous instant is a whole period that says nothing about timing.
    """
    a, b = np.sort(a), np.sort(b)
    a_in, b_in = a[(a >= lo) & (a <= hi)], b[(b >= lo) & (b <= hi)]
    if ends is not None:
        a_in = a_in[~_unpaired_at_ends(a_in, b, ends, margin)]
        b_in = b_in[~_unpaired_at_ends(b_in, a, ends, margin)]
    if len(a_in) == 0 and len(b_in) == 0:
        return 0.0
    if len(a) == 0 or len(b) == 0:
        return hi - lo

    def one_way(x: np.ndarray, y: np.ndarray) -> float:
        k = np.clip(np.searchsorted(y, x), 1, len(y) - 1) if len(y) > 1 else np.zeros(
            len(x), dtype=int)
        d = np.abs(x - y[k])
        if len(y) > 1:
            d = np.minimum(d, np.abs(x - y[k - 1]))
        return float(d.max())

    return max(one_way(a_in, b) if len(a_in) else 0.0, one_way(b_in, a) if len(b_in) else 0.0)


def _frequency(on: np.ndarray, a: float, b: float) -> float:
    x = on[(on >= a) & (on <= b)]
    return (len(x) - 1) / (x[-1] - x[0]) if len(x) >= 3 else math.nan


# ------------------------------------------------------------------------------------------
# the non-ideality estimate


def _model_params(circuit: Circuit, model: str, defaults: Mapping[str, float]) -> dict:
    m = circuit.models.get(model.lower())
    params = dict(defaults)
    if m is not None:
        params.update({k: v for k, v in m.params.items() if k in defaults})
    return params


def _device_drop(circuit: Circuit, sw: Switch, i_max: float, drive: float | None) -> float:
    """The conduction drop of an idealised transistor (netlist.devices) in ngspice, V.

    MOSFET: ``(RD + RS + 1/(KP (Vgs - VTO))) I`` with Vgs the largest gate drive of the
    pelcs run (the triode-region channel resistance, KP in A/V²); BJT: a saturated
    collector–emitter drop of 0.2 V plus ``(RC + RE) I``.
    """
    letter, _, model_name = sw.device[:3]
    if letter == "X" and len(sw.device) > 4:  # a macro-model: its transistor and resistors
        model_name = sw.device[3]
    m = circuit.models.get(model_name.lower())
    p = {k.lower(): float(v) for k, v in (m.params.items() if m else ())}
    if letter == "Q":
        return 0.2 + (p.get("rc", 0.0) + p.get("re", 0.0)) * i_max
    vt = abs(p.get("vto", p.get("vth", 0.0)))
    kp = p.get("kp", 0.0)
    over = max((drive if drive is not None else vt + 5.0) - vt, 0.5)
    r_channel = 1.0 / (kp * over) if kp > 0 else 0.0
    return (p.get("rd", 0.0) + p.get("rs", 0.0) + r_channel) * i_max


def _nonideality(
    circuit: Circuit, settings: NgspiceSettings, currents: Mapping[str, np.ndarray],
    drives: Mapping[str, float] | None = None,
) -> NonIdeality:
    """δ of the module docstring, with the models of the ngspice rung that ran.
    ``currents``: the current each device carries (A, a number or a waveform whose largest
    value is taken; :func:`netlist.pwl.carried_current`); ``drives``: the largest control
    voltage of each switch (V), for idealised transistors."""
    drives = drives or {}
    diodes, switches = {}, {}
    for el in circuit.elements:
        if el.built_for:
            continue  # pelcs's construction for one line (a limiter): ngspice runs the line
        i_max = float(np.max(np.abs(currents[el.name]))) if el.name in currents else 0.0
        if isinstance(el, Diode):
            if settings.diode_model is not None:
                p = _model_params(circuit, el.model, _DIODE_DEFAULTS)
                p.update({k: float(v) for k, v in settings.diode_model.items() if k in p})
                drop = p["n"] * VT_THERMAL * math.log1p(i_max / p["is"]) + p["rs"] * i_max
            else:  # the model as written: a macro-model's junctions in parallel, its series R
                drop = diode_residual(circuit, el, 0.0, 0.0, i_max, i_max)
            diodes[el.name] = drop
        elif isinstance(el, Switch) and getattr(el, "device", None) is not None:
            switches[el.name] = _device_drop(circuit, el, i_max, drives.get(el.name))
        elif isinstance(el, Switch):
            p = _model_params(circuit, el.model, _SWITCH_DEFAULTS)
            if settings.switch_model is not None:
                p["ron"] = settings.switch_model.ron
            switches[el.name] = p["ron"] * i_max
    v_ref = _v_ref(circuit)
    total = sum(diodes.values()) + sum(switches.values())
    delta = total / v_ref if v_ref > 0 else 0.0
    return NonIdeality(diodes, switches, v_ref, delta)


def _pwl_residual(
    circuit: Circuit, fits: Sequence, fitted: Mapping[str, float],
    carried: Mapping[str, float], drives: Mapping[str, float],
) -> NonIdeality:
    """δ of what ngspice's models differ from pelcs' piecewise-linear devices
    (:mod:`netlist.pwl`): per diode the largest distance between its line and its model over
    the currents it carries (from a twentieth of the fitted current, a thousandth for a fit
    of several segments, to the larger of the
    fitted current and the one it carries in the pwl run, A; nothing for a diode that
    carries nothing), per switch what its ``Ron``
    leaves of its model (:func:`netlist.pwl.switch_residual`); over the largest source
    voltage."""
    from netlist.pwl import switch_residual

    by_name = {f.element: f for f in fits}
    diodes, switches = {}, {}
    for el in circuit.elements:
        f = by_name.get(el.name)
        if f is None:
            continue
        i_fit, i_run = fitted.get(el.name, 0.0), carried.get(el.name, 0.0)
        if isinstance(el, Diode):
            i_hi = max(i_fit, i_run)
            if not i_hi > 1e-9:  # it carries nothing: no drop to miss
                diodes[el.name] = 0.0
                continue
            # a fit of several segments holds down to LOW_FRACTION of its current
            i_lo = (i_fit if i_fit > 1e-9 else i_hi) * (LOW_FRACTION if f.branches else 0.05)
            diodes[el.name] = (diode_residual(circuit, el, f.vf, f.ron, i_lo, i_hi,
                                              f.branches)
                               if f.how != "given" else
                               _nonideality_drop(circuit, el, i_hi, f.vf, f.ron))
        elif isinstance(el, Switch):
            if getattr(el, "device", None) is not None:
                switches[el.name] = switch_residual(circuit, el, f.ron, i_run,
                                                    drives.get(el.name))
            else:
                p = _model_params(circuit, el.model, _SWITCH_DEFAULTS)
                switches[el.name] = abs(p["ron"] - f.ron) * i_run
    v_ref = _v_ref(circuit)
    total = sum(diodes.values()) + sum(switches.values())
    return NonIdeality(diodes, switches, v_ref, total / v_ref if v_ref > 0 else 0.0)


def _nonideality_drop(circuit: Circuit, el: Diode, i: float, vf: float, ron: float) -> float:
    """A diode's model drop at ``i`` against a line given by the user (V): the distance at
    ``i`` from the line to the characteristic the fits follow (:func:`netlist.pwl.
    diode_residual`: the area, ISR, IKF, a macro-model's junctions)."""
    return diode_residual(circuit, el, vf, ron, i, i)


def _v_ref(circuit: Circuit) -> float:
    """The largest independent source voltage (V); the sources pelcs built for a line
    ngspice runs as written (a limiter's rails, a time-stepped resistor's controls:
    ``Element.built_for``) are none."""
    v_ref = 0.0
    for el in circuit.elements:
        if isinstance(el, VoltageSource) and not el.built_for:
            v_ref = max(v_ref, abs(el.dc), _peak(el.waveform))
    return v_ref


def _peak(wave) -> float:
    if isinstance(wave, Pulse):
        return max(abs(wave.v1), abs(wave.v2))
    if isinstance(wave, Sin):
        return abs(wave.vo) + abs(wave.va)
    values = getattr(wave, "values", None)
    return max((abs(v) for v in values), default=0.0) if values else 0.0


