"""Present a :class:`~ngspice_checks.compare.Comparison`: text table, figure, Markdown, JSON.

:func:`write_report` writes, into one directory, for a netlist ``NAME.cir``:

- ``NAME.png``: one row per probe, both traces over the whole run (pelcs solid, ngspice
  dashed) and a zoom on the last periods of the steady-state window;
- ``NAME.md``: the verdict, the settings of both runs (ngspice's ladder rung), both wall
  times side by side, the metric tables with their tolerances, the notes, the figure;
- ``NAME.json``: the same as data (:meth:`Comparison.to_dict`);
- ``NAME.ngspice.cir``: the deck ngspice ran (the rung's edits and sense sources included).

:func:`format_table` is what ``pelcs check`` prints.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import NamedTuple

import numpy as np

from lcs.atomic import atomic_path
from netlist.probes import probe_unit
from netlist.units import format_eng
from ngspice_checks.compare import Comparison
from pelcs.figures import axis_label, envelope, new_figure, save_figure, time_unit
from pelcs.jsonout import dumps

__all__ = ["comparison_figure", "format_table", "markdown_report", "plot_comparison", "to_json",
           "verdict_line", "write_report"]


def _eng(value: float | None, unit: str = "") -> str:
    """``value`` in engineering notation (``"1.5 mV"``), ``"n/a"`` when there is none."""
    if value is None or not math.isfinite(value):
        return "n/a"
    return format_eng(float(value), unit)


def _pct(x: float) -> str:
    """A fraction as a percentage (``"1.25 %"``), ``"n/a"`` when not finite."""
    return "n/a" if not math.isfinite(x) else f"{100 * x:.2f} %"


def _verdict(ok: bool) -> str:
    return "ok" if ok else "FAIL"


class _Cells(NamedTuple):
    """A compared probe's figures as the table and the Markdown report write them."""

    nrms: str
    nrms_tol: str
    mean_pelcs: str
    mean_ngspice: str
    mean_diff: str
    mean_tol: str
    ripple_pelcs: str
    ripple_ngspice: str
    ripple_diff: str
    ripple_tol: str


def _probe_cells(p) -> _Cells:
    """The figures of one compared probe: NRMS and the mean and ripple differences as
    percentages of the probe's scale, the values in SI units, the tolerances beside them."""
    u = probe_unit(p.probe)
    return _Cells(_pct(p.nrms), _pct(p.nrms_tol), _eng(p.mean_pelcs, u),
                  _eng(p.mean_ngspice, u), _pct(p.mean_error / p.scale),
                  _pct(p.mean_tol / p.scale), _eng(p.ripple_pelcs, u),
                  _eng(p.ripple_ngspice, u), _pct(p.ripple_error / p.scale),
                  _pct(p.ripple_tol / p.scale))


def _probe_verdict(cmp: Comparison, p) -> str:
    """A probe's verdict: a pass under a tolerance too wide to decide is not agreement."""
    if not p.ok:
        return "FAIL"
    if p.pointwise or p.unjudged:
        return f"inconclusive ({p.pointwise or p.unjudged})"
    return "inconclusive" if p.widest > cmp.tolerances.conclusive else "ok"


def probe_verdict(cmp: Comparison, probe) -> str:
    """A probe's verdict as the table prints it: ``ok``, ``FAIL`` or ``inconclusive``."""
    return _probe_verdict(cmp, probe)


def switch_verdict(switch) -> str:
    """A switch's verdict as the table prints it: ``ok``, ``FAIL`` or ``not compared``."""
    return _verdict(switch.ok) if switch.method != "none" else "not compared"


def verdict_line(cmp: Comparison) -> str:
    """The verdict line ``pelcs check`` prints last: ``within tolerance``, ``OUT OF
    TOLERANCE: ...`` or ``INCONCLUSIVE: ...``."""
    return _summary(cmp)


def _transient_cell(p) -> str:
    """Where the NRMS was taken, when not over the whole run, and the transient's figure."""
    if p.nrms_over == "run":
        return ""
    return (f"; NRMS over the steady state, transient {_pct(p.transient_nrms)} "
            f"[{_pct(p.transient_tol)}]")


def _summary(cmp: Comparison) -> str:
    """The last line: the verdict and what it rests on."""
    if cmp.verdict == "fail":
        return "OUT OF TOLERANCE: " + "; ".join(cmp.failures)
    if cmp.verdict == "inconclusive":
        why = []
        wide = [p.probe for p in cmp.probes if p.widest > cmp.tolerances.conclusive]
        if wide:
            widest = max(p.widest for p in cmp.probes)
            why.append(f"tolerances of up to {100 * widest:.3g} % (over "
                       f"{100 * cmp.tolerances.conclusive:.3g} %) decide nothing for "
                       + ", ".join(wide))
        if cmp.sensitivity:
            why.append(cmp.sensitivity + ", so two simulations of it need not agree point "
                       "by point; the waveforms and instants that differ are not judged, the "
                       "means and ripples are within tolerances widened by twice pelcs' own "
                       "spread")
        if cmp.orbit:
            why.append(cmp.orbit + "; the window's metrics that differ are not judged")
        return "INCONCLUSIVE: " + "; ".join(why) + "; no agreement shown"
    if cmp.transient:
        return "within tolerance over the steady state: " + cmp.transient
    if cmp.sensitivity:
        return "within tolerance point by point, although " + cmp.sensitivity
    return "within tolerance"


def _devices_line(cmp: Comparison) -> str:
    if cmp.devices == "pwl":
        return "piecewise-linear diodes and switches fitted to ngspice's models"
    return "ideal diodes and switches"


def _settings_line(cmp: Comparison) -> str:
    """ngspice's settings of the comparison: its rung of the ladder and what it set."""
    s = cmp.settings
    line = f"rung {cmp.rung} ({s.name}"
    return line + (f": {s.description})" if s.description else ")")


# ------------------------------------------------------------------------------------------
# text


def format_table(cmp: Comparison) -> str:
    """The summary ``pelcs check`` prints: header, one line per probe and switch, verdict.

    Differences are relative to each probe's scale (max(RMS, ½ peak-to-peak) of the pelcs
    waveform), tolerances in brackets.
    """
    lines = [f"{cmp.file}: {cmp.title}".rstrip(": ")]
    lines.append(
        f"pelcs: {cmp.pelcs_steps} steps of {_eng(cmp.step, 's')} (θ = {cmp.theta:g}) in "
        f"{cmp.pelcs_wall:.3g} s   |   ngspice: {cmp.ngspice_points} points in "
        f"{cmp.ngspice_wall:.3g} s ({cmp.ngspice_total:.3g} s with start-up"
        + (f" and {len(cmp.attempts)} failed rung{'s' * (len(cmp.attempts) > 1)}"
           if cmp.attempts else "") + f"), {_settings_line(cmp)}"
    )
    per = (f"{cmp.n_periods} period{'s' if cmp.n_periods != 1 else ''} of "
           f"{_eng(cmp.period, 's')} ({cmp.period_source})"
           if cmp.n_periods else cmp.period_source)
    lines.append(f"steady state: {_eng(cmp.window[0], 's')} to {_eng(cmp.window[1], 's')}, "
                 f"{per}; pelcs devices: {cmp.devices}; "
                 + ("model drops the fits leave" if cmp.devices == "pwl" else
                    "non-ideal drops") + f" δ = {_pct(cmp.nonideal.delta)} of "
                 f"{_eng(cmp.nonideal.v_ref, 'V')}")
    head = (f"{'probe':<12} {'NRMS [tol]':>18} {'mean pelcs':>11} {'ngspice':>11} "
            f"{'diff [tol]':>19} {'ripple pelcs':>12} {'ngspice':>11} {'diff [tol]':>19}  ")
    lines.append(head)
    for p in cmp.probes:
        c = _probe_cells(p)
        lines.append(
            f"{p.probe:<12} {c.nrms:>8} [{c.nrms_tol:>7}] {c.mean_pelcs:>11} "
            f"{c.mean_ngspice:>11} {c.mean_diff:>8} [{c.mean_tol:>7}] {c.ripple_pelcs:>12} "
            f"{c.ripple_ngspice:>11} {c.ripple_diff:>8} [{c.ripple_tol:>7}]  "
            f"{_probe_verdict(cmp, p)}" + (f" ({', '.join(p.failures)})" if p.failures
                                           else "") + _transient_cell(p)
        )
    for s in cmp.switches:
        if s.method == "instants" and s.reason:  # one side only, or neither, switches
            what = (f"{s.n_pelcs}/{s.n_ngspice} switchings: {s.reason}"
                    + (f", max offset [{_eng(s.tol, 's')}]" if not s.ok else ""))
        elif s.method == "instants":
            what = (f"{s.n_pelcs}/{s.n_ngspice} switchings, max offset "
                    f"{_eng(s.max_offset, 's')} [{_eng(s.tol, 's')}]"
                    + (f" ({s.note})" if s.note else ""))
        elif s.method == "frequency":
            what = (f"frequency {_eng(s.freq_pelcs, 'Hz')} / {_eng(s.freq_ngspice, 'Hz')} "
                    f"[{_pct(s.tol)}] ({s.reason})")
        else:
            what = f"not compared: {s.reason}"
        verdict = ("" if s.method == "none" else
                   f"inconclusive ({s.inconclusive}: pelcs perturbed moves them by "
                   f"{_eng(s.self_offset, 's')})" if s.inconclusive else _verdict(s.ok))
        if s.inconclusive == "another orbit":
            verdict = "inconclusive (another orbit)"
        lines.append(f"switch {s.switch} ({s.driven}): {what}  {verdict}")
    for n in cmp.notes:
        lines.append(f"note: {n}")
    lines.append(_summary(cmp))
    return "\n".join(line.rstrip() for line in lines)


# ------------------------------------------------------------------------------------------
# figure

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
        ax.set_title(f"NRMS {_pct(p.nrms)} (tol {_pct(p.nrms_tol)})", loc="right",
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
        az.set_title(f"mean {_eng(p.mean_pelcs, u)} / {_eng(p.mean_ngspice, u)}, ripple "
                     f"{_eng(p.ripple_pelcs, u)} / {_eng(p.ripple_ngspice, u)}",
                     loc="right", fontsize=8, color=color, pad=3)
    axes[0, 0].legend(fontsize=8, loc="best")  # (pelcs solid, ngspice dashed)
    axes[-1, 0].set_xlabel(f"time [{tunit}]")
    axes[-1, 1].set_xlabel(f"time [{zunit}] (last periods)")
    name = Path(cmp.file).name
    fig.suptitle(f"{cmp.title}  ({name})\npelcs (solid) vs ngspice (dashed, "
                 f"{_settings_line(cmp)}): "
                 f"{_summary(cmp).split(':')[0]}", fontsize=10,
                 color="black" if cmp.ok else "red")
    return fig


# ------------------------------------------------------------------------------------------
# Markdown and JSON


def markdown_report(cmp: Comparison, figure: str | None = None) -> str:
    """The Markdown report (``figure``: a path relative to the report, to embed)."""
    s = cmp.settings
    out = [f"# pelcs vs ngspice: {cmp.title or Path(cmp.file).name}", ""]
    head, _, rest = _summary(cmp).partition(": ")
    out.append(f"**{head[0].upper() + head[1:]}**" + (f": {rest}" if rest else ""))
    out += ["", f"Netlist: `{cmp.file}`"
            + (f", parameters {', '.join(f'{k}={v}' for k, v in cmp.params.items())}"
               if cmp.params else ""), ""]
    out += ["## Runs", "",
            "| | pelcs | ngspice |", "|---|---|---|",
            f"| wall time | {cmp.pelcs_wall:.3g} s (+ {cmp.pelcs_load:.2g} s loading the "
            f"compiled kernels) | {cmp.ngspice_wall:.3g} s ({cmp.ngspice_total:.3g} s with "
            "process start-up and failed rungs) |",
            f"| time points | {cmp.pelcs_steps} steps of {_eng(cmp.step, 's')}, θ = "
            f"{cmp.theta:g} | {cmp.ngspice_points} (variable step) |",
            f"| settings | {_devices_line(cmp)} | {_settings_line(cmp)} |", ""]
    if cmp.device_fits:
        out += ["pelcs' devices: " + "; ".join(f.line() for f in cmp.device_fits) + ".", ""]
    if s.options or s.pulse_min_edge or s.diode_model or s.switch_model:
        parts = []
        if s.options:
            parts.append("`.options " + " ".join(
                k if v is None else f"{k}={v}" for k, v in s.options.items()) + "`")
        if s.pulse_min_edge:
            parts.append(f"PULSE edges and widths >= {_eng(s.pulse_min_edge, 's')}")
        if s.diode_model:
            parts.append("diode models " + " ".join(f"{k}={v}" for k, v in
                                                   s.diode_model.items()))
        if s.switch_model:
            parts.append(f"switch models RON={s.switch_model.ron:g} "
                         f"ROFF={s.switch_model.roff:g} VH>={s.switch_model.vh_min:g}")
        out += ["ngspice rung edits: " + "; ".join(parts) + ".", ""]
    for r, name, why in cmp.attempts:
        out.append(f"- rung {r} ({name}) failed: {why}")
    if cmp.attempts:
        out.append("")
    per = (f"{cmp.n_periods} period{'s' if cmp.n_periods != 1 else ''} of "
           f"{_eng(cmp.period, 's')} ({cmp.period_source})"
           if cmp.n_periods else cmp.period_source)
    out += [f"Compared from {_eng(cmp.span[0], 's')} to {_eng(cmp.span[1], 's')}; steady "
            f"state from {_eng(cmp.window[0], 's')}: {per}.", ""]
    ni = cmp.nonideal
    drops = [f"{k} {_eng(v, 'V')}" for k, v in {**ni.diode_drops, **ni.switch_drops}.items()]
    what = ("What the fits leave of ngspice's models at the currents the devices carry"
            if cmp.devices == "pwl" else
            "Non-ideal drops of ngspice's models at the currents the devices carry")
    out += [f"{what}: "
            f"{', '.join(drops) or 'none'}; δ = {_pct(ni.delta)} of "
            f"{_eng(ni.v_ref, 'V')} (tolerances: module docstring of "
            "`ngspice_checks/compare.py`).", ""]
    out += ["## Probes", "",
            "Differences relative to the probe's scale s = max(RMS, ½ peak-to-peak) of the "
            "pelcs waveform; tolerances in brackets.", "",
            "| probe | ngspice | NRMS | mean pelcs | mean ngspice | diff | ripple pelcs | "
            "ripple ngspice | diff | |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for p in cmp.probes:
        c = _probe_cells(p)
        out.append(
            f"| `{p.probe}` | `{p.ngspice_probe}` | {c.nrms} [{c.nrms_tol}] | "
            f"{c.mean_pelcs} | {c.mean_ngspice} | {c.mean_diff} [{c.mean_tol}] | "
            f"{c.ripple_pelcs} | {c.ripple_ngspice} | {c.ripple_diff} [{c.ripple_tol}] | "
            f"{_probe_verdict(cmp, p)}" + _transient_cell(p) + " |")
    if cmp.probes:
        out += ["", f"NRMS leaves out {_pct(cmp.probes[0].excluded)} of the grid points "
                "(those next to a switching instant).", ""]
    if cmp.switches:
        out += ["## Switching", "",
                "| switch | driven | compared | pelcs | ngspice | max offset | tolerance | |",
                "|---|---|---|---|---|---|---|---|"]
        for w in cmp.switches:
            if w.method == "frequency":
                vals = (f"{_eng(w.freq_pelcs, 'Hz')}", f"{_eng(w.freq_ngspice, 'Hz')}", "",
                        _pct(w.tol))
            else:
                vals = (f"{w.n_pelcs} switchings", f"{w.n_ngspice} switchings",
                        _eng(w.max_offset, "s"), _eng(w.tol, "s"))
            verdict = _verdict(w.ok) if w.method != "none" else w.reason
            if w.note:
                verdict += f" ({w.note})"
            out.append(f"| {w.switch} | {w.driven} | {w.method} | " + " | ".join(vals)
                       + f" | {verdict} |")
        out.append("")
    if cmp.notes:
        out += ["## Notes", ""] + [f"- {n}" for n in cmp.notes] + [""]
    if figure:
        out += ["## Waveforms", "", f"![pelcs vs ngspice]({figure})", ""]
    return "\n".join(out)


def write_report(cmp: Comparison, directory: str | os.PathLike, *, plot: bool = True
                 ) -> list[Path]:
    """Write NAME.md, NAME.json, NAME.png (``plot``) and NAME.ngspice.cir into ``directory``.

    Returns
    -------
    list of Path
        The files written.
    """
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    stem = Path(cmp.file).stem if cmp.file and cmp.file != "<string>" else "check"
    written = []
    png = None
    if plot and cmp.pelcs_result is not None and cmp.ngspice_result is not None:
        png = plot_comparison(cmp, d / f"{stem}.png")
        written.append(png)
    md = d / f"{stem}.md"
    with atomic_path(md) as tmp:
        tmp.write_text(markdown_report(cmp, png.name if png else None))
    js = d / f"{stem}.json"
    with atomic_path(js) as tmp:
        tmp.write_text(to_json(cmp) + "\n")
    written += [md, js]
    if cmp.ngspice_result is not None:
        deck = d / f"{stem}.ngspice.cir"
        with atomic_path(deck) as tmp:
            tmp.write_text(cmp.ngspice_result.netlist)
        written.append(deck)
    return written


def to_json(cmp: Comparison) -> str:
    """:meth:`Comparison.to_dict` as strict JSON text (:func:`pelcs.jsonout.dumps`: NaN and
    infinities as null; anything else JSON has no type for as its text)."""
    return dumps(cmp.to_dict(), indent=2, default=str)
