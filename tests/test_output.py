"""Output of ``pelcs simulate``: the ``.tran TSTEP`` grid by default, every step
on request, and the writers (CSV, NPZ, Parquet) against independent readers."""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest

from lcs.results import SimulationResult, output_times, resample
from pelcs.cli import main
from pelcs.writers import write_csv, write_npz, write_parquet, write_result

SIM = Path(__file__).parent / "netlists" / "sim"
BOOST = str(SIM / "boost_dcm.cir")  # .tran 0.2u 20m 0 0.2u
BUCK = str(SIM / "buck_ccm.cir")


def _result(t, y, names=("v(out)", "i(L1)")) -> SimulationResult:
    t = np.asarray(t, dtype=float)
    return SimulationResult(t=t, names=tuple(names), y=np.asarray(y, dtype=float),
                            x_final=np.zeros(1), lambda_final=np.zeros(0),
                            notes=["a note, with a comma"])


def test_output_times_are_multiples_of_the_spacing_and_end_at_the_last_time():
    assert np.array_equal(output_times(0.0, 1.0, 0.25), [0, 0.25, 0.5, 0.75, 1.0])
    # TSTART between grid points: the grid starts at the next multiple; a stop time that is
    # no multiple is written as the last point (ngspice writes TSTOP too).
    assert np.allclose(output_times(0.1, 0.9, 0.25), [0.25, 0.5, 0.75, 0.9])
    # 16 ms at 0.2 us: round-off in k dt does not lose or duplicate the last point.
    t = output_times(0.0, 16e-3, 0.2e-6)
    assert len(t) == 80001 and t[-1] == 16e-3 and np.all(np.diff(t) > 0)
    with pytest.raises(ValueError, match="positive"):
        output_times(0.0, 1.0, 0.0)


def test_resample_is_exact_on_stored_steps_and_linear_between():
    # Steps at 0, 0.1, 0.2, 0.25 (an event), 0.3, ... of y = t^2: on stored steps the value is
    # the step's own, between them the chord.
    t = np.array([0.0, 0.1, 0.2, 0.25, 0.3, 0.4, 0.5])
    y = np.column_stack([t ** 2, -t])
    r = resample(_result(t, y), 0.2)
    assert np.allclose(r.t, [0.0, 0.2, 0.4, 0.5])
    assert np.array_equal(r.y, y[[0, 2, 5, 6]])
    r = resample(_result(t, y), 0.15)
    assert np.allclose(r.t, [0.0, 0.15, 0.3, 0.45, 0.5])
    assert r.y[1, 0] == pytest.approx((0.01 + 0.04) / 2)
    assert r.y[3, 0] == pytest.approx((0.16 + 0.25) / 2)
    assert r.names == ("v(out)", "i(L1)") and r.notes == ["a note, with a comma"]


def test_resample_equals_numpy_interp_column_by_column():
    # Random stored instants, some repeated (a switching stores two rows at one instant:
    # np.interp takes the later), random spacings: the same numbers as np.interp, bit for bit.
    rng = np.random.default_rng(7)
    for trial in range(100):
        n = int(rng.integers(2, 60))
        t = np.sort(rng.uniform(0.0, 1.0, n))
        t[0] = 0.0
        if trial % 3 == 0 and n > 3:
            t[2] = t[1]
        q = 3 if trial % 2 else 12  # (np.interp itself up to 8 columns, vectorised beyond)
        y = rng.normal(size=(n, q))
        dt = float(rng.uniform(0.01, 0.3))
        r = resample(_result(t, y, names=tuple(f"p{k}" for k in range(q))), dt)
        ref = np.column_stack([np.interp(r.t, t, y[:, j]) for j in range(q)])
        assert np.array_equal(r.y, ref)
    # Non-finite values (a run that blew up) follow np.interp's rules too.
    t = np.linspace(0.0, 1.0, 7)
    y = rng.normal(size=(7, 12))
    y[2, 3], y[4, 5], y[5, 6] = np.inf, -np.inf, np.nan
    r = resample(_result(t, y, names=tuple(f"p{k}" for k in range(12))), 0.07)
    ref = np.column_stack([np.interp(r.t, t, y[:, j]) for j in range(12)])
    assert np.array_equal(r.y, ref, equal_nan=True)
    # The output grid is the step grid: the stored rows themselves.
    t = np.arange(11) * 0.1
    y = np.column_stack([t, t ** 2])
    r = resample(_result(t, y), 0.1)
    assert r.y is y or np.array_equal(r.y, y)


def test_resample_in_blocks_equals_numpy_interp(monkeypatch):
    # The vectorised path interpolates a block of output rows at a time; with blocks of 1, 2
    # and 3 rows (a last block short, repeated stored instants at block edges) the numbers are
    # still np.interp's, bit for bit.
    import lcs.results

    rng = np.random.default_rng(11)
    for block in (12, 25, 36):  # (1, 2 and 3 rows of 12 probes)
        monkeypatch.setattr(lcs.results, "_RESAMPLE_BLOCK", block)
        for _ in range(30):
            n = int(rng.integers(3, 80))
            t = np.sort(rng.uniform(0.0, 1.0, n))
            t[0] = 0.0
            t[n // 2] = t[n // 2 - 1]
            y = rng.normal(size=(n, 12))
            r = resample(_result(t, y, names=tuple(f"p{k}" for k in range(12))),
                         float(rng.uniform(0.005, 0.2)))
            ref = np.column_stack([np.interp(r.t, t, y[:, j]) for j in range(12)])
            assert np.array_equal(r.y, ref)


def test_csv_is_numpy_savetxt_text(tmp_path):
    rng = np.random.default_rng(1)
    t = np.sort(rng.random(9000)) * 1e-3
    y = rng.normal(size=(9000, 2)) * [1e3, 1e-9]
    y[5, 0], y[6, 1], y[7, 1] = np.nan, np.inf, -0.0
    r = _result(t, y, names=("v(out)", "v(a,b)"))
    buf = io.StringIO()
    np.savetxt(buf, np.column_stack([t, y]), fmt="%.10g", delimiter=",")
    path = write_csv(r, tmp_path / "r.csv")
    text = path.read_text()
    assert text == 'time,v(out),"v(a,b)"\n' + buf.getvalue()


def test_npz_and_parquet_round_trip(tmp_path):
    pd = pytest.importorskip("pandas")
    t = np.linspace(0, 1e-3, 101)
    r = _result(t, np.column_stack([np.sin(t * 1e4), np.cos(t * 1e4)]))
    d = np.load(write_npz(r, tmp_path / "r.npz"))
    assert np.array_equal(d["t"], t) and np.array_equal(d["v(out)"], r.y[:, 0])
    assert list(d["names"]) == ["v(out)", "i(L1)"] and str(d["error"]) == ""
    df = pd.read_parquet(write_parquet(r, tmp_path / "r.parquet"))
    assert list(df.columns) == ["time", "v(out)", "i(L1)"]
    assert np.array_equal(df["time"].to_numpy(), t)
    assert np.array_equal(df["i(L1)"].to_numpy(), r.y[:, 1])
    import pyarrow.parquet as pq

    meta = pq.read_schema(tmp_path / "r.parquet").metadata
    assert b"a note, with a comma" in meta[b"pelcs.notes"]
    with pytest.raises(ValueError, match="use .csv, .npz, .parquet"):
        write_result(r, tmp_path / "r.txt")


@pytest.mark.parametrize("compress", [False, True])
def test_npz_is_numpys_archive_member_for_member(tmp_path, compress, monkeypatch):
    # The writer transposes a block of probes at a time (here 120 probes of 100 points over
    # a 40 kB buffer: three blocks, the last one short); its archive must be the one numpy
    # writes, the same members with the same bytes. (The buffer, 4 MB in use, is shrunk with
    # the data: 10 MB of random doubles took seconds to compress twice.)
    from pelcs import writers

    monkeypatch.setattr(writers._probe_columns, "__defaults__", (40_000,))
    rng = np.random.default_rng(7)
    t = np.linspace(0.0, 1e-3, 100)
    names = tuple(f"v(n{i})" for i in range(120))
    r = _result(t, rng.standard_normal((100, 120)), names=names)
    ours = np.load(write_npz(r, tmp_path / "ours.npz", compress=compress))
    save = np.savez_compressed if compress else np.savez
    save(tmp_path / "numpy.npz", t=t, y=r.y, names=np.array(names, dtype=str),
         notes=np.array(r.notes, dtype=str), error=np.array(""),
         **{n: np.ascontiguousarray(r.y[:, j]) for j, n in enumerate(names)})
    ref = np.load(tmp_path / "numpy.npz")
    assert ours.files == ref.files
    for key in ref.files:
        assert ours.zip.read(key + ".npy") == ref.zip.read(key + ".npy"), key


def test_npz_without_points_or_probes(tmp_path):
    for t, y, names in [(np.zeros(0), np.zeros((0, 2)), ("v(out)", "i(L1)")),
                        (np.linspace(0, 1, 5), np.zeros((5, 0)), ())]:
        d = np.load(write_npz(_result(t, y, names=names), tmp_path / "e.npz"))
        assert d["y"].shape == y.shape and list(d["names"]) == list(names)
        assert all(d[n].shape == (len(t),) for n in names)


def test_command_writes_the_tran_tstep_grid_by_default(tmp_path, capsys):
    # buck_ccm: .tran 0.1u ... with the step TMAX; ask for a step of 0.05 us: the file still
    # holds the TSTEP grid, like ngspice's, and its values are those of the steps there.
    out_default, out_all = tmp_path / "d.npz", tmp_path / "a.npz"
    assert main(["simulate", BOOST, "--tstop", "0.2m", "--step", "0.05u", "-o",
                 str(out_default)]) == 0
    text = capsys.readouterr().out
    assert main(["simulate", BOOST, "--tstop", "0.2m", "--step", "0.05u", "--all-steps", "-o",
                 str(out_all)]) == 0
    text_all = capsys.readouterr().out
    d, a = np.load(out_default), np.load(out_all)
    assert np.allclose(d["t"], np.arange(1001) * 0.2e-6, rtol=0, atol=1e-15)
    assert "(1001 points, every 200 ns (.tran TSTEP; --all-steps writes all " in text
    assert len(a["t"]) > 4000 and "every step)" in text_all
    # (The PULSE edges shift the step grid by 10 ns: every TSTEP instant falls between steps.)
    # The chord of the stored steps.
    for j in range(2):
        assert np.allclose(np.interp(d["t"], a["t"], a["y"][:, j]), d["y"][:, j], atol=1e-12)


def test_command_output_step_and_every(tmp_path, capsys):
    out = tmp_path / "r.csv"
    assert main(["simulate", BOOST, "--tstop", "0.2m", "--output-step", "1u", "-o",
                 str(out)]) == 0
    assert "(201 points, every 1 µs (--output-step; " in capsys.readouterr().out
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert np.allclose(data[:, 0], np.arange(201) * 1e-6, rtol=0, atol=1e-15)
    assert main(["simulate", BOOST, "--tstop", "0.2m", "--every", "10", "-o", str(out)]) == 0
    assert "every 10th step" in capsys.readouterr().out
    assert main(["simulate", BOOST, "--tstop", "0.2m", "--every", "2", "--output-step", "1u"]
                ) == 2
    err = capsys.readouterr().err
    assert "--output-step and --all-steps/--every both choose the points" in err
    assert main(["simulate", BOOST, "--tstop", "0.2m", "--output-step=-1u"]) == 2
    assert "--output-step -1u: must be positive" in capsys.readouterr().err
    assert main(["simulate", BOOST, "--tstop", "0.2m", "-o", str(tmp_path / "r.xlsx")]) == 2
    assert ".csv or .npz or .parquet" in capsys.readouterr().err


def test_command_parquet_output(tmp_path, capsys):
    pd = pytest.importorskip("pandas")
    out = tmp_path / "r.parquet"
    assert main(["simulate", BUCK, "--tstop", "50u", "--probe", "v(out),i(L1)", "-o",
                 str(out)]) == 0
    df = pd.read_parquet(out)
    assert list(df.columns) == ["time", "v(out)", "i(L1)"] and len(df) > 10
