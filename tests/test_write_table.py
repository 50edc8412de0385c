"""The one writer of result tables (pelcs.writers.write_table, write_arrays): CSV, NPZ and
Parquet by extension, each file whole or not at all, and the text of every column kind."""

from __future__ import annotations

import csv
import zipfile

import numpy as np
import pytest

from pelcs.writers import npz_name, write_arrays, write_table


def _columns():
    return {"name": np.array(["up", "a, b", "down"], dtype=object),
            "p": np.array([0.1, 1 / 3, -2.5e-7]),
            "k": np.arange(3),
            "ok": np.array([True, False, True]),
            "settled": np.array([True, None, False], dtype=object)}


def test_csv_text_of_every_column_kind(tmp_path):
    path = write_table(tmp_path / "t.csv", _columns(), digits=None)
    assert path.read_text() == ("name,p,k,ok,settled\n"
                                "up,0.1,0,1,1\n"
                                '"a, b",0.3333333333333333,1,0,\n'
                                "down,-2.5e-07,2,1,0\n")
    # repr: every float reads back as itself
    rows = list(csv.DictReader(path.open(newline="")))
    assert [float(r["p"]) for r in rows] == [0.1, 1 / 3, -2.5e-7]


def test_csv_of_floats_has_the_digits_asked(tmp_path):
    cols = {"time": np.array([0.0, 1 / 3]), "v(a,b)": np.array([np.pi, -np.inf])}
    text = write_table(tmp_path / "f.csv", cols).read_text()
    assert text == '"time","v(a,b)"\n0,3.141592654\n0.3333333333,-inf\n'.replace(
        '"time"', "time")
    text = write_table(tmp_path / "g.csv", cols, digits=4).read_text()
    assert text.splitlines()[1:] == ["0,3.142", "0.3333,-inf"]
    # no rows: the header alone
    empty = {"time": np.empty(0), "x": np.empty(0)}
    assert write_table(tmp_path / "e.csv", empty).read_text() == "time,x\n"


def test_npz_members_are_the_columns_then_the_meta(tmp_path):
    cols = {"t": np.array([0.0, 1.0]), "k": np.arange(2)}
    path = write_table(tmp_path / "a.npz", cols, meta={"note": "hello"})
    with np.load(path, allow_pickle=False) as data:
        assert list(data) == ["t", "k", "note"]
        assert np.array_equal(data["t"], cols["t"]) and data["k"].dtype == np.int64
        assert str(data["note"]) == "hello"


def test_write_arrays_is_numpy_savez_member_for_member(tmp_path):
    arrays = {"a": np.arange(6.0).reshape(2, 3), "s": np.array("text"),
              "names": np.array(["x", "y"])}
    for compress, save in ((False, np.savez), (True, np.savez_compressed)):
        ours = write_arrays(tmp_path / f"ours{compress}.npz", arrays, compress=compress)
        theirs = tmp_path / f"numpy{compress}.npz"
        save(theirs, **arrays)
        za, zb = zipfile.ZipFile(ours), zipfile.ZipFile(theirs)
        assert za.namelist() == zb.namelist()
        for k in za.namelist():
            assert za.read(k) == zb.read(k)
            assert za.getinfo(k).compress_type == zb.getinfo(k).compress_type
    assert npz_name(tmp_path / "d") == tmp_path / "d.npz"
    assert npz_name(tmp_path / "d.npz") == tmp_path / "d.npz"


def test_parquet_keeps_the_meta(tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")
    cols = {"time": np.array([0.0, 1.0]), "x": np.array([2.0, 3.0])}
    path = write_table(tmp_path / "a.parquet", cols, meta={"pelcs.error": "none"})
    table = pq.read_table(path)
    assert table.column_names == ["time", "x"]
    assert table.schema.metadata[b"pelcs.error"] == b"none"
    assert table.column("x").to_pylist() == [2.0, 3.0]


def test_format_overrides_the_extension_and_unknown_is_refused(tmp_path):
    cols = {"x": np.array([1.5])}
    assert write_table(tmp_path / "t.dat", cols, format=".csv").read_text() == "x\n1.5\n"
    with pytest.raises(ValueError, match="unknown output format '.txt'"):
        write_table(tmp_path / "t.txt", cols)


def test_a_failed_write_leaves_the_earlier_file(tmp_path):
    target = tmp_path / "t.csv"
    target.write_text("good\n")

    class Boom:
        def __str__(self):  # (fails while the rows are written)
            raise OSError(28, "No space left on device")

    bad = {"s": np.array(["a", Boom()], dtype=object)}
    with pytest.raises(OSError):
        write_table(target, bad)
    assert target.read_text() == "good\n"
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]


def test_the_analyses_tables_as_they_were_written(tmp_path):
    # The text the sweep and bifurcation writers wrote before they moved to pelcs, but for
    # the line ends (one CSV dialect: "\n").
    from lcs.analysis.bifurcation import BifurcationDiagram, SweepBranch
    from lcs.analysis.tables import SweepTable
    from pelcs.writers import write_bifurcation, write_sweep

    table = SweepTable(inputs=("duty", "run"), input_values=np.array([[0.3, 0], [0.3, 1]]),
                       measures=("mean(v(out))",), values=np.array([[2 / 3], [np.nan]]),
                       ok=np.array([True, False]), messages=["", 'failed: "x", y'])
    assert write_sweep(table, tmp_path / "s.csv").read_text() == (
        "duty,run,mean(v(out)),ok,settled,message\n"
        "0.3,0,0.6666666666666666,1,1,\n"
        '0.3,1,nan,0,,"failed: ""x"", y"\n')
    up = SweepBranch("up", np.array([0.1, 0.2]), np.arange(4.0).reshape(2, 2, 1) / 3,
                     np.zeros((2, 1)), np.array([True, True]))
    d = BifurcationDiagram("vin", ("v(out)",), ("x",), 5, 2, False, [up])
    assert write_bifurcation(d, tmp_path / "d.csv").read_text() == (
        "direction,vin,k,v(out)\n"
        "up,0.1,0,0.0\nup,0.1,1,0.3333333333333333\n"
        "up,0.2,0,0.6666666666666666\nup,0.2,1,1.0\n")
    path = write_bifurcation(d, tmp_path / "d", npz=True)
    assert path.name == "d.npz"
    with np.load(path, allow_pickle=False) as z:
        np.testing.assert_array_equal(z["up_samples"], up.samples)
        assert str(z["param_name"]) == "vin" and list(z["directions"]) == ["up"]
