"""SPICE numbers: engineering suffixes on input, engineering notation on output.

SPICE reads ``10uF`` as 10e-6, ``1kOhm`` as 1e3, ``1Meg`` as 1e6 and ``1mil`` as 25.4e-6: the
letters after the number are a scale suffix (case-insensitive) followed by a unit that is
ignored. Beware the classic traps, which pelcs keeps for compatibility with SPICE: ``M`` is
milli (mega is ``Meg``) and ``10F`` is ten femto, not ten farads.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

from lcs.units_format import format_eng as _format_eng

if TYPE_CHECKING:
    from decimal import Decimal

# Scale suffixes as powers of ten. Checked in this order so that "meg" and "mil" win over "m".
_POW10 = {"t": 12, "g": 9, "k": 3, "m": -3, "u": -6, "n": -9, "p": -12, "f": -15, "a": -18}
MIL = 25.4e-6  # m, one thousandth of an inch

_NUMBER = re.compile(r"([+-]?(?:\d+\.?\d*|\.\d+))([eE][+-]?\d+)?([a-zA-Z]*)")


def suffix_scale(letters: str) -> tuple[int | None, float]:
    """Scale given by the letters after a number.

    Parameters
    ----------
    letters : str
        Suffix and unit, e.g. ``"uF"``, ``"Meg"``, ``"V"`` or ``""``.

    Returns
    -------
    (int or None, float)
        The power of ten of the suffix (``None`` for ``mil``, which is not one), and the
        multiplier itself.
    """
    low = letters.lower()
    if low.startswith("meg"):
        return 6, 1e6
    if low.startswith("mil"):
        return None, MIL
    if low and low[0] in _POW10:
        p = _POW10[low[0]]
        return p, 10.0**p
    return 0, 1.0


def parse_number(text: str) -> float | None:
    """The value of a SPICE number, or ``None`` if ``text`` is not one.

    Parameters
    ----------
    text : str
        E.g. ``"1e-3"``, ``"10uF"``, ``"-2.5k"``, ``"1Meg"``, ``"5V"``. Leading sign allowed;
        anything after the letters (``"1k2"``) makes it not a number.

    Returns
    -------
    float or None
        The value in SI units. The conversion goes through the decimal text (``100u`` is
        exactly ``float("100e-6")``), so a number written by :func:`format_number` reads back
        bit for bit.
    """
    m = _NUMBER.fullmatch(text)
    if m is None:
        return None
    mant, exp, letters = m.groups()
    if not letters:
        return float(text)
    p, scale = suffix_scale(letters)
    if p is None:
        return float(mant + (exp or "")) * scale
    e = int(exp[1:]) if exp else 0
    return float(f"{mant}e{e + p}")


# Suffixes used for output, largest first (no "mil", "a" or "m"-for-mega confusion).
_OUT = [(12, "T"), (9, "G"), (6, "Meg"), (3, "k"), (0, ""), (-3, "m"), (-6, "u"), (-9, "n"),
        (-12, "p"), (-15, "f")]


def format_number(value: float) -> str:
    """SPICE text for ``value`` that :func:`parse_number` reads back exactly.

    Values from 0.01 to 999 are written plainly (``0.5``, ``12``), others with an
    engineering suffix (``1e-4`` -> ``"100u"``, ``50000.0`` -> ``"50k"``). The digits are
    those of ``repr(value)``, the shortest text that reads back as the same float, with the
    decimal point moved; :func:`parse_number` also converts through the decimal text, so the
    value survives bit for bit.

    Parameters
    ----------
    value : float
        A finite number.
    """
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot write non-finite value {value!r} to a netlist")
    if value == 0:
        return "0"
    from decimal import Decimal  # (only netlists written need it: 1 ms of every start)

    d = Decimal(repr(value))
    e = d.adjusted()  # exponent of the leading digit
    if -2 <= e <= 2:
        return _plain(d)
    if not -15 <= e < 15:
        return repr(value)
    p = min(12, 3 * (e // 3))
    return _plain(d.scaleb(-p)) + dict(_OUT)[p]


def _plain(d: Decimal) -> str:
    return format(d.normalize(), "f")


def format_eng(value: float | None, unit: str = "", digits: int = 4) -> str:
    """Readable engineering notation for people: ``format_eng(1e-4, "F") == "100 µF"``.

    :func:`lcs.units_format.format_eng` (a rounding that reaches 1000 carries into the next
    prefix: ``format_eng(0.99996, "V") == "1 V"``), with ``None`` (a parameter left at its
    default) written as ``"default"``.

    Parameters
    ----------
    value : float or None
        The value in SI units; ``None`` gives ``"default"``.
    unit : str
        Unit symbol appended after the suffix.
    digits : int
        Significant digits.
    """
    if value is None:
        return "default"
    return _format_eng(value, unit, digits)
