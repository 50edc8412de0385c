"""Text-level edits of an ngspice netlist ("deck") for the ngspice runner.

The runner needs a few mechanical changes to the user's netlist before ngspice sees it: add an
``.options`` line, replace the parameters of the D and SW ``.model`` lines, give PULSE sources
finite edges, override the ``.tran`` times and insert 0 V sense sources for current probes.
Until ``netlist.parser``/``netlist.writer`` exist these edits work on the text: the deck is
split into *logical lines* (``+`` continuation lines joined), each edit rewrites whole logical
lines, and comments and everything else pass through untouched. Every function here is pure
(text in, text out) so that the same edits can later be done on a parsed ``Circuit`` and
written back with ``write_circuit``.

Values that are plain SPICE numbers (``10n``, ``2.2u``, ``1e-3``) are computed in Python;
values given as ``{expression}`` are combined into new ngspice numparam expressions (``max``,
``min``), so that ``.param``-driven netlists keep working.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

from netlist.units import parse_number

# the first token of a logical line that ends the deck (``.ends`` closes a subcircuit)
_END = re.compile(r"^\s*\.end\s*$", re.IGNORECASE)


def format_number(value: float) -> str:
    """A float as an ngspice token that round-trips exactly (``repr`` is valid SPICE)."""
    return repr(float(value))


def split_tokens(text: str) -> list[str]:
    """Split at white space outside ``{...}`` and ``(...)``.

    ``Vg gate 0 PULSE(0 1 {a * b})`` gives ``['Vg', 'gate', '0', 'PULSE(0 1 {a * b})']``.
    """
    tokens: list[str] = []
    depth = 0
    cur: list[str] = []
    for ch in text:
        if ch in "{(":
            depth += 1
        elif ch in "})":
            depth = max(0, depth - 1)
        if ch.isspace() and depth == 0:
            if cur:
                tokens.append("".join(cur))
                cur = []
        else:
            cur.append(ch)
    if cur:
        tokens.append("".join(cur))
    return tokens


def logical_lines(text: str) -> list[str]:
    """The deck as logical lines: ``+`` continuations joined to their line, title first.

    Continuation lines are joined with one space; comment lines (``*``) and blank lines are
    kept as they are (a blank line or comment between a line and its continuation is moved
    after the joined line, which ngspice treats the same way).
    """
    physical = text.splitlines()
    if not physical:
        return []
    out = [physical[0]]  # the title is never a continuation or a command
    pending: list[str] = []  # comments seen since the last statement
    for line in physical[1:]:
        stripped = line.lstrip()
        if stripped.startswith("+") and len(out) > 1:
            out[-1] = out[-1].rstrip() + " " + stripped[1:].strip()
            continue
        if not stripped or stripped.startswith("*"):
            pending.append(line)
            continue
        out.extend(pending)
        pending = []
        out.append(line)
    out.extend(pending)
    return out


def _strip_inline_comment(line: str) -> str:
    """The line without an ngspice inline comment (``; ...`` or `` $ ...``)."""
    cut = len(line)
    for marker in (";", " $ ", "\t$ "):
        i = line.find(marker)
        if i >= 0:
            cut = min(cut, i)
    return line[:cut]


def _is_statement(line: str) -> bool:
    s = line.lstrip()
    return bool(s) and not s.startswith("*")


def _end_index(lines: list[str]) -> int:
    """Index of the top-level ``.end`` line, or ``len(lines)`` when there is none."""
    for i, line in enumerate(lines[1:], start=1):
        if _END.match(_strip_inline_comment(line)):
            return i
    return len(lines)


def _join(lines: list[str]) -> str:
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------------------
# .options


def add_options(text: str, options: Mapping[str, str | float | None]) -> str:
    """Append an ``.options`` line just before ``.end``.

    ngspice applies ``.options`` lines in order when the analysis starts, so options added
    last override the user's own (checked on ngspice 39 with ``method``).

    Parameters
    ----------
    text : str
        The netlist.
    options : mapping
        Option name -> value; a value None gives a bare flag (``.options noopiter``).
    """
    if not options:
        return text
    parts = [k if v is None else f"{k}={v}" for k, v in options.items()]
    lines = logical_lines(text)
    end = _end_index(lines)
    lines.insert(end, ".options " + " ".join(parts))
    return _join(lines)


# ------------------------------------------------------------------------------------------
# .ic


def add_initial_conditions(text: str, voltages: Mapping[str, float]) -> str:
    """Append ``.ic v(node)=value ...`` lines just before ``.end``.

    Written last, they override the user's own ``.ic`` for the same nodes. With UIC, ngspice
    starts the transient from them; without, they hold the nodes during the operating
    point. Ground (``0``) is left out.
    """
    items = [(n, v) for n, v in voltages.items() if str(n) not in ("0", "gnd")]
    if not items:
        return text
    lines = logical_lines(text)
    end = _end_index(lines)
    chunk = 8  # a few nodes per line, so that a large circuit gives readable lines
    new = [".ic " + " ".join(f"v({n})={format_number(float(v))}" for n, v in items[k:k + chunk])
           for k in range(0, len(items), chunk)]
    lines[end:end] = new
    return _join(lines)


# ------------------------------------------------------------------------------------------
# .model


@dataclass
class ModelLine:
    """A parsed ``.model NAME TYPE(params)`` line. ``params`` keep their text values."""

    name: str
    type: str
    params: dict[str, str]

    def render(self) -> str:
        body = " ".join(f"{k.upper()}={v}" for k, v in self.params.items())
        return f".model {self.name} {self.type.upper()}({body})"


_MODEL = re.compile(r"^\s*\.model\s+(\S+)\s+([a-z]+)\s*(.*)$", re.IGNORECASE | re.DOTALL)
_PARAM = re.compile(r"([a-z_][a-z0-9_]*)\s*=\s*(\{[^}]*\}|[^\s,()]+)", re.IGNORECASE)


def parse_model(line: str) -> ModelLine | None:
    """Parse a ``.model`` logical line; None if ``line`` is not one."""
    m = _MODEL.match(_strip_inline_comment(line))
    if m is None:
        return None
    body = m.group(3).strip()
    if body.startswith("(") and body.endswith(")"):
        body = body[1:-1]
    params = {k.lower(): v for k, v in _PARAM.findall(body)}
    return ModelLine(m.group(1), m.group(2).lower(), params)


def models(text: str) -> list[ModelLine]:
    """All ``.model`` lines of the deck (subcircuits included)."""
    out = []
    for line in logical_lines(text):
        model = parse_model(line)
        if model is not None:
            out.append(model)
    return out


def replace_diode_models(text: str, params: Mapping[str, str | float]) -> str:
    """Give every D model exactly ``params`` (the user's diode parameters are dropped).

    pelcs treats diodes as ideal whatever their model says, so the model only shapes how
    closely ngspice approximates the ideal diode; the names stay, the instances are untouched.
    """
    new = {k.lower(): str(v) for k, v in params.items()}
    lines = logical_lines(text)
    for i, line in enumerate(lines):
        model = parse_model(line) if i else None
        if model is not None and model.type == "d":
            lines[i] = ModelLine(model.name, "D", dict(new)).render()
    return _join(lines)


def _at_least(value: str | None, floor: float) -> str:
    """An ngspice value equal to max(value, floor) (value None or absent counts as 0)."""
    if value is None:
        return format_number(floor)
    num = parse_number(value)
    if num is not None:
        return value if num >= floor else format_number(floor)
    inner = value[1:-1] if value.startswith("{") and value.endswith("}") else value
    return f"{{max({inner}, {format_number(floor)})}}"


def replace_switch_models(text: str, ron: float, roff: float, vh_min: float = 0.0) -> str:
    """Set RON/ROFF of every SW model and raise its hysteresis VH to at least ``vh_min``.

    VT (the threshold) is part of the circuit's behaviour and is kept, as is any larger VH.

    Parameters
    ----------
    ron, roff : float
        On and off resistance (ohm).
    vh_min : float
        Smallest hysteresis half-width (V); 0 keeps the user's VH.
    """
    lines = logical_lines(text)
    for i, line in enumerate(lines):
        model = parse_model(line) if i else None
        if model is None or model.type != "sw":
            continue
        params = dict(model.params)
        params["ron"] = format_number(ron)
        params["roff"] = format_number(roff)
        if vh_min > 0:
            params["vh"] = _at_least(params.get("vh"), vh_min)
        lines[i] = ModelLine(model.name, "SW", params).render()
    return _join(lines)


# ------------------------------------------------------------------------------------------
# PULSE sources

_PULSE = re.compile(r"\bpulse\s*\(", re.IGNORECASE)
# PULSE written without parentheses: ``PULSE 0 1 0 1n 1n 5u 10u`` up to the end of the line
# or the next keyword of a source line (AC, DC, DISTOF1/2).
_PULSE_BARE = re.compile(r"\bpulse\b(?!\s*\()((?:\s+(?!(?:ac|dc|distof[12])\b)[^\s()]+)*)",
                         re.IGNORECASE)


def _closing_paren(text: str, start: int) -> int:
    """Index of the ``)`` matching the ``(`` at ``start - 1`` (braces and parens nest)."""
    depth = 1
    for j in range(start, len(text)):
        if text[j] in "({":
            depth += 1
        elif text[j] in ")}":
            depth -= 1
            if depth == 0:
                return j
    raise ValueError(f"unbalanced parentheses in {text!r}")


def _expr(value: str) -> str:
    """``value`` usable inside a numparam expression (strip the braces, keep numbers)."""
    v = value.strip()
    if v.startswith("{") and v.endswith("}"):
        return "(" + v[1:-1] + ")"
    num = parse_number(v)
    return format_number(num) if num is not None else v


def _finite_pulse(args: list[str], min_edge: float) -> list[str]:
    """PULSE arguments with PW >= min_edge and nonzero TR/TF >= min_edge, period kept.

    TR or TF of 0 (or absent) are left alone: ngspice replaces them by TSTEP, which is
    already finite. When the wider pulse would not fit in the period, TR is shortened.
    """
    a = list(args) + [None] * (7 - len(args))  # v1 v2 td tr tf pw per
    tr, tf, pw, per = a[3], a[4], a[5], a[6]
    if pw is None:  # PW defaults to TSTOP: a single long pulse, nothing to fix
        return args

    def floored(v: str | None) -> str | None:
        if v is None:
            return None
        num = parse_number(v)
        if num is not None:
            return v if num == 0 or num >= min_edge else format_number(min_edge)
        return f"{{max({_expr(v)}, {format_number(min_edge)})}}"  # expressions: 0 can't be told

    new_tr, new_tf = floored(tr), floored(tf)
    new_pw = _at_least(pw, min_edge)
    if per is not None and new_tr is not None and new_tf is not None:
        nums = [parse_number(v) for v in (new_tr, new_tf, new_pw, per)]
        if None not in nums:
            t_r, t_f, p_w, p = nums
            if p > 0 and t_r + t_f + p_w > p:
                new_tr = format_number(max(p - t_f - p_w, min_edge))
        else:
            new_tr = (
                f"{{min({_expr(new_tr)}, max({_expr(per)} - {_expr(new_tf)} - "
                f"{_expr(new_pw)}, {format_number(min_edge)}))}}"
            )
    a[3], a[4], a[5] = new_tr, new_tf, new_pw
    out = [v for v in a[:7] if v is not None]
    if len(a) > 7:
        out += [v for v in a[7:] if v is not None]
    # keep positional meaning: a None in the middle cannot happen because pw is given
    return out


def finite_pulse_edges(text: str, min_edge: float) -> str:
    """Give every ``PULSE(...)`` source a pulse width and nonzero edges of at least min_edge.

    ngspice 39 takes "timestep too small" at the corners of a PULSE with PW=0 (a sawtooth) or
    with edges of a few ps; 1 ns on a 400 us period changes nothing measurable. Both the
    parenthesised form ``PULSE(...)`` and ``PULSE 0 1 ...`` without parentheses are edited
    (the latter is written back with parentheses).

    Parameters
    ----------
    min_edge : float
        Smallest PW and nonzero TR/TF (s).
    """
    lines = logical_lines(text)
    for i, line in enumerate(lines):
        if i == 0 or not _is_statement(line) or line.lstrip().startswith("."):
            continue
        out, pos = [], 0
        for m in _PULSE.finditer(line):
            if m.start() < pos:
                continue
            close = _closing_paren(line, m.end())
            args = split_tokens(line[m.end() : close].replace(",", " "))
            fixed = _finite_pulse(args, min_edge)
            out.append(line[pos : m.end()] + " ".join(fixed))
            pos = close
        if out:
            lines[i] = "".join(out) + line[pos:]
            continue
        m = _PULSE_BARE.search(line)
        if m and m.group(1).strip():
            args = split_tokens(m.group(1).replace(",", " "))
            fixed = _finite_pulse(args, min_edge)
            lines[i] = line[: m.start()] + "PULSE(" + " ".join(fixed) + ")" + line[m.end():]
    return _join(lines)


# ------------------------------------------------------------------------------------------
# .tran


@dataclass
class TranLine:
    """The ``.tran`` line's fields as text (numbers or ``{expressions}``)."""

    tstep: str
    tstop: str
    tstart: str | None = None
    tmax: str | None = None
    uic: bool = False


def _tran_from_tokens(tokens: list[str]) -> TranLine | None:
    uic = any(t.lower() == "uic" for t in tokens[1:])
    vals = [t for t in tokens[1:] if t.lower() != "uic"]
    if len(vals) < 2:
        return None
    return TranLine(
        vals[0],
        vals[1],
        vals[2] if len(vals) > 2 else None,
        vals[3] if len(vals) > 3 else None,
        uic,
    )


def parse_tran(text: str) -> TranLine | None:
    """The deck's ``.tran`` line, or None."""
    for line in logical_lines(text)[1:]:
        tokens = split_tokens(_strip_inline_comment(line))
        if tokens and tokens[0].lower() == ".tran":
            return _tran_from_tokens(tokens)
    return None


def set_tran(
    text: str, tstep: float | None = None, tstop: float | None = None, *, uic: bool = True
) -> str:
    """Override TSTEP and/or TSTOP of the ``.tran`` line (add one if there is none).

    A TSTART at or beyond the new TSTOP is reset to 0. Note that TSTEP is also ngspice's
    default for PULSE edges given as 0, so changing it changes those edges (as in ngspice).

    Parameters
    ----------
    tstep, tstop : float or None
        New print step and stop time (s); None keeps the netlist's.
    uic : bool
        Used only when a ``.tran`` line has to be created.
    """
    if tstep is None and tstop is None:
        return text
    lines = logical_lines(text)
    for i, line in enumerate(lines[1:], start=1):
        tokens = split_tokens(_strip_inline_comment(line))
        if tokens and tokens[0].lower() == ".tran":
            tran = _tran_from_tokens(tokens)
            if tran is None:
                raise ValueError(f"cannot read the .tran line {line!r}")
            if tstep is not None:
                tran.tstep = format_number(tstep)
            if tstop is not None:
                tran.tstop = format_number(tstop)
                start = parse_number(tran.tstart) if tran.tstart else None
                if start is not None and start >= tstop:
                    tran.tstart = "0"
            fields = [tran.tstep, tran.tstop]
            if tran.tstart is not None or tran.tmax is not None:
                fields.append(tran.tstart or "0")
            if tran.tmax is not None:
                fields.append(tran.tmax)
            if tran.uic:
                fields.append("UIC")
            lines[i] = ".tran " + " ".join(fields)
            return _join(lines)
    if tstop is None:
        raise ValueError("the netlist has no .tran line: give tstop")
    step = tstep if tstep is not None else tstop / 1000.0
    tran_line = f".tran {format_number(step)} {format_number(tstop)}" + (" UIC" if uic else "")
    lines.insert(_end_index(lines), tran_line)
    return _join(lines)


# ------------------------------------------------------------------------------------------
# elements and current sense sources


@dataclass
class ElementLine:
    """A top-level element line: its index among the logical lines and its tokens."""

    index: int
    tokens: list[str]

    @property
    def name(self) -> str:
        return self.tokens[0]


def top_level_elements(text: str) -> list[ElementLine]:
    """Element lines outside ``.subckt`` blocks, in netlist order."""
    out = []
    depth = 0
    for i, line in enumerate(logical_lines(text)):
        if i == 0 or not _is_statement(line):
            continue
        tokens = split_tokens(_strip_inline_comment(line))
        if not tokens:
            continue
        head = tokens[0].lower()
        if head == ".subckt":
            depth += 1
        elif head == ".ends":
            depth = max(0, depth - 1)
        elif head == ".end":
            break
        elif depth == 0 and not head.startswith("."):
            out.append(ElementLine(i, tokens))
    return out


def sense_names(element: str) -> tuple[str, str]:
    """(source name, node name) of the 0 V sense source inserted for ``element``."""
    key = re.sub(r"[^a-z0-9_]", "_", element.lower())  # d.x1.d1 (flattened) -> d_x1_d1
    return f"vpelcs_{key}", f"pelcs_{key}_s"


def insert_sense_source(text: str, element: str) -> str:
    """Put a 0 V source in series with ``element`` at its second node.

    ``D1 a k DMOD`` becomes ``D1 a pelcs_d1_s DMOD`` plus ``vpelcs_d1 pelcs_d1_s k 0``, so
    that ``i(vpelcs_d1)`` is the element's current from its first node through it to its
    second (pelcs' sign convention). Works for every element whose first two nodes carry its
    current (R C D S I E F G H); raises KeyError if there is no such top-level element.
    """
    lines = logical_lines(text)
    key = element.lower()
    for el in top_level_elements(text):
        if el.name.lower() == key:
            if len(el.tokens) < 3:
                raise ValueError(f"element line too short: {' '.join(el.tokens)}")
            source, node = sense_names(element)
            tokens = list(el.tokens)
            n_minus = tokens[2]
            tokens[2] = node
            lines[el.index] = " ".join(tokens)
            lines.insert(el.index + 1, f"{source} {node} {n_minus} 0")
            return _join(lines)
    raise KeyError(element)
