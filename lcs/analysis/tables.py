"""Tables of sweep results: one row per run, input columns then measurement columns.

:class:`SweepTable` is what a parameter sweep or a Monte Carlo run returns: the inputs of
every run (swept parameter values, run index, the component values drawn) and its
measurements, with the nominal measurements of a Monte Carlo run. It writes CSV, gives a
pandas DataFrame, per-measurement statistics, a line plot against a swept parameter and
histograms of the Monte Carlo distributions.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["SweepTable"]


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
        Failure message per run (empty when it succeeded).
    swept : tuple[str, ...]
        The input columns that are swept parameters (a subset of ``inputs``).
    units : dict
        SI unit per column name (``"V"``, ``"A"``, ``"Ω"``; ``""`` when unknown).
    nominal : ndarray, shape (len(measures),) or None
        Monte Carlo: the measurements with nominal component values (at the first point of
        the parameter grid).
    runs : int
        Monte Carlo runs per parameter point (0: no Monte Carlo).
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

    def __len__(self) -> int:
        return int(self.values.shape[0])

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
        data["message"] = list(self.messages)
        return pd.DataFrame(data)

    def to_csv(self, path: str | Path) -> None:
        """CSV with a header row; numbers in full precision (``repr``), SI units."""
        with open(path, "w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow([*self.inputs, *self.measures, "ok", "message"])
            for i in range(len(self)):
                ins = [str(int(v)) if n == "run" else repr(float(v))
                       for n, v in zip(self.inputs, self.input_values[i], strict=True)]
                w.writerow([*ins, *(repr(float(v)) for v in self.values[i]),
                            int(bool(self.ok[i])), self.messages[i]])

    def statistics(self) -> dict[str, dict[str, float]]:
        """Per measurement over the successful runs: ``n``, ``mean``, ``std`` (sample,
        ddof = 1), ``min``, ``p5``, ``median``, ``p95``, ``max`` (and ``nominal`` if known)."""
        out = {}
        for j, name in enumerate(self.measures):
            v = self.values[self.ok, j]
            v = v[np.isfinite(v)]
            s: dict[str, float] = {"n": float(v.size)}
            if v.size:
                s.update(mean=float(np.mean(v)),
                         std=float(np.std(v, ddof=1)) if v.size > 1 else 0.0,
                         min=float(np.min(v)), p5=float(np.percentile(v, 5)),
                         median=float(np.median(v)), p95=float(np.percentile(v, 95)),
                         max=float(np.max(v)))
            if self.nominal is not None:
                s["nominal"] = float(self.nominal[j])
            out[name] = s
        return out

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
        """One panel per measurement against the first swept parameter; one line per value
        of the other swept parameters."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        if not self.swept:
            raise ValueError("nothing swept: no parameter to plot against")
        x_name = self.swept[0]
        x = self.column(x_name)
        others = list(self.swept[1:])
        keys = [tuple(self.column(o)[i] for o in others) for i in range(len(self))]
        groups = list(dict.fromkeys(keys))
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
            ax.set_ylabel(self._label(name))
            ax.grid(alpha=0.3)
            if others:
                ax.legend(fontsize="small", loc="best")
        axes[-1].set_xlabel(self._label(x_name))
        axes[0].set_title(title or f"sweep of {', '.join(self.swept)}")
        fig.savefig(path, dpi=130)

    def histogram(self, path: str | Path, title: str | None = None, bins: int | None = None
                  ) -> None:
        """One histogram per measurement over the successful runs, with the mean, ±1 std
        and the nominal value marked."""
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        n = len(self.measures)
        cols = 1 if n == 1 else 2
        rows = (n + cols - 1) // cols
        fig = Figure(figsize=(5.5 * cols, 3.4 * rows + 0.6), layout="constrained")
        FigureCanvasAgg(fig)
        axes = fig.subplots(rows, cols, squeeze=False).ravel()
        stats = self.statistics()
        for ax, name in zip(axes, self.measures, strict=False):
            v = self.column(name)[self.ok]
            v = v[np.isfinite(v)]
            nb = bins or int(np.clip(np.sqrt(max(v.size, 1)), 5, 50))
            ax.hist(v, bins=nb, color="tab:blue", alpha=0.7, label=f"{v.size} runs")
            s = stats[name]
            if v.size:
                ax.axvline(s["mean"], color="k", lw=1.5, label=f"mean {s['mean']:.5g}")
                for sign in (-1, 1):
                    ax.axvline(s["mean"] + sign * s["std"], color="k", ls="--", lw=1,
                               label=f"±1 std ({s['std']:.3g})" if sign > 0 else None)
            if "nominal" in s:
                ax.axvline(s["nominal"], color="tab:red", lw=1.5,
                           label=f"nominal {s['nominal']:.5g}")
            ax.set_xlabel(self._label(name))
            ax.set_ylabel("runs")
            ax.legend(fontsize="small", loc="best")
        for ax in axes[n:]:
            ax.set_visible(False)
        fig.suptitle(title or f"Monte Carlo, {self.runs} runs ({self.distribution})")
        fig.savefig(path, dpi=130)
