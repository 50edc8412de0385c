"""Convergence study: ngspice approaches pelcs as its diode and switch models approach the ideal.

::

    .venv/bin/python -m pelcs.convergence [--out DIR] [--fast] [--converters buck,boost]

(:mod:`pelcs.convergence` runs :func:`run_study` and writes :func:`columns` and :func:`figure`:
this package gives the data and writes no file.)

pelcs treats D and S as ideal whatever their ``.model`` says; ngspice simulates the models.
Here one scale ε sets all three departures from the ideal at once,

    switch RON = ε ohm,   diode RS = ε ohm,   diode emission coefficient N = ε
    (IS = 1e-12 A and ROFF = 1e9 ohm fixed, VT kept),

so that the forward drop N·Vt·ln(I/IS) + RS·I and the switch drop RON·I both shrink in
proportion to ε. For ε from 1 (a soft diode with a 0.7 V drop and a 1 ohm switch) down to
1e-4 the bundled buck (CCM) and boost converters are simulated by both (``compare`` with the
same netlist; only the models change, and the ladder is limited to its first five rungs so
that rung 5 cannot swap the models for its own) and the differences are recorded:

- the relative difference of the mean output voltage over the last 10 periods,
- the normalised RMS difference of ``v(out)`` and ``i(L1)`` over the run.

Expected: first order in ε (the drops are linear in ε) until ngspice's own integration error
(TMAX = T/100, reltol = 1e-3) takes over. Results: ``results/convergence.csv`` and
``results/convergence.png`` (log-log) in this package; ``tests/test_ngspice_compare.py``
runs a two-point version.

Measured (ngspice 39, 5 ms runs, 9 levels, 10 s in all): the relative difference of the mean
output falls from 19 % at ε = 1 to 3.1e-4 (buck) and 1.8e-4 (boost) at ε = 1e-3, first order
(slopes 0.93 and 1.0 over those three decades). Below ε = 1e-3 the boost keeps falling (1.2e-5
at 1e-4) while the buck levels off at 6e-5 to 9e-5: there ngspice's own time-stepping error,
not its models, is what is left. The boost needs the ladder's rung 3 (Gear + shunts) for
ε <= 0.3, the buck runs as written throughout.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from . import deck
from .compare import compare
from .runner import DEFAULT_LADDER

__all__ = ["ConvergencePoint", "columns", "figure", "model_deck", "order", "run_study"]

NETLISTS = Path(__file__).resolve().parents[1] / "converters" / "netlists"
RESULTS = Path(__file__).resolve().parent / "results"

#: ε values of the full study (ohm for RON and RS, dimensionless for N)
LEVELS = (1.0, 0.3, 0.1, 0.03, 0.01, 3e-3, 1e-3, 3e-4, 1e-4)
FAST_LEVELS = (0.1, 0.01)

#: stop times (s): the boost's averaged dynamics ring for about 4 ms after the lossier
#: models move its steady state, the buck settles within its 5 ms
TSTOP = {"buck": 5e-3, "boost": 5e-3}
FAST_TSTOP = {"buck": 1e-3, "boost": 1e-3}

# no smooth-models rung: it would replace the models under study by its own
_LADDER = DEFAULT_LADDER[:5]


@dataclass
class ConvergencePoint:
    """One converter at one ε.

    Attributes
    ----------
    converter : str
    eps : float
        Model scale ε: RON = RS = ε ohm, N = ε.
    delta : float
        Relative drop estimate δ of :mod:`ngspice_checks.compare`.
    rung, settings : int, str
        ngspice ladder rung and its name.
    vout_pelcs, vout_ngspice : float
        Mean output voltage over the last 10 periods (V).
    mean_error : float
        |vout_ngspice - vout_pelcs| / |vout_pelcs|.
    nrms_vout, nrms_il : float
        NRMS differences of v(out) and i(L1) over the run (fraction of the probe's scale).
    ngspice_wall, pelcs_wall : float
        Wall times (s).
    """

    converter: str
    eps: float
    delta: float
    rung: int
    settings: str
    vout_pelcs: float
    vout_ngspice: float
    mean_error: float
    nrms_vout: float
    nrms_il: float
    ngspice_wall: float
    pelcs_wall: float


def model_deck(text: str, eps: float) -> str:
    """The netlist with every D model ``IS=1e-12 N=ε RS=ε`` and every SW model ``RON=ε``."""
    out = deck.replace_diode_models(text, {"is": "1e-12", "n": repr(eps), "rs": repr(eps)})
    return deck.replace_switch_models(out, ron=eps, roff=1e9)


def run_study(converters: Sequence[str] = ("buck", "boost"),
              levels: Sequence[float] = LEVELS,
              tstop: dict[str, float] | None = None) -> list[ConvergencePoint]:
    """Compare pelcs and ngspice for every converter and ε.

    Parameters
    ----------
    converters : sequence of str
        Names of bundled netlists (``converters/netlists/<name>.cir``).
    levels : sequence of float
        ε values.
    tstop : dict, optional
        Stop time per converter (s); default :data:`TSTOP`.

    Returns
    -------
    list of ConvergencePoint
    """
    stops = tstop or TSTOP
    points = []
    for name in converters:
        text = (NETLISTS / f"{name}.cir").read_text()
        for eps in levels:
            # the study is of ngspice converging to pelcs' *ideal* devices
            cmp = compare(model_deck(text, eps), ["v(out)", "i(L1)"], tstop=stops.get(name),
                          settings=_LADDER, timeout=300, devices="ideal")
            vout, il = cmp.probes
            points.append(ConvergencePoint(
                converter=name, eps=eps, delta=cmp.nonideal.delta, rung=cmp.rung,
                settings=cmp.settings.name, vout_pelcs=vout.mean_pelcs,
                vout_ngspice=vout.mean_ngspice,
                mean_error=abs(vout.mean_error) / abs(vout.mean_pelcs),
                nrms_vout=vout.nrms, nrms_il=il.nrms, ngspice_wall=cmp.ngspice_wall,
                pelcs_wall=cmp.pelcs_wall,
            ))
    return points


def columns(points: Sequence[ConvergencePoint]) -> dict[str, np.ndarray]:
    """The study as a table: one column per field of :class:`ConvergencePoint`, in its order,
    one row per point (``converter``, ``settings``: strings; ``rung``: int; the rest floats in
    SI units: ``eps`` in ohm (and dimensionless N), ``vout_*`` in V, ``*_wall`` in s,
    ``delta``, ``mean_error`` and ``nrms_*`` fractions)."""
    out = {}
    for f in fields(ConvergencePoint):
        values = [getattr(p, f.name) for p in points]
        out[f.name] = np.array(values, dtype=object if f.type == "str" else
                               np.int64 if f.type == "int" else float)
    return out


def order(points: Sequence[ConvergencePoint], converter: str) -> float | None:
    """The order in ε of the mean error of ``converter`` between its largest and smallest ε
    (the slope of the log-log line through the two), or None with fewer than two points or a
    zero error."""
    pts = sorted((p for p in points if p.converter == converter), key=lambda p: p.eps)
    if len(pts) < 2 or not (pts[0].mean_error > 0 and pts[-1].mean_error > 0):
        return None
    return math.log(pts[-1].mean_error / pts[0].mean_error) / math.log(pts[-1].eps / pts[0].eps)


def figure(points: Sequence[ConvergencePoint]):
    """Log-log plot of the three differences against ε, one panel per converter: a matplotlib
    Figure on the Agg canvas (written by the caller)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    names = list(dict.fromkeys(p.converter for p in points))
    fig = Figure(figsize=(5.2 * len(names), 4.4), dpi=120, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, len(names), squeeze=False)[0]
    series = [("mean_error", "mean v(out), relative", "o-", "#1f77b4"),
              ("nrms_vout", "NRMS v(out)", "s--", "#d62728"),
              ("nrms_il", "NRMS i(L1)", "^:", "#2ca02c")]
    for ax, name in zip(axes, names, strict=True):
        pts = sorted((p for p in points if p.converter == name), key=lambda p: p.eps)
        eps = [p.eps for p in pts]
        for attr, label, style, color in series:
            ax.loglog(eps, [getattr(p, attr) for p in pts], style, color=color, label=label,
                      ms=5, lw=1.2)
        # first-order guide through the largest mean error
        top = max(pts, key=lambda p: p.eps)
        ax.loglog(eps, [top.mean_error * e / top.eps for e in eps], color="0.6", lw=0.8,
                  ls="-.", label="slope 1")
        for p in pts:
            if p.rung:
                ax.annotate(f"rung {p.rung}", (p.eps, p.mean_error), fontsize=6,
                            color="0.4", textcoords="offset points", xytext=(3, -9))
        ax.set_xlabel("model scale ε  (RON = RS = ε Ω, N = ε)")
        ax.set_ylabel("ngspice - pelcs")
        ax.set_title(f"{name}.cir", fontsize=10)
        ax.grid(True, which="both", color="0.9", lw=0.5)
        ax.legend(fontsize=8, loc="lower right")
    fig.suptitle("ngspice converges to pelcs as its diode and switch models approach the ideal",
                 fontsize=10)
    return fig
