"""Tables of sweep results: one row per run, input columns then measurement columns.

:class:`SweepTable` is what a parameter sweep or a Monte Carlo run returns: the inputs of
every run (swept parameter values, run index, the component values drawn) and its
measurements, with the nominal measurements of a Monte Carlo run. It writes CSV, gives a
pandas DataFrame, per-measurement statistics, a line plot against a swept parameter and
histograms of the Monte Carlo distributions.

A Monte Carlo table over a parameter grid holds ``runs`` consecutive rows per grid point; its
statistics, nominal values and histograms are per grid point, never over the mixture of the
points.
"""

from __future__ import annotations

import csv
import math
import textwrap
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..atomic import atomic_path
from ..units_format import format_eng, si_prefix

__all__ = ["MAX_HISTOGRAM_POINTS", "SweepTable"]

#: Grid points of a Monte Carlo histogram at most (one panel each).
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

    def to_csv(self, path: str | Path) -> None:
        """CSV with a header row; numbers in full precision (``repr``), SI units; ``ok`` and
        ``settled`` are 1 or 0 (``settled`` empty for a failed run)."""
        with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([*self.inputs, *self.measures, "ok", "settled", "message"])
            for i in range(len(self)):
                ins = [str(int(v)) if n == "run" else repr(float(v))
                       for n, v in zip(self.inputs, self.input_values[i], strict=True)]
                w.writerow([*ins, *(repr(float(v)) for v in self.values[i]),
                            int(bool(self.ok[i])),
                            int(bool(self.settled[i])) if self.ok[i] else "",
                            self.messages[i]])

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

    # -- figures ------------------------------------------------------------------------------

    def _label(self, name: str) -> str:
        unit = self.units.get(name, "")
        return f"{name} ({unit})" if unit else name

    def plot(self, path: str | Path, title: str | None = None) -> None:
        """Histograms (Monte Carlo) or the measurements against the first swept parameter."""
        if self.runs:
            self.histogram(path, title=title)
        else:
            self.plot_sweep(path, title=title)

    def plot_sweep(self, path: str | Path, title: str | None = None) -> None:
        """Write :meth:`sweep_figure` to ``path`` (format from the extension)."""
        fig = self.sweep_figure(title)
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=130)

    def sweep_figure(self, title: str | None = None, fig=None):
        """One panel per measurement against the first swept parameter; one line per value
        of the other swept parameters.

        ``fig``: a matplotlib Figure or SubFigure to draw into (default a new Figure on an
        Agg canvas, no pyplot). Returns the figure drawn into.
        """
        if not self.swept:
            raise ValueError("nothing swept: no parameter to plot against")
        x_name = self.swept[0]
        x = self.column(x_name)
        others = list(self.swept[1:])
        keys = [tuple(self.column(o)[i] for o in others) for i in range(len(self))]
        groups = list(dict.fromkeys(keys))
        if fig is None:
            from matplotlib.backends.backend_agg import FigureCanvasAgg
            from matplotlib.figure import Figure

            fig = Figure(figsize=(8, 2.6 * len(self.measures) + 0.8), layout="constrained")
            FigureCanvasAgg(fig)
        axes = fig.subplots(len(self.measures), 1, sharex=True, squeeze=False)[:, 0]
        for ax, name in zip(axes, self.measures, strict=True):
            y = self.column(name)
            for g in groups:
                sel = np.array([k == g for k in keys])
                order = np.argsort(x[sel], kind="stable")
                label = ", ".join(f"{o} = {v:.4g}" for o, v in zip(others, g, strict=True))
                ax.plot(x[sel][order], y[sel][order], "o-", ms=3, label=label or None)
            # Runs whose window had not settled: their values are not steady-state ones.
            loose = self.ok & np.array([name in u for u in self.unsettled], dtype=bool)
            if loose.any():
                ax.plot(x[loose], y[loose], "o", ms=8, mfc="none", mec="tab:red",
                        label="not settled (simulate longer)")
            ax.set_ylabel(self._label(name))
            ax.grid(alpha=0.3)
            if others or loose.any():
                ax.legend(fontsize="small", loc="best")
        axes[-1].set_xlabel(self._label(x_name))
        axes[0].set_title(_wrap(title or f"sweep of {', '.join(self.swept)}", 8, 12))
        return fig

    def histogram(self, path: str | Path, title: str | None = None, bins: int | None = None
                  ) -> None:
        """Write :meth:`histogram_figure` to ``path`` (format from the extension)."""
        fig = self.histogram_figure(title=title, bins=bins)
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=130)

    def histogram_figure(self, title: str | None = None, bins: int | None = None, fig=None):
        """One histogram per measurement (and grid point) over the successful runs, with the
        mean, ±1 std and the nominal value marked.

        A grid of several points gives one panel per (grid point, measurement), each grid
        point in its own colour and named in the panel's title and legend.

        Returns
        -------
        matplotlib.figure.Figure
            On an Agg canvas (no pyplot).

        Raises
        ------
        ValueError
            More than :data:`MAX_HISTOGRAM_POINTS` grid points.
        """
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from matplotlib.ticker import MaxNLocator

        points = self.n_points
        if points > MAX_HISTOGRAM_POINTS:
            raise ValueError(f"{points} grid points: histograms of at most "
                             f"{MAX_HISTOGRAM_POINTS}")
        n = len(self.measures)
        panels = [(k, j) for k in range(points) for j in range(n)]
        cols = n if points > 1 and n > 1 else (1 if len(panels) == 1 else 2)
        rows = (len(panels) + cols - 1) // cols
        width = 5.2 * cols
        if fig is None:  # (else the Figure or SubFigure given)
            fig = Figure(figsize=(width, 3.1 * rows + 0.8), layout="constrained")
            FigureCanvasAgg(fig)
        axes = fig.subplots(rows, cols, squeeze=False).ravel()
        colours = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown",
                   "tab:pink", "tab:olive", "tab:cyan", "tab:gray", "navy", "teal", "maroon"]
        index = self.point_index()
        stats = [self.statistics(k) for k in range(points)] if self.runs else \
            [self.statistics()]
        for ax, (k, j) in zip(axes, panels, strict=False):
            name, unit = self.measures[j], self.units.get(self.measures[j], "")
            colour = colours[k] if points > 1 else "tab:blue"
            rows_k = (index == k) if self.runs else np.ones(len(self), dtype=bool)
            v = self.values[self.ok & rows_k, j]
            v = v[np.isfinite(v)]
            nb = bins or int(np.clip(np.sqrt(max(v.size, 1)), 5, 50))
            where = self.point_label(k) if points > 1 else ""
            s = stats[k][name]
            # The axis in the prefixed unit of the values (mV rather than 0.0150 V).
            scale, prefix = _prefix(v, unit)
            ax.hist(v / scale, bins=nb, color=colour, alpha=0.75,
                    label=f"{where}: {v.size} runs" if where else f"{v.size} runs")
            # Enough digits to tell the mean from the nominal value when the spread is small.
            digits = 4
            if v.size and s["std"] > 0 and s["mean"] != 0:
                digits = int(np.clip(math.ceil(math.log10(abs(s["mean"]) / s["std"])) + 2,
                                     4, 10))
            if v.size:
                ax.axvline(s["mean"] / scale, color="k", lw=1.5,
                           label=f"mean {format_eng(s['mean'], unit, digits)}")
                for sign in (-1, 1):
                    ax.axvline((s["mean"] + sign * s["std"]) / scale, color="k", ls="--",
                               lw=1, label=f"±1 std ({format_eng(s['std'], unit)})" if sign > 0
                               else None)
            if "nominal" in s and math.isfinite(s["nominal"]):
                ax.axvline(s["nominal"] / scale, color="tab:red", lw=1.5,
                           label=f"nominal {format_eng(s['nominal'], unit, digits)}")
            if where:
                ax.set_title(where, loc="left", fontsize=9, color=colour)
            ax.set_xlabel(f"{name} ({prefix}{unit})" if unit else name)
            ax.set_ylabel("runs")
            # Counts of runs: whole numbers on the axis.
            ax.yaxis.set_major_locator(MaxNLocator(integer=True))
            ax.legend(fontsize="small", loc="best")
        for ax in axes[len(panels):]:
            ax.set_visible(False)
        text = title or f"Monte Carlo, {self.runs} runs ({self.distribution})"
        fig.suptitle(_wrap(text, width, 11), fontsize=11)
        return fig


def _prefix(values: np.ndarray, unit: str) -> tuple[float, str]:
    """The SI prefix of the largest of ``values``: (its factor, its symbol); none without a
    unit."""
    if not unit or not np.size(values):
        return 1.0, ""
    return si_prefix(float(np.max(np.abs(values))))


def _wrap(text: str, width_in: float, fontsize: float) -> str:
    """``text`` in lines that fit a figure ``width_in`` inches wide at ``fontsize`` points
    (an average character is about 0.55 em wide)."""
    chars = max(20, int(width_in * 72 / (0.55 * fontsize)) - 4)
    return "\n".join(textwrap.wrap(text, chars)) or text
