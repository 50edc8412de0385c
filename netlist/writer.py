"""Circuit -> netlist text that ngspice accepts and that pelcs parses back to an equal circuit.

The output is flat (no subcircuits) with every value evaluated; the global parameters are
written as ``.param`` lines so that :attr:`Circuit.params` survives the round trip. Numbers
are written with engineering suffixes only when that reads back bit for bit
(:func:`netlist.units.format_number`).

Hierarchical names
------------------
ngspice chooses an element's type from the first letter of its name, so ``X1.L1`` (inductor
``L1`` of instance ``X1``) cannot be written as it is. Like ngspice's own flattener, the
writer puts the element letter in front: ``L.X1.L1``; references to it (a K line, the
controlling source of an F/H) are spelled the same way. The parser maps a name of the form
``<letter>.<X...>`` (at least three dot-separated parts, the first one the element letter,
the second an instance name) back to ``X1.L1``. Node names such
as ``x1.n3`` need no change.

Ignored commands (``.print``, ``.control`` blocks, ...) are written back verbatim at the end,
since they are what the user asked ngspice to do.

Built groups
------------
Where pelcs simulates a netlist line as a group of elements it built (a clamping B source's
limiter, a resistor stepped in time: :class:`netlist.circuit.BuiltGroup`), ngspice is given
that line instead: the group's line is written where its first element stands, and none of
its elements. A sigmoid B source read as a comparator (:mod:`netlist.sigmoid`) is such a
line, written with the lines of the switches it drives as the netlist had them (pelcs
rewired them onto its comparison): ngspice runs the sigmoid itself.
"""

from __future__ import annotations

from lcs.signals import Am, Exp, Pulse, Pwl, Sffm, Signal, Sin

from .circuit import (
    Circuit,
    Coupling,
    CurrentSource,
    Diode,
    Element,
    Switch,
    VoltageSource,
    unique_name,
)
from .units import format_number

__all__ = ["element_line", "spice_name", "write_circuit"]


def spice_name(name: str, kind: str | None = None) -> str:
    """The name to write for an element: ``X1.L1`` -> ``L.X1.L1``, others unchanged.

    Parameters
    ----------
    name : str
        Element name, hierarchical for elements of subcircuit instances.
    kind : str, optional
        The element letter; by default the first letter of the name's last part.
    """
    if "." in name and name[0] in "xX":
        letter = kind or name.rsplit(".", 1)[1][:1]
        if letter:
            return f"{letter}.{name}"
    if kind and name[:1].upper() != kind.upper():
        # an element pelcs made of another (the E and H sources of a B source): ngspice takes
        # its type from the first letter
        return f"{kind}.{name}"
    return name


def _num(v: float) -> str:
    return format_number(float(v))


# field order of each waveform, and the fields whose missing value ngspice also takes for 0
_ZERO_DEFAULTS = frozenset({"td", "theta", "phase", "mdi", "phasec", "phases"})
_WAVE_FIELDS = {
    Pulse: ("PULSE", ("v1", "v2", "td", "tr", "tf", "pw", "per", "np_")),
    Sin: ("SIN", ("vo", "va", "freq", "td", "theta", "phase")),
    Exp: ("EXP", ("v1", "v2", "td1", "tau1", "td2", "tau2")),
    Sffm: ("SFFM", ("vo", "va", "fc", "mdi", "fs", "phasec", "phases")),
    Am: ("AM", ("va", "vo", "mf", "fc", "td", "phasec", "phases")),
}


def _waveform(sig: Signal, circuit: Circuit) -> str:
    if isinstance(sig, Pwl):
        pairs = " ".join(f"{_num(t)} {_num(v)}" for t, v in zip(sig.times, sig.values,
                                                                strict=True))
        extra = ("" if sig.repeat is None else f" r={_num(sig.repeat)}") + (
            f" td={_num(sig.delay)}" if sig.delay else "")
        return f"PWL({pairs}){extra}"
    keyword, names = _WAVE_FIELDS[type(sig)]
    vals = [getattr(sig, n) for n in names]
    # Trailing defaults are left out: a None, or a 0 that only stands for SIN's default
    # delay, damping or phase (writing them would turn an omitted FREQ into FREQ = 0).
    while vals and (vals[-1] is None
                    or (vals[-1] == 0 and names[len(vals) - 1] in _ZERO_DEFAULTS)):
        vals.pop()
    out = []
    for n, v in zip(names, vals, strict=False):
        if v is None:
            # A default in the middle cannot be left out in SPICE syntax. For TR, TF, PER,
            # FREQ and the time constants, 0 means "the default" in ngspice too; PW defaults
            # to TSTOP.
            if n == "pw" and circuit.tran is not None:
                v = circuit.tran.tstop
            else:
                v = 0.0
        out.append(_num(v))
    return f"{keyword}({' '.join(out)})"


def model_names(circuit: Circuit) -> dict[str, str]:
    """The name each model of ``circuit`` (by its key) is written under. A model of a
    subcircuit is keyed ``subckt:name``, and elements inside the subcircuit name it by that
    key: it is written under its own name where that name means it at the top level too
    (the only model of the name), else under the key with ``_`` for ``:``, so that two
    subcircuits' models of one name (Littelfuse's SCR library: a ``Pfor`` of BF 6.1 and one
    of 2.2) stay two models in the flattened deck."""
    out: dict[str, str] = {}
    used = {k for k in circuit.models if ":" not in k}
    for key, model in circuit.models.items():
        if ":" not in key:
            out[key] = model.name
        elif circuit.models.get(model.name.lower()) is model:
            out[key] = model.name
        else:
            out[key] = unique_name(key.replace(":", "_"), used)
    return out


def model_name(circuit: Circuit, ref: str) -> str:
    """The name a model that an element refers to by ``ref`` (its key, or its name) is
    written under (:func:`model_names`)."""
    model = circuit.models.get(ref.lower())
    if model is None:
        return ref
    if ":" not in ref:
        return model.name
    return model_names(circuit)[ref.lower()]


def element_line(el: Element, circuit: Circuit) -> str:
    """The netlist line of one element of ``circuit`` (the names it refers to, such as a K
    line's inductors, spelled as ``circuit`` has them)."""
    return _element(el, circuit, {e.key: e.kind for e in circuit.elements})


def _element(el: Element, circuit: Circuit, kinds: dict[str, str]) -> str:
    name = spice_name(el.name, el.kind)
    nodes = " ".join(el.nodes)
    kind = el.kind
    if kind in ("R", "L", "C"):
        line = f"{name} {nodes} {_num(el.value)}"
        ic = getattr(el, "ic", None)
        if ic is not None:
            line += f" IC={_num(ic)}"
        return line
    if isinstance(el, (VoltageSource, CurrentSource)) and hasattr(el.waveform, "spice"):
        # a B source of time alone (netlist.time_expression), written back as one
        out = "V" if isinstance(el, VoltageSource) else "I"
        return f"{spice_name(el.name, 'B')} {nodes} {out}={el.waveform.spice()}"
    if isinstance(el, (VoltageSource, CurrentSource)):
        line = f"{name} {nodes} DC {_num(el.dc)}"
        if el.waveform is not None:
            line += " " + _waveform(el.waveform, circuit)
        return line
    if isinstance(el, Diode) and el.device is not None:
        _, all_nodes, sub = el.device[:3]
        return f"{spice_name(el.name, 'X')} {' '.join(all_nodes)} {sub}"
    if isinstance(el, Diode):
        return f"{name} {nodes} {model_name(circuit, el.model)}"
    if isinstance(el, Switch) and el.device is not None:
        # an idealised transistor: ngspice simulates the device itself, with its model
        letter, all_nodes, model = el.device[:3]
        return f"{spice_name(el.name, letter)} {' '.join(all_nodes)} " \
            f"{model_name(circuit, model)}"

    if isinstance(el, Switch):
        state = {True: " ON", False: " OFF", None: ""}[el.initial]
        return f"{name} {nodes} {' '.join(el.control)} {el.model}{state}"
    if kind in ("E", "G"):
        return f"{name} {nodes} {' '.join(el.control)} {_num(el.gain)}"
    if kind in ("F", "H"):
        return f"{name} {nodes} {spice_name(el.source, kinds.get(el.source.lower()))} " \
            f"{_num(el.gain)}"
    if isinstance(el, Coupling):
        a, b = (spice_name(n, kinds.get(n.lower())) for n in el.inductors)
        return f"{name} {a} {b} {_num(el.k)}"
    raise ValueError(f"cannot write element {el.name} of kind {kind}")


def write_circuit(circuit: Circuit) -> str:
    """Netlist text for a (flattened) circuit.

    Parameters
    ----------
    circuit : Circuit
        E.g. from :func:`netlist.parser.parse_file`.

    Returns
    -------
    str
        A complete netlist: title line, ``.param``, elements, ``.model``, ``.ic``, ``.tran``,
        ``.options``, ignored commands, ``.end``.
    """
    # the title is the first line whatever it says; an empty one stays empty
    lines = [circuit.title.replace("\n", " ").strip(),
             "* written by pelcs: flattened, parameters evaluated"]
    for name, value in circuit.params.items():
        lines.append(f".param {name}={_num(value)}")
    kinds = {el.key: el.kind for el in circuit.elements}
    written_groups: set[str] = set()
    # (netlist elements a group's line writes as the netlist had them: BuiltGroup.replaces)
    replaced = {n.lower(): g for g in circuit.built_groups.values() for n in g.replaces}
    for el in circuit.elements:
        group = circuit.built_group(el) or replaced.get(el.key)
        if group is not None:
            if group.name not in written_groups:
                written_groups.add(group.name)
                lines.append(group.line)
            continue
        if isinstance(el, Diode) and el.body_of:
            continue  # a transistor's body diode, part of its model in ngspice
        lines.append(_element(el, circuit, kinds))
    devices = {el.model.lower() for el in circuit.elements
               if isinstance(el, Switch) and (el.device is not None or el.built_for
                                              or el.key in replaced)}
    written, written_models = model_names(circuit), set()
    for key, model in circuit.models.items():
        if key in devices:
            # the switch stand-in of a transistor's threshold, a built group's switch (the
            # bypasses of a resistor stepped in time), a switch rewired onto a sigmoid's
            # comparison: pelcs-only
            continue

        name = written.get(key, model.name)
        if name.lower() in written_models:
            continue  # (a subcircuit's model under its own name, also keyed by it)
        written_models.add(name.lower())
        params = " ".join(f"{k}={_num(v)}" for k, v in model.params.items())
        lines.append(f".model {name} {model.type}({params})")
    for text in circuit.subckt_texts.values():
        lines.extend(text.split("\n"))
    if circuit.initial_conditions:
        ics = " ".join(f"v({n})={_num(v)}" for n, v in circuit.initial_conditions.items())
        lines.append(f".ic {ics}")
    tran = circuit.tran
    if tran is not None:
        fields = [tran.tstep, tran.tstop]
        if tran.tstart or tran.tmax is not None:
            fields.append(tran.tstart)
        if tran.tmax is not None:
            fields.append(tran.tmax)
        line = ".tran " + " ".join(_num(f) for f in fields)
        lines.append(line + (" UIC" if tran.uic else ""))
    if circuit.options:
        opts = " ".join(f"{k}={v}" if v != "" else k for k, v in circuit.options.items())
        lines.append(f".options {opts}")
    for cmd in circuit.ignored:
        lines.append(cmd.text)
    lines.append(".end")
    return "\n".join(lines) + "\n"
