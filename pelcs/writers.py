"""Files of simulation results: CSV, NPZ and Parquet, chosen by the file's extension.

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
from pathlib import Path

import numpy as np

from lcs.atomic import atomic_path
from lcs.results import SimulationResult

__all__ = ["FORMATS", "ResultStream", "open_stream", "write_csv", "write_npz",
           "write_parquet", "write_result"]

#: File extensions the writers know, in the order the help lists them.
FORMATS = (".csv", ".npz", ".parquet")

# 10 significant digits: below the accuracy of any run, and a quarter smaller files than
# repr precision.
_DIGITS = 10
# Rows formatted per string operation: large enough to amortise Python's per-call cost,
# small enough to keep the temporary strings in cache.
_BLOCK = 4096


def _columns(result: SimulationResult) -> np.ndarray:
    if not len(result.t):
        return np.empty((0, 1 + len(result.names)))
    return np.column_stack([np.asarray(result.t, dtype=float),
                            np.asarray(result.y, dtype=float).reshape(len(result.t), -1)])


def write_csv(result: SimulationResult, path: str | os.PathLike) -> Path:
    """Write ``time,<probe>,...`` rows in SI units (s, V, A), 10 significant digits.

    A probe name with a comma (``v(a,b)``) is quoted in the header, as CSV requires. The rows
    are the text of ``numpy.savetxt(fmt="%.10g", delimiter=",")``, formatted a block of rows
    at a time (5 times faster).
    """
    out = Path(path)
    with atomic_path(out) as tmp, open(tmp, "w", newline="") as fh:
        _csv_header(fh, result.names)
        _csv_rows(fh, _columns(result))
    return out


def _csv_header(fh, names) -> None:
    csv.writer(fh, lineterminator="\n").writerow(["time", *names])


def _csv_rows(fh, data: np.ndarray) -> None:
    """Rows ``time,<probe>,...`` (``data``: shape (N, 1 + q)), a block at a time."""
    row = ",".join([f"%.{_DIGITS}g"] * data.shape[1]) + "\n"
    for i in range(0, len(data), _BLOCK):
        block = data[i:i + _BLOCK]
        fh.write((row * len(block)) % tuple(block.ravel().tolist()))


def write_npz(result: SimulationResult, path: str | os.PathLike, compress: bool = False
              ) -> Path:
    """Write a NumPy ``.npz`` archive of the run (uncompressed unless ``compress``).

    Keys: ``t`` (s), ``y`` (shape (N, q)), ``names`` (probe names, the columns of ``y``),
    one array per probe under its name (``data["v(out)"]``), ``notes``, and ``error`` (the
    error message, empty for a complete run). The archive is the one ``numpy.savez`` writes
    (``numpy.savez_compressed`` with ``compress``), member for member.
    """
    import zipfile  # (only NPZ output needs it)

    out = Path(path)
    y = np.asarray(result.y)
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with atomic_path(out) as tmp, zipfile.ZipFile(tmp, "w", method, allowZip64=True) as archive:
        def put(key: str, value) -> None:
            with archive.open(key + ".npy", "w", force_zip64=True) as member:
                np.lib.format.write_array(member, np.asanyarray(value), allow_pickle=False)

        put("t", result.t)
        put("y", y)
        put("names", np.array(result.names, dtype=str))
        put("notes", np.array(result.notes, dtype=str))
        put("error", np.array(result.error.message if result.error is not None else ""))
        columns = _probe_columns(y.reshape(len(result.t), len(result.names)))
        for name, column in zip(result.names, columns, strict=True):
            put(name, column)
    return out


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
    import pyarrow as pa
    import pyarrow.parquet as pq

    out = Path(path)
    cols = {"time": pa.array(np.asarray(result.t, dtype=float))}
    for j, name in enumerate(result.names):
        cols[name] = pa.array(np.ascontiguousarray(result.y[:, j], dtype=float))
    table = pa.table(cols).replace_schema_metadata(_parquet_metadata(result))
    with atomic_path(out) as tmp:
        pq.write_table(table, tmp, compression="zstd")
    return out


def _parquet_metadata(result: SimulationResult) -> dict[str, str]:
    """The notes (JSON) and the error message, as the file's key-value metadata."""
    import json

    return {"pelcs.notes": json.dumps(list(result.notes)),
            "pelcs.error": result.error.message if result.error is not None else ""}


def write_result(result: SimulationResult, path: str | os.PathLike) -> Path:
    """Write a result as CSV, NPZ or Parquet, chosen by the extension of ``path``.

    Raises
    ------
    ValueError
        For any other extension.
    """
    suffix = Path(path).suffix.lower()
    if suffix == ".csv":
        return write_csv(result, path)
    if suffix == ".npz":
        return write_npz(result, path)
    if suffix == ".parquet":
        return write_parquet(result, path)
    raise ValueError(f"unknown output format {suffix or '(no extension)'!r}: use "
                     f"{', '.join(FORMATS)}")


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

    def _take(self) -> tuple[np.ndarray, np.ndarray]:
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
        # (beside the temporary archive; in the temporary folder when the target is written
        # in place, a device such as /dev/null)
        if self._tmp == self.path:
            import tempfile

            self._rawdir = Path(tempfile.mkdtemp(prefix="pelcs-npz-"))
            base = self._rawdir / "rows"
        else:
            base = self._tmp
        self._raw = [base.with_name(base.name + k) for k in (".t", ".y")]
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
            put("names", np.array(self.names, dtype=str))
            put("notes", np.array(result.notes, dtype=str))
            put("error", np.array(result.error.message if result.error is not None else ""))
            for j, name in enumerate(self.names):
                raw(name, self._raw[1], (n,), q, j)
        self._discard()

    def _discard(self) -> None:
        for fh in getattr(self, "_fh", ()):
            fh.close()
        for p in getattr(self, "_raw", ()):
            p.unlink(missing_ok=True)
        if getattr(self, "_rawdir", None) is not None:
            self._rawdir.rmdir()
            self._rawdir = None


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
        if self._tmp == self.path:  # (a device written in place: the rows go elsewhere)
            import tempfile

            self._rawdir = Path(tempfile.mkdtemp(prefix="pelcs-parquet-"))
            self._raw = self._rawdir / "rows.parquet"
        else:
            self._raw = self._tmp.with_name(self._tmp.name + ".rows")
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
        raw = getattr(self, "_raw", None)
        if raw is not None:
            raw.unlink(missing_ok=True)
        if getattr(self, "_rawdir", None) is not None:
            self._rawdir.rmdir()
            self._rawdir = None


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
        raise ValueError(f"unknown output format {suffix or '(no extension)'!r}: use "
                         f"{', '.join(FORMATS)}")
    return streams[suffix](path)
