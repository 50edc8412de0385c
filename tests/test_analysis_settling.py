"""Periods of bifurcation diagrams only where the record has settled.

A transient decaying onto a period-1 orbit through a multiplier near -1 alternates, and its
points two apart differ far less than neighbours: a record of it repeats every two iterates
within the tolerance while it is no period-2 attractor. The verdict must tell the two apart
both ways: "not settled" on the decaying transient, "period 2" on a period-2 orbit (also
while its amplitude still converges to a non-zero value).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lcs.analysis.bifurcation import attractor_period, classify_attractor


def _transient(mu: complex, c: float, j0: int = 60, m: int = 100) -> np.ndarray:
    """``x_j = x* + c mu**j`` on two probes of different scales, j = j0 .. j0 + m - 1."""
    j = np.arange(j0, j0 + m)
    z = c * mu**j
    return np.column_stack([12.0 + np.real(z), 1.0 + 0.3 * np.real(z) + 0.1 * np.imag(z)])


@pytest.mark.parametrize("mu", [-0.99, -0.999])
def test_decaying_alternation_is_not_settled(mu):
    s = _transient(mu, 1e-4)
    # the repetition alone says period 2 ...
    assert np.max(np.abs(s[2:] - s[:-2])) <= 1e-7 * np.max(np.abs(s))
    assert np.max(np.abs(s[1:] - s[:-1])) > 1e-7 * np.max(np.abs(s))
    # ... the amplitude shrinks geometrically: a transient onto period 1
    a = classify_attractor(s, rtol=1e-7)
    assert a.period == 2 and not a.settled and a.onto == 1
    # the amplitude's ratio between windows of differences of neighbours 94 to 97 iterates
    # apart (whole cycles, M - 1 differences)
    assert abs(mu) ** 97 * (1 - 1e-9) <= a.decay <= abs(mu) ** 94
    assert "not settled" in a.label and attractor_period(s, 1e-7) == 0


def test_period_two_orbit_is_settled_even_with_round_off():
    rng = np.random.default_rng(1)
    j = np.arange(100)
    s = np.column_stack([12 + 1e-4 * (-1.0) ** j, 1 + 3e-4 * (-1.0) ** j])
    s = s + 1e-13 * rng.standard_normal(s.shape)
    a = classify_attractor(s, rtol=1e-7)
    assert (a.period, a.settled, a.label) == (2, True, "period 2")


def test_converging_onto_a_period_two_orbit_is_period_two():
    # the amplitude shrinks, but to 1e-4, not to zero (Aitken's limit)
    j = np.arange(100)
    s = np.column_stack([12 + (1e-4 + 1e-5 * 0.97**j) * (-1.0) ** j, 1 + 3e-4 * (-1.0) ** j])
    assert classify_attractor(s, rtol=1e-7).label == "period 2"


def test_period_four_decaying_onto_period_two():
    j = np.arange(100)
    s = (12 + 1e-3 * (-1.0) ** j + 1e-4 * 0.9999**j * np.cos(np.pi * j / 2))[:, None]
    assert np.max(np.abs(s[4:] - s[:-4])) <= 1e-7 * 12.001  # repeats every 4 ...
    a = classify_attractor(s, rtol=1e-7)
    assert a.period == 4 and not a.settled and a.onto == 2  # ... onto period 2


def test_logistic_periods_unchanged():
    def record(r, n=2000, m=64):
        x = 0.3
        for _ in range(n):
            x = r * x * (1 - x)
        out = []
        for _ in range(m):
            x = r * x * (1 - x)
            out.append(x)
        return np.array(out)

    assert [attractor_period(record(r), 1e-6) for r in (2.9, 3.2, 3.5, 3.55, 3.83)] == \
        [1, 2, 4, 8, 3]
    # chaos: no period, and no "not settled" verdict invented for it
    a = classify_attractor(record(3.9), 1e-7)
    assert a.period == 0 and a.settled and "no period" in a.label


def test_too_short_a_record_says_so():
    s = np.array([[1.0], [2.0], [1.0 + 1e-9]])
    a = classify_attractor(s, rtol=1e-7)
    assert a.period == 2 and not a.settled and a.why == "short" and "too few points" in a.label


# --- the Deane-Hamill buck (converters/netlists/vm_buck.cir) --------------------------------


def test_buck_decaying_transient_is_not_period_two(capsys):
    """Below the flip (24.517 V) the period-1 orbit's multipliers are -0.821 +- 0.071j: after
    90 periods from rest its transient alternates with neighbours 2.3e-6 apart and points two
    apart 2e-7 to 6e-7 apart, within the 1e-7 relative tolerance: the repetition said
    "period 2". At 25 V, beyond the flip, the period-2 orbit is reported as such; the orbit
    solver confirms both runs from their recorded states."""
    from pelcs.cli import main

    path = str(Path(__file__).resolve().parents[1] / "converters" / "netlists" / "vm_buck.cir")
    code = main(["bifurcation", path, "--period", "tp", "--param", "vin=24:25:2",
                 "--transient", "90", "--record", "8", "--workers", "1", "--no-progress",
                 "--confirm"])
    out = capsys.readouterr().out
    assert code == 0
    rows = {line.split(":", 1)[0].strip(): line.split(":", 1)[1].strip()
            for line in out.splitlines() if line.startswith("   ")}
    assert rows["24"].startswith("not settled"), out
    assert rows["25"] == "period 2", out
    assert "vin = 24 (fixed): period-1 orbit, stable; multipliers -0.821" in out
    assert "vin = 25 (fixed): period-2 orbit, stable" in out
    assert "1 value(s) have not settled" in out
