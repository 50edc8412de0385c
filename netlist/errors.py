"""Input errors: one exception type that carries every problem found in a netlist.

A `NetlistError` holds one or more `Diagnostic` values. Each diagnostic names the file, line
and column, gives a one-line message, the offending source line with a caret under the column,
and a hint that says what to do. Problems that belong to no single line (no ground node, a loop
of voltage sources, a degenerate topology) carry the names of the elements involved instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Location:
    """A place in a netlist file.

    Parameters
    ----------
    file : str
        Path of the file as the user gave it (or ``"<string>"``).
    line, column : int
        1-based line and column.
    text : str
        The whole source line, for the caret display.
    """

    file: str
    line: int
    column: int = 1
    text: str = ""


@dataclass(frozen=True)
class Diagnostic:
    """One problem in a netlist."""

    message: str
    location: Location | None = None
    hint: str = ""
    elements: tuple[str, ...] = field(default_factory=tuple)

    def format(self, default_file: str = "<netlist>") -> str:
        """gcc-style text: ``FILE:LINE:COL: error: message``, source line, caret, hint."""
        loc = self.location
        if loc is not None:
            head = f"{loc.file}:{loc.line}:{loc.column}: error: {self.message}"
        else:
            head = f"{default_file}: error: {self.message}"
        lines = [head]
        if loc is not None and loc.text:
            src = loc.text.rstrip("\n").expandtabs(1)
            lines.append(f"    {src}")
            lines.append("    " + " " * max(loc.column - 1, 0) + "^")
        if self.elements:
            lines.append(f"  elements involved: {', '.join(self.elements)}")
        if self.hint:
            lines.append(f"  hint: {self.hint}")
        return "\n".join(lines)


class NetlistError(Exception):
    """Every input error of pelcs: bad syntax, unknown names, impossible circuits.

    Attributes
    ----------
    diagnostics : list of Diagnostic
        All independent problems found, in file order.
    """

    def __init__(self, diagnostics: list[Diagnostic] | Diagnostic, file: str | None = None):
        if isinstance(diagnostics, Diagnostic):
            diagnostics = [diagnostics]
        self.diagnostics = list(diagnostics)
        self.file = file
        super().__init__(self.format())

    # The first diagnostic's location, for callers that want one place.
    @property
    def location(self) -> Location | None:
        return self.diagnostics[0].location if self.diagnostics else None

    @property
    def message(self) -> str:
        return self.diagnostics[0].message if self.diagnostics else ""

    def format(self) -> str:
        default = self.file or "<netlist>"
        return "\n".join(d.format(default) for d in self.diagnostics)


def ordered_diagnostics(diags: list[Diagnostic], files: list[str]) -> list[Diagnostic]:
    """Drop repeats (one definition used by many instances) and sort in file order."""
    seen = set()
    unique = []
    for d in diags:
        loc = d.location
        key = (d.message, loc.file, loc.line, loc.column) if loc else (d.message, d.elements)
        if key not in seen:
            seen.add(key)
            unique.append(d)
    order = {f: i for i, f in enumerate(files)}

    def sort_key(item: tuple[int, Diagnostic]) -> tuple:
        i, d = item
        loc = d.location
        if loc is None:
            return (1, 0, 0, 0, i)
        return (0, order.get(loc.file, len(order)), loc.line, loc.column, i)

    return [d for _, d in sorted(enumerate(unique), key=sort_key)]
