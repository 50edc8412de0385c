"""Engineering notation (:func:`netlist.units.format_eng`), the one formatter of values for
people, behind every message and the sweep plots' legends and axes: the SI prefix is that of
the rounded value, so a rounding that reaches 1000 carries into the next prefix."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from netlist.units import format_eng, si_prefix
from pelcs import sweep_plots


@pytest.mark.parametrize(
    "value, unit, digits, text",
    [
        # A rounding that reaches 1000 carries into the next prefix.
        (999.96e-3, "V", 4, "1 V"),
        (999999.6, "Hz", 4, "1 MHz"),
        (-999.96e-6, "A", 4, "-1 mA"),
        (999.96e-9, "s", 4, "1 µs"),
        (9.9996e-16, "V", 4, "1 fV"),  # up into the table's first prefix
        # ... and only then.
        (999.94e-3, "V", 4, "999.9 mV"),
        (999.96e-3, "V", 6, "999.96 mV"),
        (0.0099996, "V", 4, "10 mV"),  # 9.9996 -> 10: same prefix
        (999.9e12, "W", 4, "999.9 TW"),
        # Plain numbers, SI prefixes, negative values.
        (1e-4, "F", 4, "100 µF"),
        (47e3, "Ω", 4, "47 kΩ"),
        (2e6, "Hz", 4, "2 MHz"),
        (7.1724, "V", 4, "7.172 V"),
        (-1.5e-3, "V", 4, "-1.5 mV"),
        (-47e3, "", 4, "-47 k"),
        (1e-15, "V", 4, "1 fV"),
        (1, "s", 4, "1 s"),
        # Without a prefix: zero, non-finite, beyond the table (also after rounding).
        (0.0, "V", 4, "0 V"),
        (0, "", 4, "0"),
        (math.inf, "V", 4, "inf V"),
        (-math.inf, "V", 4, "-inf V"),
        (math.nan, "V", 4, "nan V"),
        (9.9996e14, "V", 4, "1e+15 V"),  # rounds to 1e15: as 1e15 itself
        (1e15, "V", 4, "1e+15 V"),
        (9e-16, "V", 4, "9e-16 V"),
    ],
)
def test_format_eng(value, unit, digits, text):
    assert format_eng(value, unit, digits) == text


def test_format_eng_numpy_scalars_and_none():
    assert format_eng(np.float64(0.5), "V") == "500 mV"
    assert format_eng(np.float32(2.0), "A") == "2 A"
    assert format_eng(np.int64(3000), "Hz") == "3 kHz"
    assert format_eng(None, "s") == "default"  # a parameter left at its default
    assert format_eng(np.float64(999.96e-3), "V") == "1 V"


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@settings(max_examples=300, deadline=None)
@given(st.floats(allow_nan=False, allow_infinity=False), st.integers(1, 10))
def test_prefixed_mantissa_is_in_1_to_1000(value, digits):
    text = format_eng(value, "V", digits)
    mant, _, rest = text.partition(" ")
    shown = abs(float(f"{value:.{digits}g}"))
    if 1e-15 <= shown < 1e15:  # a prefix: the mantissa is in [1, 1000), reads as the value
        prefix = rest[:-1]
        assert 1 <= abs(float(mant)) < 1000
        scale = 10.0 ** (3 * _PREFIXES.index(prefix) - 15)
        assert float(mant) * scale == pytest.approx(value, rel=10.0 ** (1 - digits))
    else:  # zero or beyond the table: no prefix
        assert text == f"{value:.{digits}g} V"


_PREFIXES = ["f", "p", "n", "µ", "m", "", "k", "M", "G", "T"]


@pytest.mark.parametrize(
    "magnitude, expected",
    [(0.015, (1e-3, "m")), (0.99996, (1e-3, "m")), (2e6, (1e6, "M")), (1.0, (1.0, "")),
     (-3e-9, (1e-9, "n")), (0.0, (1.0, "")), (math.inf, (1.0, "")), (math.nan, (1.0, "")),
     (1e15, (1.0, "")), (5e-16, (1.0, ""))],
)
def test_si_prefix(magnitude, expected):
    assert si_prefix(magnitude) == expected


def test_sweep_plot_axis_prefix():
    assert sweep_plots._prefix(np.array([0.012, -0.015]), "V") == (1e-3, "m")
    assert sweep_plots._prefix(np.array([0.012]), "") == (1.0, "")  # no unit: no prefix
    assert sweep_plots._prefix(np.array([]), "V") == (1.0, "")
