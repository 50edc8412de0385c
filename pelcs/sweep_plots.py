"""Figures of a sweep table (:class:`lcs.analysis.tables.SweepTable`): the measurements against
the first swept parameter, or the histograms of a Monte Carlo run, as ``pelcs sweep --plot``
writes them and ``SweepResult.plot()`` draws them.
"""

from __future__ import annotations

import math
import os
import textwrap
from pathlib import Path

import numpy as np

from lcs.analysis.tables import MAX_HISTOGRAM_POINTS, SweepTable
from netlist.units import format_eng, si_prefix
from pelcs.figures import new_figure, save_figure

__all__ = ["histogram_figure", "plot_table", "sweep_figure"]

#: A colour per grid point of a Monte Carlo table (at most :data:`MAX_HISTOGRAM_POINTS`).
_COLOURS = ["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink",
            "tab:olive", "tab:cyan", "tab:gray", "navy", "teal", "maroon"]


def plot_table(table: SweepTable, path: str | os.PathLike, title: str | None = None) -> Path:
    """Write the histograms (Monte Carlo) or the measurements against the first swept
    parameter to ``path`` (format from the extension); the path written."""
    fig = histogram_figure(table, title) if table.runs else sweep_figure(table, title)
    return save_figure(fig, path, dpi=130)


def _label(table: SweepTable, name: str) -> str:
    unit = table.units.get(name, "")
    return f"{name} ({unit})" if unit else name


def sweep_figure(table: SweepTable, title: str | None = None, fig=None):
    """One panel per measurement against the first swept parameter; one line per value of
    the other swept parameters.

    ``fig``: a matplotlib Figure or SubFigure to draw into (default a new Figure on an Agg
    canvas, no pyplot). Returns the figure drawn into.
    """
    if not table.swept:
        raise ValueError("nothing swept: no parameter to plot against")
    x_name = table.swept[0]
    x = table.column(x_name)
    others = list(table.swept[1:])
    keys = [tuple(table.column(o)[i] for o in others) for i in range(len(table))]
    groups = list(dict.fromkeys(keys))
    fig = new_figure((8, 2.6 * len(table.measures) + 0.8), fig)
    axes = fig.subplots(len(table.measures), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name in zip(axes, table.measures, strict=True):
        y = table.column(name)
        for g in groups:
            sel = np.array([k == g for k in keys])
            order = np.argsort(x[sel], kind="stable")
            label = ", ".join(f"{o} = {v:.4g}" for o, v in zip(others, g, strict=True))
            ax.plot(x[sel][order], y[sel][order], "o-", ms=3, label=label or None)
        # Runs whose window had not settled: their values are not steady-state ones.
        loose = table.ok & np.array([name in u for u in table.unsettled], dtype=bool)
        if loose.any():
            ax.plot(x[loose], y[loose], "o", ms=8, mfc="none", mec="tab:red",
                    label="not settled (simulate longer)")
        ax.set_ylabel(_label(table, name))
        ax.grid(alpha=0.3)
        if others or loose.any():
            ax.legend(fontsize="small", loc="best")
    axes[-1].set_xlabel(_label(table, x_name))
    axes[0].set_title(_wrap(title or f"sweep of {', '.join(table.swept)}", 8, 12))
    return fig


def histogram_figure(table: SweepTable, title: str | None = None, bins: int | None = None,
                     fig=None):
    """One histogram per measurement (and grid point) over the successful runs, with the
    mean, ±1 std and the nominal value marked.

    A grid of several points gives one panel per (grid point, measurement), each grid point
    in its own colour and named in the panel's title and legend.

    Returns
    -------
    matplotlib.figure.Figure
        ``fig`` (a Figure or SubFigure to draw into), else a new one on an Agg canvas.

    Raises
    ------
    ValueError
        More than :data:`~lcs.analysis.tables.MAX_HISTOGRAM_POINTS` grid points.
    """
    from matplotlib.ticker import MaxNLocator

    points = table.n_points
    if points > MAX_HISTOGRAM_POINTS:
        raise ValueError(f"{points} grid points: histograms of at most "
                         f"{MAX_HISTOGRAM_POINTS}")
    n = len(table.measures)
    panels = [(k, j) for k in range(points) for j in range(n)]
    cols = n if points > 1 and n > 1 else (1 if len(panels) == 1 else 2)
    rows = (len(panels) + cols - 1) // cols
    width = 5.2 * cols
    fig = new_figure((width, 3.1 * rows + 0.8), fig)
    axes = fig.subplots(rows, cols, squeeze=False).ravel()
    index = table.point_index()
    stats = [table.statistics(k) for k in range(points)] if table.runs else \
        [table.statistics()]
    for ax, (k, j) in zip(axes, panels, strict=False):
        name, unit = table.measures[j], table.units.get(table.measures[j], "")
        colour = _COLOURS[k] if points > 1 else "tab:blue"
        rows_k = (index == k) if table.runs else np.ones(len(table), dtype=bool)
        v = table.values[table.ok & rows_k, j]
        v = v[np.isfinite(v)]
        nb = bins or int(np.clip(np.sqrt(max(v.size, 1)), 5, 50))
        where = table.point_label(k) if points > 1 else ""
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
    text = title or f"Monte Carlo, {table.runs} runs ({table.distribution})"
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
