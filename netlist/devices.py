"""Transistors idealised as switches: what an M or Q element becomes, and the
report of every replacement.

A MOSFET (``M``, models NMOS/PMOS/VDMOS) becomes an ideal switch between drain and source,
on while its gate–source voltage is past the threshold: ``VTO`` of its model (ngspice's
default 0 V when the model has none; for a P-channel device the switch is on while
``v(source, gate) > -VTO``). A VDMOS model has a body diode in ngspice; pelcs keeps it as an
ideal diode from source to drain (drain to source for P-channel). A BJT (``Q``, NPN/PNP)
becomes a switch between collector and emitter, on while ``v(base, emitter)`` (``v(emitter,
base)`` for PNP) exceeds :data:`BJT_THRESHOLD`. A threshold given by the user (``--threshold
NAME=V``, per element or per model) overrides both. Gate and junction capacitances, on
resistances and the bulk/substrate terminal are dropped: the report says so.

ngspice still runs the device with its real model (the writer writes the original line).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from .circuit import GROUND
from .errors import Diagnostic, Location, NetlistError
from .knee import NodeVoltages, voltage_nodes
from .units import parse_number

__all__ = ["BJT_THRESHOLD", "DEVICE_TYPES", "ChannelLimit", "ReverseChannel", "Replacement",
           "channel_checks", "channel_limit", "dropped_parts", "gate_rc", "instance_geometry",
           "threshold"]

#: how far past its threshold a channel off in pelcs may stand against its drain by
#: rounding, per volt of the run's largest node voltage (ReverseChannel)
_ROUNDING = 1e-6
#: base–emitter voltage at which an idealised BJT switch turns on, V
BJT_THRESHOLD = 0.7

#: model types idealised as switches, and the device each is
DEVICE_TYPES = {"NMOS": "MOSFET", "PMOS": "MOSFET", "VDMOS": "MOSFET", "NPN": "BJT",
                "PNP": "BJT"}


@dataclass(frozen=True)
class Replacement:
    """What an idealised device became.

    Attributes
    ----------
    element : str
        The device's (hierarchical) name, e.g. ``"M1"`` or ``"X1.M1"``.
    model, device : str
        Its model name and type (``"NMOS"``, ``"VDMOS"``, ``"NPN"``...).
    became : str
        One line: the switch, its terminals and its control.
    threshold : float
        Switch threshold, V, and where it came from (``source``: ``"VTO"``, ``"default"``,
        ``"--threshold"``).
    source : str
    body_diode : str or None
        The name of the ideal body diode, if one was kept.
    dropped : tuple of str
        What of the device pelcs does not simulate.
    location : Location or None
        Where the device's line is (an ``M``/``Q`` line, or the ``X`` line of a macro-model).
    """

    element: str
    model: str
    device: str
    became: str
    threshold: float
    source: str
    body_diode: str | None
    dropped: tuple[str, ...]
    location: Location | None = field(default=None, compare=False, repr=False)

    def line(self) -> str:
        if self.device == "diode macro-model":
            return (f"{self.element} (diode macro-model {self.model}) -> {self.became}; "
                    f"dropped: {', '.join(self.dropped) or 'nothing'}")
        if self.device == "thyristor":  # a two-transistor model (netlist.thyristor)
            return (f"{self.element} (thyristor, two-transistor model {self.model}) -> "
                    f"{self.became}; dropped: {', '.join(self.dropped)}")
        body = f", body diode {self.body_diode}" if self.body_diode else ", no body diode"
        return (f"{self.element} ({self.device} {self.model}) -> {self.became}, threshold "
                f"{self.threshold:g} V ({self.source}){body}; dropped: "
                f"{', '.join(self.dropped)}")


@dataclass(frozen=True)
class ReverseChannel:
    """A MOSFET without a body diode (NMOS, PMOS) idealised as a switch on while
    ``v(control) > threshold``, ``control`` its gate and source. The channel of the device
    conducts either way: where the source rises past the drain (below it, P-channel) the two
    swap, and the gate opens it against the drain. The ideal switch does not: a run that
    keeps the switch off while ``v(reverse) > threshold`` (the gate against the drain) is not
    the circuit's, and :func:`netlist.knee.check_knees` makes it an error at that instant.
    The quantity checked is how far past the threshold the gate stands against the drain
    while the switch is off (V; -1 where it is on)."""

    name: str
    device: str
    control: tuple[str, str]
    reverse: tuple[str, str]
    threshold: float
    droppable = True  # (netlist.knee.knees_for_run: left out of a long streamed run)
    unchecked = "a channel that would conduct backwards"  # (its note then)
    location: Location | None = field(default=None, compare=False, repr=False)

    @property
    def _nodes(self) -> tuple[str, ...]:
        return voltage_nodes(self.control, self.reverse)

    @property
    def probes(self) -> tuple[str, ...]:
        return tuple(f"v({n})" for n in self._nodes)

    def quantity(self, columns: Sequence[np.ndarray]) -> np.ndarray:
        v = NodeVoltages(self._nodes, columns, columns[0])
        off = v.across(self.control) <= self.threshold
        over = v.across(self.reverse) - self.threshold
        # A drain on the source's potential up to rounding (an ideal diode across it, VTO
        # = 0, ngspice's default: 1.8e-15 V past) is no reverse conduction: a level-1
        # channel carries KP/2 (1 uV)^2 at a micro-volt a volt of the run's voltages
        tol = _ROUNDING * max(1.0, max(float(np.max(np.abs(c), initial=0.0)) for c in columns))
        over = np.where(over <= tol, np.minimum(over, 0.0), over)
        return np.where(off, over, -1.0)

    @classmethod
    def of(cls, name: str, device: str, control: tuple[str, str], drain: str,
           threshold: float, location: Location | None) -> ReverseChannel:
        """The check of a switch on ``control`` (gate, source; P-channel: source, gate),
        the gate against ``drain`` in the source's place."""
        pchan = device == "PMOS"
        reverse = (drain, control[1]) if pchan else (control[0], drain)
        return cls(name, device, control, reverse, threshold, location)

    def inside(self, q: np.ndarray) -> np.ndarray:
        return q <= 0.0

    def outside(self, q: float, t: float) -> Diagnostic:
        nmos = self.device == "NMOS"
        s = self.control[1] if nmos else self.control[0]
        d = self.reverse[1] if nmos else self.reverse[0]
        return Diagnostic(
            f"{self.name} ({self.device}) is off in pelcs at t = {t:.6g} s (its switch is on "
            f"only while v({self.control[0]},{self.control[1]}) > {self.threshold:g} V) "
            f"while the gate stands {q + self.threshold:.4g} V against its drain {d}: a "
            f"MOSFET's channel conducts either way (drain and source swap where {s} passes "
            f"{d}), the ideal switch does not, so the run is not this circuit", self.location,
            f"keep node {s} from passing {d} (a capacitance or a path to ground at it), or "
            "use a VDMOS model, whose body diode conducts that way", (self.name,))

    def stayed(self, lo: float, hi: float) -> None:
        return None


#: the share of a run an idealised MOSFET may carry more than its channel's most (a
#: switching edge, where its gate passes the threshold: ChannelLimit) before the run is read
#: as one of a transistor in its active region, as ACTIVE_SHARE for sliding
LIMIT_SHARE = 0.1


@dataclass(frozen=True)
class ChannelLimit:
    """The most current an idealised MOSFET's channel carries while it stays a switch.

    A level-1 MOSFET (Shichman-Hodges, ngspice's ``mos1load.c``) at an overdrive ``vov =
    v(control) - threshold`` carries at most ``beta/2 vov² (1 + lambda vov)`` with its drain
    within ``vov`` of its source (its triode region, where it is on as a switch); more
    current saturates it, the drain rising to whatever the circuit sets: the device then is
    an amplifier, not the switch that pelcs puts in its place. A VDMOS (``vdmosload.c``)
    scales it by ``1/(1 + theta vgs)`` (ngspice 39; later ngspice by the overdrive), its
    triode region is ``mtriode`` times narrower, and
    its overdrive is softened below threshold (``ksubthres``). The ideal switch, on, carries
    whatever the circuit drives through it; a run where it carries more than that bound
    (``|i|`` against the bound at the gate voltage of the same step) is not the circuit's
    there. The check is one-sided: a current under the bound is not proven to leave the
    drain near the source, but one over it is proven not to.

    Every switching edge passes through such instants (the gate crosses the threshold with
    the switch already carrying the load); :func:`netlist.knee.check_knees` refuses a run
    only when they add up to more than :data:`LIMIT_SHARE` of it, and notes them otherwise.
    The quantity is the current's excess over the bound, relative (-1 where off).
    """

    name: str
    device: str
    control: tuple[str, str]
    threshold: float  # V, the switch's (VTO, or --threshold)
    vto: float  # V, the model's, as a positive control voltage
    beta: float  # A/V², KP W/Leff M
    lam: float = 0.0  # 1/V
    theta: float = 0.0  # 1/V
    mtriode: float = 1.0
    ksubthres: float = 0.0  # V; 0: none (level 1)
    subshift: float = 0.0  # V
    location: Location | None = field(default=None, compare=False, repr=False)
    # False: a level 2 or 3 with NSUB, whose current at the triode edge may pass the bound;
    # only its KP W/Leff and VTO are read (the pwl channel, netlist.pwl): a run leaves it
    # out of its knees (netlist.studies.transient.transient_setup), stores and checks nothing
    checked: bool = True
    share = LIMIT_SHARE
    # (netlist.knee.knees_for_run: left out of a long streamed run, as ReverseChannel, which
    # every circuit of MOSFET switches has too: a 2 s boost streamed in 87 MB held 334 MB)
    droppable = True
    unchecked = "a channel carrying more than its gate voltage allows"

    @property
    def _nodes(self) -> tuple[str, ...]:
        return voltage_nodes(self.control)

    @property
    def probes(self) -> tuple[str, ...]:
        return (f"i({self.name})", *(f"v({n})" for n in self._nodes))

    def limit(self, vov: np.ndarray) -> np.ndarray:
        """The bound, A, at overdrives ``vov`` (control voltage less VTO), V."""
        vov = np.asarray(vov, dtype=float)
        if self.ksubthres > 0:  # (vdmosload.c's weak inversion: a smooth max(vov, 0))
            z = (vov - self.subshift) / self.ksubthres
            eff = self.ksubthres * np.logaddexp(0.0, z)
        else:
            eff = np.maximum(vov, 0.0)
        # (ngspice 39 reduces the mobility by THETA times vgs, not the overdrive)
        vgs = np.maximum(vov + self.vto, 0.0)
        beta = self.beta * (1 + self.lam * eff / self.mtriode) / (1 + self.theta * vgs)
        return 0.5 * beta * eff * eff

    def quantity(self, columns: Sequence[np.ndarray]) -> np.ndarray:
        current, *volts = columns
        if not self.checked:
            return np.full(np.shape(current), -1.0)
        ctl = NodeVoltages(self._nodes, volts, current).across(self.control)
        bound = self.limit(ctl - self.vto)
        with np.errstate(divide="ignore", invalid="ignore"):
            excess = np.abs(current) / bound - 1.0
        return np.where(ctl > self.threshold, np.nan_to_num(excess, nan=-1.0, posinf=np.inf),
                        -1.0)

    def inside(self, q: np.ndarray) -> np.ndarray:
        return q <= 1e-6

    def _what(self) -> str:
        ctl = (f"v({self.control[0]})" if self.control[1] == GROUND
               else f"v({self.control[0]},{self.control[1]})")
        vdmos = self.device == "VDMOS"
        scaled = " and ".join(k for k, on in (("THETA", self.theta), ("MTRIODE", self.mtriode
                                                                    != 1)) if on)
        return (f"the most its channel carries with the drain near the source at that gate "
                f"voltage, KP/2 ({ctl} - {self.vto:g} V)²"
                + (f" scaled by its {scaled}" if scaled else "")
                + f" ({'KP' if vdmos else 'KP W/L'} = {self.beta:.4g} A/V²)")

    def outside(self, q: float, t: float, total: float = 0.0) -> Diagnostic:
        # (a bound of 0: on past a --threshold under VTO, where a level-1 channel is shut)
        # (q: the median excess over the time counted, netlist.knee.check_knees)
        times = f"{q + 1:.3g} times" if math.isfinite(q) else "current past"
        return Diagnostic(
            f"{self.name} ({self.device}) is on as a switch and carries {times} "
            f"{self._what()} (the median over the {total:.3g} s of the run it is over it, "
            f"from t = {t:.6g} s): "
            "there the real device saturates, its drain rising to whatever the circuit "
            "sets (its active region, as in ngspice), where the ideal switch shorts it, so "
            "the run is not this circuit", self.location,
            "drive the gate harder, or give the model the KP (or W/L) of the device meant "
            "(a power MOSFET's KP is 1 to 50 A/V²; ngspice's level-1 default is 2e-5); an "
            "ideal switch is an S element", (self.name,))

    def brief(self, t: float, total: float) -> str:
        return (f"{self.name}: on as a switch but carrying more than {self._what()} for "
                f"{total:.3g} s of the run in all, from t = {t:.6g} s: there the real device is in "
                "its active region (as at a start, or at a slow edge where the gate passes "
                "the threshold with the switch carrying its load) and the waveforms are the "
                "ideal switch's, not the circuit's; the real device, carrying less there, "
                "may take longer to leave it (a start-up it limits lasts longer than the "
                "ideal switch's)")

    def stayed(self, lo: float, hi: float) -> None:
        return None


def channel_limit(name: str, el, model, control: tuple[str, str], threshold_v: float,
                  location: Location | None, nominal: bool = True,
                  geometry: tuple[float, float, float] | None = None) -> ChannelLimit | None:
    """The :class:`ChannelLimit` of a MOSFET ``el`` idealised on ``control`` past
    ``threshold_v``, V, of ``geometry`` (its W, L, m: :func:`instance_geometry`; None: read
    from its line without parameters), unchecked (``checked`` False) for a level 2 or 3 with
    NSUB (its depletion width shortens the channel at the triode edge); None where pelcs
    has no bound: a BSIM model, a level 3 with ETA (its threshold falls as the drain
    rises), a circuit away from its nominal
    temperature (``nominal`` False: ngspice scales KP and VTO there), or a W, L or m that
    pelcs cannot evaluate (nan: the bound would be a guess).

    Levels 2 and 3 (``mos2load.c``, ``mos3load.c``) take level 1's bound: their mobility
    reduction (THETA, UCRIT), velocity saturation (VMAX) and body charge only lower the
    current at a drain within the overdrive of the source (ngspice 39's currents there, with
    THETA, VMAX, KAPPA, GAMMA and XJ: under it, tests/test_channel_limit.py).

    Defaults are ngspice 39's: level 1 KP = 2e-5 A/V² (or UO COX, UO = 600 cm²/Vs, where
    TOX is given; levels 2 and 3 take TOX = 100 nm), W = L = 100 µm; VDMOS KP = 1 A/V²
    (later ngspice: 20, and VTO 3 V)."""
    if not nominal:
        return None
    w, length, mult = geometry if geometry is not None else instance_geometry(el, {}, {})
    if not all(math.isfinite(v) for v in (w, length, mult)):
        return None
    p = {k.lower(): v for k, v in model.params.items()}

    def num(key: str, default: float) -> float:
        v = p.get(key, default)
        return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else nan

    nan = float("nan")  # (a parameter given as something not a number: no bound)

    vto = num("vto", num("vth", 0.0))
    if "vto" not in p and "vth" not in p and model.type in ("NMOS", "PMOS"):
        from .mos_threshold import nsub_vto

        vto = nsub_vto(model.type, p)
        vto = 0.0 if vto is None else vto
    used = ("kp", "lambda", "theta", "mtriode", "ksubthres", "subshift", "level", "tox", "uo",
            "ld", "eta", "nsub")
    if vto != vto or any(num(k, 0.0) != num(k, 0.0) for k in used):
        return None
    vto = -vto if model.type == "PMOS" or (model.type == "VDMOS" and p.get("pchan")) else vto
    if model.type == "VDMOS":
        return ChannelLimit(name, "VDMOS", control, threshold_v, vto, num("kp", 1.0) * mult,
                            num("lambda", 0.0), num("theta", 0.0),
                            max(num("mtriode", 1.0), 1e-12), num("ksubthres", 0.1),
                            num("subshift", 0.0), location)
    level = num("level", 1.0)
    if level not in (1.0, 2.0, 3.0) or (level > 1 and num("eta", 0.0) != 0.0):
        return None  # (BSIM; or a level 3 whose ETA lowers its threshold with the drain)
    # (NSUB gives levels 2 and 3 a depletion width that shortens the channel from the
    # triode edge on: 1.1 um at 1e15 cm^-3, ngspice's current at Vds = Vov twice the bound
    # in an L = 2 um level 2: not checked)
    checked = not (level > 1 and num("nsub", 0.0) != 0.0)
    # (levels 2 and 3 default TOX to 100 nm: KP 2.07e-5 A/V²; level 1 to 2e-5 without it)
    tox = num("tox", 1e-7 if level > 1 else 0.0)
    kp = num("kp", num("uo", 600.0) * 1e-4 * 3.9 * 8.854214871e-12 / tox if tox > 0
             else 2e-5)
    leff = length - 2 * num("ld", 0.0)
    if leff <= 0 or kp <= 0:
        return None
    return ChannelLimit(name, model.type, control, threshold_v, vto, kp * w / leff * mult,
                        num("lambda", 0.0), location=location, checked=checked)


def channel_checks(name: str, el, model, control: tuple[str, str], drain: str,
                   threshold_v: float, location: Location | None, body: bool,
                   temps: tuple[float, float], igbt: bool = False,
                   scope: tuple[Mapping[str, float], Mapping[str, str]] | None = None) -> list:
    """The knees (:mod:`netlist.knee`) of a MOSFET ``el`` idealised as a switch on
    ``control`` past ``threshold_v``: its :class:`ReverseChannel` where it has no body diode
    (``body`` False, an NMOS or PMOS model), its :class:`ChannelLimit` where pelcs has one;
    for a BJT its :class:`netlist.base_drive.BaseDrive` (its resistors read later).
    ``temps``: the circuit's temperature and its nominal one, °C; ``igbt``:
    the MOSFET drives the macro-model's output transistor, whose current has no such bound;
    ``scope``: the parameters and ``.options`` its W, L and m read (:func:`instance_geometry`;
    None: numbers on its line)."""
    if model.type in ("NPN", "PNP") and not igbt:
        from .base_drive import BaseDrive

        bf = model.params.get("bf", 100.0)
        bf = float(bf) if isinstance(bf, (int, float)) and bf > 0 else 100.0
        return [BaseDrive(name, model.type, control, threshold_v, bf, None, location)]
    if model.type not in ("NMOS", "PMOS", "VDMOS") or getattr(el, "kind", "M") != "M":
        return []
    out: list = []
    if model.type != "VDMOS" and not body:
        out.append(ReverseChannel.of(name, model.type, control, drain, threshold_v, location))
    tnom = model.params.get("tnom", temps[1])
    nominal = isinstance(tnom, (int, float)) and abs(temps[0] - float(tnom)) < 1e-9
    geometry = instance_geometry(el, *scope) if scope is not None else None
    limit = None if igbt else channel_limit(name, el, model, control, threshold_v, location,
                                            nominal, geometry)
    return out + ([limit] if limit is not None else [])


def dropped_parts(kind: str, mtype: str, nodes: Sequence[str]) -> tuple[str, ...]:
    """What of an ``M`` or ``Q`` device (``kind``) of model type ``mtype`` with these nodes
    its ideal switch leaves out, for :attr:`Replacement.dropped`."""
    dropped = ["capacitances", "on-resistance and drops"]
    if len(nodes) > 3:
        dropped.append(f"{'bulk' if kind == 'M' else 'substrate'} terminal {nodes[3]}")
    if kind == "M" and mtype != "VDMOS":
        dropped.append("bulk diodes")
    return tuple(dropped)


def threshold(name: str, model: str, mtype: str, params: Mapping[str, float],
              overrides: Mapping[str, float], also: tuple[str, ...] = ()) -> tuple[float, str]:
    """The switch threshold of a device, V (as a positive control voltage), and its source.

    ``overrides`` (case-insensitive keys) name an element, a model, or one of ``also`` (a
    macro-model's subcircuit).
    """
    low = {k.lower(): v for k, v in overrides.items()}
    for key in (name.lower(), name.split(".")[-1].lower(), model.lower(),
                *(a.lower() for a in also)):
        if key in low:
            return float(low[key]), "--threshold"
    if mtype in ("NPN", "PNP"):
        return BJT_THRESHOLD, "default for a BJT"
    vto = params.get("vto", params.get("vth"))
    if vto is None and mtype in ("NMOS", "PMOS"):
        from .mos_threshold import nsub_vto

        vto = nsub_vto(mtype, params)
        if vto is not None:
            return (-vto if mtype == "PMOS" else vto), "VTO from the model's NSUB, as ngspice"
    if vto is None:
        return 0.0, "ngspice's default VTO = 0"
    vto = float(vto)
    return (-vto if mtype == "PMOS" or (mtype == "VDMOS" and params.get("pchan")) else vto,
            "VTO of the model")


# --------------------------------------------------------------------------------------------
# Vendor macro-models


@dataclass(frozen=True)
class Macro:
    """A subcircuit recognised as a device macro-model.

    ``kind`` is ``"transistor"`` (one M or Q inside, or IGBT-like: one MOSFET driving other
    transistors; ``ports`` maps the terminals ``drain/gate/source``, ``collector/base/emitter``
    or ``collector/gate/emitter`` to the subcircuit's ports, ``device`` is the (controlling)
    transistor, ``body`` the (anode port, cathode port) of a diode across the power
    ports or None) or ``"diode"`` (two ports joined only by diodes, resistors and
    capacitors: ``ports`` = (anode port, cathode port)). ``dropped`` names the other
    elements of the body.
    """

    kind: str
    ports: tuple
    device: object = None
    body: tuple | None = None
    dropped: tuple[str, ...] = ()
    body_model: str = ""
    igbt: bool = False


def _resistive_reach(body, ports) -> dict:
    """Node -> the port it reaches through resistors only (itself if it is a port)."""
    adj: dict[str, set[str]] = {}
    for el in body.elements:
        if el.kind == "R":
            a, b = el.nodes[:2]
            adj.setdefault(a, set()).add(b)
            adj.setdefault(b, set()).add(a)
    reach = {}
    for port in ports:
        stack, seen = [port], {port}
        while stack:
            n = stack.pop()
            reach.setdefault(n, port)
            for m in adj.get(n, ()):
                if m not in seen and m not in ports:
                    seen.add(m)
                    stack.append(m)
    return reach


def classify_macro(sub) -> Macro | None:
    """Whether a subcircuit definition (``netlist.rawdeck.SubcktDef``) is a transistor or
    diode macro-model, and how its ports map (None: expand it as it is)."""
    els = sub.body.elements
    ports = [p.lower() for p in sub.ports]
    if any(e.kind == "X" for e in els):
        return None
    reach = _resistive_reach(sub.body, ports)
    devices = [e for e in els if e.kind in "MQ"]
    if len(devices) == 1 and len(ports) >= 3:
        dev = devices[0]
        main, ctl, ret = dev.nodes[0], dev.nodes[1], dev.nodes[2]
        pm, pc, pr = reach.get(main), reach.get(ctl), reach.get(ret)
        if None in (pm, pc, pr) or len({pm, pc, pr}) < 3:
            return None
        body, body_el = None, None
        for e in els:
            if e.kind == "D" and {reach.get(e.nodes[0]), reach.get(e.nodes[1])} == {pm, pr}:
                body, body_el = (reach[e.nodes[0]], reach[e.nodes[1]]), e
                break
        dropped = tuple(e.name for e in els if e is not dev and e is not body_el)
        return Macro("transistor", (pm, pc, pr), dev, body, dropped,
                     body_el.ref if body_el is not None else "")
    mos = [e for e in devices if e.kind == "M"]
    if len(devices) >= 2 and len(mos) == 1 and len(ports) >= 3:
        # IGBT-like: a MOSFET drives the rest (its gate and source are the IGBT's gate and
        # emitter); the collector is the remaining port
        m = mos[0]
        pg, pe = reach.get(m.nodes[1]), reach.get(m.nodes[2])
        rest = [p for p in ports if p not in (pg, pe)]
        if None in (pg, pe) or pg == pe or len(rest) != 1:
            return None
        pc = rest[0]
        body, body_el = None, None
        for e in els:
            if e.kind == "D" and (reach.get(e.nodes[0]), reach.get(e.nodes[1])) == (pe, pc):
                body, body_el = (pe, pc), e
                break
        dropped = tuple(e.name for e in els if e is not m and e is not body_el)
        return Macro("transistor", (pc, pg, pe), m, body, dropped,
                     body_el.ref if body_el is not None else "", igbt=True)
    if len(ports) == 2 and els and all(e.kind in "DRC" for e in els):
        diodes = [e for e in els if e.kind == "D"]
        if not diodes:
            return None
        dirs = {(reach.get(d.nodes[0]), reach.get(d.nodes[1])) for d in diodes}
        if len(dirs) != 1 or None in next(iter(dirs)) or len(set(next(iter(dirs)))) != 2:
            return None
        a, k = next(iter(dirs))
        dropped = tuple(e.name for e in els if e.kind != "D") + tuple(
            d.name for d in diodes[1:])
        return Macro("diode", (a, k), diodes[0], None, dropped)
    return None


def subckt_text(sub) -> str:
    """A subcircuit definition as netlist text, from its statements (for ngspice, which
    simulates the macro-model itself)."""
    ports = " ".join(sub.ports)
    def written(p) -> str:  # the default's value as written (a number or {expression})
        m = re.match(r"\s*[\w.]+\s*=\s*(\{[^}]*\}|'[^']*'|\S+)", p.st.text[p.offset:])
        return m.group(1) if m else "0"

    defaults = " ".join(f"{p.name}={written(p)}" for p in sub.defaults)
    lines = [f".subckt {sub.name} {ports}" + (f" params: {defaults}" if defaults else "")]
    seen = set()
    for item in [*sub.body.params, *sub.body.elements, *sub.body.ics]:
        st = item.st
        if id(st) not in seen:
            seen.add(id(st))
            lines.append(st.text)
    lines.append(f".ends {sub.name}")
    return "\n".join(lines)


#: ngspice's default MOSFET channel width and length (``.options defw``, ``defl``), m
_DEFAULT_LENGTH = 100e-6


def _instance_text(el, key: str) -> str | None:
    """The value of instance parameter ``key`` (``w``, ``l``, ``m``) as written on an M
    line, without its braces or quotes; None where the line has none."""
    m = re.search(rf"(?i)(?<![\w.]){key}\s*=\s*(\{{[^}}]*\}}|'[^']*'|\"[^\"]*\"|[^\s=]+)",
                  el.st.text)
    if m is None:
        return None
    text = m.group(1)
    return text[1:-1] if text[:1] in "{'\"" else text


def _instance_number(el, key: str, env: Mapping[str, float]) -> float | None:
    """Instance parameter ``key`` of an M line: a number, or an expression of the
    parameters ``env`` (ngspice evaluates ``w=wn`` and ``w={wn}`` alike); None where not
    written, nan where pelcs cannot evaluate it (a function it does not know, ``agauss``)."""
    from .expressions import ExpressionError, parse_expression

    text = _instance_text(el, key)
    if text is None:
        return None
    v = parse_number(text)
    if v is None:
        try:
            v = parse_expression(text).evaluate({k.lower(): x for k, x in env.items()})
        except ExpressionError:
            return math.nan
    return float(v) if v > 0 else math.nan


def instance_geometry(el, env: Mapping[str, float], options: Mapping[str, str]
                      ) -> tuple[float, float, float]:
    """A MOSFET line's channel width and length, m, and multiplier ``m``, as ngspice 39
    reads them: ``W=``/``L=`` times ``.options scale`` (``defw``/``defl`` where not given,
    100 µm by default, unscaled), expressions evaluated on the parameters ``env``; nan for
    one pelcs cannot evaluate (:func:`channel_limit` then gives no bound)."""
    opts = {str(k).lower(): str(v) for k, v in options.items()}

    def option(key: str, default: float) -> float:
        v = parse_number(opts[key]) if opts.get(key) not in (None, "") else None
        return float(v) if v is not None and v > 0 else default

    scale = option("scale", 1.0)
    w, length, mult = (_instance_number(el, key, env) for key in ("w", "l", "m"))
    return (option("defw", _DEFAULT_LENGTH) if w is None else w * scale,
            option("defl", _DEFAULT_LENGTH) if length is None else length * scale,
            1.0 if mult is None else mult)


def _instance_length(el, key: str, default: float) -> float:
    """``W=``/``L=`` of an M line (m), ngspice's DEFW/DEFL of 100 µm when not given."""
    v = _instance_value(el, key, default)
    return v if v is not None and v > 0 else default


def _instance_value(el, key: str, default: float) -> float | None:
    """``key=`` of an M line as a number, ``default`` when not given, None when given as
    something other than a number (a parameter expression pelcs does not evaluate here)."""
    m = re.search(rf"(?i)(?<![\w.]){key}\s*=\s*([^\s=]+)", el.st.text)
    if not m:
        return default
    v = parse_number(m.group(1))
    return float(v) if v is not None else None


def gate_rc(el, model, rg: float, cgd: float = 0.0,
            scope: tuple[Mapping[str, float], Mapping[str, str]] | None = None
            ) -> tuple[float, float, float] | None:
    """An idealised MOSFET's gate as a linear RC: (R Ω, Cgs F, Cgd F), or None (a BJT, no
    capacitance).

    At a fixed bias: for a level-1..3 model the overlap capacitances ``CGSO W m`` and ``CGDO W
    m`` (W and m the instance's, read on ``scope``'s parameters and ``.options`` as
    :func:`instance_geometry` reads them; without it W from the line, ngspice's default 100 µm
    where not a number); for a VDMOS ``CGS`` and ``CGDMAX``; plus
    ``cgd``, a macro-model's gate-drain feedback capacitor. R is the model's ``RG`` (VDMOS)
    plus ``rg``, the macro-model's resistor between its gate port and the channel's gate.
    They set the switching instants: the switch turns when the gate-source capacitor's
    voltage crosses the threshold (netlist.pwl).
    """
    if el.kind != "M":
        return None
    p = {k.lower(): float(v) for k, v in model.params.items()
         if isinstance(v, (int, float))}
    if model.type == "VDMOS":
        cgs, cgd = p.get("cgs", 0.0), cgd + p.get("cgdmax", 0.0)
        rg += p.get("rg", 0.0)
    else:
        w = _instance_length(el, "w", _DEFAULT_LENGTH)
        geometry = instance_geometry(el, *scope) if scope is not None else None
        if geometry is not None and math.isfinite(geometry[0] * geometry[2]):
            w = geometry[0] * geometry[2]  # (ngspice's overlap capacitances: W m)
        cgs, cgd = p.get("cgso", 0.0) * w, cgd + p.get("cgdo", 0.0) * w
    return (rg, cgs, cgd) if cgs + cgd > 0 else None


def series_path(elements: Sequence, terminals: Sequence[str], ports: Sequence[str]) -> list:
    """The resistors on the path from each of a junction's ``terminals`` to the port it
    reaches through resistors alone (netlist.devices.classify_macro: a diode macro-model),
    without going through the other port: those in series with it. A resistor off that
    path (in series with a capacitor across the junction, or joining the two ports) is
    not."""
    adjacent: dict[str, list] = {}
    for e in elements:
        if e.kind == "R":
            a, b = (n.lower() for n in e.nodes[:2])
            adjacent.setdefault(a, []).append((b, e))
            adjacent.setdefault(b, []).append((a, e))
    out = []
    for terminal in terminals:
        start = terminal.lower()
        came: dict[str, tuple] = {start: ()}
        queue = [start]
        while queue:
            node = queue.pop(0)
            if node in ports:
                while came[node]:  # back along the path it was reached by
                    node, e = came[node]
                    out.append(e)
                break
            for nxt, e in adjacent.get(node, ()):
                if nxt not in came:
                    came[nxt] = (node, e)
                    queue.append(nxt)
    return out


#: transistors idealised inside one subcircuit instance, past which the instance is read as a
#: transistor-level amplifier (an op-amp's 20 BJTs) in an error's hint
AMPLIFIER_TRANSISTORS = 4


def amplifier_hint(replacements: Sequence[Replacement], involved: Sequence[str]) -> str:
    """The hint of a mode with undetermined quantities where those include transistors that
    pelcs idealised, :data:`AMPLIFIER_TRANSISTORS` or more inside one subcircuit instance
    (eSim's LM741, a precision rectifier's op-amp): a linear amplifier built of transistors,
    which switches do not make; "" otherwise."""
    names = {n.lower() for n in involved}
    per: dict[str, list[str]] = {}
    for r in replacements:
        if r.element.lower() in names and "." in r.element \
                and r.device in ("NPN", "PNP", "NMOS", "PMOS", "VDMOS"):
            per.setdefault(r.element.rsplit(".", 1)[0], []).append(r.element)
    big = {inst: els for inst, els in per.items() if len(els) >= AMPLIFIER_TRANSISTORS}
    if not big:
        return ""
    insts = ", ".join(f"{inst} ({len(els)} transistors)" for inst, els in big.items())
    return (f"{insts}: a linear amplifier built of transistors (an op-amp's own circuit), "
            "which pelcs idealises into switches that amplify nothing, so its nodes are left "
            "undetermined; model the amplifier as ideal instead: an E source of high gain "
            "between its inputs, or a B source (clamped to its supplies)")


def active_at_operating_point(replacements: Sequence[Replacement],
                              unsettled: Sequence[str]) -> list[Replacement]:
    """The idealised transistors among ``unsettled``, the comparators that have no consistent
    state at the DC operating point (:func:`lcs.simulation.initial.unsettled_in_note`): each
    on/off state's operating point turns them to another. A real transistor there settles
    between on and off, conducting part of its current at a control voltage near its
    threshold: in its active region, as the transistors of an amplifier, a follower, a
    current source or a linear regulator are biased (a common-gate stage's MOSFET: ngspice's
    operating point has it in saturation); or off, its emitter held only by leakage where the
    switches' off state leaves it floating (a class-B output pair). An ideal switch has
    neither."""
    names = {n.lower() for n in unsettled}
    return [r for r in replacements
            if r.element.lower() in names and r.device in DEVICE_TYPES]


def active_message(active: Sequence[Replacement]) -> tuple[str, str]:
    """The error and its hint for transistors that :func:`active_at_operating_point` found."""
    names = ", ".join(r.element for r in active)
    one = len(active) == 1
    message = (f"no DC operating point with {names} as {'a switch' if one else 'switches'}: "
               f"each on/off state's operating point turns {'it' if one else 'them'} to "
               "another, where a real transistor settles between on and off (its active "
               "region, as an amplifier's, a follower's or a current source's transistors are "
               "biased) or off with a node held only by its leakage; the run would start "
               "from the initial conditions (zero where none is given), not from the "
               "circuit's operating point, and follow switches where the circuit amplifies")
    hint = ("pelcs simulates transistors that switch fully on or off; model an amplifier "
            "stage as a controlled source (E, G or a B source clamped to its supplies). If "
            "the transistors do switch once the run starts (a converter that regulates at "
            "DC), add UIC to the .tran line to start from the initial conditions instead")
    return message, hint


#: the share of a run an idealised transistor slides on its threshold past which it is read
#: as biased in its active region: a switching edge's Miller plateau, partly on for tens of
#: ns (ngspice's dcdc.sp with its Cgd, 16 ns in 0.2 ms), stays far below it; an LC
#: oscillator's transistor (15 % of the run) or an amplifier's at its bias (28 %) do not
ACTIVE_SHARE = 0.1


def sliding_message(slid: Sequence[tuple[Replacement, float, float]]) -> tuple[str, str]:
    """The error and its hint for idealised transistors that slid: (replacement, the start
    of its first sliding interval, its time sliding in all), s."""
    r, start, total = slid[0]
    others = "".join(f", {o.element} too" for o, _, _ in slid[1:])
    message = (f"{r.element} slid on its threshold from t = {start:.4g} s ({total:.3g} s of the "
               f"run in all{others}): the idealised transistor held with its control at "
               f"{r.threshold:g} V, partly on, carrying the current the circuit sets, is a "
               "transistor in its active region (an amplifier's, an oscillator's or a linear "
               "regulator's), which the switch model does not describe: the waveforms are not "
               "the circuit's")
    hint = ("pelcs simulates transistors that switch fully on or off; model an amplifying "
            "stage as a controlled source (E, G or a B source clamped to its supplies)")
    return message, hint


def refuse_active_transistors(replacements: Sequence[Replacement], notes: Sequence[str],
                              file: str = "", sliding: Sequence[tuple] = (),
                              t_end: float = 0.0) -> None:
    """Refuse (NetlistError, at the first one's line) a run in which idealised transistors
    among ``replacements`` left the switch model: ``notes`` (those of a run from the DC
    operating point) say that they have no consistent state there
    (:func:`active_at_operating_point`), or they slid (``sliding``: the run's intervals,
    (switch, start s, end s or None: still sliding at ``t_end``, s)), held at their threshold
    partly on for more than :data:`ACTIVE_SHARE` of the run. Either is a
    transistor in its active region, and the run is not the circuit's."""
    from lcs.simulation.initial import unsettled_in_note  # (the run's module: loaded by then)

    active = active_at_operating_point(replacements, unsettled_in_note(list(notes)))
    if active:
        message, hint = active_message(active)
        raise NetlistError(Diagnostic(message=message, hint=hint, location=active[0].location,
                                      elements=tuple(r.element for r in active)), file=file)
    by_name = {r.element.lower(): r for r in replacements if r.device in DEVICE_TYPES}
    slid: dict[str, list] = {}
    for switch, t0, t1 in sliding:
        r = by_name.get(str(switch).lower())
        if r is not None:
            entry = slid.setdefault(r.element, [r, t0, 0.0])
            entry[2] += (t1 if t1 is not None else max(t_end, t0)) - t0
    slid = {k: v for k, v in slid.items() if v[2] > ACTIVE_SHARE * t_end}
    if slid:
        found = [tuple(v) for v in slid.values()]
        message, hint = sliding_message(found)
        raise NetlistError(Diagnostic(message=message, hint=hint, location=found[0][0].location,
                                      elements=tuple(slid)), file=file)
