"""The figure of ``pelcs check``: pelcs (solid) and ngspice (dashed) per probe, the whole run
and a zoom on the last periods of the steady-state window (``--report``'s ``NAME.png``, and
``CheckResult.plot()``).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from netlist.units import probe_unit
from ngspice_checks.compare import Comparison
from ngspice_checks.report import eng, percent, settings_line, verdict_line
from pelcs.figures import axis_label, envelope, new_figure, save_figure, time_unit

__all__ = ["comparison_figure", "plot_comparison"]

_PELCS, _NGSPICE = "#1f77b4", "#d62728"


def plot_comparison(cmp: Comparison, path: str | os.PathLike, *, dpi: int = 110,
                    zoom_periods: int = 5) -> Path:
    """Write :func:`comparison_figure` to ``path`` (format from the extension)."""
    return save_figure(comparison_figure(cmp, dpi=dpi, zoom_periods=zoom_periods), path)


def comparison_figure(cmp: Comparison, *, dpi: int = 110, zoom_periods: int = 5, fig=None):
    """Overlay plot: one row per probe, whole run and a zoom on the last periods.

    Parameters
    ----------
    cmp : Comparison
        With its ``pelcs_result`` and ``ngspice_result``.
    dpi : int
    zoom_periods : int
        Periods shown in the zoom (fewer if the window has fewer); without a period the zoom
        shows the whole steady-state window. The dotted lines are the means over the whole
        window (``n_periods`` periods), which a waveform still settling may not centre on.

    fig : matplotlib Figure or SubFigure, optional
        To draw into (default a new Figure on an Agg canvas, no pyplot).

    Returns
    -------
    The figure drawn into.
    """
    res, ng = cmp.pelcs_result, cmp.ngspice_result
    if res is None or ng is None:
        raise ValueError("the comparison holds no waveforms (pelcs_result/ngspice_result)")
    t_p, t_n = np.asarray(res.t), np.asarray(ng.time)
    scale, tunit = time_unit(cmp.span[1])
    z1 = cmp.window[1]
    if cmp.period and cmp.n_periods:
        z0 = z1 - min(zoom_periods, cmp.n_periods) * cmp.period
    else:
        z0 = cmp.window[0]
    zscale, zunit = time_unit(z1 - z0)
    rows = max(1, len(cmp.probes))
    fig = new_figure((12.5, 1.3 + 2.2 * rows), fig, dpi=dpi)
    axes = fig.subplots(rows, 2, squeeze=False, width_ratios=[2.3, 1.4])
    for k, p in enumerate(cmp.probes):
        yp, yn = np.asarray(res[p.probe]), np.asarray(ng.signals[p.ngspice_probe])
        u = probe_unit(p.probe)
        ax = axes[k, 0]
        tt, yy = envelope(t_p, yp)
        ax.plot(tt / scale, yy, color=_PELCS, lw=0.9, label="pelcs")
        tt, yy = envelope(t_n, yn)
        ax.plot(tt / scale, yy, color=_NGSPICE, lw=0.9, ls="--", label="ngspice")
        ax.axvspan(cmp.window[0] / scale, cmp.window[1] / scale, color="0.5", alpha=0.1, lw=0)
        ax.set_xlim(cmp.span[0] / scale, cmp.span[1] / scale)
        ax.set_ylabel(axis_label(p.probe))
        ax.grid(True, color="0.9", lw=0.6)
        color = "0.3" if p.ok else "red"
        ax.set_title(f"NRMS {percent(p.nrms)} (tol {percent(p.nrms_tol)})", loc="right",
                     fontsize=8, color=color, pad=3)
        az = axes[k, 1]
        for t, y, style in ((t_p, yp, dict(color=_PELCS, lw=1.1)),
                            (t_n, yn, dict(color=_NGSPICE, lw=1.1, ls="--"))):
            sel = (t >= z0) & (t <= z1)
            az.plot(t[sel] / zscale, y[sel], **style)
        az.axhline(p.mean_pelcs, color=_PELCS, lw=0.7, ls=":")
        az.axhline(p.mean_ngspice, color=_NGSPICE, lw=0.7, ls=":")
        az.set_xlim(z0 / zscale, z1 / zscale)
        az.grid(True, color="0.9", lw=0.6)
        az.tick_params(labelsize=8)
        az.set_title(f"mean {eng(p.mean_pelcs, u)} / {eng(p.mean_ngspice, u)}, ripple "
                     f"{eng(p.ripple_pelcs, u)} / {eng(p.ripple_ngspice, u)}",
                     loc="right", fontsize=8, color=color, pad=3)
    axes[0, 0].legend(fontsize=8, loc="best")  # (pelcs solid, ngspice dashed)
    axes[-1, 0].set_xlabel(f"time [{tunit}]")
    axes[-1, 1].set_xlabel(f"time [{zunit}] (last periods)")
    name = Path(cmp.file).name
    fig.suptitle(f"{cmp.title}  ({name})\npelcs (solid) vs ngspice (dashed, "
                 f"{settings_line(cmp)}): "
                 f"{verdict_line(cmp).split(':')[0]}", fontsize=10,
                 color="black" if cmp.ok else "red")
    return fig
