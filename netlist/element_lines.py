"""Element lines of the reader (:mod:`netlist.reader`): R L C, V I sources with their
transient functions, D, S, E F G H, K, X instances, and M Q devices (idealised later,
:mod:`netlist.devices`), each into a :class:`~netlist.rawdeck.RawElement` with its location.
A mixin of the reader: it uses the reader's ``parse``, ``value``, ``assigns``, ``error``,
``body`` and ``deck``."""

from __future__ import annotations

import re

from . import current_switch, xspice
from .behavioural_expr import BehaviouralError, circuit_quantity, parse_behavioural
from .dialect import (
    _NONLINEAR,
    _PASSIVE_IGNORED,
    _TEMPERATURE_PARAMS,
    ELEMENTS,
    UNSUPPORTED_WAVES,
    WAVE_ALIASES,
    WAVE_ARGS,
    first_token,
    hierarchical_name,
    node_name,
)
from .expressions import Token
from .ltspice import PARASITICS as _PARASITICS
from .ltspice import explicit_parasitics
from .rawdeck import (
    RawElement,
    RawParam,
    Statement,
    Value,
)
from .switched_resistor import is_switched_value
from .table_source import TableError, read_table
from .time_value import ACCEPTED as TIME_ACCEPTED
from .time_value import other_quantity, reads_time_only, time_in_comparisons
from .units import parse_number

# ------------------------------------------------------------------------------ reading

# Bname n+ n- V=expr | I=expr
_VALUE_LINE = re.compile(r"(?is)(\S+)\s+([^\s=]+)\s+([^\s=]+)\s+([RLC])\s*=\s*(\S.*?)\s*$")
_B_LINE = re.compile(r"(?is)(\S+)\s+([^\s=]+)\s+([^\s=]+)\s+([VI])\s*=\s*(\S.*?)\s*$")
# Ename n+ n- VALUE={expr} (vol=), Gname n+ n- VALUE={expr} (cur=): ngspice's front end makes
# them an E (G) of gain 1 driven by a B source V={expr} (inpcom.c), i.e. a B source V= (I=)
# between n+ and n-; it reads the expression from its '{' to the end of the line
# Rname n+ n- r=value (C c=, L l=): the value named by its keyword
_KEYWORD_VALUE = re.compile(r"(?is)\S+\s+[^\s=]+\s+[^\s=]+\s+(([RLC])\s*=\s*)")
# Ename n+ n- (nc+, nc-) gain (G alike): the control pair in parentheses
_PAREN_CONTROL = re.compile(r"(?s)\S+\s+[^\s(),]+\s+[^\s(),]+\s+(\(\s*[^\s(),]+\s*[,\s]\s*"
                            r"[^\s(),]+\s*\))")
_PAREN_BLANKS = str.maketrans("(),", "   ")
# Ename n+ n- POLY(ND) ... (G alike; F, H with controlling sources): SPICE2's polynomial source
_POLY = re.compile(r"(?is)(\S+)\s+([^\s=]+)\s+([^\s=]+)\s+(poly)\s*\(\s*(\d+)\s*\)(.*)$")
# Rname n+ n- {expr} (or 'expr'): a value written without its keyword
_POSITIONAL_VALUE = re.compile(r"""(?is)(\S+)\s+([^\s=]+)\s+([^\s=]+)\s+"""
                               r"""(\{.*\}|'[^']*'|"[^"]*")\s*$""")
_EG_VALUE = re.compile(r"(?is)(\S+)\s+([^\s=]+)\s+([^\s=]+)\s+(value|vol|cur)\b\s*=?\s*"
                       r"(\{.*\})\s*$")


def ngspice_value_token(text: str) -> str:
    """The part of an unquoted, unbraced ``R``/``L``/``C`` value (``c = ...``) that ngspice
    takes for the value: up to the first blank outside parentheses. Its front end puts braces
    around that token alone (inpcom.c, ``inp_fix_param_values``), and the transformation of a
    value that reads the circuit takes the first braced expression of the line as the
    equation (``inp_compat``); the rest of the line is dropped. So
    ``c = (v(a) < {5}) ? {1u} : {2u}`` is the capacitance ``(v(a) < 5)``, 1 F or 0 F
    (measured in ngspice 39: an RC of 1 Ohm at 2e-6 of its 1 V after 2 us), while
    ``c = (v(a)<{5})?{1u}:{2u}``, one token, is the conditional (0.865 V, 1 uF). A value
    starting with a digit, a sign, a point or a quote is not cut."""
    if not text or text[0] in "0123456789.+-'\"{":
        return text
    return first_token(text)


class ElementLines:
    """The element-line handlers of :class:`netlist.reader._Reader`."""

    def element(self, letter: str, st: Statement) -> None:
        rule, what, usage = ELEMENTS[letter]
        if letter == "B":
            self.behavioural(st, usage)
            return
        if letter in "RLC" and self.nonlinear_value(letter, st, what):
            return
        if letter in "RLC":
            m = _KEYWORD_VALUE.match(st.text)
            if m is not None and m.group(2).upper() == letter:
                # ngspice's `R1 a b r=1k` (C c=, L l=): the value after its keyword, read
                # with the keyword blanked out (the columns kept for the messages)
                st = Statement(st.text[:m.start(2)] + " " * (m.end(0) - m.start(2)) +
                               st.text[m.end(0):], st.file, st.segments)
        if letter in "EG" and self.value_source(letter, st):
            return
        if letter in "EFGH" and self.poly_source(letter, st):
            return
        if letter in "EG" and self.table_source(letter, st):
            return
        if letter in "EG":
            m = _PAREN_CONTROL.match(st.text)
            if m is not None:
                # ngspice reads `E1 n+ n- (nc+, nc-) gain` as its control pair: the
                # parentheses and the comma blanked out (the columns kept for the messages)
                blank = st.text[m.start(1):m.end(1)].translate(_PAREN_BLANKS)
                st = Statement(st.text[:m.start(1)] + blank + st.text[m.end(1):], st.file,
                               st.segments)
        if letter in "EFGH":
            m = _NONLINEAR.search(st.text)
            if m:
                self.error(f"nonlinear or behavioural {letter} source ('{m.group(1)}') is not "
                           "supported", st, m.start(1),
                           f"pelcs needs linear controlled sources: {usage}")
                return
        tree = self.parse(st, rule, what, usage)
        ch = tree.children
        name = hierarchical_name(str(ch[0]), letter)
        if rule == "passive":
            self.passive(letter, name, ch, st, what)
        elif rule == "source":
            self.source(letter, name, ch, st)
        elif rule == "diode":
            self.body.elements.append(RawElement(
                "D", name, st, (node_name(ch[1]), node_name(ch[2])), ref=str(ch[3]),
                ref_offset=ch[3].start_pos, params=self.diode_area(ch[4:], st)))
        elif rule == "switch":
            state = None
            if len(ch) > 6:
                state = ch[6].children[0].type == "ON"
            self.body.elements.append(RawElement(
                "S", name, st, (node_name(ch[1]), node_name(ch[2])),
                control=(node_name(ch[3]), node_name(ch[4])), ref=str(ch[5]),
                ref_offset=ch[5].start_pos, state=state))
        elif rule == "device":
            self.device(letter, name, ch, st, usage)
        elif rule == "vcontrolled":
            v = self.value(ch[5], st)
            if v is not None:
                self.body.elements.append(RawElement(
                    letter, name, st, (node_name(ch[1]), node_name(ch[2])),
                    control=(node_name(ch[3]), node_name(ch[4])), value=v))
        elif rule == "ccontrolled":
            v = self.value(ch[4], st)
            if v is not None:
                self.body.elements.append(RawElement(
                    letter, name, st, (node_name(ch[1]), node_name(ch[2])),
                    ref=hierarchical_name(str(ch[3])), ref_offset=ch[3].start_pos, value=v))
        elif rule == "coupling":
            v = self.value(ch[3], st)
            if v is not None:
                self.body.elements.append(RawElement(
                    "K", name, st, (), value=v,
                    refs=((hierarchical_name(str(ch[1])), ch[1].start_pos),
                          (hierarchical_name(str(ch[2])), ch[2].start_pos))))
        else:
            self.instance(name, ch, st)

    def xspice_element(self, st: Statement) -> None:
        """``Aname port... model``: an XSPICE code model instance (:mod:`netlist.xspice`),
        elaborated with its model in its instance."""
        try:
            name, ports, model, offset = xspice.read_instance(st)
        except xspice.XspiceError as exc:
            self.error(exc.message, st, exc.offset, exc.hint)
            return
        self.body.elements.append(RawElement("A", name, st, (), ref=model, ref_offset=offset,
                                             ports=ports))

    def current_switch(self, st: Statement) -> None:
        """``Wname n+ n- Vcontrol model [ON|OFF]`` (netlist.current_switch)."""
        try:
            name, nodes, (vname, v_at), (model, m_at), state = current_switch.read_line(
                st.text)
        except current_switch.CswError as exc:
            self.error(exc.message, st, exc.offset, exc.hint)
            return
        self.body.elements.append(RawElement(
            "W", hierarchical_name(name, "W"), st, tuple(map(node_name, nodes)), ref=model,
            ref_offset=m_at, refs=((vname, v_at),), state=state))

    def behavioural(self, st: Statement, usage: str) -> None:
        """``Bname n+ n- V=expr`` or ``I=expr``: the expression parsed here (its own grammar,
        :mod:`netlist.behavioural`), evaluated in elaboration."""
        m = _B_LINE.match(st.text)
        if m is None:
            words = st.text.split()
            at = len(st.text)
            if len(words) >= 4:
                at = st.text.find(words[3], len(words[0]))
            self.error(f"behavioural source '{words[0]}' needs two nodes then V=expression or "
                       "I=expression", st, at, f"syntax: {usage}")
            return
        text, offset = m.group(5), m.start(5)
        if len(text) >= 2 and text[0] == text[-1] and text[0] in "'\"":
            text, offset = text[1:-1], offset + 1
        tree = self.behavioural_tree(text, st, offset, f"syntax: {usage}")
        if tree is None:
            return
        name = hierarchical_name(m.group(1), "B")
        self.body.elements.append(RawElement(
            "B", name, st, (node_name(m.group(2)), node_name(m.group(3))),
            behaviour=(m.group(4).upper(), tree, text, offset)))

    def behavioural_tree(self, text: str, st: Statement, offset: int, hint: str):
        """A B expression parsed (netlist.behavioural_expr) after its ``.func`` calls are
        expanded; None (and a diagnostic) if it cannot be."""
        expanded = self.expand_funcs(text, st, offset)
        if expanded is None:
            return None
        try:
            return parse_behavioural(expanded)
        except BehaviouralError as exc:
            if expanded != text:  # (an offset in the expansion is not one in the text)
                self.error(f"{exc.message} (with its .func calls expanded)", st, offset,
                           exc.hint or hint)
            else:
                self.error(exc.message, st, offset + exc.offset, exc.hint or hint)
            return None

    def value_source(self, letter: str, st: Statement) -> bool:
        """``Ename n+ n- VALUE={expr}`` (or ``vol=``) and ``Gname n+ n- VALUE={expr}`` (or
        ``cur=``) read as ngspice does, as a B source ``V={expr}`` (``I={expr}``) between the
        same nodes; False for any other E/G line."""
        m = _EG_VALUE.match(st.text)
        if m is None or (m.group(4).lower(), letter) in (("vol", "G"), ("cur", "E")):
            return False
        text, offset = m.group(5), m.start(5)
        tree = self.behavioural_tree(text, st, offset,
                                     f"syntax: {letter}name n+ n- VALUE={{expression}}")
        if tree is None:
            return True
        name = hierarchical_name(m.group(1), letter)
        self.body.elements.append(RawElement(
            "B", name, st, (node_name(m.group(2)), node_name(m.group(3))),
            behaviour=("V" if letter == "E" else "I", tree, text, offset)))
        return True

    def table_source(self, letter: str, st: Statement) -> bool:
        """``Ename n+ n- TABLE {expr} = (x1, y1) (x2, y2)`` (G alike) read as the B source
        :mod:`netlist.table_source` makes of it, with its note; False for any other line."""
        try:
            table = read_table(st.text, letter)
        except TableError as exc:
            self.error(exc.message, st, exc.offset, exc.hint)
            return True
        if table is None:
            return False
        tree = self.behavioural_tree(table.text, st, table.offset,
                                     f"syntax: {letter}name n+ n- TABLE {{expression}} = "
                                     "(x1, y1) (x2, y2)")
        if tree is None:
            return True
        self.body.elements.append(RawElement(
            "B", hierarchical_name(table.name, letter), st,
            (node_name(table.nodes[0]), node_name(table.nodes[1])),
            behaviour=("V" if letter == "E" else "I", tree, table.text, table.offset),
            note=table.note))
        return True

    def poly_source(self, letter: str, st: Statement) -> bool:
        """``Ename n+ n- POLY(ND) c1+ c1- ... p0 p1 ...`` (G alike; F and H name ND controlling
        sources) whose polynomial is affine: read as the B source ``V=`` (E, H) or ``I=``
        (G, F) ``p0 + p1*x1 + ... + pND*xND``. ngspice hands the coefficients as written to its
        spice2poly code model (enhtrans.c): the first is p0 (measured in ngspice 39:
        ``POLY(1) a 0 2`` is 2 V, not SPICE2's 2*v(a)), then one per input, then the
        higher-order terms, which must be zero here. False when the line is not a POLY."""
        m = _POLY.match(st.text)
        if m is None:
            return False
        nd, rest, at = int(m.group(5)), m.group(6), m.start(4)
        words = [(w.group(0), m.start(6) + w.start())
                 for w in re.finditer(r"[^\s(),]+", rest)]
        per = 2 if letter in "EG" else 1
        usage = (f"{letter}name n+ n- POLY(ND) " +
                 ("nc1+ nc1- ... " if per == 2 else "Vname1 ... ") + "p0 p1 ...")
        if nd < 1 or len(words) < per * nd + 1:
            self.error(f"POLY({nd}) needs {per * nd} "
                       f"{'controlling nodes' if per == 2 else 'controlling sources'} and at "
                       "least one coefficient", st, at, f"syntax: {usage}")
            return True
        ctl, coefs = words[:per * nd], words[per * nd:]
        for word, offset in coefs[1 + nd:]:
            if parse_number(word) != 0.0:
                self.error(f"{letter} source with a nonlinear POLY({nd}): coefficient "
                           f"'{word}' multiplies a product of its inputs", st, offset,
                           "pelcs reads a POLY whose terms past p0 and the first-order ones "
                           "are zero (an affine source)")
                return True
        if per == 2:
            inputs = [f"v({ctl[2 * k][0]},{ctl[2 * k + 1][0]})" for k in range(nd)]
        else:
            inputs = [f"i({ctl[k][0]})" for k in range(nd)]
        terms = [f"({coefs[0][0]})"] + [f"({c})*{x}" for (c, _), x in
                                          zip(coefs[1:1 + nd], inputs, strict=False)]
        text = " + ".join(terms)
        try:
            tree = parse_behavioural(text)
        except BehaviouralError as exc:
            self.error(f"POLY source: {exc.message}", st, at, f"syntax: {usage}")
            return True
        name = hierarchical_name(m.group(1), letter)
        self.body.elements.append(RawElement(
            "B", name, st, (node_name(m.group(2)), node_name(m.group(3))),
            behaviour=("V" if letter in "EH" else "I", tree, text, at)))
        return True

    def nonlinear_value(self, letter: str, st: Statement, what: str) -> bool:
        """``Cname n+ n- c='expression'`` (R, L alike) whose expression reads the circuit's
        voltages, currents or time: a nonlinear or time-varying element, said so where it is
        (the grammar would stop at the '=')."""
        m = _VALUE_LINE.match(st.text)
        if m is None or m.group(4).upper() != letter:
            return letter == "R" and self.positional_time_value(st)
        text, offset = m.group(5), m.start(5)
        if len(text) >= 2 and text[0] == text[-1] and text[0] in "'\"{":
            text, offset = text[1:-1], offset + 1
        else:
            token = ngspice_value_token(text)
            if token != text:
                return self.cut_value(letter, st, what, m, text, token, offset)
        try:
            tree = parse_behavioural(text)
            found = circuit_quantity(tree)
        except BehaviouralError:
            return False  # (the grammar's message)
        if found is not None and letter == "R" and reads_time_only(tree):
            # a piecewise-constant function of time (netlist.time_value): read in elaboration
            self.body.elements.append(RawElement(
                "R", hierarchical_name(m.group(1), "R"), st,
                (node_name(m.group(2)), node_name(m.group(3))),
                behaviour=("time", tree, text, offset)))
            return True
        if found is not None and letter == "R" and is_switched_value(tree):
            # constants switched on a comparison of the circuit (netlist.switched_resistor)
            self.body.elements.append(RawElement(
                "R", hierarchical_name(m.group(1), "R"), st,
                (node_name(m.group(2)), node_name(m.group(3))),
                behaviour=("switched", tree, text, offset)))
            return True
        if found == "time" and letter == "R":
            found = other_quantity(tree) or found
        if found is not None and letter == "C" and tree.tag == "?" and \
                circuit_quantity(tree.args[1]) is None and not reads_time_only(tree):
            # constant below a knee of its voltage (netlist.knee): checked in elaboration
            self.body.elements.append(RawElement(
                "C", hierarchical_name(m.group(1), "C"), st,
                (node_name(m.group(2)), node_name(m.group(3))),
                behaviour=("knee", tree, text, offset)))
            return True
        if found is not None:
            self.error(f"{what} '{m.group(1)}' has a value that depends on {found}: a "
                       f"{'time-varying' if found == 'time' else 'nonlinear'} {what}", st,
                       offset, TIME_ACCEPTED + "; or two constants switched on a comparison "
                       "of the circuit's voltages and currents, R = 'v(ctl) > 2.5 ? 10 : 1k'"
                       if letter == "R" else
                       f"pelcs needs a constant {what} value: give the one it has over "
                       "the run" + (" (for a saturable inductance, the unsaturated one)"
                                    if letter == "L" else "")
                       + ("; a value stepped in time is read for a resistor only (R = "
                          "'time < 1m ? 10 : 20')" if found == "time" else ""))
        return found is not None

    def positional_time_value(self, st: Statement) -> bool:
        """``Rname n+ n- {expression}`` (or ``'expression'``) whose expression reads time
        and nothing else of the circuit: ngspice makes it a B source as it does ``R = ...``
        (inpcom.c); read as a resistor stepped in time (:mod:`netlist.time_value`). False for
        any other line (the grammar's)."""
        m = _POSITIONAL_VALUE.match(st.text)
        if m is None:
            return False
        text, offset = m.group(4)[1:-1], m.start(4) + 1
        try:
            tree = parse_behavioural(text)
        except BehaviouralError:
            return False
        if not reads_time_only(tree):
            return False
        self.body.elements.append(RawElement(
            "R", hierarchical_name(m.group(1), "R"), st,
            (node_name(m.group(2)), node_name(m.group(3))),
            behaviour=("time", tree, text, offset)))
        return True

    def cut_value(self, letter: str, st: Statement, what: str, m: re.Match, text: str,
                  token: str, offset: int) -> bool:
        """An unquoted value that reads the circuit and has a blank outside parentheses:
        ngspice's value is its first token only (:func:`ngspice_value_token`). A capacitor
        whose token compares its own voltage with a constant is read as ngspice reads it,
        the comparison's 1 F while it holds (a knee capacitor: the run is checked to stay on
        that side, where ngspice's capacitance would be 0 F), with a note; anything else that
        reads the circuit is refused, saying what ngspice reads. False when the value reads
        nothing of the circuit (a constant expression: the grammar's own rules)."""
        try:
            found = circuit_quantity(parse_behavioural(text))
        except BehaviouralError:
            try:  # (what follows the token may not be an expression: ngspice drops it)
                found = circuit_quantity(parse_behavioural(token))
            except BehaviouralError:
                found = None
        if found is None:
            return False
        name, key = m.group(1), m.group(4)
        rest = text[len(token):].strip()
        reads = (f"ngspice reads an unquoted value only up to its first blank outside "
                 f"parentheses: {key} = {token}, the rest ('{rest}') dropped")
        try:
            tree = parse_behavioural(token)
        except BehaviouralError:
            tree = None
        if letter == "R" and tree is not None and reads_time_only(tree) and \
                time_in_comparisons(tree):
            self.body.elements.append(RawElement(
                "R", hierarchical_name(name, "R"), st,
                (node_name(m.group(2)), node_name(m.group(3))),
                behaviour=("time", tree, token, offset),
                note=(f"value written unquoted, {key} = {text}: {reads}; write {key} = '...' "
                      "in quotes for the expression as written")))
            return True
        if letter == "C" and tree is not None and tree.tag in ("<", ">", "<=", ">="):
            knee = parse_behavioural(f"{token} ? 1 : 0")
            self.body.elements.append(RawElement(
                "C", hierarchical_name(name, "C"), st,
                (node_name(m.group(2)), node_name(m.group(3))),
                behaviour=("knee", knee, f"{token} ? 1 : 0", offset),
                note=(f"value written unquoted, {key} = {text}: {reads}, so its capacitance "
                      f"is the comparison {token} itself, 1 F while it holds (0 F else), as "
                      f"ngspice simulates it; write {key} = '...' in quotes for the "
                      "conditional")))
            return True
        self.error(f"{what} '{name}': its value is written unquoted: {reads}", st, offset,
                   f"write {key} = '...' in quotes for the expression as written; pelcs "
                   f"reads a {what} value 'v(n+,n-) < K ? C0 : ...' (a constant below a knee)"
                   if letter == "C" else
                   f"write {key} = '...' in quotes for the expression as written; "
                   + (TIME_ACCEPTED if letter == "R" else f"pelcs needs a constant {what} "
                      "value"))
        return True

    def diode_area(self, extras: list, st: Statement) -> list[RawParam]:
        """A D line's area factors: its positional AREA (the first bare value after the
        model), ``area=`` and ``m=``. ngspice multiplies the area by m and scales the junction
        by it (IS and the conductance 1/RS; diosetup.c, diotemp.c); its other instance
        parameters (OFF, IC=, TEMP= ...) are read for their syntax only. The positional AREA
        (SPICE3's and LTspice's spelling) is refused: ngspice 39 stops at it, with or without
        OFF after it ("could not find a valid modelname", measured)."""
        out: list[RawParam] = []
        for t in extras:
            if isinstance(t, Token):
                self.error(f"diode area '{t}' written without area=: ngspice 39 refuses a "
                           "bare value after a diode's model (\"could not find a valid "
                           "modelname\")", st, t.start_pos,
                           f"write area={t} (SPICE3's and LTspice's positional area)")
                continue
            elif t.data == "assign" and t.children[0].lower() in ("area", "m"):
                tok, key = t.children[1], t.children[0].lower()
            else:
                continue
            v = self.value(tok, st)
            if v is not None:
                out.append(RawParam(key, v, st, tok.start_pos))
        return out

    def passive(self, letter: str, name: str, ch: list, st: Statement, what: str) -> None:
        ic = None
        parasitics: dict = {}
        mult: list[RawParam] = []
        model, model_at = "", 0
        given = [t for t in ch[4:] if not isinstance(t, Token)
                 and t.children[0].lower() in ("r", "resistance")]
        if letter == "R" and given and ch[3].type == "WORD" and parse_number(ch[3]) is None:
            # ngspice's 'R1 a b MODEL r=VALUE': the model first, the value as r=
            model, model_at, v = str(ch[3]), ch[3].start_pos, self.value(given[0].children[1], st)
            ch = [*ch[:4], *(t for t in ch[4:] if t is not given[0])]
        else:
            v = self.value(ch[3], st)
        for t in ch[4:]:
            if isinstance(t, Token):
                if parse_number(t) is not None:
                    self.error(f"unexpected '{t}' in {what} '{name}'", st, t.start_pos,
                               f"syntax: {ELEMENTS[letter][2]}")
                    return
                if letter == "R":
                    # a model name after the value (R1 1 2 600k MDR): ngspice uses the
                    # value, scaled by the model's TC1, TC2 away from its TNOM
                    model, model_at = str(t), t.start_pos
                    continue
                self.deck.notes.append(f"{name}: model '{t}' ignored, the value is used")
                continue
            key_tok, val_tok, *more = t.children  # (more: TC=TC1,TC2)
            key = key_tok.lower()
            if more and key != "tc":
                self.error(f"parameter '{key_tok}' of {what} '{name}' takes one value", st,
                           more[0].start_pos, f"write {key_tok}=VALUE")
                return
            if key == "ic" and letter in "LC":
                ic = self.value(val_tok, st)
                if ic is None:
                    return
            elif key in _TEMPERATURE_PARAMS or key == "tc":
                # ngspice scales R, L and C by 1 + TC1 dT + TC2 dT^2 (restemp.c, captemp.c,
                # indtemp.c): applied in netlist.flatten (TC=TC1[,TC2] the two at once)
                names = ("tc1", "tc2") if key == "tc" else (key,)
                for pname, tok in zip(names, (val_tok, *more), strict=False):
                    tv = self.value(tok, st)
                    if tv is None:
                        return
                    mult.append(RawParam(pname, tv, st, key_tok.start_pos))
            elif key in _PASSIVE_IGNORED:
                if any(self.value(tok, st) is None for tok in (val_tok, *more)):
                    return
            elif key == "m":
                # ngspice's multiplicity: m elements in parallel (resload.c, capload.c,
                # indtemp.c), applied in netlist.flatten
                mv = self.value(val_tok, st)
                if mv is None:
                    return
                mult.append(RawParam("m", mv, st, key_tok.start_pos))
            elif key in _PARASITICS.get(letter, ()):
                pv = self.value(val_tok, st)
                if pv is None:
                    return
                parasitics[key] = (pv, key_tok)
            else:
                accepted = "IC=" if letter in "LC" else "none that change the value"
                if letter in _PARASITICS:
                    accepted += ", and LTspice's " + ", ".join(
                        k.capitalize() + "=" for k in _PARASITICS[letter])
                hint = f"instance parameters accepted for a {what}: {accepted}"
                if key == "scale":
                    hint = "fold the scale factor into the value"
                self.error(f"unsupported parameter '{key_tok}' on {what} '{name}'", st,
                           key_tok.start_pos, hint)
                return
        if v is None:
            return
        if mult and parasitics:
            self.error(f"{what} '{name}': m= together with LTspice's "
                       f"{', '.join(k.capitalize() + '=' for k in parasitics)}", st,
                       mult[0].offset, "write the parallel elements out, or fold the "
                       "multiplier into the values")
            return
        a, b = node_name(ch[1]), node_name(ch[2])
        b_main = self.parasitics(letter, name, a, b, parasitics, st)
        self.body.elements.append(RawElement(letter, name, st, (a, b_main), value=v, ic=ic,
                                             params=mult, ref=model, ref_offset=model_at))

    def parasitics(self, letter: str, name: str, a: str, b: str, found: dict,
                   st: Statement) -> str:
        """LTspice's parasitics as elements (:func:`netlist.ltspice.explicit_parasitics`)."""
        return explicit_parasitics(self.body.elements, self.deck.notes, letter, name, a, b,
                                   found, st)

    def source(self, letter: str, name: str, ch: list, st: Statement) -> None:
        dc: Value | None = None
        wave = None
        ok = True
        parasitics: dict = {}
        for part in ch[3:]:
            if isinstance(part, Token):  # the value before any keyword: the DC value
                dc = self.value(part, st)
                ok = ok and dc is not None
                continue
            if part.data == "assign":
                key_tok, val_tok = part.children
                key = key_tok.lower()
                if key in ("r", "td") and wave is not None and wave[0] == "pwl":
                    # ngspice's PWL(...) r=T td=T: repeat from the point at T; delay
                    pv = self.value(val_tok, st)
                    if pv is None:
                        return
                    wave[3][key] = (pv, key_tok.start_pos)
                    continue
                if key not in _PARASITICS.get(letter, ()):
                    self.error(f"unsupported parameter '{key_tok}' on source '{name}'", st,
                               key_tok.start_pos, "LTspice's Rser= and Cpar= are accepted, "
                               "and r= and td= after a PWL(...)")
                    return
                pv = self.value(val_tok, st)
                if pv is None:
                    return
                parasitics[key] = (pv, key_tok)
                continue
            if part.data == "dc_part":
                dc = self.value(part.children[-1], st)
                ok = ok and dc is not None
            elif part.data == "ac_part":
                for t in part.children[1:]:
                    ok = ok and self.value(t, st) is not None
            else:
                kw = part.children[0].children[0]
                kind = WAVE_ALIASES.get(kw.lower(), kw.lower())
                if kind in UNSUPPORTED_WAVES:
                    self.error(f"{kw.upper()} sources are not supported", st, kw.start_pos,
                               UNSUPPORTED_WAVES[kind])
                    return
                toks = part.children[1].children if len(part.children) > 1 else []
                args = [self.value(t, st) for t in toks]
                if any(a is None for a in args):
                    return
                lo, hi = WAVE_ARGS[kind]
                if hi is not None and len(args) > hi and kind != "pwl":
                    # (ngspice reads every number into the source's coefficients and uses
                    # the first ones: SIN(0 1 200 0 0 0 0), a 7th value some tools write,
                    # is the sine of the first six; measured in ngspice 39)
                    self.deck.notes.append(
                        f"line {st.loc(kw.start_pos).line}: {name}: {kw.upper()} takes at "
                        f"most {hi} values; the {len(args) - hi} after them ignored, as "
                        "ngspice ignores them")
                    args = args[:hi]
                if len(args) < lo or (hi is not None and len(args) > hi):
                    names = {
                        "pulse": "V1 V2 [TD [TR [TF [PW [PER [NP]]]]]]",
                        "sin": "VO VA [FREQ [TD [THETA [PHASE]]]]",
                        "exp": "V1 V2 [TD1 [TAU1 [TD2 [TAU2]]]]",
                        "sffm": "VO VA [FC [MDI [FS [PHASEC [PHASES]]]]]",
                        "am": "VA VO [MF [FC [TD [PHASEC [PHASES]]]]]",
                    }.get(kind, "T1 V1 [T2 V2 ...]")
                    self.error(f"{kw.upper()} takes {lo} to {hi} values, got {len(args)}"
                               if hi else f"{kw.upper()} needs at least {lo} values",
                               st, kw.start_pos, f"syntax: {kw.upper()}({names})")
                    return
                if kind == "pwl" and len(args) % 2:
                    self.error(f"PWL needs time-value pairs, got {len(args)} values", st,
                               kw.start_pos, "syntax: PWL(T1 V1 T2 V2 ...)")
                    return
                wave = (kind, args, kw.start_pos, {})
        if not ok:
            return
        a, b = node_name(ch[1]), node_name(ch[2])
        b_main = self.parasitics(letter, name, a, b, parasitics, st)
        self.body.elements.append(RawElement(letter, name, st, (a, b_main), value=dc,
                                             wave=wave))

    def instance(self, name: str, ch: list, st: Statement) -> None:
        words: list[Token] = []
        params: list[RawParam] = []
        seen_params = False
        for item in ch[1:]:
            if item.data == "x_word":
                if seen_params or params:
                    tok = item.children[0]
                    self.error(f"unexpected '{tok}' after the parameters of '{name}'", st,
                               tok.start_pos, "syntax: Xname node... subckt [params: a=1 ...]")
                    return
                words.append(item.children[0])
            elif item.data == "x_params":
                seen_params = True
            else:
                params.extend(self.assigns([item], st))
        if not words:
            self.error(f"subcircuit instance '{name}' names no subcircuit", st, len(st.text),
                       "syntax: Xname node... subckt [params: a=1 ...]")
            return
        sub = words[-1]
        self.body.elements.append(RawElement(
            "X", name, st, tuple(node_name(w) for w in words[:-1]), ref=str(sub),
            ref_offset=sub.start_pos, params=params))


    def device(self, letter: str, name: str, ch: list, st: Statement, usage: str) -> None:
        """M and Q lines: nodes, then the model (the last word that is not a number or a
        flag), then instance parameters (ignored: the device becomes an ideal switch)."""
        words = [t for t in ch[1:] if isinstance(t, Token)]
        cands = [i for i, t in enumerate(words)
                 if parse_number(t) is None and t.lower() not in ("on", "off")]
        if not cands:
            self.error(f"{name}: no model name", st, len(st.text), f"syntax: {usage}")
            return
        mi = cands[-1]
        nodes = words[:mi]
        if len(nodes) not in (3, 4):
            where = words[mi].start_pos
            self.error(f"{name}: {len(nodes)} nodes before the model '{words[mi]}', expected "
                       "3 or 4", st, where, f"syntax: {usage}")
            return
        self.body.elements.append(RawElement(
            letter, name, st, tuple(node_name(n) for n in nodes), ref=str(words[mi]),
            ref_offset=words[mi].start_pos))
