"""Numbers with units: SPICE numbers read and written, and values written for people.

The one parser (:func:`parse_number`) and the two writers of pelcs: :func:`format_number`
writes SPICE text that reads back exactly (``100u``), :func:`format_eng` writes a value for
people in engineering notation with SI prefixes (``100 µF``: every message, table, legend and
axis), :func:`si_prefix` gives an axis its prefixed unit.

SPICE reads ``10uF`` as 10e-6, ``1kOhm`` as 1e3, ``1Meg`` as 1e6 and ``1mil`` as 25.4e-6: the
letters after the number are a scale suffix (case-insensitive) followed by a unit that is
ignored. Beware the classic traps, which pelcs keeps for compatibility with SPICE: ``M`` is
milli (mega is ``Meg``) and ``10F`` is ten femto, not ten farads.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

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


#: SI prefixes by power of ten (µ, not u: this is for people, not for SPICE netlists).
PREFIXES = {-15: "f", -12: "p", -9: "n", -6: "µ", -3: "m", 0: "", 3: "k", 6: "M", 9: "G",
            12: "T"}
_LOW, _HIGH = 1e-15, 1e15  # magnitudes with a prefix: [1 f, 1000 T)


def _exponent(magnitude: float) -> int:
    """The power of ten of the prefix of ``magnitude`` (in [1e-15, 1e15)): a multiple of 3
    (clamped to the table, should log10 round across an end)."""
    return max(-15, min(12, 3 * math.floor(math.floor(math.log10(magnitude)) / 3)))


def format_eng(value: float | None, unit: str = "", digits: int = 4) -> str:
    """``value`` for people, to ``digits`` significant digits with the SI prefix that puts the
    mantissa in [1, 1000): ``format_eng(1e-4, "F") == "100 µF"``,
    ``format_eng(0.0015, "V") == "1.5 mV"``; ``None`` (a parameter left at its default) is
    ``"default"``.

    The prefix is that of the rounded value: 0.99996 V at 4 digits is ``"1 V"``, not
    ``"1000 mV"`` (a rounding that reaches 1000 carries into the next prefix). Zero,
    non-finite values and magnitudes (after rounding) outside [1e-15, 1e15) are written without
    a prefix (``"0 V"``, ``"nan V"``, ``"1e+15 V"``).

    Parameters
    ----------
    value : float or None
        The value in SI units (a number or a numpy scalar); ``None`` gives ``"default"``.
    unit : str
        Unit symbol appended after the prefix.
    digits : int
        Significant digits.
    """
    if value is None:
        return "default"
    value = float(value)
    shown = float(f"{value:.{digits}g}")  # the value as it will read
    if shown == 0 or not math.isfinite(shown) or not _LOW <= abs(shown) < _HIGH:
        return f"{value:.{digits}g} {unit}".rstrip()
    p = _exponent(abs(shown))
    mant = f"{value / 10.0**p:.{digits}g}"
    if abs(float(mant)) >= 1000 and p < 12:  # (round-off of the division at a tie)
        p += 3
        mant = f"{value / 10.0**p:.{digits}g}"
    return f"{mant} {PREFIXES[p]}{unit}".rstrip()


def si_prefix(magnitude: float) -> tuple[float, str]:
    """The SI prefix of ``magnitude`` as (its factor, its symbol), e.g. ``(1e-3, "m")`` for
    0.015; ``(1.0, "")`` for zero, non-finite values and magnitudes outside [1e-15, 1e15).

    For an axis in a prefixed unit: no rounding, so 0.99996 gives ``(1e-3, "m")``.
    """
    big = abs(float(magnitude))
    if not (math.isfinite(big) and _LOW <= big < _HIGH):
        return 1.0, ""
    p = _exponent(big)
    return 10.0**p, PREFIXES[p]

