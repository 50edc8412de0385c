"""Figures of a periodic orbit and of a continuation (the commands print these as text; the
Python API draws them). From the reports ``pelcs orbit --json`` and ``pelcs continue --json``
print; on an Agg canvas, no pyplot.
"""

from __future__ import annotations

import numpy as np

from pelcs.figures import axis_label, new_figure


def _unit_circle(ax) -> None:
    a = np.linspace(0.0, 2.0 * np.pi, 361)
    ax.plot(np.cos(a), np.sin(a), color="0.5", lw=0.8, label="unit circle |μ| = 1")


def orbit_figure(report: dict, fig=None):
    """Two panels: the Floquet multipliers in the complex plane with the unit circle (none
    for an orbit not converged: said in the panel), and the orbit's points in the plane of
    its first two states (or the first state against k)."""
    fig = new_figure((10.0, 4.2), fig)
    ax1, ax2 = fig.subplots(1, 2)
    _unit_circle(ax1)
    if report["multipliers"] is not None:
        mus = np.array([complex(a, b) for a, b in report["multipliers"]])
        ax1.plot(mus.real, mus.imag, "x", color="tab:red", ms=9, mew=2,
                 label=f"Floquet multipliers ({report['stability']})")
    else:
        ax1.text(0.5, 0.5, "no orbit: Newton did not converge,\nno multipliers",
                 transform=ax1.transAxes, ha="center", va="center", color="tab:red")
    ax1.set_xlabel("Re μ (1)")
    ax1.set_ylabel("Im μ (1)")
    ax1.set_aspect("equal", adjustable="datalim")
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize="small", loc="upper left")
    ax1.set_title(f"period-{report['order']} orbit, T = {report['period']:.4g} s",
                  fontsize=10)
    pts = np.asarray(report["points"], dtype=float)
    states = list(report["states"])
    label = "orbit points" if report["converged"] else "last Newton iterate (not an orbit)"
    if pts.shape[1] >= 2:
        xs, ys = np.append(pts[:, 0], pts[0, 0]), np.append(pts[:, 1], pts[0, 1])
        ax2.plot(xs, ys, "o-", color="tab:blue", label=label)
        ax2.set_xlabel(axis_label(states[0]))
        ax2.set_ylabel(axis_label(states[1]))
    else:
        ax2.plot(np.arange(len(pts)), pts[:, 0], "o", color="tab:blue", label=label)
        ax2.set_xlabel("k (periods)")
        ax2.set_ylabel(axis_label(states[0]))
    ax2.grid(alpha=0.3)
    ax2.legend(fontsize="small", loc="best")
    return fig


def continuation_figure(report: dict, fig=None):
    """Two panels against the parameter: the largest multiplier modulus (|μ| = 1 marked) and
    the first state of the orbit's first point; bifurcations as vertical lines, one colour
    per type."""
    fig = new_figure((8.0, 5.6), fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    pn = report["param_name"]
    branch = report["branch"]
    p = np.array([o["param"] for o in branch], dtype=float)
    mx = np.array([max((abs(complex(a, b)) for a, b in o["multipliers"]), default=np.nan)
                   if o["multipliers"] is not None else np.nan for o in branch])
    ax1.plot(p, mx, "o-", ms=3, color="tab:blue", label="max |μ| of the orbit")
    ax1.axhline(1.0, color="0.4", ls="--", lw=0.8, label="|μ| = 1 (stability limit)")
    ax1.set_ylabel("max |μ| (1)")
    states = list(report["states"])
    if states and branch:
        x = np.array([o["point"][0] for o in branch], dtype=float)
        ax2.plot(p, x, "o-", ms=3, color="tab:green", label=f"{states[0]} at the first point")
        ax2.set_ylabel(axis_label(states[0]))
    colours = {"flip": "tab:red", "fold": "tab:orange", "neimark-sacker": "tab:purple",
               "border": "tab:brown"}
    seen = set()
    for b in report["bifurcations"]:
        colour = colours.get(b["type"], "k")
        for ax in (ax1, ax2):  # (each panel's legend names every colour it shows)
            ax.axvline(b["param"], color=colour, lw=1.0,
                       label=f"{b['type']} bifurcation" if b["type"] not in seen else None)
        seen.add(b["type"])
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3)
        ax.legend(fontsize="small", loc="best")
    ax2.set_xlabel(pn)
    ax1.set_title(f"period-{report['order']} orbit continued in {pn}", fontsize=10)
    return fig
