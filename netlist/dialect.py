"""The ngspice dialect pelcs reads: element letters and their grammar rules, what is refused
(with the ideal equivalent to use), commands ignored, model types, source functions, and the
spelling of node and element names."""

from __future__ import annotations

import re

from .circuit import GROUND


def split_top_level(text: str, keep_empty: bool = False) -> list[str]:
    """``text`` split at the commas outside parentheses (``v(a,b), i(L1)``), each part
    stripped; empty parts dropped, or with ``keep_empty`` kept where something else is
    (a call's arguments ``f(a,,b)``: none at all for ``f()``)."""
    parts, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        if ch == "(":
            depth += 1
        elif ch == ")":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i].strip())
            start = i + 1
    parts.append(text[start:].strip())
    if keep_empty:
        return parts if any(parts) else []
    return [p for p in parts if p]


# ------------------------------------------------------------------------------ tables

# element letter -> (start rule of grammar.lark, description, usage)
ELEMENTS: dict[str, tuple[str, str, str]] = {
    "R": ("passive", "resistor", "Rname n+ n- value"),
    "L": ("passive", "inductor", "Lname n+ n- value [IC=current]"),
    "C": ("passive", "capacitor", "Cname n+ n- value [IC=voltage]"),
    "V": ("source", "voltage source",
          "Vname n+ n- [[DC] value] [PULSE(...)|SIN(...)|PWL(...)|EXP(...)]"),
    "I": ("source", "current source",
          "Iname n+ n- [[DC] value] [PULSE(...)|SIN(...)|PWL(...)|EXP(...)]"),
    "D": ("diode", "diode", "Dname anode cathode model"),
    "S": ("switch", "switch", "Sname n+ n- nc+ nc- model [ON|OFF]"),
    "E": ("vcontrolled", "voltage-controlled voltage source", "Ename n+ n- nc+ nc- gain"),
    "G": ("vcontrolled", "voltage-controlled current source", "Gname n+ n- nc+ nc- gm"),
    "F": ("ccontrolled", "current-controlled current source", "Fname n+ n- Vcontrol gain"),
    "H": ("ccontrolled", "current-controlled voltage source", "Hname n+ n- Vcontrol r"),
    "K": ("coupling", "coupling", "Kname L1 L2 k"),
    "M": ("device", "MOSFET", "Mname drain gate source [bulk] model [L=.. W=..]"),
    "Q": ("device", "BJT", "Qname collector base emitter [substrate] model [area]"),
    "X": ("instance", "subcircuit instance", "Xname node... subckt [params: name=value...]"),
    # read by the reader itself (an expression grammar of its own: netlist.behavioural)
    "B": ("behavioural", "behavioural source", "Bname n+ n- V=expression or I=expression"),
}

_IDEAL = ("pelcs simulates ideal elements: model its function with R, L, C, sources, "
          "controlled sources (E F G H), ideal diodes (D) and ideal switches (S)")

# element letter -> (what it is, hint)
UNSUPPORTED_ELEMENTS: dict[str, tuple[str, str]] = {
    "J": ("JFET", "pelcs simulates ideal elements: use an S switch driven by the gate voltage"),
    "Z": ("MESFET", "pelcs simulates ideal elements: use an S switch driven by the gate voltage"),
    "T": ("transmission line", "approximate the line with a ladder of L and C sections"),
    "O": ("lossy transmission line", "approximate the line with a ladder of R, L, C sections"),
    "U": ("uniform RC line", "approximate the line with a ladder of R and C sections"),
    "P": ("coupled transmission line", "approximate it with coupled inductors (K) and C"),
    "Y": ("transmission line", "approximate the line with a ladder of L and C sections"),
    "N": ("Verilog-A/OSDI device", _IDEAL),
}

# dot commands that pelcs accepts and lists in Circuit.ignored
IGNORED_COMMANDS = {
    ".backanno",
    ".print", ".save", ".plot", ".probe", ".meas", ".measure", ".four", ".fourier", ".op",
    ".width", ".temp", ".nodeset", ".ac", ".dc", ".noise", ".tf", ".sens", ".pz", ".disto",
    ".sp", ".csparam",
}

UNSUPPORTED_COMMANDS: dict[str, str] = {
    ".if": "conditional netlists are not supported: choose with --param and expressions",
    ".elseif": "conditional netlists are not supported",
    ".else": "conditional netlists are not supported",
    ".endif": "conditional netlists are not supported",
    ".data": "data tables are not supported",
    ".endl": ".endl closes a section of a library file read with .lib FILE SECTION",
    ".endc": ".endc without .control",
}

SUPPORTED_COMMANDS = (".param .subckt/.ends .model .ic .tran .step .options .include .lib "
                      ".global .title .control/.endc .end")

_MODEL_TYPES = {"D": "D", "SW": "SW", "CSW": "CSW", "NMOS": "NMOS", "PMOS": "PMOS",
                "VDMOS": "VDMOS", "NPN": "NPN", "PNP": "PNP"}
_UNSUPPORTED_MODELS = {
    "NJF": "JFET", "PJF": "JFET", "NMF": "MESFET", "PMF": "MESFET",
    "R": "semiconductor resistor", "C": "semiconductor capacitor", "L": "inductor",
    "LTRA": "lossy line", "URC": "uniform RC line", "TRANSLINE": "line",
}

# instance parameters accepted (and ignored: they do not change the nominal value) besides IC
_PASSIVE_IGNORED = {"tce", "noisy", "ac"}
# instance parameters of R, L, C that scale the value away from the nominal temperature
_TEMPERATURE_PARAMS = ("tc1", "tc2", "temp", "dtemp")

# waveform -> (minimum, maximum number of arguments)
WAVE_ARGS = {"pulse": (2, 8), "sin": (2, 6), "exp": (2, 6), "pwl": (2, None)}
# other spellings ngspice reads -> the waveform
WAVE_ALIASES = {"sine": "sin"}
# source functions ngspice has and pelcs does not -> what to use instead
UNSUPPORTED_WAVES = {
    "sffm": "write the frequency-modulated waveform as a PWL table",
    "am": "write the amplitude-modulated waveform as a PWL table",
    "trnoise": "pelcs simulates deterministic sources: leave the noise out",
    "trrandom": "pelcs simulates deterministic sources: leave the random source out",
}

_WORD = re.compile(r"[^\s(){}=,'\"]+")
_NONLINEAR = re.compile(r"(?i)\b(poly|value|table|laplace|freq|vol|cur)\s*[=({]")
_NUL_HINT = "pelcs reads plain-text SPICE netlists"

_TOKEN_NAMES = {
    "WORD": "a name or a value", "EXPR": "an {expression}", "LPAR": "'('", "RPAR": "')'",
    "EQUAL": "'='", "COMMA": "','", "STRING": "a quoted path", "PARAMS": "'params:'",
    "$END": "end of line", "DC": "DC", "AC": "AC", "UIC": "UIC", "ON": "ON", "OFF": "OFF",
    "PULSE": "PULSE", "SIN": "SIN", "PWL": "PWL", "EXP": "EXP", "SINE": "SINE",
    "SFFM": "SFFM", "AM": "AM", "TRNOISE": "TRNOISE", "TRRANDOM": "TRRANDOM",
    "STARTUP": "STARTUP", "STEADY": "STEADY", "NODISCARD": "NODISCARD", "NCHAN": "NCHAN",
    "PCHAN": "PCHAN",
}


def node_name(word: str) -> str:
    """The canonical node name: lower case, ``gnd`` is ``0``."""
    n = word.lower()
    return GROUND if n == "gnd" else n


def hierarchical_name(word: str, kind: str | None = None) -> str:
    """Map ngspice's flattened spelling ``L.X1.L1`` back to the hierarchical name ``X1.L1``.

    Parameters
    ----------
    word : str
        An element name as written.
    kind : str, optional
        The element letter; by default the first letter of ``word``.
    """
    if "." not in word:
        return word
    parts = word.split(".")
    letter = (kind or word[0]).upper()
    if (
        len(parts) >= 3
        and len(parts[0]) == 1
        and parts[0].upper() == letter
        and parts[1][:1] in ("x", "X")
    ):
        return word[2:]
    return word


