"""Tables of sweep results: one row per run, input columns then measurement columns.

:class:`SweepTable` is what a parameter sweep or a Monte Carlo run returns: the inputs of
every run (swept parameter values, run index, the component values drawn) and its
measurements, with the nominal measurements of a Monte Carlo run. It gives its columns (the
application writes them: :func:`pelcs.writers.write_sweep`), a pandas DataFrame and
per-measurement statistics (its figures: :mod:`pelcs.sweep_plots`).

A Monte Carlo table over a parameter grid holds ``runs`` consecutive rows per grid point; its
statistics, nominal values and histograms are per grid point, never over the mixture of the
points.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["MAX_HISTOGRAM_POINTS", "SweepTable"]

#: Grid points of a Monte Carlo histogram at most (one panel each: :mod:`pelcs.sweep_plots`).
MAX_HISTOGRAM_POINTS = 12

@dataclass
class SweepTable:
    """Sweep or Monte Carlo results.

    Attributes
    ----------
    inputs : tuple[str, ...]
        Input column names: swept parameters, then ``run`` (Monte Carlo), then the drawn
        component values.
    input_values : ndarray, shape (N, len(inputs))
    measures : tuple[str, ...]
        Measurement names (``mean(v(out))``).
    values : ndarray, shape (N, len(measures))
        NaN where a run failed.
    ok : ndarray of bool, shape (N,)
    messages : list of str
        Failure message per run; for a run that succeeded, empty or why it has not settled.
    swept : tuple[str, ...]
        The input columns that are swept parameters (a subset of ``inputs``).
    units : dict
        SI unit per column name (``"V"``, ``"A"``, ``"Ω"``; ``""`` when unknown).
    nominal : ndarray, shape (n_points, len(measures)) or None
        Monte Carlo: the measurements with nominal component values, one row per grid point
        (:meth:`point_params`).
    runs : int
        Monte Carlo runs per parameter point (0: no Monte Carlo). Row ``i`` of a Monte Carlo
        table belongs to grid point ``i // runs``.
    seed : int or None
    distribution : str
        ``"uniform"`` or ``"gaussian"`` (Monte Carlo).
    tolerances : list of str
        What was drawn, e.g. ``"R1 ±5 % (R1=5%)"``.
    notes : list of str
    wall_time : float
        Seconds.
    engine : str
        Where the runs ran.
    settled : ndarray of bool, shape (N,), or None
        Whether the run succeeded and its steady-state window had settled; None: every run
        that succeeded.
    unsettled : list of tuple of str
        Per run, the measurements whose probe had not settled (empty: all settled).
    """

    inputs: tuple[str, ...]
    input_values: np.ndarray
    measures: tuple[str, ...]
    values: np.ndarray
    ok: np.ndarray
    messages: list[str]
    swept: tuple[str, ...] = ()
    units: dict[str, str] = field(default_factory=dict)
    nominal: np.ndarray | None = None
    runs: int = 0
    seed: int | None = None
    distribution: str = ""
    tolerances: list[str] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    wall_time: float = 0.0
    engine: str = ""
    settled: np.ndarray | None = None
    unsettled: list[tuple[str, ...]] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.unsettled:
            self.unsettled = [()] * len(self.messages)
        if self.nominal is not None:
            self.nominal = np.atleast_2d(np.asarray(self.nominal, dtype=float))
        if self.settled is None:
            self.settled = np.asarray(self.ok, dtype=bool).copy()

    def __len__(self) -> int:
        return int(self.values.shape[0])

    # -- grid points ------------------------------------------------------------------------

    @property
    def n_points(self) -> int:
        """Grid points: ``len(self) // runs`` for Monte Carlo, else one per row."""
        return len(self) // max(self.runs, 1)

    def point_index(self) -> np.ndarray:
        """The grid point of every row, shape (N,)."""
        return np.arange(len(self)) // max(self.runs, 1)

    def point_params(self, point: int) -> dict[str, float]:
        """The swept parameter values of grid point ``point``."""
        row = int(point) * max(self.runs, 1)
        return {name: float(self.column(name)[row]) for name in self.swept}

    def point_label(self, point: int) -> str:
        """``"duty = 0.3, vin = 12"`` (empty without swept parameters)."""
        return ", ".join(f"{k} = {v:.6g}" for k, v in self.point_params(point).items())

    def column(self, name: str) -> np.ndarray:
        """One input or measurement column, shape (N,)."""
        if name in self.inputs:
            return self.input_values[:, self.inputs.index(name)]
        if name in self.measures:
            return self.values[:, self.measures.index(name)]
        raise KeyError(f"no column {name!r}; columns: "
                       f"{', '.join(self.inputs + self.measures)}")

    def __getitem__(self, name: str) -> np.ndarray:
        return self.column(name)

    # -- output -------------------------------------------------------------------------------

    def to_dataframe(self):
        """A pandas DataFrame: the input columns, the measurements, ``ok`` and ``message``."""
        import pandas as pd

        data: dict[str, object] = {}
        for j, name in enumerate(self.inputs):
            col = self.input_values[:, j]
            data[name] = col.astype(int) if name == "run" else col
        for j, name in enumerate(self.measures):
            data[name] = self.values[:, j]
        data["ok"] = self.ok.astype(bool)
        data["settled"] = np.asarray(self.settled, dtype=bool)
        data["message"] = list(self.messages)
        return pd.DataFrame(data)

    def columns(self) -> dict[str, np.ndarray]:
        """The table's columns in order: the inputs (``run`` as integers), the measurements
        (SI units, NaN where a run failed), ``ok`` (bool), ``settled`` (True, False, or None
        for a failed run) and ``message`` (str); what ``pelcs sweep -o OUT.csv`` writes."""
        data: dict[str, np.ndarray] = {}
        for j, name in enumerate(self.inputs):
            col = self.input_values[:, j]
            data[name] = col.astype(np.int64) if name == "run" else col.astype(float)
        for j, name in enumerate(self.measures):
            data[name] = self.values[:, j].astype(float)
        data["ok"] = np.asarray(self.ok, dtype=bool)
        data["settled"] = np.array([bool(s) if ok else None for s, ok in
                                    zip(self.settled, self.ok, strict=True)], dtype=object)
        data["message"] = np.array(list(self.messages), dtype=object)
        return data

    def statistics(self, point: int | None = None) -> dict[str, dict[str, float]]:
        """Per measurement over the successful runs: ``n`` (int), ``mean``, ``std`` (sample,
        ddof = 1), ``min``, ``p5``, ``median``, ``p95``, ``max`` (and ``nominal`` if known,
        NaN when the nominal run failed).

        Parameters
        ----------
        point : int, optional
            The grid point of a Monte Carlo table (:meth:`point_params`). Required when the
            table has more than one: statistics over several grid points would mix their
            distributions. A table without Monte Carlo runs gives them over all its rows.

        Raises
        ------
        ValueError
            ``point`` omitted for a Monte Carlo table of several grid points, or out of range.
        """
        if point is None:
            if self.runs and self.n_points > 1:
                raise ValueError(f"the Monte Carlo table has {self.n_points} grid points: "
                                 "pass point=K or use point_statistics()")
            rows = np.ones(len(self), dtype=bool)
            point = 0
        else:
            point = int(point)
            if not 0 <= point < self.n_points:
                raise ValueError(f"point {point}: the table has {self.n_points} grid points")
            rows = self.point_index() == point if self.runs else \
                np.arange(len(self)) == point
        out = {}
        for j, name in enumerate(self.measures):
            v = self.values[self.ok & rows, j]
            v = v[np.isfinite(v)]
            s: dict[str, float] = {"n": int(v.size)}
            if v.size:
                s.update(mean=float(np.mean(v)),
                         std=float(np.std(v, ddof=1)) if v.size > 1 else 0.0,
                         min=float(np.min(v)), p5=float(np.percentile(v, 5)),
                         median=float(np.median(v)), p95=float(np.percentile(v, 95)),
                         max=float(np.max(v)))
            if self.nominal is not None and point < self.nominal.shape[0]:
                s["nominal"] = float(self.nominal[point, j])
            out[name] = s
        return out

    def point_statistics(self) -> list[dict]:
        """:meth:`statistics` of every grid point: ``[{"params": {name: value}, "statistics":
        {measure: {...}}}, ...]`` in grid order (one entry without a grid)."""
        if not self.runs:
            return [{"params": {}, "statistics": self.statistics()}]
        return [{"params": self.point_params(k), "statistics": self.statistics(k)}
                for k in range(self.n_points)]
