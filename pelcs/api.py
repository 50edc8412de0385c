"""The Python API for design scripts: load a netlist, formulate it, simulate it.

::

    import pelcs

    res = pelcs.simulate("converters/netlists/buck.cir", tstop="2m",
                         probes=["v(out)", "i(L1)"], params={"duty": 0.4})
    print(res.t[-1], res["v(out)"][-1])          # s, V

    circuit = pelcs.load("converters/netlists/buck.cir")
    system = pelcs.formulate(circuit)            # SwitchedLCS: one LCS per switch mode
    lcs = system.mode({"S1": True})              # A, B, C, D, E, F of the mode S1 on

Calling :func:`simulate` in a loop with other ``params`` is cheap: the netlist as read is
kept by the bytes of its files (an edited file is read again) and the formulated system by
the element values it depends on (not the independent sources'); each run still gives, bit
for bit, what a fresh parse gives (docs/performance.md, "Many runs of one netlist").

The analyses of the command line are functions of the same names and options, returning
result objects with ``.to_pandas()``, ``.plot()`` and a short summary
(:mod:`pelcs.api_analyses`)::

    orb = pelcs.orbit("converters/netlists/boost.cir", param={"duty": 0.4})
    orb.stability, orb.multipliers               # None when Newton did not converge
    sw = pelcs.sweep("converters/netlists/buck.cir", param={"duty": (0.2, 0.8, 7)},
                     measure=["mean(v(out))"])
    sw.to_pandas(), sw.plot()

Times accept SPICE text (``"5m"``, ``"0.2u"``) as well as numbers in seconds. Input errors
raise :class:`netlist.errors.NetlistError`; a run that cannot continue raises
:class:`lcs.results.SimulationError` whose ``.result`` holds everything up to the failure
(or pass ``check=False`` to get that result back with ``result.error`` set).
"""

from __future__ import annotations

import functools
import os
from collections.abc import Mapping, Sequence

from lcs.model import SwitchedLCS
from lcs.results import SimulationError, SimulationResult
from netlist.circuit import Circuit
from netlist.errors import Diagnostic, NetlistError

from .api_analyses import basins, bifurcation, check, continuation, orbit, sweep
from .api_results import Simulation, as_simulation

__all__ = ["SimulationError", "SimulationResult", "ac", "basins", "bifurcation", "check",
           "continuation", "formulate", "load", "orbit", "simulate", "sweep"]

Source = Circuit | str | os.PathLike


def load(path_or_text: str | os.PathLike, params: Mapping[str, float] | None = None,
         *, thresholds: Mapping[str, float] | None = None) -> Circuit:
    """Parse a netlist file or netlist text into a flattened circuit.

    Parameters
    ----------
    path_or_text : str, path-like or PySpice Circuit
        A file path, or the netlist itself: a string with a line break is taken as netlist
        text (its first line is the title, as in SPICE); a ``PySpice.Spice.Netlist.Circuit``
        is read from the SPICE text PySpice renders (its ``.include`` files too).
    params : mapping of str to float or str, optional
        Overrides of global ``.param`` values; a value may be SPICE text (``"100k"``).
    thresholds : mapping of str to float, optional
        Switch thresholds (V) of transistors (M, Q) idealised as switches, by element or
        model name; ``circuit.replacements`` lists what each device became
        (:mod:`netlist.devices`).

    Returns
    -------
    Circuit

    Raises
    ------
    NetlistError
        Every problem found in the netlist, or a missing file.
    """
    from netlist.parser import load_source

    return load_source(path_or_text, params, thresholds, reuse=True)


def formulate(circuit: Source, params: Mapping[str, float] | None = None) -> SwitchedLCS:
    """The switched linear complementarity system of a circuit.

    Parameters
    ----------
    circuit : Circuit, or a path or netlist text for :func:`load`
    params : mapping, optional
        ``.param`` overrides (only with a path or text).

    Returns
    -------
    SwitchedLCS
        ``system.mode({"S1": True})`` is the LCS of one switch configuration (built on first
        use); ``system.states``, ``.inputs``, ``.diodes``, ``.switches`` name its variables.
    """
    from netlist.formulation import formulate as _formulate

    return _formulate(_circuit(circuit, params))


def simulate(
    circuit_or_path: Source,
    tstop: float | str | None = None,
    step: float | str | None = None,
    theta: float | None = None,
    probes: Sequence[str] | str | None = None,
    every: int = 1,
    params: Mapping[str, float] | None = None,
    *,
    check: bool = True,
    progress: bool = False,
    switching: str | None = None,
    controllers: Sequence = (),
    strict: bool = False,
    devices: str = "ideal",
    losses: bool = False,
    load: str | None = None,
    pwl: Mapping[str, tuple[float, float]] | None = None,
    output_step: float | str | None = None,
    keep_events: int | None = None,
) -> Simulation:
    """Simulate a circuit with the Moreau θ time-stepping scheme.

    Parameters
    ----------
    circuit_or_path : Circuit, or a path or netlist text for :func:`load`
    tstop, step : float or str, optional
        Stop time and step, s (or SPICE text such as ``"5m"``); default from ``.tran``
        (step: the bound ngspice puts on its own, ``netlist.studies.timestep.tran_step``).
    theta : float, optional
        θ in [1/2, 1]: 1/2 trapezoidal (second order between events), 1 backward Euler.
        Default 1/2, or 1 where :mod:`lcs.integrators.moreau.theta_screen` finds θ < 1 unreliable
        (noted; ``res.theta`` is the value used).
    probes : sequence of str, or str, optional
        ``"v(out)"``, ``"v(a,b)"``, ``"i(L1)"``, ``"i(D1)"``...; default every state.
    every : int
        Keep every N-th step (the first and the last point are always kept).
    params : mapping, optional
        ``.param`` overrides (only with a path or text).
    check : bool
        Raise :class:`SimulationError` when the run fails (default); with False, return the
        partial result with ``result.error`` set.
    progress : bool
        Progress bar on a terminal for runs longer than about a second.
    switching : str, optional
        Comparator method for every switch (``"auto"``, ``"implicit"``, ``"explicit"``,
        ``"hysteresis"``; docs/switching.md).
    controllers : sequence, optional
        :mod:`lcs.controllers` objects driving named switches (e.g.
        ``OpenLoopPWM("S1", 50e3, 0.4)``) instead of their netlist control.
    strict : bool
        A circuit that is certainly not passive (a negative resistance, an active source
        feeding a diode) raises :class:`NetlistError` instead of a
        :class:`~lcs.theory.passivity.NonPassiveWarning` (the run then goes on and may grow
        without bound; a state growth beyond 1e6 is noted in ``res.notes``).
    devices : str
        ``"ideal"`` or ``"pwl"``: diodes with a Vf and Ron fitted to their models, switches
        with their on-resistance (``res.device_fits``; :mod:`netlist.pwl`); ``pwl``
        gives ``{element or model name: (vf, ron)}`` instead of the fit.
    losses : bool
        ``res.losses`` (:class:`netlist.studies.losses.LossReport`): conduction losses per device,
        input and output power (``load``: the load resistor's name, default the resistor
        taking the most power) and efficiency over the steady-state window.
    output_step : float or str, optional
        The points returned: ``None`` (default) every stored step (every ``every``-th, and
        the switching instants); a spacing (s, or SPICE text such as ``"1u"``) or
        ``"tran"`` (what ``pelcs simulate`` writes by default: the ``.tran`` TSTEP grid, or
        every step where that grid is finer than the step or too coarse for the sources)
        the instants ``k dt`` from TSTART on, linearly interpolated between the stored
        points (:func:`lcs.results.resample`). The run then holds that grid and not every
        step (``res.stats.points_stored`` counts the steps stored on the way).
    keep_events : int, optional
        Keep only the last ``keep_events`` switchings in ``res.events`` and count the others
        (``res.switchings``). With ``output_step`` as well, the run's memory does not grow
        with its length. Default: every switching (12 bytes each).

    Returns
    -------
    pelcs.api_results.Simulation
        A :class:`~lcs.results.SimulationResult`: ``res.t`` (s, shape (N,)), ``res["v(out)"]``
        (shape (N,), SI units), ``res.y`` (shape (N, len(probes))), ``res.names``,
        ``res.notes``, ``res.stats``; ``res.to_pandas()``, ``res.plot(ax=None)`` (the
        figure of ``pelcs simulate --plot``) and a notebook display.

    Raises
    ------
    NetlistError
        Input errors: the netlist, unknown probes, bad times, a degenerate topology.
    SimulationError
        With ``check=True``, a step without a (unique) solution or a non-finite state; the
        partial result is ``exc.result``.
    """
    from netlist.studies.transient import simulate_circuit

    circuit = _circuit(circuit_or_path, params)
    if isinstance(probes, str):
        probes = [probes]
    kw = dict(tstop=_seconds(circuit, "tstop", tstop), step=_seconds(circuit, "step", step),
              theta=theta, probes=probes, every=every, progress=progress,
              switching=switching, controllers=controllers, strict=strict)
    if output_step is not None and not (isinstance(output_step, str)
                                        and output_step.strip().lower() == "tran"):
        output_step = _seconds(circuit, "output_step", output_step)
        if not (isinstance(output_step, (int, float)) and output_step > 0):
            raise ValueError(f"output_step must be positive, got {output_step!r}")
    elif output_step is not None:
        output_step = "tran"
    if devices != "ideal" or losses:
        from netlist.studies.realistic import simulate_devices

        # (the losses are integrated over every step: the grid is taken afterwards)
        result = simulate_devices(circuit, devices=devices, losses=losses, load=load,
                                  pwl=dict(pwl or {}), **kw)
        if output_step is not None:
            from lcs.results import resample
            from netlist.studies.transient import transient_setup

            dt = output_step
            if dt == "tran":
                dt = transient_setup(circuit, tstop=kw["tstop"], step=kw["step"]).print_step
            if dt is not None:
                result = resample(result, dt)
    else:
        # (the system is kept for the next run; its stored shortened steps are not, so that
        # this run gives what a newly parsed netlist gives, bit for bit)
        from netlist.studies.left_out import models_left_out
        from netlist.system_cache import reused_system

        result = simulate_circuit(circuit, system=reused_system(circuit),
                                  options=_fresh_steps_options(), output_step=output_step,
                                  keep_events=keep_events, **kw)
        if note := models_left_out(circuit):
            result.notes.append(note)
    result = as_simulation(result)
    if result.error is not None:
        result.error.result = result
    if check:
        result.raise_if_error()
    return result


def ac(
    circuit: Source,
    *,
    period: float | str | None = None,
    inject: str | None = None,
    probes: Sequence[str] = (),
    freq: Sequence[float] | str | None = None,
    loop: str | None = None,
    method: str = "exact",
    params: Mapping[str, float] | None = None,
    freqs: Sequence[float] | str | None = None,
    **options,
):
    """Small-signal frequency response of a switching converter around its periodic steady
    state (``pelcs ac``).

    ::

        fr = pelcs.ac("buck_vc.cir", period="ts", inject="Vc", probes=["v(out)"],
                      freq=np.logspace(2, 4.7, 50))   # or freq="100:50k:50", as --freq
        fr.freq, fr["v(out)"]            # Hz, complex V/V
        fr.mag_db("v(out)"), fr.phase_deg("v(out)")
        fr.to_frd()                      # python-control FrequencyResponseData
        fr.model                         # sampled-data model: discrete-time StateSpace

    Parameters
    ----------
    circuit : Circuit, path or netlist text
    period : float or str, optional
        Switching period, s (SPICE text or a ``.param`` name); default the period the
        netlist defines (:func:`netlist.studies.measure.defined_period`, named in ``.notes``).
    inject : str
        Independent source to perturb (control-to-output: a DC control source;
        line-to-output: the input source; output impedance: a zero-valued current source).
    probes : sequence of str
    freq : sequence of float or str, optional
        Hz, or the ``--freq`` text ``"FMIN:FMAX[:N]"`` (N log-spaced, default 30) or ``"F"``;
        default 30 points from fs/1000 to fs/2. The name of the command's ``--freq`` and of
        the result's ``.freq``; ``freqs=``, the earlier name, is still taken.
    loop : str, optional
        Zero-volt source in the feedback path: loop gain ``"T"`` and ``.margins``.
    method : str
        ``"exact"`` or ``"sweep"``.
    params : mapping, optional
        ``.param`` overrides (with a path or text).
    **options
        Passed to :func:`netlist.studies.ac.ac_analysis` (``step``, ``theta``, ``amplitude``,
        ``settle``, ``cycles``, ...).

    Returns
    -------
    lcs.smallsignal.FrequencyResponse
    """
    from netlist.studies.ac import ac_analysis
    from netlist.studies.sweep import parse_value

    if freqs is not None:
        if freq is not None:
            raise TypeError("pelcs.ac: give freq= (freqs= is its earlier name), not both")
        freq = freqs
    if isinstance(freq, str):
        from netlist.studies.ac import parse_frequencies

        freq = parse_frequencies(freq, what="freq=")
    c = _circuit(circuit, params)
    if isinstance(period, str):
        try:
            period = parse_value(period, "period")
        except NetlistError:
            pass  # a .param name
    return ac_analysis(c, period=period, inject=inject, probes=probes, freqs=freq,
                       loop=loop, method=method, **options)


@functools.cache
def _fresh_steps_options():
    """``MoreauOptions(keep_odd_steps=False)`` (frozen: one for every run)."""
    from lcs.integrators.moreau.integrator import MoreauOptions

    return MoreauOptions(keep_odd_steps=False)


def _circuit(source: Source, params: Mapping[str, float] | None) -> Circuit:
    if isinstance(source, Circuit):
        if params:
            raise TypeError("params need a netlist path or text: a parsed Circuit has its "
                            "parameters evaluated already (pelcs.load(path, params=...))")
        return source
    from netlist.parser import is_pyspice_circuit

    if isinstance(source, (str, os.PathLike)) or is_pyspice_circuit(source):
        return load(source, params)
    raise TypeError(f"expected a Circuit, a netlist path, netlist text or a PySpice Circuit, "
                    f"got {type(source).__name__}")


def _seconds(circuit: Circuit, what: str, value: float | str | None) -> float | None:
    from netlist.units import parse_number

    if value is None or not isinstance(value, str):
        return value
    seconds = parse_number(value.strip())
    if seconds is None:
        raise NetlistError(Diagnostic(f"{what}: {value!r} is not a time",
                                      hint="seconds as a number or SPICE text, e.g. '5m'"),
                           file=circuit.file)
    return seconds

