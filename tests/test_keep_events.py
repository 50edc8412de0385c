"""A run that keeps only its last switchings (``keep_events``): the same run, whose events are
the tail of the full run's, with the earlier ones counted, so that a long run's memory does
not grow with its switchings."""

from __future__ import annotations

import numpy as np
import pytest

import pelcs
from lcs.results import Events
from lcs.simulation import recorder
from pelcs.cli import main

PATHS = ["converters/netlists/buck.cir", "converters/netlists/vm_buck.cir",
         "converters/netlists/boost_smc.cir", "tests/netlists/closed_loop/sync_buck.cir"]


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("block", [3, recorder.EVENT_BLOCK])
def test_the_last_switchings_kept_are_the_full_runs_last(path, block, monkeypatch):
    whole = pelcs.simulate(path, check=False)
    monkeypatch.setattr(recorder, "EVENT_BLOCK", block)
    tail = pelcs.simulate(path, check=False, keep_events=5)
    n = len(whole.events)
    assert n > 10
    assert isinstance(tail.events, Events) and len(tail.events) == 5
    assert tail.events == whole.events[n - 5:]
    assert tail.events.earlier == n - 5 and tail.events.count == n
    assert tail.switchings == whole.switchings == n
    assert tail.stats.intervals == whole.stats.intervals
    assert tail.modes_visited == whole.modes_visited
    assert tail.sliding == whole.sliding
    assert np.array_equal(tail.t, whole.t) and np.array_equal(tail.y, whole.y)


def test_keeping_more_than_the_run_has_keeps_them_all():
    path = PATHS[0]
    assert pelcs.simulate(path, keep_events=10**6).events == pelcs.simulate(path).events


def test_keep_events_must_be_positive():
    with pytest.raises(ValueError, match="keep_events"):
        pelcs.simulate(PATHS[0], keep_events=0)


def test_the_summary_counts_every_switching(monkeypatch, capsys):
    # (pelcs simulate keeps the last EVENTS_KEPT switchings; the summary counts all of them)
    from pelcs.commands import simulate as command

    full = pelcs.simulate(PATHS[0]).switchings
    monkeypatch.setattr(command, "EVENTS_KEPT", 7)
    assert main(["simulate", PATHS[0], "--no-progress"]) == 0
    assert f"; {full} switching events" in capsys.readouterr().out


def test_sliced_events_count_what_precedes_them():
    ev = Events(np.array([1.0, 2.0, 3.0]), np.array([0, 1, 0], np.int32),
                ((True,), (False,)), earlier=4)
    assert ev.count == 7 and ev[1:].earlier == 5 and ev[:2].earlier == 4
    assert ev[1:].count == 7 and ev[:2].count == 6
    assert "the last 3 of 7" in repr(ev)
    assert ev != Events(ev.t, ev.index, ev.modes)


def test_the_last_sliding_intervals_kept_are_the_full_runs_last(monkeypatch):
    # The sliding-mode boost with a square current reference (1 A and 3 A, 2 ms period):
    # the surface is left at every step of the reference and reached again, two sliding
    # intervals a period, the last one still open at the end.
    from pathlib import Path

    text = Path("tests/netlists/closed_loop/boost_smc.cir").read_text().replace(
        "Viref ref 0 DC {-iref}", "Viref ref 0 PULSE(-1 -3 2m 1u 1u 1m 2m)")
    whole = pelcs.simulate(text, check=False)
    assert len(whole.sliding) > 20 and whole.sliding[-1][2] is None
    monkeypatch.setattr(recorder, "EVENT_BLOCK", 3)
    tail = pelcs.simulate(text, check=False, keep_events=4)
    assert tail.sliding == whole.sliding[-4:]
    assert tail.events == whole.events[len(whole.events) - 4:]


def test_paired_sliding_intervals_are_cut_at_the_runs_end():
    # Records paired as they came (keep_events), then a run whose end comes before some of
    # them (a run cut short): an interval ending after the end is open there, a start after
    # it did not happen.
    from lcs.simulation.codes import EV_SLIDE_END, EV_SLIDE_START

    rec = recorder.Recorder(("x",), 4, 4, np.array([-1]), keep_events=1)
    rec._slide_parts = [(np.array([1.0, 2.0, 3.0, 4.0, 6.0]),
                         np.array([EV_SLIDE_START, EV_SLIDE_END, EV_SLIDE_START, EV_SLIDE_END,
                                   EV_SLIDE_START], np.int64))]
    rec.keep_events = 2
    rec._pair_slides()
    assert rec._slides == [(0, 1.0, 2.0), (0, 3.0, 4.0)] and rec._slide_open == {0: 6.0}
    _, sliding, _ = rec.events(["S1"], (False,), 3.5)
    assert sliding == [("S1", 1.0, 2.0), ("S1", 3.0, None)]
    _, sliding, _ = rec.events(["S1"], (False,), 10.0)
    assert sliding == [("S1", 3.0, 4.0), ("S1", 6.0, None)]  # (the last two kept)
