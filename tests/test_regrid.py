"""A run's output grid computed as the run goes (lcs.simulation.regrid): the numbers of
lcs.results.resample at the end of the run, bit for bit, and a memory that does not grow with
the run's length."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_inductor_cutsets import RL_SWITCH

import lcs.simulation.recorder as recorder_module
from lcs.integrators.moreau.integrator import MoreauOptions
from lcs.results import resample, resample_arrays
from lcs.simulation.regrid import Regrid
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import simulate_circuit
from pelcs.cli import main

NETLISTS = Path(__file__).parent.parent / "converters" / "netlists"
BUCK = NETLISTS / "buck.cir"  # source-driven PWM, 50 kHz, h = 0.2 us
VM_BUCK = NETLISTS / "vm_buck.cir"  # comparator PWM: instants located inside steps


def _blocks(rng, n):
    cuts = np.sort(rng.integers(0, n + 1, int(rng.integers(0, 10))))
    edges = [0, *cuts.tolist(), n]
    return list(zip(edges[:-1], edges[1:], strict=True))


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_regrid_in_blocks_is_resample_bit_for_bit():
    # Random stored instants (repeated ones: a switching stores two rows at one instant),
    # rows on the output grid (the shortcut that returns them unchanged), rows within
    # round-off of the grid and of its last instant, a start time, non-finite values, few
    # and many columns: any cut into blocks gives resample's arrays exactly.
    rng = np.random.default_rng(5)
    for trial in range(1500):
        n = int(rng.integers(1, 200))
        kind = trial % 5
        dt = float(rng.uniform(0.003, 0.2))
        if kind == 0:
            t = np.sort(rng.uniform(0.0, 1.0, n))
        elif kind == 1:
            t = np.sort(np.round(rng.uniform(0.0, 1.0, n), 2))
        elif kind == 2:  # the output grid itself, the last row possibly off it
            dt = 0.01
            t = np.arange(n) * dt
            if n > 2 and trial % 2:
                t[-1] = t[-2] + 0.003
        elif kind == 3:  # within a few 1e-9 dt of the grid
            dt = 0.01
            t = np.sort(np.arange(n) * dt + rng.choice([-3, -1, 0, 1, 3], n) * 4e-10 * dt)
        else:
            t = np.cumsum(rng.uniform(0.0, 0.02, n)) + 0.3
        t[0] = max(t[0], 0.0) if kind != 4 else t[0]
        q = 3 if trial % 2 else 12
        y = rng.normal(size=(n, q))
        if trial % 40 == 0:
            y[n // 2, 0] = np.nan
        t_from = float(rng.uniform(0.0, 0.5)) if trial % 7 == 0 else -np.inf
        keep = t >= t_from
        g = Regrid(dt, q, t_from)
        for a, b in _blocks(rng, n):
            g.take(t[a:b], y[a:b])
        ot, oy = g.finish()
        if not keep.any():
            assert ot.size == 0 and oy.shape == (0, q)
            continue
        rt, ry = resample_arrays(t[keep], y[keep], dt)
        assert np.array_equal(ot, rt)
        assert np.array_equal(oy, ry, equal_nan=True)
        assert g.kept == keep.sum()


def _same_as_resampled(circuit, dt, **kw):
    full = simulate_circuit(circuit, **kw)
    went = simulate_circuit(circuit, output_step=dt, **kw)
    ref = resample(full, dt)
    assert np.array_equal(went.t, ref.t)
    assert np.array_equal(went.y, ref.y)
    assert went.events == full.events
    assert went.stats.points_stored == len(full.t)
    return full, went


@pytest.mark.parametrize("dt", [1.3e-5, 1e-4])
def test_buck_resampled_as_it_goes_is_resampled_at_the_end(dt):
    # 1.3e-5 s: the PWM's switching instants fall inside the output intervals.
    full, went = _same_as_resampled(parse_file(BUCK), dt, tstop=4e-3)
    assert len(went.t) < len(full.t) / 10


def test_comparator_every_and_sparse_kernel_resampled_as_they_go():
    # Comparator switchings located inside steps (rows at the instants), every 3rd step,
    # the sparse kernel (its carried products would change at round-off if a chunk were cut:
    # the recorder makes room for the whole chunk).
    _same_as_resampled(parse_file(VM_BUCK), 3.3e-5, tstop=4e-3)
    _same_as_resampled(parse_file(BUCK), 1.3e-5, tstop=4e-3, every=3)
    full, _ = _same_as_resampled(parse_file(BUCK), 7e-6, tstop=3e-3,
                                 options=MoreauOptions(kernel="sparse", chunk_steps=4000))
    assert full.stats.kernel == "sparse"


def small_blocks(monkeypatch, rows: int = 40) -> None:
    """Recorders whose buffers hold ``rows`` rows: the kernel returns STEP_FULL mid-chunk
    and hands its rows over many times in a run."""
    init = recorder_module.Recorder.__init__

    def small(self, *a, **k):
        init(self, *a, **k)
        self.block = rows

    monkeypatch.setattr(recorder_module.Recorder, "__init__", small)
    monkeypatch.setattr(recorder_module.Recorder, "room", lambda self, rows: None)


def test_tiny_blocks_and_tstart(monkeypatch):
    # Blocks of 40 rows (the kernel returns STEP_FULL mid-chunk, hands its rows over, goes
    # on) and a .tran TSTART: still resample's numbers.
    small_blocks(monkeypatch)
    _same_as_resampled(parse_file(VM_BUCK), 2.1e-5, tstop=3e-3)
    text = BUCK.read_text().replace(".tran 0.2u 5m 0 0.2u UIC", ".tran 0.2u 3m 1.03m 0.2u UIC")
    full, went = _same_as_resampled(parse_string(text), 1.1e-5)
    assert went.t[0] >= 1.03e-3 and full.t[0] >= 1.03e-3
    assert went.stats.peak_rows < 200


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_memory_does_not_grow_with_the_run():
    # The same number of output points from a run ten times longer: the rows held at once
    # are the same (a kernel call's worth), where keeping every step holds ten times more.
    c = parse_file(BUCK)
    short = simulate_circuit(c, tstop=8e-3, output_step=8e-5)
    long = simulate_circuit(c, tstop=80e-3, output_step=8e-4)
    assert len(short.t) == len(long.t) == 101
    assert long.stats.points_stored > 9 * short.stats.points_stored
    assert long.stats.peak_rows == short.stats.peak_rows
    assert long.stats.peak_rows <= 2 * MoreauOptions().chunk_steps
    every_step = simulate_circuit(c, tstop=80e-3)
    assert every_step.stats.peak_rows > 10 * long.stats.peak_rows
    # --every N with N ten times larger: the rows of its output, as many.
    short = simulate_circuit(c, tstop=8e-3, every=400)
    long = simulate_circuit(c, tstop=80e-3, every=4000)
    assert abs(len(long.t) - len(short.t)) <= 2
    assert long.stats.peak_rows == short.stats.peak_rows < 500


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_exact_method_and_all_steps_unchanged(tmp_path):
    # The exact method resamples its own points at the end, as before; --all-steps writes
    # every stored step; the CLI's default grid is the resampled every-step run.
    c = parse_file(BUCK)
    exact = simulate_circuit(c, tstop=1e-3, method="exact")
    ex = simulate_circuit(c, tstop=1e-3, method="exact", output_step=3e-6)
    ref = resample(exact, 3e-6)
    assert np.array_equal(ex.t, ref.t) and np.array_equal(ex.y, ref.y)
    out_all, out_grid = tmp_path / "all.npz", tmp_path / "grid.npz"
    assert main(["simulate", str(BUCK), "--tstop", "2m", "--all-steps", "-o", str(out_all),
                 "--no-progress"]) == 0
    assert main(["simulate", str(BUCK), "--tstop", "2m", "--output-step", "13u", "-o",
                 str(out_grid), "--no-progress"]) == 0
    a, g = np.load(out_all), np.load(out_grid)
    full = simulate_circuit(parse_file(BUCK), tstop=2e-3)
    assert np.array_equal(a["t"], full.t)
    ref = resample(full, 13e-6)
    assert np.array_equal(g["t"], ref.t)
    for j, name in enumerate(full.names):
        assert np.array_equal(g[name], ref.y[:, j])


def test_api_output_step():
    import pelcs

    res = pelcs.simulate(str(BUCK), tstop="2m", output_step="10u")
    every = pelcs.simulate(str(BUCK), tstop="2m")
    ref = resample(every, 10e-6)
    assert np.array_equal(res.t, ref.t) and np.array_equal(res.y, ref.y)
    assert res.stats.points_stored == len(every.t)
    with pytest.raises(ValueError, match="positive"):
        pelcs.simulate(str(BUCK), tstop="2m", output_step=-1.0)


def test_a_system_that_pins_states_keeps_every_row_and_resamples_at_the_end():
    # An inductor opened by a switch: a jump found after the run could cut its end, so every
    # row is kept (peak_rows: all of them) and the grid is taken at the end, the same numbers.
    full, went = _same_as_resampled(parse_string(RL_SWITCH), 3.3e-6, step=1e-7)
    assert went.stats.peak_rows >= len(full.t)


def test_an_interrupted_run_keeps_its_grid_up_to_where_it_stopped(monkeypatch):
    # A Ctrl-C answered at the fourth kernel call: the grid up to the last completed step,
    # the same as the interrupted run's every step resampled.
    import signal

    import lcs.interrupt

    def interrupted_at_call(n):
        calls = iter(range(10 ** 9))
        return lambda: signal.SIGINT if next(calls) >= n else None

    c = parse_file(BUCK)
    opts = MoreauOptions(chunk_steps=3000)
    monkeypatch.setattr(lcs.interrupt, "requested", interrupted_at_call(3))
    full = simulate_circuit(c, tstop=4e-3, options=opts)
    monkeypatch.setattr(lcs.interrupt, "requested", interrupted_at_call(3))
    went = simulate_circuit(c, tstop=4e-3, options=opts, output_step=1.3e-5)
    assert full.error.kind == went.error.kind == "interrupted"
    assert 0 < went.t[-1] == full.t[-1] < 4e-3
    ref = resample(full, 1.3e-5)
    assert np.array_equal(went.t, ref.t) and np.array_equal(went.y, ref.y)


def test_the_run_size_check_counts_the_output_grid(monkeypatch):
    # 1e7 steps of two probes: every step is 480 MB of rows, the 1001-point grid a block's
    # worth; under a 64 MB limit the first is refused before any work, the second runs.
    from netlist.errors import NetlistError
    from netlist.studies.transient import check_run_size, transient_setup

    monkeypatch.setenv("PELCS_MAX_MEMORY", "64M")
    setup = transient_setup(parse_file(BUCK), tstop=2.0)
    with pytest.raises(NetlistError, match="memory"):
        check_run_size(setup, 2)
    check_run_size(setup, 2, output_step=2e-3)
