"""Circuit -> switched linear complementarity system (one LCS per switch configuration).

For one configuration of the ideal switches (on = short, off = open) the circuit becomes::

    x' = A x + B λ + E u
    w  = C x + D λ + F u,        0 <= w ⊥ λ >= 0

with the states ``x`` (inductor currents ``i(L)``, A, and capacitor voltages ``v(C)``, V, in
netlist order), one complementarity pair per ideal diode and the independent sources ``u``
(V in volts, I in amperes, netlist order).

Method (modified nodal analysis of a resistive companion network). In each mode

- a capacitor becomes a voltage source of value ``x_C``, an inductor a current source ``x_L``;
- a diode whose λ is its current becomes a current source ``λ`` (anode -> cathode), and its
  ``w`` is the reverse voltage ``v(k) - v(a)``; a diode whose λ is its reverse voltage becomes
  a voltage source ``v(a) - v(k) = -λ``, and its ``w`` is its current;
- a closed switch becomes a 0 V source, an open switch is dropped;
- resistors, independent and controlled sources stay what they are.

The MNA equations ``M z = K ξ`` (``z`` node voltages and branch currents, ``ξ = (x, λ, u)``)
are solved for the linear map ``z = Z ξ`` by a pseudo-inverse, so a part of the circuit that
floats in some mode (a node reached only through an open switch) does no harm as long as
everything the dynamics needs is uniquely determined; that is checked against the null space
of ``M`` (a part held only by a very large resistor, regular at double precision, is solved
whole: :data:`netlist.mna_solve.ROUNDOFF_RTOL`). Then ``dv_C/dt = i_C / C``,
``Lmat di_L/dt = v_L`` (``Lmat`` holds the mutual inductances ``k sqrt(L1 L2)`` of K elements)
and the ``w`` rows are read off.

What λ stands for, per diode and mode, is chosen so that this works: λ = current is
preferred; with at most :data:`EXHAUSTIVE_DIODE_LIMIT` diodes every assignment is tried in the
order "fewest voltage-type diodes first, then earlier diodes (netlist order) voltage-type
first" until the companion network is solvable and determines every needed quantity; with
more diodes a normal-tree assignment is tried and then improved greedily.

Degenerate modes (a loop of capacitors / voltage sources / closed switches / E, H sources, a
cutset of inductors / current sources / F, G sources, ``k = 1`` coupling) are rejected with a
:class:`~netlist.errors.NetlistError` that names the elements and the switch configuration.
Two such loops and cutsets never reach it, made regular when the netlist is read: capacitors
from one node to nodes that voltage sources join (:mod:`netlist.capacitor_loops`, one state
for them) and inductors that are the only branches from a floating group of voltage sources
(:mod:`netlist.inductor_cutsets`, the group's potential held by E sources). Capacitors
without a state: :mod:`netlist.reductions`, :mod:`netlist.capacitor_links`.
One cutset is not degenerate: an uncoupled inductor that no other branch parallels in a mode
carries no current there. In every mode when nothing else joins its terminals
(:func:`netlist.reductions.open_inductors`, e.g. one end unconnected); in the modes whose open
switches leave it so (in series with a switch). It keeps its state ``i(L)``, pinned at zero in
those modes (:attr:`lcs.model.ModeModel.pinned`): the MNA takes it for a 0 V branch (whose
current Kirchhoff's law makes zero, and whose voltage is that of ``L di/dt`` with
``di/dt = 0``, as in ngspice), and its state has no dynamics there. Entering such a mode with
a current, an ideal switch cuts it to zero at once: the run applies that jump and notes the
energy ``½ L i²`` lost (:mod:`lcs.simulation.driver`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator, Sequence
from functools import cached_property

import numpy as np

from lcs.model import (
    IDEALISED_OPTION,
    LAMBDA_CURRENT,
    LAMBDA_VOLTAGE,
    LCS,
    OPERATING_POINT_OPTION,
    TERMINALS_OPTION,
    ComplementarityPair,
    ModeKey,
    ModeModel,
    OutputMap,
    SwitchControl,
    SwitchedLCS,
)
from lcs.network import NetworkRealisation

from .capacitor_links import capacitor_links, linked_builder
from .circuit import GROUND, Circuit, Element
from .degenerate import CURRENT_KINDS as _CURRENT_KINDS
from .degenerate import check_topology, pinnable_inductors, pinned_in
from .devices import amplifier_hint
from .errors import Diagnostic, NetlistError
from .mna import VOLTAGE_KINDS as _VOLTAGE_KINDS
from .mna import Mna as _Mna
from .mna import Stamps, coalesce, dense_form
from .mna_solve import Entries, Solution, clean
from .perfect_coupling import transformer_sources
from .probes import PROBE, TWO_TERMINAL
from .pwl import vf_offsets
from .reductions import held_capacitors, open_inductors, reduced
from .suggest import did_you_mean, short_list
from .topology import Partition, SwitchedBridges, UnionFind

__all__ = ["formulate", "storage_matrix", "EXHAUSTIVE_DIODE_LIMIT"]

# With up to this many diodes every λ-type assignment may be tried (2**m MNA solves).
EXHAUSTIVE_DIODE_LIMIT = 12


_KNOWN_KINDS = TWO_TERMINAL | {"K"}


def formulate(circuit: Circuit) -> SwitchedLCS:
    """The switched LCS of a flattened circuit; modes are built lazily on first use.

    Only cheap, mode-independent checks run here (element values, references of F/H/K
    elements and switch models, the inductance matrix); each switch configuration is
    formulated, and its topology checked, when it is first asked for.

    Parameters
    ----------
    circuit : Circuit
        A flattened circuit (no subcircuits, parameters evaluated).

    Returns
    -------
    SwitchedLCS
        States ``i(L…)``/``v(C…)`` in netlist order, inputs the V and I sources, one
        complementarity pair per diode, switches with their ``.model`` thresholds; the
        builder returns a :class:`~lcs.model.ModeModel` whose ``output(probes)`` maps probe
        strings (``v(n)``, ``v(a,b)``, ``i(X)``, state names) to ``y = Cy x + Dy λ + Fy u``.

    Notes
    -----
    Probes are case-insensitive; ``gnd`` is ground. ``i(X)`` works for every two-terminal
    element (R L C D S V I E F G H) and flows from n+ through X to n- (anode to cathode for a
    diode; zero for an open switch). ``v(C1)`` is the node voltage if a node ``c1`` exists
    (as in SPICE), else the state ``v(C1)``. A probe of a quantity that is not determined in
    the mode (a floating part of the circuit) raises :class:`NetlistError`.

    Raises
    ------
    NetlistError
        For invalid element values or references, or a singular inductance matrix; later,
        when a mode is built, for a degenerate topology in that mode.
    """
    formulator = _formulator(circuit)
    return SwitchedLCS(
        switches=formulator.switch_controls,
        states=formulator.state_names,
        inputs=formulator.input_names,
        diodes=[d.name for d in formulator.diodes], builder=formulator.builder,
        pinnable=sorted(formulator.state_index[k] for k in formulator.pinnable),
        storage=_storage(formulator), offsets=vf_offsets(formulator.diodes, formulator.input_names),
        shadowed=[f"v({c.key})" for c in formulator.capacitors if c.key in formulator.node_index])


def storage_matrix(circuit: Circuit) -> np.ndarray:
    """The circuit's stored-energy matrix in the formulation's state order.

    ``½ x' K x`` is the energy (J) stored in the inductors (including mutual inductances of K
    couplings) and capacitors, for ``x`` ordered as :attr:`SwitchedLCS.states` of
    :func:`formulate` (netlist order, inductors and capacitors interleaved). It is the usual
    storage-function candidate for a passivity check (``lcs.theory.passivity.check_passivity(lcs,
    energy=K)``).

    Returns
    -------
    ndarray, shape (n, n)
        Symmetric; H on inductor rows/columns, F on capacitor ones. A capacitor that
        :func:`formulate` leaves out (across sources only) has no row.
    """
    return _storage(_formulator(circuit))


def _formulator(circuit: Circuit) -> _Formulator:
    """The formulator of the circuit without what :func:`netlist.reductions.reduced` leaves
    out (``v(C)`` still their voltage; links: :func:`~netlist.capacitor_links.linked_builder`)."""
    held = held_capacitors(circuit)
    links = capacitor_links(circuit, held)
    f = _Formulator(reduced(circuit, held, links))
    f.held_nodes = {key: x.nodes for key, x in (*held.items(), *links.items())}
    f.builder = linked_builder(f.build_mode, links, f.state_index, f.by_key, f.n)
    return f


def _storage(f: _Formulator) -> np.ndarray:
    """:func:`storage_matrix` of a circuit's formulator."""
    K = np.zeros((f.n, f.n))
    rows = [f.state_index[el.key] for el in f.inductors]
    K[np.ix_(rows, rows)] = f.Lmat
    for el in f.capacitors:
        K[f.state_index[el.key], f.state_index[el.key]] = float(el.value)
    return getattr(f.builder, "storage", lambda k: k)(K)


def _error(message: str, hint: str = "", elements: Sequence[str] = (), el: Element | None = None,
           file: str | None = None) -> NetlistError:
    location = el.location if el is not None else None
    return NetlistError(
        Diagnostic(message=message, location=location, hint=hint, elements=tuple(elements)),
        file=file,
    )


class _Formulator:
    """Mode-independent bookkeeping of one circuit, and the per-mode builder."""

    def __init__(self, circuit: Circuit):
        self.circuit = circuit
        self.file = circuit.file
        diagnostics: list[Diagnostic] = []

        def bad(message: str, el: Element | None, hint: str = "",
                elements: Sequence[str] | None = None) -> None:
            if elements is None:
                elements = (el.name,) if el is not None else ()
            diagnostics.append(Diagnostic(
                message=message, location=el.location if el is not None else None, hint=hint,
                elements=tuple(elements)))

        self.elements: list[Element] = []
        self.by_key: dict[str, Element] = {}
        for el in circuit.elements:
            if el.kind not in _KNOWN_KINDS:
                bad(f"element {el.name}: kind {el.kind!r} cannot be formulated", el,
                    "pelcs handles R L C V I D S E F G H K elements")
                continue
            if el.key in self.by_key:
                bad(f"duplicate element name {el.name}", el, "element names must be unique "
                    "(case-insensitive)")
                continue
            if el.kind in TWO_TERMINAL and len(el.nodes) != 2:
                bad(f"element {el.name} needs 2 nodes, has {len(el.nodes)}", el)
                continue
            self.by_key[el.key] = el
            self.elements.append(el)
        self.two_terminal = [el for el in self.elements if el.kind in TWO_TERMINAL]
        self._controlled = any(el.kind in "EFGH" for el in self.elements)

        for el in self.two_terminal:
            value = getattr(el, "value", None)
            if el.kind == "R" and (value is None or value == 0 or not math.isfinite(value)):
                bad(f"resistor {el.name} has resistance {value}", el,
                    "a short is a 0 V source or a closed switch; use a nonzero finite value")
            if el.kind in "LC" and (value is None or not (value > 0) or not math.isfinite(value)):
                what = "inductance" if el.kind == "L" else "capacitance"
                bad(f"{el.name} has {what} {value}; it must be positive and finite", el)
            if el.kind in "EFGH" and not math.isfinite(el.gain):
                bad(f"controlled source {el.name} has gain {el.gain}", el)
            if el.kind in "FH":
                ctrl = self.by_key.get(el.source.lower()) if el.source else None
                if ctrl is None or ctrl.kind != "V":
                    volts = [c.name for c in self.elements if c.kind == "V"]
                    bad(f"{el.name}: controlling source {el.source!r} is not a voltage source",
                        el, "F and H sources sense the current of a V source; add a 0 V source "
                        "in series with the branch to sense" + (
                            f" (voltage sources: {', '.join(volts)})" if volts else ""))

        # Names, in netlist order.
        self.state_elements = [el for el in self.two_terminal if el.kind in "LC"]
        self.state_names = [
            f"i({el.name})" if el.kind == "L" else f"v({el.name})" for el in self.state_elements
        ]
        self.state_index = {el.key: i for i, el in enumerate(self.state_elements)}
        self.input_elements = [el for el in self.two_terminal if el.kind in "VI"]
        self.input_names = [el.name for el in self.input_elements]
        self.input_index = {el.key: i for i, el in enumerate(self.input_elements)}
        self.diodes = [el for el in self.two_terminal if el.kind == "D"]
        self.diode_index = {el.key: i for i, el in enumerate(self.diodes)}
        self.switches = [el for el in self.two_terminal if el.kind == "S"]
        self.inductors = [el for el in self.two_terminal if el.kind == "L"]
        # Inductors whose current Kirchhoff's law holds at zero in every mode: 0 V branches
        # of the MNA, states without dynamics (see the module docstring).
        self.pinned = frozenset(open_inductors(circuit))
        self._transformer = transformer_sources(circuit)  # (E, F imposing nothing)
        self.live_inductors = [el for el in self.inductors if el.key not in self.pinned]
        # ... and those that open switches may leave so (set with the switch controls below)
        self.pinnable: frozenset[str] = frozenset()
        self.capacitors = [el for el in self.two_terminal if el.kind == "C"]
        self.n = len(self.state_elements)
        self.m = len(self.diodes)
        self.p = len(self.input_elements)
        self.nxi = self.n + self.m + self.p

        nodes: dict[str, None] = {}
        for el in self.two_terminal:
            for node in (*el.nodes, *getattr(el, "control", ())):
                nodes.setdefault(node, None)
        nodes.pop(GROUND, None)
        self.nodes = list(nodes)
        self.node_index = {node: i for i, node in enumerate(self.nodes)}

        self.switch_controls = []
        for sw in self.switches:
            params: dict[str, float] = {}
            if sw.model:
                model = circuit.models.get(sw.model.lower())
                if model is None:
                    bad(f"switch {sw.name}: unknown model {sw.model!r}", sw,
                        "add a `.model NAME SW(VT=... VH=...)` line")
                else:
                    params = {k.lower(): v for k, v in model.params.items()}
            (ncp, ncm), (na, nb) = sw.control, sw.nodes[:2]
            options: dict = params | ({} if sw.initial is None else {"initial": sw.initial})
            if sw.device is not None or sw.strict:
                options[IDEALISED_OPTION] = True
            dc = {OPERATING_POINT_OPTION: True} if circuit.tran and not circuit.tran.uic else {}
            options |= {TERMINALS_OPTION: f"v({na},{nb})", **dc}  # (terminals: ROFF, cuts)
            self.switch_controls.append(SwitchControl(
                name=sw.name, control=f"v({ncp},{ncm})", vt=float(params.get("vt", 0.0)),
                vh=float(params.get("vh", 0.0)), options=options))

        if self.switches and self.inductors:
            self.pinnable = pinnable_inductors(self)
        # What each probe asked for names (probe -> ("v", node, node) or ("i", element)).
        self._probes: dict[str, tuple] = {}
        # the terminals of the capacitors :func:`formulate` left out, by key
        self.held_nodes: dict[str, tuple[str, str]] = {}
        self.builder = self.build_mode
        self.Lmat = np.zeros((0, 0))  # set by _inductance_inverse
        self.Linv = self._inductance_inverse(bad)
        if diagnostics:
            raise NetlistError(diagnostics, file=self.file)

    # -- inductance matrix -------------------------------------------------------------

    def _inductance_inverse(self, bad) -> np.ndarray:
        """Inverse of the inductance matrix ``Lmat`` (1/H), inductors in netlist order.

        ``Lmat[i, i] = L_i``, ``Lmat[i, j] = k sqrt(L_i L_j)`` for a K element coupling the
        two (dot at each inductor's n+). Must be positive definite: ``|k| = 1`` (no leakage)
        or mutually inconsistent couplings make the inductor currents dependent.
        """
        nl = len(self.inductors)
        index = {el.key: i for i, el in enumerate(self.inductors)}
        lmat = np.diag([float(el.value) for el in self.inductors]) if nl else np.zeros((0, 0))
        couplings: dict[tuple[int, int], Element] = {}
        ok = True
        for kel in (el for el in self.elements if el.kind == "K"):
            names = tuple(kel.inductors)
            idx = [index.get(str(name).lower()) for name in names]
            if len(names) != 2 or None in idx:
                bad(f"coupling {kel.name} refers to {', '.join(map(str, names))}, which are not "
                    "two inductors of the circuit", kel)
                ok = False
                continue
            i, j = idx
            if i == j:
                bad(f"coupling {kel.name} couples {names[0]} with itself", kel)
                ok = False
                continue
            pair = (min(i, j), max(i, j))
            if pair in couplings:
                bad(f"coupling {kel.name} repeats the coupling {couplings[pair].name} of "
                    f"{names[0]} and {names[1]}", kel)
                ok = False
                continue
            k = float(kel.k)
            if not math.isfinite(k):
                bad(f"coupling {kel.name} has k = {k}", kel)
                ok = False
                continue
            couplings[pair] = kel
            mutual = k * math.sqrt(lmat[i, i] * lmat[j, j])
            lmat[i, j] = lmat[j, i] = mutual
        self.Lmat = lmat
        if not ok or nl == 0 or not couplings or not np.all(np.isfinite(lmat)):
            with np.errstate(divide="ignore"):
                diag = np.diag(lmat).copy() if nl else np.zeros(0)
                diag[~(diag > 0)] = 1.0  # invalid values were reported above
            return np.diag(1.0 / diag) if nl else np.zeros((0, 0))
        # Scale to unit diagonal so the test is on the coupling coefficients alone.
        d = 1.0 / np.sqrt(np.diag(lmat))
        eig, vec = np.linalg.eigh(d[:, None] * lmat * d[None, :])
        if eig[0] <= 1e-9:
            weak = vec[:, 0]
            involved = [self.inductors[i] for i in np.flatnonzero(np.abs(weak) > 1e-3)]
            keys = {el.key for el in involved}
            ks = [kel for (i, j), kel in couplings.items()
                  if self.inductors[i].key in keys and self.inductors[j].key in keys]
            diagnostics_el = ks[0] if ks else None
            bad(f"coupled inductors {', '.join(el.name for el in involved)} have a "
                f"{'singular' if abs(eig[0]) <= 1e-9 else 'indefinite'} inductance matrix "
                f"(couplings {', '.join(k.name for k in ks)})", diagnostics_el,
                "|k| = 1 makes the currents dependent (a pair coupled to nothing else is an "
                "ideal transformer to pelcs); use |k| < 1 (0.999: a leakage inductance)",
                [k.name for k in ks] + [el.name for el in involved])
            return np.diag(1.0 / np.diag(lmat))
        return np.linalg.inv(lmat)

    @cached_property
    def stamps(self) -> Stamps:
        """Every element's MNA terms, for any mode (:class:`~netlist.mna.Stamps`)."""
        return Stamps(self)

    # -- topology of the switch modes -------------------------------------------------
    # Modes differ only in their closed switches: the rest's components and bridges are found once.

    @cached_property
    def _voltage_partition(self) -> Partition:
        """Components of the voltage-defined branches (V C E H) but switches, transformers' E."""
        return Partition([tuple(el.nodes[:2]) for el in self.two_terminal if el.key in self.pinned
                          or el.kind in _VOLTAGE_KINDS and el.key not in self._transformer])

    @cached_property
    def _tree_partition(self) -> Partition:
        """Components of those and the resistors (a normal tree's first branches)."""
        return Partition([tuple(el.nodes[:2]) for el in self.two_terminal
                          if el.kind in _VOLTAGE_KINDS or el.kind == "R"
                          or el.key in self.pinned])

    @cached_property
    def _current_bridges(self) -> SwitchedBridges:
        """Bridges of the branches that carry current (all but the open switches); the
        diodes are the fixed edges ``k0 ..``, ``k0 = len(fixed) - m``."""
        fixed = [tuple(el.nodes[:2]) for el in self.two_terminal
                 if el.kind != "S" and el.kind != "D"]
        return SwitchedBridges(fixed + [tuple(d.nodes[:2]) for d in self.diodes],
                               [tuple(sw.nodes[:2]) for sw in self.switches])

    @cached_property
    def _cutset_bridges(self) -> SwitchedBridges:
        """Bridges of the branches that are not current-defined (and not open switches);
        the diodes last, as in :attr:`_current_bridges`."""
        fixed = [tuple(el.nodes[:2]) for el in self.two_terminal if el.kind not in "DS" and (
            el.kind not in _CURRENT_KINDS or el.key in self.pinned | self._transformer)]
        return SwitchedBridges(fixed + [tuple(d.nodes[:2]) for d in self.diodes],
                               [tuple(sw.nodes[:2]) for sw in self.switches])

    def _closed(self, on: frozenset[str]) -> list[int]:
        """Indices of the closed switches."""
        return [j for j, sw in enumerate(self.switches) if sw.key in on]

    def _closed_edges(self, on: frozenset[str]) -> list[tuple[str, str]]:
        """The closed switches' (node, node) edges."""
        return [tuple(self.switches[j].nodes[:2]) for j in self._closed(on)]

    def _diode_bridges(self, graph: SwitchedBridges, on: frozenset[str]) -> list[int]:
        """Indices of the diodes that are bridges of ``graph`` in mode ``on``."""
        cut = graph.bridges(self._closed(on))
        k0 = graph.size - self.m
        return [i for i in range(self.m) if k0 + i in cut]

    def _voltage_loop(self, on: frozenset[str]) -> bool:
        """Whether the voltage-defined branches of the mode (V C E H and closed switches)
        close a loop (what :meth:`_check_topology` reports first)."""
        partition = self._voltage_partition
        return partition.has_cycle or partition.joined(self._closed_edges(on))[1]

    # -- one mode ----------------------------------------------------------------------

    def describe(self, on: frozenset[str]) -> str:
        return ", ".join(
            f"{sw.name}={'on' if sw.key in on else 'off'}" for sw in self.switches)

    def build_mode(self, key: ModeKey) -> ModeModel:
        """Formulate one switch configuration (``key[i]`` True = switch i closed)."""
        if len(key) != len(self.switches):
            raise ValueError(f"mode key needs {len(self.switches)} entries, got {len(key)}")
        on = frozenset(sw.key for sw, closed in zip(self.switches, key, strict=True) if closed)
        desc = self.describe(on)
        # (from here on, `on` also holds the inductors the mode pins: 0 V branches, as the
        # closed switches)
        pins = pinned_in(self, on)
        on = on | pins
        if self._voltage_loop(on):
            # (the search below would fail, or find a singular matrix, and this be reported:
            # a 64-cell MMC arm's shoot-through took 0.12 s, an SVD, to get there)
            self._check_topology(on, desc)
        # A loop of voltage-defined branches or a cutset of current-defined ones makes the MNA
        # matrix singular (its branch or KCL rows sum to zero): with a regular matrix and no
        # controlled source (whose gains can keep such a loop regular) the check cannot fail,
        # and is skipped (0.4 ms a mode on a 64-cell MMC arm). Otherwise it runs first, so
        # that its message, not the λ-type search's, names the degeneracy.
        try:
            mna, sol = self._choose_diode_types(on, desc)
        except NetlistError as exc:
            self._check_topology(on, desc)
            exc.file = exc.file or self.file  # (the solver's own errors name no file)
            raise
        if sol.null.shape[1] or self._controlled:
            self._check_topology(on, desc)
        n, m = self.n, self.m
        shorted = self._shorted(on)
        isolated = self._isolated(on)
        network = None
        if not sol.null.shape[1]:
            # (built when asked for: the sparse kernel needs it, the dense one does not; 1-2
            # ms a mode on a 64-cell MMC arm)
            def network():
                return self._network(mna, shorted, isolated, pins)
        dx = np.zeros((n, self.nxi))
        if self.capacitors:
            i_c = sol.evaluate_terms([mna._current_terms(el) for el in self.capacitors])
            rows = [self.state_index[el.key] for el in self.capacitors]
            dx[rows] = i_c / np.array([float(el.value) for el in self.capacitors])[:, None]
        live = [a for a, el in enumerate(self.inductors) if el.key not in pins]
        if live:
            # (a pinned inductor has no dynamics: its row stays zero; it is uncoupled, so
            # the live inductors' block of Linv is the inverse of theirs of Lmat)
            v_l = sol.evaluate_terms([mna._voltage_terms(*self.inductors[a].nodes[:2])
                                      for a in live])
            rows = [self.state_index[self.inductors[a].key] for a in live]
            dx[rows] = self.Linv[np.ix_(live, live)] @ v_l
        w = sol.evaluate_terms([mna.w_terms(d) for d in self.diodes])
        if not (np.all(np.isfinite(dx)) and np.all(np.isfinite(w))):
            raise _error(f"switch mode {desc or '(no switches)'}: the LCS matrices overflow "
                         "(values beyond 1e308)",
                         "an element value of extreme magnitude (e.g. L = 1e-308 H): check "
                         "the values and their units", file=self.file)
        dx, w = clean(dx), clean(w)
        # A diode shorted by closed switches (e.g. a switch's antiparallel diode while it
        # conducts) has w = 0 identically; its row is round-off of the elimination, whose
        # sign would make the step's LCP infeasible (w < 0 that no λ can lift).
        w[shorted] = 0.0
        pairs = tuple(
            ComplementarityPair(d.name, LAMBDA_VOLTAGE if d.key in mna.vdiodes else LAMBDA_CURRENT)
            for d in self.diodes
        )
        # A diode that only open switches connect to the rest (in series with an open
        # switch) carries no current: its w (the current, λ its reverse voltage) is zero
        # identically, and the elimination's round-off there (1e-16 with either sign) would
        # read as a non-passive D.
        for i in isolated:
            if pairs[i].lam == LAMBDA_VOLTAGE:
                w[i] = 0.0
        lcs = LCS(
            A=dx[:, :n], B=dx[:, n:n + m], E=dx[:, n + m:],
            C=w[:, :n], D=w[:, n:n + m], F=w[:, n + m:],
            states=tuple(self.state_names), pairs=pairs, inputs=tuple(self.input_names),
        )

        def output(probes: Sequence[str]) -> OutputMap:
            names = tuple(probes)
            forms = []
            for probe in names:
                form = self._probe_terms(mna, probe)
                # (with no null space every quantity is determined)
                if sol.null.shape[1] and not sol.determined(dense_form(form, mna.nz)):
                    raise _error(
                        f"probe {probe} is not determined with {desc or 'this circuit'}",
                        "part of the circuit floats in this configuration (e.g. a node reached "
                        "only through an open switch, or with no path to ground); probe a "
                        "quantity that does not depend on it",
                        file=self.file)
                forms.append(form)
            y = clean(sol.evaluate_forms(forms, mna.width))
            return OutputMap(names=names, Cy=y[:, :n], Dy=y[:, n:n + m], Fy=y[:, n + m:])

        return ModeModel(lcs=lcs, output=output, network=network,
                         pinned={self.state_index[k]: float(self.by_key[k].value)
                                 for k in sorted(pins, key=lambda k: self.state_index[k])})

    def _network(self, mna: _Mna, shorted: list[int], isolated: list[int],
                 pins: frozenset[str]) -> NetworkRealisation:
        """The sparse network of a mode whose MNA matrix is regular: ``Y z = S ξ``, the
        state derivatives ``Rx z`` and the pairs' ``w`` ``Rw z`` (:mod:`lcs.network`)."""
        nz = mna.nz
        Y = tuple(np.ascontiguousarray(a) for a in mna.entries)
        S = tuple(np.ascontiguousarray(a) for a in mna.K_entries)
        xr: list[int] = []
        xc: list[int] = []
        xv: list[float] = []
        for el in self.capacitors:
            i = self.state_index[el.key]
            for c, v in mna._current_terms(el):
                xr.append(i)
                xc.append(c)
                xv.append(v / float(el.value))
        if self.inductors:
            index = [self.state_index[el.key] for el in self.inductors]
            for a, el in enumerate(self.inductors):
                if el.key in pins:
                    continue  # (no dynamics; uncoupled, so no other inductor's either)
                for c, v in mna._voltage_terms(*el.nodes[:2]):
                    for b in np.flatnonzero(self.Linv[:, a]):
                        xr.append(index[b])
                        xc.append(c)
                        xv.append(self.Linv[b, a] * v)
        wr: list[int] = []
        wc: list[int] = []
        wv: list[float] = []
        for i, d in enumerate(self.diodes):
            for c, v in mna.w_terms(d):
                wr.append(i)
                wc.append(c)
                wv.append(v)
        if any(c >= nz for c in xc + wc):  # pragma: no cover
            raise AssertionError("a derivative or w form names a source directly")
        Rx, Rw = coalesce(xr, xc, xv, nz), coalesce(wr, wc, wv, nz)
        zero = set(shorted) | {i for i in isolated if self.diodes[i].key in mna.vdiodes}
        return NetworkRealisation(nz=nz, n=self.n, m=self.m, p=self.p, Y=Y, S=S, Rx=Rx,
                                  Rw=Rw, zero_w=tuple(sorted(zero)))

    def _shorted(self, on: frozenset[str]) -> list[int]:
        """Indices of the diodes whose terminals closed switches join."""
        uf = UnionFind()
        for sw in self.switches:
            if sw.key in on:
                uf.union(*sw.nodes)
        return [i for i, d in enumerate(self.diodes) if uf.find(d.nodes[0]) == uf.find(d.nodes[1])]

    def _isolated(self, on: frozenset[str]) -> list[int]:
        """Indices of the diodes whose terminals no other path joins once the open switches
        are removed (every element but the diode and the open switches carries current)."""
        # A diode is isolated exactly when it is a bridge of the graph of the elements that
        # carry current (one search for every diode, not a union-find per diode).
        return self._diode_bridges(self._current_bridges, on)

    def _check_topology(self, on: frozenset[str], desc: str) -> None:
        """Reject loops of voltage-defined and cutsets of current-defined branches
        (:func:`netlist.degenerate.check_topology`)."""
        check_topology(self, on, desc)

    # -- diode types -------------------------------------------------------------------

    def _needed_forms(self, mna: _Mna) -> list[tuple[str, str, np.ndarray]]:
        """What the dynamics and the switches need: (label, element name, linear form)."""
        needed = [(f"i({el.name})", el.name, mna.current(el)) for el in self.capacitors]
        needed += [(f"the voltage across {el.name}", el.name, mna.voltage(*el.nodes))
                   for el in self.inductors if el.key not in mna.on]
        needed += [(f"w of diode {d.name}", d.name, mna.w_form(d)) for d in self.diodes]
        needed += [(f"the control voltage v({sw.control[0]},{sw.control[1]}) of {sw.name}",
                    sw.name, mna.voltage(*sw.control)) for sw in self.switches]
        return needed

    def _try(self, on: frozenset[str], vdiodes: frozenset[str]):
        """MNA of one λ-type assignment and its defects, (text, element) pairs; [] = usable."""
        mna = _Mna(self, on, vdiodes)
        sol = Solution(None, Entries(*mna.K_entries, (mna.nz, self.nxi)), entries=mna.entries)
        defects = [(f"{label} is constrained by Kirchhoff's laws", name)
                   for label, name in map(self._xi_name, sol.inconsistent)]
        if sol.null.shape[1]:  # (with no null space every quantity is determined)
            needed = self._needed_forms(mna)
            ok = sol.determined_many([form[:mna.nz] for _, _, form in needed])
            defects += [(f"{label} is not determined", name)
                        for (label, name, _), good in zip(needed, ok, strict=True) if not good]
        return mna, sol, defects

    def _xi_name(self, j: int) -> tuple[str, str]:
        """Label and element name of entry j of ξ = (x, λ, u)."""
        n, m = self.n, self.m
        if j < n:
            return self.state_names[j], self.state_elements[j].name
        if j < n + m:
            return f"λ of {self.diodes[j - n].name}", self.diodes[j - n].name
        return f"input {self.input_names[j - n - m]}", self.input_names[j - n - m]

    def _forced_types(self, on: frozenset[str]) -> tuple[set[str], set[str]]:
        """Diodes whose λ type the topology decides: (forced voltage-type, forced current-type).

        A diode whose terminals are joined by voltage-defined branches closes a loop with
        them, so its voltage is imposed and λ must be its current. A diode that is the only
        non-current-defined branch between two parts of the circuit lies in a cutset with
        current-defined branches, so its current is imposed and λ must be its voltage.
        Assignments breaking either rule make the MNA inconsistent, so skipping them does not
        change which assignment the search finds first.
        """
        # (the voltage-defined branches: V C E H and the closed switches)
        partition = self._voltage_partition
        uf, _ = partition.joined(self._closed_edges(on))
        root = partition.root
        forced_current = {d.key for d in self.diodes
                          if uf.find(root(d.nodes[0])) == uf.find(root(d.nodes[1]))}
        # d is in a cutset with current-defined branches exactly when it is a bridge of the
        # other branches and the diodes.
        forced_voltage = {self.diodes[i].key
                          for i in self._diode_bridges(self._cutset_bridges, on)}
        return forced_voltage, forced_current - forced_voltage

    def _candidates(self, on: frozenset[str], free: list[str],
                    forced_voltage: set[str], skip: int = 0) -> Iterator[frozenset[str]]:
        """λ-type assignments to try: sets of diodes whose λ is the reverse voltage.

        Fewest voltage-type diodes first; among equally many, the one whose first differing
        diode (netlist order) is voltage-type (``itertools.combinations`` order). Diodes the
        topology decides (:meth:`_forced_types`) are fixed, the rest enumerated, from ``skip``
        free voltage-type diodes on (:meth:`_min_voltage_diodes`: fewer cannot be usable);
        beyond :data:`EXHAUSTIVE_DIODE_LIMIT` free diodes only a normal-tree assignment is
        offered (and greedily repaired by the caller).
        """
        if len(free) <= EXHAUSTIVE_DIODE_LIMIT:
            for size in range(skip, len(free) + 1):
                for combo in itertools.combinations(free, size):
                    yield frozenset(forced_voltage.union(combo))
        else:
            tree = self._tree_assignment(on)
            yield frozenset(forced_voltage.union(k for k in free if k in tree))

    def _min_voltage_diodes(self, on: frozenset[str]) -> int:
        """A lower bound on the voltage-type diodes of a usable assignment: the diodes of a
        normal tree (:meth:`_tree_assignment`). Each joins two parts of the circuit that the
        voltage-defined branches and resistors leave apart; with fewer voltage-type diodes,
        some part is bounded by current-imposed branches only (inductors, current sources,
        current-type diodes), a cutset whose currents Kirchhoff's law ties: the MNA is
        inconsistent. (A 6-cell MMC arm tried up to 2^12 assignments a mode, 1 s of set-up.)"""
        return len(self._tree_assignment(on))

    def _tree_assignment(self, on: frozenset[str]) -> frozenset[str]:
        """Voltage-type diodes from a normal tree (Kruskal, voltage-defined branches first).

        Branches whose voltage is known go into the tree first, then resistors, then diodes;
        a diode that enters the tree must have its voltage as λ. This keeps as many diodes
        current-type as the topology allows.
        """
        # (the components of the voltage-defined branches and resistors do not depend on
        # the order they are added in: those of the switchless ones are found once)
        partition = self._tree_partition
        uf, _ = partition.joined(self._closed_edges(on))
        root = partition.root
        return frozenset(d.key for d in self.diodes
                         if uf.union(root(d.nodes[0]), root(d.nodes[1])))

    def _choose_diode_types(self, on: frozenset[str], desc: str):
        """The first usable λ-type assignment (see :meth:`_candidates`), MNA and solution."""
        forced_voltage, forced_current = self._forced_types(on)
        free = [d.key for d in self.diodes
                if d.key not in forced_voltage and d.key not in forced_current]
        first = None
        skip = 0
        if len(free) <= EXHAUSTIVE_DIODE_LIMIT:
            skip = max(0, self._min_voltage_diodes(on) - len(forced_voltage))
        for vdiodes in self._candidates(on, free, forced_voltage, skip):
            mna, sol, defects = self._try(on, vdiodes)
            if not defects:
                return mna, sol
            if first is None:
                first = (vdiodes, defects)
        if skip:
            # (the failure is reported with the defects of the first assignment in the full
            # order, every free diode current-type, as without the skip)
            vdiodes = frozenset(forced_voltage)
            first = (vdiodes, self._try(on, vdiodes)[2])
        if len(free) > EXHAUSTIVE_DIODE_LIMIT:
            # Greedy repair: flip one free diode at a time while the number of defects drops.
            vdiodes, defects = first
            improved = True
            while defects and improved:
                improved = False
                for key in free:
                    trial = vdiodes ^ {key}
                    mna, sol, trial_defects = self._try(on, frozenset(trial))
                    if not trial_defects:
                        return mna, sol
                    if len(trial_defects) < len(defects):
                        vdiodes, defects, improved = frozenset(trial), trial_defects, True
            first = (vdiodes, defects)
        vdiodes, defects = first
        where = f" with {desc}" if desc else ""
        involved = list(dict.fromkeys(name for _, name in defects))
        el, built = self.circuit.located(involved)  # (the line of the first, K12 for L1_m)
        raise _error(f"no explicit LCS{where}: " + "; ".join(text for text, _ in defects[:6])
                     + (" ..." if len(defects) > 6 else "")
                     + (" (with every diode's λ its current)" if not vdiodes else ""),
                     amplifier_hint(self.circuit.replacements, involved) or "some quantity is not "
                     "fixed by the circuit in this configuration (a floating part that matters, "
                     "or controlled sources whose gains make the network singular); check the "
                     "elements named" + built, involved, el=el, file=self.file)

    # -- probes ------------------------------------------------------------------------

    def _probe_terms(self, mna: _Mna, probe: str) -> list[tuple[int, float]]:
        """A probe's linear form in ``mna``'s mode as (column over (z, ξ), coefficient)
        terms, in the order of its dense form (:meth:`_Mna.voltage`, :meth:`_Mna.current`)."""
        what = self._probes.get(probe) or self._probes.setdefault(probe,
                                                                  self._resolve_probe(probe))
        if what[0] == "v":
            return mna._voltage_terms(what[1], what[2])
        return mna._current_terms(what[1])

    def _resolve_probe(self, probe: str) -> tuple:
        """What a probe names: ``("v", node, node)`` or ``("i", element)``."""
        match = PROBE.match(probe)
        if match:
            kind, a, b = match.group(1).lower(), match.group(2).lower(), match.group(3)
            a = GROUND if a == "gnd" else a
            if kind == "v":
                if b is not None:
                    b = b.lower()
                    b = GROUND if b == "gnd" else b
                    if self._is_node(a) and self._is_node(b):
                        return "v", a, b
                elif self._is_node(a):
                    return "v", a, GROUND
                elif a in self.by_key and self.by_key[a].kind == "C":
                    # The state name v(C1) (a node of that name wins, as in SPICE).
                    return ("v", *self.by_key[a].nodes[:2])
                elif a in self.held_nodes:
                    return ("v", *self.held_nodes[a])
            elif b is None:  # (an element pelcs replaced: the one carrying its current)
                el = self.by_key.get((self.circuit.current_carrier(a) or a).lower())
                if el is not None and el.kind in TWO_TERMINAL:
                    return "i", el
        nodes = sorted(self.nodes)
        elements = [el.name for el in self.two_terminal]
        hint = ("probes are v(NODE), v(NODE,NODE), i(ELEMENT) or a state name; nodes: "
                + short_list([GROUND, *nodes]) + "; elements: " + short_list(elements))
        guess = did_you_mean(probe, [f"v({n})" for n in nodes]
                             + [f"i({e})" for e in elements]
                             + [f"v({el.name})" for el in self.two_terminal
                                if el.kind == "C"])
        raise _error(f"unknown probe {probe!r}", f"{guess} ({hint})" if guess else hint,
                     file=self.file)

    def _is_node(self, name: str) -> bool:
        return name == GROUND or name in self.node_index
