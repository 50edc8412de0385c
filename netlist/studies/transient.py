"""From a parsed circuit to a Moreau time-stepping run: the glue between netlist and lcs.

:func:`transient_setup` gathers what a run needs from the circuit: the switched LCS, one
resolved waveform per independent source (in the order of ``SwitchedLCS.inputs``), the
initial state, the time span and the step. :func:`simulate_circuit` runs it.

Defaults follow the netlist's ``.tran TSTEP TSTOP [TSTART [TMAX]] [UIC]``: the run goes from 0
to TSTOP with the step ngspice bounds its own by (:func:`tran_step`: TMAX if given, else
``min(TSTEP, (TSTOP - TSTART)/50)``; shorter where a SIN or EXP source needs it); TSTEP is the
print interval (:func:`print_step`); points before TSTART are not returned. A
netlist without ``.tran`` needs the stop time from the caller; the step then defaults to
1/100 of the shortest source period (PULSE PER, SIN 1/FREQ), at most 1/5000 of the run.

Initial state (:mod:`.start`): with UIC, the ``IC=`` and ``.ic`` values; without, ngspice's
DC operating point. An initial state that the diodes cannot accept (e.g. a capacitor
charged against a diode that connects it to another capacitor) jumps at t = 0 to the consistent
state given by :func:`lcs.theory.wellposed.state_jump` (charge and flux conservation through the
impulsive diode currents), reported once in the notes.

Probes (:func:`check_probes`): ``v(n)``, ``v(a,b)``, ``i(X)`` for a two-terminal element, and
the state names ``i(L1)``, ``v(C1)``; they are checked against the circuit's nodes and
elements before the run, so that a typo is an input error with a hint and not a failed run.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from lcs.controllers import measured_probes
from lcs.integrators.moreau.integrator import MoreauOptions, simulate
from lcs.model import LCS, SwitchedLCS
from lcs.results import SimulationResult
from lcs.signals import Dc, Signal, resolve
from lcs.simulation.held_point import AuxiliaryPoint

from ..behavioural import gone_probe
from ..capacitor_links import capacitor_links, check_link_initial, link_note, link_probe
from ..capacitor_loops import reduced_probe
from ..circuit import (
    Circuit,
    CurrentSource,
    VoltageSource,
)
from ..devices import refuse_active_transistors
from ..errors import Diagnostic, NetlistError
from ..formulation import formulate, storage_matrix
from ..knee import KneeCapacitor, check_knees, knee_probes, knees_for_run
from ..limits import MEMORY, STEPS
from ..passive import structurally_passive
from ..probes import PROBE, TWO_TERMINAL, shadowed_probe
from ..reductions import held_capacitors, held_note, held_probe, open_inductors, parallel_diodes
from ..steps import step_note
from ..suggest import did_you_mean
from ..system_cache import kept_with
from .finer_step import finer_on_chattering
from .growth import GrowthWatch, state_growth
from .start import initial_state, start_state
from .timestep import (
    MIN_STEPS_PER_RUN,
    STEPS_PER_PERIOD,
    default_step,
    print_step,
    tran_step,
)

__all__ = [
    "TransientSetup",
    "check_probes",
    "default_step",
    "initial_state",
    "passivity_unreported",
    "print_step",
    "run_setup",
    "simulate_circuit",
    "tran_step",
    "transient_setup",
]

# the note of a circuit without states, whose default probes are its node voltages
_DEFAULT_PROBES = "no inductor or capacitor: the default probes are the node voltages"


@dataclass
class TransientSetup:
    """Everything a time-stepping run of a circuit needs.

    Attributes
    ----------
    system : SwitchedLCS
    signals : list of Signal
        One resolved waveform per input, in ``system.inputs`` order.
    x0 : ndarray, shape (n,)
        Initial state (A, V) in ``system.states`` order.
    t_stop, h : float
        Stop time and step, s.
    t_save : float
        Points before this time are dropped from the result (``.tran`` TSTART), s.
    energy : ndarray, shape (n, n)
        Stored-energy matrix (½ x'Kx, J), for jumps and energy balances.
    notes : list of str
        What the user should know about how the run was set up.
    nonpassive : list
        The modes the passivity screen found non-passive.
    default_probes : list of str or None
        The probes of a run that names none, where they are not the states (a circuit with
        no inductor or capacitor: its node voltages).
    file : str
        The netlist file, for messages.
    print_step : float or None
        The spacing of the points written by default, s (None: every step).
    print_note : str or None
        Why that spacing is not the ``.tran`` TSTEP (:func:`print_step`).
    operating_point : bool
        Start from the DC operating point (ngspice's ``.tran`` without ``UIC``).
    """

    system: SwitchedLCS
    signals: list[Signal]
    x0: np.ndarray
    t_stop: float
    h: float
    t_save: float = 0.0
    energy: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)
    nonpassive: list = field(default_factory=list)
    default_probes: list[str] | None = None
    file: str = ""
    print_step: float | None = None
    print_note: str | None = None
    knees: tuple = ()  # the netlist.knee capacitors and circuit.knees checked after the run
    # start from the DC operating point (ngspice's .tran without UIC), x0 giving only the
    # states no DC equation sets; an AuxiliaryPoint: that of the circuit with its .ic nodes
    # held (netlist.studies.start.held_start)
    operating_point: bool | AuxiliaryPoint = False
    # the idealised transistors (netlist.devices.Replacement), checked at the operating point
    transistors: tuple = ()


def _input_error(circuit: Circuit, message: str, hint: str) -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file=circuit.file)


def _waveforms(circuit: Circuit, inputs: Sequence[str]) -> list[Signal]:
    waves = []
    for name in inputs:
        el = circuit.element(name)
        assert isinstance(el, (VoltageSource, CurrentSource))
        waves.append(el.waveform if el.waveform is not None else Dc(el.dc))
    return waves


def transient_setup(
    circuit: Circuit,
    *,
    tstop: float | None = None,
    step: float | None = None,
    system: SwitchedLCS | None = None,
    strict: bool = False,
    given: dict[str, float] | None = None,
) -> TransientSetup:
    """Collect the switched LCS, sources, initial state and time span of a circuit.

    The modes of a circuit that is not passive by construction
    (:func:`~netlist.passive.structurally_passive`: positive R, L, C, ideal diodes and
    switches, independent sources) are screened for passivity
    (:func:`lcs.theory.screening.screen_modes`: exact necessary conditions, cached with the
    formulation): a mode that fails gives a
    :class:`~lcs.theory.passivity.NonPassiveWarning` (once per set-up), a note and
    ``setup.nonpassive``. The ideal model of a non-passive circuit may grow without bound;
    the run goes on, as the model says, unless ``strict``.

    Parameters
    ----------
    circuit : Circuit
        A parsed, flattened circuit.
    tstop, step : float, optional
        Override ``.tran`` TSTOP and the step (s). Without ``.tran``, ``tstop`` is required
        and ``step`` defaults to :func:`default_step`.
    system : SwitchedLCS, optional
        An already formulated system of this circuit (formulated here when omitted).

    strict : bool
        Refuse a non-passive circuit (NetlistError) instead of warning.
    given : dict of str to float, optional
        The ``.param`` values given to the parser (``--param``): the note on a netlist's
        ``.step`` names them as the values this run uses.

    Raises
    ------
    NetlistError
        No ``.tran`` and no tstop given, a non-positive time, a step longer than the run, or
        (with ``strict``) a non-passive circuit.
    """
    tran = circuit.tran
    notes: list[str] = []
    if tstop is None:
        if tran is None:
            raise _input_error(circuit, "no .tran analysis and no stop time given",
                               "add '.tran TSTEP TSTOP' to the netlist or pass --tstop "
                               "(e.g. --tstop 5m)")
        tstop = tran.tstop
    if not (np.isfinite(tstop) and tstop > 0):
        raise _input_error(circuit, f"stop time must be positive, got {tstop:g} s",
                           "give a positive TSTOP")
    if system is None:
        system = formulate(circuit)
    waves = _waveforms(circuit, system.inputs)
    if step is None:
        if tran is not None:
            step, why = tran_step(tran, waves, tstop, system.inputs)
            if why:
                notes.append(why)
        else:
            step = default_step(waves, tstop)
            notes.append(f"no .tran step: h = {step:.4g} s (1/{STEPS_PER_PERIOD} of the "
                         f"shortest source period, at most 1/{MIN_STEPS_PER_RUN} of the run)")
    if not (np.isfinite(step) and step > 0):
        raise _input_error(circuit, f"time step must be positive, got {step:g} s",
                           "give a positive step")
    if step > tstop:
        raise _input_error(circuit, f"time step {step:g} s exceeds the stop time {tstop:g} s",
                           "choose a step smaller than the stop time")
    # ngspice fills omitted PULSE edges, EXP time constants ... from TSTEP, not from TMAX.
    tstep_res = tran.tstep if tran is not None else step
    signals = [resolve(w, tstep_res, tstop) for w in waves]

    x0, operating_point = start_state(circuit, system, notes)
    notes.extend(circuit.notes)
    for r in circuit.replacements:
        notes.append("idealised: " + r.line())
    for key, into in parallel_diodes(circuit).items():
        name = next(el.name for el in circuit.elements if el.key == key)
        notes.append(f"{name} is in parallel with {into}: merged into it (one ideal diode, "
                     f"i({into}) is their sum)")
    # (a fact of the topology: kept with the system, formulated from the same circuit)
    _pin_open_inductors(circuit, system.states, x0, notes,
                        kept_with(system, "open_inductors", lambda: open_inductors(circuit)))
    held = kept_with(system, "held_capacitors", lambda: held_capacitors(circuit))
    notes.extend(held_note(held))
    links = kept_with(system, "capacitor_links", lambda: capacitor_links(circuit, held))
    if links:
        check_link_initial(circuit, links, system.states, x0)
        notes.extend(link_note(links))
    if circuit.steps:
        notes.append(step_note(circuit, given or {}))
    t_save = tran.tstart if tran is not None and tran.tstart < tstop else 0.0
    # (formulate keeps the stored energy: built again, 5 ms on a 200-stage multiplier)
    energy = system.storage if system.storage is not None else storage_matrix(circuit)
    nonpassive = _screen_passivity(circuit, system, energy, notes, strict)
    default_probes = None
    if not system.states:
        # With no state the default probes (the states) would be none: a CSV of times only.
        default_probes = [f"v({node})" for node in circuit.nodes[1:]]
        notes.append(f"{_DEFAULT_PROBES} ({', '.join(default_probes)}); --probe chooses others")
    shown, shown_note = print_step(tran, waves, float(step))
    return TransientSetup(system, signals, x0, float(tstop), float(step), float(t_save),
                          energy, notes, nonpassive, default_probes, circuit.file or "",
                          shown, shown_note,
                          (*(el for el in circuit.elements if isinstance(el, KneeCapacitor)),
                           *(k for k in circuit.knees if getattr(k, "checked", True))),
                          operating_point, tuple(circuit.replacements))


@contextmanager
def passivity_unreported() -> Iterator[None]:
    """No :class:`~lcs.notices.NonPassiveWarning` inside: for a set-up or run of a circuit
    that is not the one simulated (the ideal circuit of a ``--devices pwl`` run), whose
    passivity is not the user's question. A strict set-up is still refused (``strict``
    raises, not warns)."""
    import warnings

    from lcs.notices import NonPassiveWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NonPassiveWarning)
        yield


def _screen_passivity(circuit: Circuit, system: SwitchedLCS, energy: np.ndarray,
                      notes: list[str], strict: bool) -> list:
    """Warn (or with ``strict`` refuse) when a mode is certainly not passive."""
    passive = (kept_with(system, "passive", lambda: structurally_passive(circuit, energy))
               if energy is system.storage else structurally_passive(circuit, energy))
    if passive:
        # Passive by construction: the numerical screen could not fire (0.3 s of a 200-stage
        # multiplier's set-up, 800 unknowns' eigenvalues; its import, 1.5 ms of every start).
        return []
    import warnings

    from lcs.theory.screening import NonPassiveWarning, screen_modes

    bad = screen_modes(system, energy)
    if not bad:
        return bad
    message = bad[0].message()
    if len(bad) > 1:
        message += f" (and {len(bad) - 1} other mode{'s' if len(bad) > 2 else ''})"
    if strict:
        raise _input_error(circuit, message,
                           "the ideal model of a non-passive circuit may grow without bound "
                           "or have no solution; drop --strict (strict=False) to run it "
                           "anyway, or see `pelcs lcs` for every mode")
    note = message + "; the run follows the ideal model, which may grow without bound"
    notes.append(note)
    where = f"{circuit.file}: " if circuit.file and circuit.file != "<string>" else ""
    warnings.warn(NonPassiveWarning(where + note), stacklevel=3)
    return bad


def _pin_open_inductors(circuit: Circuit, states: Sequence[str], x0: np.ndarray,
                        notes: list[str], keys: Sequence[str]) -> None:
    """Note the inductors no other branch parallels (:func:`netlist.reductions.open_inductors`)
    and set their initial current to zero: an ``IC=`` current there has nowhere to flow, and
    its energy ``½ L i²`` is lost at t = 0 (said in the note)."""
    from ..units import format_eng

    index = {name.lower(): k for k, name in enumerate(states)}
    for key in keys:
        el = circuit.element(key)
        k = index[f"i({el.name})".lower()]
        text = (f"{el.name}: no other branch joins its terminals (one end unconnected?), so "
                "its current is 0 (as ngspice finds it); its state is held at 0 A")
        if x0[k] != 0.0:
            lost = 0.5 * float(el.value) * x0[k] ** 2
            text += (f"; its initial current {format_eng(x0[k], 'A')} has no path: it jumps "
                     f"to 0 at t = 0 and {format_eng(lost, 'J')} (½ L i²) is lost")
            x0[k] = 0.0
        notes.append(text)


def check_probes(circuit: Circuit, probes: Sequence[str], *,
                 path_currents: bool = False) -> list[str]:
    """Check probe names against the circuit's nodes and elements.

    Parameters
    ----------
    circuit : Circuit
    probes : sequence of str
        ``v(n)``, ``v(a,b)`` (``0`` or ``gnd`` is ground), ``i(X)`` for a two-terminal
        element, or a state name (``v(C1)`` is the capacitor voltage unless a node ``c1``
        exists: then ``v(c1)`` in another spelling is the node, as in ngspice, and the state's
        own spelling is an error, since ngspice would read the node).

    path_currents : bool
        Accept ``i(V)`` of a source a capacitor without a state is across, without its
        current, for a caller that accounts for the rest (the losses' input power).

    Returns
    -------
    list of str
        The probes, stripped of surrounding blanks.

    Raises
    ------
    NetlistError
        One diagnostic per bad probe, with the nodes and elements in the hint.
    """
    nodes = {n.lower() for n in circuit.nodes} | {"gnd"}
    two_terminal = {el.key: el for el in circuit.elements if el.kind in TWO_TERMINAL}
    capacitors = {k for k, el in two_terminal.items() if el.kind == "C"}
    out, bad = [], []
    switches = {el.key for el in circuit.elements if el.kind == "S"}
    merged = parallel_diodes(circuit)
    held = held_capacitors(circuit)
    links = capacitor_links(circuit, held)
    for probe in probes:
        m = PROBE.match(probe)
        ok = False
        d = re.match(r"^\s*d\s*\(\s*([^,()\s]+)\s*\)\s*$", probe, re.I)
        if d:  # d(S1): the on-fraction of a switch (lcs.integrators.moreau.integrator)
            ok = d.group(1).lower() in switches
        elif m:
            kind, a, b = m.group(1).lower(), m.group(2).lower(), m.group(3)
            if b is None and a in circuit.loop_capacitors and a not in nodes | capacitors:
                raise NetlistError([reduced_probe(circuit, probe, kind, a)], file=circuit.file)
            if kind == "v":
                if (b is None and a in nodes and a in capacitors
                        and probe.strip() == f"v({two_terminal[a].name})"):
                    raise NetlistError([shadowed_probe(probe, two_terminal[a])],
                                       file=circuit.file)
                ok = (a in nodes and (b is None or b.lower() in nodes)) or (
                    b is None and a in capacitors)
                gone = [x for x in (a, (b or "").lower()) if x in circuit.gone_nodes]
                if not ok and gone:
                    raise NetlistError([gone_probe(circuit, probe, gone[0])],
                                       file=circuit.file)
            else:
                if b is None and a not in two_terminal:
                    # (an element pelcs replaced: the built element carrying its current)
                    a = (circuit.current_carrier(a) or a).lower()
                stop = held_probe(probe, a, held, path_currents) if b is None else None
                if stop is None and b is None and not path_currents:
                    stop = link_probe(probe, a, links)
                if stop is not None:
                    raise NetlistError([stop], file=circuit.file)
                ok = b is None and a in two_terminal and a not in merged
                if b is None and a in merged:
                    raise NetlistError([Diagnostic(
                        message=f"probe {probe.strip()!r}: {two_terminal[a].name} is merged "
                                f"into {merged[a]} (ideal diodes in parallel)",
                        hint=f"probe i({merged[a]}): the current of both")],
                        file=circuit.file)
        (out if ok else bad).append(probe.strip())
    if bad:
        node_list = ", ".join(n for n in circuit.nodes)
        elements = ", ".join(el.name for el in two_terminal.values())
        known = ([f"v({n})" for n in circuit.nodes]
                 + [f"i({el.name})" for k, el in two_terminal.items() if k not in merged]
                 + [f"v({two_terminal[k].name})" for k in capacitors]
                 + [f"d({el.name})" for el in circuit.elements if el.kind == "S"])
        raise NetlistError([
            Diagnostic(
                message=f"unknown probe {p!r}",
                hint=_with_guess(did_you_mean(p, known),
                                 "probes are v(NODE), v(NODE,NODE) or i(ELEMENT); nodes: "
                                 f"{_short(node_list)}; elements: {_short(elements)}"),
            ) for p in bad
        ], file=circuit.file)
    return out


def _with_guess(guess: str, hint: str) -> str:
    return f"{guess} ({hint})" if guess else hint


def _short(text: str, limit: int = 300) -> str:
    return text if len(text) <= limit else text[:limit].rsplit(", ", 1)[0] + ", ..."


class _JumpRecorder:
    """The ``on_inconsistent`` handler: :func:`~lcs.theory.wellposed.state_jump` with a readable
    note.

    A non-passive mode has no jump rule; the state is then left as it is (the first step
    absorbs the jump, which the Moreau driver notes).
    """

    def __init__(self, energy: np.ndarray | None):
        self.energy = energy
        self.note: str | None = None

    def __call__(self, lcs: LCS, x: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, str]:
        # (imported here: scipy.linalg is only needed for an inconsistent initial state)
        from lcs.theory.wellposed import state_jump

        try:
            jump = state_jump(lcs, x, u, energy=self.energy)
        except ValueError as exc:
            # The driver adds that the first step absorbs the jump.
            self.note = (f"t = 0: the initial state is inconsistent with the diodes and the "
                         f"circuit has no jump rule ({exc})")
            return x, self.note
        changed = [
            f"{s}: {a:.6g} -> {b:.6g}"
            for s, a, b in zip(jump.states, jump.x_minus, jump.x_plus, strict=True)
            if not np.isclose(a, b, rtol=1e-12, atol=1e-15)
        ]
        through = [p for p, e in zip(jump.pairs, jump.eta, strict=True) if e > 0]
        impulse = ", ".join(f"{p} carries {e:.4g} C" if kind == "current" else
                            f"{p} takes {e:.4g} V·s"
                            for p, e, kind in zip(jump.pairs, jump.eta,
                                                  [pr.lam for pr in lcs.pairs], strict=True)
                            if e > 0)
        self.note = (
            f"t = 0: the initial state is inconsistent with the diodes "
            f"({', '.join(through) or 'none'} would have to conduct an impulse): the state "
            f"jumps ({'; '.join(changed)}); charge and flux are conserved through the "
            f"impulse ({impulse}), {jump.dissipated:.4g} J dissipated in it "
            "(lcs.theory.wellposed.state_jump)"
        )
        return jump.x_plus, self.note


def simulate_circuit(
    circuit: Circuit,
    *,
    tstop: float | None = None,
    step: float | None = None,
    theta: float | None = None,
    probes: Sequence[str] | None = None,
    every: int = 1,
    progress: bool = False,
    options: MoreauOptions | None = None,
    system: SwitchedLCS | None = None,
    switching: str | None = None,
    controllers: Sequence = (),
    save_at: Sequence[float] = (),
    strict: bool = False,
    method: str = "moreau",
    output_step: float | str | None = None,
    knees: bool = True,
    keep_events: int | None = None,
    path_currents: bool = False,
) -> SimulationResult:
    """Simulate a parsed circuit with the Moreau θ scheme (or exactly, ``method="exact"``).

    :func:`transient_setup` followed by :func:`run_setup`.

    Parameters
    ----------
    circuit : Circuit
    tstop, step : float, optional
        Override the ``.tran`` stop time and step (s).
    theta : float, optional
        θ in [1/2, 1] (1/2: trapezoidal, second order; 1: backward Euler). Default: 1/2,
        or 1 where θ < 1 is not reliable (:func:`choose_theta`).
    probes : sequence of str, optional
        ``v(n)``, ``v(a,b)``, ``i(X)`` or state names; default every state.
    every : int
        Keep every N-th step (the first and the last point are always kept).
    progress : bool
        Progress bar on a terminal for long runs.
    options : MoreauOptions, optional
        Numerical options of the stepper.
    system : SwitchedLCS, optional
        Reuse a formulated system (e.g. across parameter sweeps of the sources only).
    switching : str, optional
        Comparator method for every switch: ``"auto"`` (per switch from its model),
        ``"implicit"``, ``"explicit"`` or ``"hysteresis"`` (see docs/switching.md).
    controllers : sequence, optional
        :mod:`lcs.controllers` objects that drive named switches instead of their netlist
        control (open-loop PWM, sampled PI PWM, sliding surfaces).
    save_at : sequence of float, optional
        Extra instants (s) to land on and store (e.g. stroboscopic samples).
    strict : bool
        Refuse a non-passive circuit instead of warning (see :func:`transient_setup`).
    method : str
        ``"moreau"`` (time-stepping) or ``"exact"`` (event-driven, exact between events:
        :mod:`lcs.integrators.exact`; the step is then the output spacing; DC, PULSE, PWL and SIN
        sources and netlist comparators only).
    output_step : float or "tran", optional
        The points returned: the instants ``k output_step`` (s) from TSTART on, linearly
        interpolated between the stored points (:func:`lcs.results.resample`); ``"tran"``:
        the spacing ``pelcs simulate`` writes by default (``setup.print_step``, every
        step when None). A Moreau run computes them as it goes and does not hold every
        step. Default: the stored points themselves.
    knees : bool
        Check that the capacitors constant below a knee stayed there (:mod:`netlist.knee`);
        off for a run whose result is not an answer (the ideal run that sizes pwl fits).
    keep_events : int, optional
        A Moreau run keeps only its last ``keep_events`` switchings in ``result.events``
        and counts the others (``result.switchings``): with ``output_step`` its memory then
        does not grow with its length. Default: all.
    path_currents : bool
        ``i(V)`` probes of sources that capacitors without a state are across, without their
        current (:func:`check_probes`); for :mod:`netlist.studies.losses`.

    Returns
    -------
    SimulationResult
        ``t`` shape (N,), ``y`` shape (N, len(probes)), ``res["v(out)"]`` by probe name.
        ``error`` is set (and the data end at the last completed step) if a step failed;
        see :mod:`lcs.integrators.moreau.integrator`.

    Raises
    ------
    NetlistError
        Bad times, unknown probes, or a degenerate topology in a mode the run reaches.
    ValueError
        θ outside [1/2, 1] or ``every`` not a positive integer.
    """
    if probes is not None:
        # a typo is an input error before any work (the names known: kept with the system)
        names = tuple(probes)
        probes = list(check_probes(circuit, probes, path_currents=path_currents)
                      if system is None else kept_with(
                          system, ("probes", names, path_currents),
                          lambda: check_probes(circuit, names, path_currents=path_currents)))
    if controllers:  # what they measure too: a current pelcs does not compute is refused
        check_probes(circuit, measured_probes(controllers))
    setup = transient_setup(circuit, tstop=tstop, step=step, system=system, strict=strict)

    def run(finer: float | None) -> SimulationResult:
        s = setup
        if finer is not None:
            with passivity_unreported():  # (reported by the first set-up)
                s = transient_setup(circuit, tstop=tstop, step=finer, system=setup.system)
        return run_setup(s, theta=theta, probes=probes, every=every, progress=progress,
                         options=options, switching=switching, controllers=controllers,
                         save_at=save_at, method=method, output_step=output_step,
                         knees=knees, keep_events=keep_events)

    if step is not None or method != "moreau":
        return run(None)
    return finer_on_chattering(run, setup.h, setup.t_stop)


def run_setup(
    setup: TransientSetup,
    *,
    theta: float | None = None,
    probes: Sequence[str] | None = None,
    every: int = 1,
    progress: bool = False,
    options: MoreauOptions | None = None,
    switching: str | None = None,
    controllers: Sequence = (),
    save_at: Sequence[float] = (),
    method: str = "moreau",
    output_step: float | str | None = None,
    knees: bool = True,
    keep_events: int | None = None,
    rows_to=None,
) -> SimulationResult:
    """Run a prepared :class:`TransientSetup` (arguments as in :func:`simulate_circuit`).

    With ``rows_to`` (:class:`lcs.simulation.driver.RowStream`), a Moreau run hands its
    output rows to it as it makes them and the result holds the last one
    (``result.stats.points_streamed`` counts them; -1 where the run could not stream: the
    exact method, a knee check on every step, a mode that pins a state).

    The set-up's notes come first in ``result.notes``; an initial state jump is reported by
    a note of its own; points before ``setup.t_save`` are dropped. ``result.theta`` is the θ
    used (:func:`choose_theta`). With ``output_step``, the points are those of
    :func:`lcs.results.resample` of the points kept (the note on the state's growth is then
    about them).
    """
    notes = setup.notes if probes is None else [  # (the default probes are not the run's)
        n for n in setup.notes if not n.startswith(_DEFAULT_PROBES)]
    if probes is None:
        probes = setup.default_probes
    print_note = None
    if output_step == "tran":
        output_step, print_note = setup.print_step, setup.print_note
    run_knees, knee_note = knees_for_run(setup.knees if knees else (), setup.t_stop / setup.h,
                                         method == "moreau" and (rows_to is not None
                                                                 or output_step is not None))
    extra = knee_probes(run_knees, probes, setup.system.states)
    if extra:
        probes = [*(setup.system.states if probes is None else probes), *extra]
    # (a knee is checked on every step, not only on the output grid, the last row or every
    # N-th step: such a run keeps every step and is resampled, or thinned, at the end)
    checked = bool(run_knees)
    kept_every, every = every, (1 if checked and method == "moreau" else every)
    streamed = output_step if method == "moreau" and not checked else None
    watch = None
    if rows_to is not None and method == "moreau" and not checked:
        rows_to = watch = GrowthWatch(rows_to, setup.t_stop)
    else:
        rows_to = None
    check_run_size(setup, len(setup.system.states) if probes is None else len(probes), every,
                   streamed, streamed=rows_to is not None)
    jump = _JumpRecorder(setup.energy)
    theta_note = None
    if method == "moreau":
        theta, theta_note = choose_theta(setup, theta)
    if method == "exact":
        from lcs.integrators.exact.simulate import simulate_exact

        if controllers:
            raise ValueError("the exact method follows the netlist's comparators, not Python "
                             "controllers: use method='moreau'")
        result = simulate_exact(
            setup.system, setup.signals, setup.x0, setup.t_stop, setup.h,
            probes=None if probes is None else list(probes), save_at=save_at,
            on_inconsistent=jump, operating_point=setup.operating_point)
    elif method != "moreau":
        raise ValueError(f"unknown method {method!r}: 'moreau' or 'exact'")
    else:
        result = simulate(
            setup.system, setup.signals, setup.x0, setup.t_stop, setup.h, theta=theta,
            probes=None if probes is None else list(probes), every=every,
            progress=progress, on_inconsistent=jump, options=options, switching=switching,
            save_at=save_at, controllers=controllers, output_step=streamed,
            output_from=setup.t_save if setup.t_save > 0 else -np.inf,
            keep_events=keep_events, rows_to=rows_to, operating_point=setup.operating_point,
        )
    result.notes[:0] = notes + ([theta_note] if theta_note else [])
    # (at the DC point only without UIC: with it, the user chose the start)
    refuse_active_transistors(setup.transistors, result.notes if setup.operating_point else (),
                              setup.file, result.sliding, setup.t_stop)
    if method == "moreau":
        result.theta, result.step = theta, setup.h
    check_knees(run_knees, result, len(extra))
    if knee_note:
        result.notes.append(knee_note)
    if every != kept_every and len(result.t):  # every N-th row, the last, the save_at ones
        keep = (np.arange(len(result.t)) % kept_every == 0) | np.isin(result.t, save_at)
        keep[-1] = True
        result.t, result.y = result.t[keep], result.y[keep]
    growth = (watch.note(result) if watch is not None and result.stats.points_streamed >= 0
              else state_growth(result))
    if growth is not None:
        result.notes.append(growth)
    if setup.t_save > 0:
        keep = result.t >= setup.t_save
        result.t, result.y = result.t[keep], result.y[keep]
    if print_note:
        result.notes.append(print_note)
    if output_step is not None and streamed is None:
        from lcs.results import resample

        result.stats.points_stored = len(result.t)
        result = resample(result, output_step)
    return result


def check_run_size(setup: TransientSetup, probes: int, every: int = 1,
                   output_step: float | None = None, streamed: bool = False) -> None:
    """Refuse, before anything is allocated, a run whose steps or stored results exceed the
    limits :data:`netlist.limits.STEPS` and :data:`netlist.limits.MEMORY`.

    Parameters
    ----------
    setup : TransientSetup
    probes : int
        Columns stored per point.
    every : int
        One point stored every ``every`` steps.
    output_step : float, optional
        The points are the instants ``k output_step`` (s), computed as the run goes
        (:mod:`lcs.simulation.regrid`): the run holds those and a block of steps.
    streamed : bool
        The rows go to a file as the run makes them (``run_setup(rows_to=...)``): the run
        holds a block of them.

    Raises
    ------
    NetlistError
        Naming the figure, the limit, its environment variable and what to change.
    """
    from netlist.units import format_eng

    steps = setup.t_stop / setup.h
    points = steps / max(1, int(every)) + 1
    if output_step is not None and not setup.system.pinnable:
        # (a system that pins states keeps every step: lcs.simulation.driver)
        # the output grid (its rows gathered, then joined) and a block of the steps
        points = min(points, (setup.t_stop - setup.t_save) / output_step + 2 + _BLOCK_ROWS)
    if streamed and not setup.system.pinnable and not knees_for_run(setup.knees, steps, True)[0]:
        points = min(points, 2 * _BLOCK_ROWS)
    # the recorder's buffer, then the result copied out of it (or resampled)
    need = 2.0 * points * (probes + 1) * 8.0
    try:
        max_steps = STEPS.value()
        max_bytes = None if MEMORY.allows(need) else MEMORY.value()
    except ValueError as exc:
        raise NetlistError(Diagnostic(message=str(exc), hint="unset it or give a number"),
                           file=setup.file) from None

    def span() -> str:  # (for the messages only: 10 us a run)
        return f"0 to {format_eng(setup.t_stop, 's')} with h = {format_eng(setup.h, 's')}"

    if not steps <= max_steps:
        raise NetlistError(Diagnostic(
            message=f"the run takes {steps:.3g} time steps ({span()}), more than the limit of "
                    f"{max_steps:.3g}",
            hint="a larger step (--step, .tran TMAX) or a shorter run (--tstop); "
                 + STEPS.hint(f"{10 ** math.ceil(math.log10(steps)):.0e}")),
            file=setup.file)
    if max_bytes is not None and not need <= max_bytes:
        raise NetlistError(Diagnostic(
            message=f"the run would store {points:.3g} points of {probes} probe"
                    f"{'s' if probes != 1 else ''} ({span()}): "
                    f"{format_eng(need, 'B')} of memory, more than the limit of "
                    f"{format_eng(max_bytes, 'B')}",
            hint="store fewer points (--every N), fewer probes (--probe), a larger step or "
                 f"a shorter run; {MEMORY.hint('64G')} (default: the memory available)"),
            file=setup.file)


#: rows a run resampled as it goes holds besides its output grid: the recorder's block and
#: a chunk of steps (:class:`lcs.simulation.recorder.Recorder`, ``MoreauOptions.chunk_steps``)
_BLOCK_ROWS = 2 * 32768


#: θ of a run when none is given and θ < 1 is reliable
DEFAULT_THETA = 0.5


def choose_theta(setup: TransientSetup, theta: float | None) -> tuple[float, str | None]:
    """θ for a Moreau run of ``setup``, and a note when θ < 1 is not reliable there.

    ``theta=None``: :data:`DEFAULT_THETA`, unless
    :func:`lcs.integrators.moreau.theta_screen.screen_theta` finds a mode whose λ = 0 configuration
    has stiff dynamics that its diodes cancel; then θ = 1 (backward Euler, first order) with a note
    saying why. A θ < 1 given explicitly is kept, with the same finding as a note.
    """
    from lcs.integrators.moreau.theta_screen import screen_theta

    wanted = DEFAULT_THETA if theta is None else float(theta)
    risks = screen_theta(setup.system, setup.h, wanted, energy=setup.energy)
    if not risks:
        return wanted, None
    r = min(risks, key=lambda r: r.g)
    text = r.message(setup.h, wanted)
    if theta is None:
        return 1.0, (f"{text}: the run uses θ = 1 (backward Euler, first order); θ = "
                     f"{wanted:g} would need a step below {r.h_max:.3g} s")
    return wanted, (f"{text}; θ = 1 (backward Euler) or a step below {r.h_max:.3g} s avoids "
                    "it")

