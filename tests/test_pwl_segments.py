"""Diodes of several piecewise-linear segments (``--devices pwl``, :func:`netlist.pwl.segment_fit`):
the fitted characteristic against Shockley's equation with series resistance, evaluated here
on its own, and the circuit pelcs builds from it (ideal diodes in parallel, each behind its
own Vf and Ron) against the characteristic it was built from."""

from __future__ import annotations

import math

import numpy as np
import pytest

import pelcs
from netlist.circuit import Diode
from netlist.pwl import (
    CHORD_TOLERANCE,
    LOW_FRACTION,
    MAX_SEGMENTS,
    SEGMENT_TOLERANCE,
    VT_THERMAL,
    diode_fit,
    diode_residual,
    pwl_circuit,
    pwl_voltage,
    segment_fit,
    segments_of,
)
from netlist.studies.transient import simulate_circuit


def shockley(i, is_, n, rs):
    """The diode's voltage at current i: n Vt ln(1 + i/IS) + RS i (V)."""
    return n * VT_THERMAL * np.log1p(np.asarray(i) / is_) + rs * np.asarray(i)


def branch_voltage(vf, ron, branches, i):
    """The voltage at which the parallel branches, each max(0, (v - Vf_k)/Ron_k), carry i
    in all: bisection on the branches' current (not the lines the fit is written as)."""
    segs = [(vf, ron), *branches]
    lo, hi = 0.0, 10.0
    for _ in range(200):
        v = 0.5 * (lo + hi)
        total = sum(max(0.0, (v - a) / r) for a, r in segs)
        lo, hi = (v, hi) if total < i else (lo, v)
    return 0.5 * (lo + hi)


# (IS, N, RS, carried current): the corpus' DC restorer's diode and the doubler's BAR42
# (the mixer's diode and a power diode at 10 A, whose lines miss over their own range, below)
CASES = [(2.0298e-15, 1.0, 0.0, 1.26e-3), (1.13853e-8, 1.0, 0.99517, 0.0771)]


@pytest.mark.parametrize("is_, n, rs, i_max", CASES)
def test_segments_follow_shockley_over_three_decades(is_, n, rs, i_max):
    vf, ron, branches, error = segment_fit([{"is": is_, "n": n, "rs": rs}], i_max)
    assert 1 <= len(branches) <= 2  # one segment misses by far more than the tolerance
    i = np.logspace(math.log10(LOW_FRACTION * i_max), math.log10(i_max), 37)
    got = np.array([branch_voltage(vf, ron, branches, x) for x in i])
    miss = np.abs(got - shockley(i, is_, n, rs))
    assert miss.max() <= error + 1e-6  # the error it reports bounds it
    # within 0.65 N Vt over the three decades (the one line's error over its own range)
    assert error < 0.65 * n * VT_THERMAL
    # the one segment misses by several times more at the low end
    vf1, ron1 = diode_fit(is_, n, rs, i_max)
    assert np.max(np.abs(vf1 + ron1 * i - shockley(i, is_, n, rs))) > 2.5 * error
    # above a tenth of the current it carries, the same line as one segment: a converter's
    # diode at its load current sees the same diode
    top = i[i >= i_max / 10]
    assert [branch_voltage(vf, ron, branches, x) for x in top] == pytest.approx(
        vf1 + ron1 * top, abs=1e-9)
    # a convex characteristic: each branch opens above the last, and all conduct
    knees = [vf] + [b[0] for b in branches]
    assert knees == sorted(knees) and ron > 0 and all(b[1] > 0 for b in branches)


# the corpus mixer's 1N4148 (at the 2.03 uA its pwl run carries, and at 0.45 mA)
MIXER = {"is": 2.52e-9, "n": 1.752, "rs": 0.568}


@pytest.mark.parametrize("is_, n, rs, i_max", [(2.52e-9, 1.752, 0.568, 2.03e-6),
                                               (2.52e-9, 1.752, 0.568, 4.49e-4),
                                               (1e-9, 1.5, 0.05, 10.0)])
def test_chords_over_the_whole_range_where_the_line_misses(is_, n, rs, i_max):
    # no line follows these exponentials over [I/20, I] (RS small beside N Vt / I), so the
    # line with two chords below it misses too; chords over the whole range follow them
    params = {"is": is_, "n": n, "rs": rs}
    line = diode_fit(is_, n, rs, i_max)
    top = np.logspace(math.log10(i_max / 20), math.log10(i_max), 200)
    line_miss = np.max(np.abs(line[0] + line[1] * top - shockley(top, is_, n, rs)))
    assert line_miss > SEGMENT_TOLERANCE
    vf, ron, branches, error, said = segments_of([params], i_max)
    assert said == pytest.approx(line_miss, rel=0.02)  # what the report line says it missed
    assert 2 <= 1 + len(branches) <= MAX_SEGMENTS
    i = np.logspace(math.log10(LOW_FRACTION * i_max), math.log10(i_max), 61)
    got = np.array([branch_voltage(vf, ron, branches, x) for x in i])
    miss = got - shockley(i, is_, n, rs)
    # the error it reports bounds the miss, within the chords' tolerance or with the most
    assert np.max(np.abs(miss)) <= error + 1e-6
    assert error <= CHORD_TOLERANCE or 1 + len(branches) == MAX_SEGMENTS
    assert error < 0.15 * n * VT_THERMAL  # against 0.65 N Vt for the line's top segment
    # the chords are moved up by half their error: the fit lies on both sides of the model
    assert np.min(miss) < -0.4 * error and np.max(miss) > 0.4 * error
    knees = [vf] + [b[0] for b in branches]
    assert knees == sorted(knees) and ron > 0 and all(b[1] > 0 for b in branches)
    assert segment_fit([params], i_max) == (vf, ron, branches, error)


def test_mixer_diode_follows_ngspice_over_three_decades(tmp_path, ngspice):
    # the fit at 2.03 uA against ngspice's own operating points of the same diode, from
    # 1e-3 of that current up to it: within the error the fit reports
    from ngspice_helpers import ngspice_dc_voltages

    i_max = 2.03e-6
    vf, ron, branches, error = segment_fit([MIXER], i_max)
    currents = i_max * np.array([1e-3, 3e-3, 1e-2, 3e-2, 0.1, 0.3, 1.0])
    want = ngspice_dc_voltages(
        "D1 a 0 DM\n.model DM D(IS=2.52n RS=0.568 N=1.752 CJO=4p VJ=0.5 M=0.4 TT=20n BV=100)\n",
        currents, tmp_path)
    got = pwl_voltage(vf, ron, branches, currents)
    assert np.max(np.abs(got - want)) <= error + 2e-5
    # in current, the model's exponential: within 12 % at every one of these voltages
    assert np.max(np.abs(got - want)) / (MIXER["n"] * VT_THERMAL) < 0.11


def test_one_segment_kept_where_it_fits():
    # the bundled converters' near-ideal diode (N = 0.05): one line within 6 mV of the model
    # over the three decades, the same line as before
    vf, ron, branches, error = segment_fit([{"is": 1e-12, "n": 0.05, "rs": 1e-3}], 8.91)
    assert branches == () and (vf, ron) == diode_fit(1e-12, 0.05, 1e-3, 8.91)
    i = np.logspace(math.log10(LOW_FRACTION * 8.91), math.log10(8.91), 200)
    assert error == pytest.approx(np.max(np.abs(vf + ron * i - shockley(i, 1e-12, 0.05, 1e-3))),
                                  rel=0.05)
    assert error < SEGMENT_TOLERANCE


NETLIST = """* a ramp through 1 kOhm into a diode
V1 in 0 PWL(0 0 1m 5)
R1 in a 1k
D1 a 0 DR
.model DR D(IS=2.0298e-15 N=1)
.tran 1u 1m
.end
"""


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_circuit_realises_the_segments(tmp_path):
    path = tmp_path / "ramp.cir"
    path.write_text(NETLIST)
    circuit = pelcs.load(path)
    run, fits = pwl_circuit(circuit, {"D1": 4.3e-3}, {})
    fit = fits[0]
    assert len(fit.branches) >= 1 and fit.error is not None
    assert "segments: fit of IS=2.03e-15" in fit.line()
    diodes = [el.name for el in run.elements if isinstance(el, Diode)]
    # one complementarity pair per segment
    assert len(diodes) == 1 + len(fit.branches)
    segs = [(fit.vf, fit.ron), *fit.branches]
    ron_names = ["D1#ron"] + [f"D1#ron{k}" for k in range(2, len(segs) + 1)]
    res = simulate_circuit(run, probes=["v(a)", "i(D1)", *(f"i({r})" for r in ron_names)])
    v, i = np.asarray(res["v(a)"]), np.asarray(res["i(D1)"])
    branch = [np.asarray(res[f"i({r})"]) for r in ron_names]
    # the element carries the branches' total; the power the losses take, |i| v(|i|), is
    # the branches' own (Vf_k i_k + Ron_k i_k^2)
    assert np.max(np.abs(sum(branch) - i)) < 1e-12
    power = sum(a * x + r * x * x for (a, r), x in zip(segs, branch, strict=True))
    assert np.max(np.abs(np.abs(i) * fit.voltage(np.abs(i)) - power)) < 1e-9
    on = i > 1e-9
    # D1 carries the total current: the node voltage is the characteristic at it
    want = np.array([branch_voltage(fit.vf, fit.ron, fit.branches, x) for x in i[on]])
    assert np.max(np.abs(v[on] - want)) < 1e-6
    # and the source's current balances: (v(in) - v(a))/1k = i(D1)
    t = np.asarray(res.t)
    assert np.max(np.abs((5.0 * t / 1e-3 - v) / 1e3 - i)) < 1e-9
    assert np.max(np.abs(fit.voltage(i[on]) - want)) < 1e-9
    # what pelcs check takes as the fit's residual is the error it reports
    assert diode_residual(circuit, circuit.element("D1"), fit.vf, fit.ron,
                          LOW_FRACTION * 4.3e-3, 4.3e-3, fit.branches) == pytest.approx(
        fit.error, rel=0.05)
    # the segment of the largest currents is the one-segment fit
    assert fit.top == pytest.approx(diode_fit(2.0298e-15, 1.0, 0.0, 4.3e-3), rel=1e-9)


def test_a_diode_carrying_an_inductors_current_keeps_one_segment():
    # the boost's diode D(IS=1e-9 N=1.5 RS=0.05): one line misses by 0.17 V at 3 mA, but
    # its segments would cancel part of the inductor's dynamics (netlist.studies.realistic)
    from pathlib import Path

    from netlist.studies.realistic import simulate_devices

    c = pelcs.load(Path(__file__).parent / "netlists" / "devices" / "boost_sw_pwl.cir")
    res = simulate_devices(c, devices="pwl", probes=["v(out)"], tstop=2e-3)
    fit = {f.element: f for f in res.device_fits}["D1"]
    assert fit.branches == () and "one segment: an inductor's current" in fit.how
    assert fit.error > SEGMENT_TOLERANCE
    assert not any("is not reliable" in n for n in res.notes)  # θ = 1/2 kept
