"""Bifurcation diagrams: sweep one parameter, record the attractor's samples.

For every parameter value p the map ``factory(p)`` is iterated: ``transient`` iterates are
discarded, the next ``record`` are kept (any probes the map knows, e.g. ``v(out)`` sampled
once per period). Two modes, as in the literature on nonsmooth converters:

* fixed initial condition (default): every value starts from ``x0``. Values are independent
  and are spread over all cores.
* follow (``follow=True``): each value starts from the final state of the previous one, so
  that an attractor is followed as long as it exists; sweeping up and down exposes
  hysteresis (coexisting attractors). A follow sweep is sequential by nature; the up and down
  sweeps run in parallel, and ``chunks > 1`` splits each direction into that many
  contiguous pieces that run in parallel, each starting from ``x0`` (each piece then follows
  its attractor only from its own first value: use it when the attractor is unique or the
  transient is long enough, not for hysteresis hunting at the chunk boundaries).

The diagram gives its arrays and its table as plain data; the files (NPZ or CSV) and the
scatter plot are the application's (:func:`pelcs.writers.write_bifurcation`,
:mod:`pelcs.analysis_plots`).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import interrupt
from .maps import Map, MapError
from .parallel import portable, task_engine

__all__ = [
    "Attractor",
    "BifurcationDiagram",
    "SweepBranch",
    "attractor_period",
    "bifurcation_diagram",
    "classify_attractor",
]

MapFactory = Callable[[float], Map]


@dataclass
class SweepBranch:
    """One sweep direction of a diagram.

    Attributes
    ----------
    direction : str
        ``"fixed"`` (every value from x0), ``"up"`` or ``"down"`` (follow mode).
    values : ndarray, shape (K,)
        Parameter values in the order they were visited.
    samples : ndarray, shape (K, M, q)
        Recorded probe values (NaN where a run failed).
    x_final : ndarray, shape (K, n)
        Map state after the last recorded iterate.
    ok : ndarray of bool, shape (K,)
    messages : list of str
        Failure messages (empty strings for successful values).
    """

    direction: str
    values: np.ndarray
    samples: np.ndarray
    x_final: np.ndarray
    ok: np.ndarray
    messages: list[str] = field(default_factory=list)


@dataclass
class BifurcationDiagram:
    """The result of :func:`bifurcation_diagram`.

    Attributes
    ----------
    param_name : str
    probes : tuple[str, ...]
    state_names : tuple[str, ...]
    transient, record : int
    follow : bool
    branches : list of SweepBranch
    wall_time : float
        Seconds.
    notes : list of str
    engine : str
        Where the tasks ran (e.g. ``"2 local processes"``, ``"Dask scheduler ..."``).
    """

    param_name: str
    probes: tuple[str, ...]
    state_names: tuple[str, ...]
    transient: int
    record: int
    follow: bool
    branches: list[SweepBranch]
    wall_time: float = 0.0
    notes: list[str] = field(default_factory=list)
    engine: str = ""

    def branch(self, direction: str) -> SweepBranch:
        for b in self.branches:
            if b.direction == direction:
                return b
        raise KeyError(direction)

    def arrays(self) -> dict[str, np.ndarray]:
        """Arrays ``<direction>_values`` (K,), ``<direction>_samples`` (K, M, q),
        ``<direction>_x_final`` (K, n), ``<direction>_ok`` (K,) per branch, plus
        ``probes``, ``states``, ``param_name``, ``directions``, ``transient``, ``record``,
        ``follow``: the members of ``pelcs bifurcation -o OUT.npz``."""
        arrays: dict[str, np.ndarray] = {
            "param_name": np.array(self.param_name),
            "probes": np.array(self.probes),
            "states": np.array(self.state_names),
            "directions": np.array([b.direction for b in self.branches]),
            "transient": np.array(self.transient),
            "record": np.array(self.record),
            "follow": np.array(self.follow),
        }
        for b in self.branches:
            arrays[f"{b.direction}_values"] = b.values
            arrays[f"{b.direction}_samples"] = b.samples
            arrays[f"{b.direction}_x_final"] = b.x_final
            arrays[f"{b.direction}_ok"] = b.ok
        return arrays

    def columns(self) -> dict[str, np.ndarray]:
        """One row per recorded sample: ``direction`` (str), the parameter, ``k`` (the
        recorded iterate, int), the probes (SI units); what ``pelcs bifurcation -o OUT.csv``
        writes."""
        direction, param, k = [], [], []
        samples = []
        for b in self.branches:
            n, m = b.samples.shape[:2]
            direction += [b.direction] * (n * m)
            param.append(np.repeat(np.asarray(b.values, dtype=float), m))
            k.append(np.tile(np.arange(m, dtype=np.int64), n))
            samples.append(np.asarray(b.samples, dtype=float).reshape(n * m, -1))
        q = len(self.probes)
        rows = np.concatenate(samples) if samples else np.empty((0, q))
        cols = {"direction": np.array(direction, dtype=object),
                self.param_name: np.concatenate(param) if param else np.empty(0),
                "k": np.concatenate(k) if k else np.empty(0, np.int64)}
        for j, probe in enumerate(self.probes):
            cols[probe] = rows[:, j]
        return cols


def _sweep_task(task, report) -> list[tuple[np.ndarray, np.ndarray, bool, str]]:
    """Worker: one contiguous run of parameter values (follow: sequential)."""
    factory, values, x0, transient, record, probes, follow = task
    out = []
    x_init = np.asarray(x0, dtype=float)
    for v in values:
        try:
            m = factory(float(v))
            s = m.sample(x_init, transient, record, probes)
        except MapError as exc:
            nq = len(probes) if probes else x_init.size
            out.append((np.full((record, nq), np.nan), np.full(x_init.size, np.nan), False,
                        str(exc)))
            x_init = np.asarray(x0, dtype=float)
            report(1)
            continue
        values, ok, message = s.values, s.ok, s.message
        check = getattr(m, "check_attractor", None)
        if ok and check is not None:
            # (a map whose circuit has quantities to keep on one side of a knee: its
            # attractor, run again from the last state, must keep them, else the samples
            # are not the circuit's)
            problem = check(s.x_final, record)
            if problem:
                values, ok, message = np.full_like(values, np.nan), False, problem
        out.append((values, s.x_final, ok, message))
        # After a failure (divergence) the follow sweep restarts from x0.
        x_init = s.x_final if (follow and s.ok) else np.asarray(x0, dtype=float)
        report(1)
    return out


def bifurcation_diagram(
    factory: MapFactory,
    values: Sequence[float],
    *,
    x0,
    transient: int,
    record: int,
    probes: Sequence[str] | None = None,
    follow: bool = False,
    directions: Sequence[str] = ("up",),
    workers: int | None = None,
    chunks: int | None = None,
    progress: bool = False,
    param_name: str = "p",
    start_method: str | None = None,
    scheduler=None,
) -> BifurcationDiagram:
    """Sweep a parameter and record the samples of the attractor at every value.

    Parameters
    ----------
    factory : callable
        ``factory(value) -> Map``; picklable for ``workers > 1`` (e.g.
        :class:`netlist.studies.sweep.CircuitMapFactory`, or a module-level function).
    values : sequence of float, shape (K,)
        Parameter values, in increasing sweep order.
    x0 : array_like, shape (n,)
        Initial state (fixed mode: for every value; follow mode: for the first value).
    transient, record : int
        Iterates discarded, then recorded, per value.
    probes : sequence of str, optional
        What to record; default the map's states.
    follow : bool
        Start each value from the previous value's final state.
    directions : sequence of str
        Follow mode only: ``("up",)``, ``("down",)`` or ``("up", "down")``.
    workers : int, optional
        Local processes (default: all cores).
    chunks : int, optional
        Fixed mode: tasks (default 4 per worker, for load balance; the split does not change
        any number). Follow mode: contiguous pieces per direction run in parallel, each from
        ``x0`` (default 1: a true follow).
    progress : bool
        tqdm bar on a terminal.
    param_name : str
    start_method : str, optional
        Multiprocessing start method (default fork where available).
    scheduler : None, str or distributed.Client, optional
        Where the tasks run (:func:`~.parallel.task_engine`): default locally; ``"local"``
        a Dask local cluster; a Dask scheduler address (``"tcp://host:8786"``) or client.
        The diagram is the same whatever runs it.

    Returns
    -------
    BifurcationDiagram
    """
    t_wall = time.perf_counter()
    values = np.asarray(values, dtype=float)
    if values.ndim != 1 or values.size == 0:
        raise ValueError("values must be a non-empty 1-D sequence")
    if int(transient) < 0 or int(record) < 1:
        raise ValueError("transient must be >= 0 and record >= 1")
    x0 = np.asarray(x0, dtype=float)
    probes = tuple(probes) if probes else None
    if not follow:
        directions = ("fixed",)
    else:
        directions = tuple(directions)
        bad = [d for d in directions if d not in ("up", "down")]
        if bad or not directions:
            raise ValueError(f"directions must be 'up' and/or 'down', got {directions}")
    with task_engine(scheduler, workers, start_method=start_method) as engine:
        if engine.distributed:
            factory = portable(factory)
        if not follow:
            n_chunks = chunks or min(values.size, 4 * engine.workers)
        else:
            n_chunks = chunks or 1
        n_chunks = max(1, min(int(n_chunks), values.size))
        tasks, layout = [], []
        for d in directions:
            seq = values[::-1] if d == "down" else values
            for piece in np.array_split(seq, n_chunks):
                if piece.size:
                    tasks.append((factory, piece, x0, int(transient), int(record), probes,
                                  bool(follow)))
                    layout.append((d, piece))
        results = engine.run(_sweep_task, tasks, progress=progress,
                             total=values.size * len(directions), desc="bifurcation",
                             unit="value", partial=True)
        engine_name = engine.description
    # Probe names and state names from one map (cheap: built once per process).
    m0 = factory(float(values[0]))
    names = probes or m0.state_names
    nq = len(probes) if probes else len(m0.state_names)
    branches = []
    for d in directions:
        # (an interrupt, lcs.interrupt, leaves the tasks under way unfinished (None): a
        # branch holds the values of the finished tasks only)
        done = [(piece, res) for (lay, piece), res in zip(layout, results, strict=True)
                if lay == d and res is not None]
        rows = [r for _, res in done for r in res]
        seq = np.concatenate([piece for piece, _ in done]) if done else values[:0]
        branches.append(SweepBranch(
            direction=d, values=seq.copy(),
            samples=np.stack([r[0] for r in rows]) if rows else
            np.empty((0, int(record), nq)),
            x_final=np.stack([r[1] for r in rows]) if rows else np.empty((0, x0.size)),
            ok=np.array([r[2] for r in rows], dtype=bool),
            messages=[r[3] for r in rows],
        ))
    notes = []
    planned = values.size * len(directions)
    finished = sum(b.values.size for b in branches)
    if finished < planned:
        signum = interrupt.requested()
        how = f" ({interrupt.signal_name(signum)})" if signum is not None else ""
        notes.append(f"the diagram was interrupted{how} after {finished} of {planned} "
                     "parameter values: it holds the finished values only")
    failed = sum(int((~b.ok).sum()) for b in branches)
    if failed:
        notes.append(f"{failed} parameter value(s) failed; their samples are NaN")
    return BifurcationDiagram(
        param_name=param_name, probes=tuple(names), state_names=tuple(m0.state_names),
        transient=int(transient), record=int(record), follow=bool(follow), branches=branches,
        wall_time=time.perf_counter() - t_wall, notes=notes, engine=engine_name,
    )


# The record's points of a settled periodic attractor repeat to round-off: changes of the
# cycle's amplitude below this (relative to the largest sample) are noise, not a trend.
_NOISE = 1e-12
# ... and a change of the amplitude by less than this fraction over the record is no trend.
_TREND = 1e-6
# A period-k pattern whose points k apart differ by more than this fraction of the cycle's
# amplitude is not a cycle yet.
_SEPARATION = 1e-2


@dataclass(frozen=True)
class Attractor:
    """What a record of iterates says about the attractor.

    Attributes
    ----------
    period : int
        Smallest k with the points repeating every k iterates over the record (within
        ``rtol``), 0 when there is none up to ``max_period``.
    settled : bool
        The repetition is the attractor's, not a stage of a decaying transient: the
        differences between points ``d`` apart (each proper divisor ``d`` of the period)
        do not shrink geometrically towards zero across the record, and the points k
        apart differ by less than 1 % of those differences (the record must hold at least
        ``k + d + 1`` iterates to tell). True for periods 0 and 1.
    decay : float
        The ratio of the cycle amplitude at the end of the record to the one at its start
        (1.0 when not measured): about ``|mu|**(M - d - k)`` for a transient decaying with
        the multiplier ``mu`` onto period d.
    onto : int
        When not settled: the lower period the pattern is measured against.
    why : str
        When not settled: ``"lower"`` (the cycle's amplitude shrinks geometrically: a
        transient decaying onto period ``onto``), ``"moving"`` (points k apart still differ
        by more than 1 % of the amplitude) or ``"short"`` (too few points to tell).
    max_period : int
        The longest period looked for.
    """

    period: int
    settled: bool = True
    decay: float = 1.0
    onto: int = 0
    max_period: int = 64
    why: str = ""

    @property
    def label(self) -> str:
        """``"period k"``, ``"not settled"`` or ``"no period <= ..."`` for the summaries."""
        if self.settled:
            return f"period {self.period}" if self.period else \
                f"no period <= {self.max_period} (not settled, quasi-periodic or chaotic)"
        if self.why == "short":
            return (f"period-{self.period} pattern, too few points recorded to tell whether "
                    "it has settled")
        if self.why == "moving":
            return (f"not settled (a period-{self.period} pattern whose points still move by "
                    "more than 1 % of its amplitude)")
        return f"not settled (a transient decaying onto period {self.onto})"


def classify_attractor(samples: np.ndarray, rtol: float = 1e-7, max_period: int = 64
                       ) -> Attractor:
    """Period of a recorded sample sequence, and whether the record has settled.

    A transient decaying onto a period-1 orbit through a multiplier near -1 alternates:
    ``x_j = x* + c mu**j``. Its points two apart differ by ``|c| |mu|**j |1 - mu**2|``, ten
    times less than neighbours for ``mu = -0.9``: a record in which the neighbours differ by
    more than ``rtol`` and the points two apart by less looks like period 2. The two are told
    apart by the amplitude of the cycle (the largest difference between points ``d`` apart,
    ``d`` a proper divisor of the period, over one period of iterates): on a periodic
    attractor it stays the same over the record, on the transient it shrinks geometrically
    towards zero.

    Parameters
    ----------
    samples : ndarray, shape (M,) or (M, q)
        Recorded iterates of one parameter value.
    rtol : float
        Tolerance of the repetition relative to the largest sample magnitude (and 1e-12
        absolute). Keep it small (1e-7): the points of a period-2 orbit may nearly coincide
        in one probe (the voltage-mode buck's two v(out) samples differ by 1e-4 V near 26.6 V
        while the currents differ).
    max_period : int

    Returns
    -------
    Attractor
    """
    s = np.asarray(samples, dtype=float)
    if s.ndim == 1:
        s = s[:, None]
    if not np.all(np.isfinite(s)) or s.shape[0] < 2:
        return Attractor(0)
    scale = max(float(np.max(np.abs(s))), 1e-12)
    m = s.shape[0]
    for k in range(1, min(max_period, m - 1) + 1):
        if np.max(np.abs(s[k:] - s[:-k])) <= rtol * scale + 1e-12:
            break
    else:
        return Attractor(0, max_period=max_period)
    for d in _maximal_divisors(k):
        verdict, ratio = _settling(s, d, k, scale)
        if verdict != "settled":
            return Attractor(k, settled=False, decay=ratio, onto=d, why=verdict)
    return Attractor(k)


def _maximal_divisors(k: int) -> list[int]:
    """The proper divisors ``k / p`` of k, p its prime factors (every proper divisor divides
    one of them): the lower periods a period-k pattern could be decaying onto."""
    out, n, p = [], k, 2
    while p * p <= n:
        if n % p == 0:
            out.append(k // p)
            while n % p == 0:
                n //= p
        p += 1
    if n > 1:
        out.append(k // n)
    return out


def _settling(s: np.ndarray, d: int, k: int, scale: float) -> tuple[str, float]:
    """Whether the record's period-k pattern is the attractor's, seen against period d.

    Returns ``(verdict, ratio)``: ``"settled"`` (the points repeat every k iterates to
    round-off, or the cycle's amplitude at lag d stays while the k-apart differences die
    out: convergence onto a period-k orbit), ``"lower"`` (the amplitude shrinks
    geometrically with the k-apart differences: a transient onto period d), ``"moving"``
    (the k-apart points differ by more than 1 % of the amplitude: no cycle yet) or
    ``"short"`` (fewer than k + 1 differences at lag d); ``ratio`` is the amplitude's
    last/first.
    """
    e = np.max(np.abs(s[d:] - s[:-d]), axis=1)  # lag-d differences, (M - d,)
    r = np.max(np.abs(s[k:] - s[:-k]), axis=1)  # lag-k differences, (M - k,)
    noise = _NOISE * scale * 10
    if float(np.max(r)) <= noise:
        return "settled", 1.0  # repeats to round-off: a periodic orbit
    n = e.size
    if n < k + 1:
        return "short", float("nan")
    # Windows of k consecutive differences (every phase of the cycle once) at the start
    # and at the end of the record.
    amp_first, amp_last = float(np.max(e[:k])), float(np.max(e[n - k:]))
    ratio = amp_last / amp_first if amp_first > 0 else 0.0
    if float(np.max(r)) > _SEPARATION * float(np.max(e)):
        return "moving", ratio
    if amp_first - amp_last <= noise + _TREND * amp_first:
        return "settled", ratio  # the same amplitude
    # The amplitude shrinks. Onto period d, the k-apart differences are a fixed fraction of
    # it (x_j = x* + c mu^j: |1 - mu^k| / |1 - mu^d|) and shrink at its rate; converging
    # onto a period-k orbit, they die out while the amplitude stays.
    drift_first, drift_last = float(np.max(r[:k])), float(np.max(r[-k:]))
    if drift_last <= noise or drift_first <= 0.0:
        return "settled", ratio
    rate_amp = np.log(max(ratio, 1e-300))
    rate_drift = np.log(max(drift_last / drift_first, 1e-300))
    if rate_drift < 0 and 2.0 * rate_drift <= rate_amp <= 0.5 * rate_drift:
        return "lower", ratio  # both shrink at one rate (within a factor 2)
    return "settled", ratio


def attractor_period(samples: np.ndarray, rtol: float = 1e-6, max_period: int = 64) -> int:
    """Period of the attractor seen in a recorded sample sequence: the smallest period k of
    the record (see :func:`classify_attractor`), 0 if none up to ``max_period`` or if the
    record has not settled (a transient decaying onto a lower period).

    Parameters
    ----------
    samples : ndarray, shape (M, q)
        Recorded iterates of one parameter value.
    rtol : float
        Tolerance relative to the largest sample magnitude (and 1e-12 absolute).
    max_period : int
    """
    a = classify_attractor(samples, rtol, max_period)
    return a.period if a.settled else 0
