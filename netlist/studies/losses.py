"""Conduction losses, input and output power and efficiency over the steady-state window
(``--losses``).

Over the window ``pelcs check`` uses (the last whole periods of the switching source, up to
10; :func:`netlist.studies.measure.steady_state_window`):

- conduction loss of every diode and switch, ``mean(Vf |i| + Ron i²)`` with the device's
  piecewise-linear parameters (zero for ideal devices), W;
- loss in every resistor, ``mean(R i²)`` (a resistor stepped in time, :mod:`netlist.time_value`,
  the sum over its segments: ``mean(R(t) i²)``; its ideal bypass switches lose nothing and are
  not listed);
- input power, the power the independent voltage sources deliver, ``mean(-v i)`` (SPICE's
  current direction, from n+ through the source);
- output power, the power of the load: the resistor named by ``load``, else the resistor
  that takes the most power;
- efficiency ``P_out / P_in``.

What is neither loss nor output (the change of the stored energy over the window, other
resistors) is reported as the balance.

The figures are those of a steady state only if the window is one: every inductor current and
capacitor voltage is checked with :func:`netlist.studies.measure.settling` (the averages over the
window's periods agree within :data:`~netlist.studies.measure.SETTLE_LEVEL` of the probe's RMS: no
net inductor voltage, no net capacitor charge over a period). A window that has not settled
is reported as such (:attr:`LossReport.settled`, the efficiency line says "not settled"):
while an output capacitor still charges, part of the input goes into storage and the
efficiency reads low.

A switch that slides (Filippov relay: a MOSFET with its gate RC following its gate through
its linear region, ``--devices pwl``) inside the window has no recorded current of its own
there: a sliding step combines the end states of both of its modes, and the currents
recorded are that combination, not the device's. The input power and the device losses are
then not computed (NaN), and ``caveat`` says why.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..capacitor_links import capacitor_links
from ..circuit import Capacitor, Circuit, Diode, Inductor, Resistor, Switch, VoltageSource
from ..reductions import held_capacitors, parallel_diodes
from ..time_value import time_resistor_part
from .measure import (
    Measurement,
    probe_unit,
    settling,
    steady_state_period,
    steady_state_window,
)

__all__ = ["LossReport", "loss_probes", "losses", "storage_probes"]


@dataclass
class LossReport:
    """Powers over the steady-state window (W), and the efficiency.

    Attributes
    ----------
    window : (float, float)
        s.
    periods : int
        Whole periods in it (0: the last 20 % of the run).
    devices : dict
        Conduction loss per diode and switch, W.
    resistors : dict
        Loss per resistor other than the load, W.
    p_in, p_out : float
        W.
    load : str
    efficiency : float
        ``p_out / p_in`` (nan without input power).
    unsettled : tuple of Settling
        The storage probes (inductor currents, capacitor voltages) whose averages still drift
        over the window's periods (:func:`netlist.studies.measure.settling`); empty when settled.
    checked : bool
        Whether the check could be made (False: less than two periods in the run).
    caveat : str
        Why some powers are not computed (NaN), or "".
    """

    window: tuple
    periods: int
    devices: dict = field(default_factory=dict)
    resistors: dict = field(default_factory=dict)
    p_in: float = float("nan")
    p_out: float = float("nan")
    load: str = ""
    efficiency: float = float("nan")
    unsettled: tuple = ()
    checked: bool = True
    caveat: str = ""

    @property
    def settled(self) -> bool:
        """Whether the window was checked and every storage probe had settled over it."""
        return self.checked and not self.unsettled

    def settling_text(self) -> str:
        """Why the window is not a steady state, in words ('' when it is one)."""
        from ..units import format_eng

        if not self.checked:
            return "not checked: the run holds less than two periods"
        if not self.unsettled:
            return ""
        worst = max(self.unsettled, key=lambda c: c.drift / c.limit if c.limit > 0
                    else math.inf)
        unit = probe_unit(worst.probe)
        more = f" and {len(self.unsettled) - 1} more" if len(self.unsettled) > 1 else ""
        return (f"{worst.probe} averages drift by {format_eng(worst.drift, unit)} over "
                f"{worst.parts} (limit {worst.basis}){more}; run longer")

    @property
    def balance(self) -> float:
        """``p_in - p_out - losses`` (W): stored-energy change and rounding."""
        return self.p_in - self.p_out - sum(self.devices.values()) - sum(
            self.resistors.values())

    def to_dict(self) -> dict:
        return {"window": list(self.window), "periods": self.periods,
                "devices_W": dict(self.devices), "resistors_W": dict(self.resistors),
                "input_W": self.p_in, "output_W": self.p_out, "load": self.load,
                "efficiency": self.efficiency, "balance_W": self.balance,
                "settled": self.settled, "settling": self.settling_text(),
                "caveat": self.caveat}

    def lines(self) -> list[str]:
        def w(v: float) -> str:
            return f"{v:.4g} W" if v == v else "n/a"

        out = [f"losses over {self.window[0]:.6g}..{self.window[1]:.6g} s "
               f"({self.periods} periods): input {w(self.p_in)}, output {w(self.p_out)} "
               f"({self.load})"]
        parts = [f"{k} {w(v)}" for k, v in {**self.devices, **self.resistors}.items()]
        if parts:
            out.append("  conduction: " + ", ".join(parts))
        efficiency = (f"{100 * self.efficiency:.2f} %" if self.efficiency == self.efficiency
                      else "n/a")
        why = self.settling_text()
        if why:
            # (not a bare figure: the window is not a steady state, or was not checked)
            out.append(f"efficiency: {efficiency} "
                       f"({'not settled: ' if self.checked else ''}{why})")
        else:
            out.append(f"efficiency: {efficiency}")
        if self.caveat:
            out.append(f"  ({self.caveat})")
        return out


def _sources(circuit: Circuit) -> list[VoltageSource]:
    return [el for el in circuit.elements
            if isinstance(el, VoltageSource) and "#" not in el.name]


def _vprobe(a: str, b: str) -> str:
    return f"v({a})" if b == "0" else f"v({a},{b})"


def storage_probes(circuit: Circuit) -> list[str]:
    """The inductor currents and capacitor voltages (as node voltages) whose settling
    :func:`losses` checks."""
    probes = []
    for el in circuit.elements:
        if "#" in el.name:
            continue
        if isinstance(el, Inductor):
            probes.append(f"i({el.name})")
        elif isinstance(el, Capacitor):
            probes.append(_vprobe(*el.nodes[:2]))
    return list(dict.fromkeys(probes))


def _held_power(result, circuit: Circuit, everything_held: dict, sel: np.ndarray,
                span: float, p_in: float) -> tuple[float, str]:
    """The input power with that of the capacitors the sources alone join
    (:func:`netlist.reductions.held_capacitors`), whose current the recorded source currents
    leave out, and a caveat ("" when none). Through independent sources only, the power they
    give such a capacitor is ``d(½ C v²)/dt``: its mean over the window is exact from the
    capacitor's voltage at the window's ends. Through E or H sources too, the sources' share
    is not known: NaN and the caveat (``everything_held``: :func:`held_capacitors`)."""
    held = [(k, h) for k, h in everything_held.items() if not h.constant]
    if not held or span <= 0:
        return p_in, ""
    values = {el.key: float(el.value) for el in circuit.elements if isinstance(el, Capacitor)}
    names = {v.name for v in _sources(circuit)}
    for key, h in held:
        if not set(h.path) <= names:
            return float("nan"), (
                f"input power not computed: {h.name} is across {', '.join(h.path)}, not "
                "independent sources alone, whose share of its charging current is not "
                "known (it holds no state)")
        v = np.asarray(result[_vprobe(*h.nodes)], dtype=float)[sel]
        p_in += 0.5 * values[key] * (v[-1] ** 2 - v[0] ** 2) / span
    return p_in, ""


def _link_power(result, circuit: Circuit, held: dict, sel: np.ndarray, span: float) -> float:
    """The mean power the DC sources give the link capacitors of loops of capacitors and DC
    sources (:func:`netlist.capacitor_links.capacitor_links`), which the recorded source
    currents leave out: a link's current ``C dv/dt`` circulates through its loop, where the
    sources' voltage is its ``const`` (``v = Σ a v_key + const``), so they give it
    ``const C dv/dt``, whose mean over the window is exact from the link's voltage at the
    window's ends (zero over a settled whole number of periods)."""
    total = 0.0
    if span <= 0:
        return total
    for link in capacitor_links(circuit, held).values():
        if not link.sources or link.const == 0.0:
            continue
        v = np.asarray(result[_vprobe(*link.nodes)], dtype=float)[sel]
        total += link.const * link.value * (v[-1] - v[0]) / span
    return total


def _b_source_part(circuit: Circuit, el) -> bool:
    """An element pelcs built inside a B source (the diodes and resistor of a limiter,
    :mod:`netlist.limiter`; a comparator's resistor): pelcs's construction of an ideal
    source, whose inner currents are no power of the circuit. Not a segment of a resistor
    stepped in time (that resistor's power)."""
    return "#" in el.name and (isinstance(el, Diode) and el.ideal
                               or isinstance(el, Resistor)
                               and not time_resistor_part(circuit, el))


def loss_probes(circuit: Circuit) -> list[str]:
    """The probes :func:`losses` needs."""
    merged = parallel_diodes(circuit)
    probes = []
    for el in circuit.elements:
        own = "#" not in el.name or (isinstance(el, Resistor)
                                     and time_resistor_part(circuit, el))
        if isinstance(el, (Diode, Switch, Resistor)) and own and el.key not in merged:
            probes.append(f"i({el.name})")
    for v in _sources(circuit):
        probes += [f"i({v.name})", _vprobe(*v.nodes[:2])]
    return list(dict.fromkeys(probes + storage_probes(circuit)))


def losses(result, circuit: Circuit, fits: Sequence = (), load: str | None = None,
           period: float | None = None) -> LossReport:
    """The :class:`LossReport` of a run that recorded :func:`loss_probes`.

    ``fits``: :class:`netlist.pwl.PwlFit` of the devices (none: ideal, zero loss);
    ``circuit``: the circuit as written (not the piecewise-linear one).
    """
    t = np.asarray(result.t, dtype=float)
    per, _ = steady_state_period(circuit, result) if period is None else (period, "")
    (a, b), n = steady_state_window((float(t[0]), float(t[-1])), per)
    sel = (t >= a) & (t <= b)
    tw = t[sel]
    span = tw[-1] - tw[0] if tw.size > 1 else 0.0

    def mean(y):
        y = np.asarray(y, dtype=float)[sel]
        return float(np.trapezoid(y, tw) / span) if span > 0 else float(np.mean(y))

    fit = {f.element: f for f in fits}
    rep = LossReport((a, b), n)
    merged = parallel_diodes(circuit)
    for el in circuit.elements:
        if isinstance(el, Switch) and el.built_for:
            continue  # a bypass of a resistor stepped in time: ideal, part of the resistor
        if _b_source_part(circuit, el):
            continue
        if isinstance(el, (Diode, Switch)) and el.key not in merged:
            f = fit.get(el.name)
            if f is None:
                rep.devices[el.name] = 0.0
                continue
            i = np.asarray(result[f"i({el.name})"], dtype=float)
            rep.devices[el.name] = mean(np.abs(i) * f.voltage(np.abs(i)))
    powers = {}
    for el in circuit.elements:
        if isinstance(el, Resistor) and not _b_source_part(circuit, el):
            i = np.asarray(result[f"i({el.name})"], dtype=float)
            # (a segment of a resistor stepped in time: that resistor's power)
            owner = el.built_for or el.name
            powers[owner] = powers.get(owner, 0.0) + mean(el.value * i * i)
    if powers:
        rep.load = next((k for k in powers if load and k.lower() == load.lower()), None) or \
            max(powers, key=powers.get)
        rep.p_out = powers.pop(rep.load)
        rep.resistors = powers
    p_in = 0.0
    for v in _sources(circuit):
        p_in += mean(-np.asarray(result[_vprobe(*v.nodes[:2])], dtype=float)
                     * np.asarray(result[f"i({v.name})"], dtype=float))
    held = held_capacitors(circuit)
    p_in += _link_power(result, circuit, held, sel, span)
    p_in, rep.caveat = _held_power(result, circuit, held, sel, span, p_in)
    rep.p_in = p_in
    rep.efficiency = rep.p_out / p_in if p_in > 0 else float("nan")
    checks = settling(result, [Measurement("mean", p, f"mean({p})")
                               for p in storage_probes(circuit)], (a, b), per)
    rep.checked = bool(checks) or not storage_probes(circuit)
    rep.unsettled = tuple(c for c in checks if not c.settled)
    slid: dict[str, float] = {}
    for name, t0, t1 in getattr(result, "sliding", ()):
        overlap = min(t1, b) - max(t0, a)
        if overlap > 0:
            slid[name] = slid.get(name, 0.0) + overlap
    if slid:
        nan = float("nan")
        rep.devices = {k: nan for k in rep.devices}
        rep.p_in, rep.efficiency = nan, nan
        rep.caveat = ("input power and device losses not computed: " + ", ".join(
            f"{k} slides over {100 * v / (b - a):.2g} % of the window" for k, v in slid.items())
            + " (a MOSFET following its gate through its linear region), where the recorded "
            "currents combine its two modes' steps")
    return rep
