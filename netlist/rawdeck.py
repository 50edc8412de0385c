"""The raw deck: what the reader (:mod:`netlist.reader`) makes of netlist text before any
evaluation. Statements keep their source location; values stay as text or parsed
expressions; subcircuits, models and parameters are as written. :mod:`netlist.flatten`
elaborates a deck into a :class:`~netlist.circuit.Circuit`."""

from __future__ import annotations

from dataclasses import dataclass, field

from .circuit import IgnoredCommand
from .errors import Location
from .expressions import Expression

__all__ = ["Body", "Deck", "RawElement", "RawIc", "RawModel", "RawParam", "RawStep", "RawTran",
           "Statement", "SubcktDef", "Value"]

# ------------------------------------------------------------------------------ statements


class Statement:
    """One logical statement: the joined text of a line and its continuation lines.

    Parameters
    ----------
    text : str
        The statement with comments removed and continuation lines joined by one space
        (the ``+`` itself becomes a space).
    file : str
        File name as shown to the user.
    segments : list of (int, int, int, str)
        For each physical line: offset of its first character in ``text``, its 1-based line
        number, the 0-based column of that character in the line, and the whole line.
    """

    __slots__ = ("text", "file", "segments", "_locs")

    def __init__(self, text: str, file: str, segments: list[tuple[int, int, int, str]]):
        self.text = text
        self.file = file
        self.segments = segments
        self._locs: dict[tuple[int, int], Location] = {}

    def loc(self, offset: int = 0) -> Location:
        """Location of the character at ``offset`` in :attr:`text` (past the end allowed)."""
        # (kept: a deck evaluated for many runs asks for the same locations each time; by
        # the segments too, which the reader extends with continuation lines)
        key = (offset, len(self.segments))
        found = self._locs.get(key)
        if found is None:
            found = self._locs[key] = self._loc(offset)
        return found

    def _loc(self, offset: int) -> Location:
        segs = self.segments
        i = len(segs) - 1
        while i > 0 and segs[i][0] > offset:
            i -= 1
        start, line, col0, raw = segs[i]
        return Location(self.file, line, col0 + (offset - start) + 1, raw)

    def __repr__(self) -> str:
        return f"Statement({self.text!r})"


# ------------------------------------------------------------------------------ the deck


@dataclass(slots=True, eq=False)
class Value:
    """A number or an expression as written, and where.

    ``number`` is set for a literal (and for a constant expression); otherwise ``expr`` is
    evaluated during elaboration.
    """

    number: float | None
    expr: Expression | None
    st: Statement
    offset: int

    @property
    def loc(self) -> Location:
        return self.st.loc(self.offset)


@dataclass(slots=True, eq=False)
class RawParam:
    """``name=value`` in ``.param``, a ``.subckt`` header or an ``X`` line (name lower case)."""

    name: str
    value: Value
    st: Statement
    offset: int

    @property
    def loc(self) -> Location:
        return self.st.loc(self.offset)


@dataclass(slots=True, eq=False)
class RawElement:
    """An element line after syntax analysis, before evaluation and flattening.

    ``ref`` is the model (D, S), the controlling source (F, H) or the subcircuit (X); ``refs``
    are the two inductors of a K; ``behaviour`` is a B source's expression; ``wave`` is
    ``(kind, args, offset, extras)`` of a V/I transient function (``extras``: a PWL's ``r``
    and ``td``, name -> (value, offset)); ``params`` are the parameter overrides of an X.
    """

    kind: str
    name: str
    st: Statement
    nodes: tuple[str, ...]
    control: tuple[str, ...] = ()
    ref: str = ""
    ref_offset: int = 0
    value: Value | None = None
    ic: Value | None = None
    wave: tuple[str, list[Value], int, dict] | None = None
    refs: tuple[tuple[str, int], ...] = ()
    params: list[RawParam] = field(default_factory=list)
    state: bool | None = None
    # an R, L or C line's temperature parameters (TC1=, TC2=, TCE=, TEMP=, DTEMP=:
    # netlist.temperature)
    temperature: list[RawParam] = field(default_factory=list)
    # a B source: ("V" or "I", the parsed expression, its text, its offset in the statement)
    behaviour: tuple | None = None
    # what the reading of the line made of it, noted in each instance after the element's
    # name (an E/G TABLE read as a comparator: netlist.table_source)
    note: str = ""
    # an XSPICE A element: its ports (netlist.xspice.Port); ``ref`` is its model
    ports: tuple = ()


@dataclass(slots=True, eq=False)
class RawIc:
    """One node of ``.ic V(node)=value`` as written (``offset``: where the node name is)."""

    node: str
    value: Value
    st: Statement
    offset: int


@dataclass(eq=False)
class Body:
    """Statements of the top level or of one subcircuit definition, in file order."""

    elements: list[RawElement] = field(default_factory=list)
    params: list[RawParam] = field(default_factory=list)
    ics: list[RawIc] = field(default_factory=list)


@dataclass(eq=False)
class SubcktDef:
    """A ``.subckt`` definition: name, ports, default parameters and body. ``key`` is its key
    in :attr:`Deck.subckts`: its lower-case name, prefixed ``parent:`` for a definition nested
    in ``parent``'s (local to it, as in ngspice); ``parent`` is that key, else None."""

    name: str
    ports: list[str]
    defaults: list[RawParam]
    body: Body
    st: Statement
    key: str = ""
    parent: str | None = None


@dataclass(eq=False)
class RawModel:
    """A ``.model`` card as written: name, device type and parameters.

    ``scope`` is the subcircuit whose definition holds the card (lower case), None at the
    top level: ngspice makes such a model local to that subcircuit."""

    name: str
    type: str
    params: list[RawParam]
    st: Statement
    scope: str | None = None


@dataclass(eq=False)
class RawTran:
    """A ``.tran`` card as written: its values (TSTEP TSTOP [TSTART [TMAX]]) and UIC."""

    values: list[Value]
    uic: bool
    st: Statement


@dataclass
class RawStep:
    """``.step param NAME START STOP INCR`` or ``.step param NAME list V1 V2 ...``: the
    parameter and its values (evaluated in elaboration)."""

    name: str
    values: list[Value]
    linear: bool  # START STOP INCR (else a list)
    st: Statement
    name_pos: int


@dataclass(eq=False)
class Deck:
    """Everything read from a netlist and its includes, not yet evaluated or flattened."""

    file: str
    title: str = ""
    top: Body = field(default_factory=Body)
    # by SubcktDef.key: the lower-case name, a nested definition's prefixed by its parent's
    subckts: dict[str, SubcktDef] = field(default_factory=dict)
    models: list[RawModel] = field(default_factory=list)
    # XSPICE code-model cards (netlist.xspice.CodeModel) by lower-case name
    code_models: dict = field(default_factory=dict)
    trans: list[RawTran] = field(default_factory=list)
    steps: list[RawStep] = field(default_factory=list)
    options: dict[str, str] = field(default_factory=dict)
    ignored: list[IgnoredCommand] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)  # what the reader did the user should know
    globals: set[str] = field(default_factory=set)
    files: list[str] = field(default_factory=list)  # display names in reading order

    def subckt_key(self, ref: str, scope: str | None) -> str | None:
        """The definition an instance in the body of ``scope`` (a key of :attr:`subckts`;
        None at the top level) names by ``ref``: one nested in ``scope`` or in a definition
        around it, nearest first, else a top-level one; None when there is none."""
        name = ref.lower()
        while scope is not None:
            key = f"{scope}:{name}"
            if key in self.subckts:
                return key
            scope = self.subckts[scope].parent if scope in self.subckts else None
        return name if name in self.subckts else None

