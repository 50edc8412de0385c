"""Stored discretisations of shortened steps: PWM edges fall at the same offsets
from the grid every period, so the elimination of a shortened step is done once per length and
mode. The results equal those of a fresh discretisation of every shortened step (to
round-off), and the converter's mean output its analytic value."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from converters.scaling import interleaved_buck, mmc_arm
from lcs.integrators.moreau.dense.layout import ODD_SETS
from lcs.integrators.moreau.dense.modes import ODD_BYTES_PER_MODE, odd_slots
from lcs.integrators.moreau.integrator import MoreauOptions
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import simulate_circuit

ROOT = Path(__file__).resolve().parents[1]


def _pair(circuit, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        a = simulate_circuit(circuit, **kw)
        b = simulate_circuit(circuit, options=MoreauOptions(odd_slots=0), **kw)
    return a, b


def _close(a, b, rtol=1e-9):
    # Located comparator instants move with the round-off of the states, which the voltage-
    # mode buck (a chaos benchmark) amplifies over its 10 ms: 1e-14 s at the end when the
    # formulation's LU and SVD solves differ in their last bits. 1e-10 of the run still
    # tells a stored step of the wrong length (a whole sub-step, 1e-7 of it here).
    assert a.t.shape == b.t.shape
    assert np.allclose(a.t, b.t, rtol=0, atol=1e-10 * b.t[-1])
    scale = np.abs(b.y).max(axis=0)
    assert np.all(np.abs(a.y - b.y) <= rtol * scale + 1e-300)


def test_interleaved_buck_stored_lengths_equal_fresh_ones_and_give_d_vin():
    # 8 phases, 24 V, D = 0.4, CCM at 1 ohm: the mean output is D Vin = 9.6 V; 60 periods
    # settle the LC filter (f0 = 1.6 kHz) only partly, so compare the two runs first.
    circuit = parse_string(interleaved_buck(8, periods=60, rload=1.0))
    a, b = _pair(circuit, probes=["v(out)"])
    assert a.stats.odd_steps == b.stats.odd_steps > 1000
    assert a.stats.odd_stored > 0.9 * a.stats.odd_steps
    assert a.stats.odd_discretised <= 8 * a.stats.modes_built
    assert b.stats.odd_stored == 0 and b.stats.odd_discretised == 0
    _close(a, b)


def test_interleaved_buck_mean_output_is_d_vin():
    circuit = parse_string(interleaved_buck(4, periods=1200, steps_per_period=50))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = simulate_circuit(circuit, probes=["v(out)"])
    T = 1 / 50e3
    last = res.t >= res.t[-1] - 10 * T
    t, v = res.t[last], res["v(out)"][last]
    mean = np.sum(0.5 * (v[1:] + v[:-1]) * np.diff(t)) / (t[-1] - t[0])
    assert res.stats.odd_stored > 0
    assert mean == pytest.approx(0.4 * 24.0, rel=2e-3)


def test_mmc_arm_and_comparator_buck_equal_fresh_discretisations():
    a, b = _pair(parse_string(mmc_arm(4, periods=1)))
    assert a.stats.odd_stored > 0
    _close(a, b)
    # Comparator switchings are located inside steps at instants that do not recur: those
    # sub-steps are never stored, and the results are the same.
    a, b = _pair(parse_file(ROOT / "converters" / "netlists" / "vm_buck.cir"), tstop=10e-3)
    assert a.stats.located > 10
    _close(a, b)


def test_slots_per_mode_are_bounded_by_memory():
    assert odd_slots(3, 2, 2) == 8
    assert odd_slots(3, 2, 2, 0) == 0
    n = m = 200
    size = 8 * (n * n + 2 * n * 4 + n * m + (1 + ODD_SETS) * m * m)
    assert odd_slots(n, m, 4) == max(1, ODD_BYTES_PER_MODE // size) == 1
    assert odd_slots(2000, 2000, 1) == 0  # one slot over the budget: none
