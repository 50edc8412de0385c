"""From a parsed circuit to a Moreau time-stepping run: the glue between netlist and lcs.

:func:`transient_setup` gathers what a run needs from the circuit: the switched LCS, one
resolved waveform per independent source (in the order of ``SwitchedLCS.inputs``), the
initial state, the time span and the step. :func:`simulate_circuit` runs it.

Defaults follow the netlist's ``.tran TSTEP TSTOP [TSTART [TMAX]] [UIC]``: the run goes from 0
to TSTOP with the step TMAX if given, else TSTEP; points before TSTART are not returned.

Initial state: an element's ``IC=`` first; otherwise a capacitor gets ``v(n+) - v(n-)`` from
``.ic v(node)=...`` lines (ground is 0 V; a node missing from ``.ic`` counts as 0 V only if
the other node is given); everything else starts at zero. pelcs always starts from these values
(as ngspice does with UIC); without UIC ngspice would first compute a DC operating point, which
the result's notes point out. An initial state that the diodes cannot accept (e.g. a capacitor
charged against a diode that connects it to another capacitor) jumps at t = 0 to the consistent
state given by :func:`lcs.wellposed.state_jump`, reported once in the notes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from lcs.model import LCS, SwitchedLCS
from lcs.moreau import MoreauOptions, simulate
from lcs.results import SimulationResult
from lcs.signals import Dc, Signal, resolve
from lcs.wellposed import state_jump

from .circuit import GROUND, Capacitor, Circuit, CurrentSource, Inductor, VoltageSource
from .errors import Diagnostic, NetlistError
from .formulation import formulate, storage_matrix


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
    """

    system: SwitchedLCS
    signals: list[Signal]
    x0: np.ndarray
    t_stop: float
    h: float
    t_save: float = 0.0
    energy: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)


def _input_error(circuit: Circuit, message: str, hint: str) -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file=circuit.file)


def transient_setup(
    circuit: Circuit,
    *,
    tstop: float | None = None,
    step: float | None = None,
    system: SwitchedLCS | None = None,
) -> TransientSetup:
    """Collect the switched LCS, sources, initial state and time span of a circuit.

    Parameters
    ----------
    circuit : Circuit
        A parsed, flattened circuit.
    tstop, step : float, optional
        Override ``.tran`` TSTOP and the step (s).
    system : SwitchedLCS, optional
        An already formulated system of this circuit (formulated here when omitted).

    Raises
    ------
    NetlistError
        No ``.tran`` and no tstop/step given, or a non-positive time.
    """
    tran = circuit.tran
    notes: list[str] = []
    if tstop is None:
        if tran is None:
            raise _input_error(circuit, "no .tran analysis and no stop time given",
                               "add '.tran TSTEP TSTOP' to the netlist or pass --tstop")
        tstop = tran.tstop
    if step is None:
        if tran is None:
            raise _input_error(circuit, "no .tran analysis and no step given",
                               "add '.tran TSTEP TSTOP' to the netlist or pass --step")
        step = tran.tmax if tran.tmax else tran.tstep
    if not (np.isfinite(tstop) and tstop > 0):
        raise _input_error(circuit, f"stop time must be positive, got {tstop:g} s",
                           "give a positive TSTOP")
    if not (np.isfinite(step) and step > 0):
        raise _input_error(circuit, f"time step must be positive, got {step:g} s",
                           "give a positive step")
    if step > tstop:
        raise _input_error(circuit, f"time step {step:g} s exceeds the stop time {tstop:g} s",
                           "choose a step smaller than the stop time")
    tstep_res = tran.tstep if tran is not None else step
    if system is None:
        system = formulate(circuit)

    signals = []
    for name in system.inputs:
        el = circuit.element(name)
        assert isinstance(el, (VoltageSource, CurrentSource))
        wave = el.waveform if el.waveform is not None else Dc(el.dc)
        signals.append(resolve(wave, tstep_res, tstop))

    x0 = initial_state(circuit, system.states, notes)
    if tran is not None and not tran.uic and (
        any(x != 0 for x in x0) or circuit.initial_conditions
    ):
        notes.append("pelcs starts from the given initial conditions (as ngspice with UIC); "
                     "without UIC ngspice first computes a DC operating point")
    t_save = tran.tstart if tran is not None and tran.tstart < tstop else 0.0
    return TransientSetup(system, signals, x0, float(tstop), float(step), float(t_save),
                          storage_matrix(circuit), notes)


def initial_state(circuit: Circuit, states: Sequence[str], notes: list[str] | None = None
                  ) -> np.ndarray:
    """Initial state from element ``IC=`` values and ``.ic`` node voltages.

    Parameters
    ----------
    circuit : Circuit
    states : sequence of str
        State names ``i(L1)`` / ``v(C1)`` in the order wanted.

    Returns
    -------
    ndarray, shape (len(states),)
        A for inductor currents, V for capacitor voltages.
    """
    ics = circuit.initial_conditions
    x0 = np.zeros(len(states))
    for k, name in enumerate(states):
        el = circuit.element(name[2:-1])
        if isinstance(el, Inductor):
            x0[k] = el.ic or 0.0
        elif isinstance(el, Capacitor):
            if el.ic is not None:
                x0[k] = el.ic
                continue
            a, b = el.nodes
            va = 0.0 if a == GROUND else ics.get(a)
            vb = 0.0 if b == GROUND else ics.get(b)
            if va is None and vb is None:
                continue
            if (va is None or vb is None) and notes is not None:
                missing = a if va is None else b
                notes.append(f"{el.name}: node {missing} has no .ic; taken as 0 V")
            x0[k] = (va or 0.0) - (vb or 0.0)
    return x0


def simulate_circuit(
    circuit: Circuit,
    *,
    tstop: float | None = None,
    step: float | None = None,
    theta: float = 0.5,
    probes: Sequence[str] | None = None,
    every: int = 1,
    progress: bool = False,
    options: MoreauOptions | None = None,
    system: SwitchedLCS | None = None,
) -> SimulationResult:
    """Simulate a parsed circuit with the Moreau θ scheme.

    Parameters
    ----------
    circuit : Circuit
    tstop, step : float, optional
        Override the ``.tran`` stop time and step (s).
    theta : float
        θ in [1/2, 1] (1/2: trapezoidal, second order; 1: backward Euler).
    probes : sequence of str, optional
        ``v(n)``, ``v(a,b)``, ``i(X)`` or state names; default every state.
    every : int
        Keep every N-th step.
    progress : bool
        Progress bar on a terminal for long runs.
    system : SwitchedLCS, optional
        Reuse a formulated system (e.g. across parameter sweeps of the sources only).

    Returns
    -------
    SimulationResult
        ``error`` is set (and the data end early) if a step failed; see :mod:`lcs.moreau`.
    """
    setup = transient_setup(circuit, tstop=tstop, step=step, system=system)
    energy = setup.energy

    def jump(lcs: LCS, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return state_jump(lcs, x, u, energy=energy).x_plus

    if probes is not None:
        probes = list(probes)
        # Validate probe names up front so a typo is an input error, not a failed run.
        setup.system.outputs(setup.system.key(None), probes)
    result = simulate(
        setup.system, setup.signals, setup.x0, setup.t_stop, setup.h, theta=theta,
        probes=probes, every=every, progress=progress, on_inconsistent=jump, options=options,
    )
    result.notes[:0] = setup.notes
    if setup.t_save > 0:
        keep = result.t >= setup.t_save
        result.t, result.y = result.t[keep], result.y[keep]
    return result
