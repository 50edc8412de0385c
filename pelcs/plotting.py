"""Plots of simulation results: PNG (one panel per probe); the files are :mod:`pelcs.writers`'.

Probe units follow from the probe syntax: ``v(...)`` is in volts, ``i(...)`` in amperes. The
time axis is scaled to s, ms, µs or ns from the length of the run. Figures are drawn on
matplotlib's Agg canvas directly (no pyplot, so the caller's backend and open figures are left
alone), which also makes them work without a display.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lcs.results import SimulationResult
from netlist.units import format_eng
from pelcs.figures import axis_label, new_figure, probe_unit, save_figure, time_unit
from pelcs.figures import envelope as _envelope  # (tests read it here)
from pelcs.writers import write_csv, write_npz, write_result  # noqa: F401  (their old home)

__all__ = [
    "auto_zoom",
    "period_mean",
    "plot_result",
    "result_figure",
    "probe_unit",
    "time_unit",
    "write_csv",
    "write_npz",
    "write_result",
]


def period_mean(t: np.ndarray, y: np.ndarray) -> float:
    """Time average of samples ``y`` at times ``t`` (trapezoidal rule), same unit as ``y``.

    (Written out because ``np.trapz`` is ``np.trapezoid`` from NumPy 2 on.)
    """
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    return float(0.5 * np.sum((y[1:] + y[:-1]) * np.diff(t)) / (t[-1] - t[0]))


def _fmt_si(value: float, unit: str) -> str:
    return format_eng(float(value), unit)


def auto_zoom(result: SimulationResult, periods: int = 3) -> tuple[float, float] | None:
    """A window over the last few switching periods of a run, for a detail view.

    The switching period is estimated from the switching events: a mode that recurs
    periodically comes back once per period. Returns None without at least ``periods + 1``
    recurrences of the last mode (a diode-only circuit, a short run).

    Returns
    -------
    (float, float) or None
        ``(t0, t1)``, s, ending at the last stored time.
    """
    if not len(result.t) or len(result.events) < 2:
        return None
    t_end = float(result.t[-1])
    last_mode = result.events[-1][1]
    starts = [t for t, mode in result.events if mode == last_mode and t <= t_end]
    if len(starts) < periods + 1:
        return None
    t0 = starts[-periods - 1]
    # Whole periods back from the last event, then shifted to end at the last point.
    width = starts[-1] - t0
    if not width > 0:
        return None
    t0 = max(float(result.t[0]), t_end - width)
    return (t0, t_end) if t_end - t0 < 0.5 * (t_end - float(result.t[0])) else None


def plot_result(
    result: SimulationResult,
    path: str | os.PathLike,
    *,
    title: str | None = None,
    probes: Sequence[str] | None = None,
    zoom: tuple[float, float] | str | None = "auto",
    t_stop: float | None = None,
    dpi: int = 130,
) -> Path:
    """Plot probes of a run (:func:`result_figure`) into a file, whole or not at all; the
    format follows the extension (``.png``, ``.svg``, ``.pdf``); returns the path written."""
    return save_figure(result_figure(result, title=title, probes=probes, zoom=zoom,
                                     t_stop=t_stop, dpi=dpi), path)


def result_figure(
    result: SimulationResult,
    *,
    fig=None,
    title: str | None = None,
    probes: Sequence[str] | None = None,
    zoom: tuple[float, float] | str | None = "auto",
    t_stop: float | None = None,
    dpi: int = 130,
):
    """Probes of a run, one panel per probe over a shared time axis.

    Parameters
    ----------
    result : SimulationResult
        A run, possibly failed: the failure time is then marked on every panel.
    fig : matplotlib Figure or SubFigure, optional
        Where to draw; default a new Figure.
    title : str, optional
        Figure title (e.g. the netlist title).
    probes : sequence of str, optional
        Probes to plot, default all of ``result.names``.
    zoom : (float, float) or "auto" or None
        A time window (s) shown in a second column next to the whole run, with the mean of
        each probe over it; ``"auto"``: the last three switching periods (:func:`auto_zoom`),
        if the run has them.
    t_stop : float, optional
        The stop time the run was asked for, s: the time axis of a failed run extends to it,
        the part not simulated shaded.
    dpi : int
        Resolution of a new figure (dots per inch).

    Returns
    -------
    matplotlib Figure or SubFigure
        ``fig``, or the new Figure.
    """
    names = list(probes) if probes is not None else list(result.names)
    t = np.asarray(result.t)
    t_end = float(t[-1]) if len(t) else 0.0
    error = result.error
    t_axis = max(t_end, t_stop or 0.0, error.time if error is not None else 0.0)
    scale, tunit = time_unit(t_axis)
    window = auto_zoom(result) if zoom == "auto" else zoom
    panels = max(1, len(names))
    ncols = 2 if window is not None else 1
    fig = new_figure((9.0 + 3.2 * (ncols - 1), 1.2 + 2.1 * panels), fig=fig, dpi=dpi)
    axes = fig.subplots(panels, ncols, sharex="col", squeeze=False,
                        width_ratios=[3.0, 1.3][:ncols])
    colors = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#17becf"]
    for k, name in enumerate(names):
        ax = axes[k, 0]
        color = colors[k % len(colors)]
        y = np.asarray(result[name])
        unit = probe_unit(name)
        tt, yy = _envelope(t, y)
        ax.plot(tt / scale, yy, color=color, lw=0.9)
        ax.set_ylabel(axis_label(name))
        ax.grid(True, color="0.88", lw=0.6)
        if len(t) > 1:
            ax.set_xlim(t[0] / scale, t_axis / scale)
        if len(y):
            ax.set_title(f"final {_fmt_si(y[-1], unit)}", loc="right", fontsize=8,
                         color="0.3", pad=3)
        if error is not None:
            ax.axvline(error.time / scale, color="red", ls="--", lw=1.0)
            if t_axis > error.time:
                ax.axvspan(error.time / scale, t_axis / scale, color="red", alpha=0.06, lw=0)
        if window is not None:
            _zoom_panel(axes[k, 1], t, y, window, color, unit)
            ax.axvspan(window[0] / scale, window[1] / scale, color="0.5", alpha=0.12, lw=0)
    if error is not None:
        axes[0, 0].set_title(f"run stopped at t = {_fmt_si(error.time, 's')} ({error.kind})",
                             color="red", fontsize=9, loc="left", pad=3)
    axes[-1, 0].set_xlabel(f"time [{tunit}]")
    if window is not None:
        zscale, zunit = time_unit(window[1] - window[0])
        axes[0, 1].set_title("last switching periods", fontsize=8, color="0.3", loc="left",
                             pad=3)
        axes[-1, 1].set_xlabel(f"time [{zunit}]")
    if title:
        fig.suptitle(title, fontsize=11)
    return fig


def _zoom_panel(ax, t: np.ndarray, y: np.ndarray, window: tuple[float, float], color: str,
                unit: str) -> None:
    """The detail of one probe over ``window`` (s), with its mean (trapezoidal) over it."""
    t0, t1 = window
    zscale, _ = time_unit(t1 - t0)
    sel = (t >= t0) & (t <= t1)
    ts, ys = t[sel], y[sel]
    ax.plot(ts / zscale, ys, color=color, lw=1.0)
    ax.grid(True, color="0.88", lw=0.6)
    if len(ts) > 1:
        ax.set_xlim(ts[0] / zscale, ts[-1] / zscale)
        mean = period_mean(ts, ys)
        ax.axhline(mean, color="0.35", ls=":", lw=0.9)
        ax.set_title(f"mean {_fmt_si(mean, unit)}", loc="right", fontsize=8, color="0.3",
                     pad=3)
    ax.tick_params(labelsize=8)
