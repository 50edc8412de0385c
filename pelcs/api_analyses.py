"""The analyses of the command line as Python functions: ``pelcs.check``, ``pelcs.orbit``,
``pelcs.continuation``, ``pelcs.bifurcation``, ``pelcs.basins``, ``pelcs.sweep``.

Each takes the netlist file and the options of its command as keyword arguments of the same
names (``--locate-tol`` is ``locate_tol``; :mod:`pelcs.api_options` says which Python values
they take besides the command-line text), parses them with the command's parser, runs the
same code as the command (the ``prepare``/``compute`` functions of
:mod:`pelcs.commands`), and returns a result object (:mod:`pelcs.api_results`) holding what
the command's ``--json`` prints, with ``.to_pandas()``, ``.plot()`` and a short ``repr``.
Without ``period``, the period is the one the netlist defines, as in the command.

Errors: input errors raise :class:`netlist.errors.NetlistError` (its message is the
command's); an option the command does not have raises TypeError, a value its parser refuses
ValueError; a map that fails raises :class:`lcs.analysis.maps.MapError`. What the command
reports with exit status 3 without failing (an orbit Newton did not converge to, a
continuation that stopped early) is a result saying so.
"""

from __future__ import annotations

import contextlib
import os
import warnings
from collections.abc import Mapping, Sequence

from .api_options import namespace
from .api_results import (
    BasinsResult,
    BifurcationResult,
    CheckResult,
    ContinuationResult,
    OrbitResult,
    SweepResult,
)

__all__ = ["basins", "bifurcation", "check", "continuation", "orbit", "sweep"]

Path = str | os.PathLike
Params = Mapping[str, object] | Sequence[str] | None
Texts = Sequence[str] | str | None


@contextlib.contextmanager
def _strictness(strict: bool):
    """``strict``: a circuit that is not passive, or a transistor idealised, raises (as the
    command's ``--strict``); else the warning is shown once."""
    from lcs.notices import IdealisedDeviceWarning, NonPassiveWarning

    with warnings.catch_warnings():
        for category in (NonPassiveWarning, IdealisedDeviceWarning):
            warnings.simplefilter("error" if strict else "once", category)
        yield


def _options(values: dict) -> dict:
    """The keyword arguments of an API function that are options of its command."""
    return {k: v for k, v in values.items() if k not in ("file", "strict")}


def check(file: Path, *, probe: Texts = None, param: Params = None, tstop=None, period=None,
          pelcs_param: Params = None, devices: str = "auto", timeout="600",
          strict: bool = False) -> CheckResult:
    """``pelcs check``: simulate the netlist with pelcs and with ngspice, and compare.

    Parameters
    ----------
    file : path
        The netlist file.
    probe : str or list of str, optional
        ``"v(out)"``, ``"i(L1)"``... (default every state).
    param : mapping or list of ``"NAME=VALUE"``, optional
        ``.param`` overrides in both simulators.
    tstop, period : float (s) or SPICE text, optional
        Stop time (default ``.tran``'s) and steady-state period (default found).
    pelcs_param : mapping, optional
        Overrides in pelcs only (a deliberate difference).
    devices : ``"auto"``, ``"ideal"`` or ``"pwl"``
    timeout : float (s) or text
        ngspice's wall-time limit per ladder rung.
    strict : bool
        Refuse a circuit that is not passive.

    Returns
    -------
    CheckResult
        ``.verdict`` (``"ok"``, ``"fail"``, ``"inconclusive"``), ``.verdict_line`` (what the
        command prints: ``within tolerance``, ``OUT OF TOLERANCE: ...``,
        ``INCONCLUSIVE: ...``), ``.table``, ``.report`` (its ``--json``).

    Raises
    ------
    ngspice_checks.runner.NgspiceUnavailable, NgspiceFailed, ngspice_checks.compare.CheckError
        The comparison could not be made (the command's exit status 3).
    """
    opts = _options(locals())
    from pelcs.commands import check as command

    args = namespace("check", file, opts, function="pelcs.check")
    with _strictness(strict):
        cmp = command.compare(args)
    return CheckResult(comparison=cmp, report=cmp.to_dict())


def orbit(file: Path, *, period=None, param: Params = None, order=1, transient=100,
          x0=None, step=None, theta=None, t0=0, event: str | None = None,
          method: str = "moreau", tol="1e-10", strict: bool = False) -> OrbitResult:
    """``pelcs orbit``: a period-``order`` orbit of the stroboscopic map by Newton shooting,
    its Floquet multipliers, stability and switching pattern.

    Parameters
    ----------
    file : path
    period : float (s), SPICE text or a ``.param`` name, optional
        Default: the period the netlist defines (its note in ``.report["notes"]``).
    param : mapping or list of ``"NAME=VALUE"``, optional
    order, transient : int
        The orbit's period in periods T; periods simulated before Newton.
    x0 : mapping or text, optional
        Initial state, e.g. ``{"v(C1)": 12}`` (others: the netlist's IC).
    step, theta, t0 : optional
        Time step (s), Moreau θ, sampling phase (s).
    event : str, optional
        Sample at an event (``"S1:on"``, ``"v(out)>12"``) instead of every T.
    method : ``"moreau"`` or ``"exact"``
    tol : float
        Newton tolerance on the scaled residual.
    strict : bool

    Returns
    -------
    OrbitResult
        ``.converged``, ``.points``, ``.multipliers`` (None when not converged),
        ``.stability``, ``.report`` (the command's ``--json``).
    """
    opts = _options(locals())
    from pelcs.commands import orbit as command

    args = namespace("orbit", file, opts, function="pelcs.orbit")
    with _strictness(strict):
        report, found = command.compute(args)
    return OrbitResult(orbit=found, report=report)


def continuation(file: Path, *, param: Params, period=None, order=1, tol="1e-10",
                 locate_tol=None, transient=100, no_locate: bool = False, x0=None,
                 step=None, theta=None, t0=0, method: str = "moreau", start: Texts = None,
                 workers=None, scheduler: str | None = None,
                 strict: bool = False) -> ContinuationResult | list[ContinuationResult]:
    """``pelcs continue``: follow a periodic orbit as a ``.param`` varies; locate its
    bifurcations (flip, fold, Neimark-Sacker, border collisions).

    Parameters
    ----------
    file : path
    param : mapping or list
        Exactly one range, ``{"vin": "20:30:41"}`` or ``{"vin": (20, 30, 41)}`` (N values,
        N - 1 steps; default N 41), and fixed overrides.
    period, order, tol, transient, x0, step, theta, t0, method : optional
        As :func:`orbit`.
    locate_tol : float, optional
        Bisection tolerance in the parameter (default ``|STOP - START| * 1e-4``).
    no_locate : bool
        Report the step brackets without bisection.
    start : str or list of str, optional
        Continue from these starting states (``"v(C1)=10:30:3"``), in parallel.
    workers, scheduler : optional
        Worker processes; a Dask scheduler's address.
    strict : bool

    Returns
    -------
    ContinuationResult
        ``.complete``, ``.bifurcations``, ``.report`` (the command's ``--json``); with
        ``start``, a list of them, one per start (``.report["same_as"]``: the index of an
        earlier start with the same orbit, or None).
    """
    opts = _options(locals())
    from pelcs.commands import continuation as command

    args = namespace("continue", file, opts, function="pelcs.continuation")
    with _strictness(strict):
        setup = command.prepare(args)
        if args.start:
            report, results = command.compute_many(args, setup)
            head = {k: v for k, v in report.items() if k != "continuations"}
            return [ContinuationResult(result=res, report={**head, **c})
                    for c, res in zip(report["continuations"], results, strict=True)]
        report, res = command.compute(args, setup)
    return ContinuationResult(result=res, report=report)


def bifurcation(file: Path, *, param: Params, transient, record, period=None,
                probe: Texts = None, follow: bool = False, direction: str = "both",
                chunks=None, x0=None, step=None, theta=None, t0=0, method: str = "moreau",
                confirm: bool = False, workers=None, scheduler: str | None = None,
                strict: bool = False) -> BifurcationResult:
    """``pelcs bifurcation``: the probes sampled once per period over ``record`` periods
    after ``transient``, at every value of one ``.param``.

    Parameters
    ----------
    file : path
    param : mapping or list
        Exactly one range (``{"duty": "0.3:0.6:200"}``, ``(START, STOP, N)`` or evenly
        spaced values; default N 200) and fixed overrides.
    transient, record : int
        Periods discarded, periods recorded.
    period : optional
        As :func:`orbit`.
    probe : str or list of str, optional
        Default every state.
    follow : bool
        Start each value from the previous one's final state, ``direction`` ``"up"``,
        ``"down"`` or ``"both"``; ``chunks`` independent pieces per direction.
    confirm : bool
        Confirm each run of the summary with the orbit solver (``.summary_text``).
    x0, step, theta, t0, method, workers, scheduler, strict : optional

    Returns
    -------
    BifurcationResult
        ``.diagram``, ``.runs`` (the attractor period along the parameter),
        ``.summary_text`` (what the command prints).
    """
    opts = _options(locals())
    from pelcs.commands import bifurcation as command

    args = namespace("bifurcation", file, opts, function="pelcs.bifurcation")
    with _strictness(strict):
        setup = command.prepare(args)
        diagram = command.compute(args, setup)
        confirmations = command.confirm_runs(diagram, setup["factory"]) if confirm else None
    title = setup["circuit"].title
    runs = [(b.direction, *run) for b in diagram.branches
            for run in command.period_runs(b.values, b.samples, b.ok, b.messages)]
    text = command.summary(diagram, str(file), title, setup["m"], [], confirmations)
    return BifurcationResult(diagram=diagram, file=str(file), title=title,
                             summary_text=text, runs=runs)


def basins(file: Path, *, grid, period=None, param: Params = None, x0=None, step=None,
           theta=None, t0=0, method: str = "moreau", no_merge: bool = False, workers=None,
           scheduler: str | None = None, strict: bool = False) -> BasinsResult:
    """``pelcs basins``: attractors and their basins over a grid of two states (simple cell
    mapping, one period T per cell).

    Parameters
    ----------
    file : path
    grid : mapping or str
        Two states and their cells: ``{"v(C1)": (0, 24, 12), "i(L1)": (0, 4, 10)}`` or
        ``"v(C1)=0:24:12,i(L1)=0:4:10"`` (default 100 cells per axis).
    period, param, x0, step, theta, t0, method : optional
        As :func:`orbit`; the other states are fixed at the initial state.
    no_merge : bool
        Keep touching periodic groups as separate attractors.
    workers, scheduler, strict : optional

    Returns
    -------
    BasinsResult
        ``.basins`` (``group``, ``steps``, ``attractors``), ``.summary_text``.
    """
    opts = _options(locals())
    from pelcs.commands import basins as command

    args = namespace("basins", file, opts, function="pelcs.basins")
    with _strictness(strict):
        setup = command.prepare(args)
        bm = command.compute(args, setup)
    title = setup["factory"].circuit().title
    return BasinsResult(basins=bm, file=str(file), title=title,
                        summary_text=command.summary(bm, str(file), title, setup["m"], []))


def sweep(file: Path, *, measure: Texts, param: Params = None, tolerance=None, runs=None,
          seed=None, distribution: str = "uniform", tstop=None, step=None, theta=None,
          period=None, workers=None, scheduler: str | None = None,
          strict: bool = False) -> SweepResult:
    """``pelcs sweep``: steady-state measurements over a ``.param`` grid and/or Monte Carlo
    runs.

    Parameters
    ----------
    file : path
    measure : str or list of str
        ``"mean(v(out))"``, ``"ripple(i(L1))"`` (mean, avg, rms, ripple, pp, min, max,
        final).
    param : mapping or list, optional
        Swept values (``"0.2:0.8:7"``, ``(0.2, 0.8, 7)``, a list of values; default N 11)
        and fixed overrides; the netlist's ``.step`` lines are swept too.
    tolerance : mapping or list, optional
        Monte Carlo tolerances, ``{"C*": "10%", "R1": "5%"}``, with ``runs`` and ``seed``
        and ``distribution`` (``"uniform"`` or ``"gaussian"``).
    tstop, step, theta, period : optional
    workers, scheduler, strict : optional

    Returns
    -------
    SweepResult
        ``.table``, ``.report`` (the command's ``--json``), ``.summary_text``.
    """
    opts = _options(locals())
    from pelcs.commands import sweep as command

    args = namespace("sweep", file, opts, function="pelcs.sweep")
    with _strictness(strict), command.labelled_errors():
        setup = command.prepare(args)
        table = command.compute(args, setup)
    title = setup["title"]
    return SweepResult(table=table, report=command.to_json(table, str(file), title, []),
                       summary_text=command.summary(table, str(file), title, []),
                       plot_title=command.plot_title(table, title, str(file)))
