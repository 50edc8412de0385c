"""What every figure of pelcs shares: a figure on matplotlib's Agg canvas, written whole,
axis labels with units, a readable time unit, a dense waveform thinned to its visible
envelope, and titles that fit.

Figures are drawn on the Agg canvas directly (no pyplot: the caller's backend and open figures
are left alone, and no display is needed). Used by every plot of the CLI and of the Python
API (:mod:`pelcs.plotting`, :mod:`pelcs.api_plots`, :mod:`pelcs.analysis_plots`,
:mod:`pelcs.sweep_plots`, :mod:`pelcs.check_report`, the Bode plots of ``pelcs ac``).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from lcs.atomic import atomic_path
from netlist.probes import probe_unit

__all__ = ["axis_label", "envelope", "fit_title", "new_figure", "probe_unit", "save_figure",
           "time_unit"]

# Above this many points per panel the curve is drawn as its min/max envelope over buckets
# of samples: a switching ripple of 10^5 points looks the same and draws 10x faster.
_ENVELOPE_POINTS = 20000
_ENVELOPE_BUCKETS = 4000

_TIME_UNITS = [(1.0, "s"), (1e-3, "ms"), (1e-6, "µs"), (1e-9, "ns")]


def new_figure(size: tuple[float, float], fig=None, **kwargs):
    """``fig`` if given (a matplotlib Figure or SubFigure to draw into), else a new Figure of
    ``size`` inches with a constrained layout on an Agg canvas; ``kwargs`` go to
    :class:`~matplotlib.figure.Figure` (``dpi``)."""
    if fig is not None:
        return fig
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=size, layout="constrained", **kwargs)
    FigureCanvasAgg(fig)
    return fig


def save_figure(fig, path: str | os.PathLike, dpi: float | None = None) -> Path:
    """Write ``fig`` to ``path``, whole or not at all (format from the extension; ``dpi``:
    the figure's own when None); the path written."""
    out = Path(path)
    with atomic_path(out) as tmp:
        fig.savefig(tmp, **({} if dpi is None else {"dpi": dpi}))
    return out


def axis_label(name: str) -> str:
    """A probe's axis label with its unit, ``v(C1) [V]`` (the name alone without one)."""
    unit = probe_unit(name)
    return f"{name} [{unit}]" if unit else name


def fit_title(ax, text: str, fontsize: float = 11.0, share: float = 0.9, **kwargs) -> None:
    """Set ``text`` as the title of the matplotlib axes ``ax``, no wider than ``share`` of the
    axes: wrapped onto a second line at a word boundary, then in a smaller font (down to 7 pt)
    if it is still wider. A netlist's title line can be a long sentence; matplotlib would
    draw it across the neighbouring panel or past the figure's edge.

    ``share`` leaves room for a constrained layout, which narrows the axes when it draws.
    ``kwargs`` go to :meth:`~matplotlib.axes.Axes.set_title`.
    """
    import textwrap

    renderer = ax.figure.canvas.get_renderer()
    limit = share * ax.get_window_extent(renderer).width
    title = ax.set_title(text, fontsize=fontsize, **kwargs)

    def width() -> float:
        return title.get_window_extent(renderer).width

    if width() <= limit:
        return
    # (two lines, or three when the words do not split evenly; never cut)
    chars = max(int(len(text) * limit / width()), math.ceil(len(text) / 2) + 1)
    title.set_text("\n".join(textwrap.wrap(text, chars)))
    size = fontsize
    while width() > limit and size > 7.0:
        size -= 0.5
        title.set_fontsize(size)


def time_unit(t_end: float) -> tuple[float, str]:
    """Scale and unit name for a time axis ending at ``t_end`` (s).

    Returns
    -------
    (float, str)
        ``(scale, unit)`` with ``t / scale`` between 1 and 1000 at the end of the axis, e.g.
        ``(1e-3, "ms")`` for a 5 ms run.
    """
    for scale, unit in _TIME_UNITS:
        if abs(t_end) >= scale:
            return scale, unit
    return _TIME_UNITS[-1]


def envelope(t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Min/max of ``y`` over buckets of consecutive samples, as one zigzag curve.

    Keeps the visible shape of a dense waveform (its ripple band and every spike) with
    2 points per bucket.
    """
    n = len(t)
    if n <= _ENVELOPE_POINTS:
        return t, y
    per = math.ceil(n / _ENVELOPE_BUCKETS)
    cut = (n // per) * per
    yb = y[:cut].reshape(-1, per)
    tb = t[:cut].reshape(-1, per)
    lo, hi = yb.argmin(axis=1), yb.argmax(axis=1)
    rows = np.arange(len(yb))
    first = np.minimum(lo, hi)
    second = np.maximum(lo, hi)
    tt = np.column_stack([tb[rows, first], tb[rows, second]]).ravel()
    yy = np.column_stack([yb[rows, first], yb[rows, second]]).ravel()
    return np.concatenate([tt, t[cut:]]), np.concatenate([yy, y[cut:]])
