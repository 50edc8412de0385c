"""ngspice's XSPICE magnetic core (``core``) and its windings (``lcouple``), read exactly as
coupled inductors while the core stays on one straight segment of its B-H curve.

eSim's transformer writes a winding per ``lcouple`` and one ``core``, their mmf ports in a
loop of their own::

    a1 (in gnd) (m1 gnd) primary      .model primary lcouple(num_turns=310)
    a2 (out gnd) (m2 gnd) secondary   .model secondary lcouple(num_turns=620)
    a3 (m1 m2) iron                   .model iron core(H_array=[...] B_array=[...] area=1
                                                      length=0.01)

ngspice's semantics (``src/xspice/icm/xtradev/{lcouple,core}/cfunc.mod``): a winding of ``N``
turns drives its mmf port to ``N i`` (``i`` its current, from + to - through it) and has the
voltage ``N dΦ/dt``, ``Φ`` (Wb) the current of its mmf port from - to +; the core of length
``l`` (m) and area ``A`` (m²) passes the flux ``Φ = A B(H)`` from + to - through its port,
``H = mmf/l`` (A/m) its port's voltage over its length and ``B`` (T) the piecewise-linear
table, its outer segments extended, its corners rounded within ``input_domain`` of each
breakpoint (by default a fraction, 0.01, of the shorter adjacent segment).

The same flux passes through every port of one loop; ground may join the ports of several
loops (eSim writes each mmf port to ground), each loop's flux passing from its own port into
ground to its own port out of it (KCL at every other node). With ``Φ`` through the core from
+ to -, a winding whose port the loop passes from - to + has the sign ``s = +1``, otherwise
``-1``, times the sign of ``N`` (ngspice's mmf ``N i`` and voltage ``N dΦ/dt`` both turn
with it): ``v_k = s_k |N_k| dΦ/dt``, and the core's mmf is ``sum_k s_k |N_k| i_k``; a
winding of no turns is a short no flux links. On a straight segment of slope
``μ = dB/dH`` (H/m), ``Φ = Φ0 + A μ sum_k s_k |N_k| i_k / l``, so

    v_k = sum_j L_kj di_j/dt,   L_kj = s_k s_j |N_k N_j| μ A / l,

the inductances ``L_k = N_k² μ A / l`` coupled without leakage (``k = s_k s_j``): an ideal
transformer and its magnetizing inductance (:func:`netlist.perfect_coupling.build_transformer`),
exact. pelcs takes the segment around ``H = 0`` (the core demagnetised; collinear
neighbouring segments are one) and checks after the run that ``H`` stayed on it, clear of the
rounded corners at its ends (:mod:`netlist.knee`): a run that leaves it is an error naming the
instant (saturation is nonlinear; pelcs does not simulate it). ngspice's winding voltage is a
backward difference of the flux whatever its integration method, an error of the order of
its step. The hysteresis mode (``mode=2``) and magnetic circuits other than one loop of one
core and its windings are refused. A deck written for ngspice gets A and ``.model`` lines.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from .circuit import GROUND, Circuit, Element, Inductor, substituted
from .errors import Diagnostic
from .perfect_coupling import build_transformer
from .writer import spice_name

__all__ = ["MAGNETIC_CORE", "CoreField", "MagneticCore", "Winding", "resolve_cores"]

#: :attr:`netlist.circuit.BuiltGroup.construct` of a core and its windings
MAGNETIC_CORE = "XSPICE magnetic core"

_FORM = ("pelcs reads one XSPICE core (mode=1, the B-H table) whose mmf port is in one loop "
         "with the mmf ports of its lcouple windings and nothing else, as coupled inductors "
         "on the table's segment around H = 0")
_LINEAR = ("pelcs reads the core as linear on the straight segment of its table around "
           "H = 0 (of positive slope): give the table such a segment")
# slopes this close (relative) are one straight segment
_COLLINEAR = 1e-9


@dataclass
class Winding(Inductor):
    """An ``lcouple`` winding (its electrical port ``nodes``), before its core gives it an
    inductance: ``mmf`` its mmf port (+, -), ``turns`` its number of turns."""

    mmf: tuple[str, str] = (GROUND, GROUND)
    turns: float = 1.0


@dataclass
class MagneticCore(Element):
    """A ``core`` in its piecewise-linear mode: ``nodes`` its mmf port (+, -), ``h`` (A/m)
    and ``b`` (T) its table, ``area`` (m²), ``length`` (m), ``input_domain`` (A/m, or a
    fraction of the shorter adjacent segment if ``fraction``)."""

    h: tuple[float, ...] = ()
    b: tuple[float, ...] = ()
    area: float = 1.0
    length: float = 1.0
    input_domain: float = 0.01
    fraction: bool = True
    kind: ClassVar[str] = "A"


@dataclass
class CoreField:
    """The field ``H = scale * i(magnetizing)`` (A/m) of a core read as linear on
    ``lo < H < hi``: a knee of :func:`netlist.knee.check_knees`."""

    name: str
    magnetizing: str
    scale: float
    lo: float
    hi: float
    slope: float
    location: object = field(default=None, repr=False)

    @property
    def probes(self) -> tuple[str, ...]:
        return (f"i({self.magnetizing})",)

    def quantity(self, columns: Sequence[np.ndarray]) -> np.ndarray:
        return self.scale * columns[0]

    def inside(self, h: np.ndarray) -> np.ndarray:
        return (h > self.lo) & (h < self.hi)

    @property
    def region(self) -> str:
        if math.isinf(self.lo) and math.isinf(self.hi):
            return "H takes any value (the table is one straight line)"
        if math.isinf(self.lo):
            return f"H < {self.hi:g} A/m"
        if math.isinf(self.hi):
            return f"H > {self.lo:g} A/m"
        return f"{self.lo:g} < H < {self.hi:g} A/m"

    def outside(self, h: float, t: float) -> Diagnostic:
        return Diagnostic(
            f"core '{self.name}' is linear (dB/dH {self.slope:.6g} H/m) only while "
            f"{self.region}, the straight part of its B-H table around H = 0; the run took "
            f"its field to {h:.4g} A/m at t = {t:.6g} s, where B bends (saturation, "
            "nonlinear)", self.location,
            "pelcs simulates a core on that segment only; shorten the run, lower the "
            "windings' volt-seconds or currents, or give the table a straight segment over "
            "the field the circuit reaches", (self.name,))

    def stayed(self, lo: float, hi: float) -> str:
        return (f"{self.name}: core read as linear, dB/dH {self.slope:.6g} H/m while "
                f"{self.region}: the run stayed there ({lo:.4g} to {hi:.4g} A/m)")


def _segment(core: MagneticCore) -> tuple[float, float, float, float] | tuple[str, str]:
    """``(slope, lo, hi, b0)``: the straight part of the core's B(H) around H = 0, ``b0``
    (T) its line's B at H = 0, or what is wrong with the table and what to do."""
    h, b = core.h, core.b
    if len(h) != len(b) or len(h) < 2:
        return (f"H_array and B_array need the same number of values, two at least "
                f"({len(h)} and {len(b)})", "give one B value (T) per H value (A/m)")
    if any(not h[i + 1] > h[i] for i in range(len(h) - 1)):
        return ("H_array is not increasing", "write the table's H values (A/m) in "
                "increasing order, each B value (T) in its place")
    if not core.input_domain >= 0:
        # (ngspice takes it, unchecked: its rounding turns into a jump of B past each
        # breakpoint, which the segment's ends here do not follow)
        return (f"input_domain {core.input_domain:g} is negative", "give input_domain, "
                "the half-width of the rounding of the table's corners, at least 0 "
                "(ngspice's range: 1e-12 to 0.5)")
    if not core.fraction:
        # ngspice's core then passes no flux at all ("Violation of 50% rule in breakpoints"
        # at every step, its windings shorts): no inductance is its answer
        short = next((i for i in range(len(h) - 1)
                      if h[i + 1] - h[i] < 2.0 * core.input_domain), None)
        if short is not None:
            return (f"its segment from H = {h[short]:g} to {h[short + 1]:g} A/m is shorter "
                    f"than twice input_domain ({core.input_domain:g} A/m, absolute as "
                    "fraction=FALSE): ngspice's core refuses such a table (its '50% rule') "
                    "and passes no flux",
                    "give input_domain (A/m) at most half the shortest segment, or "
                    "fraction=TRUE (input_domain then a fraction of the segments)")
    slopes = [(b[i + 1] - b[i]) / (h[i + 1] - h[i]) for i in range(len(h) - 1)]
    n = len(h)

    def domain(i: int) -> float:  # the rounding half-width at interior breakpoint i
        if not core.fraction:
            return core.input_domain
        return core.input_domain * min(h[i] - h[i - 1], h[i + 1] - h[i])

    def collinear(i: int, j: int) -> bool:
        return abs(slopes[i] - slopes[j]) <= _COLLINEAR * max(abs(slopes[i]), abs(slopes[j]))

    j = 0
    while j < n - 2 and h[j + 1] <= 0.0:
        j += 1
    first = last = j
    while first > 0 and collinear(first - 1, j):
        first -= 1
    while last < n - 2 and collinear(last + 1, j):
        last += 1
    lo = h[first] + domain(first) if first > 0 else -math.inf
    hi = h[last + 1] - domain(last + 1) if last + 1 < n - 1 else math.inf
    if not lo < 0.0 < hi:
        return (f"H = 0 is at a corner of the B-H table (within its rounding, "
                f"{lo:g} .. {hi:g} A/m)", _LINEAR)
    if not slopes[j] > 0:
        return (f"the B-H table's slope around H = 0 is {slopes[j]:g}, not positive",
                _LINEAR)
    return slopes[j], lo, hi, b[j] - slopes[j] * h[j]


def resolve_cores(circuit: Circuit, earlier_problems: bool = False) -> list[Diagnostic]:
    """Replace each core and its windings in ``circuit`` (in place) by their coupled
    inductors (the module docstring), a note for each; the problems found (a winding
    without a core is not one of them after ``earlier_problems``: its core's line may be
    the one refused)."""
    cores = [el for el in circuit.elements if isinstance(el, MagneticCore)]
    windings = [el for el in circuit.elements if isinstance(el, Winding)]
    if not cores and not windings:
        return []
    diags: list[Diagnostic] = []
    ports: list[Element] = [*cores, *windings]

    def mmf(el: Element) -> tuple[str, str]:
        return el.mmf if isinstance(el, Winding) else (el.nodes[0], el.nodes[1])

    at: dict[str, list[Element]] = {}
    for el in ports:
        for n in set(mmf(el)):
            at.setdefault(n, []).append(el)
    electrical = {n for el in circuit.elements if not isinstance(el, MagneticCore)
                  for n in el.nodes}
    for n, els in at.items():
        if n != GROUND and n in electrical:
            other = next(el for el in circuit.elements
                         if not isinstance(el, MagneticCore) and n in el.nodes)
            diags.append(Diagnostic(
                f"{els[0].name}: its mmf port's node '{n}' is also a node of '{other.name}'",
                els[0].location, _FORM, (els[0].name,)))
    new: dict[str, list[Element]] = {}
    gone = {el.key for el in ports}
    used = {el.key for el in circuit.elements}
    nodes = {n.lower() for el in circuit.elements for n in el.nodes}
    placed: set[str] = set()
    for core in cores:
        loop, problem = _loop(core, at, mmf)
        if problem:
            diags.append(Diagnostic(f"core '{core.name}': {problem}", core.location, _FORM,
                                    (core.name,)))
            continue
        order = {el.key: i for i, el in enumerate(circuit.elements)}
        loop.sort(key=lambda ws: order[ws[0].key])
        # (a winding of no turns is a short no flux links: the others' reference is one
        # with turns)
        loop.sort(key=lambda ws: ws[0].turns == 0)
        if loop[0][0].turns == 0:
            diags.append(Diagnostic(
                f"core '{core.name}': no winding in its loop has turns (num_turns 0)",
                core.location, "give a winding num_turns other than 0", (core.name,)))
            continue
        segment = _segment(core)
        if isinstance(segment[0], str):
            diags.append(Diagnostic(f"core '{core.name}': {segment[0]}", core.location,
                                    segment[1], (core.name,)))
            continue
        slope, lo, hi, b0 = segment
        placed.update(w.key for w, _ in loop)
        per_turn2 = slope * core.area / core.length
        coils = [Inductor(w.name, w.nodes, w.location, value=w.turns ** 2 * per_turn2,
                          ic=w.ic) for w, _ in loop]
        first, s1 = loop[0]
        # ngspice's winding differentiates the flux from its value at the previous step,
        # zero before the first when the run starts from the initial conditions (UIC): the
        # core starts at B = 0, H = -b0/mu, not at H = 0 (an operating point sets both)
        start = ""
        if b0 != 0.0 and (circuit.tran is None or circuit.tran.uic):
            h0 = -b0 / slope
            coils[0].ic = h0 * core.length / (s1 * first.turns)
            start = (f"; from the initial conditions it starts at B = 0, H = {h0:.6g} A/m "
                     f"(ngspice's winding starts from zero flux; B is {b0:g} T at H = 0): "
                     f"i({{lm}}) = {coils[0].ic:.6g} A")
        # a winding's sense: the loop's way through its port, reversed by negative turns
        # (ngspice's mmf N i and voltage N dPhi/dt both change sign with N)
        senses = [s * math.copysign(1.0, w.turns) for w, s in loop]
        signs = [s * senses[0] for s in senses]
        lm, _, _ = build_transformer(circuit, coils, signs, core.name, MAGNETIC_CORE,
                                     core.location, _lines(core, [w for w, _ in loop]),
                                     used, nodes, new)
        # H = sum s_k N_k i_k / l = s1 N1 i(lm) / l
        circuit.knees.append(CoreField(core.name, lm, s1 * first.turns / core.length, lo, hi,
                                       slope, core.location))
        circuit.notes.append(
            f"{core.name}: XSPICE core read as linear, dB/dH {slope:.6g} H/m (the straight "
            f"part of its B-H table around H = 0, checked after a transient run and over an "
            f"orbit, a bifurcation and a continuation: not by basins or ac), its windings "
            + ", ".join(f"{w.name} ({w.turns:g} turns, {c.value:.6g} H, "
                        f"{'same' if g > 0 else 'opposite'} sense)"
                        for (w, _), c, g in zip(loop, coils, signs, strict=True))
            + f" coupled without leakage: an ideal transformer with {first.name}'s "
            f"inductance, {lm}, across it; i({lm}) times {s1 * first.turns:g}/"
            f"{core.length:g} m is the field H" + start.replace("{lm}", lm))
    for w in windings:
        if w.key not in placed and not diags and not earlier_problems:
            diags.append(Diagnostic(f"lcouple winding '{w.name}' is in no loop with a core",
                                    w.location, _FORM, (w.name,)))
    if not diags:
        circuit.elements[:] = substituted(circuit.elements, new, gone)
    return diags


def _loop(core: MagneticCore, at: dict[str, list[Element]], mmf
          ) -> tuple[list[tuple[Winding, float]], str]:
    """The windings in the core's mmf loop with their signs (the module docstring), in loop
    order from the core's - node, or what keeps the loop from being one.

    Every magnetic node but ground joins two ports. Ground may join the ports of several
    loops (eSim's windings and cores put one node of each mmf port there): the flux of a
    loop through ground passes from its path out of the core's - node to its path into the
    core's + node, ground's other ports being other loops' (KCL holds at every other node of
    each path)."""
    start, end = core.nodes[0], core.nodes[1]
    if start == end:
        return [], "its mmf port's two nodes are one"

    def walk(node: str, forward: bool) -> tuple[list[tuple[Winding, float]], bool, str]:
        # the windings from the core's node `node` away from the core, to ground or (True)
        # round to the core again; a winding's sign is that of the forward direction
        out: list[tuple[Winding, float]] = []
        came: Element = core
        while node != GROUND:
            els = at[node]
            if len(els) != 2:
                return [], False, (f"magnetic node '{node}' joins {len(els)} mmf ports, not "
                                   "two: the ports are not one loop")
            el = els[0] if els[1] is came else els[1]
            if el is core:
                return out, True, ""
            if isinstance(el, MagneticCore):
                return [], False, f"its loop holds another core, '{el.name}'"
            plus, minus = mmf(el)
            if plus == minus:
                return [], False, f"the mmf port of '{el.name}' has its two nodes one"
            # forward, entering at its + node is -1; backward, leaving at it
            out.append((el, (-1.0 if plus == node else 1.0) * (1.0 if forward else -1.0)))
            node, came = (minus if plus == node else plus), el
        return out, False, ""

    ahead, closed, problem = walk(end, True)
    if problem:
        return [], problem
    if not closed:  # through ground: the path into the core's + node, reversed
        behind, _, problem = walk(start, False)
        if problem:
            return [], problem
        ahead += behind[::-1]
    if not ahead:
        return [], "no winding is in its loop"
    return ahead, ""


def _lines(core: MagneticCore, windings: Sequence[Winding]) -> str:
    """The A and ``.model`` lines ngspice is given for a core and its windings."""
    def num(v: float) -> str:  # (XSPICE's own number reader: no SI suffixes)
        return f"{float(v):.15g}"

    lines = []
    for w in windings:
        model = f"pelcs_lcouple_{w.key.replace('.', '_')}"
        lines += [f"{spice_name(w.name, 'A')} ({w.nodes[0]} {w.nodes[1]}) "
                  f"({w.mmf[0]} {w.mmf[1]}) {model}",
                  f".model {model} lcouple(num_turns={num(w.turns)})"]
    model = f"pelcs_core_{core.key.replace('.', '_')}"
    lines += [f"{spice_name(core.name, 'A')} ({core.nodes[0]} {core.nodes[1]}) {model}",
              f".model {model} core(H_array=[{' '.join(map(num, core.h))}] "
              f"B_array=[{' '.join(map(num, core.b))}] area={num(core.area)} "
              f"length={num(core.length)} input_domain={num(core.input_domain)} "
              f"fraction={'TRUE' if core.fraction else 'FALSE'})"]
    return "\n".join(lines)
