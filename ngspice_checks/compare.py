"""Simulate one netlist with pelcs and with ngspice and compare the waveforms.

Entry point: :func:`compare` (``pelcs check FILE`` on the command line). It returns a
:class:`Comparison` with one :class:`ProbeComparison` per probe, one
:class:`SwitchingComparison` per switch, both wall times and the ngspice rung that was needed;
``pelcs.check_report`` turns it into a table, a figure, Markdown and JSON.

One circuit, two simulators
---------------------------
The netlist is parsed once into a :class:`~netlist.circuit.Circuit` (with the ``--param``
overrides). pelcs simulates that circuit; ngspice runs ``netlist.writer.write_circuit`` of the
*same* object (flattened, every value evaluated), so both see identical element values. The
only differences between the two decks are these, each reported in ``Comparison.notes``:

- both get ``UIC`` on the ``.tran`` line when the netlist has none: they start from the same
  initial conditions (without it each would start from its own DC operating point, which
  ideal and real devices make differ);
- commands pelcs ignores (``.save``, ``.control`` blocks, ``.four``, ``.meas``, ``.print``)
  are left out: a ``.save`` would hide the probes' vectors and a ``.control`` block would run
  the analysis a second time;
- the runner's ladder (:mod:`ngspice_checks.runner`) may add options, finite PULSE edges or
  smoother models; ``Comparison.rung`` and ``.settings`` say which rung ran.

A stop time given to :func:`compare` shortens both runs alike.

Time alignment
--------------
ngspice's time points are uneven and not pelcs' grid. Both results are interpolated linearly
onto one uniform grid over their common time span, with the spacing of the pelcs step (the
``.tran`` TMAX or TSTEP). Interpolating a waveform that jumps at a switching instant (a diode
current, a switch-node voltage) smears the jump over one grid step, and two simulators that
switch a few nanoseconds apart disagree there by the whole jump: grid points within
``guard`` of a switching instant (of either simulator) are left out of the RMS error, with
``guard`` = one grid step + the largest switching offset measured (the excluded fraction is
reported; about 4 % for 100 steps per period).

Devices: like with like
-----------------------
ngspice runs the netlist's device models. pelcs runs ideal devices, or (``devices="pwl"``,
and by default when the netlist has idealised transistors or macro-models, or diode and
switch models whose drops would widen the tolerances past their floors, k·δ > 1 %)
piecewise-linear fits of those models (:mod:`netlist.pwl`: diodes fitted over the current
they carry in an ideal run, switches with their on-resistance, MOSFETs with their gate RC):
the run ``pelcs simulate --devices pwl`` makes, on the circuit it builds
(:func:`netlist.studies.realistic.pwl_run`: refits, junction charges, breakdown branches).
docs/check.md says how the choice is made.

Metrics and their tolerances
----------------------------
ngspice's diodes and switches are not ideal: a diode with ``N = 0.05`` drops about 36 mV at
1 A, a switch drops RON·I, and what of these drops pelcs does not represent is what separates
a correct pelcs run from ngspice's. The tolerances scale with it through the *relative
non-ideal drop*

    δ = (Σ_diodes V_D(I_D) + Σ_switches RON·I_S) / V_ref,

with V_D(I) = N·Vt·ln(1 + I/IS) + RS·I (Vt = 25.85 mV, ngspice's defaults IS = 1e-14,
N = 1, RS = 0, RON = 1 ohm when the model omits them), I the current each element carries
in the pelcs run (:func:`netlist.pwl.carried_current`: the level it stays below for 99 % of
its conduction time, so that an inrush only the time step limits does not count), V_ref the
largest source voltage. With piecewise-linear devices the drops are replaced by what the fits
leave: per diode the largest distance between its line and its model over the currents it
carries, per MOSFET the triode curvature, per SW switch nothing. The sum over every diode and
switch bounds the drop along any one current path. Each probe gets a *scale*
s = max(RMS, ½·peak-to-peak) of its pelcs waveform over the run (its RMS for a signal with a
DC level, its amplitude for an AC one). With k = :attr:`Tolerances.k_nonideal` (2):

==========================  ===============================  ===============================
metric                      definition                       passes when
==========================  ===============================  ===============================
NRMS error                  RMS(ngspice - pelcs) / s on the  <= 3 % + k·δ
                            common grid (guard excluded)
mean                        time average over the last       |diff| / s <= max(1 %, k·δ)
                            whole periods, each side's own
                            samples (trapezoidal)
ripple                      peak-to-peak over the same       |diff| <= 10 % of pelcs' ripple
                            periods                          + (0.5 % + k·δ)·s
switching instants          per switch and direction, the    <= 3 ngspice steps (its TMAX:
                            largest distance from an         ``.tran`` TMAX, else min(TSTEP,
                            instant of one simulator to the  TSTOP/50)); + one pelcs step
                            nearest of the other (both       for sampled (explicit/latched)
                            ways); whole run for a source-   switches; + max(1 %, k·δ) of
                            driven switch, steady-state      the period for comparator
                            window for a comparator          switches
switching frequency         turn-ons per second over the     within 10 %
                            window (free-running switches)
==========================  ===============================  ===============================

Where the instants come from: pelcs' ``result.events``; ngspice's crossings of the switch's
control voltage ``v(nc+, nc-)`` through VT, with VH and the ON/OFF flag as in ngspice's SW
model, interpolated between its time points. For a switch with hysteresis (VH > 0) both
sides are measured alike at the crossings of the *half* band VT ± VH/2: ngspice stores the
control after its switch has acted, up to one step's change short of the band edge, so the
edges themselves are not reliably crossed in its output. An instant within the tolerance
of the start or end of the common run with no partner within the tolerance is left out (and
counted in ``SwitchingComparison.note``): its partner would lie past that end, where neither
run shows it (pelcs records no event at its last time point; ngspice interpolates a
switching at its last point a fraction of a step early), and pairing it with the previous
instant reads as an offset of a whole period.

A comparison whose NRMS or mean tolerance exceeds :attr:`Tolerances.conclusive` (10 %) is
*inconclusive* (``Comparison.verdict``; ``pelcs check`` exits 4), never agreement: such a
tolerance lets a tenfold load error through. A switch that switches in one simulator and
never in the other fails.

Why these numbers: the 1 % / 3 % floors are ngspice's own accuracy on these circuits
(``reltol`` 1e-3 locally, ``relaxed`` rung 1e-2, errors that accumulate over thousands of
switching periods) and the ideal-element comparisons in ``tests/test_ngspice_converters.py``;
the k·δ terms are twice the first-order effect of the drops (a drop of ΔV on a path moves an
average by about ΔV, and the conversion ratio can amplify it, e.g. 1/(1-D) in a boost); the
ripple floor keeps a nearly flat waveform (an LC-filtered output) from failing on
numerical noise; ngspice does not locate switching instants but lands them on its time
steps (comparator switches) or on the PULSE corners (gate-driven ones), hence a few of its
steps. A comparator's instant also follows the circuit state: an offset of ε·T changes its
duty cycle by ε and a period average by about ε, which the mean tolerance allows anyway;
in a transient its crossing of a ramp can be nearly tangential (ill-conditioned), hence the
steady-state window. The instants are compared where both define them the same way: a
switch that pelcs slides on (implicit Filippov relay, ``result.sliding``) has no instants
there, and a free-running switch (a hysteretic comparator without any periodic source, e.g. a
sliding-mode current loop or a relaxation oscillator) accumulates phase drift over many
periods, so its switching *frequency* over the last periods is compared instead.

Sensitive runs (state-driven switching)
---------------------------------------
Where a switch follows the state (a comparator), pelcs also runs perturbed (half its step,
comparators sampled on its grid) and, when the window still fails, restarted from ngspice's
state at the window's start: :mod:`ngspice_checks.sensitivity` gives the rules (the window
only, a transient judged by pelcs' own change, inconclusive on a sensitive orbit or on
coexisting orbits).

Period
------
The mean and the ripple are taken over the last whole periods (up to 10, at most a quarter of
the run). The period is, in this order: the ``period`` argument (``--period``); the period
of the source that drives a switch's control directly (a PULSE gate, a ramp); the longest
PULSE period / SIN 1/FREQ among the sources; the median time between recurrences of the last
switch mode in the pelcs run (free-running converters). Without any of these the window is
the last 20 % of the run.
"""

from __future__ import annotations

import copy
import math
import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from lcs.results import SimulationResult
from netlist.circuit import (
    GROUND,
    Capacitor,
    Circuit,
    Diode,
    Switch,
)
from netlist.errors import Diagnostic, NetlistError
from netlist.probes import voltage_probe
from netlist.pwl import carried_current
from netlist.time_value import internal_nodes

from .comparison import Comparison, ProbeComparison, SwitchingComparison, Tolerances
from .measures import (
    _SWITCH_DEFAULTS,
    NonIdeality,
    _frequency,
    _hausdorff,
    _in_window,
    _Instants,
    _mean,
    _model_params,
    _ngspice_instants,
    _nonideality,
    _pelcs_instants,
    _pwl_residual,
    _scale,
    _strictly_increasing,
    _unpaired_at_ends,
    _window,
    detect_period,
)
from .runner import NgspiceSettings, ProbeError, ngspice_version, run_ngspice
from .sensitivity import _nrms, _perturbed_runs, _restart_check, _sensitivity, run_theta

__all__ = [
    "CheckError",
    "Comparison",
    "NonIdeality",
    "ProbeComparison",
    "SwitchingComparison",
    "Tolerances",
    "compare",
    "default_probes",
    "detect_period",
    "ngspice_probe",
]


#: switch kinds (``SimulationResult.switching``) whose instants fall on pelcs' grid
_SAMPLED = ("explicit", "latched")


class CheckError(RuntimeError):
    """The comparison could not be made: the pelcs run failed.

    Input problems (no probes to compare, ``d(S)`` probes, no stop time) are
    :class:`~netlist.errors.NetlistError`, as everywhere in pelcs.
    """


def _input_error(message: str, hint: str = "", file: str = "<netlist>") -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file=file)


# ------------------------------------------------------------------------------------------
# probes


def _node_set(circuit: Circuit) -> set[str]:
    return {n.lower() for n in circuit.nodes} | {"gnd"}


def default_probes(circuit: Circuit) -> list[str]:
    """Every state of the circuit: ``i(L…)`` and ``v(C…)`` in netlist order.

    The states are what both simulators integrate; they are continuous in time (so a
    pointwise comparison is meaningful even across switching instants) and every other
    waveform follows from them. A capacitor's ``v(C1)`` is measured in ngspice as the node
    voltage difference across it (:func:`ngspice_probe`). ``v(out)`` is usually one of them.

    Raises
    ------
    NetlistError
        The circuit has no inductor and no capacitor.
    """
    from netlist.reductions import source_capacitors

    held = set(source_capacitors(circuit))  # voltage sources alone across them: no state
    nodes = _node_set(circuit)

    def state(el) -> str:
        if el.kind == "L":
            return f"i({el.name})"
        if el.name.lower() in nodes:  # (v(C1) reads a node c1 in both)
            return voltage_probe(*el.nodes[:2])
        return f"v({el.name})"

    out = [state(el) for el in circuit.elements
           if el.kind in ("L", "C") and el.key not in held]
    if not out:
        raise _input_error("the circuit has no inductor or capacitor to compare by default",
                           "give the probes: --probe 'v(out)'", circuit.file)
    return out


def ngspice_probe(circuit: Circuit, probe: str) -> str:
    """The ngspice runner's spelling of a pelcs probe.

    ``v(C1)`` (a capacitor, when no node is called ``c1``) becomes ``v(n+,n-)``, or
    ``v(n+)`` when n- is ground; everything else is passed as it is (the runner reads
    ``i(X)`` of any two-terminal element).

    Raises
    ------
    NetlistError
        ``d(S1)`` (a switch's on-fraction) has no ngspice counterpart.
    """
    text = probe.strip()
    head = text[:2].lower()
    if head == "d(":
        raise _input_error(f"probe {probe!r}: the on-fraction d(S) exists in pelcs only",
                           "compare v(...) and i(...) probes", circuit.file)
    if head == "v(" and "," not in text:
        name = text[2:-1].strip()
        if name.lower() not in _node_set(circuit):
            try:
                el = circuit.element(name)
            except KeyError:
                return text
            if isinstance(el, Capacitor):
                return voltage_probe(*el.nodes[:2])
    return text


# ------------------------------------------------------------------------------------------
# the comparison


def _prepare(circuit: Circuit, tstop: float | None, notes: list[str]) -> Circuit:
    """A copy of the circuit as both simulators will run it (see the module docstring)."""
    c = copy.deepcopy(circuit)
    if c.tran is None:
        if tstop is None:
            raise _input_error("no .tran analysis and no stop time given",
                               "add '.tran TSTEP TSTOP' to the netlist or pass --tstop",
                               circuit.file)
        from netlist.studies.transient import default_step

        waves = [el.waveform for el in c.elements if getattr(el, "waveform", None)]
        step = default_step(waves, tstop)
        from netlist.circuit import Tran

        c.tran = Tran(tstep=step, tstop=tstop, uic=True)
        notes.append(f"no .tran: both run to {tstop:.4g} s with step {step:.4g} s")
    tran = c.tran
    if tstop is not None:
        tran = replace(tran, tstop=float(tstop),
                       tstart=tran.tstart if tran.tstart < tstop else 0.0)
    if not tran.uic:
        notes.append("both run with UIC (added): from the same initial conditions (without it "
                     "each would start from its own DC operating point, which ideal and real "
                     "devices make differ)")
        tran = replace(tran, uic=True)
    c.tran = tran
    if c.ignored:
        dropped = sorted({cmd.text.split()[0].lower() for cmd in c.ignored if cmd.text.split()})
        notes.append(f"left out of the ngspice deck (pelcs ignores them too): "
                     f"{', '.join(dropped)}")
        c.ignored = []
    return c


def _ngspice_tmax(c: Circuit) -> float:
    """ngspice's largest time step: TMAX, else min(TSTEP, (TSTOP - TSTART)/50)."""
    tran = c.tran
    default = min(tran.tstep, (tran.tstop - tran.tstart) / 50.0)
    return float(tran.tmax) if tran.tmax else float(default)


def compare(
    source: str | os.PathLike | Circuit,
    probes: Sequence[str] | None = None,
    *,
    params: Mapping[str, float | str] | None = None,
    pelcs_params: Mapping[str, float | str] | None = None,
    tstop: float | None = None,
    period: float | None = None,
    theta: float | None = None,
    tolerances: Tolerances | None = None,
    settings: NgspiceSettings | Sequence[NgspiceSettings] | None = None,
    timeout: float | None = 600.0,
    devices: str = "auto",
) -> Comparison:
    """Simulate a netlist with pelcs and ngspice and compare them probe by probe.

    Parameters
    ----------
    source : path, netlist text, Circuit or PySpice Circuit
        The netlist (a string with a line break is netlist text).
    probes : sequence of str, optional
        pelcs probes (``v(out)``, ``v(a,b)``, ``i(L1)``, ``v(C1)``); default
        :func:`default_probes` (every state).
    params : mapping, optional
        ``.param`` overrides for both simulators (not with a Circuit).
    pelcs_params : mapping, optional
        Further overrides for pelcs only: a deliberate difference, to see the check fail.
    tstop : float, optional
        Stop time for both (s); default the ``.tran`` TSTOP.
    period : float, optional
        Steady-state period (s); default :func:`detect_period`.
    theta : float, optional
        pelcs' θ; default as ``pelcs simulate`` chooses it (1/2, or 1 where θ < 1 is
        unreliable: :func:`netlist.studies.transient.choose_theta`).
    tolerances : Tolerances, optional
    settings : NgspiceSettings or sequence of them, optional
        ngspice ladder (default the runner's :data:`~ngspice_checks.runner.DEFAULT_LADDER`).
    timeout : float or None
        ngspice wall-time limit per rung (s).
    devices : {"auto", "ideal", "pwl"}
        pelcs' devices: ``"pwl"`` piecewise-linear fits of ngspice's models
        (:mod:`netlist.pwl`), ``"ideal"`` ideal ones, ``"auto"`` (default) the fits when the
        netlist has real device models (see the module docstring).

    Returns
    -------
    Comparison

    Raises
    ------
    netlist.errors.NetlistError
        Input errors (netlist, probes, parameters, no stop time, nothing to compare).
    CheckError
        The pelcs run failed.
    ngspice_checks.runner.NgspiceError
        ngspice unavailable (NgspiceUnavailable) or failed on every rung (NgspiceFailed).
    """
    from lcs.build.ready import load_kernels as warm_up
    from netlist.parser import load_source as load
    from netlist.studies.sweep import check_period_multiple
    from netlist.studies.transient import check_probes, simulate_circuit
    from netlist.writer import write_circuit

    if devices not in ("auto", "ideal", "pwl"):
        raise ValueError(f"devices must be 'auto', 'ideal' or 'pwl', got {devices!r}")
    tol = tolerances or Tolerances()
    notes: list[str] = []
    if isinstance(source, Circuit):
        if params or pelcs_params:
            raise TypeError("params need a netlist path or text, not a parsed Circuit")
        base = source
        file = source.file
    else:
        base = load(source, params)
        file = base.file
    circuit = _prepare(base, tstop, notes)
    if period is not None:
        # the mean and ripple over whole periods: a period the switching does not repeat in
        # would average over fractions of it
        check_period_multiple(circuit, float(period))
    if pelcs_params:
        pel = _prepare(load(source, {**(params or {}), **pelcs_params}), tstop, [])
        notes.append("deliberate difference: pelcs runs with "
                     + ", ".join(f"{k}={v}" for k, v in pelcs_params.items())
                     + ", ngspice with the netlist's values")
    else:
        pel = circuit
    probes = check_probes(circuit, list(probes)) if probes else default_probes(circuit)
    ng_probes = [ngspice_probe(circuit, p) for p in probes]
    # (not the ideal bypasses of a resistor stepped in time: ngspice runs that resistor)
    switch_els = [el for el in circuit.elements if isinstance(el, Switch) and not el.built_for]
    controls = [f"v({a},{b})" if b != GROUND else f"v({a})" for a, b in
                (sw.control for sw in switch_els)]
    # pelcs also records every diode and switch current: the drop estimate needs them
    from netlist.reductions import parallel_diodes

    merged = parallel_diodes(circuit)  # carried by another diode's pair in pelcs
    switch_keys = {sw.key for sw in switch_els}
    devices_els = [el for el in circuit.elements if (isinstance(el, Diode) and el.key not in
                                                     merged) or el.key in switch_keys]
    extra = [f"i({el.name})" for el in devices_els]
    pel_probes = list(dict.fromkeys(list(probes) + extra + controls))
    # every node voltage too: their values at t = 0+ give ngspice a consistent start
    inner = internal_nodes(circuit)
    node_probes = [f"v({n})" for n in circuit.nodes if n != GROUND and n not in inner]
    pel_probes = list(dict.fromkeys(pel_probes + node_probes))

    # ngspice missing: say so before spending time on the pelcs run
    ngspice_version()
    load_time = warm_up()
    t0 = time.perf_counter()
    try:
        result = simulate_circuit(pel, theta=theta, probes=pel_probes)
    except NetlistError as exc:
        from netlist.pwl import pwl_circuit
        from netlist.studies.realistic import switch_loop

        if devices == "ideal" or not switch_loop(exc, switch_els):
            raise
        # an ideal switch closes a loop with capacitors and voltage sources, which the
        # switches' on resistance breaks: the drops are estimated from a run with them, as
        # pelcs simulate --devices pwl sizes its fits (netlist.studies.realistic.pwl_run)
        result = simulate_circuit(pwl_circuit(pel, {}, {})[0], theta=theta,
                                  probes=pel_probes)
        devices = "pwl"
    pelcs_wall = time.perf_counter() - t0
    if result.error is not None:
        raise CheckError(f"pelcs failed at t = {result.error.time:.6g} s: "
                         f"{result.error.message}")
    # like with like: real device models -> pelcs with piecewise-linear fits of them
    t_ideal = np.asarray(result.t, dtype=float)
    carried = {el.name: carried_current(t_ideal, result[f"i({el.name})"])
               for el in devices_els}
    drives = {sw.name: float(np.max(np.abs(result[ctrl])))
              for sw, ctrl in zip(switch_els, controls, strict=True)}
    ideal_delta = _nonideality(circuit, NgspiceSettings("as-written"), carried, drives)
    use_pwl, why = _choose_devices(devices, circuit, ideal_delta, tol)
    fits: list = []
    run_c = pel  # the circuit pelcs' compared run simulates
    fitted_at = carried  # the currents the fits were sized at (A)
    if use_pwl:
        # the run `pelcs simulate --devices pwl` makes, on the circuit it builds (the fits,
        # their refits from the pwl run, the junctions' charge, breakdown branches)
        from netlist.studies.realistic import pwl_run

        t0 = time.perf_counter()
        try:
            run = pwl_run(pel, pel_probes, theta=theta)
        except NetlistError as exc:
            if devices == "pwl":
                raise
            run = None  # auto: compare the ideal run, with the tolerances of ideal devices
            use_pwl = False
            notes.append(f"pelcs with --devices pwl ({why}) stopped ({exc.message}): ideal "
                         "devices compared")
        fitted = run.result if run is not None else None
        if fitted is None:
            pass
        elif fitted.error is None:
            # (the fits' lines are among the run's notes, below)
            result, pelcs_wall = fitted, time.perf_counter() - t0
            fits, run_c, fitted_at = run.fits, run.circuit, run.sized
            notes.append(f"pelcs ran with --devices pwl ({why})")
        elif devices == "pwl":
            raise CheckError(f"pelcs (--devices pwl) failed at t = "
                             f"{fitted.error.time:.6g} s: {fitted.error.message}")
        else:  # auto: compare the ideal run, with the tolerances of ideal devices
            use_pwl, fits, run_c = False, [], pel
            notes.append(f"pelcs with --devices pwl ({why}) failed at t = "
                         f"{fitted.error.time:.6g} s ({fitted.error.message}): ideal devices "
                         "compared")
    elif devices == "auto" and why:
        notes.append(f"pelcs ran with ideal devices ({why})")
    notes.extend(f"pelcs: {n}" for n in result.notes)
    # switching that follows the state (comparators): pelcs once more at half the step, to
    # tell its own sensitivity from a disagreement (module docstring, "Sensitive runs")
    theta = run_theta(result)
    others = _perturbed_runs(run_c, result, theta, pel_probes, switch_els, notes)
    # and ngspice measures every state then: pelcs may restart from its state (below)
    state_probes = ([ngspice_probe(circuit, st) for st in default_probes(circuit)]
                    if others else [])

    deck = write_circuit(circuit)
    start = {p[2:-1]: float(result[p][0]) for p in node_probes}
    try:
        ng = run_ngspice(deck, list(dict.fromkeys(ng_probes + controls + state_probes)),
                         settings=settings,
                         timeout=timeout, initial_voltages=start,
                         workdir=Path(file).parent if file and file != "<string>" else None)
    except ProbeError as exc:
        raise _input_error(f"ngspice cannot measure a probe: {exc}",
                           "compare node voltages and currents of top-level elements",
                           file) from exc

    t_p = np.asarray(result.t, dtype=float)
    t_n = np.asarray(ng.time, dtype=float)
    span = (max(t_p[0], t_n[0]), min(t_p[-1], t_n[-1]))
    # (the step the run took: the .tran line's, or one pelcs chose to resolve a source)
    h = result.step or float(pel.tran.tmax or pel.tran.tstep)
    step = min(h, (span[1] - span[0]) / 20)
    per, per_source = detect_period(pel, result, period)
    window, n_periods = _window(span, per)

    t_run = np.asarray(result.t, dtype=float)
    currents = {el.name: carried_current(t_run, result[f"i({el.name})"])
                for el in devices_els}
    rung_models = (ng.settings_used.diode_model is not None
                   or ng.settings_used.switch_model is not None)
    if use_pwl and not rung_models:
        nonideal = _pwl_residual(circuit, fits, fitted_at, currents, drives)
    else:
        if use_pwl:
            notes.append("ngspice's ladder replaced the device models (rung "
                         f"{ng.rung}): the tolerances follow the drops of its models, not "
                         "what the fits leave")
        nonideal = _nonideality(circuit, ng.settings_used, currents, drives)
    kd = tol.k_nonideal * nonideal.delta
    if tol.nrms + kd > tol.conclusive:
        left = "what the fits leave of " if use_pwl and not rung_models else ""
        notes.append(f"{left}ngspice's diode and switch models drop "
                     f"{100 * nonideal.delta:.3g} % of "
                     f"{nonideal.v_ref:.4g} V: tolerances of {100 * (tol.nrms + kd):.3g} % "
                     f"(over {100 * tol.conclusive:.3g} %) decide nothing, the comparison is "
                     "inconclusive; near-ideal models (D: IS=1e-12 N=0.05 RS=1m, SW: RON=1m "
                     "ROFF=1e9) or --devices pwl make it sharp")

    # switching instants
    names = [sw.name for sw in switch_els]
    p_inst = _pelcs_instants(result, names)
    reading: list[tuple] = []
    o_inst = [_pelcs_instants(o, names) for o in others]
    o_t = [np.asarray(o.t, dtype=float) for o in others]
    tmax_ng = _ngspice_tmax(circuit)
    jumping = [el.name for el in circuit.elements
               if getattr(getattr(el, "waveform", None), "keyword", "") == "B"
               and getattr(el.waveform, "jumps", False)]
    if jumping:
        notes.append(f"{', '.join(jumping)}: a B source of time that jumps (floor, a "
                     "comparison): pelcs steps to each jump, ngspice puts no breakpoint there "
                     f"and lands it inside its step (up to {tmax_ng:.3g} s here), which can "
                     "move its averages; a smaller TMAX on the .tran line brings ngspice's "
                     "answer to the jumps' own")
    switch_cmp: list[SwitchingComparison] = []
    all_instants: list[np.ndarray] = []
    for sw, ctrl in zip(switch_els, controls, strict=True):
        at_terminal = False
        mp = _model_params(circuit, sw.model, _SWITCH_DEFAULTS)
        vh = mp["vh"]
        sm = ng.settings_used.switch_model
        if sm is not None:
            vh = max(vh, sm.vh_min)
        if vh > 0:
            # hysteresis: both sides measured alike, at the crossings of the half band
            # (ngspice stores the control after its switch has acted, up to one step's
            # change short of the band edge: the edges are not reliably crossed in its
            # output, the half band is crossed once per switching in both)
            ni = _ngspice_instants(t_n, ng.signals[ctrl], mp["vt"], vh / 2, sw.initial)
            pi = _ngspice_instants(t_p, result[ctrl], mp["vt"], vh / 2, sw.initial)
            ph = [_ngspice_instants(t, o[ctrl], mp["vt"], vh / 2, sw.initial)
                  for t, o in zip(o_t, others, strict=True)]
        else:
            ni = _ngspice_instants(t_n, ng.signals[ctrl], mp["vt"], 0.0, sw.initial)
            pi = p_inst[sw.name]
            ph = [oi[sw.name] for oi in o_inst]
            at_terminal = use_pwl and getattr(sw, "gate_rc", None) is not None
            if at_terminal:
                # the pwl switch turns on its internal gate capacitor (and may slide there
                # while the MOSFET follows its gate, as ngspice's does in its linear region);
                # ngspice's instants are read at the gate terminal: both sides there
                pi = _ngspice_instants(t_p, result[ctrl], mp["vt"], 0.0, sw.initial)
                ph = [_ngspice_instants(t, o[ctrl], mp["vt"], 0.0, sw.initial)
                      for t, o in zip(o_t, others, strict=True)]
        all_instants += [pi.on, pi.off, ni.on, ni.off]
        # how to read another pelcs run's instants alike (the restart below)
        reading.append((sw.name, ctrl, mp["vt"], vh / 2 if vh > 0 else 0.0, sw.initial,
                        vh <= 0 and not at_terminal, ni))
        driven = result.switching.get(sw.name, "?")
        switch_cmp.append(_compare_switch(sw.name, driven, ctrl, pi, ni, result, span, window,
                                          per, per_source, tmax_ng, h, tol, kd,
                                          at_terminal=vh <= 0 and at_terminal, others=ph))
    instants = np.sort(np.concatenate(all_instants)) if all_instants else np.empty(0)
    offsets = [s.max_offset for s in switch_cmp if s.method == "instants"]
    guard = step + (max(offsets) if offsets else 0.0)

    # the common grid, and the points near a switching instant left out of the NRMS
    n_grid = int(round((span[1] - span[0]) / step)) + 1
    grid = np.linspace(span[0], span[1], max(n_grid, 2))
    mask = np.ones(len(grid), dtype=bool)
    if len(instants):
        k = np.searchsorted(instants, grid)
        near_right = np.abs(instants[np.minimum(k, len(instants) - 1)] - grid)
        near_left = np.abs(instants[np.maximum(k - 1, 0)] - grid)
        mask = np.minimum(near_left, near_right) > guard
    if mask.sum() < 0.5 * len(grid):  # switching everywhere (chattering): keep all points
        notes.append("switching instants too dense to leave out: NRMS over every grid point")
        mask[:] = True


    probe_cmp = []
    tp_u, tn_u = t_p, t_n
    steady = grid >= window[0]  # the steady-state window; before it, the transient
    selfs: list[tuple[str, float, float, float]] = []  # probe, transient, window, tolerance
    halves: list[tuple[float, float]] = []  # largest change of the window mean, ripple
    steady_nrms: list[float] = []  # pelcs against ngspice over the window only
    for probe, ngp in zip(probes, ng_probes, strict=True):
        yp, yn = np.asarray(result[probe], float), np.asarray(ng.signals[ngp], float)
        tpi, ypi = _strictly_increasing(tp_u, yp)
        tni, yni = _strictly_increasing(tn_u, yn)
        gp, gn = np.interp(grid, tpi, ypi), np.interp(grid, tni, yni)
        sel_run = (t_p >= span[0]) & (t_p <= span[1])
        scale = _scale(yp[sel_run])
        nrms = _nrms(gn - gp, mask) / scale
        wp, wn = _in_window(tpi, ypi, *window), _in_window(tni, yni, *window)
        rp, rn = float(np.ptp(wp[1])), float(np.ptp(wn[1]))
        self_nrms = math.nan
        if others:
            # the largest change any perturbed pelcs run makes (module docstring)
            run_, tr_, win_, dm, dr = 0.0, 0.0, 0.0, 0.0, 0.0
            for t_o, o in zip(o_t, others, strict=True):
                toi, yoi = _strictly_increasing(t_o, np.asarray(o[probe], float))
                d = np.interp(grid, toi, yoi) - gp
                run_ = max(run_, _nrms(d, mask) / scale)
                tr_ = max(tr_, np.nan_to_num(_nrms(d, mask & ~steady)) / scale)
                win_ = max(win_, _nrms(d, mask & steady) / scale)
                wo = _in_window(toi, yoi, *window)
                dm = max(dm, abs(_mean(*wo) - _mean(*wp)))
                dr = max(dr, abs(float(np.ptp(wo[1])) - rp))
            self_nrms = run_
            selfs.append((probe, tr_, win_, tol.nrms + kd))
            halves.append((dm, dr))
        probe_cmp.append(ProbeComparison(
            probe=probe, ngspice_probe=ngp, scale=scale,
            nrms=nrms, nrms_tol=tol.nrms + kd,
            mean_pelcs=_mean(*wp), mean_ngspice=_mean(*wn),
            mean_tol=max(tol.mean, kd) * scale,
            ripple_pelcs=rp, ripple_ngspice=rn,
            ripple_tol=tol.ripple_rel * rp + (tol.ripple_floor + kd) * scale,
            excluded=float(1.0 - mask.mean()), self_nrms=self_nrms,
            transient_nrms=_nrms(gn - gp, mask & ~steady) / scale,
        ))
        steady_nrms.append(_nrms(gn - gp, mask & steady) / scale)
    transient, sensitivity = _sensitivity(probe_cmp, switch_cmp, selfs, halves, steady_nrms,
                                          window, tol)
    orbit = ""
    failing = any(not p.ok for p in probe_cmp) or any(not w.ok for w in switch_cmp)
    if others and failing:
        orbit = _restart_check(run_c, lambda st: ngspice_probe(circuit, st), result, ng,
                               probes, probe_cmp, switch_cmp,
                               reading, grid, mask & steady, window, notes)

    return Comparison(
        file=str(file), title=base.title, params=dict(params or {}),
        pelcs_params=dict(pelcs_params or {}), probes=probe_cmp, switches=switch_cmp,
        tstop=float(circuit.tran.tstop), step=h, theta=theta, span=span, period=per,
        period_source=per_source, window=window, n_periods=n_periods, nonideal=nonideal,
        tolerances=tol, rung=ng.rung, settings=ng.settings_used,
        attempts=[(a.rung, a.settings.name, a.reason or "") for a in ng.attempts if not a.ok],
        pelcs_wall=pelcs_wall, pelcs_load=load_time, pelcs_steps=result.stats.steps,
        ngspice_wall=ng.wall_time, ngspice_total=ng.total_time, ngspice_points=len(t_n),
        notes=notes, pelcs_result=result, ngspice_result=ng,
        devices="pwl" if use_pwl else "ideal", device_fits=list(fits),
        transient=transient, sensitivity=sensitivity, orbit=orbit,
    )


def _choose_devices(devices: str, circuit: Circuit, ideal: NonIdeality, tol: Tolerances
                    ) -> tuple[bool, str]:
    """Whether pelcs runs with piecewise-linear devices, and why (see the module
    docstring): asked for; or, with ``"auto"``, idealised transistors or device macro-models
    in the netlist, or drops of its diode and switch models that would widen the tolerances
    past their floors (k·δ of the ideal run > the mean floor)."""
    if devices != "auto":
        return devices == "pwl", "--devices " + devices
    if circuit.replacements:
        return True, "the netlist has transistors or device macro-models"
    if tol.k_nonideal * ideal.delta > tol.mean:
        return True, (f"its device models drop {100 * ideal.delta:.3g} % of "
                      f"{ideal.v_ref:.4g} V at the currents they carry")
    return False, ""


def _compare_switch(
    name: str, driven: str, control: str, pi: _Instants, ni: _Instants,
    result: SimulationResult, span: tuple[float, float], window: tuple[float, float],
    period: float | None, period_source: str, tmax_ng: float, h: float, tol: Tolerances,
    kd: float, at_terminal: bool = False, others: Sequence[_Instants] = (),
) -> SwitchingComparison:
    """Instants (or, free-running, the frequency) of one switch; see the module docstring.
    ``at_terminal``: both sides' instants are crossings of the control at the device's
    terminals (a pwl MOSFET with its gate RC), which pelcs' sliding does not remove."""
    fp = _frequency(pi.on, *window)
    fn = _frequency(ni.on, *window)

    def count(x: _Instants, lo: float, hi: float) -> int:
        """Switchings in [lo, hi] (pelcs' events start at 0, ngspice's output at TSTART)."""
        return int(sum(((v >= lo) & (v <= hi)).sum() for v in (x.on, x.off)))

    n_p, n_n = count(pi, *span), count(ni, *span)
    sliding = [s for s in result.sliding if s[0] == name]
    if sliding and not at_terminal:
        start = min(s[1] for s in sliding)
        return SwitchingComparison(
            name, driven, control, "none", n_p, n_n, math.nan, math.nan, fp, fn, span,
            f"pelcs slides on its surface from t = {start:.4g} s (ideal relay, no "
            "instants); ngspice's switch chatters at its time step there")
    free_running = driven != "source" and period_source.startswith(("median", "no periodic"))
    if free_running:
        return SwitchingComparison(
            name, driven, control, "frequency", count(pi, *window), count(ni, *window),
            math.nan, tol.frequency, fp, fn, window,
            "free-running: phase drift makes instants incomparable over many periods")
    limit = tol.switching_steps * tmax_ng + (h if driven in _SAMPLED else 0.0)
    ends = span  # the common run, whose ends may cut an instant from its partner
    a, b = span
    if driven != "source" and period is not None:
        # a comparator's instant follows the circuit state: an offset of ε·T changes a duty
        # cycle by ε and a period average by about ε, which the mean tolerance allows
        limit += max(tol.mean, kd) * period
        # and in a transient a crossing of the ramp can be nearly tangential (the instant
        # is then ill-conditioned): compared in the steady-state window, as mean and ripple
        a, b = span = window
    pairs = ((pi.on, ni.on), (pi.off, ni.off))
    offs = [_hausdorff(x, y, a, b, ends, limit) for x, y in pairs]
    cut = sum(int(_unpaired_at_ends(v[(v >= a) & (v <= b)], w, ends, limit).sum())
              for x, y in pairs for v, w in ((x, y), (y, x)))
    at_ends = (f"{cut} instant{'s' if cut > 1 else ''} within the tolerance of the run's "
               "start or end left out: the partner would lie past it" if cut else "")
    if (n_p == 0) != (n_n == 0):  # one side switches, the other never does: no agreement
        who = "pelcs" if n_p else "ngspice"
        return SwitchingComparison(
            name, driven, control, "instants", count(pi, a, b), count(ni, a, b), math.inf,
            limit, fp, fn, span, f"only {who} switches ({max(n_p, n_n)} switchings over the "
            "run, none in the other)")
    self_offset = math.nan
    if others:
        # pelcs against its perturbed runs, measured as against ngspice (same span, pairing)
        self_offset = max(_hausdorff(x, y, a, b, ends, limit) for o in others
                          for x, y in ((pi.on, o.on), (pi.off, o.off)))
    return SwitchingComparison(
        name, driven, control, "instants", count(pi, a, b), count(ni, a, b), max(offs), limit,
        fp, fn, span, "" if n_p else "neither switches", note=at_ends,
        self_offset=self_offset)
