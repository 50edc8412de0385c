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

__all__ = ["FORMATS", "write_csv", "write_npz", "write_parquet", "write_result"]

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
    data = _columns(result)
    row = ",".join([f"%.{_DIGITS}g"] * data.shape[1]) + "\n"
    with atomic_path(out) as tmp, open(tmp, "w", newline="") as fh:
        csv.writer(fh, lineterminator="\n").writerow(["time", *result.names])
        for i in range(0, len(data), _BLOCK):
            block = data[i:i + _BLOCK]
            fh.write((row * len(block)) % tuple(block.ravel().tolist()))
    return out


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
    import json

    import pyarrow as pa
    import pyarrow.parquet as pq

    out = Path(path)
    cols = {"time": pa.array(np.asarray(result.t, dtype=float))}
    for j, name in enumerate(result.names):
        cols[name] = pa.array(np.ascontiguousarray(result.y[:, j], dtype=float))
    meta = {"pelcs.notes": json.dumps(list(result.notes)),
            "pelcs.error": result.error.message if result.error is not None else ""}
    table = pa.table(cols).replace_schema_metadata(meta)
    with atomic_path(out) as tmp:
        pq.write_table(table, tmp, compression="zstd")
    return out


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
