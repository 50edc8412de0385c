"""Results and errors of a Moreau time-stepping run (see
:mod:`lcs.integrators.moreau.integrator`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np


class Events(Sequence):
    """A run's switchings ``[(t, mode)]``: instants (s) and the modes entered, as arrays (12
    bytes a switching, not a Python tuple's 80), read as the list of pairs.

    A run that keeps only its last switchings (``keep_events``) holds those, and counts the
    others in ``earlier``: ``len(events)`` is the number held, :attr:`count` the run's.

    Parameters
    ----------
    t : ndarray, shape (N,)
        Switching instants, s, increasing.
    index : ndarray of int32, shape (N,)
        Per switching, the mode entered as an index into ``modes``.
    modes : tuple of tuple[bool, ...]
        The modes entered.
    earlier : int
        Switchings before ``t[0]`` that are not held.
    """

    __slots__ = ("t", "index", "modes", "earlier")

    def __init__(self, t: np.ndarray, index: np.ndarray, modes: tuple, earlier: int = 0):
        self.t = t
        self.index = index
        self.modes = modes
        self.earlier = int(earlier)

    @property
    def count(self) -> int:
        """The switchings up to the last one held: those held and the earlier ones (for a
        run's ``result.events``, all of its switchings; a slice keeps the earlier ones
        before its first, not those after its last)."""
        return self.earlier + len(self.t)

    def __len__(self) -> int:
        return len(self.t)

    def __getitem__(self, i):
        if isinstance(i, slice):
            start = range(len(self.t))[i]
            earlier = self.earlier + start[0] if len(start) and i.step in (None, 1) \
                else self.earlier
            return Events(self.t[i], self.index[i], self.modes, earlier)
        return float(self.t[i]), self.modes[int(self.index[i])]

    def __iter__(self):
        modes = self.modes
        return zip(self.t.tolist(), (modes[j] for j in self.index.tolist()), strict=True)

    def __eq__(self, other) -> bool:
        if not isinstance(other, Sequence) or isinstance(other, str):
            return NotImplemented
        if isinstance(other, Events) and other.earlier != self.earlier:
            return False
        return len(self) == len(other) and list(self) == list(other)

    __hash__ = None  # (mutable arrays; compared by value)

    def __repr__(self) -> str:
        if self.earlier:
            return f"Events(the last {len(self)} of {self.count} switchings)"
        return f"Events({len(self)} switchings)" if len(self) > 6 else repr(list(self))

    def __reduce__(self):
        return Events, (self.t, self.index, self.modes, self.earlier)


class SimulationError(RuntimeError):
    """A time step could not be completed.

    Attributes
    ----------
    kind : str
        ``"no_solution"`` (the step's LCP has no solution: Lemke ray termination, confirmed by
        enumeration for small m), ``"non_unique"`` (two LCP solutions give different
        states), ``"non_finite"`` (NaN or infinity in the state), ``"chattering"`` (a
        comparator switched more than ``MoreauOptions.max_switchings`` times inside one
        step), ``"sliding"`` (a comparator toggles without progress and its method has no
        sliding mode), ``"pinned_jump"`` (a comparator's switching left an inductor's current
        no path, a jump to zero the run applies only at known switching instants:
        :mod:`lcs.simulation.pinned`), ``"interrupted"`` (SIGINT or SIGTERM inside
        :func:`lcs.interrupt.deferred_interrupts`; ``time`` is then where it stopped).
    time : float
        End of the failing step, s (the LCP is posed at that instant).
    t_prev : float
        Start of the failing step, s; results are complete up to this time.
    mode : dict[str, str]
        Switch states (``{"S1": "on"}``); empty for a single LCS.
    pairs : tuple[str, ...]
        Diodes (complementarity pairs) involved.
    switch : str or None
        The switch of a ``"chattering"`` or ``"sliding"`` error.
    result : SimulationResult or None
        The partial result (everything computed before the failing step).
    """

    def __init__(self, message: str, *, kind: str, time: float, t_prev: float,
                 mode: dict[str, str] | None = None, pairs: tuple[str, ...] = (),
                 switch: str | None = None):
        super().__init__(message)
        self.message = message
        self.kind = kind
        self.time = float(time)
        self.t_prev = float(t_prev)
        self.mode = dict(mode or {})
        self.pairs = tuple(pairs)
        self.switch = switch
        self.result: SimulationResult | None = None


@dataclass
class SimulationStats:
    """Counters of a run.

    Attributes
    ----------
    steps : int
        Time steps taken (regular, shortened, and the parts of steps split at comparator
        switching instants).
    odd_steps : int
        Steps not of the regular length h (landing on a breakpoint, or split at a comparator
        switching).
    fallbacks : int
        Steps whose LCP went to Lemke (the active-set fast path was not accepted).
    warm_solves : int
        Steps whose cached active set was not accepted and that pivoted from it
        (``MoreauOptions.warm_iter``); those that did not converge went on to Lemke.
    lcp_pivots : int
        Lemke pivots in total.
    factorisations : int
        Active-set factorisations computed (cache misses).
    factor_updates : int
        Of those, the ones made by rank-one updates of a cached active set a few pairs away.
    uniqueness_checks : int
        Lemke solutions checked for a unique next state by enumeration.
    odd_stored : int
        Shortened steps served by a stored discretisation of their length.
    odd_discretised : int
        Shortened-step lengths discretised and stored.
    intervals : int
        Intervals of constant switch mode.
    located : int
        Comparator switchings located inside a step.
    root_evaluations : int
        Trial steps of the instant search (about 2-4 per located switching).
    sliding_steps : int
        Steps taken in sliding mode (Filippov relay: two modes per step).
    modes_built : int
        Switch modes whose matrices were built.
    kernel : str
        How the Moreau steps were solved: ``"dense"`` (each mode's stored θ-discretised
        matrices, :mod:`lcs.integrators.moreau.dense`) or ``"sparse"`` (factorised KKT systems of
        the circuit's network, :mod:`lcs.integrators.moreau.sparse`).
    dense_steps : int
        In a sparse run, grid steps handed to the dense kernel (block pivoting found no
        accepted active set: Lemke decides), or taken by it after a mode without a network.
    wall_time : float
        Seconds spent in :func:`simulate` / :func:`simulate_lcs`.
    kernel_time : float
        Seconds of ``wall_time`` spent inside the compiled stepping kernels (the rest is the
        run's set-up in Python: planning, mode matrices, the initial state, the results).
    points_stored : int
        Points the run stored (the start, every ``every``-th step, switching instants, the
        last step; at or after the output's start when resampled): the rows of the result,
        unless it was resampled onto an output grid as the run went.
    peak_rows : int
        The most stored points held at once (the output buffer's rows, and while resampling
        as the run goes the rows kept for the next output instants): a run's memory beyond
        its result and its events.
    points_streamed : int
        Output rows handed to the run's row stream as it went (``rows_to``): those are not
        in the result, which then holds the last one only. -1 when the run was not
        streamed.
    """

    steps: int = 0
    odd_steps: int = 0
    fallbacks: int = 0
    warm_solves: int = 0
    lcp_pivots: int = 0
    factorisations: int = 0
    factor_updates: int = 0
    uniqueness_checks: int = 0
    odd_stored: int = 0
    odd_discretised: int = 0
    intervals: int = 0
    located: int = 0
    root_evaluations: int = 0
    sliding_steps: int = 0
    modes_built: int = 0
    kernel: str = "dense"
    dense_steps: int = 0
    wall_time: float = 0.0
    kernel_time: float = 0.0
    points_stored: int = 0
    peak_rows: int = 0
    points_streamed: int = -1

    @property
    def us_per_step(self) -> float:
        return 1e6 * self.wall_time / self.steps if self.steps else float("nan")


@dataclass
class SimulationResult:
    """Stored probes of a run.

    Attributes
    ----------
    t : ndarray, shape (N,)
        Times, s: the start, every ``every``-th step, and the last step.
    names : tuple[str, ...]
        Probe names (columns of ``y``).
    y : ndarray, shape (N, q)
        Probe values ``Cy x + Dy λ + Fy u`` (SI units of each probe).
    x_final : ndarray, shape (n,)
        State after the last completed step.
    lambda_final : ndarray, shape (m,)
        Multipliers of the last completed step.
    modes_visited : list of tuple[bool, ...]
        Switch modes in order of first use.
    events : Events or list of (float, tuple[bool, ...])
        Switching instants (s) and the mode entered (source-driven, controller, comparator
        and sampled switchings alike), as pairs (:class:`Events` holds them as arrays). A
        run asked to keep only its last switchings holds those (:attr:`switchings` counts
        them all).
    stats : SimulationStats
    notes : list[str]
        Things the user should know (e.g. an inconsistent initial state was corrected).
    error : SimulationError or None
        Set when the run stopped early; ``t``/``y`` then end at ``error.t_prev``.
    sliding : list of (str, float, float or None)
        Sliding-mode intervals: switch, start and end (s; None if still sliding at the end).
    switching : dict[str, str]
        How each switch was driven: ``"source"``, ``"controller"``, ``"implicit"``,
        ``"hysteresis"``, ``"explicit"`` or ``"latched"`` (``docs/switching.md``).
    event_log : list of lcs.integrators.exact.integrator.ExactEvent
        Exact method only: every event (time, element, kind, mode after).
    device_fits : list of netlist.pwl.PwlFit
        With piecewise-linear devices: each diode's and switch's Vf and Ron.
    losses : netlist.studies.losses.LossReport or None
        When asked for: conduction losses, input and output power, efficiency.
    theta : float or None
        θ of a Moreau run of a netlist (:func:`netlist.studies.transient.choose_theta`).
    step : float or None
        Its step h, s (the ``.tran`` step or the one chosen for it, a finer grid's where the
        run was taken again on one).
    """

    t: np.ndarray
    names: tuple[str, ...]
    y: np.ndarray
    x_final: np.ndarray
    lambda_final: np.ndarray
    modes_visited: list = field(default_factory=list)
    events: list = field(default_factory=list)
    stats: SimulationStats = field(default_factory=SimulationStats)
    notes: list = field(default_factory=list)
    error: SimulationError | None = None
    sliding: list = field(default_factory=list)
    switching: dict = field(default_factory=dict)
    event_log: list = field(default_factory=list)
    device_fits: list = field(default_factory=list)
    losses: object = None
    theta: float | None = None
    step: float | None = None

    @property
    def ok(self) -> bool:
        return self.error is None

    @property
    def points(self) -> int:
        """The run's output points: those held in ``t``, or those streamed to a file as the
        run went (``stats.points_streamed``)."""
        streamed = self.stats.points_streamed
        return streamed if streamed >= 0 else len(self.t)

    @property
    def switchings(self) -> int:
        """The run's switchings, those not held in ``events`` included."""
        return getattr(self.events, "earlier", 0) + len(self.events)

    def __repr__(self) -> str:
        # A few lines, not the arrays (a run holds up to millions of points).
        t = np.asarray(self.t)
        span = f"t {t[0]:.6g} .. {t[-1]:.6g} s" if t.size else "no points"
        names = ", ".join(self.names[:8]) + (f", ... ({len(self.names)})"
                                              if len(self.names) > 8 else "")
        lines = [f"<SimulationResult: {t.size} points, {span}; probes {names}>"]
        if self.error is not None:
            lines.append(f"  error: {str(self.error)[:200]}")
        if self.notes:
            lines.append(f"  {len(self.notes)} note(s): {str(self.notes[0])[:120]}")
        return "\n".join(lines)

    def to_pandas(self):
        """The probes as a ``pandas.DataFrame``: one column per probe (SI units), indexed by
        time (s, index name ``"time"``); the notes and the error message in ``.attrs``."""
        import pandas as pd

        df = pd.DataFrame(np.asarray(self.y), columns=list(self.names),
                          index=pd.Index(np.asarray(self.t), name="time"))
        df.attrs["notes"] = list(self.notes)
        if self.error is not None:
            df.attrs["error"] = str(self.error)
        return df

    def __getitem__(self, name: str) -> np.ndarray:
        """Column of probe ``name`` (case-insensitive), shape (N,)."""
        try:
            j = self.names.index(name)
        except ValueError:
            lower = [s.lower() for s in self.names]
            if name.lower() not in lower:
                raise KeyError(
                    f"no probe {name!r}; stored probes: {', '.join(self.names)}"
                ) from None
            j = lower.index(name.lower())
        return self.y[:, j]

    def raise_if_error(self) -> SimulationResult:
        """Raise the stored :class:`SimulationError`, if any; return self otherwise."""
        if self.error is not None:
            raise self.error
        return self


def output_times(t_first: float, t_last: float, dt: float, k_from: int | None = None
                 ) -> np.ndarray:
    """The instants ``k dt`` (k = 0, 1, ...) in ``[t_first, t_last]``, and ``t_last`` itself
    when it is not one of them (a stop time that is no multiple of ``dt``, a failed run), s.
    With ``k_from``, those from the instant ``k_from dt`` on (the same numbers: the rest of
    the grid)."""
    if not dt > 0:
        raise ValueError(f"output step must be positive, got {dt!r}")
    k0 = int(np.ceil(t_first / dt - 1e-9))
    first = k_from is None or k_from <= k0
    if not first:
        k0 = k_from
    k1 = int(np.floor(t_last / dt + 1e-9))
    t = np.arange(k0, k1 + 1, dtype=float) * dt
    if t.size and abs(t[-1] - t_last) <= 1e-9 * dt:
        t[-1] = t_last
    elif t_last > (t[-1] if t.size else -np.inf):
        t = np.append(t, t_last)
    if first and t.size and abs(t[0] - t_first) <= 1e-9 * dt:
        t[0] = t_first
    return t


#: entries of the output that :func:`resample` interpolates at a time
_RESAMPLE_BLOCK = 1 << 16


def resample(result: SimulationResult, dt: float) -> SimulationResult:
    """The result at the instants of :func:`output_times` (``k dt``, as ngspice writes a
    ``.tran TSTEP`` grid), linearly interpolated between the stored points.

    Where an output instant is a stored step (the usual case when ``dt`` is a multiple of the
    step), its value is the step's exactly. Everything but ``t`` and ``y`` is shared with
    ``result`` (``y`` too when the output grid is the step grid).

    Parameters
    ----------
    result : SimulationResult
    dt : float
        Output spacing, s.

    Returns
    -------
    SimulationResult
        ``t`` shape (N',), ``y`` shape (N', q).
    """
    from dataclasses import replace

    t = np.asarray(result.t, dtype=float)
    if t.size == 0:
        return replace(result)
    y = np.asarray(result.y, dtype=float)
    tout, yout = resample_arrays(t, y, dt)
    return replace(result, t=tout, y=yout)


def resample_arrays(t: np.ndarray, y: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`resample` of stored times ``t`` (s, shape (N,), N >= 1, non-decreasing) and
    probes ``y`` (shape (N, q)): the output instants and their rows (``y`` itself when the
    output grid is the step grid)."""
    tout = output_times(float(t[0]), float(t[-1]), dt)
    return tout, rows_at(t, y, tout, dt)


def rows_at(t: np.ndarray, y: np.ndarray, tout: np.ndarray, dt: float) -> np.ndarray:
    """The rows of stored times ``t`` (s, shape (N,)) and probes ``y`` (shape (N, q)) at the
    output instants ``tout`` (s) of spacing ``dt``: ``y`` itself when the instants are the
    stored times (within ``1e-9 dt``, one for one), else :func:`interpolate`."""
    if tout.size == t.size and np.all(np.abs(tout - t) <= 1e-9 * dt):
        return y  # (the output grid is the step grid)
    return interpolate(t, y, tout)


def interpolate(t: np.ndarray, y: np.ndarray, tout: np.ndarray) -> np.ndarray:
    """``y`` (shape (N, q)) at the instants ``tout`` (s, inside ``[t[0], t[-1]]``), linearly
    interpolated between the stored times ``t`` (s, non-decreasing) with ``np.interp``'s
    arithmetic, bit for bit.

    Each value depends only on the stored points around its instant (the last one at or
    before it and the next one): the rows of any slice of ``t``, ``y`` that holds them give
    the same numbers (:mod:`lcs.simulation.regrid` interpolates a run block by block so).
    """
    if y.shape[1] <= 8 or not np.all(np.isfinite(y)):
        # (few columns: np.interp's own loop is the faster; non-finite values: its rules)
        yout = np.empty((tout.size, y.shape[1]))
        for j in range(y.shape[1]):
            yout[:, j] = np.interp(tout, t, y[:, j])
        return yout
    # np.interp's arithmetic for every column at once: the last stored point at or before
    # each instant (the later of two points at one instant, as np.interp takes), then
    # slope * (x - x0) + y0, and exactly the stored value on a stored instant.
    i0 = np.clip(np.searchsorted(t, tout, side="right") - 1, 0, t.size - 1)
    i1 = np.minimum(i0 + 1, t.size - 1)
    dx = t[i1] - t[i0]
    on_point = (tout == t[i0]) | (dx == 0)
    safe = np.where(on_point, 1.0, dx)
    offset = tout - t[i0]
    # A block of output rows at a time: the temporaries of the whole output (five arrays of
    # its size, fresh pages the kernel zeroes) took 0.4-0.8 s on 40,001 points of 400 probes;
    # a block's are reused from one block to the next.
    yout = np.empty((tout.size, y.shape[1]))
    rows = max(1, _RESAMPLE_BLOCK // y.shape[1])
    for a in range(0, tout.size, rows):
        b = min(a + rows, tout.size)
        y0 = y[i0[a:b]]
        slope = (y[i1[a:b]] - y0) / safe[a:b, None]
        np.copyto(yout[a:b], np.where(on_point[a:b, None], y0,
                                      slope * offset[a:b, None] + y0))
    return yout
