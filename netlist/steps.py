"""``.step param`` lines: the reader's part; :mod:`netlist.flatten` evaluates
them into ``circuit.steps`` and ``pelcs sweep`` runs them."""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

from .rawdeck import RawStep, Statement

if TYPE_CHECKING:
    from .circuit import Circuit

__all__ = ["evaluate_steps", "read_step", "step_note"]


def read_step(reader, st: Statement) -> None:
    """Parse a ``.step`` line into ``reader.deck.steps`` (errors through ``reader``)."""
    usage = ".step param NAME START STOP INCR  or  .step param NAME list V1 V2 ..."
    tree = reader.parse(st, "step_cmd", ".step", usage)
    if reader.sub is not None:
        reader.error(".step inside a subcircuit", st, 0, "move it to the top level")
        return
    toks = list(tree.children[1:])
    words = [str(t).lower() for t in toks]
    if words and words[0] in ("oct", "dec", "lin"):
        if words[0] != "lin":
            reader.error(f".step {words[0]} is not supported", st, toks[0].start_pos,
                       "give the values with .step param NAME list V1 V2 ...")
            return
        toks, words = toks[1:], words[1:]
    if words and words[0] == "param":
        toks, words = toks[1:], words[1:]
    if not toks or toks[0].type != "WORD" or not re.fullmatch(r"[A-Za-z_][\w.]*",
                                                              str(toks[0])):
        reader.error(".step needs a parameter name", st, toks[0].start_pos if toks else 0,
                   f"syntax: {usage} (a .param of the netlist)")
        return
    name, name_pos = str(toks[0]), toks[0].start_pos
    rest, linear = toks[1:], True
    if rest and str(rest[0]).lower() == "list":
        rest, linear = rest[1:], False
        if not rest:
            reader.error(".step ... list needs values", st, len(st.text), f"syntax: {usage}")
            return
    elif len(rest) != 3:
        reader.error(f".step param {name}: expected START STOP INCR or list V1 V2 ...",
                   st, rest[0].start_pos if rest else len(st.text), f"syntax: {usage}")
        return
    values = [reader.value(t, st) for t in rest]
    if any(v is None for v in values):
        return
    reader.deck.steps.append(RawStep(name, values, linear, st, name_pos))


def evaluate_steps(builder) -> None:
    """``.step param`` lines -> ``builder.circuit.steps`` (name, values), one sweep axis each
    (``builder``: netlist.flatten's, for its parameters, evaluation and errors)."""
    seen: dict[str, int] = {}
    known = {k.lower(): k for k in builder.circuit.params}
    for st in builder.deck.steps:
        loc = st.st.loc(st.name_pos)
        key = st.name.lower()
        if key not in known:
            builder.error(f".step: '{st.name}' is not a .param of the netlist", loc,
                          "define it with .param (its value is the nominal one) or step one of "
                          f"{', '.join(sorted(known.values())) or 'the parameters'}",
                          dependent=True)
            continue
        if key in seen:
            builder.error(f".step: '{st.name}' is stepped twice (first at line {seen[key]})",
                          loc, "give all its values on one .step line")
            continue
        seen[key] = loc.line
        vals = [builder.evaluate(v, builder.global_env, builder.global_failed) for v in st.values]
        if any(v is None for v in vals):
            continue
        if st.linear:
            start, stop, incr = vals
            n = (stop - start) / incr if incr else -1.0
            if not incr or n < -1e-9:
                builder.error(f".step param {st.name}: INCR {incr:g} does not lead from "
                              f"{start:g} to {stop:g}", st.values[2].loc,
                              "give INCR with the sign of STOP - START (and not 0)")
                continue
            count = int(math.floor(n + 1e-9)) + 1
            if count > 100000:
                builder.error(f".step param {st.name}: {count} values", st.values[2].loc,
                              "at most 100000 values per .step: use a larger INCR")
                continue
            # 12 digits: 0.2 + 2 * 0.2 is 0.6, not 0.6000000000000001
            values = tuple(float(f"{start + k * incr:.12g}") for k in range(count))
        else:
            values = tuple(float(v) for v in vals)
        builder.circuit.steps.append((known[key], values))


def step_note(circuit: Circuit, given: dict[str, float]) -> str:
    """The note of a netlist with ``.step`` lines, which a simulation does not sweep: the
    values of the stepped parameters it uses, nominal or ``given`` (``--param``)."""
    names = ", ".join(name for name, _ in circuit.steps)
    head = f"the netlist's .step ({names}) is run by `pelcs sweep`; this run uses "
    given = {k.lower(): v for k, v in given.items()}
    if not any(name.lower() in given for name, _ in circuit.steps):
        return head + "the nominal .param values"
    return head + ", ".join(
        f"{name} = {given[name.lower()]:.6g} (--param)" if name.lower() in given
        else f"{name} = {circuit.params.get(name, circuit.params.get(name.lower())):.6g} "
        "(nominal)"
        for name, _ in circuit.steps)
