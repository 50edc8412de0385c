"""Elaboration: a :class:`~netlist.parser.Deck` -> a flattened, checked :class:`Circuit`.

Parameters
----------
Global ``.param`` definitions may refer to each other in any order: evaluated in dependency
order, a cycle reported naming its parameters. Overrides (``params=``, ``--param``) replace
global definitions first, so those depending on them follow; an unknown one is an error.

Subcircuits
-----------
Definitions are global. Inside an instance, names are looked up first among the subcircuit's
own parameters (the ``.subckt`` header defaults, replaced by the instance's ``params:`` values
evaluated where the instance stands, and the body's ``.param`` lines), then among the global
ones (lexical scoping, as in ngspice). An instance ``X1`` turns element ``L1`` into ``X1.L1``
and node ``n3`` into ``x1.n3`` (nested: ``X1.X2.L1``, ``x1.x2.n3``); ports become the instance's
nodes, ground and ``.global`` nodes stay; references (F/H sources, K inductors) get the prefix.
``.model`` lines are global, except those inside a ``.subckt`` definition, local to it as in
ngspice (:meth:`_Builder.models`); XSPICE cards are evaluated per instance."""

from __future__ import annotations

import copy
import math
from collections import ChainMap, Counter
from collections.abc import Callable, Mapping
from importlib import import_module

from lcs.signals import Exp, Pulse, Pwl, Signal, Sin, modulated

from . import current_switch, xspice
from .behavioural import elaborate, resolve_comparators
from .checks import check_circuit, value_problem
from .circuit import (
    GROUND,
    Capacitor,
    Cccs,
    Ccvs,
    Circuit,
    Coupling,
    CurrentSource,
    Diode,
    Element,
    Inductor,
    Model,
    Resistor,
    Switch,
    Tran,
    Vccs,
    Vcvs,
    VoltageSource,
)
from .errors import Diagnostic, Location, NetlistError, ordered_diagnostics
from .expressions import ExpressionError
from .limits import ELEMENTS
from .rawdeck import Body, Deck, RawElement, RawParam, Statement, Value
from .steps import evaluate_steps
from .suggest import close_matches
from .switched_resistor import elaborate_resistor
from .value_scaling import deck_temperatures, multiplier, temperature_factor

# default parameters of ngspice's SW model that pelcs uses
SW_DEFAULTS = {"vt": 0.0, "vh": 0.0}

_MAX_DEPTH = 100  # subcircuit nesting; deeper is surely a generated mistake
_NAN = float("nan")  # the value of an element whose value could not be evaluated


def build_circuit(deck: Deck, overrides: Mapping[str, float] | None = None,
                  thresholds: Mapping[str, float] | None = None) -> Circuit:
    """Evaluate, flatten and check a deck.

    Parameters
    ----------
    deck : Deck
        From :func:`netlist.parser.read_deck`.
    overrides : mapping of str to float, optional
        Global parameter values that replace the netlist's definitions.
    thresholds : mapping of str to float, optional
        Switch thresholds (V) of idealised transistors, by element or model name
        (:mod:`netlist.devices`).

    Raises
    ------
    NetlistError
        With all problems found, in file order (problems without a location last).
    """
    builder = _Builder(deck)
    builder.thresholds = dict(thresholds or {})
    circuit = builder.build(overrides or {})
    # Elements whose values failed are kept (with NaN values) so that the topology checks
    # see the whole circuit; only a subcircuit instance that could not be expanded leaves a
    # hole, and then connectivity problems would be artefacts of the hole.
    # (a circuit over the element limit is not expanded: nothing to check)
    diags = builder.diags + ([] if builder.too_large else check_circuit(
        circuit, builder.ref_locs, topology=not builder.incomplete))
    if diags:
        raise NetlistError(ordered_diagnostics(diags, deck.files), deck.file)
    return circuit


def independent_problems(deck: Deck, overrides: Mapping[str, float] | None = None
                         ) -> list[Diagnostic]:
    """Problems of a deck some statements of could not be read (missing from ``deck``):
    those a missing statement cannot cause or hide (bad values, expression errors other than
    unknown names, duplicate definitions, parameter cycles, malformed instances). Unknown
    parameters, models, subcircuits, controlling sources and connectivity wait for the syntax."""
    builder = _Builder(deck)
    circuit = builder.build(overrides or {})
    diags = [d for i, d in enumerate(builder.diags) if i not in builder.dependent]
    diags += [d for d in check_circuit(circuit, builder.ref_locs, topology=False)
              if d.message.startswith("duplicate element name")]
    return diags


class _Builder:
    def __init__(self, deck: Deck):
        self.deck = deck
        self.thresholds: dict[str, float] = {}  # idealised transistors' thresholds, V
        self._macros: dict = {}  # subcircuit name -> netlist.devices.Macro or None
        # subcircuit name -> {model name: its key in circuit.models} (models())
        self.local_models: dict[str, dict[str, str]] = {}
        self.diags: list[Diagnostic] = []
        self.ref_locs: dict[tuple[str, str], Location] = {}
        self.circuit = Circuit(title=deck.title, file=deck.file, files=tuple(deck.files))
        self.global_env: dict[str, float] = {}
        self.global_failed: set[str] = set()
        self.incomplete = False  # an instance could not be expanded
        self.too_large = False  # over the element limit: not expanded
        self.dependent: set[int] = set()  # indices in diags, see independent_problems
        self.temp, self.tnom = deck_temperatures(self)  # °C, the circuit's and nominal
        self.resistor_models: dict[str, Model] = {}  # (netlist.value_scaling)

    def error(self, message: str, loc: Location | None, hint: str = "",
              elements: tuple[str, ...] = (), dependent: bool = False) -> None:
        """Record a problem; ``dependent`` if a statement missing from the deck may cause it."""
        if dependent:
            self.dependent.add(len(self.diags))
        self.diags.append(Diagnostic(message, loc, hint, elements))

    def value_or_nan(self, value: Value, env: Mapping[str, float], failed: set[str]) -> float:
        v = self.evaluate(value, env, failed)
        return _NAN if v is None else v

    def evaluate(self, value: Value, env: Mapping[str, float], failed: set[str]) -> float | None:
        """The value of a number or expression; ``None`` after reporting a problem."""
        if value.number is not None:
            return value.number
        expr = value.expr
        if expr.names & failed:  # already reported where that parameter is defined
            return None
        try:
            return expr.evaluate(env)
        except ExpressionError as exc:
            hint = exc.hint
            if exc.message.startswith("unknown parameter"):
                name = exc.message.split("'")[1]
                close = close_matches(name, list(env))
                if close:
                    hint = f"did you mean {' or '.join(close)}? ({hint})"
            self.error(exc.message, value.st.loc(value.offset + exc.offset), hint,
                       dependent=exc.message.startswith("unknown parameter"))
            return None

    def scope(self, defs: list[RawParam], fixed: Mapping[str, float],
              parent: Mapping[str, float], parent_failed: set[str]
              ) -> tuple[dict[str, float], set[str]]:
        """Evaluate a set of parameter definitions in dependency order.

        Parameters
        ----------
        defs : list of RawParam
            Definitions of this scope.
        fixed : mapping
            Values that replace definitions (overrides); their names must be in ``defs``.
        parent : mapping
            The enclosing scope, for names not defined here.
        parent_failed : set of str
            Names of the enclosing scope that could not be evaluated (already reported).

        Returns
        -------
        (dict, set)
            The values of this scope, and the names that failed.
        """
        table: dict[str, RawParam] = {}
        for p in defs:
            first = table.get(p.name)
            if first is not None:
                self.error(f"parameter '{p.name}' is defined twice (first at line "
                           f"{first.loc.line})", p.loc,
                           "a parameter has one definition; override it with --param or "
                           "params: instead")
                continue
            table[p.name] = p
        values: dict[str, float] = dict(fixed)
        failed: set[str] = set()
        env = ChainMap(values, parent)
        state: dict[str, int] = {}
        path: list[str] = []

        def deps(name: str) -> list[str]:
            expr = table[name].value.expr
            return [] if expr is None else sorted(n for n in expr.names if n in table)

        def done(name: str) -> bool:
            return name in values or name in failed or state.get(name) == 2

        # each after the ones it uses, depth first without recursion (thousands may chain)
        for root in table:
            if done(root):
                continue
            state[root] = 1
            path.append(root)
            stack = [(root, iter(deps(root)))]
            while stack:
                name, pending = stack[-1]
                for dep in pending:
                    if done(dep):
                        continue
                    if state.get(dep) == 1:
                        cycle = path[path.index(dep):] + [dep]
                        self.error(f"parameter cycle: {' -> '.join(cycle)}",
                                   table[cycle[0]].loc, "parameters must not depend on "
                                   "themselves, directly or through others",
                                   tuple(dict.fromkeys(cycle)))
                        failed.update(cycle)
                        continue
                    state[dep] = 1
                    path.append(dep)
                    stack.append((dep, iter(deps(dep))))
                    break
                else:
                    stack.pop()
                    path.pop()
                    state[name] = 2
                    if name in failed:
                        continue
                    v = self.evaluate(table[name].value, env, failed | parent_failed)
                    if v is None:
                        failed.add(name)
                    else:
                        values[name] = v
        ordered = {name: values[name] for name in table if name in values}
        return ordered, failed | parent_failed

    # ------------------------------------------------------------------ the circuit

    def build(self, overrides: Mapping[str, float]) -> Circuit:
        deck, c = self.deck, self.circuit
        defined = {p.name for p in deck.top.params}
        fixed: dict[str, float] = {}
        for name, value in overrides.items():
            key = name.lower()
            if key not in defined:
                known = ", ".join(sorted(defined)) or "none"
                self.error(f"unknown parameter '{name}' in the overrides (--param)", None,
                           f"the netlist defines these global parameters: {known}", dependent=True)
            else:
                try:
                    number = float(value)
                except (TypeError, ValueError):
                    number = math.nan
                if not math.isfinite(number):
                    self.error(f"override of parameter '{name}' is not a finite number: "
                               f"{value!r}", None, "give a number, e.g. --param fs=100k")
                    continue
                fixed[key] = number
        self.global_env, self.global_failed = self.scope(deck.top.params, fixed, {}, set())
        c.params = dict(self.global_env)
        self.models()
        self.tran()
        evaluate_steps(self)
        c.options = dict(deck.options)
        c.ignored = list(deck.ignored)
        c.notes[:0] = list(deck.notes)
        if self.within_element_limit():
            self.expand(deck.top, "", "", None, self.global_env, self.global_failed, ())
            self.diags.extend(refused := resolve_comparators(c))
            self.incomplete |= bool(refused)  # (one refused leaves its output node a hole)
            if any(el.kind == "A" or hasattr(el, "mmf") for el in c.elements):  # (1 ms)
                self.diags.extend(import_module("netlist.magnetic_core").resolve_cores(
                    c, bool(self.diags)))
            if c.knees or c.replacements:  # (BJTs' base resistors, once the circuit is whole)
                self.diags.extend(import_module("netlist.base_drive").resolve_base_drives(c))
        return c

    def within_element_limit(self) -> bool:
        """Whether the expanded circuit stays within :data:`netlist.limits.ELEMENTS`,
        counted before expanding (per subcircuit once: nested instances multiply, and a few
        lines can ask for 2^25 elements); an error at the top-level instance that goes over
        it otherwise. An instance of an unknown subcircuit counts one (its error); a
        recursive one is reported here, once (the expansion would report it on every path to
        it)."""
        subckts = self.deck.subckts
        sizes: dict[str, int] = {}
        cycles: list[tuple[RawElement, tuple[str, ...]]] = []

        def size(body: Body, inside: tuple[str, ...]) -> int:
            n = 0
            scope = inside[-1] if inside else None
            for el in body.elements:
                key = self.deck.subckt_key(el.ref, scope) if el.kind == "X" else None
                if key is None:
                    n += 1  # (an unknown subcircuit: one error per instance path)
                elif key in inside:
                    # (found here once: the expansion would meet it on every path to it,
                    # 2^22 times in a fuzzed tree)
                    cycles.append((el, (*inside, key)))
                elif len(inside) < _MAX_DEPTH:
                    if key not in sizes:
                        # (the nesting depth is bounded by the subcircuits' count)
                        sizes[key] = size(subckts[key].body, (*inside, key))
                    n += sizes[key]
            return n

        try:
            limit = ELEMENTS.value()
        except ValueError as exc:
            self.error(str(exc), None, "unset it or give a number of elements")
            self.too_large = True
            return False
        total = 0
        for el in self.deck.top.elements:
            total += size(Body(elements=[el]), ())
            if cycles:
                inner, chain = cycles[0]
                self.error(f"subcircuit '{subckts[chain[-1]].name}' instantiates itself "
                           f"({' -> '.join(chain)})", inner.st.loc(inner.ref_offset),
                           "a subcircuit must not contain itself")
                self.too_large = True  # (not expanded)
                return False
            if total > limit:
                self.error(f"the circuit expands to more than {limit:.6g} elements (at "
                           f"instance {el.name}: {size(self.deck.top, ()):.6g} in all)",
                           el.st.loc(0), ELEMENTS.hint("1e6"))
                self.too_large = True
                return False
        return True

    def models(self) -> None:
        """``.model`` cards -> ``circuit.models``. A card inside a ``.subckt`` definition is
        local to it, as in ngspice: its elements see it before a global model of the same
        name, which the rest of the netlist keeps. It is stored under
        ``subckt:name`` (:meth:`model_key`), and under its own name as well when no other
        card has that name (a model written inside a subcircuit and named elsewhere)."""
        env, failed = self.global_env, self.global_failed
        names = Counter(m.name.lower() for m in self.deck.models)
        for m in self.deck.models:
            name = m.name.lower()
            key = name if m.scope is None else f"{m.scope}:{name}"
            loc = m.st.loc(0)
            if key in self.circuit.models or key in self.resistor_models:
                first = (self.circuit.models.get(key) or self.resistor_models[key]).location
                self.error(f"model '{m.name}' is defined twice (first at line {first.line})",
                           loc, "rename one of the models")
                continue
            params: dict[str, float] = dict(SW_DEFAULTS) if m.type == "SW" else {}
            for p in m.params:
                v = self.evaluate(p.value, env, failed)
                if v is not None:
                    params[p.name] = v
            # (a resistor model: read by the resistors that name it, not a device's model)
            models = self.resistor_models if m.type == "R" else self.circuit.models
            models[key] = model = Model(m.name, m.type, params, loc)
            if m.scope is not None:
                self.local_models.setdefault(m.scope, {})[name] = key
                if names[name] == 1:
                    models[name] = model

    def model_key(self, ref: str, scope: str | None) -> str:
        """The model an element of subcircuit ``scope`` (a key of ``deck.subckts``; None: the
        top level) names by ``ref``: its own, else one of a definition around it, else the
        global one."""
        while scope is not None:  # (the definition's own, then those around it)
            key = self.local_models.get(scope, {}).get(ref.lower())
            if key is not None:
                return key
            sub = self.deck.subckts.get(scope)
            scope = sub.parent if sub is not None else None
        return ref

    def tran(self) -> None:
        trans = self.deck.trans
        if not trans:
            return
        for extra in trans[1:]:
            self.error(f"second .tran (first at line {trans[0].st.loc(0).line})",
                       extra.st.loc(0), "pelcs runs one transient analysis: keep one .tran")
        t = trans[0]
        vals = [self.evaluate(v, self.global_env, self.global_failed) for v in t.values]
        if any(v is None for v in vals):
            return
        names = ["TSTEP", "TSTOP", "TSTART", "TMAX"]
        ok = True
        no_tstep = vals[0] == 0 and vals[1] > 0
        if no_tstep:
            # LTspice writes `.tran 0 TSTOP [TSTART [TMAX]]`: no print step
            tmax = vals[3] if len(vals) > 3 and vals[3] > 0 else None
            vals[0] = tmax if tmax is not None else vals[1] / 1000.0
            self.circuit.notes.append(
                f".tran TSTEP 0 (LTspice): the print interval taken as "
                f"{'TMAX' if tmax else 'TSTOP/1000'} = {vals[0]:g} s")
        for i, (name, v) in enumerate(zip(names, vals, strict=False)):
            if (v < 0 if name == "TSTART" else v <= 0):
                self.error(f".tran {name} must be {'>= 0' if i == 2 else 'positive'}, got "
                           f"{v:g}", t.values[i].loc, "syntax: .tran TSTEP TSTOP [TSTART "
                           "[TMAX]] [UIC], times in seconds")
                ok = False
        if ok and len(vals) > 2 and vals[2] >= vals[1]:
            self.error(f".tran TSTART ({vals[2]:g}) must be before TSTOP ({vals[1]:g})",
                       t.values[2].loc, "TSTART is when output starts; it must be < TSTOP")
            ok = False
        if ok:
            self.circuit.tran = Tran(vals[0], vals[1], vals[2] if len(vals) > 2 else 0.0,
                                     vals[3] if len(vals) > 3 else None, t.uic, no_tstep)

    def expand(self, body: Body, name_prefix: str, node_prefix: str,
               ports: dict[str, str] | None, env: Mapping[str, float], failed: set[str],
               stack: tuple[str, ...]) -> None:
        """Add the elements of one body (the top level or a subcircuit instance)."""
        glob = self.deck.globals

        if ports is None:
            def mapnode(n: str) -> str:
                return n
        else:
            def mapnode(n: str) -> str:
                if n == GROUND:
                    return n
                m = ports.get(n)
                if m is not None:
                    return m
                return n if n in glob else node_prefix + n

        ics = self.circuit.initial_conditions
        for ic in body.ics:
            v = self.evaluate(ic.value, env, failed)
            if v is None:
                continue
            node = mapnode(ic.node)
            if node in ics and not name_prefix:
                self.error(f".ic sets node '{node}' twice", ic.st.loc(ic.offset),
                           "give each node one initial voltage")
            ics[node] = v
            self.ref_locs.setdefault(("ic", node), ic.st.loc(ic.offset))

        scope = stack[-1] if stack else None
        for el in body.elements:
            if (el.kind in "DSMQW" or (el.kind == "R" and el.ref)) and self.local_models:
                key = self.model_key(el.ref, scope)
                if key != el.ref:
                    el = copy.copy(el)
                    el.ref = key
            if el.kind == "X":
                self.instance(el, name_prefix, node_prefix, mapnode, env, failed, stack)
            elif el.kind in "MQ":
                self.circuit.elements.extend(self.device(el, name_prefix, mapnode, env))
            elif el.behaviour is not None:  # B, C of a knee (.behavioural); R (.switched_resistor)
                refused = len(self.diags)
                self.circuit.elements += elaborate_resistor(
                    el, name_prefix, mapnode, env, self.circuit, self.error) if el.kind == "R" \
                    else elaborate(el, name_prefix, mapnode, env, failed, self.error)
                # (a refused element leaves a hole, as an instance not expanded does: no
                # connectivity checks, 'control node not connected')
                self.incomplete |= len(self.diags) > refused
                if el.note:
                    self.circuit.notes.append(f"{name_prefix}{el.name}: {el.note}")
            elif el.kind == "W":  # a current-controlled switch (netlist.current_switch)
                self.circuit.elements += self.current_switch(el, name_prefix, mapnode)
            elif el.kind == "A":  # an XSPICE code model (netlist.xspice)
                refused = len(self.diags)
                self.circuit.elements += xspice.elaborate_element(
                    el, name_prefix, mapnode, env, self.deck.code_models,
                    lambda v: self.evaluate(v, env, failed), self.circuit, self.error)
                self.incomplete |= len(self.diags) > refused
            else:
                self.circuit.elements.append(self.element(el, name_prefix, mapnode, env, failed))

    def current_switch(self, el: RawElement, prefix: str, mapnode: Callable[[str], str]
                       ) -> list:
        name = prefix + el.name
        (vname, v_at), = el.refs
        key, loc = name.lower(), el.st.loc(0)
        self.ref_locs[(f"{key}#i", "source")] = el.st.loc(v_at)
        self.ref_locs[(key, "model")] = el.st.loc(el.ref_offset)
        self.ref_locs[(key, "control")] = loc
        return current_switch.elaborate(
            name, tuple(map(mapnode, el.nodes)), mapnode(f"{el.name.lower()}#i"),
            prefix + vname, el.ref, el.state, loc, self.circuit,
            lambda message, hint: self.error(message, el.st.loc(el.ref_offset), hint, (name,)))

    def device(self, el: RawElement, prefix: str, mapnode: Callable[[str], str], env) -> list:
        """An M or Q element idealised: a switch, the VDMOS body diode (netlist.devices);
        ``env``: the parameters its W, L and m= read (netlist.devices.instance_geometry)."""
        # (imported by the circuits that have devices: 1 ms of the others' start)
        from .devices import Replacement, channel_checks, dropped_parts, gate_rc, threshold
        from .gate_charge import gate_law

        name = prefix + el.name if prefix else el.name
        loc, scope = el.st.loc(0), (env, self.deck.options)
        nodes = tuple(map(mapnode, el.nodes))
        model = self.circuit.models.get(el.ref.lower())
        want = ("NMOS", "PMOS", "VDMOS") if el.kind == "M" else ("NPN", "PNP")
        if model is None:
            self.error(f"{name}: unknown model '{el.ref}'", el.st.loc(el.ref_offset),
                       f"define it with .model {el.ref} {'/'.join(want)}(...)", (name,),
                       dependent=True)
            return []
        if model.type not in want:
            self.error(f"{name}: model '{el.ref}' is a {model.type} model, not "
                       f"{' or '.join(want)}", el.st.loc(el.ref_offset),
                       "use a model of the device's type", (name,))
            return []
        thr, source = threshold(name, model.name, model.type, model.params, self.thresholds)
        mt = model.type
        pchan = mt in ("PMOS", "PNP") or (mt == "VDMOS" and bool(model.params.get("pchan")))
        a, g, b = nodes[0], nodes[1], nodes[2]  # drain/collector, gate/base, source/emitter
        control = (b, g) if pchan else (g, b)
        sw_model = f"pelcs_sw_{name.lower().replace('.', '_')}"
        self.circuit.models[sw_model] = Model(sw_model, "SW", {**SW_DEFAULTS, "vt": thr}, loc)
        out: list = [Switch(name, (a, b), loc, control, sw_model, None,
                            device=(el.kind, nodes, el.ref if ":" in el.ref else model.name),
                            gate_rc=gate_rc(el, model, 0.0, scope=scope),
                            cgd_law=gate_law(el, model, g, a, scope))]
        self.circuit.knees += channel_checks(name, el, model, control, a, thr, loc, False,
                                             (self.temp, self.tnom), scope=scope)
        body = None
        if mt == "VDMOS":
            body = f"{name}_body"
            out.append(Diode(body, (a, b) if pchan else (b, a), loc, "", body_of=name))
        terms = ("drain", "source", "gate") if el.kind == "M" else ("collector", "emitter",
                                                                      "base")
        ctl = f"v({control[0]})" if control[1] == GROUND else f"v({control[0]},{control[1]})"
        became = (f"ideal switch {terms[0]} {a} - {terms[1]} {b}, on while {ctl} > {thr:g} V")
        self.circuit.replacements.append(Replacement(name, model.name, mt, became, thr, source,
                                                     body, dropped_parts(el.kind, mt, nodes),
                                                     loc))
        return out

    def macro(self, el: RawElement, sub, macro, name: str, port_map: Mapping[str, str],
              env: Mapping[str, float]) -> None:
        """A device macro-model instance as one ideal switch (and body diode) or one ideal
        diode between its ports (netlist.devices.classify_macro)."""
        from . import devices
        from .devices import Replacement, gate_rc, series_path, subckt_text, threshold
        from .gate_charge import GateDrainLaw, macro_gate_drain

        loc, scope = el.st.loc(0), (env, self.deck.options)
        ports = {p.lower(): n for p, n in port_map.items()}
        inst_nodes = tuple(port_map[p] for p in sub.ports)
        origin = ("X", inst_nodes, sub.name)
        self.circuit.subckt_texts[sub.name.lower()] = subckt_text(sub)
        if macro.kind == "diode":
            a, k = (ports[p] for p in macro.ports)
            models = tuple(self.model_key(e.ref, sub.key) for e in sub.body.elements
                           if e.kind == "D")
            # in series: the resistors on the junction's path to the ports (not a leakage
            # across them, NXP's 1N4148's 5.8 GΩ, nor a snubber's R + C across it)
            junction = next(e for e in sub.body.elements if e.kind == "D")
            series = sum(self._resistance(e) for e in series_path(
                sub.body.elements, junction.nodes[:2], [p.lower() for p in sub.ports]))
            self.circuit.elements.append(Diode(name, (a, k), loc, models[0],
                                               device=(*origin, models, series)))
            self.circuit.replacements.append(Replacement(
                name, sub.name, "diode macro-model", f"ideal diode {a} -> {k}", 0.0,
                "no threshold", None, macro.dropped, loc))
            return
        dev = macro.device
        model = self.circuit.models.get(self.model_key(dev.ref, sub.key).lower())
        want = ("NMOS", "PMOS", "VDMOS") if dev.kind == "M" else ("NPN", "PNP")
        if model is None or model.type not in want:
            self.error(f"{name}: the transistor {dev.name} of macro-model '{sub.name}' has no "
                       f"{'/'.join(want)} model '{dev.ref}'", dev.st.loc(dev.ref_offset),
                       "define the model inside the subcircuit or at the top level", (name,))
            return
        thr, source = threshold(name, model.name, model.type, model.params,
                                self.thresholds, also=(sub.name,))
        mt = model.type
        pchan = mt in ("PMOS", "PNP") or (mt == "VDMOS" and bool(model.params.get("pchan")))
        a, g, b = (ports[p] for p in macro.ports)
        control = (b, g) if pchan else (g, b)
        sw_model = f"pelcs_sw_{name.lower().replace('.', '_')}"
        self.circuit.models[sw_model] = Model(sw_model, "SW", {**SW_DEFAULTS, "vt": thr}, loc)
        series = sum(self._resistance(e) for e in sub.body.elements
                     if e.kind == "R" and set(e.nodes[:2]) & {dev.nodes[0], dev.nodes[2]}
                     and len(set(map(str.lower, e.nodes[:2])) & {p.lower() for p in
                                                                    sub.ports}) == 1)
        gate_port = next(p for p in sub.ports if p.lower() == macro.ports[1])
        rg = sum(self._resistance(e) for e in sub.body.elements if e.kind == "R"
                 and {n.lower() for n in e.nodes[:2]} == {gate_port.lower(),
                                                          dev.nodes[1].lower()})
        cgd, law = macro_gate_drain(sub, dev, self._resistance, lambda ref: self.circuit
                                    .models.get(self.model_key(ref, sub.key).lower()))
        law = GateDrainLaw(*law, g, a, -1.0 if pchan else 1.0) if law else None
        self.circuit.elements.append(Switch(name, (a, b), loc, control, sw_model, None,
                                            device=(*origin, model.name, series),
                                            gate_rc=gate_rc(dev, model, rg, cgd, scope),
                                            cgd_law=law))
        self.circuit.knees += devices.channel_checks(
            name, dev, model, control, a, thr, loc, macro.body is not None,
            (self.temp, self.tnom), macro.igbt, scope)
        body = None
        if macro.body is not None or mt == "VDMOS":
            body = f"{name}_body"
            an, ca = ((ports[macro.body[0]], ports[macro.body[1]]) if macro.body is not None
                      else ((a, b) if pchan else (b, a)))
            self.circuit.elements.append(Diode(body, (an, ca), loc, macro.body_model,
                                               body_of=name))
        terms = ("drain", "source") if dev.kind == "M" and not macro.igbt else (
            "collector", "emitter")
        ctl = f"v({control[0]})" if control[1] == GROUND else f"v({control[0]},{control[1]})"
        self.circuit.replacements.append(Replacement(
            name, f"{sub.name}: {dev.name} {model.name}",
            "IGBT-like macro-model" if macro.igbt else f"{mt} macro-model",
            f"ideal switch {terms[0]} {a} - {terms[1]} {b}, on while {ctl} > {thr:g} V",
            thr, source, body, macro.dropped, loc))

    def _resistance(self, el: RawElement) -> float:
        """A macro's resistor value (global parameters only; nan-free: 0 if unknown)."""
        v = self.evaluate(el.value, self.global_env, set()) if el.value is not None else None
        return float(v) if v is not None and math.isfinite(v) else 0.0

    def instance(self, el: RawElement, name_prefix: str, node_prefix: str,
                 mapnode: Callable[[str], str], env: Mapping[str, float], failed: set[str],
                 stack: tuple[str, ...]) -> None:
        st = el.st
        key = self.deck.subckt_key(el.ref, stack[-1] if stack else None) or el.ref.lower()
        sub = self.deck.subckts.get(key)
        if sub is None:
            known = ", ".join(s.name for s in self.deck.subckts.values()
                              if s.parent is None) or "none defined"
            self.error(f"unknown subcircuit '{el.ref}' in instance {name_prefix}{el.name}",
                       st.loc(el.ref_offset), f"define it with .subckt {el.ref} ... .ends "
                       f"(subcircuits: {known})", dependent=True)
            self.incomplete = True
            return
        if key in stack:
            chain = " -> ".join([*stack, key])
            self.error(f"subcircuit '{sub.name}' instantiates itself ({chain})",
                       st.loc(el.ref_offset), "a subcircuit must not contain itself")
            self.incomplete = True
            return
        if len(stack) >= _MAX_DEPTH:
            self.error(f"subcircuits nested more than {_MAX_DEPTH} levels deep at instance "
                       f"{name_prefix}{el.name}", st.loc(0), "flatten part of the hierarchy")
            self.incomplete = True
            return
        if len(el.nodes) != len(sub.ports):
            self.error(f"instance {el.name} connects {len(el.nodes)} node"
                       f"{'s' if len(el.nodes) != 1 else ''} but subcircuit '{sub.name}' has "
                       f"{len(sub.ports)} port{'s' if len(sub.ports) != 1 else ''} "
                       f"({' '.join(sub.ports)})", st.loc(0),
                       f"syntax: {el.name} <{len(sub.ports)} nodes> {sub.name} [params: ...]")
            self.incomplete = True
            return
        header = {p.name for p in sub.defaults}
        fixed: dict[str, float] = {}
        child_failed_extra: set[str] = set()
        for p in el.params:
            if p.name not in header:
                known = ", ".join(sorted(header)) or "none"
                self.error(f"subcircuit '{sub.name}' has no parameter '{p.name}'", p.loc,
                           f"its parameters (on the .subckt line): {known}")
                continue
            v = self.evaluate(p.value, env, failed)
            if v is None:
                child_failed_extra.add(p.name)
            else:
                fixed[p.name] = v
        values, child_failed = self.scope(sub.defaults + sub.body.params, fixed,
                                          self.global_env, self.global_failed)
        port_map = {port: mapnode(n) for port, n in zip(sub.ports, el.nodes, strict=True)}
        scope_env = ChainMap(values, self.global_env)
        if key not in self._macros:
            from .devices import classify_macro

            self._macros[key] = classify_macro(sub)
        macro = self._macros[key]
        if macro is not None:
            self.macro(el, sub, macro, f"{name_prefix}{el.name}", port_map, scope_env)
            return
        self.expand(sub.body, f"{name_prefix}{el.name}.", f"{node_prefix}{el.name.lower()}.",
                    port_map, scope_env, child_failed | child_failed_extra, (*stack, key))

    def element(self, el: RawElement, prefix: str, mapnode: Callable[[str], str],
                env: Mapping[str, float], failed: set[str]) -> Element:
        kind = el.kind
        st = el.st
        name = prefix + el.name if prefix else el.name
        loc = st.loc(0)
        nodes = tuple(map(mapnode, el.nodes))
        key = name.lower()
        if kind in "RLC":
            v = self.value_or_nan(el.value, env, failed)
            problem = value_problem(kind, v)
            if problem:
                self.error(f"{name}: {problem[0]}", el.value.loc, problem[1], (name,))
            m = multiplier(self, el, name, env, failed)
            # m elements in parallel, as ngspice: R/m, L/m, C*m
            v = v * m if kind == "C" else v / m
            v *= temperature_factor(self, el, name, env, failed)
            if kind == "R":
                return Resistor(name, nodes, loc, v)
            ic = None if el.ic is None else self.value_or_nan(el.ic, env, failed)
            cls = Inductor if kind == "L" else Capacitor
            return cls(name, nodes, loc, v, ic)
        if kind in "VI":
            dc = 0.0 if el.value is None else self.value_or_nan(el.value, env, failed)
            wave = None
            if el.wave is not None:
                wave = self.waveform(el.wave, env, failed, st)
            cls = VoltageSource if kind == "V" else CurrentSource
            return cls(name, nodes, loc, dc, wave)
        if kind == "D":
            self.ref_locs[(key, "model")] = st.loc(el.ref_offset)
            return Diode(name, nodes, loc, el.ref, area=multiplier(self, el, name, env, failed))
        if kind == "S":
            self.ref_locs[(key, "model")] = st.loc(el.ref_offset)
            self.ref_locs[(key, "control")] = st.loc(0)
            return Switch(name, nodes, loc, tuple(map(mapnode, el.control)), el.ref, el.state)
        if kind in "EG":
            gain = self.value_or_nan(el.value, env, failed)
            self.ref_locs[(key, "control")] = st.loc(0)
            cls = Vcvs if kind == "E" else Vccs
            return cls(name, nodes, loc, tuple(map(mapnode, el.control)), gain)
        if kind in "FH":
            gain = self.value_or_nan(el.value, env, failed)
            self.ref_locs[(key, "source")] = st.loc(el.ref_offset)
            cls = Cccs if kind == "F" else Ccvs
            return cls(name, nodes, loc, prefix + el.ref, gain)
        if kind == "K":
            k = self.value_or_nan(el.value, env, failed)
            problem = value_problem("K", k)
            if problem:
                self.error(f"{name}: {problem[0]}", el.value.loc, problem[1], (name,))
            (l1, o1), (l2, o2) = el.refs
            self.ref_locs[(key, "inductor0")] = st.loc(o1)
            self.ref_locs[(key, "inductor1")] = st.loc(o2)
            return Coupling(name, (), loc, (prefix + l1, prefix + l2), k)
        raise AssertionError(f"element kind {kind}")  # the reader accepts no other kind

    def waveform(self, wave: tuple[str, list[Value], int, dict], env: Mapping[str, float],
                 failed: set[str], st: Statement) -> Signal | None:
        """The transient waveform; ``None`` after reporting a problem."""
        kind, args, offset, extras = wave
        vals = [self.evaluate(a, env, failed) for a in args]
        if any(v is None for v in vals):
            return None
        if kind == "pwl":
            times, values = tuple(vals[0::2]), tuple(vals[1::2])
            for i in range(1, len(times)):
                if times[i] < times[i - 1]:
                    self.error(f"PWL time {times[i]:g} s comes before the previous time "
                               f"{times[i - 1]:g} s", args[2 * i].loc,
                               "PWL points are (time, value) pairs in increasing time")
                    return None
            if times[0] < 0:
                self.error(f"PWL starts at a negative time {times[0]:g} s", args[0].loc,
                           "times are >= 0")
                return None
            more = {}
            for key, (val, pos) in extras.items():
                v = self.evaluate(val, env, failed)
                if v is None:
                    return None
                more[key] = (v, pos)
            repeat = None
            if "r" in more and more["r"][0] >= -0.5:  # ngspice: r = -1 repeats nothing
                repeat, pos = more["r"]
                if repeat not in times or repeat >= times[-1]:
                    self.error(f"PWL r={repeat:g} s is not one of its times before the last "
                               f"({times[-1]:g} s)", st.loc(pos),
                               "r= names the time of the point the repetition starts from "
                               "(r=0: the whole waveform)")
                    return None
            delay = more["td"][0] if "td" in more else 0.0
            return Pwl(times, values, repeat, delay)
        if kind == "pulse":
            sig = Pulse(*vals)
            fields = ["V1", "V2", "TD", "TR", "TF", "PW", "PER", "NP"]
            for i in range(3, len(vals)):
                if vals[i] < 0:
                    self.error(f"PULSE {fields[i]} must not be negative, got {vals[i]:g}",
                               args[i].loc, "syntax: PULSE(V1 V2 TD TR TF PW PER [NP])")
                    return None
            return sig
        if kind == "sin":
            if len(vals) > 2 and vals[2] < 0:
                self.error(f"SIN frequency must not be negative, got {vals[2]:g}", args[2].loc,
                           "syntax: SIN(VO VA FREQ TD THETA PHASE), FREQ in Hz")
                return None
            return Sin(*vals)
        if kind == "exp":
            for i in (3, 5):
                if len(vals) > i and vals[i] < 0:
                    self.error(f"EXP time constant must not be negative, got {vals[i]:g}",
                               args[i].loc, "syntax: EXP(V1 V2 TD1 TAU1 TD2 TAU2)")
                    return None
            return Exp(*vals)
        return modulated(kind, vals)  # SFFM, AM
