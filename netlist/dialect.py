"""The ngspice dialect pelcs reads: element letters and their grammar rules, what is refused
(with the ideal equivalent to use), commands ignored, model types, source functions, and the
spelling of node and element names."""

from __future__ import annotations

import re

from .circuit import GROUND


def missing_include_hint(including: str, files: list[str]) -> str:
    """What to do about an include that does not exist, and what ngspice does with it
    (measured, ngspice 39: in the top file it loads no circuit, "there aren't any circuits
    loaded"; in an included file it drops that whole file, the elements before the include
    as well as after it, and simulates what is left without a word beyond "Could not find
    include file"). pelcs refuses both: what ngspice then simulates is not the netlist."""
    hint = "check the path (relative paths in .include and .lib are relative to the " \
        "including file)"
    if files and including != files[0]:
        return (hint + f"; ngspice drops all of '{including}' for it (every element of "
                "that file, before the include and after it) and simulates what is left, "
                "which is not this circuit")
    return hint + "; ngspice loads no circuit either"


def strip_comment(line: str) -> str:
    """Remove ``;`` and ``$`` inline comments (``$`` only after white space, before a space)."""
    i = line.find(";")
    if i >= 0:
        line = line[:i]
    if "$" in line:
        j = line.find("$")
        while j >= 0:
            before_ok = j == 0 or line[j - 1] in " \t"
            after_ok = j + 1 == len(line) or line[j + 1] in " \t"
            if before_ok and after_ok:
                return line[:j]
            j = line.find("$", j + 1)
    return line


_ASSIGNMENT = re.compile(r"([A-Za-z_][\w.]*)\s*=(?!=)")


def param_assignments(text: str, start: int) -> list[tuple[str, int, str, int]] | None:
    """The ``NAME = VALUE`` items of a ``.param`` statement from ``start``, each value
    running to the next ``NAME =`` outside parentheses, braces and quotes, as ngspice's
    numparam reads an unbraced expression (``.param vs = vrms * sqrt(2)``): ``(name, its
    offset, value text without trailing commas, its offset)``; None where the text is not
    that form (something before the first name, a value missing)."""
    found: list[re.Match] = []
    depth, quote, i = 0, "", start
    while i < len(text):
        ch = text[i]
        if quote:
            quote = "" if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch in "({":
            depth += 1
        elif ch in ")}":
            depth -= 1
        elif depth == 0 and (i == start or not (text[i - 1].isalnum() or text[i - 1] in "_.")):
            m = _ASSIGNMENT.match(text, i)
            if m is not None:
                found.append(m)
                i = m.end()
                continue
        i += 1
    if not found or text[start:found[0].start()].strip():
        return None
    out = []
    for k, m in enumerate(found):
        end = found[k + 1].start() if k + 1 < len(found) else len(text)
        raw = text[m.end():end]
        value = raw.strip().rstrip(",").rstrip()
        if not value:
            return None
        out.append((m.group(1), m.start(1), value, m.end() + len(raw) - len(raw.lstrip())))
    return out


def ngspice_param_token(value: str, alone: bool = True) -> str:
    """What ngspice takes for an unbraced ``.param`` value (its ``inp_fix_param_values`` and
    numparam): all of it where it starts with a digit, ``.``, a signed number or a quote and
    is the line's only assignment (``.param b = 1 + a``); else only up to the first white
    space outside parentheses (``sqrt(2)``, ``max(1, 2)``, ``(a * 2)``), and ngspice stops
    at what follows (``a * 2``), or, on a line of several assignments, drops it (``.param
    b = 1 + a, c = 2`` sets b to 1). ``alone`` is false in a subcircuit too, where ngspice
    39 cuts a value that starts with a number as well (``.param rv = 1 + 2`` sets rv to 1)."""
    first = value[:1]
    if alone and (first.isdigit() or first in ".\"" or (first in "+-" and value[1:2].isdigit())):
        return value
    return first_token(value)


def first_token(text: str) -> str:
    """``text`` up to its first blank outside parentheses: the token ngspice's front end puts
    braces around in an unbraced value (inpcom.c, ``inp_fix_param_values``), the rest of it
    left outside."""
    depth = 0
    for i, ch in enumerate(text):
        if ch.isspace() and depth <= 0:
            return text[:i]
        depth += (ch == "(") - (ch == ")")
    return text


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
_PASSIVE_IGNORED = {"noisy", "ac"}
# instance parameters of R, L, C that scale the value away from the nominal temperature
# (and TC=TC1[,TC2], netlist.element_lines)
_TEMPERATURE_PARAMS = ("tc1", "tc2", "tce", "temp", "dtemp")

# waveform -> (minimum, maximum number of arguments)
WAVE_ARGS = {"pulse": (2, 8), "sin": (2, 6), "exp": (2, 6), "pwl": (2, None), "sffm": (2, 7),
             "am": (2, 7)}
# other spellings ngspice reads -> the waveform
WAVE_ALIASES = {"sine": "sin"}
# source functions ngspice has and pelcs does not -> what to use instead
UNSUPPORTED_WAVES = {
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


#: the keywords a node or a model may be named (grammar.lark: node, model_name)
NAME_KEYWORDS = frozenset({"DC", "AC", "PULSE", "SIN", "SINE", "SFFM", "AM", "TRNOISE",
                           "TRRANDOM", "PWL", "EXP", "OFF", "ON"})


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




# .tran's fields by position, and what ngspice 39 says of a parameter name written bare there
_TRAN_FIELDS = ("TSTEP", "TSTOP", "TSTART", "TMAX")
_TRAN_NAME = re.compile(r"[A-Za-z_]\w*")


def tran_bare_name(words: list[str]) -> tuple[int, str, str] | None:
    """The first ``.tran`` field written as a bare parameter name (``.tran tstep tstop``):
    its index in ``words``, the message and the hint; None when there is none.

    ngspice 39 substitutes no parameter in a ``.tran`` line outside braces: it stops with
    "TSTEP is invalid, must be greater than zero" (TSTOP likewise), or "unknown parameter on
    .tran" for TSTART and TMAX (measured).
    """
    for k, word in enumerate(words[:4]):
        if word[:1] in "{'" or not _TRAN_NAME.fullmatch(word):
            continue
        field = _TRAN_FIELDS[k] if len(words) > 1 else "TSTOP"
        said = (f"{field} is invalid, must be greater than zero" if field in ("TSTEP", "TSTOP")
                else "unknown parameter on .tran")
        return (k, f".tran {field} '{word}' is a bare name: ngspice reads no parameter there "
                   f"(ngspice 39: \"{said}\")", f"write it in braces: {{{word}}}")
    return None
