"""ngspice's XSPICE code models (``Aname ports... model``) with an exact or stated ideal
equivalent.

An XSPICE ``A`` element connects ports to a code model named by a ``.model NAME TYPE(...)``
card whose parameters may be vectors (``in_gain=[1 -1]``) and booleans (``log=FALSE``).
A port is a node (``n``), a differential pair (``(a b)``, or ``a b`` after a differential
type), or a vector of these in brackets (``[a b]``), optionally preceded by its type: ``%v``
(a node voltage), ``%vd`` (a voltage difference), ``%gd`` (a conductance between two nodes);
``%h``/``%hd`` (a current in, the lcouple's ports); the current, digital and other types
are refused. pelcs reads eight analog models:

==========  ==================================================================================
model       becomes
==========  ==================================================================================
gain        ``out = out_offset + gain*(in + in_offset)``: linear, E and DC sources (exact)
summer      ``out = out_offset + out_gain*sum(in_gain[i]*(in[i] + in_offset[i]))``: linear
            (exact)
triangle    a constant-frequency triangle (every ``freq_array`` entry equal): a repeating PWL
            voltage source from ``out_low`` at t = 0 up to ``out_high`` at
            ``duty_cycle/freq``, down to ``out_low`` at ``1/freq`` (exact)
square      a constant-frequency square: a PULSE voltage source, ``out_low`` for the period's
            first ``1 - duty_cycle``, up over ``rise_time``, ``out_high`` to the period's end,
            down over ``fall_time`` (exact)
limit       of ``|gain| >= 1000``: a comparator between ``out_lower_limit`` and
            ``out_upper_limit`` whose step is at the midpoint of its linear range (an
            idealisation: said in a note)
aswitch     an ideal S switch (``RON = r_on``, off open) on while the control is past the
            midpoint of ``cntl_off`` and ``cntl_on`` (an idealisation: said in a note)
lcouple,    windings on a magnetic core: coupled inductors from the slope of the core's B-H
core        table around H = 0, the run checked to stay on that segment
            (:mod:`netlist.magnetic_core`: exact there)
==========  ==================================================================================

The limit comparator then goes where a comparator B source goes
(:func:`netlist.behavioural.resolve_comparators`): onto the S switches it drives.
``docs/xspice.md`` has the semantics, checked against ngspice's code models.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from lcs.signals import Pulse, Pwl

from .behavioural import Comparator, linear_elements, source_name
from .behavioural_expr import Affine, Step, linearise, parse_behavioural
from .circuit import GROUND, Circuit, Element, Model, Switch, VoltageSource
from .dialect import hierarchical_name, node_name
from .expressions import ExpressionError, parse_expression
from .rawdeck import RawElement, Statement, Value
from .units import parse_number

__all__ = ["ACCEPTED_MODELS", "CODE_MODELS", "CodeModel", "Port", "XspiceError", "elaborate",
           "elaborate_element", "read_instance", "read_model"]

# the code models of ngspice's XSPICE library (src/xspice/icm), by name
CODE_MODELS = frozenset((
    "climit d_dt divide file_source gain hyst ilimit int limit mult multi_input_pwl oneshot "
    "pwl s_xfer sine slew square summer triangle adc_bridge d_and d_buffer d_dff d_dlatch "
    "d_fdiv d_inverter d_jkff d_nand d_nor d_open_c d_open_e d_or d_osc d_pulldown d_pullup "
    "d_ram d_source d_srff d_srlatch d_state d_tff d_tristate d_xnor d_xor dac_bridge "
    "icm_spice2poly aswitch capacitor cmeter core inductor lcouple lmeter memristor "
    "potentiometer zener d_to_real real_delay real_gain real_to_v d_lut d_genlut "
    "d_pwm d_cosim").split())

# model -> (ports: name, default type, allowed types, vector), (parameter -> default)
# (None: required; a list: a vector parameter)
_SPECS: dict[str, tuple[tuple[tuple[str, str, tuple[str, ...], bool], ...], dict]] = {
    "gain": ((("in", "v", ("v", "vd"), False), ("out", "v", ("v", "vd"), False)),
             {"in_offset": 0.0, "gain": 1.0, "out_offset": 0.0}),
    "summer": ((("in", "v", ("v", "vd"), True), ("out", "v", ("v", "vd"), False)),
               {"in_offset": [0.0], "in_gain": [1.0], "out_gain": 1.0, "out_offset": 0.0}),
    "limit": ((("in", "v", ("v", "vd"), False), ("out", "v", ("v", "vd"), False)),
              {"in_offset": 0.0, "gain": 1.0, "out_lower_limit": None,
               "out_upper_limit": None, "limit_range": 1e-6, "fraction": 0.0}),
    "triangle": ((("cntl_in", "v", ("v", "vd"), False), ("out", "v", ("v", "vd"), False)),
                 {"cntl_array": [0.0], "freq_array": [1e3], "out_low": -1.0,
                  "out_high": 1.0, "duty_cycle": 0.5}),
    "square": ((("cntl_in", "v", ("v", "vd"), False), ("out", "v", ("v", "vd"), False)),
               {"cntl_array": [0.0], "freq_array": [1e3], "out_low": -1.0, "out_high": 1.0,
                "duty_cycle": 0.5, "rise_time": 1e-9, "fall_time": 1e-9}),
    "aswitch": ((("cntl_in", "v", ("v", "vd"), False), ("out", "gd", ("gd",), False)),
                {"cntl_off": 0.0, "cntl_on": 1.0, "log": 1.0, "r_off": 1e12, "r_on": 1.0}),
    "lcouple": ((("l", "hd", ("h", "hd"), False), ("mmf_out", "hd", ("hd",), False)),
                {"num_turns": 1.0}),
    "core": ((("mc", "gd", ("g", "gd"), False),),
             {"h_array": [], "b_array": [], "area": None, "length": None,
              "input_domain": 0.01, "fraction": 1.0, "mode": 1.0, "in_low": 0.0,
              "in_high": 1.0, "hyst": 0.1, "out_lower_limit": 0.0, "out_upper_limit": 1.0}),
}
ACCEPTED_MODELS = tuple(_SPECS)
ACCEPTED = ("pelcs reads the XSPICE code models gain, summer, triangle and square (constant "
            "frequency), "
            "limit (gain >= 1000, as a comparator), aswitch (as an ideal switch), and "
            "lcouple windings on a core (linear around H = 0), with %v, %vd, %gd and the "
            "lcouple's %hd ports (docs/xspice.md)")
_DIFFERENTIAL = ("vd", "id", "gd", "hd")
_MIN_LIMIT_GAIN = 1e3


class XspiceError(Exception):
    """A problem with an A line or an XSPICE model, at ``offset`` in its statement."""

    def __init__(self, message: str, offset: int, hint: str = ACCEPTED,
                 st: Statement | None = None):
        super().__init__(message)
        self.message, self.offset, self.hint = message, offset, hint
        self.st = st  # the statement the offset is in (None: the A line's)


@dataclass(eq=False)
class CodeModel:
    """``.model NAME TYPE(...)`` of an XSPICE code model: parameter -> values as written
    (a vector parameter has several) and the offset of its name."""

    name: str
    type: str
    params: dict[str, tuple[list[Value], int]]
    st: Statement


@dataclass(frozen=True)
class Port:
    """One port of an A line: its type as written (``""``: the model's default), its nodes
    (one, or two for a differential port) or, for a vector, its ``members``."""

    type: str
    nodes: tuple[str, ...]
    offset: int
    members: tuple[Port, ...] = field(default=())
    vector: bool = False


# ------------------------------------------------------------------------------ reading

_TOKEN = re.compile(r"\s*(\[|\]|\(|\)|%[A-Za-z_]+|~|\{[^}]*\}|[^\s\[\]()%~]+)")


def _tokens(text: str, start: int) -> list[tuple[str, int]]:
    out = []
    pos = start
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if m is None:
            if text[pos:].strip():
                raise XspiceError(f"unexpected {text[pos]!r}", pos)
            break
        if m.group(1):
            out.append((m.group(1), m.start(1)))
        pos = m.end()
    return out


def read_model(st: Statement, name: str, mtype: str, start: int) -> CodeModel:
    """The parameters of an XSPICE ``.model`` card, from ``start`` (after its type)."""
    text = st.text
    toks = _tokens_eq(text, start)
    if toks and toks[0][0] == "(":
        if toks[-1][0] != ")":
            raise XspiceError(f"'(' of model '{name}' is not closed", toks[0][1],
                              ".model NAME TYPE(param=value ...)")
        toks = toks[1:-1]
    params: dict[str, tuple[list[Value], int]] = {}
    i = 0
    while i < len(toks):
        pname, at = toks[i]
        if not re.fullmatch(r"[A-Za-z_]\w*", pname):
            raise XspiceError(f"unexpected '{pname}' in model '{name}': expected NAME=VALUE",
                              at, ".model NAME TYPE(param=value param=[v1 v2 ...] ...)")
        if i + 1 >= len(toks) or toks[i + 1][0] != "=" or i + 2 >= len(toks):
            raise XspiceError(f"parameter '{pname}' of model '{name}' has no value", at,
                              "write NAME=VALUE or NAME=[V1 V2 ...]")
        i += 2
        values: list[tuple[str, int]] = []
        if toks[i][0] == "[":
            i += 1
            while i < len(toks) and toks[i][0] != "]":
                values.append(toks[i])
                i += 1
            if i >= len(toks):
                raise XspiceError(f"'[' of parameter '{pname}' is not closed", at,
                                  "write NAME=[V1 V2 ...]")
            i += 1
        else:
            values.append(toks[i])
            i += 1
        params[pname.lower()] = ([_value(tok, off, st) for tok, off in values], at)
    return CodeModel(name, mtype.lower(), params, st)


def _tokens_eq(text: str, start: int) -> list[tuple[str, int]]:
    out: list[tuple[str, int]] = []
    for tok, off in _tokens(text, start):
        # NAME=VALUE written without spaces: split at the '='
        while "=" in tok and tok != "=":
            k = tok.index("=")
            if k:
                out.append((tok[:k], off))
            out.append(("=", off + k))
            tok, off = tok[k + 1:], off + k + 1
        if tok:
            out.append((tok, off))
    return out


def _value(tok: str, off: int, st: Statement) -> Value:
    low = tok.lower()
    if low in ("true", "false"):
        return Value(1.0 if low == "true" else 0.0, None, st, off)
    if tok.startswith("{") and tok.endswith("}"):
        try:
            expr = parse_expression(tok[1:-1])
        except ExpressionError as exc:
            raise XspiceError(exc.message, off + 1 + exc.offset, exc.hint) from None
        return Value(None, expr, st, off)
    num = parse_number(tok)
    if num is None or not math.isfinite(num):
        raise XspiceError(f"invalid value '{tok}'", off,
                          "a number, TRUE/FALSE, or an expression in braces")
    return Value(num, None, st, off)


def read_instance(st: Statement) -> tuple[str, tuple[Port, ...], str, int]:
    """``Aname port... model``: the name, the ports and the model name with its offset."""
    toks = _tokens(st.text, 0)
    if len(toks) < 3:
        raise XspiceError(f"XSPICE element '{toks[0][0]}' needs its ports and a model name",
                          len(st.text), "syntax: Aname port... model, a port being a node, "
                          "(n+ n-) or [n1 n2 ...], optionally after %v, %vd, %gd")
    name = hierarchical_name(toks[0][0], "A")
    model, moff = toks[-1]
    body = toks[1:-1]
    ports: list[Port] = []
    i = 0
    while i < len(body):
        port, i = _port(body, i, "")
        ports.append(port)
    return name, tuple(ports), model, moff


def _port(toks: list[tuple[str, int]], i: int, outer: str) -> tuple[Port, int]:
    tok, off = toks[i]
    ptype = outer
    if tok.startswith("%"):
        ptype = tok[1:].lower()
        i += 1
        if i >= len(toks):
            raise XspiceError(f"port type '{tok}' without its port", off)
        tok, _ = toks[i]
    if tok == "[":
        members = []
        i += 1
        while i < len(toks) and toks[i][0] != "]":
            m, i = _port(toks, i, ptype)
            members.append(m)
        if i >= len(toks):
            raise XspiceError("'[' of a vector port is not closed", off, "write [n1 n2 ...]")
        return Port(ptype, (), off, tuple(members), True), i + 1
    if tok == "(":
        if i + 3 >= len(toks) or toks[i + 3][0] != ")":
            raise XspiceError("a differential port is two nodes in parentheses", off,
                              "write (n+ n-)")
        a, b = toks[i + 1][0], toks[i + 2][0]
        return Port(ptype, (node_name(a), node_name(b)), off), i + 4
    if tok in ("]", ")"):
        raise XspiceError(f"unexpected '{tok}'", off)
    if tok == "~":
        raise XspiceError("'~' (an inverted digital port) in an XSPICE element", off,
                          "pelcs reads analog code models only; " + ACCEPTED)
    if ptype in _DIFFERENTIAL:
        if i + 1 >= len(toks) or toks[i + 1][0] in "[]()":
            raise XspiceError(f"a %{ptype} port is two nodes", off, "write (n+ n-)")
        return Port(ptype, (node_name(tok), node_name(toks[i + 1][0])), off), i + 2
    return Port(ptype, (node_name(tok),), off), i + 1


# ------------------------------------------------------------------------------ elaboration


def _fail(message: str, offset: int, hint: str = ACCEPTED,
          st: Statement | None = None) -> XspiceError:
    return XspiceError(message, offset, hint, st)


def elaborate_element(el: RawElement, prefix: str, mapnode: Callable[[str], str],
                      env: Mapping[str, float], code_models: Mapping[str, CodeModel],
                      evaluate: Callable[[Value], float | None], circuit: Circuit,
                      error: Callable[..., None]) -> list[Element]:
    """An A element of the raw deck in its instance: its elements (:func:`elaborate`), or
    none after reporting a problem with ``error(message, location, hint, elements,
    dependent=...)``."""
    name = prefix + el.name if prefix else el.name
    model = code_models.get(el.ref.lower())
    if model is None:
        error(f"{name}: unknown XSPICE model '{el.ref}'", el.st.loc(el.ref_offset),
              f"define it with .model {el.ref} TYPE(...); {ACCEPTED}", (name,), dependent=True)
        return []
    try:
        return elaborate(name, el.ports, model, el.st, el.ref_offset, mapnode, prefix, env,
                         evaluate, circuit.models, circuit.notes)
    except XspiceError as exc:
        error(exc.message, (exc.st or el.st).loc(exc.offset), exc.hint, (name,))
        return []


def elaborate(name: str, ports: tuple[Port, ...], model: CodeModel, st: Statement,
              model_offset: int, mapnode: Callable[[str], str], prefix: str,
              env: Mapping[str, float], evaluate: Callable[[Value], float | None],
              models: dict[str, Model], notes: list[str]) -> list[Element]:
    """The elements equal (or, for limit and aswitch, ideally equal) to one A element.

    Parameters
    ----------
    name : str
        The element's flattened name.
    ports, model, st, model_offset
        As read (:func:`read_instance`, :func:`read_model`).
    mapnode : callable
        Node names as written -> the flattened circuit's.
    prefix : str
        The instance prefix of names (``X1.``).
    env : mapping
        Parameter values (lower-case names) for :func:`netlist.behavioural_expr.linearise`.
    evaluate : callable
        A parameter value of the model card -> float (``None`` after reporting a problem).
    models : dict
        The circuit's models: an aswitch adds its switch's.
    notes : list of str
        The run's notes: the idealisations are said there.

    Raises
    ------
    XspiceError
        A model pelcs does not read, a port of a type or shape the model does not take, a
        parameter the model does not have, or a form without an ideal equivalent.
    """
    mtype = model.type
    if mtype not in _SPECS:
        kind = "digital" if mtype.startswith("d_") or mtype in ("adc_bridge", "dac_bridge") \
            else "nonlinear or dynamic"
        raise _fail(f"{name}: XSPICE code model '{mtype}' (model '{model.name}', {kind}) "
                    "has no ideal equivalent in pelcs", model_offset)
    spec, defaults = _SPECS[mtype]
    if len(ports) != len(spec):
        raise _fail(f"{name}: the {mtype} code model has {len(spec)} ports "
                    f"({', '.join(p[0] for p in spec)}), the line gives {len(ports)}",
                    ports[0].offset if ports else model_offset,
                    f"syntax: Aname {' '.join(p[0] for p in spec)} {model.name}")
    params: dict[str, float | list[float]] = {}
    for pname, (vals, at) in model.params.items():
        if pname not in defaults:
            raise _fail(f"model '{model.name}': '{pname}' is not a parameter of the {mtype} "
                        "code model", at, f"its parameters: {', '.join(defaults)}",
                        st=model.st)
        nums = [evaluate(v) for v in vals]
        if any(x is None for x in nums):
            return []
        vector = isinstance(defaults[pname], list)
        if not vector and len(nums) != 1:
            raise _fail(f"model '{model.name}': '{pname}' takes one value, not a vector", at,
                        f"write {pname}=VALUE", st=model.st)
        params[pname] = nums if vector else nums[0]
    for pname, dv in defaults.items():
        if pname not in params:
            if dv is None or dv == []:
                raise _fail(f"model '{model.name}': the {mtype} code model needs '{pname}'",
                            0, f"add {pname}=VALUE to .model {model.name}", st=model.st)
            params[pname] = dv
    # the ports: types allowed, shape
    quantities: list[list[str]] = []
    for port, (pname, dtype, allowed, vector) in zip(ports, spec, strict=True):
        members = port.members if port.vector else (port,)
        if port.vector != vector:
            raise _fail(f"{name}: port '{pname}' of the {mtype} code model "
                        f"{'is a vector: write [n1 n2 ...]' if vector else 'is not a vector'}",
                        port.offset, f"syntax: Aname {' '.join(p[0] for p in spec)} model")
        texts = []
        for m in members:
            ptype = m.type or dtype
            if ptype not in allowed:
                raise _fail(f"{name}: port '{pname}' of type %{ptype}", m.offset,
                            f"pelcs reads port '{pname}' of the {mtype} code model as "
                            f"{' or '.join('%' + a for a in allowed)} (a current, digital "
                            "or named-source port has no ideal equivalent here)")
            if ptype in _DIFFERENTIAL and len(m.nodes) != 2 or \
                    ptype not in _DIFFERENTIAL and len(m.nodes) != 1:
                size = "two nodes" if ptype in _DIFFERENTIAL else "one node"
                raise _fail(f"{name}: a %{ptype} port is {size}", m.offset,
                            "write (n+ n-) for a differential port")
            if any(n.lower() == "null" for n in m.nodes):
                raise _fail(f"{name}: an unconnected (null) port", m.offset,
                            "connect every port of an analog code model")
            texts.append(f"v({','.join(m.nodes)})")
        quantities.append(texts)
    out_port = ports[-1]
    out_nodes = tuple(map(mapnode, out_port.nodes))
    if len(out_nodes) == 1:
        out_nodes = (out_nodes[0], GROUND)
    loc = st.loc(0)
    p = params

    def affine(text: str):
        return linearise(parse_behavioural(text), text, env, mapnode, source_name(prefix))

    if mtype in ("lcouple", "core"):  # a core and its windings: netlist.magnetic_core
        return _magnetic(name, ports, model, params, mapnode, loc)
    if mtype in ("gain", "summer"):
        if mtype == "gain":
            text = f"{p['out_offset']!r} + {p['gain']!r}*({quantities[0][0]} + {p['in_offset']!r})"
        else:
            n = len(quantities[0])
            gains, offs = list(p["in_gain"]), list(p["in_offset"])
            for key, vec in (("in_gain", gains), ("in_offset", offs)):
                if key in model.params and len(vec) != n:
                    raise _fail(f"model '{model.name}': {key} has {len(vec)} values for {n} "
                                "inputs", model.params[key][1], "give one value per input",
                                st=model.st)
            gains = gains if "in_gain" in model.params else [1.0] * n
            offs = offs if "in_offset" in model.params else [0.0] * n
            terms = " + ".join(f"{g!r}*({q} + {o!r})"
                               for g, q, o in zip(gains, quantities[0], offs, strict=True))
            text = f"{p['out_offset']!r} + {p['out_gain']!r}*({terms})"
        return linear_elements(name, "V", out_nodes, affine(text), loc)
    if mtype == "limit":
        lo, hi, gain = p["out_lower_limit"], p["out_upper_limit"], p["gain"]
        if not hi > lo:
            raise _fail(f"model '{model.name}': out_upper_limit {hi:g} is not above "
                        f"out_lower_limit {lo:g}", model.params["out_upper_limit"][1],
                        "the upper limit must be above the lower one", st=model.st)
        source_in = affine(quantities[0][0])
        if isinstance(source_in, Affine) and source_in.constant:
            # an input tied to ground (a subcircuit port wired to 0): no comparison, the
            # output is the clamped constant, as ngspice's (within its limit_range
            # smoothing of a limit: 2.5e-7 V at a corner with the default 1e-6)
            level = min(hi, max(lo, gain * (source_in.const + p["in_offset"])))
            notes.append(f"{name}: XSPICE limit of a constant input ({quantities[0][0]} = "
                         f"{source_in.const:g} V): its output is the constant {level:g} V")
            return linear_elements(name, "V", out_nodes, Affine((), level), loc)
        if abs(gain) < _MIN_LIMIT_GAIN:
            raise _fail(f"model '{model.name}': a limit of gain {gain:g} is a clamp (its "
                        "output follows its input between the limits): nonlinear",
                        model.params["gain"][1] if "gain" in model.params else model_offset,
                        f"pelcs reads a limit of |gain| >= {_MIN_LIMIT_GAIN:g} as a comparator; "
                        + ACCEPTED, st=model.st if "gain" in model.params else None)
        mid = 0.5 * (lo + hi)
        text = (f"{lo!r} + {hi - lo!r}*u({gain!r}*({quantities[0][0]} + {p['in_offset']!r})"
                f" - {mid!r})")
        step = affine(text)
        assert isinstance(step, Step)
        width = (hi - lo) / abs(gain)
        notes.append(f"{name}: XSPICE limit (gain {gain:g}) read as a comparator between "
                     f"{lo:g} and {hi:g} V, stepping where its linear output would be {mid:g} "
                     f"V; ngspice's output ramps over {width:.3g} V of input (plus its "
                     f"{p['limit_range']:g} smoothing), so a switch it gates turns within "
                     "that input range of pelcs' instant")
        return [Comparator(name, out_nodes, loc, "V", step,
                           f"XSPICE limit {model.name}: {quantities[0][0]}",
                           what="XSPICE limit")]
    if mtype in ("triangle", "square"):
        freqs, cntls = list(p["freq_array"]), list(p["cntl_array"])
        if len(freqs) != len(cntls) or len(freqs) < 2:
            raise _fail(f"model '{model.name}': cntl_array and freq_array need the same "
                        "number of values, two at least", 0,
                        "cntl_array=[c1 c2 ...] freq_array=[f1 f2 ...]", st=model.st)
        if any(f != freqs[0] for f in freqs) or not freqs[0] > 0:
            raise _fail(f"model '{model.name}': a {mtype} whose frequency follows its control "
                        f"input (freq_array {freqs}) is a voltage-controlled oscillator",
                        model.params["freq_array"][1],
                        f"pelcs reads a {mtype} of one frequency (all freq_array values "
                        "equal, > 0); " + ACCEPTED, st=model.st)
        d = p["duty_cycle"]
        if not 1e-6 <= d <= 0.999999:
            raise _fail(f"model '{model.name}': duty_cycle {d:g} outside [1e-6, 0.999999]",
                        model.params["duty_cycle"][1], "ngspice's limits for duty_cycle",
                        st=model.st)
        period = 1.0 / freqs[0]
        if mtype == "square":
            return [VoltageSource(name, out_nodes, loc, p["out_low"],
                                  _square(model, p, period, d))]
        wave = Pwl((0.0, d * period, period), (p["out_low"], p["out_high"], p["out_low"]),
                   0.0, 0.0)
        return [VoltageSource(name, out_nodes, loc, p["out_low"], wave)]
    # aswitch
    off, on = p["cntl_off"], p["cntl_on"]
    if abs(on - off) < 1e-12:
        raise _fail(f"model '{model.name}': cntl_on and cntl_off are equal", model_offset,
                    "ngspice's aswitch needs them 1e-12 apart at least")
    ctl_port = ports[0]
    ctl = tuple(map(mapnode, ctl_port.nodes))
    if len(ctl) == 1:
        ctl = (ctl[0], GROUND)
    mid = 0.5 * (on + off)
    if on < off:  # on below the midpoint: the control reversed
        ctl, vt = (ctl[1], ctl[0]), -mid
    else:
        vt = mid
    r_on = max(p["r_on"], 1e-3)  # ngspice's floor of r_on
    key = f"pelcs_aswitch_{name.lower().replace('.', '_')}"
    models[key] = Model(key, "SW", {"vt": vt, "vh": 0.0, "ron": r_on, "roff": p["r_off"]},
                        loc)
    law = "exponentially (log=TRUE)" if p["log"] else "linearly"
    notes.append(f"{name}: XSPICE aswitch read as an ideal switch on while "
                 f"{quantities[0][0]} is {'above' if on > off else 'below'} {mid:g} V (the "
                 f"midpoint of cntl_off {off:g} and cntl_on {on:g}), RON {r_on:g} Ω, open "
                 f"when off; ngspice's resistance varies {law} with the control, from "
                 f"r_off {p['r_off']:g} Ω at cntl_off to r_on at cntl_on, and beyond them: "
                 "the same where the control sits at cntl_off or cntl_on")
    return [Switch(name, out_nodes, loc, ctl, key, None)]


def _square(model: CodeModel, p: dict, period: float, d: float) -> Pulse:
    """ngspice's square (src/xspice/icm/analog/square/cfunc.mod): ``out_low`` for the
    period's first ``1 - duty_cycle``, then up over ``rise_time``, ``out_high`` to the period's
    end, down over ``fall_time`` into the next: PULSE(low high (1-d)T rise fall dT-rise T)."""
    rise, fall = p["rise_time"], p["fall_time"]
    for key, value in (("rise_time", rise), ("fall_time", fall)):
        if not value > 0:
            raise _fail(f"model '{model.name}': {key} {value:g} is not positive",
                        model.params[key][1], "give the edge's duration, s", st=model.st)
    if rise > d * period or fall > (1 - d) * period:
        raise _fail(f"model '{model.name}': its edges (rise_time {rise:g}, fall_time "
                    f"{fall:g} s) do not fit in its high and low times ({d * period:g}, "
                    f"{(1 - d) * period:g} s)", model.params.get("rise_time", (0, 0))[1],
                    "shorten the edges", st=model.st)
    return Pulse(p["out_low"], p["out_high"], (1 - d) * period, rise, fall,
                 d * period - rise, period)


def _magnetic(name: str, ports: tuple[Port, ...], model: CodeModel, p: dict,
              mapnode: Callable[[str], str], loc) -> list[Element]:
    """An lcouple winding or a core, resolved together by
    :func:`netlist.magnetic_core.resolve_cores` once every element is read."""
    from .magnetic_core import MagneticCore, Winding

    def port(i: int) -> tuple[str, str]:
        nodes = tuple(map(mapnode, ports[i].nodes))
        return (nodes[0], GROUND) if len(nodes) == 1 else (nodes[0], nodes[1])

    if model.type == "lcouple":
        return [Winding(name, port(0), loc, value=math.nan, mmf=port(1),
                        turns=p["num_turns"])]
    if p["mode"] != 1.0:
        raise _fail(f"model '{model.name}': the core's hysteresis mode (mode={p['mode']:g}) "
                    "has no ideal equivalent in pelcs", model.params["mode"][1],
                    "pelcs reads a core in its piecewise-linear mode (mode=1, the default) "
                    "on the straight segment of its table around H = 0", st=model.st)
    for key in ("area", "length"):
        if not p[key] > 0:
            raise _fail(f"model '{model.name}': the core's {key} {p[key]:g} is not positive",
                        model.params[key][1], f"give {key} in m{'²' if key == 'area' else ''}",
                        st=model.st)
    return [MagneticCore(name, port(0), loc, h=tuple(p["h_array"]), b=tuple(p["b_array"]),
                         area=p["area"], length=p["length"],
                         input_domain=p["input_domain"], fraction=bool(p["fraction"]))]
