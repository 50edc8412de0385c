"""The results of the Python API's analyses, for scripts and notebooks.

Every result holds the report the command's ``--json`` prints (``.report``, a dict) and the
computed object (the comparison, orbit, continuation, diagram, basin map or sweep table), and
gives:

- ``.to_pandas()``: a DataFrame (the sweep and the bifurcation diagram one row per run or
  recorded sample, as the command's CSV);
- ``.plot(ax=None)``: the matplotlib Figure, drawn by the command's plotting code (on an Agg
  canvas, no pyplot); with ``ax``, the figure is drawn in the place of that Axes (a subfigure
  of its figure), and that figure is returned;
- a short ``repr`` (what was computed and the verdict, a few lines) and ``_repr_html_`` (the
  summary as a small table and the figure as an inline PNG) for notebooks.
"""

from __future__ import annotations

import base64
import html
import io
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from lcs.results import SimulationResult

#: The resolution of the figure inlined by ``_repr_html_`` (dots per inch): small pages.
HTML_DPI = 50


def _target(ax):
    """The SubFigure taking the place of ``ax`` (removed), or None for a new Figure."""
    if ax is None:
        return None
    spec = ax.get_subplotspec()
    if spec is None:
        raise ValueError("plot(ax=...): the Axes must be a subplot (fig.subplots / "
                         "fig.add_subplot), whose place the figure takes")
    parent = ax.figure
    ax.remove()
    return parent.add_subfigure(spec)


def _root(fig):
    """The top-level Figure of a Figure or SubFigure."""
    while getattr(fig, "figure", fig) is not fig and fig.figure is not None:
        fig = fig.figure
    return fig


def _html(title: str, rows: list[tuple[str, Any]], fig) -> str:
    """A small HTML table of ``rows`` under ``title``, and ``fig`` as an inline PNG."""
    cells = "".join(f"<tr><th style='text-align:left'>{html.escape(str(k))}</th>"
                    f"<td style='text-align:left'>{html.escape(str(v))}</td></tr>"
                    for k, v in rows)
    out = f"<div><b>{html.escape(title)}</b><table>{cells}</table>"
    if fig is not None:
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=HTML_DPI)
        data = base64.b64encode(buf.getvalue()).decode("ascii")
        out += f"<img src='data:image/png;base64,{data}'/>"
    return out + "</div>"


def _short(text: str, width: int = 100) -> str:
    return text if len(text) <= width else text[: width - 3] + "..."


class _Result:
    """Shared: ``repr`` from :meth:`summary`, ``_repr_html_`` from it and the figure."""

    def summary(self) -> list[tuple[str, Any]]:  # pragma: no cover - every result has one
        raise NotImplementedError

    def _title(self) -> str:
        raise NotImplementedError

    def __repr__(self) -> str:
        lines = [f"<{type(self).__name__} {self._title()}>"]
        lines += [f"  {k}: {_short(str(v))}" for k, v in self.summary()]
        return "\n".join(lines)

    def _repr_html_(self) -> str:
        try:
            fig = self.plot()
        except ValueError:  # (nothing to draw: e.g. a sweep of no parameter)
            fig = None
        return _html(self._title(), self.summary(), fig)


def _name(report: dict) -> str:
    return Path(report.get("file", "")).name


@dataclass(repr=False)
class CheckResult(_Result):
    """``pelcs check``: pelcs against ngspice.

    Attributes
    ----------
    verdict : str
        ``"ok"``, ``"fail"`` or ``"inconclusive"`` (the JSON report's ``verdict``).
    verdict_line : str
        What ``pelcs check`` prints last: ``within tolerance``, ``OUT OF TOLERANCE: ...``
        or ``INCONCLUSIVE: ...``.
    table : str
        The table ``pelcs check`` prints.
    comparison : ngspice_checks.comparison.Comparison
        Everything compared, with both waveforms (``.pelcs_result``, ``.ngspice_result``).
    report : dict
        What ``pelcs check --json`` prints.
    """

    comparison: Any
    report: dict = field(default_factory=dict)

    @property
    def verdict(self) -> str:
        return self.comparison.verdict

    @property
    def ok(self) -> bool:
        """True when the verdict is agreement (exit status 0 of ``pelcs check``)."""
        return self.comparison.ok

    @property
    def verdict_line(self) -> str:
        from pelcs.check_report import verdict_line

        return verdict_line(self.comparison)

    @property
    def table(self) -> str:
        from pelcs.check_report import format_table

        return format_table(self.comparison)

    def _title(self) -> str:
        return f"pelcs check {_name(self.report)}: {self.verdict_line.split(':')[0]}"

    def summary(self) -> list[tuple[str, Any]]:
        from pelcs.check_report import probe_verdict, switch_verdict

        c = self.comparison
        rows = [("verdict", self.verdict_line),
                ("probes", ", ".join(f"{p.probe} {probe_verdict(c, p)}" for p in c.probes)),
                ("switches", ", ".join(f"{s.switch} {switch_verdict(s)}"
                                       for s in c.switches) or "none"),
                ("run", f"tstop {c.tstop:.4g} s, step {c.step:.4g} s, θ = {c.theta:g}; "
                        f"ngspice rung {c.rung}")]
        return rows

    def to_pandas(self):
        """One row per probe: the metrics and tolerances of the table (SI units), ``ok``,
        ``conclusive`` and the ``verdict`` the table prints (``ok``, ``FAIL``,
        ``inconclusive``)."""
        import pandas as pd

        from pelcs.check_report import probe_verdict

        cols = ["probe", "nrms", "nrms_tol", "mean_pelcs", "mean_ngspice", "mean_error",
                "mean_tol", "ripple_pelcs", "ripple_ngspice", "ripple_error", "ripple_tol",
                "ok", "conclusive"]
        rows = [{**{k: p[k] for k in cols}, "verdict": probe_verdict(self.comparison, q)}
                for p, q in zip(self.report["probes"], self.comparison.probes, strict=True)]
        return pd.DataFrame(rows, columns=[*cols, "verdict"])

    def plot(self, ax=None):
        """pelcs (solid) and ngspice (dashed) per probe, whole run and last periods: the
        figure of ``pelcs check --report``."""
        from pelcs.check_report import comparison_figure

        return _root(comparison_figure(self.comparison, fig=_target(ax)))


@dataclass(repr=False)
class OrbitResult(_Result):
    """``pelcs orbit``: a periodic orbit of the stroboscopic (or event) map.

    Attributes
    ----------
    converged : bool
        False: Newton found no orbit; ``points`` is its last iterate, ``multipliers`` None.
    points : ndarray, shape (order, n)
        The orbit's states at the sampling instants (SI units of each state).
    multipliers : ndarray of complex or None
        Floquet multipliers (None when not converged).
    stability : str
    report : dict
        What ``pelcs orbit --json`` prints.
    orbit : lcs.analysis.orbits.PeriodicOrbit
    """

    orbit: Any
    report: dict = field(default_factory=dict)

    @property
    def converged(self) -> bool:
        return bool(self.report["converged"])

    @property
    def points(self) -> np.ndarray:
        return np.asarray(self.report["points"], dtype=float)

    @property
    def multipliers(self) -> np.ndarray | None:
        m = self.report["multipliers"]
        return None if m is None else np.array([complex(a, b) for a, b in m])

    @property
    def stability(self) -> str:
        return self.report["stability"]

    @property
    def states(self) -> list[str]:
        return list(self.report["states"])

    @property
    def text(self) -> str:
        """The report ``pelcs orbit`` prints."""
        from pelcs.commands.orbit import format_orbit

        return format_orbit(self.report, _name(self.report))

    def _title(self) -> str:
        r = self.report
        what = (f"period-{r['order']} orbit" if self.converged
                else f"NO period-{r['order']} orbit found")
        return f"pelcs orbit {_name(r)}: {what}, T = {r['period']:.6g} s"

    def summary(self) -> list[tuple[str, Any]]:
        r = self.report
        rows = [("stability", r["stability"])]
        if self.converged:
            mods = r["multiplier_moduli"]
            rows.append(("max |μ|", f"{max(mods):.6g}" if mods else "-"))
        else:
            rows.append(("multipliers", "none: Newton did not converge (last iterate only)"))
        rows.append(("Newton", f"{'converged' if self.converged else 'NOT converged'} in "
                               f"{r['iterations']} iteration(s), scaled residual "
                               f"{r['residual']:.3g}"))
        if r.get("pattern_text"):
            rows.append(("pattern", r["pattern_text"]))
        return rows

    def to_pandas(self):
        """One row per point of the orbit (``k``), one column per state (SI units)."""
        import pandas as pd

        df = pd.DataFrame(self.points, columns=self.states)
        df.insert(0, "k", np.arange(len(df)))
        return df

    def plot(self, ax=None):
        """The Floquet multipliers in the complex plane with the unit circle (a converged
        orbit), and the orbit's points in the plane of its first two states."""
        from pelcs.api_plots import orbit_figure

        return _root(orbit_figure(self.report, fig=_target(ax)))


@dataclass(repr=False)
class ContinuationResult(_Result):
    """``pelcs continue``: a periodic orbit followed in a parameter, its bifurcations.

    Attributes
    ----------
    complete : bool
        False: the continuation stopped early (exit status 3 of the command).
    bifurcations : list of dict
        ``{"type", "param", "bracket", "detail", "located", ...}``.
    report : dict
        What ``pelcs continue --json`` prints.
    result : lcs.analysis.continuation.ContinuationResult
    """

    result: Any
    report: dict = field(default_factory=dict)

    @property
    def complete(self) -> bool:
        return bool(self.report["complete"])

    @property
    def bifurcations(self) -> list[dict]:
        return list(self.report["bifurcations"])

    @property
    def text(self) -> str:
        """The report ``pelcs continue`` prints."""
        from pelcs.commands.continuation import format_continuation

        return format_continuation(self.report, _name(self.report))

    def _title(self) -> str:
        r = self.report
        return (f"pelcs continue {_name(r)}: period-{r['order']} orbit in {r['param_name']} "
                f"from {r['start']:g} to {r['stop']:g}")

    def summary(self) -> list[tuple[str, Any]]:
        r = self.report
        bifs = "; ".join(f"{b['type']} at {r['param_name']} = {b['param']:.6g}"
                         for b in r["bifurcations"]) or "none found"
        return [("orbits", f"{len(r['branch'])}" + ("" if self.complete
                                                    else " (stopped early)")),
                ("bifurcations", bifs)]

    def to_pandas(self):
        """One row per orbit of the branch: the parameter, the first point's states, the
        largest multiplier modulus (NaN where Newton did not converge), the stability."""
        import pandas as pd

        r = self.report
        rows = []
        for o in r["branch"]:
            mus = o["multipliers"]
            row = {r["param_name"]: o["param"]}
            row.update(zip(r["states"], o["point"], strict=False))
            row["max_abs_multiplier"] = (max(abs(complex(a, b)) for a, b in mus)
                                         if mus else np.nan)
            row["stability"] = o["stability"]
            rows.append(row)
        return pd.DataFrame(rows, columns=[r["param_name"], *r["states"],
                                           "max_abs_multiplier", "stability"])

    def plot(self, ax=None):
        """The largest multiplier modulus along the parameter (|μ| = 1 marked) and the
        orbit's first point, with the bifurcations marked."""
        from pelcs.api_plots import continuation_figure

        return _root(continuation_figure(self.report, fig=_target(ax)))


@dataclass(repr=False)
class BifurcationResult(_Result):
    """``pelcs bifurcation``: the sampled attractor along a parameter.

    Attributes
    ----------
    diagram : lcs.analysis.bifurcation.BifurcationDiagram
    summary_text : str
        What ``pelcs bifurcation`` prints.
    runs : list of (str, float, float, str)
        The summary's runs: direction, from, to, the attractor's period or the failure.
    """

    diagram: Any
    file: str = ""
    title: str = ""
    summary_text: str = ""
    runs: list = field(default_factory=list)

    def _title(self) -> str:
        d = self.diagram
        k = d.branches[0].values.size if d.branches else 0
        return (f"pelcs bifurcation {Path(self.file).name}: {d.param_name}, {k} values, "
                f"{d.record} periods recorded")

    def summary(self) -> list[tuple[str, Any]]:
        rows = []
        for direction, lo, hi, label in self.runs[:8]:
            span = f"{lo:.6g}" if lo == hi else f"{lo:.6g} .. {hi:.6g}"
            rows.append((f"{direction} {span}", label))
        if len(self.runs) > 8:
            rows.append(("...", f"{len(self.runs) - 8} more runs (.runs)"))
        return rows

    def to_pandas(self):
        """One row per recorded sample, as ``pelcs bifurcation -o OUT.csv``: ``direction``,
        the parameter, ``k`` (the recorded period), the probes (SI units)."""
        import pandas as pd

        return pd.DataFrame(self.diagram.columns())

    def plot(self, ax=None):
        """The diagram as ``pelcs bifurcation --plot`` draws it."""
        from pelcs.analysis_plots import bifurcation_figure

        return _root(bifurcation_figure(self.diagram, title=self.title or Path(self.file).name,
                                        fig=_target(ax)))


@dataclass(repr=False)
class BasinsResult(_Result):
    """``pelcs basins``: attractors and basins by simple cell mapping.

    Attributes
    ----------
    basins : lcs.analysis.basins.BasinMap
        ``.group`` (0: leaves the grid), ``.steps``, ``.attractors``, ``.grid``.
    summary_text : str
        What ``pelcs basins`` prints.
    """

    basins: Any
    file: str = ""
    title: str = ""
    summary_text: str = ""

    def _title(self) -> str:
        a0, a1 = self.basins.grid.axes
        return (f"pelcs basins {Path(self.file).name}: {a0.name} x {a1.name}, "
                f"{a0.count} x {a1.count} cells")

    def summary(self) -> list[tuple[str, Any]]:
        bm = self.basins
        n = bm.grid.size
        sink = int(np.count_nonzero(bm.group == 0))
        rows = [("attractors", len(bm.attractors)),
                ("leave the grid", f"{sink} of {n} cells")]
        for at in bm.attractors[:6]:
            rows.append((f"attractor {at.group}", f"{at.period} periodic cell(s), basin "
                                                  f"{at.basin_cells} cells"))
        return rows

    def to_pandas(self):
        """One row per cell: the two states at its centre, ``group`` (the attractor whose
        basin it is; 0 leaves the grid, -1 not computed) and ``steps`` (periods to reach
        it)."""
        import pandas as pd

        bm = self.basins
        a0, a1 = bm.grid.axes
        centres = bm.grid.centres()
        return pd.DataFrame({a0.name: centres[:, 0], a1.name: centres[:, 1],
                             "group": np.asarray(bm.group).ravel(),
                             "steps": np.asarray(bm.steps).ravel()})

    def plot(self, ax=None):
        """Basins and transient time, as ``pelcs basins --plot`` draws them."""
        from pelcs.analysis_plots import basins_figure

        return _root(basins_figure(
            self.basins, title=f"basins: {self.title or Path(self.file).name}",
            fig=_target(ax)))


@dataclass(repr=False)
class SweepResult(_Result):
    """``pelcs sweep``: measurements over a parameter grid and/or Monte Carlo runs.

    Attributes
    ----------
    table : lcs.analysis.tables.SweepTable
    report : dict
        What ``pelcs sweep --json`` prints (``rows``, ``statistics``...).
    summary_text : str
        What ``pelcs sweep`` prints.
    plot_title : str
        The title of the command's plot.
    """

    table: Any
    report: dict = field(default_factory=dict)
    summary_text: str = ""
    plot_title: str = ""

    def _title(self) -> str:
        t = self.table
        what = f"Monte Carlo, {t.runs} runs" if t.runs else \
            (f"sweep of {', '.join(t.swept)}" if t.swept else "one run")
        return f"pelcs sweep {_name(self.report)}: {what}"

    def summary(self) -> list[tuple[str, Any]]:
        t = self.table
        rows = [("runs", f"{len(t)}, {int(np.sum(t.ok))} ok"
                         + (f", {int(np.sum(t.ok & ~t.settled))} not settled"
                            if t.settled is not None and np.any(t.ok & ~t.settled) else "")),
                ("measures", ", ".join(t.measures))]
        if t.runs:
            rows.append(("seed", t.seed))
        return rows

    def to_pandas(self):
        """One row per run, as ``pelcs sweep -o OUT.csv``: the inputs (swept parameters,
        ``run`` and the drawn values of a Monte Carlo run), the measurements (SI units),
        ``ok``, ``settled``, ``message``."""
        import pandas as pd

        t = self.table
        data: dict[str, Any] = {}
        for j, name in enumerate(t.inputs):
            col = np.asarray(t.input_values)[:, j] if len(t) else np.empty(0)
            data[name] = col.astype(int) if name == "run" else col.astype(float)
        for j, name in enumerate(t.measures):
            data[name] = np.asarray(t.values)[:, j] if len(t) else np.empty(0)
        data["ok"] = np.asarray(t.ok, dtype=bool)
        data["settled"] = [bool(s) if ok else None for s, ok in zip(t.settled, t.ok,
                                                                    strict=True)]
        data["message"] = list(t.messages)
        return pd.DataFrame(data)

    def plot(self, ax=None):
        """The measurements against the first swept parameter, or the histograms of a Monte
        Carlo run, as ``pelcs sweep --plot`` draws them."""
        from pelcs.sweep_plots import histogram_figure, sweep_figure

        t = self.table
        title = self.plot_title or None
        fig = _target(ax)
        if t.runs:
            return _root(histogram_figure(t, title=title, fig=fig))
        return _root(sweep_figure(t, title=title, fig=fig))


class Simulation(SimulationResult):
    """``pelcs simulate``: a run's probes (:class:`lcs.results.SimulationResult`, every
    attribute and method of it), with the figure ``pelcs simulate --plot`` draws
    (``.plot(ax=None)``) and a notebook display of its summary and figure."""

    def plot(self, ax=None):
        """One panel per probe over the run, and the last switching periods with their mean
        where the run has them, as ``pelcs simulate --plot`` draws them."""
        from pelcs.plotting import result_figure

        return _root(result_figure(self, fig=_target(ax)))

    def summary(self) -> list[tuple[str, Any]]:
        """What ``pelcs simulate`` prints first: points, span, probes, steps, switchings,
        and the error or the notes."""
        t = np.asarray(self.t)
        rows: list[tuple[str, Any]] = [
            ("points", self.points),
            ("t", f"{t[0]:.6g} .. {t[-1]:.6g} s" if t.size else "no points"),
            ("probes", ", ".join(self.names)),
            ("steps", self.stats.steps),
            ("switchings", self.switchings),
        ]
        if self.error is not None:
            rows.append(("error", str(self.error)))
        rows += [("note", note) for note in self.notes]
        return rows

    def _repr_html_(self) -> str:
        t = np.asarray(self.t)
        fig = self.plot() if t.size and len(self.names) else None
        return _html("simulation", self.summary(), fig)


def as_simulation(result: SimulationResult) -> Simulation:
    """``result`` as a :class:`Simulation` (the same attributes; no copy of its arrays)."""
    if isinstance(result, Simulation):
        return result
    out = Simulation.__new__(Simulation)
    out.__dict__.update(result.__dict__)
    return out
