"""Reading and syntax: netlist text (and its includes) -> :class:`~netlist.rawdeck.Deck`.

Stages 1 and 2 of :mod:`netlist.parser` (see its docstring): decoding, statements with their
locations, ``+`` continuations, comments, ``.control`` blocks, ``.include``/``.lib``, and the
lark parse of each statement with specific messages for what pelcs does not read.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from pathlib import Path

from . import expressions, xspice
from .circuit import IgnoredCommand
from .control_block import apply_control
from .dialect import (
    _MODEL_TYPES,
    _TOKEN_NAMES,
    _UNSUPPORTED_MODELS,
    _WORD,
    ELEMENTS,
    IGNORED_COMMANDS,
    NAME_KEYWORDS,
    SUPPORTED_COMMANDS,
    UNSUPPORTED_COMMANDS,
    UNSUPPORTED_ELEMENTS,
    missing_include_hint,
    ngspice_param_token,
    node_name,
    param_assignments,
    strip_comment,
    tran_bare_name,
)
from .element_lines import ElementLines
from .errors import Diagnostic, Location, NetlistError, ordered_diagnostics
from .expressions import ExpressionError, Token, Tree, lark_parser, parse_expression
from .funcs import Func, FuncReading
from .netlist_bytes import decode as _decode
from .netlist_bytes import read_bytes as _read_bytes
from .rawdeck import (
    Body,
    Deck,
    RawIc,
    RawModel,
    RawParam,
    RawTran,
    Statement,
    SubcktDef,
    Value,
)
from .steps import read_step
from .units import parse_number
from .value_scaling import read_resistor_model

_NAME = re.compile(r"[A-Za-z_]\w*")
# .model NAME TYPE of an XSPICE code model (netlist.xspice)
_CODE_MODEL = re.compile(r"(?i)\.model\s+(\S+?)\s+([A-Za-z_]\w*)(?=\s|\(|$)")

# ------------------------------------------------------------------------------ reading


class _Block:
    """A ``.control ... .endc`` block: kept verbatim, listed as ignored."""

    __slots__ = ("text", "loc")

    def __init__(self, text: str, loc: Location):
        self.text = text
        self.loc = loc


def split_statements(lines: list[tuple[int, str]], file: str, diags: list[Diagnostic]
                     ) -> list[Statement | _Block]:
    """Numbered physical lines -> logical statements (title line already removed).

    Parameters
    ----------
    lines : list of (int, str)
        1-based line number and text, in order (a library section gives a subset).
    file : str
        File name for locations.
    diags : list of Diagnostic
        Problems are appended here (a stray ``+`` line, an unterminated ``.control``).
    """
    out: list[Statement | _Block] = []
    cur: Statement | None = None
    control: list[str] | None = None
    control_loc: Location | None = None
    for lineno, raw in lines:
        if control is not None:
            control.append(raw.rstrip())
            if raw.strip().lower().startswith(".endc"):
                out.append(_Block("\n".join(control), control_loc))
                control = None
            continue
        code = strip_comment(raw) if (";" in raw or "$" in raw) else raw
        if "\u00b5" in code:
            # ngspice reads every µ as 'u' (inpcom.c's utf8_check; LTspice writes 1000µF)
            code = code.replace("\u00b5", "u")
        stripped = code.strip()
        if not stripped or stripped[0] == "*":
            continue
        col0 = len(code) - len(code.lstrip())
        if stripped[0] == "+":
            if cur is None:
                diags.append(Diagnostic(
                    "continuation line '+' with no statement before it",
                    Location(file, lineno, col0 + 1, raw),
                    "a line starting with '+' continues the previous statement"))
                continue
            rest = code[col0 + 1:].rstrip()
            start = len(cur.text) + 1
            cur.text = f"{cur.text} {rest}"
            cur.segments.append((start, lineno, col0 + 1, raw))
            continue
        if stripped == ")" and cur is not None and cur.text.count("(") > cur.text.count(")"):
            # a bare ')' line closes a multi-line .model, as ngspice reads it
            start = len(cur.text) + 1
            cur.text = f"{cur.text} )"
            cur.segments.append((start, lineno, col0, raw))
            continue
        first = stripped.split(None, 1)[0].lower()
        if first == ".control":
            control = [raw.rstrip()]
            control_loc = Location(file, lineno, col0 + 1, raw)
            cur = None
            continue
        if first == ".end":
            # ngspice turns the line into a comment and reads on (inpcom.c), so what follows
            # it is still the netlist: elements and analyses as well as .control blocks
            continue
        cur = Statement(stripped.rstrip(), file, [(0, lineno, col0, raw)])
        out.append(cur)
    if control is not None:
        diags.append(Diagnostic(".control block without .endc", control_loc,
                                "close the block with a .endc line"))
    return out


# ------------------------------------------------------------------------------ the reader


class _Reader(ElementLines, FuncReading):
    """Reads a netlist and its includes into a :class:`Deck`, collecting diagnostics."""

    def __init__(self, file: str):
        self.deck = Deck(file=file)
        self.diags: list[Diagnostic] = []
        self.stack: list[Path] = []  # resolved paths being read, for include cycles
        self.sub: SubcktDef | None = None
        self.lark = lark_parser()
        # problems inside a subcircuit definition (lower-case name) and unsupported models
        # (lower-case name): errors only if the circuit uses them, since ngspice skips
        # definitions nothing instantiates
        self.deferred: dict[str, list[Diagnostic]] = {}
        self.deferred_models: dict[str, Diagnostic] = {}
        # the included files as read (display path, bytes): what netlist.deck_cache checks
        self.included: list[tuple[str, bytes]] = []
        # .func definitions (netlist.funcs), by lower-case name, and their statements
        self.funcs: dict[str, Func] = {}
        self.func_defs: dict[str, Statement] = {}

    # -- diagnostics

    def error(self, message: str, st: Statement | None, offset: int = 0, hint: str = "",
              loc: Location | None = None) -> None:
        if loc is None and st is not None:
            loc = st.loc(offset)
        self.diags.append(Diagnostic(message, loc, hint))

    def raise_problems(self, overrides: dict[str, float] | None,
                       independent: Callable | None = None) -> None:
        """Raise the syntax problems, with the problems of the rest that they cannot cause.

        Parameters
        ----------
        overrides : dict, optional
            Parameter overrides, for evaluating the statements that could be read; ``None``
            to report the syntax problems alone.
        independent : callable, optional
            ``independent(deck, overrides) -> list of Diagnostic``: the problems of the
            statements that could be read (:func:`netlist.flatten.independent_problems`,
            passed in by :mod:`netlist.parser` so that reading does not import elaboration).
        """
        if not self.diags:
            return
        diags = list(self.diags)
        if overrides is not None and independent is not None:
            diags += independent(self.deck, overrides)
        raise NetlistError(ordered_diagnostics(diags, self.deck.files), self.deck.file)

    # -- files

    def read_top(self, text: str, file: str, base: Path | None) -> None:
        if text.startswith("\ufeff"):
            text = text[1:]
        lines = text.split("\n")
        if not text.strip():
            self.diags.append(Diagnostic("empty netlist", Location(file, 1, 1, ""),
                                         "a netlist starts with a title line, then elements"))
            return
        self.deck.title = lines[0].strip().rstrip("\r")
        numbered = [(i + 1, s.rstrip("\r")) for i, s in enumerate(lines[1:], start=1)]
        self.deck.files.append(file)
        if base is not None:
            self.stack.append(base)
        self.run(split_statements(numbered, file, self.diags))
        if self.sub is not None:
            self.error(f"subcircuit '{self.sub.name}' has no .ends", self.sub.st, 0,
                       "close the definition with .ends")
            self.sub = None
        self.settle_unused()
        self.settle_trans(file)
        apply_control(self.deck, file, self.error)

    def settle_unused(self) -> None:
        """Report the deferred problems of what the circuit uses; note what it does not."""
        used: set[str] = set()
        refs: set[str] = set()
        bodies: list[tuple[Body, str | None]] = [(self.deck.top, None)]
        while bodies:
            body, scope = bodies.pop()
            for el in body.elements:
                key = (el.ref or "").lower()
                sub_key = self.deck.subckt_key(key, scope) if el.kind == "X" else None
                if sub_key is not None:
                    if sub_key not in used:
                        used.add(sub_key)
                        bodies.append((self.deck.subckts[sub_key].body, sub_key))
                elif key:
                    refs.add(key)
        for key, diags in self.deferred.items():
            if key in used:
                self.diags.extend(diags)
                continue
            sub = self.deck.subckts.get(key)
            where = f"{sub.st.file}:{sub.st.loc(0).line}" if sub is not None else ""
            self.deck.notes.append(
                f"subcircuit '{sub.name if sub else key}' ({where}) is not used: skipped, as "
                f"ngspice skips it (it holds what pelcs does not read: {diags[0].message})")
        for key, diag in self.deferred_models.items():
            if key in refs:
                self.diags.append(diag)
            else:
                loc = diag.location
                at = f"{loc.file}:{loc.line}" if loc is not None else ""
                self.deck.notes.append(f"model '{key}' ({at}) is not used: skipped, as "
                                       f"ngspice skips it ({diag.message})")

    def settle_trans(self, file: str) -> None:
        """A wrapper file with its own .tran around an included netlist that has one too:
        the top-level file's .tran is run (as the user wrote it last), the others noted."""
        trans = self.deck.trans
        if not trans:
            self.control_tran(file)
            return
        top = [t for t in trans if t.st.file == file]
        if len(trans) < 2 or len(top) != 1:
            return
        kept = top[0]
        for t in trans:
            if t is not kept:
                self.deck.notes.append(
                    f"{t.st.file}:{t.st.loc(0).line}: .tran ignored: the top-level file's "
                    f".tran (line {kept.st.loc(0).line}) is run")
        self.deck.trans = [kept]

    def include(self, path_text: str, st: Statement, offset: int, section: str | None) -> None:
        including = st.file
        base_dir = os.path.dirname(including) if not including.startswith("<") else ""
        display = os.path.normpath(os.path.join(base_dir, path_text))
        path = Path(display)
        at = st.loc(offset)
        try:
            resolved = path.resolve()
        except (OSError, RuntimeError):
            resolved = path
        if resolved in self.stack:
            chain = " -> ".join([p.name for p in self.stack] + [path.name])
            self.error(f"include cycle: {chain}", st, offset,
                       "a file must not include itself, directly or through other files")
            return
        if not os.path.lexists(path):
            self.diags.append(Diagnostic(f"file not found: '{display}'", at,
                                         missing_include_hint(st.file, self.deck.files)))
            return
        try:
            data = _read_bytes(path, display, at)
            text = _decode(data, display, title=False)
        except NetlistError as exc:
            self.diags.extend(exc.diagnostics)
            return
        self.included.append((display, data))
        numbered = [(i + 1, s.rstrip("\r")) for i, s in enumerate(text.split("\n"))]
        if section is not None:
            numbered = self._section(numbered, section, display, st, offset)
            if numbered is None:
                return
        self.deck.files.append(display)
        self.stack.append(resolved)
        try:
            self.run(split_statements(numbered, display, self.diags))
        finally:
            self.stack.pop()

    def _section(self, numbered: list[tuple[int, str]], section: str, display: str,
                 st: Statement, offset: int) -> list[tuple[int, str]] | None:
        """The lines between ``.lib SECTION`` and ``.endl`` of a library file."""
        inside = False
        out: list[tuple[int, str]] = []
        found = False
        for lineno, raw in numbered:
            words = raw.split()
            head = words[0].lower() if words else ""
            if not inside:
                if head == ".lib" and len(words) == 2 and words[1].lower() == section.lower():
                    inside = found = True
                continue
            if head == ".endl":
                inside = False
                break
            out.append((lineno, raw))
        if not found:
            self.error(f"library section '{section}' not found in '{display}'", st, offset,
                       "the library file must contain '.lib SECTION' ... '.endl'")
            return None
        return out

    # -- statements

    def run(self, statements: list[Statement | _Block]) -> None:
        # .func definitions first: a call may come before them, as in ngspice
        for st in statements:
            if isinstance(st, Statement) and st.text[:5].lower() == ".func":
                self.define_func(st)
        for st in statements:
            if isinstance(st, _Block):
                self.deck.ignored.append(IgnoredCommand(st.text, st.loc))
                continue
            try:
                self.statement(st)
            except _Abandon:
                pass

    def parse(self, st: Statement, rule: str, what: str, usage: str) -> Tree:
        try:
            return self.lark.parse(st.text, start=rule)
        except expressions.UnexpectedInput as exc:
            self._syntax(st, exc, what, usage)
            raise _Abandon from None

    def _syntax(self, st: Statement, exc: expressions.UnexpectedInput, what: str,
                usage: str) -> None:
        hint = f"syntax: {usage}"
        name = _WORD.match(st.text)
        label = f"{what} '{name.group()}'" if name and what[0] != "." else what
        if isinstance(exc, expressions.UnexpectedEOF) or (
            isinstance(exc, expressions.UnexpectedToken) and exc.token.type == "$END"
        ):
            expected = getattr(exc, "expected", set()) or set()
            words = list(_WORD.finditer(st.text))
            if expected == {"EQUAL"} and words and words[-1].end() == len(st.text):
                # a word too many at the end: the parser took it for the start of NAME=VALUE
                prev = words[-1]
                self.error(f"unexpected '{prev.group()}' in {label}: expected NAME=VALUE or "
                           "the end of the line", st, prev.start(), hint)
                return
            self.error(f"incomplete {label}: {_expected(expected)} missing", st,
                       len(st.text), hint)
        elif isinstance(exc, expressions.UnexpectedToken):
            tok = exc.token
            if exc.expected == {"EQUAL"} and exc.token_history:
                prev = exc.token_history[-1]
                self.error(f"unexpected '{prev}' in {label}: expected NAME=VALUE", st,
                           prev.start_pos, hint)
                return
            self.error(f"unexpected '{tok}' in {label}", st, tok.start_pos, hint)
        elif isinstance(exc, expressions.UnexpectedCharacters):
            ch = st.text[exc.pos_in_stream]
            what_ch = "quote" if ch in "'\"" else "character"
            self.error(f"unexpected {what_ch} {ch!r} in {label}", st, exc.pos_in_stream,
                       hint + ("; quotes and braces must be closed on the same statement"
                               if ch in "'\"{" else ""))
        else:  # pragma: no cover - lark raises only the three above
            self.error(f"cannot parse {label}", st, 0, hint)

    def control_tran(self, file: str) -> None:
        """No .tran line: the first ``tran`` command of the top-level file's ``.control``
        block, which is what ngspice runs."""
        for block in self.deck.ignored:
            loc = block.location
            if loc is None or loc.file != file or not block.text.lower().startswith(".control"):
                continue
            for i, raw in enumerate(block.text.split("\n")):
                m = re.match(r"(?i)\s*(tran)\s", raw)
                if m is None:
                    continue
                code = strip_comment(raw).rstrip()
                # read as `.tran ...`: offset 1 of the statement is the `t` of the line
                st = Statement("." + code[m.start(1):], file,
                               [(0, loc.line + i, m.start(1) - 1, raw)])
                n = len(self.deck.trans)
                try:
                    self.cmd_tran(st)
                except _Abandon:
                    return
                if len(self.deck.trans) > n:
                    self.deck.notes.append(f"line {loc.line + i}: the .control block's `tran` "
                                           "command read as the .tran line (ngspice runs it)")
                return

    def statement(self, st: Statement) -> None:
        sub = self.sub
        head = st.text.split(None, 1)[0].lower() if st.text.strip() else ""
        if sub is None or head in (".subckt", ".ends"):
            self.read_statement(st)
            return
        n = len(self.diags)
        try:
            self.read_statement(st)
        finally:
            if len(self.diags) > n:
                self.deferred.setdefault(sub.key, []).extend(self.diags[n:])
                del self.diags[n:]

    def read_statement(self, st: Statement) -> None:
        m = _WORD.match(st.text)
        if m is None:
            self.error(f"unexpected {st.text[0]!r} at the start of a statement", st, 0,
                       "a statement starts with an element name (R1, L1, ...) or a dot "
                       "command (.param, .tran, ...)")
            return
        word = m.group()
        if word[0] == ".":
            self.command(word.lower(), st)
            return
        letter = word[0].upper()
        if letter == "A":
            self.xspice_element(st)
            return
        if letter == "W":
            self.current_switch(st)
            return
        if letter in ELEMENTS:
            self.element(letter, st)
            return
        if letter in UNSUPPORTED_ELEMENTS:
            what, hint = UNSUPPORTED_ELEMENTS[letter]
            self.error(f"unknown element type '{letter}' ({what})", st, 0, hint)
            return
        self.error(f"unknown element type '{word[0]}' in '{word}'", st, 0,
                   "pelcs knows the elements R L C V I D S W E F G H K X B M Q A and dot commands")

    # -- values

    def value(self, tok: Token, st: Statement, bare_expression: bool = False) -> Value | None:
        """A WORD or EXPR token -> Value; ``None`` (and a diagnostic) if it is not valid."""
        if tok.type == "EXPR":
            return self.expression(tok[1:-1], st, tok.start_pos + 1)
        num = parse_number(tok)
        if num is not None and not math.isfinite(num):
            self.error(f"number '{tok}' is too large: it is not a finite double", st,
                       tok.start_pos, "write a value below 1.8e308; "
                       "SPICE numbers are double precision")
            return None
        if num is not None:
            return Value(num, None, st, tok.start_pos)
        if bare_expression or _NAME.fullmatch(tok):  # (ngspice puts a parameter's value
            return self.expression(str(tok), st, tok.start_pos)  # for its bare name too)
        hint = ("a value is a number with an optional suffix (f p n u m k meg g t mil) and "
                "unit, or an expression in braces")
        if re.search(r"[-+*/^]", tok[1:]):
            hint = f"write expressions in braces: {{{tok}}}"
        if tok[:2].lower() == "0x":  # (ngspice 39: 0x10 outside braces is 0 V)
            hint = f"ngspice reads '{tok}' here as 0, hexadecimal only in braces: {{{tok}}}"
        self.error(f"invalid number '{tok}'", st, tok.start_pos, hint)
        return None

    def expression(self, text: str, st: Statement, offset: int) -> Value | None:
        expanded = self.expand_funcs(text, st, offset)
        if expanded is None:
            return None
        try:
            expr = parse_expression(expanded)
        except ExpressionError as exc:
            if expanded != text:  # (an offset in the expansion is not one in the text)
                self.error(f"{exc.message} (with its .func calls expanded)", st, offset,
                           exc.hint)
            else:
                self.error(exc.message, st, offset + exc.offset, exc.hint)
            return None
        if expr.constant:
            try:
                return Value(expr.evaluate({}), None, st, offset)
            except ExpressionError as exc:
                self.error(exc.message, st, offset + exc.offset, exc.hint)
                return None
        return Value(None, expr, st, offset)

    def assigns(self, items: list, st: Statement, bare_expression: bool = False
                ) -> list[RawParam]:
        out = []
        for t in items:
            name_tok, val_tok = t.children
            v = self.value(val_tok, st, bare_expression)
            if v is not None:
                out.append(RawParam(name_tok.lower(), v, st, name_tok.start_pos))
        return out

    @property
    def body(self) -> Body:
        return self.sub.body if self.sub is not None else self.deck.top

    # -- dot commands

    def command(self, cmd: str, st: Statement) -> None:
        handler = _COMMANDS.get(cmd)
        if handler is not None:
            handler(self, st)
            return
        if cmd in IGNORED_COMMANDS:
            self.deck.ignored.append(IgnoredCommand(" ".join(st.text.split()), st.loc(0)))
            return
        if cmd in UNSUPPORTED_COMMANDS:
            self.error(f"{cmd} is not supported", st, 0, UNSUPPORTED_COMMANDS[cmd])
            return
        self.error(f"unknown dot command '{st.text.split()[0]}'", st, 0,
                   f"supported: {SUPPORTED_COMMANDS}; accepted and ignored: "
                   + " ".join(sorted(IGNORED_COMMANDS)))

    def cmd_param(self, st: Statement) -> None:
        start = len(st.text.split(None, 1)[0])
        items = param_assignments(st.text, start)
        if items is not None:  # (unbraced expressions too, as ngspice reads them)
            for name, at, text, off in items:
                braced = text[:1] + text[-1:] in ("{}", "''")
                # (a number first takes the whole line at the top level only: in a
                # subcircuit, or beside a braced value, ngspice 39 cuts it too, measured)
                token = ngspice_param_token(text, len(items) == 1 and self.sub is None)
                if not braced and token != text:
                    self.error(f"ngspice reads '{token}' as the value of '{name}', not "
                               f"'{text}'", st, off + len(token),
                               "an unbraced value that starts with a name or '(', is one of "
                               "several or is in a subcircuit ends at a space outside (): "
                               f"write {name}={{{text}}}")
                    continue
                v = self.expression(text[1:-1], st, off + 1) if braced else \
                    self.value(Token("WORD", text, start_pos=off), st, True)
                if v is not None:
                    self.body.params.append(RawParam(name.lower(), v, st, at))
            return
        tree = self.parse(st, "param_cmd", ".param", ".param name=value [name=value ...]")
        items = tree.children[1:]
        if not items:
            self.error(".param defines no parameter", st, len(st.text),
                       "syntax: .param name=value [name=value ...]")
            return
        self.body.params.extend(self.assigns(items, st, bare_expression=True))

    def cmd_subckt(self, st: Statement) -> None:
        usage = ".subckt name node... [params: name=value ...]"
        tree = self.parse(st, "subckt_cmd", ".subckt", usage)
        name_tok = tree.children[1]
        ports: list[str] = []
        defaults: list[RawParam] = []
        for item in tree.children[2:]:
            if item.data == "x_word":
                if defaults:
                    tok = item.children[0]
                    self.error(f"unexpected '{tok}' after the parameters of .subckt "
                               f"'{name_tok}'", st, tok.start_pos, f"syntax: {usage}")
                else:
                    ports.append(node_name(item.children[0]))
            elif item.data == "assign":
                defaults.extend(self.assigns([item], st, bare_expression=True))
        # (a definition inside another is local to it, as in ngspice: Deck.subckt_key)
        parent = self.sub.key if self.sub is not None else None
        key = name_tok.lower() if parent is None else f"{parent}:{name_tok.lower()}"
        sub = SubcktDef(str(name_tok), ports, defaults, Body(), st, key, parent)
        if key in self.deck.subckts:
            prev = self.deck.subckts[key].st.loc(0)
            self.error(f"subcircuit '{name_tok}' is defined twice (first at line {prev.line})",
                       st, name_tok.start_pos, "rename one of the definitions")
        else:
            self.deck.subckts[key] = sub
        self.sub = sub

    def cmd_ends(self, st: Statement) -> None:
        tree = self.parse(st, "ends_cmd", ".ends", ".ends [name]")
        if self.sub is None:
            self.error(".ends without .subckt", st, 0, "remove it or add the .subckt line")
            return
        if len(tree.children) > 1:
            tok = tree.children[1]
            if tok.lower() != self.sub.name.lower():  # (ngspice 39 ignores it, measured)
                self.deck.notes.append(f"line {st.loc(0).line}: .ends {tok} closes subcircuit "
                                       f"'{self.sub.name}' (ngspice ignores the name after .ends)")
        parent = self.sub.parent
        self.sub = self.deck.subckts.get(parent) if parent is not None else None

    def cmd_model(self, st: Statement) -> None:
        m = _CODE_MODEL.match(st.text)
        if m is not None and m.group(2).lower() in xspice.CODE_MODELS:
            try:
                self.deck.code_models[m.group(1).lower()] = xspice.read_model(
                    st, m.group(1), m.group(2), m.end())
            except xspice.XspiceError as exc:
                self.error(exc.message, st, exc.offset, exc.hint)
            return
        tree = self.parse(st, "model_cmd", ".model",
                          ".model name D(...), SW(...), NMOS/PMOS/VDMOS(...) or NPN/PNP(...)")
        name_tok, type_tok = tree.children[1], tree.children[2]
        mtype = type_tok.upper()
        if mtype not in _MODEL_TYPES:
            what = _UNSUPPORTED_MODELS.get(mtype)
            hint = "pelcs knows diode models (D) and voltage-controlled switch models (SW)"
            if what in ("MOSFET", "BJT", "JFET", "MESFET"):
                hint = (f"a {what} used as a switch is an S element driven by its gate/base "
                        "voltage with a .model NAME SW(VT=... VH=...)")
            elif what == "current switch":
                hint = "use an S switch with a SW model, controlled by a voltage"
            label = f" ({what})" if what else ""
            if mtype == "R":
                read_resistor_model(self, st, name_tok, tree)  # (netlist.value_scaling)
                return
            self.deferred_models[name_tok.lower()] = Diagnostic(
                f"model type '{type_tok}'{label} is not supported", st.loc(type_tok.start_pos),
                hint)
            return
        items = tree.children[3].children if len(tree.children) > 3 else []
        flags = [t for t in items if t.data == "flag"]
        items = [t for t in items if t.data != "flag"]
        for t in flags:
            tok = t.children[0]
            if mtype != "VDMOS":
                self.error(f"'{tok}' is a VDMOS flag, not a parameter of a {mtype} model", st,
                           tok.start_pos, "remove it")
                return
        if mtype in ("D", "SW", "CSW"):
            params = self.assigns(items, st)
        else:
            # A vendor's transistor model: only its threshold matters to pelcs, and such
            # files carry text values (mfg=..., type=...): those are skipped, not errors.
            params = []
            for t in items:
                name_t, val_t = t.children
                if val_t.type == "EXPR" or parse_number(val_t) is not None:
                    v = self.value(val_t, st)
                    if v is not None:
                        params.append(RawParam(name_t.lower(), v, st, name_t.start_pos))
            for t in flags:
                tok = t.children[0]
                params.append(RawParam(tok.lower(), Value(1.0, None, st, tok.start_pos), st,
                                       tok.start_pos))
        scope = self.sub.key if self.sub is not None else None
        self.deck.models.append(RawModel(str(name_tok), _MODEL_TYPES[mtype], params, st, scope))

    def cmd_ic(self, st: Statement) -> None:
        tree = self.parse(st, "ic_cmd", ".ic", ".ic v(node)=value [v(node)=value ...]")
        for item in tree.children[1:]:
            v_tok, node_tok, val_tok = item.children
            if v_tok.lower() != "v":
                self.error(f".ic sets node voltages: expected v(node), got {v_tok}(...)", st,
                           v_tok.start_pos, "inductor currents are set with IC= on the L line")
                continue
            v = self.value(val_tok, st)
            if v is not None:
                self.body.ics.append(RawIc(node_name(node_tok), v, st, node_tok.start_pos))

    def cmd_tran(self, st: Statement) -> None:
        tree = self.parse(st, "tran_cmd", ".tran", ".tran TSTEP TSTOP [TSTART [TMAX]] [UIC]")
        if self.sub is not None:
            self.error(".tran inside a subcircuit", st, 0, "move it to the top level")
            return
        ch = [t for t in tree.children[1:] if isinstance(t, Token)]
        flags = {t.children[0].type: t.children[0] for t in tree.children[1:]
                 if isinstance(t, Tree)}
        line = st.loc(0).line
        for kind, what in _TRAN_MODIFIERS.items():
            if kind in flags:
                self.deck.notes.append(f"line {line}: .tran {flags[kind]} (LTspice) ignored: "
                                       f"{what}")
        if (bare := tran_bare_name([str(t) for t in ch])) is not None:
            self.error(bare[1], st, ch[bare[0]].start_pos, bare[2])
            return
        values = [self.value(t, st) for t in ch]
        if any(v is None for v in values):
            return
        if len(values) == 1:  # LTspice's .tran TSTOP: its .tran 0 TSTOP
            self.deck.notes.append(f"line {line}: .tran TSTOP (LTspice; ngspice needs .tran "
                                   "TSTEP TSTOP) read as .tran 0 TSTOP")
            values.insert(0, Value(0.0, None, st, ch[0].start_pos))
        self.deck.trans.append(RawTran(values, "UIC" in flags, st))

    def cmd_step(self, st: Statement) -> None:
        read_step(self, st)

    def cmd_options(self, st: Statement) -> None:
        tree = self.parse(st, "options_cmd", ".options", ".options name[=value] ...")
        for item in tree.children[1:]:
            key = item.children[0].lower()
            self.deck.options[key] = str(item.children[1]) if len(item.children) > 1 else ""

    def cmd_include(self, st: Statement) -> None:
        tree = self.parse(st, "include_cmd", ".include", ".include FILE")
        tok = tree.children[1]
        self.include(_unquote(tok), st, tok.start_pos, None)

    def cmd_lib(self, st: Statement) -> None:
        tree = self.parse(st, "lib_cmd", ".lib", ".lib FILE SECTION")
        tok = tree.children[1]
        if len(tree.children) < 3:
            path = _unquote(tok)
            base = path.replace("\\", "/").rsplit("/", 1)[-1].lower()
            if base.startswith("standard."):
                # LTspice's own device libraries (standard.dio, .mos, .bjt ...): the models
                # a schematic uses are in the netlist or its includes, not needed here
                self.deck.notes.append(f"line {st.loc(0).line}: .lib {path} (LTspice's "
                                       "standard library) ignored")
                return
            self.include(path, st, tok.start_pos, None)  # LTspice: .lib FILE = .include
            return
        self.include(_unquote(tok), st, tok.start_pos, str(tree.children[2]))

    def cmd_global(self, st: Statement) -> None:
        tree = self.parse(st, "global_cmd", ".global", ".global node ...")
        self.deck.globals.update(node_name(t) for t in tree.children[1:])

    def cmd_title(self, st: Statement) -> None:
        parts = st.text.split(None, 1)
        self.deck.title = parts[1].strip() if len(parts) > 1 else ""


def _unquote(tok: Token) -> str:
    s = str(tok)
    if len(s) >= 2 and s[0] in "\"'{" and s[-1] in "\"'}":
        return s[1:-1].strip()
    return s


def _expected(expected: set[str]) -> str:
    if set(expected) - {"$END"} == {"WORD", *NAME_KEYWORDS}:
        expected = {"WORD"}  # (a name: that it may spell a keyword says nothing)
    names = sorted({_TOKEN_NAMES.get(e, e.lower()) for e in expected if e != "$END"})
    if len(names) <= 1:
        return names[0] if names else "a field"
    return ", ".join(names[:-1]) + " or " + names[-1]


# LTspice's .tran modifiers pelcs accepts, and why they change nothing or what they change
_TRAN_MODIFIERS = {
    "STARTUP": "pelcs starts from the initial conditions (0 where none is given) with every "
               "source at its value from t = 0, without LTspice's 20 us ramp",
    "STEADY": "pelcs runs to TSTOP",
    "NODISCARD": "pelcs returns the points from TSTART on, as ngspice",
}


class _Abandon(Exception):
    """A statement was reported as wrong; go on with the next one."""


_COMMANDS = {
    ".param": _Reader.cmd_param,
    ".subckt": _Reader.cmd_subckt,
    ".ends": _Reader.cmd_ends,
    ".model": _Reader.cmd_model,
    ".ic": _Reader.cmd_ic,
    ".tran": _Reader.cmd_tran,
    ".step": _Reader.cmd_step,
    ".options": _Reader.cmd_options,
    ".option": _Reader.cmd_options,
    ".opt": _Reader.cmd_options,
    ".include": _Reader.cmd_include,
    ".inc": _Reader.cmd_include,
    ".lib": _Reader.cmd_lib,
    ".global": _Reader.cmd_global,
    ".title": _Reader.cmd_title,
    # (read before the rest of its file: _Reader.define_func)
    ".func": lambda reader, st: None,
}


def read_deck(text: str, file: str = "<string>", path: Path | None = None) -> Deck:
    """Read netlist text (and its includes) into a :class:`Deck`, without evaluating it.

    Raises
    ------
    NetlistError
        With every syntax problem found.
    """
    reader = _Reader(file)
    reader.read_top(text, file, path.resolve() if path is not None else None)
    reader.raise_problems(None)
    return reader.deck
