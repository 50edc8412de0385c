"""Present a :class:`~ngspice_checks.compare.Comparison`: text table, Markdown, JSON.

:func:`write_report` writes, into one directory, for a netlist ``NAME.cir``:

- ``NAME.png``: the figure the caller draws (``pelcs check --report``: one row per probe,
  both traces over the whole run and a zoom on the last periods, :mod:`pelcs.check_plots`);
- ``NAME.md``: the verdict, the settings of both runs (ngspice's ladder rung), both wall
  times side by side, the metric tables with their tolerances, the notes, the figure;
- ``NAME.json``: the same as data (:meth:`Comparison.to_dict`);
- ``NAME.ngspice.cir``: the deck ngspice ran (the rung's edits and sense sources included).

:func:`format_table` is what ``pelcs check`` prints.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from pathlib import Path

import numpy as np

from lcs.atomic import atomic_path
from netlist.units import format_eng, probe_unit

from .compare import Comparison

__all__ = ["eng", "format_table", "markdown_report", "percent", "settings_line", "to_json",
           "verdict_line", "write_report"]


def eng(value: float | None, unit: str = "") -> str:
    """``value`` in engineering notation (``"1.5 mV"``), ``"n/a"`` when there is none."""
    if value is None or not math.isfinite(value):
        return "n/a"
    return format_eng(float(value), unit)


def percent(x: float) -> str:
    """A fraction as a percentage (``"1.25 %"``), ``"n/a"`` when not finite."""
    return "n/a" if not math.isfinite(x) else f"{100 * x:.2f} %"


def _verdict(ok: bool) -> str:
    return "ok" if ok else "FAIL"


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
    return (f"; NRMS over the steady state, transient {percent(p.transient_nrms)} "
            f"[{percent(p.transient_tol)}]")


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


def settings_line(cmp: Comparison) -> str:
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
        f"pelcs: {cmp.pelcs_steps} steps of {eng(cmp.step, 's')} (θ = {cmp.theta:g}) in "
        f"{cmp.pelcs_wall:.3g} s   |   ngspice: {cmp.ngspice_points} points in "
        f"{cmp.ngspice_wall:.3g} s ({cmp.ngspice_total:.3g} s with start-up"
        + (f" and {len(cmp.attempts)} failed rung{'s' * (len(cmp.attempts) > 1)}"
           if cmp.attempts else "") + f"), {settings_line(cmp)}"
    )
    per = (f"{cmp.n_periods} period{'s' if cmp.n_periods != 1 else ''} of "
           f"{eng(cmp.period, 's')} ({cmp.period_source})"
           if cmp.n_periods else cmp.period_source)
    lines.append(f"steady state: {eng(cmp.window[0], 's')} to {eng(cmp.window[1], 's')}, "
                 f"{per}; pelcs devices: {cmp.devices}; "
                 + ("model drops the fits leave" if cmp.devices == "pwl" else
                    "non-ideal drops") + f" δ = {percent(cmp.nonideal.delta)} of "
                 f"{eng(cmp.nonideal.v_ref, 'V')}")
    head = (f"{'probe':<12} {'NRMS [tol]':>18} {'mean pelcs':>11} {'ngspice':>11} "
            f"{'diff [tol]':>19} {'ripple pelcs':>12} {'ngspice':>11} {'diff [tol]':>19}  ")
    lines.append(head)
    for p in cmp.probes:
        u = probe_unit(p.probe)
        lines.append(
            f"{p.probe:<12} {percent(p.nrms):>8} [{percent(p.nrms_tol):>7}] "
            f"{eng(p.mean_pelcs, u):>11} {eng(p.mean_ngspice, u):>11} "
            f"{percent(p.mean_error / p.scale):>8} [{percent(p.mean_tol / p.scale):>7}] "
            f"{eng(p.ripple_pelcs, u):>12} {eng(p.ripple_ngspice, u):>11} "
            f"{percent(p.ripple_error / p.scale):>8} [{percent(p.ripple_tol / p.scale):>7}]  "
            f"{_probe_verdict(cmp, p)}" + (f" ({', '.join(p.failures)})" if p.failures
                                           else "") + _transient_cell(p)
        )
    for s in cmp.switches:
        if s.method == "instants" and s.reason:  # one side only, or neither, switches
            what = (f"{s.n_pelcs}/{s.n_ngspice} switchings: {s.reason}"
                    + (f", max offset [{eng(s.tol, 's')}]" if not s.ok else ""))
        elif s.method == "instants":
            what = (f"{s.n_pelcs}/{s.n_ngspice} switchings, max offset "
                    f"{eng(s.max_offset, 's')} [{eng(s.tol, 's')}]"
                    + (f" ({s.note})" if s.note else ""))
        elif s.method == "frequency":
            what = (f"frequency {eng(s.freq_pelcs, 'Hz')} / {eng(s.freq_ngspice, 'Hz')} "
                    f"[{percent(s.tol)}] ({s.reason})")
        else:
            what = f"not compared: {s.reason}"
        verdict = ("" if s.method == "none" else
                   f"inconclusive ({s.inconclusive}: pelcs perturbed moves them by "
                   f"{eng(s.self_offset, 's')})" if s.inconclusive else _verdict(s.ok))
        if s.inconclusive == "another orbit":
            verdict = "inconclusive (another orbit)"
        lines.append(f"switch {s.switch} ({s.driven}): {what}  {verdict}")
    for n in cmp.notes:
        lines.append(f"note: {n}")
    lines.append(_summary(cmp))
    return "\n".join(line.rstrip() for line in lines)


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
            f"| time points | {cmp.pelcs_steps} steps of {eng(cmp.step, 's')}, θ = "
            f"{cmp.theta:g} | {cmp.ngspice_points} (variable step) |",
            f"| settings | {_devices_line(cmp)} | {settings_line(cmp)} |", ""]
    if cmp.device_fits:
        out += ["pelcs' devices: " + "; ".join(f.line() for f in cmp.device_fits) + ".", ""]
    if s.options or s.pulse_min_edge or s.diode_model or s.switch_model:
        parts = []
        if s.options:
            parts.append("`.options " + " ".join(
                k if v is None else f"{k}={v}" for k, v in s.options.items()) + "`")
        if s.pulse_min_edge:
            parts.append(f"PULSE edges and widths >= {eng(s.pulse_min_edge, 's')}")
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
           f"{eng(cmp.period, 's')} ({cmp.period_source})"
           if cmp.n_periods else cmp.period_source)
    out += [f"Compared from {eng(cmp.span[0], 's')} to {eng(cmp.span[1], 's')}; steady "
            f"state from {eng(cmp.window[0], 's')}: {per}.", ""]
    ni = cmp.nonideal
    drops = [f"{k} {eng(v, 'V')}" for k, v in {**ni.diode_drops, **ni.switch_drops}.items()]
    what = ("What the fits leave of ngspice's models at the currents the devices carry"
            if cmp.devices == "pwl" else
            "Non-ideal drops of ngspice's models at the currents the devices carry")
    out += [f"{what}: "
            f"{', '.join(drops) or 'none'}; δ = {percent(ni.delta)} of "
            f"{eng(ni.v_ref, 'V')} (tolerances: module docstring of "
            "`ngspice_checks/compare.py`).", ""]
    out += ["## Probes", "",
            "Differences relative to the probe's scale s = max(RMS, ½ peak-to-peak) of the "
            "pelcs waveform; tolerances in brackets.", "",
            "| probe | ngspice | NRMS | mean pelcs | mean ngspice | diff | ripple pelcs | "
            "ripple ngspice | diff | |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    for p in cmp.probes:
        u = probe_unit(p.probe)
        out.append(
            f"| `{p.probe}` | `{p.ngspice_probe}` | {percent(p.nrms)} [{percent(p.nrms_tol)}] | "
            f"{eng(p.mean_pelcs, u)} | {eng(p.mean_ngspice, u)} | "
            f"{percent(p.mean_error / p.scale)} [{percent(p.mean_tol / p.scale)}] | "
            f"{eng(p.ripple_pelcs, u)} | {eng(p.ripple_ngspice, u)} | "
            f"{percent(p.ripple_error / p.scale)} [{percent(p.ripple_tol / p.scale)}] | "
            f"{_probe_verdict(cmp, p)}" + _transient_cell(p) + " |")
    if cmp.probes:
        out += ["", f"NRMS leaves out {percent(cmp.probes[0].excluded)} of the grid points "
                "(those next to a switching instant).", ""]
    if cmp.switches:
        out += ["## Switching", "",
                "| switch | driven | compared | pelcs | ngspice | max offset | tolerance | |",
                "|---|---|---|---|---|---|---|---|"]
        for w in cmp.switches:
            if w.method == "frequency":
                vals = (f"{eng(w.freq_pelcs, 'Hz')}", f"{eng(w.freq_ngspice, 'Hz')}", "",
                        percent(w.tol))
            else:
                vals = (f"{w.n_pelcs} switchings", f"{w.n_ngspice} switchings",
                        eng(w.max_offset, "s"), eng(w.tol, "s"))
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


def write_report(cmp: Comparison, directory: str | os.PathLike, *,
                 figure: Callable[[Comparison, Path], Path] | None = None) -> list[Path]:
    """Write NAME.md, NAME.json, NAME.ngspice.cir and, with ``figure``, NAME.png into
    ``directory``.

    Parameters
    ----------
    figure : callable, optional
        ``figure(cmp, path)`` writes the comparison's figure to ``path`` and returns it (the
        application's drawing: ``pelcs.check_plots.plot_comparison``); None: no figure.

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
    if figure is not None and cmp.pelcs_result is not None and cmp.ngspice_result is not None:
        png = figure(cmp, d / f"{stem}.png")
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
    """:meth:`Comparison.to_dict` as JSON text (NaN written as null)."""
    return json.dumps(_finite(cmp.to_dict()), indent=2, default=_json_default,
                      allow_nan=False)


def _json_default(obj):
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    return str(obj)


def _finite(obj):
    """NaN and infinities as None (JSON has no NaN); containers walked recursively."""
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, (float, np.floating)) and not math.isfinite(float(obj)):
        return None
    return obj
