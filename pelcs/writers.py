"""Files of results: CSV, NPZ and Parquet, chosen by the file's extension.

One writer, :func:`write_table` (a table of named columns; :func:`write_arrays` its NPZ
archive), writes every result file of pelcs: a run's waveforms (:func:`write_result`), and
the tables the analyses' results give as plain data (a sweep's ``columns()``, a bifurcation
diagram's ``columns()`` and ``arrays()``, the basins' ``arrays()``), which the commands and
the Python API write; the mathematics (``lcs``) writes no file. A run's file written as the
run goes is :func:`open_stream`'s.

Each is written whole or not at all (:func:`lcs.atomic.atomic_path`): a full disk or a
Ctrl-C during the write leaves an earlier file of the same name as it was.

The writers must not dominate a run: measured on 83,201 points of 3 columns
(``benchmarks/bench_command.py``), numpy's ``savetxt`` took 0.22 s, the block formatting of
:func:`write_csv` 0.045 s (same text), an uncompressed NPZ a few ms and Parquet (pyarrow,
zstd) about 0.02 s plus pyarrow's import. On 40,001 points of 400 probes (a 200-stage
voltage multiplier's states) :func:`write_npz` takes 0.34 s against 0.53 s when the probes'
columns came from one transposed copy of the results (see :func:`_probe_columns`).
"""

from __future__ import annotations

import csv
import os
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from lcs.atomic import atomic_path
from lcs.results import SimulationResult

__all__ = ["FORMATS", "ResultStream", "npz_name", "open_stream", "result_columns",
           "write_arrays", "write_basins", "write_bifurcation", "write_csv", "write_lcs_npz",
           "write_npz", "write_parquet", "write_result", "write_sweep", "write_table"]

#: File extensions the writers know, in the order the help lists them.
FORMATS = (".csv", ".npz", ".parquet")

# 10 significant digits: below the accuracy of any run, and a quarter smaller files than
# repr precision.
_DIGITS = 10
# Rows formatted per string operation: large enough to amortise Python's per-call cost,
# small enough to keep the temporary strings in cache.
_BLOCK = 4096


# ---------------------------------------------------------------------------------------------
# The one writer: a table of named columns, by extension


def write_table(path: str | os.PathLike, columns: Mapping[str, ArrayLike], *,
                meta: Mapping[str, str] | None = None, digits: int | None = _DIGITS,
                npz: Iterable[tuple[str, ArrayLike]] | None = None, compress: bool = False,
                format: str | None = None) -> Path:
    """Write a table of named columns as CSV, NPZ or Parquet, chosen by the extension of
    ``path`` (or ``format``), whole or not at all (:func:`lcs.atomic.atomic_path`).

    Every result file of pelcs goes through this function (or :func:`write_arrays`, its NPZ
    archive): a run's waveforms (:func:`write_result`), a sweep's table, a bifurcation
    diagram, the basins, a frequency response; only the files written as a run goes
    (:func:`open_stream`) are written a block at a time.

    Parameters
    ----------
    path : str or os.PathLike
    columns : mapping of str to array, each of shape (N,)
        The columns in order. Floats (SI units), integers, booleans (written 1 or 0 in CSV)
        or objects (strings; ``None`` is an empty CSV field).
    meta : mapping of str to str, optional
        Parquet: the file's key-value metadata. NPZ: one string member each, after the
        columns. CSV: not written (the format has no place for it).
    digits : int or None
        CSV: significant digits of the floats (``%.{digits}g``); None writes the shortest
        text that reads back as the same float (``repr``).
    npz : iterable of (str, array), optional
        The NPZ archive's members instead of the columns and ``meta`` (a run's archive holds
        ``t``, ``y``, ``names``...; see :func:`write_npz`). Consumed lazily: a member may be
        a buffer the iterable overwrites for the next one.
    compress : bool
        NPZ: deflate the members (``numpy.savez_compressed``).
    format : {".csv", ".npz", ".parquet"}, optional
        The format whatever the extension (default: the extension's).

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        An extension (or ``format``) not in :data:`FORMATS`.
    """
    suffix = (format or Path(path).suffix).lower()
    if suffix == ".csv":
        return _write_csv_table(Path(path), columns, digits)
    if suffix == ".npz":
        if npz is None:
            npz = [*columns.items(), *((k, np.array(v)) for k, v in (meta or {}).items())]
        return write_arrays(path, npz, compress=compress)
    if suffix == ".parquet":
        return _write_parquet_table(Path(path), columns, meta or {})
    raise _unknown_format(suffix)


def _unknown_format(suffix: str) -> ValueError:
    return ValueError(f"unknown output format {suffix or '(no extension)'!r}: use "
                      f"{', '.join(FORMATS)}")


def write_arrays(path: str | os.PathLike, arrays: Iterable[tuple[str, ArrayLike]]
                 | Mapping[str, ArrayLike], *, compress: bool = False) -> Path:
    """Write a NumPy ``.npz`` archive, member for member the one ``numpy.savez`` writes
    (``numpy.savez_compressed`` with ``compress``), whole or not at all.

    ``arrays`` is consumed lazily, one member written before the next is asked for; it holds
    no object arrays (the archive is read with ``allow_pickle=False``).
    """
    import zipfile  # (only NPZ output needs it)

    out = Path(path)
    items = arrays.items() if isinstance(arrays, Mapping) else arrays
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with atomic_path(out) as tmp, zipfile.ZipFile(tmp, "w", method, allowZip64=True) as archive:
        for key, value in items:
            with archive.open(key + ".npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=False)
    return out


def npz_name(path: str | os.PathLike) -> Path:
    """``path`` with ``.npz`` added when it has not that extension, as ``numpy.savez`` names
    its files (the analyses' archives keep that name)."""
    name = os.fspath(path)
    return Path(name if name.endswith(".npz") else name + ".npz")


def _write_csv_table(out: Path, columns: Mapping[str, ArrayLike], digits: int | None) -> Path:
    arrays = [np.asarray(c) for c in columns.values()]
    with atomic_path(out) as tmp, open(tmp, "w", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(list(columns))
        if digits is not None and arrays and all(a.dtype.kind == "f" for a in arrays):
            _csv_rows(fh, np.column_stack(arrays) if len(arrays[0])
                      else np.empty((0, len(arrays))), digits)
        elif arrays:
            writer.writerows(zip(*(_csv_cells(a, digits) for a in arrays), strict=True))
    return out


def _csv_rows(fh, data: np.ndarray, digits: int = _DIGITS) -> None:
    """Rows of floats (``data``: shape (N, columns)), a block at a time: the text of
    ``numpy.savetxt(fmt="%.{digits}g", delimiter=",")``, 5 times faster."""
    row = ",".join([f"%.{digits}g"] * data.shape[1]) + "\n"
    for i in range(0, len(data), _BLOCK):
        block = data[i:i + _BLOCK]
        fh.write((row * len(block)) % tuple(block.ravel().tolist()))


def _csv_cells(column: np.ndarray, digits: int | None) -> list[str]:
    """The CSV text of one column's values (see :func:`write_table`)."""
    def number(v: float) -> str:
        return repr(float(v)) if digits is None else f"%.{digits}g" % v

    kind = column.dtype.kind
    values = column.tolist()
    if kind == "f":
        return [number(v) for v in values]
    if kind == "b":
        return ["1" if v else "0" for v in values]
    if kind in "iu":
        return [str(v) for v in values]
    return ["" if v is None else "1" if v is True else "0" if v is False
            else number(v) if isinstance(v, float) else str(v) for v in values]


def _write_parquet_table(out: Path, columns: Mapping[str, ArrayLike],
                         meta: Mapping[str, str]) -> Path:
    """An Apache Parquet table (pyarrow, zstd), ``meta`` as its key-value metadata."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    def array(c):
        c = np.asarray(c)
        return pa.array(np.ascontiguousarray(c) if c.dtype.kind in "fiub" else c.tolist())

    table = pa.table({name: array(c) for name, c in columns.items()})
    table = table.replace_schema_metadata(dict(meta))
    with atomic_path(out) as tmp:
        pq.write_table(table, tmp, compression="zstd")
    return out


# ---------------------------------------------------------------------------------------------
# A simulation's result


def result_columns(result: SimulationResult) -> dict[str, np.ndarray]:
    """``time`` (s) and one float column per probe (SI units): the table of the run's CSV and
    Parquet files."""
    t = np.asarray(result.t, dtype=float)
    y = np.asarray(result.y, dtype=float).reshape(len(t), len(result.names))
    return {"time": t, **{name: y[:, j] for j, name in enumerate(result.names)}}


def _result_npz(result: SimulationResult) -> Iterator[tuple[str, ArrayLike]]:
    """The members of a run's archive (see :func:`write_npz`), the probes' columns last."""
    y = np.asarray(result.y)
    yield "t", result.t
    yield "y", y
    yield from _run_info(result.names, result)
    columns = _probe_columns(y.reshape(len(result.t), len(result.names)))
    yield from zip(result.names, columns, strict=True)


def _run_info(names, result: SimulationResult) -> Iterator[tuple[str, np.ndarray]]:
    """The members of a run's archive after ``t`` and ``y``: ``names``, ``notes``,
    ``error``."""
    yield "names", np.array(names, dtype=str)
    yield "notes", np.array(result.notes, dtype=str)
    yield "error", np.array(result.error.message if result.error is not None else "")


def write_csv(result: SimulationResult, path: str | os.PathLike) -> Path:
    """Write ``time,<probe>,...`` rows in SI units (s, V, A), 10 significant digits.

    A probe name with a comma (``v(a,b)``) is quoted in the header, as CSV requires. The rows
    are the text of ``numpy.savetxt(fmt="%.10g", delimiter=",")``.
    """
    return write_table(path, result_columns(result), format=".csv")


def _csv_header(fh, names) -> None:
    csv.writer(fh, lineterminator="\n").writerow(["time", *names])


def write_npz(result: SimulationResult, path: str | os.PathLike, compress: bool = False
              ) -> Path:
    """Write a NumPy ``.npz`` archive of the run (uncompressed unless ``compress``).

    Keys: ``t`` (s), ``y`` (shape (N, q)), ``names`` (probe names, the columns of ``y``),
    one array per probe under its name (``data["v(out)"]``), ``notes``, and ``error`` (the
    error message, empty for a complete run). The archive is the one ``numpy.savez`` writes
    (``numpy.savez_compressed`` with ``compress``), member for member.
    """
    return write_arrays(path, _result_npz(result), compress=compress)


def _probe_columns(y: np.ndarray, block_bytes: int = 4 << 20):
    """The columns of ``y`` (N, q), each contiguous, transposed a block of probes at a time
    into one reused buffer of ``block_bytes``.

    Transposing the whole of ``y`` at once takes as much fresh memory as the results, and
    the kernel zeroes every new page of it (64 MB for 200 probes of 40,001 points); a strided
    column goes through numpy's slower buffered copy. Each yielded row is overwritten by the
    next block: write it before asking for the next one.
    """
    n, q = y.shape
    b = max(1, min(q, block_bytes // max(1, y.dtype.itemsize * n)))
    buf = np.empty((b, n), dtype=y.dtype)
    for k in range(0, q, b):
        kb = min(b, q - k)
        np.copyto(buf[:kb], y[:, k:k + kb].T)
        yield from buf[:kb]


def write_parquet(result: SimulationResult, path: str | os.PathLike) -> Path:
    """Write an Apache Parquet table (pyarrow, zstd): a ``time`` column (s) and one float64
    column per probe (SI units), with the notes and the error message in the file's
    key-value metadata (``pelcs.notes`` as JSON, ``pelcs.error``).

    ``pandas.read_parquet(path)`` gives the same frame as ``result.to_pandas()`` with
    ``time`` as a column.
    """
    return write_table(path, result_columns(result), meta=_parquet_metadata(result),
                       format=".parquet")


def _parquet_metadata(result: SimulationResult) -> dict[str, str]:
    """The notes (JSON) and the error message, as the file's key-value metadata."""
    import json

    return {"pelcs.notes": json.dumps(list(result.notes)),
            "pelcs.error": result.error.message if result.error is not None else ""}


def write_result(result: SimulationResult, path: str | os.PathLike) -> Path:
    """Write a result as CSV, NPZ or Parquet, chosen by the extension of ``path``
    (:func:`write_csv`, :func:`write_npz`, :func:`write_parquet`).

    Raises
    ------
    ValueError
        For any other extension.
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".parquet":
        return write_table(path, result_columns(result), meta=_parquet_metadata(result))
    return write_table(path, result_columns(result), npz=_result_npz(result))


# ---------------------------------------------------------------------------------------------
# The analyses' results: their plain data (``columns()``, ``arrays()``), written here


def write_sweep(table, path: str | os.PathLike) -> Path:
    """A sweep or Monte Carlo table (:class:`lcs.analysis.tables.SweepTable`) as CSV,
    whatever the extension: one row per run, its :meth:`~lcs.analysis.tables.SweepTable.columns`,
    the numbers in full precision (``repr``), ``ok`` and ``settled`` 1 or 0 (``settled``
    empty for a failed run)."""
    return write_table(path, table.columns(), digits=None, format=".csv")


def write_bifurcation(diagram, path: str | os.PathLike, npz: bool | None = None) -> Path:
    """A bifurcation diagram (:class:`lcs.analysis.bifurcation.BifurcationDiagram`): its
    ``arrays()`` as a compressed NPZ when ``path`` ends in ``.npz`` (or ``npz``; ``.npz``
    added to a name without it, as numpy does), else its ``columns()`` as CSV (one row per
    recorded sample, full precision)."""
    if npz if npz is not None else Path(path).suffix.lower() == ".npz":
        return write_arrays(npz_name(path), diagram.arrays(), compress=True)
    return write_table(path, diagram.columns(), digits=None, format=".csv")


def write_basins(basins, path: str | os.PathLike) -> Path:
    """Basins of attraction (:class:`lcs.analysis.basins.BasinMap`): its ``arrays()`` as a
    compressed NPZ (``.npz`` added to a name without it, as numpy does)."""
    return write_arrays(npz_name(path), basins.arrays(), compress=True)


def write_lcs_npz(path: str | os.PathLike, obj, probes=(), modes=None) -> Path:
    """An LCS or a switched LCS as ``.npz`` (:func:`lcs.export.to_arrays`; read back by
    :func:`lcs.export.load_npz`), uncompressed, ``.npz`` added to a name without it."""
    from lcs.export import to_arrays

    return write_arrays(npz_name(path), to_arrays(obj, probes, modes))


# Rows a stream gathers before it writes them (a Parquet row group; the CSV text and the raw
# NPZ columns are written in such blocks too): 64k rows of 1 + q float64 columns.
_STREAM_ROWS = 1 << 16


class ResultStream:
    """A result file written as the run goes (:func:`open_stream`): the output rows are
    written in blocks as the run makes them (:class:`lcs.simulation.driver.RowStream`), and
    the file is renamed onto its name by :meth:`close` once complete, as the writers above
    write it whole (:func:`lcs.atomic.atomic_path`). The same file as
    :func:`write_result` of the held result.

    A write that fails (a full disk) stops the writing and removes the temporary file; the
    run goes on, and :meth:`close` raises the error. :meth:`abort` removes the temporary file
    (a run that could not be streamed: its result is then written whole).

    Attributes
    ----------
    path : Path
    rows : int
        Rows received.
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.rows = 0
        self.names: tuple[str, ...] = ()
        self._target = None
        self._tmp: Path | None = None
        self._error: OSError | None = None
        self._t: list[np.ndarray] = []
        self._y: list[np.ndarray] = []
        self._held = 0
        self._sides: list[Path] = []
        self._sidedir: Path | None = None

    def open(self, names: tuple[str, ...]) -> None:
        """Start the file (a temporary one beside ``path``) with the probe names."""
        self.names = tuple(names)
        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            target = atomic_path(self.path)
            self._tmp = target.__enter__()
        except OSError as exc:
            self._error = exc  # (raised by close: the run goes on)
            return
        self._target = target
        self._guard(self._start)

    def write(self, t: np.ndarray, y: np.ndarray) -> None:
        """The next rows: times (s, shape (N,)) and probes (shape (N, q)); copied."""
        self.rows += len(t)
        if self._error is not None or not len(t):
            return
        self._t.append(np.array(t, dtype=float))
        self._y.append(np.array(y, dtype=float).reshape(len(t), len(self.names)))
        self._held += len(t)
        if self._held >= _STREAM_ROWS:
            self._guard(self._flush)

    def close(self, result: SimulationResult) -> Path:
        """Finish the file with ``result``'s notes and error and rename it onto ``path``.

        Raises
        ------
        OSError
            A write that failed on the way (the target is left as it was).
        """
        try:
            if self._error is None:
                self._guard(self._flush)
            if self._error is None:
                self._guard(lambda: self._finish(result))
        except BaseException:  # (a second Ctrl-C while the file is finished: none left)
            self.abort()
            raise
        if self._error is not None:
            raise self._error
        self._target.__exit__(None, None, None)
        self._target = None
        return self.path

    def abort(self) -> None:
        """Remove the temporary file; the target is left as it was."""
        if self._target is not None:
            self._discard()
            self._target.__exit__(RuntimeError, RuntimeError("aborted"), None)
            self._target = None

    def _guard(self, step) -> None:
        try:
            step()
        except OSError as exc:
            self._error = exc
            self.abort()

    def _side(self, suffix: str) -> Path:
        """A file for the rows before the target is finished: beside the temporary file, or
        in a temporary folder of its own when the target is a device written in place (such
        as /dev/null); removed by :meth:`_discard_sides`."""
        if self._tmp == self.path:
            if self._sidedir is None:
                import tempfile

                self._sidedir = Path(tempfile.mkdtemp(prefix="pelcs-rows-"))
            side = self._sidedir / ("rows" + suffix)
        else:
            side = self._tmp.with_name(self._tmp.name + suffix)
        self._sides.append(side)
        return side

    def _discard_sides(self) -> None:
        for side in self._sides:
            side.unlink(missing_ok=True)
        self._sides = []
        if self._sidedir is not None:
            self._sidedir.rmdir()
            self._sidedir = None

    def _take(self) -> np.ndarray:
        """The rows gathered, as ``time,<probe>...`` columns (shape (N, 1 + q))."""
        data = np.empty((self._held, 1 + len(self.names)))
        i = 0
        for t, y in zip(self._t, self._y, strict=True):
            data[i:i + len(t), 0] = t
            data[i:i + len(t), 1:] = y
            i += len(t)
        self._t, self._y, self._held = [], [], 0
        return data

    # (each format: the start, a block of rows, the end, what an abort leaves)
    def _start(self) -> None:
        raise NotImplementedError

    def _flush(self) -> None:
        raise NotImplementedError

    def _finish(self, result: SimulationResult) -> None:
        raise NotImplementedError

    def _discard(self) -> None:
        pass


class _CsvStream(ResultStream):
    def _start(self) -> None:
        self._fh = open(self._tmp, "w", newline="")
        _csv_header(self._fh, self.names)

    def _flush(self) -> None:
        if self._held:
            _csv_rows(self._fh, self._take())

    def _finish(self, result: SimulationResult) -> None:
        self._fh.close()

    def _discard(self) -> None:
        fh = getattr(self, "_fh", None)
        if fh is not None:
            fh.close()


class _NpzStream(ResultStream):
    """The times and rows go to two raw files beside the target as they come; :meth:`close`
    copies them into the archive a block at a time (the probes' columns too)."""

    def _start(self) -> None:
        self._raw = [self._side(k) for k in (".t", ".y")]
        self._fh = [open(p, "wb") for p in self._raw]

    def _flush(self) -> None:
        if self._held:
            data = self._take()
            self._fh[0].write(np.ascontiguousarray(data[:, 0]).tobytes())
            self._fh[1].write(np.ascontiguousarray(data[:, 1:]).tobytes())

    def _finish(self, result: SimulationResult) -> None:
        import zipfile

        for fh in self._fh:
            fh.close()
        n, q = self.rows, len(self.names)
        block = max(1, (4 << 20) // (8 * max(q, 1)))  # (rows of 4 MB)
        with zipfile.ZipFile(self._tmp, "w", zipfile.ZIP_STORED, allowZip64=True) as archive:
            def member(key: str):
                return archive.open(key + ".npy", "w", force_zip64=True)

            def raw(key: str, path: Path, shape: tuple, width: int = 1,
                    column: int | None = None) -> None:
                # (the header numpy writes, then the data a block of rows at a time)
                with member(key) as out, open(path, "rb") as src:
                    np.lib.format.write_array_header_1_0(out, {
                        "descr": np.lib.format.dtype_to_descr(np.dtype(float)),
                        "fortran_order": False, "shape": shape})
                    for i in range(0, n, block):
                        rows = np.fromfile(src, float, min(block, n - i) * width)
                        if column is not None:
                            rows = np.ascontiguousarray(rows.reshape(-1, width)[:, column])
                        out.write(rows.tobytes())

            def put(key: str, value) -> None:
                with member(key) as out:
                    np.lib.format.write_array(out, np.asanyarray(value), allow_pickle=False)

            raw("t", self._raw[0], (n,))
            raw("y", self._raw[1], (n, q), q)
            for key, value in _run_info(self.names, result):
                put(key, value)
            for j, name in enumerate(self.names):
                raw(name, self._raw[1], (n,), q, j)
        self._discard()

    def _discard(self) -> None:
        for fh in getattr(self, "_fh", ()):
            fh.close()
        self._discard_sides()


class _ParquetStream(ResultStream):
    """The rows go to a Parquet file beside the target as they come, a row group at a time;
    :meth:`close` copies its row groups into the target under the schema that carries the
    notes and the error (known only then), as :func:`write_parquet` writes them: readers
    take the key-value metadata from that schema (``pq.read_table(path).schema.metadata``),
    not from the file's footer alone."""

    def _start(self) -> None:
        import pyarrow as pa
        import pyarrow.parquet as pq

        self._pa = pa
        self._schema = pa.schema([(name, pa.float64()) for name in ("time", *self.names)])
        self._raw = self._side(".rows")
        self._writer = pq.ParquetWriter(self._raw, self._schema, compression="zstd")

    def _flush(self) -> None:
        if self._held:
            data = self._take()
            pa = self._pa
            self._writer.write_table(pa.table(
                {name: pa.array(np.ascontiguousarray(data[:, j]))
                 for j, name in enumerate(("time", *self.names))}, schema=self._schema))

    def _finish(self, result: SimulationResult) -> None:
        import pyarrow.parquet as pq

        self._writer.close()
        schema = self._schema.with_metadata(_parquet_metadata(result))
        rows = pq.ParquetFile(self._raw)
        with pq.ParquetWriter(self._tmp, schema, compression="zstd") as out:
            for i in range(rows.num_row_groups):
                out.write_table(rows.read_row_group(i).replace_schema_metadata(
                    schema.metadata))
            if not rows.num_row_groups:
                out.write_table(schema.empty_table())
        rows.close()
        self._discard()

    def _discard(self) -> None:
        writer = getattr(self, "_writer", None)
        if writer is not None and writer.is_open:
            writer.close()
        self._discard_sides()


def open_stream(path: str | os.PathLike) -> ResultStream:
    """A :class:`ResultStream` for ``path``, its format chosen by the extension as
    :func:`write_result` chooses it.

    Raises
    ------
    ValueError
        For any other extension.
    """
    streams = {".csv": _CsvStream, ".npz": _NpzStream, ".parquet": _ParquetStream}
    suffix = Path(path).suffix.lower()
    if suffix not in streams:
        raise _unknown_format(suffix)
    return streams[suffix](path)
