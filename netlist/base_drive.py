"""The base current a BJT idealised as a switch can get, against the collector current the
switch carries.

pelcs turns a BJT into a switch from collector to emitter, on while ``v(base, emitter)``
passes its threshold (:mod:`netlist.devices`); its base draws nothing. A real BJT is a closed
switch only saturated: its collector current at most ``BF`` times its base current. Biased
with less base current it is in its forward-active region, an amplifier, and the collector
sits wherever ``BF Ib`` puts it (a review deck: v(c) 0.2 V as a switch, 0.96 V in ngspice).
Where the base is reached by resistors only, the most base current the circuit can supply
is bounded by ``Σ (v(k) - v(emitter) - VBE_LOW)⁺ / R_k`` over the resistors ``R_k`` from the
base to the nodes ``k``: the base cannot sit below ``VBE_LOW`` above the emitter while the
device conducts, and the far ends' voltages are the run's (loading by the base current only
pulls them towards the base). A switch carrying more than ``BF`` times that bound is a
transistor in its active region there, and the run is not the circuit's. The check is
one-sided: a base driven by a source, or reached through anything but resistors (a
speed-up capacitor, a diode, another transistor), is not checked.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from .circuit import GROUND, Capacitor, Circuit, Inductor, Resistor, Switch, VoltageSource
from .errors import Diagnostic, Location
from .knee import NodeVoltages, voltage_nodes
from .probes import voltage_probe
from .thyristor import read_thyristors
from .units import format_eng

__all__ = ["VBE_HIGH", "VBE_LOW", "BaseClamp", "BaseDrive", "resolve_base_drives",
           "thyristor_pairs"]

#: the least base–emitter voltage of a conducting silicon BJT the bound assumes, V (ngspice's
#: default IS = 1e-16 A: 0.54 V at 1 µA): lower than the device's, so the bound is over
#: the base current it gets
VBE_LOW = 0.5


@dataclass(frozen=True)
class BaseDrive:
    """A BJT ``name`` (``device`` NPN or PNP) idealised as a switch on while
    ``v(control) > threshold``, ``control`` its base and emitter (PNP: emitter and base),
    gain ``beta`` (its model's BF), its base reached by ``resistors`` ((far node, Ω) each;
    None until :func:`resolve_base_drives` reads the circuit). A knee of
    :func:`netlist.knee.check_knees` with a ``share``: its quantity is the switch's current
    over ``beta`` times the bound on the base current, less 1 (-1 where off)."""

    name: str
    device: str
    control: tuple[str, str]
    threshold: float
    beta: float
    resistors: tuple[tuple[str, float], ...] | None = None
    location: Location | None = field(default=None, compare=False, repr=False)
    share = 0.1  # (as netlist.devices.LIMIT_SHARE)
    # (netlist.knee.knees_for_run: left out of a long streamed run, as a MOSFET's checks: a
    # 2 s NPN boost written to a CSV held 321 MB with it, 87 MB without)
    droppable = True
    unchecked = "a base drive too weak to saturate it"

    @property
    def base(self) -> str:
        return self.control[0] if self.device == "NPN" else self.control[1]

    @property
    def emitter(self) -> str:
        return self.control[1] if self.device == "NPN" else self.control[0]

    @property
    def _nodes(self) -> tuple[str, ...]:
        return voltage_nodes(self.control, [n for n, _ in self.resistors or ()])

    @property
    def probes(self) -> tuple[str, ...]:
        return (f"i({self.name})", *(f"v({n})" for n in self._nodes))

    def base_bound(self, v: NodeVoltages) -> np.ndarray:
        """The most base current the resistors supply, A, at the run's node voltages."""
        sign = 1.0 if self.device == "NPN" else -1.0
        ib = v.zero.copy()
        for node, r in self.resistors or ():
            ib += np.maximum(sign * v.across((node, self.emitter)) - VBE_LOW, 0.0) / r
        return ib

    def quantity(self, columns: Sequence[np.ndarray]) -> np.ndarray:
        current, *volts = columns
        v = NodeVoltages(self._nodes, volts, current)
        on = v.across(self.control) > self.threshold
        most = self.beta * self.base_bound(v)
        scale = max(1.0, float(np.max(np.abs(current), initial=0.0)))
        with np.errstate(divide="ignore", invalid="ignore"):
            excess = np.where(most > 0, np.abs(current) / most - 1.0,
                              np.where(np.abs(current) > 1e-9 * scale, np.inf, -1.0))
        return np.where(on, excess, -1.0)

    def inside(self, q: np.ndarray) -> np.ndarray:
        return q <= 1e-6

    def _what(self) -> str:
        def v(node: str) -> str:
            return "0" if node == GROUND else f"v({node})"

        pairs = [(v(n), v(self.emitter)) if self.device == "NPN" else (v(self.emitter), v(n))
                 for n, _ in self.resistors or ()]
        terms = " + ".join(f"({a}{'' if b == '0' else f' - {b}'} - {VBE_LOW:g} V)/"
                           f"{format_eng(r, 'Ω')}"
                           for (a, b), (_, r) in zip(pairs, self.resistors or (), strict=True))
        return (f"BF = {self.beta:g} times the most base current its base resistors supply "
                f"({terms})")

    def outside(self, q: float, t: float, total: float = 0.0) -> Diagnostic:
        return Diagnostic(
            f"{self.name} ({self.device}) is on as a switch and carries {q + 1:.3g} times "
            f"{self._what()} at t = {t:.6g} s, for {total:.3g} s of the run in all: there "
            "the real transistor is not saturated but in its forward-active region (its "
            "collector current BF times its base current, as in ngspice), where the ideal "
            "switch shorts collector to emitter, so the run is not this circuit",
            self.location,
            "drive the base harder (a smaller base resistor), or model the stage as an "
            "amplifier (an E, G or B source); an ideal switch is an S element", (self.name,))

    def brief(self, t: float, total: float) -> str:
        return (f"{self.name}: on as a switch but carrying more than {self._what()} for "
                f"{total:.3g} s of the run in all, from t = {t:.6g} s: there the real "
                "transistor is in its forward-active region and the waveforms are the ideal "
                "switch's, not the circuit's")

    def stayed(self, lo: float, hi: float) -> None:
        return None


#: the most a silicon base-emitter junction stands at while conducting, V: above it the
#: junction of the device would carry the base network's current and hold the base
#: (0.8 V at a milliamp for ngspice's default IS; a power transistor's at amperes, about 1 V)
VBE_HIGH = 1.2


@dataclass(frozen=True)
class BaseClamp:
    """A BJT idealised as a switch whose base node holds state: a capacitor or an inductor
    joins it. The device's base-emitter junction holds the base near 0.7 V above the emitter
    (below it for PNP) whenever the base network would take it higher, and the charge of
    such a capacitor follows; the idealised BJT draws no base current, so its base goes
    wherever the network takes it (a monostable's base pulled up to 5 V, not 0.8 V, then
    kicked 4 V lower than in the device: its pulse 15 us against ngspice's 77 us). A knee of
    :func:`netlist.knee.check_knees` with a share: the quantity is how far the base stands
    past :data:`VBE_HIGH` (V)."""

    name: str
    device: str
    control: tuple[str, str]
    location: Location | None = field(default=None, compare=False, repr=False)
    share = 0.02
    droppable = True
    unchecked = "a base above its base-emitter junction's drop"

    @property
    def _nodes(self) -> tuple[str, ...]:
        return voltage_nodes(self.control)

    @property
    def probes(self) -> tuple[str, ...]:
        return tuple(f"v({n})" for n in self._nodes)

    def quantity(self, columns: Sequence[np.ndarray]) -> np.ndarray:
        return NodeVoltages(self._nodes, columns, columns[0]).across(self.control) - VBE_HIGH

    def inside(self, q: np.ndarray) -> np.ndarray:
        return q <= 0.0

    def _ctl(self) -> str:
        return voltage_probe(*self.control)

    def outside(self, q: float, t: float, total: float = 0.0) -> Diagnostic:
        return Diagnostic(
            f"{self.name} ({self.device}): {self._ctl()} stands at {q + VBE_HIGH:.3g} V (the "
            f"median over the {total:.3g} s of the run it is past {VBE_HIGH:g} V, from t = "
            f"{t:.6g} s), where the device's base-emitter junction would conduct and hold it "
            "near 0.7 V; the idealised BJT has no junction, so the capacitor or inductor at "
            "its base carries a charge the circuit would not give it (a monostable's pulse "
            "comes out several times too short), and the run is not this circuit",
            self.location,
            "pelcs idealises a BJT as a switch without its base-emitter junction; a circuit "
            "whose timing rests on that junction (monostables, astables, bootstraps) is "
            "outside what it simulates: use ngspice, or model the switch as an S element",
            (self.name,))

    def brief(self, t: float, total: float) -> str:
        return (f"{self.name}: {self._ctl()} past {VBE_HIGH:g} V for {total:.3g} s of the "
                f"run in all, from t = {t:.6g} s, where the device's base-emitter junction "
                "would hold it near 0.7 V: the charge at its base there is the ideal "
                "switch's, not the circuit's")

    def stayed(self, lo: float, hi: float) -> None:
        return None


def _speed_up(base: str, emitter: str, els: list, at: dict[str, list]) -> bool:
    """Whether the base is joined only by resistors and capacitors (a speed-up capacitor
    across its base resistor) from one node that an independent voltage source holds to
    ground, and perhaps resistors to a grounded emitter: the ideal base follows that node's
    edges and its capacitor's charge differs from the device's, whose base stands at its
    junction's drop and is kicked below the emitter at turn-off; both turn on and off at
    that node's edges (an NPN switch with 1 nF across 1 kΩ, with and without 4.7 kΩ from
    base to emitter: the collector's edges within 0.01 us of ngspice's)."""
    def far(e) -> str:
        return e.nodes[1] if e.nodes[0] == base else e.nodes[0]

    if not all(isinstance(e, (Resistor, Capacitor)) for e in els):
        return False
    drive = {far(e) for e in els if isinstance(e, Capacitor)}
    if len(drive) != 1 or GROUND in drive:
        return False
    (node,) = drive
    if not {far(e) for e in els} <= {node, emitter} or (emitter != GROUND and emitter in {
            far(e) for e in els}):
        return False
    return any(isinstance(e, VoltageSource) and GROUND in e.nodes[:2]
               for e in at.get(node, []))


def thyristor_pairs(pairs: Sequence[tuple[Switch, Switch]]) -> list[Diagnostic]:
    """A refusal for each of the ``pairs`` of :func:`netlist.thyristor.two_transistor_pairs`
    that :func:`netlist.thyristor.read_thyristors` left: those it does not read as an ideal
    thyristor. The loop fires and
    latches through the base currents, which the transistors idealised as switches do not
    draw: run so, the SCR never fires (PySpice power-electronics examples: 0 V where ngspice
    gives 28.9 V)."""
    out = []
    for p, n in pairs:
        out.append(Diagnostic(
            message=f"{p.name} and {n.name} form a thyristor (each drives the "
                    "other's base: the two-transistor model of an SCR), which "
                    "transistors idealised as switches cannot fire or latch: they "
                    "draw no base current, and the loop that turns a thyristor on "
                    "and holds it is made of those currents",
            location=p.location,
            hint="write the thyristor as switches pelcs reads: an ideal diode in "
                 "series with an S switch its gate drive turns on (the same "
                 "thyristor where the gate pulse lasts until the current has fallen "
                 "to zero), or an XSPICE aswitch latched through F sources and a "
                 "capacitor, as eSim's SCR is",
            elements=(p.name, n.name)))
    return out


def resolve_base_drives(circuit: Circuit) -> list[Diagnostic]:
    """Read each two-transistor thyristor that fits as an ideal one
    (:func:`netlist.thyristor.read_thyristors`);
    give each :class:`BaseDrive` of ``circuit.knees`` the resistors that reach its base,
    or drop it where the base node joins anything else (a source, a capacitor, a diode,
    another device's terminal: the base current is not bounded by resistors alone) or
    nothing at all; the refusals of :func:`thyristor_pairs` for the pairs left."""
    diags = thyristor_pairs(read_thyristors(circuit))
    drives = [k for k in circuit.knees if isinstance(k, BaseDrive) and k.resistors is None]
    if not drives:
        return diags
    at: dict[str, list] = {}
    for el in circuit.elements:
        for n in dict.fromkeys(el.nodes):
            at.setdefault(n, []).append(el)
    resolved, clamps = {}, []
    for k in drives:
        els = at.get(k.base, [])
        if k.base != GROUND and any(isinstance(e, (Capacitor, Inductor)) for e in els) \
                and not any(isinstance(e, VoltageSource) for e in els) \
                and not _speed_up(k.base, k.emitter, els, at):
            clamps.append(BaseClamp(k.name, k.device, k.control, k.location))
        if k.base == GROUND or not els or not all(
                isinstance(e, Resistor) and e.time_value is None and e.value > 0
                and len(set(e.nodes[:2])) == 2 for e in els):
            continue
        far = tuple((e.nodes[1] if e.nodes[0] == k.base else e.nodes[0], float(e.value))
                    for e in els)
        resolved[id(k)] = replace(k, resistors=far)
    circuit.knees[:] = [resolved.get(id(k), k) for k in circuit.knees
                        if not isinstance(k, BaseDrive) or id(k) in resolved
                        or k.resistors is not None] + clamps
    return diags
