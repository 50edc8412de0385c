"""``.step param`` lines: the reader's part; :mod:`netlist.flatten` evaluates
them into ``circuit.steps`` and ``pelcs sweep`` runs them."""

from __future__ import annotations

import re

from .rawdeck import RawStep, Statement

__all__ = ["read_step"]


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
