"""Circuits with many diodes and switches: no 64-bit limit anywhere, the
warm-started pivoting and the rank-one factorisation updates give the numbers of the plain
paths.

References: each copy of a converter repeated 70 times in one netlist (70 switches, 70
diodes: keys and active sets of two words) must equal the same converter simulated alone
(one switch, one diode: the one-word path, itself checked against analytic results in
tests/test_simulate_reference.py), and the buck's mean output D·Vin; the warm-started solver
must reproduce Lemke's solutions (MoreauOptions(warm_iter=0)); factorisations by rank-one
updates must reproduce those from scratch (a one-slot cache has no neighbour to update from).
"""

from __future__ import annotations

import numpy as np
import pytest

from converters import scaling
from lcs.bits import from_words, to_words, words
from lcs.integrators.moreau.integrator import MoreauOptions
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import run_setup, transient_setup

VIN, DUTY, FS = 24.0, 0.4, 50e3


def _buck_copies(values: list[tuple[float, float]], periods: int) -> str:
    """Independent bucks (inductance, load) sharing the input and one gate waveform."""
    T = 1.0 / FS
    lines = [f"{len(values)} bucks", f"Vin in 0 DC {VIN}",
             f"Vg g 0 PULSE(0 1 0 10n 10n {DUTY * T - 10e-9:g} {T:g})"]
    for i, (lind, rload) in enumerate(values, start=1):
        lines += [f"S{i} in sw{i} g 0 SWIDEAL", f"D{i} 0 sw{i} DIDEAL",
                  f"L{i} sw{i} out{i} {lind:g}", f"C{i} out{i} 0 20u IC=0",
                  f"R{i} out{i} 0 {rload:g}"]
    lines += [".model SWIDEAL SW(VT=0.5 VH=0 RON=1m ROFF=1e9)",
              ".model DIDEAL D(IS=1e-12 N=0.05 RS=1m)",
              f".tran {T / 50:g} {periods * T:g} 0 {T / 50:g} UIC", ".end"]
    return "\n".join(lines) + "\n"


def test_bitsets_round_trip():
    for value in (0, 1, (1 << 63), (1 << 64) - 1, (1 << 130) + 12345, (1 << 200) - 1):
        w = words(value.bit_length() + 1)
        assert from_words(to_words(value, w)) == value
    assert words(0) == 1 and words(64) == 1 and words(65) == 2


def test_seventy_switches_and_diodes_equal_one_copy():
    values = [(100e-6 * (1 + 0.02 * i), 5.0 + 0.1 * (i % 7)) for i in range(70)]
    big = transient_setup(parse_string(_buck_copies(values, periods=40)))
    assert len(big.system.switches) == 70 and len(big.system.diodes) == 70
    probes = [f"v(out{i + 1})" for i in range(70)]
    res = run_setup(big, probes=probes)
    assert res.ok
    for i in (0, 13, 42, 69):
        one = run_setup(transient_setup(parse_string(_buck_copies([values[i]], periods=40))),
                        probes=["v(out1)"])
        assert np.array_equal(one.t, res.t)
        ref = one["v(out1)"]
        assert np.abs(res[probes[i]] - ref).max() <= 1e-9 * np.abs(ref).max()
    # Continuous conduction settles near D·Vin (L C = 2e-9: the output is still ringing
    # after 40 periods, so only a loose check of the level).
    last = res.t > res.t[-1] - 5 / FS
    assert abs(res[probes[0]][last].mean() - DUTY * VIN) < 0.3 * DUTY * VIN


@pytest.mark.parametrize("name", ["boost_dcm", "prc", "bridge_rectifier"])
def test_warm_started_pivoting_equals_lemke(name):
    s = transient_setup(parse_file(f"converters/netlists/{name}.cir"))
    lemke = run_setup(s, options=MoreauOptions(warm_iter=0))
    warm = run_setup(s)
    assert lemke.ok and warm.ok
    assert lemke.stats.fallbacks > warm.stats.fallbacks
    assert warm.stats.warm_solves > 0
    scale = np.abs(lemke.y).max(axis=0)
    assert (np.abs(warm.y - lemke.y).max(axis=0) <= 1e-11 * scale).all()


def test_rank_one_updates_equal_factorisations_from_scratch():
    s = transient_setup(parse_string(scaling.cockcroft_walton(20, periods=6)))
    updated = run_setup(s)
    scratch = run_setup(s, options=MoreauOptions(cache_slots=1))
    assert updated.ok and scratch.ok
    assert updated.stats.fallbacks == 0 and updated.stats.warm_solves > 0
    assert updated.stats.factor_updates > 0 and scratch.stats.factor_updates == 0
    scale = np.abs(scratch.y).max()
    assert np.abs(updated.y - scratch.y).max() <= 1e-9 * scale
    # The multiplier works: the top of the smoothing column approaches 2 N Vpk from below.
    top = updated["v(C40)"] if "v(C40)" in updated.names else updated.y[:, -1]
    assert 0 < top[-1] < 2 * 20 * 100.0
