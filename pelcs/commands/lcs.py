"""``pelcs lcs FILE``: the LCS matrices of a netlist, per switch configuration.

Prints, for every requested switch mode, ``A B E`` (rows: state derivatives) and ``C D F``
(rows: the complementarity variables w) with named rows and columns, what λ stands for per
diode, and whether the mode is passive. ``--json`` prints one JSON object instead (strict
JSON: NaN and infinities, should any arise, are null)::

    {"file", "title", "states", "lambdas" (diode names), "inputs", "switches",
     "passive" (every listed mode passive), "gdcm_skipped" (null, or why the modes'
     "gdcm" are null: more than GDCM_MAX_PAIRS diodes without --gdcm), "modes": [
        {"switches": {"S1": "on"}, "A", "B", "C", "D", "E", "F" (lists of rows),
         "lambda_kinds": {"D1": "current" | "voltage"}, "lambda_labels", "w_labels",
         "passive", "passivity": {...}, "wellposedness": {...},
         "gdcm": [{"pairs", "relative_degree", "unique", "region", "gamma", ...}]}, ...]}

Input errors (bad netlist, unknown switch in ``--mode``, degenerate topology in a requested
mode) raise :class:`~netlist.errors.NetlistError`, which the CLI prints and exits 2 on.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from lcs.model import LCS, SwitchedLCS
from netlist.errors import Diagnostic, NetlistError
from pelcs.jsonout import dumps

from . import options

#: Above this many diodes a mode's GDCM conditions are left out unless ``--gdcm`` asks for
#: them: one condition per diode, each listing the sign conditions of every other diode (a
#: 200-stage multiplier's 400 diodes took minutes and gave hundreds of MB of text).
GDCM_MAX_PAIRS = 100

_ON = {"on": True, "1": True, "true": True, "closed": True,
       "off": False, "0": False, "false": False, "open": False}


def register(subparsers) -> None:
    """Add the ``lcs`` subcommand to the CLI's subparsers."""
    p = subparsers.add_parser(
        "lcs",
        help="print the linear complementarity system of a netlist, per switch mode",
        description="Formulate a netlist with ideal diodes and switches as a linear "
        "complementarity system x' = A x + B λ + E u, w = C x + D λ + F u, 0 <= w ⊥ λ >= 0, "
        "one per configuration of the switches, and print its matrices.",
    )
    p.add_argument("file", help="netlist file")
    options.add_param(p)
    p.add_argument("--mode", metavar="S1=on,S2=off",
                   help="only these switch states (switches not named: every state); "
                   "default: all modes")
    options.add_json(p)
    p.add_argument("--gdcm", action="store_true",
                   help=f"list the GDCM conditions of every diode even above {GDCM_MAX_PAIRS} "
                   "diodes (their text grows as diodes² x states: hundreds of MB for a "
                   "200-stage multiplier)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from netlist.formulation import formulate
    from netlist.parser import parse_file, parse_overrides

    params = parse_overrides(args.param)
    circuit = parse_file(args.file, params=params or None)
    system = formulate(circuit)
    keys = select_modes(system, args.mode)
    report = build_report(system, keys, system.storage, gdcm=args.gdcm,
                          progress=not args.no_progress)
    report["file"] = args.file
    report["title"] = circuit.title
    report["notes"] = reduction_notes(circuit)
    if args.json:
        print(dumps(report, indent=1))
    else:
        print(format_report(report))
    return 0


def reduction_notes(circuit) -> list[str]:
    """What the matrices leave out of the circuit: capacitors that hold no state (across
    voltage sources, or closing a loop of capacitors and DC sources), whose currents the
    printed ``E`` columns of those sources do not carry (they hold while the sources stay
    as the netlist gives them)."""
    from netlist.capacitor_links import capacitor_links, link_note
    from netlist.reductions import held_capacitors, held_note

    held = held_capacitors(circuit)
    notes = held_note(held)
    links = capacitor_links(circuit, held)
    notes.extend(link_note(links))
    sources = sorted({v for link in links.values() for v in link.sources})
    if sources:
        notes.append(f"the rows of x' of the loops' capacitors hold while {', '.join(sources)} "
                     "stay constant, as the netlist gives them (a varying source would drive "
                     "the links' currents through the loop, which the E columns leave out)")
    return notes


# -- arguments -----------------------------------------------------------------------------


def _usage_error(message: str, hint: str = "") -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file="pelcs lcs")




def select_modes(system: SwitchedLCS, spec: str | None) -> list[tuple[bool, ...]]:
    """Mode keys matching ``--mode`` (``"S1=on,S2=off"``); every mode when ``spec`` is None.

    Switches the spec does not name take both states.
    """
    if not spec:
        return system.all_keys()
    names = {s.name.lower(): i for i, s in enumerate(system.switches)}
    fixed: dict[int, bool] = {}
    valid = ", ".join(s.name for s in system.switches) or "none"
    for part in filter(None, (p.strip() for p in spec.split(","))):
        name, sep, state = part.partition("=")
        index = names.get(name.strip().lower())
        if index is None:
            raise _usage_error(f"--mode: no switch named {name.strip()!r}",
                               f"switches of this circuit: {valid}")
        if not sep or state.strip().lower() not in _ON:
            raise _usage_error(f"--mode: {part!r} is not SWITCH=on or SWITCH=off",
                               "e.g. --mode S1=on,S2=off")
        fixed[index] = _ON[state.strip().lower()]
    return [key for key in system.all_keys()
            if all(key[i] == on for i, on in fixed.items())]


# -- report --------------------------------------------------------------------------------


def _rows(matrix: np.ndarray) -> list[list[float]]:
    return [[float(v) for v in row] for row in np.asarray(matrix)]


def _passivity(lcs: LCS, energy: np.ndarray):
    """Passivity of one mode: (JSON summary, report or None).

    :func:`lcs.theory.passivity.check_passivity` with the circuit's stored energy as the first
    candidate certificate (exact for circuits of non-negative resistors and no active
    elements), then its general search.
    """
    from lcs.theory.passivity import check_passivity

    try:
        rep = check_passivity(lcs, energy=energy)
    except (np.linalg.LinAlgError, FloatingPointError, ValueError) as exc:
        return {"passive": None, "method": "failed", "margin": None,
                "reason": f"the check failed numerically ({exc}; matrix entries up to "
                          f"{_largest(lcs):.3g}: extreme element values?)"}, None
    margin = float(rep.margin)
    summary = {"passive": bool(rep.passive), "method": rep.method, "reason": rep.reason,
               "margin": margin if math.isfinite(margin) else None}
    return summary, rep


def _wellposedness(lcs: LCS, passivity_report) -> dict | None:
    """Sufficient well-posedness conditions (:mod:`lcs.theory.wellposed`) of one mode."""
    from lcs.theory.wellposed import check_wellposedness

    try:
        rep = check_wellposedness(lcs, passivity_report)
    except (np.linalg.LinAlgError, FloatingPointError, ValueError) as exc:
        return {"wellposed": False, "lambda_unique": False, "deficient_pairs": [],
                "reason": f"the check failed numerically ({exc}; matrix entries "
                          f"up to {_largest(lcs):.3g})"}
    return {"wellposed": bool(rep.wellposed), "lambda_unique": bool(rep.lambda_unique),
            "reason": rep.reason, "deficient_pairs": list(rep.deficient_pairs)}


def _gdcm(lcs: LCS) -> list[dict] | None:
    """Single-pair GDCM conditions of one mode (:func:`lcs.theory.gdcm.gdcm_conditions`).

    One entry per diode that can be held at w = 0 with λ > 0: the region (forms that vanish
    on it), Γ (the λ that holds it, > 0 inside), the relative degree and whether the
    continuation is unique. ``y`` and ``gamma`` are the linear functionals (coefficients by
    state and input name) of the region ``y = 0, gamma > 0``; for relative degree r > 1 the
    derivatives that must vanish too are in ``y_derivatives``.
    """
    from lcs.theory.gdcm import gdcm_conditions

    try:
        conditions = gdcm_conditions(lcs)
    except (np.linalg.LinAlgError, FloatingPointError, ValueError):
        return None  # (numerically out of reach: the passivity line says why)
    return [{
        "diode": cond.pairs[0],
        "y": cond.y[0].as_dict(),
        "gamma": cond.gamma[0].as_dict(),
        "y_derivatives": [f.as_dict() for f in cond.y[1:]],
        "pairs": list(cond.pairs),
        "relative_degree": int(cond.relative_degree),
        "dimension_loss": int(cond.dimension_loss),
        "unique": bool(cond.unique),
        "region": [f"{f.label} = {f} = 0" for f in cond.y],
        "gamma_text": [f"{f.label} = {f} > 0" for f in cond.gamma],
        "others": [f"{f.label} = {f} >= 0" for f in cond.others],
    } for cond in conditions]


def _largest(lcs: LCS) -> float:
    return max((float(np.max(np.abs(M))) for M in (lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, lcs.F)
                if M.size), default=0.0)


def build_report(system: SwitchedLCS, keys: list[tuple[bool, ...]],
                 energy: np.ndarray, gdcm: bool = False, progress: bool = False) -> dict:
    """The JSON-ready description of the requested modes of a switched LCS.

    Parameters
    ----------
    system : SwitchedLCS
    keys : list of tuple of bool
        The modes to describe.
    energy : ndarray (n, n)
        The circuit's storage matrix (first passivity certificate tried).
    gdcm : bool
        List the GDCM conditions even above :data:`GDCM_MAX_PAIRS` diodes (else ``"gdcm"``
        is None there and ``"gdcm_skipped"`` says why).
    progress : bool
        A progress bar on a terminal (stderr) when the report takes more than a second.
    """
    modes = []
    skip_gdcm = not gdcm and len(system.diodes) > GDCM_MAX_PAIRS
    bar = _progress_bar(progress, 3 * len(keys))
    for key in keys:
        lcs = system.mode(key)
        passivity, passivity_report = _passivity(lcs, energy)
        _tick(bar)
        wellposedness = _wellposedness(lcs, passivity_report)
        _tick(bar)
        conditions = None if skip_gdcm else _gdcm(lcs)
        _tick(bar)
        modes.append({
            "switches": system.describe_mode(key),
            "A": _rows(lcs.A), "B": _rows(lcs.B), "C": _rows(lcs.C),
            "D": _rows(lcs.D), "E": _rows(lcs.E), "F": _rows(lcs.F),
            "lambda_kinds": {p.name: p.lam for p in lcs.pairs},
            "lambda_labels": [p.lambda_label for p in lcs.pairs],
            "w_labels": [p.w_label for p in lcs.pairs],
            "passive": passivity["passive"],
            "passivity": passivity,
            "wellposedness": wellposedness,
            "gdcm": conditions,
        })
    if bar is not None:
        bar.close()
    flags = [m["passive"] for m in modes]
    skipped = (f"GDCM conditions not listed: {len(system.diodes)} diodes (above "
               f"{GDCM_MAX_PAIRS}; --gdcm lists them)") if skip_gdcm else None
    return {
        "gdcm_skipped": skipped,
        "states": list(system.states),
        "lambdas": list(system.diodes),
        "inputs": list(system.inputs),
        "switches": [{"name": s.name, "control": s.control, "vt": s.vt, "vh": s.vh}
                     for s in system.switches],
        "passive": None if any(f is None for f in flags) else all(flags),
        "modes": modes,
    }


def _progress_bar(show: bool, total: int):
    """A tqdm bar on stderr, shown after a second, on a terminal; else None."""
    import sys

    if not show or not sys.stderr.isatty():
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc="pelcs lcs", unit="check", delay=1.0, leave=False)


def _tick(bar) -> None:
    if bar is not None:
        bar.update(1)


def _fmt(value: float) -> str:
    return "0" if value == 0 else f"{value:.6g}"


def format_matrix(name: str, matrix: list[list[float]], rows: list[str],
                  cols: list[str]) -> str:
    """A matrix as text with row and column names; empty matrices say so."""
    if not rows or not cols:
        return f"{name}: empty ({len(rows)}x{len(cols)})"
    cells = [[_fmt(v) for v in row] for row in matrix]
    width0 = max(len(r) for r in rows)
    widths = [max(len(c), *(len(cells[i][j]) for i in range(len(rows))))
              for j, c in enumerate(cols)]
    lines = [f"{name}:", "  " + " " * width0 + "  "
             + "  ".join(c.rjust(w) for c, w in zip(cols, widths, strict=True))]
    for r, row in zip(rows, cells, strict=True):
        lines.append("  " + r.ljust(width0) + "  "
                     + "  ".join(v.rjust(w) for v, w in zip(row, widths, strict=True)))
    return "\n".join(lines)


def format_report(report: dict) -> str:
    """Human-readable text of :func:`build_report`'s result."""
    states, inputs = report["states"], report["inputs"]
    out = [f"{report.get('file', '')}: {report.get('title', '')}".strip(": "),
           f"states ({len(states)}): {', '.join(states) or '-'}",
           f"diodes ({len(report['lambdas'])}): {', '.join(report['lambdas']) or '-'}",
           f"inputs ({len(inputs)}): {', '.join(inputs) or '-'}"]
    for s in report["switches"]:
        out.append(f"switch {s['name']}: on when {s['control']} > {s['vt']:g} "
                   f"(hysteresis {s['vh']:g})")
    out.append("x' = A x + B λ + E u,  w = C x + D λ + F u,  0 <= w ⊥ λ >= 0")
    dx = [f"d{s}/dt" for s in states]
    for mode in report["modes"]:
        title = ", ".join(f"{k}={v}" for k, v in mode["switches"].items()) or "single mode"
        out.append("")
        out.append(f"== {title} ==")
        lam, w = mode["lambda_labels"], mode["w_labels"]
        for (diode, kind), lam_label, w_label in zip(mode["lambda_kinds"].items(), lam, w,
                                                      strict=True):
            what = "current" if kind == "current" else "reverse voltage"
            out.append(f"{diode}: λ = {lam_label} ({what}), w = {w_label}")
        out.append(format_matrix("A", mode["A"], dx, states))
        if lam:
            out.append(format_matrix("B", mode["B"], dx, lam))
        out.append(format_matrix("E", mode["E"], dx, inputs))
        if lam:
            out.append(format_matrix("C", mode["C"], w, states))
            out.append(format_matrix("D", mode["D"], w, lam))
            out.append(format_matrix("F", mode["F"], w, inputs))
        p = mode["passivity"]
        verdict = {True: "passive", False: "not passive", None: "passivity unknown"}
        out.append(f"{verdict[p['passive']]}: {p.get('reason', '')}")
        wp = mode["wellposedness"]
        if wp is not None:
            out.append(f"{'well-posed' if wp['wellposed'] else 'well-posedness not shown'}: "
                       f"{wp['reason']}")
        for cond in mode["gdcm"] or ():
            out.append(f"GDCM of {', '.join(cond['pairs'])} (relative degree "
                       f"{cond['relative_degree']}, "
                       f"{'unique' if cond['unique'] else 'non-unique'} continuation): "
                       + "; ".join(cond["region"] + cond["gamma_text"] + cond["others"]))
    if report.get("gdcm_skipped"):
        out.append("")
        out.append(f"note: {report['gdcm_skipped']}")
    if report.get("notes"):
        out.append("")
        out.extend(f"note: {n}" for n in report["notes"])
    if report["modes"]:
        verdict = {True: "every mode passive", False: "not every mode passive",
                   None: "passivity unknown"}[report["passive"]]
        out.append("")
        out.append(verdict)
    return "\n".join(out)
