"""The interface between the driver (:mod:`lcs.simulation.driver`) and an integration method.

The driver prepares everything that does not depend on how the state advances: the modes and
probes (:class:`~lcs.simulation.problem.Problem`), how each switch is driven
(:class:`~lcs.simulation.switches.SwitchPlan`), the breakpoints and the known switchings
(:class:`~lcs.simulation.schedule.RunPlan`), the initial mode and state
(:class:`~lcs.simulation.initial.InitialState`), the Python controllers and the output buffers
(:class:`~lcs.simulation.recorder.Recorder`). It then cuts the run into windows between the
controllers' sampling instants and asks the integrator to advance through each.

An integrator implements :class:`Integrator`: ``prepare`` once, ``advance`` per window, and
reports where it is (``snapshot``) and what it did (``stats``). The Moreau θ time-stepping
(:class:`lcs.integrators.moreau.integrator.MoreauIntegrator`) is one; adding another means writing
these methods, as a diffrax solver plugs into ``diffeqsolve``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..results import SimulationError
from .initial import InitialState
from .inputs import InputTable
from .problem import Problem
from .recorder import Recorder
from .schedule import KnownSwitchings, RunPlan
from .switches import SwitchPlan


@dataclass
class Run:
    """Everything an integrator needs about the run it takes part in.

    Attributes
    ----------
    problem : Problem
    plan : SwitchPlan
    schedule : RunPlan
    inputs : list of callables
        ``inputs[j](t)``, input j on a time array.
    table : InputTable
        Fast evaluation of the inputs over the run.
    t_start, t_stop : float
        The run, s.
    every : int
        Save every ``every``-th step (integrators without steps save at their own instants).
    tol : float
        Instants closer than this are one, s.
    recorder : Recorder
    initial : InitialState
    base : tuple of bool
        The switches' guessed initial states (netlist ``ON``/``OFF``), before sources,
        comparators and controllers set them.
    notes : list of str
        Things the user should know; integrators may append.
    """

    problem: Problem
    plan: SwitchPlan
    schedule: RunPlan
    inputs: list
    table: InputTable
    t_start: float
    t_stop: float
    every: int
    tol: float
    recorder: Recorder
    initial: InitialState
    base: tuple = ()
    notes: list = field(default_factory=list)


@dataclass
class Window:
    """An interval of the run between two controller sampling instants.

    ``t0``, ``t1`` (s); ``known``: the known switchings in ``[t0, t1)``; ``breakpoints``: the
    run's breakpoints strictly inside.
    """

    t0: float
    t1: float
    known: KnownSwitchings
    breakpoints: np.ndarray


@dataclass
class Snapshot:
    """Where an integrator is: time (s), switch key, state, multipliers, the sliding switch
    (-1: none) and its equivalent duty."""

    t: float
    key: int
    x: np.ndarray
    lam: np.ndarray
    slide: int
    duty: float


class Integrator:
    """Base class of the integration methods (see the module docstring).

    Attributes
    ----------
    name : str
        The method's name (``"moreau"``).
    h : float
        Its time scale, s: a time-stepper's step. Source-driven switching instants are
        searched at this resolution and instants closer than ``MERGE_FRACTION * h`` merge.
    """

    name = "integrator"
    h: float = 0.0
    #: Whether :meth:`set_state` is implemented (the run then applies the jumps of pinned
    #: states, :mod:`lcs.simulation.pinned`, between windows).
    can_set_state = False
    #: Whether it writes rows until the recorder's buffer is full and then asks for room
    #: (``Recorder.reserve``): a run written on an output grid then resamples as it goes,
    #: the recorder handing its rows over and granting a block at a time
    #: (:mod:`lcs.simulation.regrid`); otherwise every row is kept and resampled at the end.
    writes_until_full = False

    def prepare(self, run: Run) -> None:
        """Set up the run (called once, after the initial state is known)."""
        raise NotImplementedError

    def advance(self, window: Window) -> SimulationError | None:
        """Integrate from ``window.t0`` to ``window.t1``, applying its known switchings and
        saving into ``run.recorder``; return the error that stopped the run, or None."""
        raise NotImplementedError

    def snapshot(self) -> Snapshot:
        """The current time, mode and state."""
        raise NotImplementedError

    def set_state(self, x: np.ndarray) -> None:
        """Replace the current state (between two windows: a state jump the run applies)."""
        raise NotImplementedError

    def stats(self) -> dict:
        """Counters for :class:`~lcs.results.SimulationStats` (field name -> value)."""
        raise NotImplementedError

    def expected_cost(self, run: Run) -> tuple[int, float]:
        """Work units of the run for a progress bar, and the seconds they should take."""
        return 0, 0.0

    def progress(self) -> int:
        """Work units done since the last call (for the progress bar)."""
        return 0
