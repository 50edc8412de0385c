"""A run whose comparators chatter at the deck's step is taken again on finer grids until
two agree (:mod:`netlist.studies.finer_step`)."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from lcs.results import SimulationError
from netlist.parser import parse_file
from netlist.studies.finer_step import AGREEMENT, finer_on_chattering
from netlist.studies.realistic import simulate_devices

RING = (Path(__file__).parent / "corpus" / "ngspice" / "examples" / "p-to-n-examples"
        / "switch-oscillators.cir")


def _run(level: float, chatter: bool = False):
    """A fake run: one probe oscillating between 0 and 2 around ``level``."""
    t = np.linspace(0.0, 1.0, 401)
    y = (level + np.sin(40 * np.pi * t))[:, None]
    err = SimulationError("chatters", kind="chattering", time=0.5, t_prev=0.4,
                          switch="S1") if chatter else None
    return SimpleNamespace(t=t, y=y, names=("v(a)",), error=err, notes=[])


def test_the_result_is_the_finer_of_two_runs_that_agree():
    levels = {None: None, 0.1: 1.3, 0.01: 1.02, 0.001: 1.0}
    calls = []

    def run(step):
        calls.append(step)
        return _run(1.0, chatter=True) if step is None else _run(levels[step])

    res = finer_on_chattering(run, 1.0, 1.0)
    # 0.1 and 0.01 differ by 0.28 of the range (2): refined once more; 0.01 and 0.001 agree
    assert calls == [None, 0.1, 0.01, 0.001]
    assert res.y[0, 0] == pytest.approx(1.0)
    assert "switch S1 chattered at the deck's step 1 s" in res.notes[0]
    assert "the runs at 0.01 s and 0.001 s agree" in res.notes[0]


def test_runs_that_never_agree_within_the_budget_leave_the_error_and_say_not_converged():
    def run(step):
        return _run(1.0, chatter=True) if step is None else _run(1.0 / step)

    res = finer_on_chattering(run, 1.0, 1000.0)  # the budget allows 1e-3 s steps at most
    assert "NOT CONVERGED" in res.notes[0] and "0.1 s, 0.01 s, 0.001 s" in res.notes[0]
    # no answer established: the first run, stopped by its error (the command exits 1)
    assert res.error is not None and res.error.kind == "chattering"
    assert AGREEMENT < 0.05


def test_a_run_that_does_not_chatter_is_the_result_as_it_is():
    calls = []

    def run(step):
        calls.append(step)
        return _run(1.0)

    res = finer_on_chattering(run, 1.0, 1.0)
    assert calls == [None] and res.notes == []


@pytest.mark.slow  # (two runs of the ring, about 1.5 s)
def test_ngspices_ring_of_switch_inverters_runs_on_a_finer_grid():
    # '.tran 10n 80n 50p': the step is ngspice's bound 1.6 ns, eight times the inverters'
    # RC; at 0.16 ns and 16 ps the mean of v(osc_out) over the second half is 1.526 V and
    # 1.514 V, ngspice's 1.528 V (the corpus test runs ngspice on it)
    res = simulate_devices(parse_file(RING), devices="pwl", probes=["v(osc_out)"])
    assert res.error is None
    assert any("chattered at the deck's step 1.599e-09 s" in n and "agree" in n
               for n in res.notes)
    t, y = np.asarray(res.t), np.asarray(res["v(osc_out)"])
    keep = t >= 40e-9
    mean = np.trapezoid(y[keep], t[keep]) / (t[keep][-1] - t[keep][0])
    assert mean == pytest.approx(1.528, rel=0.02)


@pytest.mark.slow
def test_a_step_the_user_gives_is_not_refined():
    res = simulate_devices(parse_file(RING), devices="pwl", probes=["v(osc_out)"],
                           step=1.6e-9)
    assert res.error is not None and res.error.kind == "chattering"
    assert not any("finer grids" in n for n in res.notes)
