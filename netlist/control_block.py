"""The commands of a ``.control`` block that change what ngspice's run computes.

pelcs simulates one run: the ``.tran`` line, or the block's first ``tran`` command
(:meth:`netlist.reader._Reader.control_tran`). Of the block's other commands, these change
that run or the ones after it, as measured in ngspice 39:

- ``alter NAME VALUE`` (also ``NAME = VALUE``, ``NAME=VALUE``, ``@NAME[PARAM]=VALUE``,
  ``NAME dc VALUE``) before the block's first ``run`` or ``tran`` sets the element's value for
  that run: ``alter R1 2k`` then ``op`` gives v(n2) = 1/3 V across R1 = 2k, R2 = 1k. pelcs
  applies it to a top-level R, L or C, or the DC value of a V or I source without a waveform,
  with a note; another ``alter`` before the run is refused at its place (pelcs would simulate
  another circuit than ngspice's run).
- an ``alter`` after the first run changes only later runs (``run``, ``alter R1 3k``, ``run``
  gives 0.333 then 0.25 V), which pelcs does not simulate: a note says so.
- ``stop`` makes ngspice's run pause and ``resume`` continue it: pelcs runs the ``.tran``
  whole, which a note says; a ``resume`` before any run continues nothing (ngspice's ``op``
  after it is unchanged). An ``alter`` between a ``stop`` and its ``resume`` would change a
  value during the run: refused.

An ``alter`` in a block that starts no run (no ``run`` or ``tran``: ngspice -b then runs
nothing) is noted as not applied.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import TYPE_CHECKING

from .dialect import strip_comment
from .rawdeck import Statement, Value
from .units import format_eng, parse_number

if TYPE_CHECKING:
    from .rawdeck import Deck, RawElement

__all__ = ["apply_control"]

_COMMAND = re.compile(r"\s*([A-Za-z]+)\b")
# ngspice's control structures closed by `end` (foreach is read: its values are known)
_BLOCKS = ("while", "repeat", "dowhile", "if")
# an element's value by the name ngspice's @NAME[PARAM] and alter NAME PARAM VALUE give it
_VALUE_PARAMS = {"R": ("resistance", "r"), "C": ("capacitance", "c"),
                 "L": ("inductance", "l"), "V": ("dc",), "I": ("dc",)}
_UNITS = {"R": "Ω", "C": "F", "L": "H", "V": "V", "I": "A"}
_READ = ("pelcs applies 'alter NAME VALUE' (or NAME=VALUE, @NAME[PARAM]=VALUE) to a top-level "
         "R, L, C or a V/I source's DC value without a waveform, with a number")

Error = Callable[[str, Statement, int, str], None]


def _statement(raw: str, start: int, file: str, line: int) -> Statement:
    """The command from column ``start`` of ``raw`` as a statement located in the file."""
    return Statement(strip_comment(raw)[start:].rstrip(), file, [(0, line, start, raw)])


def _parse_alter(text: str) -> tuple[str, str | None, str] | None:
    """``alter ...`` -> (element name, parameter or None, value text); None if malformed."""
    words = [w for w in re.split(r"[\s=,]+", text.strip())[1:] if w]
    m = re.fullmatch(r"@([^\[\]]+)\[([A-Za-z_]\w*)\]", words[0]) if words else None
    if m is not None and len(words) == 2:
        return m.group(1), m.group(2).lower(), words[1]
    if len(words) == 2:
        return words[0], None, words[1]
    if len(words) == 3:
        return words[0], words[1].lower(), words[2]
    return None


def _alter(deck: Deck, st: Statement, error: Error, how: str = "", shown: str = "") -> None:
    """Apply an ``alter`` before the run to its element, with a note; refuse it otherwise."""
    parsed = _parse_alter(st.text)
    if parsed is None:
        error(f"cannot read '{st.text}'", st, 0, _READ)
        return
    name, param, value_text = parsed
    el: RawElement | None = next((e for e in deck.top.elements
                                  if e.name.lower() == name.lower()), None)
    number = parse_number(value_text)
    why = ""
    if el is None or el.kind not in _VALUE_PARAMS:
        why = (f"'{name}' is no top-level R, L, C, V or I element" if el is None
               else f"{el.kind} elements are not altered by pelcs")
    elif param is not None and param not in _VALUE_PARAMS[el.kind]:
        why = f"'{param}' is not the value of {el.name}"
    elif el.kind in "VI" and el.wave is not None:
        why = f"{el.name} has a {el.wave[0].upper()} waveform: its DC value is not what a run reads"
    elif number is None:
        why = f"'{value_text}' is not a number"
    if why:
        error(f"'{st.text}' changes ngspice's run, and pelcs cannot apply it: {why}", st, 0,
              _READ + "; or write the value on the element's line")
        return
    el.value = Value(number, None, st, st.text.find(value_text))
    unit = _UNITS[el.kind]
    deck.notes.append(f"line {st.loc(0).line}: the .control block's '{shown or st.text}' applied: "
                      f"{el.name} = {format_eng(number, unit)}{how} (ngspice alters it before "
                      "its run)")


def _commands(lines: list[str]) -> list[tuple[int, str, int, list[tuple]]]:
    """The block's commands: (index of the line, command, its column, the open control
    structures around it, innermost last: ("foreach", VAR, values) or (KIND,))."""
    out, stack = [], []
    for i, raw in enumerate(lines[1:], 1):
        m = _COMMAND.match(strip_comment(raw))
        if m is None:
            continue
        cmd = m.group(1).lower()
        if cmd == "end":
            if stack:
                stack.pop()
            continue
        out.append((i, cmd, m.start(1), list(stack)))
        if cmd == "foreach":
            words = strip_comment(raw).split()
            stack.append(("foreach", words[1].lower() if len(words) > 1 else "", words[2:]))
        elif cmd in _BLOCKS:
            stack.append((cmd,))
    return out


def _substituted(st: Statement, at: int, commands: list, first_run: int | None,
                 variables: dict[str, str]) -> tuple[Statement, str] | str:
    """``st`` with its ``$VAR`` replaced by the value it has at the block's run, and how that
    value was found; or why it cannot be known (a message)."""
    structures = commands[at][3]
    if any(k[0] != "foreach" for k in structures):
        kinds = ", ".join(k[0] for k in structures if k[0] != "foreach")
        return f"it is inside {kinds}: pelcs does not run ngspice's control flow"
    text, how = st.text, ""
    for _kind, var, values in reversed(structures):
        if f"${var}" not in text.lower() and f"${{{var}}}" not in text.lower() or not values:
            continue
        # the loop's last value once it is done, or its first where the run is in the loop
        end = next((j for j in range(at + 1, len(commands))
                    if len(commands[j][3]) < len(structures)), len(commands))
        inside = first_run is not None and first_run < end
        value = values[0] if inside else values[-1]
        how += (f" (${var} = {value}: foreach {var}'s {'first' if inside else 'last'} value "
                f"{'at the run inside the loop' if inside else 'after the loop'})")
        text = re.sub(rf"(?i)\$\{{?{re.escape(var)}\b\}}?", value, text)
    for var, value in variables.items():
        if re.search(rf"(?i)\$\{{?{re.escape(var)}\b", text):
            text = re.sub(rf"(?i)\$\{{?{re.escape(var)}\b\}}?", value, text)
            how += f" (${var} = {value}, set before it)"
    if "$" in text:
        return "it reads a variable pelcs does not know"
    return Statement(text, st.file, st.segments), how


def apply_control(deck: Deck, file: str, error: Error) -> None:
    """Apply, note or refuse the ``alter``, ``stop`` and ``resume`` commands of the
    top-level file's ``.control`` blocks (see the module's text)."""
    for block in deck.ignored:
        loc = block.location
        if loc is None or loc.file != file or not block.text.lower().startswith(".control"):
            continue
        lines = block.text.split("\n")
        commands = _commands(lines)
        first_run = next((k for k, c in enumerate(commands) if c[1] in ("run", "tran")), None)
        stopped = False
        variables: dict[str, str] = {}
        for k, (i, cmd, col, _) in enumerate(commands):
            line, ran = loc.line + i, first_run is not None and k > first_run
            if cmd == "stop":
                stopped = True
                deck.notes.append(f"line {line}: the .control block's 'stop' not applied: "
                                  "pelcs runs the .tran whole (ngspice pauses there)")
            elif cmd == "resume":
                what = ("continues ngspice's run, which pelcs runs whole" if ran else
                        "before any run continues nothing (as in ngspice)")
                deck.notes.append(f"line {line}: the .control block's 'resume' {what}")
                stopped = False
            elif cmd == "set" and not ran:
                m = re.match(r"(?i)\s*set\s+(\w+)\s*=\s*(\S+)\s*$", strip_comment(lines[i]))
                if m is not None:
                    variables[m.group(1).lower()] = m.group(2)
            elif cmd == "alter":
                st = _statement(lines[i], col, file, line)
                if first_run is None:
                    deck.notes.append(f"line {line}: the .control block's '{st.text}' not "
                                      "applied: the block starts no run (no run or tran "
                                      "command), so ngspice -b runs nothing after it")
                elif not ran:
                    found = _substituted(st, k, commands, first_run, variables)
                    if isinstance(found, str):
                        error(f"'{st.text}' changes ngspice's run, and pelcs cannot apply it: "
                              f"{found}", st, 0, "write the value on the element's line")
                    else:
                        _alter(deck, found[0], error, found[1], st.text)
                elif stopped:
                    error(f"'{st.text}' between a 'stop' and 'resume' changes a value during "
                          "ngspice's run", st, 0, "pelcs cannot change an element's value "
                          "during a run: simulate each value as its own run")
                else:
                    deck.notes.append(f"line {line}: the .control block's '{st.text}' not "
                                      "applied: it comes after the run pelcs simulates and "
                                      "changes only ngspice's later runs")
