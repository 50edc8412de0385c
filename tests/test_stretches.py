"""A long run planned a stretch at a time (:func:`lcs.simulation.schedule.plan_run`) and its
event records compacted as they come (:class:`lcs.simulation.recorder.Recorder`): the same
results as the run in one piece, with stretches and blocks made tiny here so that every run
is cut many times."""

from __future__ import annotations

import numpy as np
import pytest

import pelcs
from lcs.results import Events
from lcs.simulation import driver, recorder, schedule

# bundled converters run in stretches (2.8 s): in the full suite, not the fast subset
pytestmark = pytest.mark.slow

ROOT = "converters/netlists/"
# (the bridge rectifier and the sliding-mode boost, whose sources have no breakpoints, are
# one stretch however long)
SOURCE_DRIVEN = ["buck.cir", "boost.cir", "boost_dcm.cir", "cuk.cir", "prc.cir",
                 "vm_buck.cir"]


def _run(path: str):
    return pelcs.simulate(path, check=False)


@pytest.fixture
def counted(monkeypatch):
    """The stretches each run is planned in: ``[(t0, t1), ...]``."""
    seen: list[tuple[float, float]] = []
    plan = schedule.plan_run

    def counting(*args, **kwargs):
        for part in plan(*args, **kwargs):
            seen.append((part.t0, part.t1))
            yield part

    monkeypatch.setattr(driver, "plan_run", counting)
    return seen


def _same(a, b) -> None:
    assert np.array_equal(a.t, b.t)
    assert np.array_equal(a.y, b.y)
    assert a.events == b.events and a.sliding == b.sliding
    assert a.modes_visited == b.modes_visited
    assert np.array_equal(a.x_final, b.x_final)


@pytest.mark.parametrize("name", SOURCE_DRIVEN)
def test_a_run_in_stretches_is_the_run_in_one_piece(name, counted, monkeypatch):
    whole = _run(ROOT + name)
    assert len(counted) == 1
    counted.clear()
    monkeypatch.setattr(schedule, "STRETCH_STEPS", 97)
    cut = _run(ROOT + name)
    # (consecutive stretches from the start to the stop)
    assert len(counted) > 3
    assert counted[0][0] == 0.0 and counted[-1][1] == pytest.approx(whole.t[-1])
    assert all(a[1] == b[0] for a, b in zip(counted, counted[1:], strict=False))
    _same(whole, cut)


def test_comparator_instants_in_stretches_agree_to_round_off(monkeypatch):
    # Located comparator instants are searched afresh where a kernel call starts: a run cut
    # in stretches differs from one in one piece at round-off only.
    path = "tests/netlists/closed_loop/two_phase_buck.cir"
    whole = _run(path)
    monkeypatch.setattr(schedule, "STRETCH_STEPS", 97)
    cut = _run(path)
    assert len(whole.t) == len(cut.t) and len(whole.events) == len(cut.events)
    assert np.max(np.abs(whole.t - cut.t)) < 1e-12
    assert np.max(np.abs(whole.y - cut.y)) < 1e-8 * np.max(np.abs(whole.y))


@pytest.mark.parametrize("path", [ROOT + "boost_smc.cir", ROOT + "vm_buck.cir",
                                  "tests/netlists/closed_loop/relaxation.cir",
                                  "tests/netlists/closed_loop/sync_buck.cir"])
def test_event_records_compacted_in_blocks_give_the_same_events(path, monkeypatch):
    whole = _run(path)
    monkeypatch.setattr(recorder, "EVENT_BLOCK", 3)
    small = pelcs.simulate(path, check=False)
    _same(whole, small)
    assert isinstance(small.events, Events)


def test_events_read_as_a_list_of_pairs():
    ev = Events(np.array([1.0, 2.0, 3.0]), np.array([0, 1, 0], np.int32),
                ((True,), (False,)))
    assert ev == [(1.0, (True,)), (2.0, (False,)), (3.0, (True,))]
    assert ev[-1] == (3.0, (True,)) and ev[1:] == [(2.0, (False,)), (3.0, (True,))]
    assert len(ev[:0]) == 0 and ev[:0] == []
    assert [t for t, _ in ev] == [1.0, 2.0, 3.0]
    assert ev != [(1.0, (True,))]
