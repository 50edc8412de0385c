"""A result file written as the run goes (:func:`pelcs.writers.open_stream` handed to the run
as ``rows_to``): the same file as the result held whole and written at the end, while the
run holds neither its steps nor its output rows."""

from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from test_regrid import small_blocks

from lcs.simulation import regrid
from netlist.parser import parse_file
from netlist.studies.transient import run_setup, transient_setup
from pelcs.cli import main
from pelcs.writers import open_stream, write_result

# the bundled converters streamed to files (3.3 s): in the full suite, not the fast subset
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
BUCK = str(ROOT / "converters/netlists/buck.cir")          # .tran TSTEP = the step
VM_BUCK = str(ROOT / "converters/netlists/vm_buck.cir")    # comparator: rows off the grid
TUNNEL = str(ROOT / "tests/netlists/sim/tunnel_nonpassive.cir")


def _both(path: str, tmp: Path, suffix: str, monkeypatch, **kw):
    """The file of the run streamed, and of the run held whole, and the two results."""
    small_blocks(monkeypatch)  # (the rows reach the stream in many blocks)
    setup = transient_setup(parse_file(path))
    held = run_setup(setup, **kw)
    a = tmp / f"held{suffix}"
    write_result(held, a)
    stream = open_stream(tmp / f"streamed{suffix}")
    monkeypatch.setattr("pelcs.writers._STREAM_ROWS", 5)
    streamed = run_setup(transient_setup(parse_file(path)), rows_to=stream, **kw)
    assert streamed.stats.points_streamed >= 0
    b = stream.close(streamed)
    return a, b, held, streamed


CASES = [
    (BUCK, {"output_step": "tran"}),          # the output grid is the step grid
    (BUCK, {"output_step": 3.3e-6}),          # interpolated onto another grid
    (VM_BUCK, {"output_step": 1e-6}),         # located switchings between the steps
    (BUCK, {"every": 3}),                     # every third step, no output grid
    (VM_BUCK, {}),                            # every step and the switching instants
]


@pytest.mark.parametrize(("path", "kw"), CASES)
def test_the_streamed_csv_is_the_held_results(path, kw, tmp_path, monkeypatch):
    a, b, held, streamed = _both(path, tmp_path, ".csv", monkeypatch, **kw)
    assert a.read_bytes() == b.read_bytes()
    assert streamed.stats.points_streamed == len(held.t) > 100
    # the result holds the last row only
    assert len(streamed.t) == 1 and streamed.t[-1] == held.t[-1]
    assert np.array_equal(streamed.y[-1], held.y[-1])
    assert streamed.notes == held.notes
    assert not list(tmp_path.glob(".*"))  # (no temporary file left)


@pytest.mark.parametrize(("path", "kw"), CASES[:3])
def test_the_streamed_npz_and_parquet_are_the_held_results(path, kw, tmp_path, monkeypatch):
    a, b, held, _ = _both(path, tmp_path, ".npz", monkeypatch, **kw)
    assert a.read_bytes() == b.read_bytes()
    a, b, held, _ = _both(path, tmp_path, ".parquet", monkeypatch, **kw)
    ta, tb = pq.read_table(a), pq.read_table(b)
    assert ta.equals(tb)
    # (the notes and the error where readers look: the schema's metadata; it was None)
    assert tb.schema.metadata == ta.schema.metadata
    meta = pq.read_metadata(b).metadata
    assert meta[b"pelcs.notes"] == ta.schema.metadata[b"pelcs.notes"]
    assert not list(tmp_path.glob(".*"))


@pytest.mark.filterwarnings("ignore::lcs.notices.NonPassiveWarning")
def test_the_growth_note_of_a_streamed_run_is_the_held_runs(tmp_path, monkeypatch):
    a, b, held, streamed = _both(TUNNEL, tmp_path, ".csv", monkeypatch)
    assert a.read_bytes() == b.read_bytes()
    note = [n for n in held.notes if "grew by a factor" in n]
    assert note and note == [n for n in streamed.notes if "grew by a factor" in n]


def test_the_regrid_hands_on_only_finished_rows():
    # 0..10 s stored every 0.5 s, read on a 1 s grid: rows come out as soon as a later
    # stored row bounds them, and all of them once finished
    seen = []
    g = regrid.Regrid(1.0, 1, emit=lambda t, y: seen.append((t.copy(), y.copy())))
    t = np.arange(0, 10.01, 0.5) + 0.25
    t[0] = 0.0
    g.take(t[:7], t[:7, None] * 2)
    assert np.concatenate([s[0] for s in seen]).tolist() == [0.0, 1.0, 2.0, 3.0]
    g.take(t[7:], t[7:, None] * 2)
    last = g.finish()
    out = np.concatenate([s[0] for s in seen])
    assert out.tolist() == [*map(float, range(11)), 10.25]
    assert np.allclose(np.concatenate([s[1] for s in seen])[:, 0], 2 * out)
    assert last[0].tolist() == [10.25] and g.written == 12


def test_cli_streams_its_file_and_counts_its_points(tmp_path, capsys):
    out = tmp_path / "sub" / "run.csv"
    assert main(["simulate", BUCK, "--tstop", "1m", "--every", "4", "-o", str(out),
                 "--no-progress"]) == 0
    text = capsys.readouterr().out
    rows = out.read_text().count("\n") - 1
    assert f"wrote {out} ({rows} points, every 4th step)" in text
    assert rows == 5200 // 4 + 1


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".parquet"])
def test_a_full_disk_is_an_error_and_the_summary_prints(suffix, tmp_path, capsys):
    if not os.path.exists("/dev/full"):
        pytest.skip("no /dev/full")
    full = tmp_path / f"full{suffix}"
    full.symlink_to("/dev/full")  # (every write to it fails with ENOSPC)
    code = main(["simulate", BUCK, "--tstop", "2m", "-o", str(full), "--no-progress"])
    out, err = capsys.readouterr()
    assert code != 0 and f"cannot write {full}" in err and "disk is full" in err
    assert "final values" in out


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".parquet"])
@pytest.mark.parametrize("failure", [ValueError("a mode's set-up failed"), KeyboardInterrupt()])
def test_an_earlier_file_survives_a_run_that_fails_while_streaming(suffix, failure, tmp_path,
                                                                   monkeypatch, capsys):
    import netlist.studies.transient as transient

    out = tmp_path / f"run{suffix}"
    out.write_text("earlier\n")

    def failing(setup, rows_to=None, **kw):
        rows_to.open(("v(a)",))
        rows_to.write(np.zeros(3), np.zeros((3, 1)))
        raise failure

    monkeypatch.setattr(transient, "run_setup", failing)
    try:
        code = main(["simulate", BUCK, "-o", str(out), "--no-progress"])
    except KeyboardInterrupt:
        code = 130
    assert code in (2, 130) and out.read_text() == "earlier\n"
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # (no temporary file left)


def test_tstart_rows_are_dropped_in_the_stream(tmp_path, monkeypatch):
    text = Path(BUCK).read_text().replace(".tran 0.2u 5m 0 0.2u UIC",
                                           ".tran 0.2u 3m 1.03m 0.2u UIC")
    path = tmp_path / "late.cir"
    path.write_text(text)
    for kw in ({"output_step": 1.1e-5}, {"every": 2}):
        a, b, held, streamed = _both(str(path), tmp_path, ".csv", monkeypatch, **kw)
        assert a.read_bytes() == b.read_bytes()
        assert held.t[0] >= 1.03e-3


def test_the_run_size_check_counts_a_streamed_run_as_a_block(monkeypatch):
    # 1e7 steps of two probes written every step: 480 MB of rows held, a block's worth
    # streamed; under a 64 MB limit the first is refused before any work, the second runs.
    from netlist.errors import NetlistError
    from netlist.studies.transient import check_run_size

    monkeypatch.setenv("PELCS_MAX_MEMORY", "64M")
    setup = transient_setup(parse_file(BUCK), tstop=2.0)
    with pytest.raises(NetlistError, match="memory"):
        check_run_size(setup, 2)
    check_run_size(setup, 2, streamed=True)


def test_the_growth_note_of_a_run_stopped_early_is_the_held_ones(tmp_path, monkeypatch):
    # The growing tunnel circuit stopped by an interrupt at about 1 ms of 5 ms: the note's
    # reference is the largest magnitude in the first tenth of the rows made (0.1 ms), not
    # of the asked run (0.5 ms, a reference e^10 larger: a factor 1.05e9 was printed
    # instead of 8.22e14, and an earlier stop lost the note)
    from lcs import interrupt

    def stopped(rows_to):
        calls = [0]

        def requested():
            calls[0] += 1
            return signal.SIGINT if calls[0] > 30 else None

        monkeypatch.setattr(interrupt, "requested", requested)
        with pytest.warns(UserWarning):
            setup = transient_setup(parse_file(TUNNEL), tstop=5e-3, step=1e-9)
        return run_setup(setup, rows_to=rows_to, output_step="tran")

    held = stopped(None)
    stream = open_stream(tmp_path / "tunnel.npz")
    streamed = stopped(stream)
    stream.close(streamed)
    assert held.error.kind == streamed.error.kind == "interrupted"
    assert streamed.stats.points_streamed > 0 and held.t[-1] == streamed.t[-1] < 2e-3
    note = [n for n in held.notes if "grew by a factor" in n]
    assert note and note == [n for n in streamed.notes if "grew by a factor" in n]
    with np.load(tmp_path / "tunnel.npz") as data:
        assert note[0] in data["notes"].tolist()


@pytest.mark.parametrize("suffix", [".csv", ".npz", ".parquet"])
def test_a_stream_stopped_while_it_finishes_leaves_no_file(suffix, tmp_path, monkeypatch):
    # a second Ctrl-C while the file is completed (the NPZ copies every row once more):
    # the temporary file and the NPZ's raw rows were left beside the target
    stream = open_stream(tmp_path / f"run{suffix}")
    stream.open(("v(a)",))
    stream.write(np.arange(3.0), np.ones((3, 1)))

    def stop(result):
        raise KeyboardInterrupt

    monkeypatch.setattr(stream, "_finish", stop)
    with pytest.raises(KeyboardInterrupt):
        stream.close(None)
    assert not list(tmp_path.iterdir())


def test_a_streamed_run_of_every_step_is_held_to_a_block_by_the_size_check(
        tmp_path, capsys, monkeypatch):
    # 2.5e5 points of 2 probes held: 12 MB; streamed, a block of rows (6.3 MB). The run's
    # own check counted the held points and refused it under a 10 MB limit
    monkeypatch.setenv("PELCS_MAX_MEMORY", "10M")
    out = tmp_path / "run.npz"
    assert main(["simulate", BUCK, "--tstop", "50m", "--all-steps", "-o", str(out),
                 "--no-progress"]) == 0, capsys.readouterr().err
    with np.load(out) as data:
        assert len(data["t"]) > 250_000
    # (held, for a figure: refused, naming the limit)
    assert main(["simulate", BUCK, "--tstop", "50m", "--all-steps", "-o", str(out),
                 "--plot", str(tmp_path / "run.png"), "--no-progress"]) == 2
    assert "more than the limit of 10 MB" in capsys.readouterr().err


def test_the_summary_writes_ordinals():
    from pelcs.commands.simulate import _ordinal

    assert [_ordinal(n) for n in (2, 3, 4, 11, 12, 13, 21, 22, 101, 111)] == [
        "2nd", "3rd", "4th", "11th", "12th", "13th", "21st", "22nd", "101st", "111th"]


def test_a_run_that_fails_before_tstart_says_its_file_has_no_points(tmp_path, capsys):
    # (negative_r fails at 0.5 ms; TSTART 0.8 ms keeps nothing before that)
    deck = tmp_path / "late_fail.cir"
    deck.write_text((ROOT / "tests/netlists/sim/negative_r.cir").read_text().replace(
        ".tran 1u 1m", ".tran 1u 1m 0.8m"))
    out = tmp_path / "run.csv"
    assert main(["simulate", str(deck), "-o", str(out), "--no-progress"]) == 3
    err = capsys.readouterr().err
    assert "written with no points (the run stopped before the first point kept" in err
    assert "results up to" not in err
    assert out.read_text().count("\n") == 1  # (the header only)
