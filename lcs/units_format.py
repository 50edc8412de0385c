"""Values with units for people: engineering notation with SI prefixes (``7.172 V``,
``1.5 mV``, ``100 µF``).

The one formatter of pelcs: the plots' legends and axes (:mod:`lcs.analysis.tables`) and,
through :func:`netlist.units.format_eng`, every message, table and report of the CLI.
"""

from __future__ import annotations

import math

__all__ = ["PREFIXES", "format_eng", "si_prefix"]

#: SI prefixes by power of ten (µ, not u: this is for people, not for SPICE netlists).
PREFIXES = {-15: "f", -12: "p", -9: "n", -6: "µ", -3: "m", 0: "", 3: "k", 6: "M", 9: "G",
            12: "T"}
_LOW, _HIGH = 1e-15, 1e15  # magnitudes with a prefix: [1 f, 1000 T)


def _exponent(magnitude: float) -> int:
    """The power of ten of the prefix of ``magnitude`` (in [1e-15, 1e15)): a multiple of 3
    (clamped to the table, should log10 round across an end)."""
    return max(-15, min(12, 3 * math.floor(math.floor(math.log10(magnitude)) / 3)))


def format_eng(value: float, unit: str = "", digits: int = 4) -> str:
    """``value`` to ``digits`` significant digits with the SI prefix that puts the mantissa in
    [1, 1000): ``format_eng(1e-4, "F") == "100 µF"``, ``format_eng(0.0015, "V") == "1.5 mV"``.

    The prefix is that of the rounded value: 0.99996 V at 4 digits is ``"1 V"``, not
    ``"1000 mV"`` (a rounding that reaches 1000 carries into the next prefix). Zero,
    non-finite values and magnitudes (after rounding) outside [1e-15, 1e15) are written without
    a prefix (``"0 V"``, ``"nan V"``, ``"1e+15 V"``).

    Parameters
    ----------
    value : float
        The value in SI units (a number or a numpy scalar).
    unit : str
        Unit symbol appended after the prefix.
    digits : int
        Significant digits.
    """
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
