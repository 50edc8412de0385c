"""Netlist text -> :class:`~netlist.circuit.Circuit`: the front end of pelcs.

The work is done in three stages:

1. *Reading* (:mod:`netlist.reader`). Bytes are decoded (binary, non-UTF-8, missing files and
   directories are input errors), split into lines, and the lines into logical statements:
   the first line of the top file is the title; ``*`` comment lines, ``;`` and ``$``
   inline comments and blank lines are dropped; ``+`` continuation lines are joined to their
   statement while remembering the original line and column of every character;
   ``.control ... .endc`` blocks are kept aside as ignored; ``.end`` is read as a comment,
   as ngspice reads it: the lines after it are still the netlist's.
   ``.include`` and ``.lib`` are followed (paths relative to the including file, cycles
   detected).
2. *Syntax* (:mod:`netlist.reader`; the dialect's tables in :mod:`netlist.dialect`). Each
   statement is parsed with the LALR parser of ``grammar.lark``; the start rule is picked
   from the statement's first word (element letter or dot command), so that unsupported
   elements and commands get a specific message and a hint naming the ideal equivalent. The
   result is a :class:`~netlist.rawdeck.Deck`: raw elements with their values still as text
   or parsed expressions, parameters, subcircuit definitions, models...
3. *Elaboration* (:mod:`netlist.flatten`) evaluates the parameters, expands subcircuits and
   builds the typed circuit, then :mod:`netlist.checks` looks for semantic problems.

Every problem is a :class:`~netlist.errors.Diagnostic`; syntax problems of all statements are
collected before raising one :class:`~netlist.errors.NetlistError`.

Names
-----
Element names keep their spelling; node names are lower case and ``gnd`` is ``0``. An element
name of the form ``<letter>.<X...>`` (``L.X1.L1``), which is how ngspice and
:func:`netlist.writer.write_circuit` spell an element of a flattened subcircuit instance, is
read back as the hierarchical name ``X1.L1``; references to elements (F/H controlling
sources, K inductors) are mapped the same way.

This module is the entry point: :func:`parse_file`, :func:`parse_string`,
:func:`load_source` (a path or netlist text, with overrides given as numbers or SPICE text)
and :func:`parse_overrides`.
"""

from __future__ import annotations

import os
import re
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

from .capacitor_loops import reduce_capacitor_loops
from .circuit import Circuit
from .dialect import hierarchical_name, node_name
from .errors import Diagnostic, NetlistError
from .expressions import ExpressionError, parse_expression
from .flatten import build_circuit, independent_problems
from .free_potential import free_potential_notes
from .inductor_cutsets import regularise_inductor_cutsets
from .netlist_bytes import blank_controls
from .netlist_bytes import decode as _decode
from .netlist_bytes import read_bytes as _read_bytes
from .perfect_coupling import ideal_transformers
from .rawdeck import Deck, Statement
from .reader import _Reader, read_deck
from .switch_leakage import model_off_resistances
from .units import parse_number

__all__ = ["parse_file", "parse_string", "parse_overrides", "load_source", "read_deck", "Deck",
           "Statement", "hierarchical_name", "node_name"]


def parse_string(text: str, file: str = "<string>",
                 params: dict[str, float] | None = None,
                 thresholds: Mapping[str, float] | None = None, *,
                 reuse: bool = False) -> Circuit:
    """Parse netlist text into a flattened, checked circuit.

    Parameters
    ----------
    text : str
        The netlist; its first line is the title, as in SPICE.
    file : str
        Name used in error messages; relative ``.include`` paths are resolved from its
        directory (from the current directory for ``"<string>"``).
    params : dict of str to float, optional
        Values that replace global ``.param`` definitions (case-insensitive names); naming a
        parameter that the netlist does not define is an error.
    thresholds : mapping of str to float, optional
        Switch thresholds (V) of transistors idealised as switches, by element or model
        name (:mod:`netlist.devices`); ``circuit.replacements`` reports each.
    reuse : bool
        Read the text once for many calls (:mod:`netlist.deck_cache`): the same circuit,
        without the reading, when only ``params`` change.

    Returns
    -------
    Circuit

    Raises
    ------
    NetlistError
        For every problem in the input, with all independent problems found.
    """
    params = params or {}
    if "\x00" in text:
        _decode(text.encode("utf-8", errors="surrogatepass"), file)
    text = blank_controls(text, file)  # (as a file's text is read)
    return _idealised(_loops_and_cutsets(
        _build(_deck(text, file, None, params, reuse), params, thresholds, reuse)))


def parse_file(path: str | os.PathLike, params: dict[str, float] | None = None,
               thresholds: Mapping[str, float] | None = None, *,
               reuse: bool = False) -> Circuit:
    """Read and parse a netlist file.

    Parameters
    ----------
    path : str or path-like
        The netlist file.
    params : dict of str to float, optional
        Overrides of global ``.param`` values, as in :func:`parse_string`.
    reuse : bool
        Read the file once for many calls, as in :func:`parse_string` (read again when it or
        a file it includes holds other bytes).

    Raises
    ------
    NetlistError
        Also for a missing file, a directory, binary or non-UTF-8 content.
    """
    params = params or {}
    display = os.fspath(path)
    text = _decode(_read_bytes(display, display, None), display)
    return _idealised(_loops_and_cutsets(
        _build(_deck(text, display, display, params, reuse), params, thresholds, reuse)))


def _build(deck: Deck, params: dict[str, float], thresholds, reuse: bool) -> Circuit:
    """The deck evaluated (with ``reuse``, re-binding a kept evaluation of a kept deck:
    :mod:`netlist.rebind`)."""
    if reuse:
        from .rebind import rebound_circuit

        return rebound_circuit(deck, params, thresholds)
    return build_circuit(deck, params, thresholds)


def _deck(text: str, file: str, path: str | None, params: dict[str, float],
          reuse: bool) -> Deck:
    """The deck of ``text`` (read from the file ``path``, None for text; or with ``reuse``
    the one kept from an earlier read of the same text and includes:
    :mod:`netlist.deck_cache`); raises its problems."""
    if reuse:
        from .deck_cache import cached_deck

        return cached_deck(text, file, path, params)
    base = None
    if path is not None:
        try:
            base = Path(path).resolve()
        except (OSError, RuntimeError):
            base = Path(path)
    reader = _Reader(file)
    reader.read_top(text, file, base)
    reader.raise_problems(params, independent_problems)
    return reader.deck


_OVERRIDE = re.compile(r"\s*([A-Za-z_][\w.]*)\s*=\s*(\S.*?)\s*")


def parse_overrides(items: list[str] | None) -> dict[str, float]:
    """Command-line ``NAME=VALUE`` parameter overrides -> ``{name: value}``.

    Parameters
    ----------
    items : list of str
        E.g. ``["duty=0.3", "fs=100k", "r={2*10}"]``; a value is a SPICE number (with
        suffix) or a constant expression.

    Raises
    ------
    NetlistError
        For an item that is not ``NAME=VALUE`` or a value that is not a number; the
        diagnostic has no file location and names the item.
    """
    out: dict[str, float] = {}
    diags: list[Diagnostic] = []
    for item in items or []:
        m = _OVERRIDE.fullmatch(item)
        value = None
        if m is not None:
            text = m.group(2)
            if text.startswith("{") and text.endswith("}") or (
                    len(text) > 1 and text[0] == text[-1] == "'"):
                text = text[1:-1]
            value = parse_number(text)
            if value is None:
                try:
                    expr = parse_expression(text)
                    if expr.constant:
                        value = expr.evaluate({})
                except ExpressionError:
                    value = None
        if m is None or value is None:
            diags.append(Diagnostic(
                f"bad parameter override '{item}': expected NAME=VALUE", None,
                "e.g. --param duty=0.3 or --param fs=100k (a number with optional suffix)"))
            continue
        out[m.group(1)] = value
    if diags:
        raise NetlistError(diags, "pelcs")
    return out


def load_source(path_or_text: str | os.PathLike, params: Mapping[str, float | str] | None = None,
                thresholds: Mapping[str, float] | None = None, *,
                reuse: bool = False) -> Circuit:
    """A netlist file or netlist text (a string with a line break) as a parsed circuit.

    Parameters
    ----------
    path_or_text : str, path-like or PySpice Circuit
    params : mapping, optional
        ``.param`` overrides: numbers, or SPICE text (``"100k"``, ``"{2*ts}"``).
    reuse : bool
        Keep the read netlist for the next call (:func:`parse_string`).

    Raises
    ------
    NetlistError
        For every problem of the input or of the overrides.
    """
    values = None
    if params:
        text = [f"{k}={v}" for k, v in params.items() if isinstance(v, str)]
        values = {k: float(v) for k, v in params.items() if not isinstance(v, str)}
        values.update(parse_overrides(text))
    if is_pyspice_circuit(path_or_text):
        # PySpice renders its circuit as SPICE text, its includes as absolute paths
        text = str(path_or_text)
        if not text.lstrip().lower().startswith(".title"):
            text = f"{path_or_text.title}\n" + text
        return parse_string(text, file=f"<PySpice circuit {path_or_text.title}>",
                            params=values, thresholds=thresholds, reuse=reuse)
    if isinstance(path_or_text, str) and "\n" in path_or_text:
        return parse_string(path_or_text, params=values, thresholds=thresholds, reuse=reuse)
    return parse_file(path_or_text, params=values, thresholds=thresholds, reuse=reuse)


def is_pyspice_circuit(obj) -> bool:
    """A PySpice ``Circuit`` (duck-typed: pelcs does not import PySpice for it)."""
    return type(obj).__module__.startswith("PySpice") and hasattr(obj, "title")


def _loops_and_cutsets(circuit: Circuit) -> Circuit:
    """The circuit with its loops of capacitors and voltage sources reduced
    (:mod:`netlist.capacitor_loops`) and its floating sources' inductor cutsets made regular
    (:mod:`netlist.inductor_cutsets`): what the formulation would otherwise refuse; a note for
    each part whose potential only diodes bound (:mod:`netlist.free_potential`)."""
    notes = free_potential_notes(circuit)  # (on the netlist's own nodes and elements)
    out = regularise_inductor_cutsets(reduce_capacitor_loops(model_off_resistances(
        ideal_transformers(circuit))))
    return replace(out, notes=[*out.notes, *notes]) if notes else out


def _idealised(circuit: Circuit) -> Circuit:
    """Warn (:class:`~lcs.notices.IdealisedDeviceWarning`) that transistors became switches;
    ``--strict`` turns the warning into an error."""
    if circuit.replacements:
        import warnings

        from lcs.notices import IdealisedDeviceWarning

        n = len(circuit.replacements)
        names = ", ".join(r.element for r in circuit.replacements[:6])
        more = f" and {n - 6} more" if n > 6 else ""
        what = (f"{n} device{'s' if n > 1 else ''} (transistors, macro-models) idealised "
                f"({names}{more}); `pelcs info` lists what each became")
        warning = IdealisedDeviceWarning(f"{circuit.file}: {what}")
        # (for --strict's error: the first device's line, as every input error is shown)
        warning.location = circuit.replacements[0].location
        warning.locations = [(r.element, r.location) for r in circuit.replacements]
        warning.what = what
        warnings.warn(warning, stacklevel=3)
    return circuit
