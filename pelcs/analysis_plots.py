"""Figures of a bifurcation diagram (:class:`lcs.analysis.bifurcation.BifurcationDiagram`) and
of a basin map (:class:`lcs.analysis.basins.BasinMap`), as ``pelcs bifurcation --plot`` and
``pelcs basins --plot`` write them and the Python API's results draw them.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from lcs.analysis.basins import BasinMap
from lcs.analysis.bifurcation import BifurcationDiagram
from pelcs.figures import axis_label, fit_title, new_figure, save_figure

__all__ = ["basins_figure", "bifurcation_figure", "plot_basins", "plot_bifurcation"]

#: A colour per direction of a bifurcation sweep.
_DIRECTION_COLOURS = {"fixed": "k", "up": "tab:blue", "down": "tab:red"}


def plot_bifurcation(diagram: BifurcationDiagram, path: str | os.PathLike,
                     probes: Sequence[str] | None = None, title: str | None = None) -> Path:
    """Write :func:`bifurcation_figure` to ``path`` (format from the extension)."""
    return save_figure(bifurcation_figure(diagram, probes, title), path, dpi=150)


def bifurcation_figure(diagram: BifurcationDiagram, probes: Sequence[str] | None = None,
                       title: str | None = None, fig=None):
    """Scatter plot of the samples against the parameter, one panel per probe, one colour
    per direction of the sweep (with a legend when there are several); ``title`` default:
    what is plotted.

    ``fig``: a matplotlib Figure or SubFigure to draw into (default a new Figure on an Agg
    canvas, no pyplot). Returns the figure drawn into.
    """
    names = list(probes) if probes else list(diagram.probes)
    cols = [list(diagram.probes).index(p) for p in names]
    fig = new_figure((8, 2.6 * len(names) + 0.8), fig)
    # Marker area: fine for dense diagrams (300 x 100 points), visible for coarse ones.
    npts = sum(b.samples.shape[0] * b.samples.shape[1] for b in diagram.branches)
    size = float(np.clip(3e4 / max(npts, 1), 0.3, 6.0))
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name, c in zip(axes, names, cols, strict=True):
        for b in diagram.branches:
            m = b.samples.shape[1]
            px = np.repeat(b.values, m)
            py = b.samples[:, :, c].ravel()
            ax.scatter(px, py, s=size, c=_DIRECTION_COLOURS.get(b.direction, "k"), marker=".",
                       linewidths=0, rasterized=True,
                       label=b.direction if len(diagram.branches) > 1 else None)
        ax.set_ylabel(axis_label(name))
        ax.grid(alpha=0.3)
    if len(diagram.branches) > 1:
        axes[0].legend(markerscale=20, loc="best")
    axes[-1].set_xlabel(diagram.param_name)
    axes[0].set_title(title or f"{', '.join(names)} sampled once a period against "
                               f"{diagram.param_name}")
    return fig


def plot_basins(basins: BasinMap, path: str | os.PathLike, title: str | None = None) -> Path:
    """Write :func:`basins_figure` to ``path`` (format from the extension)."""
    return save_figure(basins_figure(basins, title), path, dpi=130)


def basins_figure(basins: BasinMap, title: str | None = None, fig=None):
    """Two panels: basins (one colour per attractor, sink grey, attractor cells black) and
    the step number (periods to reach the attractor).

    ``fig``: a matplotlib Figure or SubFigure to draw into (default a new Figure on an Agg
    canvas, no pyplot). Returns the figure drawn into.
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    a0, a1 = basins.grid.axes
    extent = (a1.lo, a1.hi, a0.lo, a0.hi)
    fig = new_figure((11, 4.6), fig)
    ax1, ax2 = fig.subplots(1, 2)
    ng = len(basins.attractors)
    base = ["#bbbbbb"] + [c for _, c in zip(range(ng), _palette(ng), strict=False)]
    # (bad: the cells not computed of an interrupted map)
    cmap = ListedColormap(base).with_extremes(bad="white")
    group, steps = basins.group, basins.steps
    if basins.computed is not None:
        group, steps = np.ma.masked_less(group, 0), np.ma.masked_less(steps, 0)
    ax1.imshow(group, origin="lower", extent=extent, aspect="auto", cmap=cmap,
               vmin=-0.5, vmax=ng + 0.5, interpolation="nearest")
    for k, at in enumerate(basins.attractors):
        ax1.plot(at.points[:, 1], at.points[:, 0], "k.", ms=3,
                 label="attractor cells" if k == 0 else None)
    # One legend entry per colour of the basins image (an image has no legend of its own).
    handles = [Patch(facecolor=base[0], label="leaves the grid")] + [
        Patch(facecolor=base[at.group],
              label=f"basin of attractor {at.group} ({at.period} cell cycle)")
        for at in basins.attractors]
    if basins.computed is not None:
        handles.append(Patch(facecolor="white", edgecolor="0.5", label="not computed"))
    dots, _ = ax1.get_legend_handles_labels()
    ax1.legend(handles=handles + dots, fontsize=7, loc="best", framealpha=0.8)
    xlabel, ylabel = axis_label(a1.name), axis_label(a0.name)
    ax1.set_xlabel(xlabel)
    ax1.set_ylabel(ylabel)
    fit_title(ax1, "basins" if title is None else title)
    im = ax2.imshow(steps, origin="lower", extent=extent, aspect="auto",
                    cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=ax2, label="periods to reach the attractor")
    ax2.set_xlabel(xlabel)
    ax2.set_ylabel(ylabel)
    fit_title(ax2, "transient time")
    return fig


def _palette(n: int) -> list:
    """``n`` distinct colours: tab10 up to 10, else spread over the hsv circle."""
    from matplotlib import colormaps

    cm = colormaps["tab10" if n <= 10 else "hsv"]
    return [cm(i % 10) if n <= 10 else cm(i / max(n, 1)) for i in range(n)]
