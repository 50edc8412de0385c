"""Comparator switching in less common situations: output and event buffers that must grow
(many switchings stored with every = 1), a comparator against a sine (not piecewise linear)
reference, two comparators in one circuit (two-phase buck)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from lcs.integrators.moreau.integrator import simulate
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import transient_setup

CL = Path(__file__).parent / "netlists" / "closed_loop"


def test_buffers_grow_with_many_located_switchings():
    s = transient_setup(parse_file(CL / "relaxation.cir"))
    res = simulate(s.system, s.signals, s.x0, 500e-6, 1e-6, probes=["v(c)", "d(S1)"])
    assert res.ok
    assert res.stats.located > 400 > 500e-6 / 1e-6 * 0.5
    # every = 1: every switching instant is an output row, in order.
    t_ev = np.array([t for t, _ in res.events])
    assert np.all(np.isin(t_ev, res.t))
    assert np.all(np.diff(res.t) > 0)
    assert len(res.t) == res.stats.steps + 1


def test_comparator_against_sine_reference_converges_second_order():
    # vm_buck.cir with the ramp replaced by a sine between the same levels: inputs inside a
    # step are then interpolated quadratically (midpoint values), so the located instants and
    # the states after them stay second order.
    txt = (CL / "vm_buck.cir").read_text().replace(
        "Vramp ramp 0 PULSE({vl} {vu} 0 {tp-2*tf} {tf} {tf} {tp})",
        "Vramp ramp 0 SIN({(vl+vu)/2} {(vu-vl)/2} {1/tp})")
    s = transient_setup(parse_string(txt))
    x0 = np.array([0.55, 11.8])
    T = 400e-6
    ts = np.array([3.0e-4, 5.0e-4])  # after the first and the second switching

    def run(h):
        r = simulate(s.system, s.signals, x0, 2 * T, h, probes=["i(L1)", "v(C1)"], save_at=ts)
        assert r.ok and r.stats.located == len(r.events) == 4
        return np.array([t for t, _ in r.events]), r.y[np.isin(r.t, ts)]

    t_ref, y_ref = run(T / 3200)
    e_t, e_y = [], []
    for div in (100, 200, 400):
        t, y = run(T / div)
        e_t.append(np.abs(t - t_ref).max())
        e_y.append(np.abs(y - y_ref).max())
    order = np.log2(np.array(e_y[:-1]) / np.array(e_y[1:]))
    assert np.all(order > 1.85), e_y
    assert e_t[-1] < 1e-9 and e_t[-1] < e_t[0] / 8, e_t


def test_two_comparators_two_phase_buck():
    s = transient_setup(parse_file(CL / "two_phase_buck.cir"))
    T = 20e-6
    res = simulate(s.system, s.signals, s.x0, 4e-3, T / 50, probes=["v(out)", "i(L1)", "i(L2)"],
                   save_at=T * np.arange(150, 201))
    assert res.ok and res.switching == {"S1": "implicit", "S2": "implicit"}
    assert len(res.stats.__dict__) and res.stats.modes_built == 4
    # Steady state: both phases switch twice per period. (Their currents need not be equal:
    # with ideal parts nothing damps the current circulating between the phases.)
    late = [(t, md) for t, md in res.events if t > 3e-3]
    per_phase = [sum(1 for i in range(1, len(late)) if late[i][1][k] != late[i - 1][1][k])
                 for k in range(2)]
    n_per = (4e-3 - 3e-3) / T
    assert all(abs(c - 2 * n_per) <= 3 for c in per_phase), per_phase
    v = res["v(out)"][np.isin(res.t, T * np.arange(150, 201))]
    assert np.ptp(v[-10:]) < 1e-6 * v.mean()  # period 1
