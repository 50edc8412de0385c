"""E and G sources with a ``TABLE``, read as the B source they are.

``Ename n+ n- TABLE {expr} = (x1, y1) (x2, y2)`` (G alike, a current): ngspice makes it a B
source whose value is the piecewise-linear interpolation of the table at the expression's
value, held at the first and last values outside the table (its front end writes it as a B
source with ``pwl(expr, x1, y1, x2, y2)``, inpcom.c). pelcs reads a table of two points,
the form a comparator or a clamped amplifier takes:

- **steep** (a gain ``|y2 - y1| / |x2 - x1|`` of :data:`STEEP_GAIN` or more: a comparator
  written as a table, ``(-1uV, 0V) (1uV, 15V)``): the comparator ``expr > xm ? y2 : y1`` at
  the table's midpoint ``xm``, which the B source machinery reads
  (:mod:`netlist.behavioural`). The two are equal wherever ``expr`` is at least half the
  table's width from ``xm``; within that band the table's output is between ``y1`` and
  ``y2``. A note says so, with the band. (Where positive feedback drives the output, as in a
  multivibrator, the band is crossed at once and ngspice's steps through it are too short
  to change the waveform; where negative feedback holds the input in the band, the
  comparator slides, the limit of an infinite gain, and the run reports the sliding.)
- **gentle**: the clamp ``max(lo, min(hi, line))`` of the table's line, which pelcs reads in
  a control path only (:mod:`netlist.behavioural` refuses it elsewhere, saying why).

Other tables (more points, or points not in increasing x: ngspice does not read
those as the line through them) are refused with what pelcs reads.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from .units import format_eng, parse_number

__all__ = ["STEEP_GAIN", "TableError", "TableSource", "read_table"]

#: a table at least this steep (V/V, or the control's units) is read as a comparator: an
#: op-amp's open-loop gain is of this order, and the band where the two differ is then below
#: 1e-4 of the output swing in the table's input
STEEP_GAIN = 1e4

_TABLE = re.compile(r"(?is)(\S+)\s+([^\s=]+)\s+([^\s=]+)\s+table\s*(\{.*?\}|\S+)\s*=?\s*(.*)$")
_POINT = re.compile(r"\(\s*([^\s,()]+)\s*[,\s]\s*([^\s,()]+)\s*\)")


class TableError(ValueError):
    """A TABLE line pelcs cannot read: ``message``, ``offset`` into the line, ``hint``."""

    def __init__(self, message: str, offset: int, hint: str = ""):
        super().__init__(message)
        self.message, self.offset, self.hint = message, offset, hint


@dataclass(frozen=True)
class TableSource:
    """A TABLE line read: the B source's ``name``, ``nodes``, its expression ``text`` (at
    ``offset`` of the line: the table's expression), and the ``note`` of the reading (to
    follow the element's name)."""

    name: str
    nodes: tuple[str, str]
    text: str
    offset: int
    note: str


def _number(word: str, offset: int) -> float:
    try:
        return float(parse_number(word))
    except (ValueError, TypeError):
        raise TableError(f"TABLE point '{word}' is not a number", offset,
                         "pelcs reads TABLE points of numbers (with units: 1uV, 15V)") from None


def read_table(line: str, letter: str) -> TableSource | None:
    """The B source of an ``E``/``G`` line with a ``TABLE``, or None for any other line.

    Raises
    ------
    TableError
        A table of other than two points, or points that are not numbers.
    """
    m = _TABLE.match(line)
    if m is None:
        return None
    expr = m.group(4)
    if expr.startswith("{"):
        expr = expr[1:-1]
    at = m.start(4)
    points = [(_number(p.group(1), m.start(5) + p.start(1)),
               _number(p.group(2), m.start(5) + p.start(2)))
              for p in _POINT.finditer(m.group(5))]
    if len(points) != 2:
        raise TableError(f"{letter} source TABLE with {len(points)} points", m.start(5),
                         "pelcs reads a TABLE of two points (a comparator, or a line clamped "
                         "at its ends); write more as a B source of comparators")
    (x1, y1), (x2, y2) = points
    if not x1 < x2:
        # ngspice interpolates the points in the order written, x increasing: written
        # otherwise it is not the line through them (measured: (1u, 0) (-1u, 15) gives 0 V
        # at an input of -0.8 V and 15 V at +3 uV), and at one x it does not run
        raise TableError(f"{letter} source TABLE points not in increasing x ({x1:g}, then "
                         f"{x2:g})", m.start(5),
                         "ngspice reads a TABLE's points in the order written, x "
                         "increasing (otherwise not as the line through them); write them "
                         "so, e.g. (-1u, 15) (1u, 0) for an inverting comparator")
    unit = "V" if letter == "E" else "A"
    if y1 == y2:  # a constant
        text = repr(y1)
        return TableSource(m.group(1), (m.group(2), m.group(3)), text, at,
                           f"TABLE ({x1:g}, {y1:g}) ({x2:g}, {y2:g}) is the "
                           f"constant {format_eng(y1, unit)}")
    gain = (y2 - y1) / (x2 - x1) if x2 != x1 else float("inf")
    xm = (x1 + x2) / 2
    if abs(gain) >= STEEP_GAIN:
        text = f"(({expr}) > {xm!r}) ? {y2!r} : {y1!r}"
        # (the input's unit: a current where the expression reads one, else a voltage)
        into = "A" if re.search(r"(?i)\bi\s*\(", expr) else "V"
        note = (f"TABLE {{{expr.strip()}}} from {format_eng(y1, unit)} to "
                f"{format_eng(y2, unit)} over {format_eng(x2 - x1, into)} of its input (a "
                f"gain of {abs(gain):.3g}) read as the comparator {expr.strip()} > "
                f"{format_eng(xm, into)} ? {format_eng(y2, unit)} : {format_eng(y1, unit)}: "
                f"equal to the table wherever its input is {format_eng((x2 - x1) / 2, into)} "
                f"or more from {format_eng(xm, into)}; within that band the table is between "
                "the two")
        return TableSource(m.group(1), (m.group(2), m.group(3)), text, at, note)
    lo, hi = min(y1, y2), max(y1, y2)
    text = f"max({lo!r}, min({hi!r}, {y1!r} + {gain!r} * (({expr}) - {x1!r})))"
    note = (f"TABLE {{{expr.strip()}}} ({x1:g}, {y1:g}) ({x2:g}, {y2:g}) read as "
            f"the clamped line {text}")
    return TableSource(m.group(1), (m.group(2), m.group(3)), text, at, note)
