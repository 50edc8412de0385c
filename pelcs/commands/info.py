"""``pelcs info FILE [--param NAME=VALUE]...``: the flattened circuit, readably.

Prints the title, the nodes, the elements grouped by kind with their values in engineering
notation, the sources with their waveforms, the switches with their control nodes and model
thresholds, the diodes, the initial conditions (``.ic`` and element ``IC=``), the analysis,
the options and the commands pelcs ignored. Input errors raise
:class:`~netlist.errors.NetlistError` (the CLI prints them and exits 2).
"""

from __future__ import annotations

import argparse

from lcs.signals import Am, Dc, Exp, Pulse, Pwl, Sffm, Signal, Sin
from netlist.circuit import GROUND, Circuit, Element
from netlist.units import format_eng, format_number

from . import options

# kind -> (heading, unit of the value)
_GROUPS = [
    ("R", "resistors", "Ω"),
    ("L", "inductors", "H"),
    ("C", "capacitors", "F"),
    ("K", "couplings", ""),
    ("V", "voltage sources", "V"),
    ("I", "current sources", "A"),
    ("E", "voltage-controlled voltage sources (E)", "V/V"),
    ("G", "voltage-controlled current sources (G)", "S"),
    ("F", "current-controlled current sources (F)", "A/A"),
    ("H", "current-controlled voltage sources (H)", "Ω"),
    ("S", "switches (ideal)", ""),
    ("D", "diodes (ideal)", ""),
]

_WAVE_UNITS = {
    Pulse: [("v1", "*"), ("v2", "*"), ("td", "s"), ("tr", "s"), ("tf", "s"), ("pw", "s"),
            ("per", "s"), ("np_", "")],
    Sin: [("vo", "*"), ("va", "*"), ("freq", "Hz"), ("td", "s"), ("theta", "1/s"),
          ("phase", "°")],
    Exp: [("v1", "*"), ("v2", "*"), ("td1", "s"), ("tau1", "s"), ("td2", "s"), ("tau2", "s")],
    Sffm: [("vo", "*"), ("va", "*"), ("fc", "Hz"), ("mdi", ""), ("fs", "Hz"), ("phasec", "°"),
           ("phases", "°")],
    Am: [("va", "*"), ("vo", "*"), ("mf", "Hz"), ("fc", "Hz"), ("td", "s"), ("phasec", "°"),
         ("phases", "°")],
}


def register(subparsers) -> None:
    """Add the ``info`` subcommand to the CLI's subparsers."""
    p = subparsers.add_parser(
        "info",
        help="print the flattened circuit of a netlist",
        description="Parse a netlist (with its includes and subcircuits) and print the "
        "flattened circuit: nodes, elements and values, sources and waveforms, switches, "
        "diodes, initial conditions, analysis, options and ignored commands.",
    )
    p.add_argument("file", help="netlist file")
    options.add_param(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from netlist.parser import parse_file, parse_overrides

    params = parse_overrides(args.param)
    circuit = parse_file(args.file, params=params or None)
    print(describe(circuit))
    return 0


def _short(value: float) -> str:
    """SPICE notation (``50k``) unless that needs many digits, then 6 significant digits."""
    text = format_number(value)
    return text if len(text) <= 10 else f"{value:.6g}"


def _eng(value: float | None, unit: str) -> str:
    return format_eng(value, unit)


def _waveform(sig: Signal | None, unit: str) -> str:
    if sig is None:
        return ""
    if isinstance(sig, Dc):
        return f"DC {_eng(sig.value, unit)}"
    if hasattr(sig, "describe"):  # a B source of time alone (netlist.time_expression)
        return sig.describe()
    if isinstance(sig, Pwl):
        pts = ", ".join(f"({_eng(t, 's')}, {_eng(v, unit)})"
                        for t, v in zip(sig.times, sig.values, strict=True))
        extra = ("" if sig.repeat is None else f", repeated from {_eng(sig.repeat, 's')}") + (
            f", delayed {_eng(sig.delay, 's')}" if sig.delay else "")
        return f"PWL {pts}{extra}"
    fields = []
    for name, u in _WAVE_UNITS[type(sig)]:
        v = getattr(sig, name)
        if name == "np_":
            if v is not None:
                fields.append(f"np={v:g}")
            continue
        shown = "default" if v is None else _eng(v, unit if u == "*" else u)
        fields.append(f"{name}={shown}")
    return f"{type(sig).__name__.upper()}({', '.join(fields)})"


def _row(el: Element, circuit: Circuit, unit: str) -> list[str]:
    kind = el.kind
    nodes = " ".join(el.nodes)
    if kind in ("R", "L", "C"):
        ic = getattr(el, "ic", None)
        extra = f"IC={_eng(ic, 'A' if kind == 'L' else 'V')}" if ic is not None else ""
        return [el.name, nodes, _eng(el.value, unit), extra]
    if kind in ("V", "I"):
        wave = _waveform(el.waveform, unit)
        return [el.name, nodes, f"DC {_eng(el.dc, unit)}", wave]
    if kind in ("E", "G"):
        return [el.name, nodes, f"{el.gain:g} {unit}", f"× v({','.join(el.control)})"]
    if kind in ("F", "H"):
        return [el.name, nodes, f"{el.gain:g} {unit}", f"× i({el.source})"]
    if kind == "K":
        return [el.name, " ".join(el.inductors), f"k={el.k:g}", ""]
    if kind == "S":
        model = circuit.models.get(el.model.lower())
        thr = ""
        if model is not None:
            vt = model.params.get("vt", 0.0)
            vh = model.params.get("vh", 0.0)
            thr = f"on when v > VT={_eng(vt, 'V')}" + (f" ± VH={_eng(vh, 'V')}" if vh else "")
        state = {True: ", initially ON", False: ", initially OFF", None: ""}[el.initial]
        return [el.name, nodes, f"control v({','.join(el.control)})",
                f"model {el.model}: {thr}{state}"]
    if kind == "D":
        if getattr(el, "ideal", False):
            what = "ideal (a clamp's limiter)"
        elif getattr(el, "body_of", ""):
            what = f"body diode of {el.body_of}"
        else:
            what = f"model {el.model}"
        return [el.name, f"{el.nodes[0]} -> {el.nodes[1]}", what, "(anode -> cathode)"]
    return [el.name, nodes, "", ""]


def _table(rows: list[list[str]], indent: str = "    ") -> list[str]:
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    out = []
    for r in rows:
        cells = [c.ljust(w) for c, w in zip(r, widths, strict=True)]
        out.append((indent + "  ".join(cells)).rstrip())
    return out


def describe(circuit: Circuit) -> str:
    """The text printed by ``pelcs info`` for a circuit.

    Parameters
    ----------
    circuit : Circuit
        A parsed (flattened) circuit.
    """
    lines = [f"file:  {circuit.file}", f"title: {circuit.title}"]
    nodes = circuit.nodes
    shown = [f"{n} (ground)" if n == GROUND else n for n in nodes]
    lines.append(f"nodes ({len(nodes)}): {', '.join(shown)}")
    if circuit.params:
        lines.append("parameters: " + ", ".join(f"{k}={_short(v)}"
                                                for k, v in circuit.params.items()))
    lines.append(f"elements ({len(circuit.elements)}):")
    for kind, heading, unit in _GROUPS:
        els = circuit.of_kind(kind)
        if not els:
            continue
        lines.append(f"  {heading} ({len(els)}):")
        lines.extend(_table([_row(el, circuit, unit) for el in els]))
    if circuit.models:
        lines.append("models:")
        for m in circuit.models.values():
            params = " ".join(f"{k.upper()}={v:g}" for k, v in m.params.items())
            note = " (pelcs uses VT, VH)" if m.type == "SW" else " (ideal in pelcs)"
            lines.append(f"    {m.name} {m.type}({params}){note}")
    ics = [f"v({n}) = {_eng(v, 'V')}" for n, v in circuit.initial_conditions.items()]
    for el in circuit.elements:
        ic = getattr(el, "ic", None)
        if ic is not None:
            what = f"i({el.name})" if el.kind == "L" else f"v({el.name})"
            ics.append(f"{what} = {_eng(ic, 'A' if el.kind == 'L' else 'V')}")
    lines.append("initial conditions:" + ("" if ics else " none"))
    lines.extend(f"    {s}" for s in ics)
    tran = circuit.tran
    if tran is None:
        lines.append("analysis: none (.tran missing)")
    else:
        tmax = f", max step {_eng(tran.tmax, 's')}" if tran.tmax is not None else ""
        lines.append(f"analysis: .tran step {_eng(tran.tstep, 's')}, stop "
                     f"{_eng(tran.tstop, 's')}, start {_eng(tran.tstart, 's')}{tmax}"
                     + (", UIC" if tran.uic else ""))
    if circuit.options:
        lines.append("options: " + " ".join(f"{k}={v}" if v else k
                                             for k, v in circuit.options.items()))
    for note in circuit.notes:
        lines.append(f"note: {note}")
    if circuit.replacements:
        lines.append(f"idealised ({len(circuit.replacements)}; --strict refuses them):")
        for r in circuit.replacements:
            lines.append(f"    {r.line()}")
    if circuit.steps:
        lines.append("steps (.step, run by pelcs sweep): " + "; ".join(
            f"{name} = {', '.join(f'{v:g}' for v in vals)}" for name, vals in circuit.steps))
    if circuit.ignored:
        lines.append(f"ignored ({len(circuit.ignored)}):")
        for cmd in circuit.ignored:
            text = cmd.text.split("\n")
            where = f"line {cmd.location.line}: " if cmd.location else ""
            more = f"  ... ({len(text)} lines)" if len(text) > 1 else ""
            lines.append(f"    {where}{text[0]}{more}")
    return "\n".join(lines)
