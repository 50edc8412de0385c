"""The flattened circuit: typed elements, models, analysis and initial conditions.

This is what the parser produces and what the formulation and the writer consume. Names:

- element names keep the user's spelling (``Vin``, ``L1``); subcircuit instances give
  hierarchical names ``X1.L1`` (instance path, then the element's own name); lookups are
  case-insensitive (:meth:`Circuit.element`);
- node names are lower case; ground is ``"0"`` (``gnd`` is mapped to it); nodes inside a
  subcircuit instance are ``x1.n3``.

Units are SI throughout (ohm, henry, farad, volt, ampere, second).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar

from lcs.signals import Signal

from .errors import Location
from .time_function import TimeValue

GROUND = "0"


@dataclass
class Element:
    """Base of all elements. ``nodes`` are the terminals, positive first. ``built_for``: the
    name of the netlist line pelcs built this element for, one of a group of elements that
    stands for that line (:class:`BuiltGroup`, :meth:`Circuit.built_group`), else ""."""

    name: str
    nodes: tuple[str, ...]
    location: Location | None = field(default=None, compare=False, repr=False)
    # (keyword-only: it follows every subclass's own fields in the constructor)
    built_for: str = field(default="", compare=False, kw_only=True)
    # The lower-case name, the key of lookups (an attribute, not a property: the formulation
    # reads it about 5,000 times a mode on a 64-cell MMC arm).
    key: str = field(init=False, compare=False, repr=False)

    kind: ClassVar[str] = "?"

    def __post_init__(self) -> None:
        self.key = self.name.lower()


@dataclass
class Resistor(Element):
    """A resistor; ``value`` in Ω. ``time_value``: the value as a piecewise-constant
    function of time (:class:`netlist.time_value.TimeValue`) of the time-stepped resistor
    whose group this element leads (it keeps the resistor's name), ``value`` its least;
    else None."""

    value: float = 0.0
    time_value: TimeValue | None = field(default=None, compare=False)
    kind: ClassVar[str] = "R"


@dataclass
class Inductor(Element):
    """An inductor; ``value`` in H, ``ic`` its initial current in A (``IC=``, else None)."""

    value: float = 0.0
    ic: float | None = None
    kind: ClassVar[str] = "L"


@dataclass
class Capacitor(Element):
    """A capacitor; ``value`` in F, ``ic`` its initial voltage in V (``IC=``, else None)."""

    value: float = 0.0
    ic: float | None = None
    kind: ClassVar[str] = "C"


@dataclass
class VoltageSource(Element):
    """Independent voltage source, v(n+) - v(n-) = value. ``waveform`` None means DC."""

    dc: float = 0.0
    waveform: Signal | None = None
    kind: ClassVar[str] = "V"


@dataclass
class CurrentSource(Element):
    """Independent current source; the current flows from n+ through the source to n-."""

    dc: float = 0.0
    waveform: Signal | None = None
    kind: ClassVar[str] = "I"


@dataclass
class Diode(Element):
    """Ideal diode, nodes (anode, cathode). ``model`` is kept for ngspice and for the
    ``--devices pwl`` fit, with ``area`` (the D line's AREA times its m: the junction's IS
    and 1/RS scale with it, as in ngspice). ``body_of``: the idealised transistor whose body
    diode this is (ngspice simulates the transistor's own), else ""."""

    model: str = ""
    area: float = 1.0
    body_of: str = field(default="", compare=False)
    # a diode of pelcs's own construction (a B source's limiter, netlist.limiter): ideal
    # whatever --devices says, never fitted
    ideal: bool = field(default=False, compare=False)
    # a diode macro-model instance: ("X", its nodes, the subcircuit), written back for ngspice
    device: tuple | None = field(default=None, compare=False)
    kind: ClassVar[str] = "D"


@dataclass
class Switch(Element):
    """Ideal switch between nodes (n+, n-), on while v(nc+) - v(nc-) > VT (+/- VH band)."""

    control: tuple[str, str] = ("0", "0")
    model: str = ""
    initial: bool | None = None  # ON (True) / OFF (False) as written on the S line, else None
    # an idealised transistor: (letter, all its nodes, its model), written back for ngspice
    device: tuple | None = field(default=None, compare=False)
    # an idealised MOSFET's gate as a linear RC: (resistance inside the device between its
    # gate terminal and the channel's gate, Ω; gate-source and gate-drain capacitances, F),
    # for --devices pwl
    gate_rc: tuple[float, float, float] | None = field(default=None, compare=False)
    # its gate-drain capacitance as a function of the gate-drain voltage, where its model
    # has one (netlist.gate_charge.GateDrainLaw): a pwl run takes its chord over the swing
    cgd_law: object = field(default=None, compare=False)
    # on only while the control exceeds VT, off at VT itself: a switch a comparator B source
    # drives through a strict comparison (netlist.behavioural)
    strict: bool = False
    kind: ClassVar[str] = "S"


@dataclass
class Vcvs(Element):
    """E: v(n+, n-) = gain * v(nc+, nc-)."""

    control: tuple[str, str] = ("0", "0")
    gain: float = 0.0
    kind: ClassVar[str] = "E"


@dataclass
class Cccs(Element):
    """F: current gain * i(Vctrl), flowing from n+ through the source to n-."""

    source: str = ""
    gain: float = 0.0
    kind: ClassVar[str] = "F"


@dataclass
class Vccs(Element):
    """G: current gain * v(nc+, nc-), flowing from n+ through the source to n-."""

    control: tuple[str, str] = ("0", "0")
    gain: float = 0.0
    kind: ClassVar[str] = "G"


@dataclass
class Ccvs(Element):
    """H: v(n+, n-) = gain * i(Vctrl)."""

    source: str = ""
    gain: float = 0.0
    kind: ClassVar[str] = "H"


@dataclass
class Coupling(Element):
    """K: mutual coupling k between two inductors (``nodes`` is empty)."""

    inductors: tuple[str, str] = ("", "")
    k: float = 0.0
    kind: ClassVar[str] = "K"


@dataclass
class Model:
    """A ``.model NAME TYPE(params)`` line. ``type`` is ``"D"`` or ``"SW"``; params lower-case."""

    name: str
    type: str
    params: dict[str, float] = field(default_factory=dict)
    location: Location | None = field(default=None, compare=False, repr=False)


@dataclass
class Tran:
    """``.tran TSTEP TSTOP [TSTART [TMAX]] [UIC]`` (seconds)."""

    tstep: float
    tstop: float
    tstart: float = 0.0
    tmax: float | None = None
    uic: bool = False
    # TSTEP written 0 (LTspice's .tran 0 TSTOP): tstep is then TSTOP/1000, a print interval
    # only, and the step follows the sources (netlist.studies.timestep.tran_step). How this
    # run chooses its step, not part of the circuit: the written deck gives ngspice the
    # TSTEP it needs (it refuses 0), so a deck read back bounds its step by that TSTEP
    no_tstep: bool = field(default=False, compare=False)


@dataclass
class IgnoredCommand:
    """A dot command or block that pelcs accepts but does not act on."""

    text: str
    location: Location | None = field(default=None, compare=False)


#: :attr:`BuiltGroup.construct` of a clamping B source's limiter (:mod:`netlist.limiter`)
LIMITER = "limiter"
#: :attr:`BuiltGroup.construct` of a resistor stepped in time (:mod:`netlist.time_value`)
TIME_STEPPED_RESISTOR = "time-stepped resistor"


@dataclass(frozen=True)
class BuiltGroup:
    """A netlist line pelcs simulates as a group of elements it built, each of which names
    the line in :attr:`Element.built_for`.

    Attributes
    ----------
    name : str
        The line's element name (``B1``, ``R4``, ``X1.B1``): its elements' ``built_for``.
    construct : str
        What pelcs built: :data:`LIMITER`, :data:`TIME_STEPPED_RESISTOR`, ...
    line : str
        The line ngspice is given in the group's place (:func:`netlist.writer.write_circuit`
        writes it at the group's first element, and none of its elements); several lines
        where the group stands for several (an ideal transformer: its windings and K lines).
    currents : tuple of (str, str)
        ``(netlist element, built element)``: a netlist element the group replaced whose
        current a built element carries, so that ``i(netlist element)`` probes it as in
        ngspice (:meth:`Circuit.current_carrier`).
    replaces : tuple of str
        Elements of the netlist pelcs kept but changed for the group, whose own lines are
        in :attr:`line` (the switches a sigmoid comparator drives, rewired onto its
        comparison: :mod:`netlist.sigmoid`): the writer writes the line in their place.
    """

    name: str
    construct: str
    line: str
    currents: tuple[tuple[str, str], ...] = ()
    replaces: tuple[str, ...] = ()


@dataclass
class Circuit:
    """A flattened circuit: no subcircuits, all parameters evaluated."""

    title: str = ""
    elements: list[Element] = field(default_factory=list)
    models: dict[str, Model] = field(default_factory=dict)  # key: lower-case model name
    initial_conditions: dict[str, float] = field(default_factory=dict)  # node -> V (.ic)
    tran: Tran | None = None
    options: dict[str, str] = field(default_factory=dict)
    params: dict[str, float] = field(default_factory=dict)  # global .param values
    ignored: list[IgnoredCommand] = field(default_factory=list)
    # transistors idealised as switches (netlist.devices.Replacement), in netlist order
    replacements: list = field(default_factory=list)
    # what reading the netlist changed (LTspice parasitics made explicit, libraries skipped)
    notes: list = field(default_factory=list, compare=False)
    # macro-model subcircuits replaced by ideal elements: name -> definition text (ngspice)
    subckt_texts: dict = field(default_factory=dict, compare=False)
    # the element lines pelcs simulates as groups of elements it built (a clamping B source,
    # a resistor stepped in time): lower-case name -> BuiltGroup
    built_groups: dict[str, BuiltGroup] = field(default_factory=dict, compare=False)
    # capacitors in a loop with voltage sources, reduced to one state each
    # (netlist.capacitor_loops): lower-case name -> (name, its nodes, the capacitor for them)
    loop_capacitors: dict = field(default_factory=dict, compare=False)
    # quantities a run must keep on the linear side of a knee, checked after it besides the
    # output nodes of comparator B sources mapped onto the switches they drive, gone from the
    # circuit (netlist.behavioural): lower-case node -> (comparator name, switch names)
    gone_nodes: dict = field(default_factory=dict, compare=False)
    # knee capacitors (netlist.knee): a magnetic core's field (netlist.magnetic_core)
    knees: list = field(default_factory=list, compare=False)
    # .step param lines: (parameter, values), one sweep axis each (run by pelcs sweep)
    steps: list[tuple[str, tuple[float, ...]]] = field(default_factory=list)
    file: str = "<string>"
    # the files read, the top one first, then each .include/.lib (as reached from the cwd)
    files: tuple[str, ...] = field(default=(), compare=False)

    def element(self, name: str) -> Element:
        """The element of that name (case-insensitive); KeyError if absent."""
        key = name.lower()
        for el in self.elements:
            if el.key == key:
                return el
        raise KeyError(name)

    def of_kind(self, kind: str) -> list[Element]:
        return [el for el in self.elements if el.kind == kind]

    def built_group(self, el: Element) -> BuiltGroup | None:
        """The group of elements pelcs built that ``el`` belongs to, None for an element of
        the netlist's own."""
        return self.built_groups[el.built_for.lower()] if el.built_for else None

    def located(self, names: Sequence[str]) -> tuple[Element | None, str]:
        """Where an error about the elements ``names`` points: the first of them whose line is
        known (None if none is), and "; " and a note naming the line pelcs built each of them
        for (``L1_m``: ``K12``), which the netlist does not write ("" if there is none)."""
        els = [el for n in names for el in self.elements if el.key == n.lower()]
        first = next((el for el in els if el.location is not None), None)
        built = [f"{el.name} is part of what pelcs built for {el.built_for} ("
                 f"{self.built_groups[el.built_for.lower()].construct})"
                 for el in els if el.built_for and el.built_for.lower() in self.built_groups]
        return first, "".join(f"; {b}" for b in built)

    def current_carrier(self, name: str) -> str | None:
        """The element pelcs built to carry the current of the netlist's element ``name``
        (case-insensitive) that a built group replaced (:attr:`BuiltGroup.currents`), None
        if there is none."""
        key = name.lower()
        for group in self.built_groups.values():
            for original, carrier in group.currents:
                if original.lower() == key:
                    return carrier
        return None

    def add_built_group(self, group: BuiltGroup, elements: Sequence[Element]) -> None:
        """Record ``group``, the elements pelcs built for one netlist line: each of
        ``elements`` gets its name in ``built_for``."""
        for el in elements:
            el.built_for = group.name
        self.built_groups[group.name.lower()] = group

    @property
    def nodes(self) -> list[str]:
        """All node names, ground first, then in order of appearance."""
        seen: dict[str, None] = {GROUND: None}
        for el in self.elements:
            for n in el.nodes:
                seen.setdefault(n, None)
            for n in getattr(el, "control", ()):
                seen.setdefault(n, None)
        return list(seen)


def unique_name(name: str, used: set[str]) -> str:
    """``name``, with ``_`` appended until its lower-case form is not in ``used`` (element or
    node names of a circuit, lower case), which it is added to: the name of an element or
    node pelcs adds to a circuit."""
    while name.lower() in used:
        name += "_"
    used.add(name.lower())
    return name


def substituted(elements: Sequence[Element], new: Mapping[str, Sequence[Element]],
                gone: Collection[str]) -> list[Element]:
    """``elements`` with each whose key is in ``new`` replaced, where it stands, by the
    elements ``new`` gives for it, and those whose key is in ``gone`` left out: the element
    list of a circuit a reduction rewrote."""
    out: list[Element] = []
    for el in elements:
        if el.key in new:
            out.extend(new[el.key])
        elif el.key not in gone:
            out.append(el)
    return out
