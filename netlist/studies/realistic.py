"""Runs with real-device effects: piecewise-linear diodes and switches (:mod:`.pwl`) and the
losses and efficiency of the steady state (:mod:`.losses`), on top of
:func:`netlist.studies.transient.simulate_circuit`."""

from __future__ import annotations

import warnings
from collections.abc import Collection, Sequence
from dataclasses import dataclass, replace

import numpy as np

from lcs.results import SimulationResult

from ..breakdown import breakdown_elements, breakdowns
from ..circuit import GROUND, Capacitor, Circuit, Diode, Switch, VoltageSource
from ..errors import Diagnostic, NetlistError
from ..gate_charge import gate_drain_chords
from ..junction_charge import fastest_junction_mode, junction_charges, with_junction_charge
from ..probes import voltage_probe
from ..pwl import carried_current, diode_params, junction_models, model_current, pwl_circuit
from ..reductions import parallel_diodes
from ..units import parse_number
from .losses import loss_probes
from .losses import losses as loss_report
from .transient import check_probes, passivity_unreported, simulate_circuit

__all__ = ["PwlRun", "fitted_circuit", "pwl_run", "simulate_devices", "switch_loop"]


def simulate_devices(circuit: Circuit, *, devices: str = "ideal", losses: bool = False,
                     load: str | None = None, probes: Sequence[str] | None = None,
                     pwl: dict | None = None, **kw) -> SimulationResult:
    """:func:`netlist.studies.transient.simulate_circuit` with piecewise-linear devices and/or
    losses.

    Parameters
    ----------
    circuit : Circuit
    devices : str
        ``"ideal"``, or ``"pwl"``: diodes with a fitted Vf and Ron, switches with their Ron
        (:mod:`netlist.pwl`; an ideal run first gives the current range of the fit,
        :func:`netlist.pwl.carried_current`), built by :func:`pwl_run`;
        ``result.device_fits`` lists them.
    losses : bool
        Also compute ``result.losses`` (:mod:`netlist.studies.losses`): conduction losses, input and
        output power (``load``: the load resistor, default the one taking the most power)
        and efficiency over the steady-state window.
    probes : sequence of str, optional
        The result's probes (default every state); the losses' own probes are not kept.
    pwl : mapping, optional
        ``{element or model name: (vf, ron)}`` (V, Ω) given instead of the fit.
    **kw
        The other arguments of :func:`~netlist.studies.transient.simulate_circuit`.
    """
    if devices not in ("ideal", "pwl"):
        raise ValueError(f"devices must be 'ideal' or 'pwl', got {devices!r}")
    want = list(probes) if probes is not None else None
    extra = loss_probes(circuit) if losses else []
    if want is not None and extra:
        # (the user's probes checked as they are: the losses' own may take the currents of
        # sources without the charging current of a capacitor across them, which the losses
        # add as its power)
        check_probes(circuit, want)
    run = _devices_run(circuit, devices, want, extra, pwl, kw)
    res = run.result
    if losses:
        res.losses = loss_report(res, circuit, run.fits, load)
        if not res.losses.settled:
            a, b = res.losses.window
            res.notes.append(f"losses: the window {a:.6g}..{b:.6g} s is not a steady state "
                             f"({res.losses.settling_text()}): the efficiency is that of the "
                             "transient, not of the converter")
    return _keep(res, run.kept)


@dataclass
class PwlRun:
    """A run with piecewise-linear devices (:func:`pwl_run`) and what it ran.

    Attributes
    ----------
    result : SimulationResult
        The run, its notes saying what each device became (``result.device_fits``).
    circuit : Circuit
        The piecewise-linear circuit it simulated: the fits, the junctions' charges, the
        breakdown branches it needed.
    fits : list of netlist.pwl.PwlFit
    sized : dict
        The current (A) each diode's and switch's fit was sized at, by name (after the
        refits from the pwl run).
    drives : dict
        Each switch's largest control voltage in the ideal run (V), by name.
    kept : int
        The first ``kept`` probes are the caller's (the rest the run watched for itself).
    """

    result: SimulationResult
    circuit: Circuit
    fits: list
    sized: dict
    drives: dict
    kept: int


def pwl_run(circuit: Circuit, probes: Sequence[str] | None = None, pwl: dict | None = None,
            **kw) -> PwlRun:
    """The run ``pelcs simulate --devices pwl`` makes (:func:`simulate_devices` with
    ``devices="pwl"``), and the circuit it built: an ideal run sizes each device's fit, the
    pwl run is made once more where it takes a diode past its breakdown voltage or well
    below its fit's currents. ``pelcs check`` compares this run.

    Parameters
    ----------
    circuit : Circuit
    probes : sequence of str, optional
        The result's probes (default every state).
    pwl : mapping, optional
        ``{element or model name: (vf, ron)}`` (V, Ω) given instead of the fit.
    **kw
        The other arguments of :func:`~netlist.studies.transient.simulate_circuit`.
    """
    run = _devices_run(circuit, "pwl", list(probes) if probes is not None else None, [],
                       pwl, kw)
    return replace(run, result=_keep(run.result, run.kept))


def _keep(res: SimulationResult, k: int) -> SimulationResult:
    """The run with its first ``k`` probes only (the others it watched for itself)."""
    if len(res.names) > k:
        res.names, res.y = tuple(res.names[:k]), res.y[:, :k]
    return res


def _devices_run(circuit: Circuit, devices: str, want: list[str] | None, extra: list[str],
                 pwl: dict | None, kw: dict) -> PwlRun:
    """The run of :func:`simulate_devices` (``extra``: the losses' probes, after ``want``),
    with every probe it watched; ``kept``: how many are ``want``."""
    fits: list = []
    charge_lines: list[str] = []
    run_circuit = circuit
    sizing_note = None
    loop_caps: list[str] = []  # capacitors an ideal switch would tie to voltage sources
    i_max: dict[str, float] = {}
    drives: dict[str, float] = {}
    split_lines: list[str] = []
    bds = breakdowns(circuit) if devices == "pwl" else {}
    broken: set[str] = set()
    if devices == "pwl":
        merged = parallel_diodes(circuit)
        # (the bypasses of a resistor stepped in time stay ideal: netlist.time_value)
        sws = [el for el in circuit.elements if isinstance(el, Switch) and not el.built_for]
        pre = [f"i({el.name})" for el in circuit.elements
               if isinstance(el, Diode) and el.key not in merged] + [
            f"i({el.name})" for el in sws]
        pre += [voltage_probe(*sw.control) for sw in sws]
        pre += [bd.probe for bd in bds.values()]
        laws = [sw.cgd_law for sw in sws if sw.cgd_law is not None and sw.gate_rc]
        pre += [f"v({n})" for law in laws for n in (law.gate, law.drain) if n != GROUND]
        pre += [_voltage_probe(el) for el in circuit.elements
                if isinstance(el, Diode) and not el.ideal and el.key not in merged]
        # (its knees unchecked: it sizes the fits, the pwl run below is the answer)
        try:
            ideal = _sizing_run(circuit, list(dict.fromkeys(pre)), kw)
        except NetlistError as exc:
            if not switch_loop(exc, sws):
                raise
            # an ideal switch closes a loop with capacitors and voltage sources, which the
            # switches' own resistances break: the fits are sized from a run with them (and
            # the diodes at their 1 mA fit) instead
            sized, _ = pwl_circuit(circuit, {}, {}, pwl)
            loop_caps = _driven_loop_caps(circuit, exc)
            ideal = _sizing_run(sized, list(dict.fromkeys(pre)), kw)
            if any(isinstance(el, Diode) for el in circuit.elements):
                sizing_note = (
                    "pwl: the ideal run that sizes the diodes' fits is degenerate ("
                    f"{exc.message.split(':')[0]}: an ideal switch would tie a capacitor's "
                    "voltage to voltage sources, a jump), so they are sized from a run "
                    "with the switches at their on resistance and the diodes at their "
                    "1 mA fit")
        # the current each device carries, not an inrush only the time step limits
        t = np.asarray(ideal.t, float)
        i_max = {el.name: carried_current(t, ideal[f"i({el.name})"])
                 for el in circuit.elements
                 if (isinstance(el, Diode) and el.key not in merged)
                 or (isinstance(el, Switch) and not el.built_for)}
        for sw in sws:
            a, b = sw.control
            drives[sw.name] = float(np.max(ideal[f"v({a})" if b == GROUND
                                                  else f"v({a},{b})"]))
        # the depletion charge of each diode, over the voltages the ideal run puts across it
        swings = {el.name: (float(np.min(ideal[_voltage_probe(el)], initial=0.0)),
                            float(np.max(ideal[_voltage_probe(el)], initial=0.0)))
                  for el in circuit.elements
                  if isinstance(el, Diode) and not el.ideal and el.key not in merged}
        charges, charge_lines = junction_charges(circuit, swings, merged)
        if laws:  # (a MOSFET's gate-drain capacitance over the swing the run puts across it)
            circuit, cgd_lines = gate_drain_chords(circuit, lambda n: ideal[f"v({n})"])
            charge_lines += cgd_lines
        run_circuit, fits = fitted_circuit(circuit, i_max, drives, pwl, charged=charges, **kw)
        split_lines: list[str] = []
        run_circuit = with_junction_charge(circuit, run_circuit, fits, charges, split_lines)
        kw, theta_line = _junction_theta(run_circuit, charges, kw, loop_caps)
        if theta_line:
            charge_lines.append(theta_line)
        # the diodes the ideal run takes past their breakdown voltage (netlist.breakdown)
        broken = {name for name, bd in bds.items()
                  if float(np.max(ideal[bd.probe], initial=0.0)) > bd.bv}
    fitted = run_circuit
    if want is None:
        from ..formulation import formulate as _formulate

        want = list(_formulate(run_circuit).states)
    # Once more if the pwl run takes another diode past its BV (a second time is an error),
    # and, in the first two runs, once more if it takes a broken-down diode well outside the
    # current its branch was fitted over, or a diode well below the currents of its fit
    # (sized by the ideal run, whose diodes drop nothing: a diode driven by a voltage near
    # its own drop carries far less): at most six runs, the last one never continued.
    tops: dict[str, float] = {}
    extended = False
    refits: list[str] = []
    watched = [f.element for f in fits if f.how != "given" and
               isinstance(circuit.element(f.element), Diode)]
    for attempt in range(6):
        run_circuit, lines = _broken_down(fitted, bds, broken, tops)
        watch = [bd.probe for name, bd in bds.items() if name not in broken]
        watch += [f"i({name}#bv)" for name in sorted(broken)]
        watch += [f"i({name})" for name in watched]
        watch += [_voltage_probe(circuit.element(name)) for name in watched]
        # (its warnings held: only the run that is the answer reports, once, below)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            res = simulate_circuit(run_circuit,
                                   probes=list(dict.fromkeys(want + extra + watch)),
                                   path_currents=bool(extra), **kw)
        more = {name for name, bd in bds.items() if name not in broken
                and float(np.max(res[bd.probe], initial=0.0)) > bd.bv}
        if more:
            if extended:
                bd = bds[sorted(more)[0]]
                raise NetlistError(Diagnostic(
                    message=f"diode {bd.name}: the run takes it past its breakdown voltage "
                            f"BV = {bd.bv:g} V again with its reverse breakdown modelled",
                    hint="pelcs models a diode's breakdown where a run first takes it there; "
                         "shorten the run or check the circuit"), file=circuit.file)
            broken |= more
            extended = True
            continue
        resized = _resized(res, bds, broken, tops) if attempt < 2 else {}
        moved = (_refitted(res, circuit, watched, i_max)
                 if watched and len(refits) < 2 and attempt < 5 else {})
        if not resized and not moved:
            break
        tops.update(resized)
        if moved:
            refits += [f"pwl: {name}'s fit sized again from the pwl run, where it carries "
                       f"{cur:.3g} A (its fit was over {_fit_top(i_max[name]) / 20:.3g}.."
                       f"{_fit_top(i_max[name]):.3g} A)" for name, cur in moved.items()]
            i_max.update(moved)
            fitted, fits = fitted_circuit(circuit, i_max, drives, pwl, charged=charges, **kw)
            split_lines = []
            fitted = with_junction_charge(circuit, fitted, fits, charges, split_lines)
    for w in {(w.category, str(w.message)): w for w in caught}.values():
        warnings.warn_explicit(w.message, w.category, w.filename, w.lineno, source=w.source)
    res.device_fits = fits
    miller = _miller_note(circuit, res)
    if miller:
        res.notes.append(miller)
    res.notes.extend(f"pwl: {f.line()}" for f in fits)
    res.notes.extend(f"pwl: {line}" for line in lines)
    temperature = _temperature_note(circuit, watched) if watched else ""
    if temperature:
        res.notes.append(temperature)
    res.notes.extend(refits)
    if devices == "pwl":
        res.notes.extend(f"pwl: {line}" for line in charge_lines + split_lines)
    if devices == "pwl" and sizing_note:
        res.notes.append(sizing_note)
    return PwlRun(res, run_circuit, fits, dict(i_max), drives, len(dict.fromkeys(want)))


def _sizing_run(circuit: Circuit, probes: list[str], kw: dict) -> SimulationResult:
    """The ideal run that sizes the fits (its knees unchecked: the pwl run is the answer).
    Its circuit is not the one simulated: a warning that it is not passive would be a second
    one beside the pwl run's, about another circuit, so only the pwl run's is shown (a strict
    run is still refused here)."""
    with passivity_unreported():
        return simulate_circuit(circuit, probes=probes, knees=False, **kw)


def _miller_note(circuit: Circuit, res: SimulationResult) -> str:
    """Why a pwl run stopped chattering on a MOSFET whose gate-drain capacitance couples its
    gate to its own drain, and what to do ("" for any other run)."""
    err = res.error
    if err is None or err.kind != "chattering":
        return ""
    sw = next((el for el in circuit.elements if isinstance(el, Switch)
               and el.name == getattr(err, "switch", None)), None)
    gate = getattr(sw, "gate_rc", None)
    if gate is None or not gate[2] > 0:
        return ""
    return (f"pwl: {sw.name}'s gate-drain capacitance ({gate[2]:.3g} F, Cgs {gate[1]:.3g} F) "
            "kicks its gate back across the threshold at each edge: a real MOSFET crosses "
            "that Miller plateau in its linear region, which an ideal switch does not have, so "
            "it toggles without end there; simulate with ideal devices (--devices ideal), where "
            "the gate has no capacitances")


def _broken_down(circuit: Circuit, bds: dict, broken: set[str], tops: dict[str, float]
                 ) -> tuple[Circuit, list[str]]:
    """The piecewise-linear circuit with the reversed branch of each diode of ``broken``
    (:func:`netlist.breakdown.breakdown_elements`, fitted up to ``tops[name]`` A where given),
    and their notes."""
    if not broken:
        return circuit, []
    parts, lines = [], []
    for name in sorted(broken):
        elements, line = breakdown_elements(bds[name], tops.get(name))
        parts += elements
        lines.append(line)
    return replace(circuit, elements=[*circuit.elements, *parts]), lines


def _resized(res: SimulationResult, bds: dict, broken: set[str], tops: dict[str, float]
             ) -> dict[str, float]:
    """The broken-down diodes whose branch carries a current well outside the range its
    line was fitted over (above 1.5 times its top, or below a twentieth of it), and that
    current (A): their line is fitted again there."""
    t = np.asarray(res.t, float)
    out = {}
    for name in sorted(broken):
        top = tops.get(name, bds[name].ibv)
        carried = carried_current(t, res[f"i({name}#bv)"])
        if carried > 1.5 * top or 1e-12 < carried < top / 20:
            out[name] = carried
    return out


def _temperature_note(circuit: Circuit, diodes: Sequence[str]) -> str:
    """What the deck's temperatures change in ngspice that the fits of ``diodes``, at 27 °C
    with their models' parameters as given (:mod:`netlist.diode_dc`), do not follow: a
    circuit temperature (``.temp``, ``.options temp=``) or a model's nominal temperature
    (its ``TNOM``, else ``.options tnom=``) other than 27 °C, at which ngspice scales the
    model's ``IS`` (``EG``, ``XTI``); "" where there is none."""

    def number(text) -> float | None:
        value = parse_number(str(text))
        return value if value is not None and abs(value - 27.0) > 1e-9 else None

    options = {str(k).lower(): v for k, v in circuit.options.items()}
    temp = options.get("temp")
    for cmd in circuit.ignored:
        words = str(cmd.text).split()
        if len(words) > 1 and words[0].lower() == ".temp":
            temp = words[1]
    said = [f"{number(temp):g} °C"] if temp is not None and number(temp) is not None else []
    merged = parallel_diodes(circuit)
    tnoms = {}
    for name in diodes:
        models, _ = junction_models(circuit, circuit.element(name), merged)
        for params, _ in models:
            given = {str(k).lower(): v for k, v in params.items()}.get("tnom",
                                                                       options.get("tnom"))
            if given is not None and number(given) is not None:
                tnoms[f"{number(given):g}"] = None
    if tnoms:
        said.append(f"TNOM = {', '.join(tnoms)} °C")
    if not said:
        return ""
    return (f"pwl: the diode fits follow ngspice's characteristic at 27 °C of the models as "
            f"given; the deck sets {' and '.join(said)}, where ngspice scales IS (EG, XTI) and "
            "its diodes carry other currents: the runs differ (remove the temperatures to "
            "compare)")


def _junction_theta(run_circuit: Circuit, charges: dict, kw: dict,
                    loop_caps: Sequence[str] = ()) -> tuple[dict, str]:
    """The run's arguments with θ = 1 where the junction capacitors' fastest mode
    (:func:`netlist.junction_charge.fastest_junction_mode`) is not resolved by the step
    (``|h μ| > 1``) and no θ is given, and a note ("" when nothing changes). ``loop_caps``:
    capacitors that only a switch's RON parts from voltage sources (the loop an ideal switch
    closes), whose RON C mode is judged the same way: at θ = 1/2 an unresolved one
    alternates from step to step (a 1 nF hold capacitor charged through RON = 10 Ω at a
    10 µs step read 0 V and 10 V in turn for a 5 V source)."""
    if not (charges or loop_caps) or kw.get("method", "moreau") != "moreau":
        return kw, ""
    from .transient import transient_setup

    with passivity_unreported():  # (the run reports the circuit's passivity, once)
        setup = transient_setup(run_circuit, tstop=kw.get("tstop"), step=kw.get("step"))
    mu = fastest_junction_mode(setup.system, setup.energy, list(charges),
                               [f"v({c})" for c in loop_caps])
    if mu is None or abs(mu) * setup.h <= 1.0:
        return kw, ""
    which = ("the junction capacitances" if not loop_caps else
             f"the switches' on resistance and {', '.join(loop_caps)}" if not charges else
             f"the junction capacitances, the switches' on resistance and "
             f"{', '.join(loop_caps)}")
    what = (f"{which} add a mode at |μ| = {abs(mu):.3g} 1/s (Re μ = "
            f"{mu.real:.3g} 1/s) that the step h = {setup.h:.3g} s does not resolve (|h μ| = "
            f"{abs(mu) * setup.h:.3g})")
    if kw.get("theta") is not None:
        if float(kw["theta"]) >= 1.0:
            return kw, ""
        return kw, f"{what}: θ = {kw['theta']:g} as given, which integrates it unresolved"
    return {**kw, "theta": 1.0}, (f"{what}: the run uses θ = 1 (backward Euler, first order), "
                                  "which damps it unresolved; θ = 1/2 would keep it ringing "
                                  "or alternating from step to step")


def _fit_top(i_max: float) -> float:
    """The top of the current range a diode's fit covers (A): its carried current, or the
    1 mA a diode that carries none is fitted at (:func:`netlist.pwl.segment_fit`)."""
    return i_max if i_max > 1e-9 else 1e-3


def _voltage_probe(el: Diode) -> str:
    """The probe of a diode's voltage, anode to cathode."""
    return voltage_probe(el.nodes[0], el.nodes[1])


def _refitted(res: SimulationResult, circuit: Circuit, diodes: Sequence[str],
              i_max: dict[str, float]) -> dict[str, float]:
    """The diodes whose current in the pwl run ``res`` lies well below the range their fit's
    top segment was fitted over (below a twentieth of its top), and that current (A): their
    fit is sized again there. (Not above: where the pwl run carries more than the ideal one,
    it is an inrush the ideal run's quantile left out as lasting a step or two, which the
    diode's resistance now spreads over more steps: a capacitor charged from a square wave.)

    The current a diode carries is the larger of its current in the run and the current its
    model carries at the voltages the run puts across it (both
    :func:`netlist.pwl.carried_current`): a diode driven by a voltage (a source through a
    small resistance) carries the model's current at that voltage, which a line fitted over
    lower currents understates beyond its top (an exponential against a line), so the run's
    own current would keep the fit there."""
    t = np.asarray(res.t, float)
    merged = parallel_diodes(circuit)
    out = {}
    for name in diodes:
        el = circuit.element(name)
        top = _fit_top(i_max.get(name, 0.0))
        params, series = diode_params(circuit, el, merged)
        v = np.asarray(res[_voltage_probe(el)], float)
        carried = max(carried_current(t, res[f"i({name})"]),
                      carried_current(t, model_current(params, v, series)))
        if 1e-9 < carried < top / 20:
            out[name] = carried
    return out


def _driven_loop_caps(circuit: Circuit, exc: NetlistError) -> list[str]:
    """The capacitors of the loops ``exc`` refuses (closed by ideal switches), if every
    switch of those loops is driven by a voltage source across its control: their RON C
    mode is then a settling the source's timing starts, which θ = 1 may damp unresolved;
    where a switch's control is the circuit's own voltage (an inverter ring), the mode is
    its timing, which an unresolved step gets wrong whatever θ ([] then)."""
    by_key = {el.key: el for el in circuit.elements}
    sources = {frozenset(el.nodes[:2]) for el in circuit.elements
               if isinstance(el, VoltageSource)}
    caps: list[str] = []
    for d in exc.diagnostics:
        for name in d.elements:
            el = by_key.get(name.lower())
            if isinstance(el, Switch) and frozenset(el.control) not in sources:
                return []
            if isinstance(el, Capacitor):
                caps.append(el.name)
    return caps


def switch_loop(exc: NetlistError, switches: Sequence[Switch]) -> bool:
    """Whether ``exc`` refuses a loop of capacitors and voltage sources that closed ideal
    switches of ``switches`` close (:func:`netlist.degenerate.check_topology`)."""
    names = {sw.name for sw in switches}
    return any(d.message.startswith("loop of capacitors/voltage sources with")
               and names.intersection(d.elements) for d in exc.diagnostics)


#: the segments' diodes must cancel nothing θ = 1/2 would feel even at this many times the
#: run's step (the θ screen's G is proportional to the step, so in effect nothing: a
#: buck's freewheeling diode of three segments at 0.1 µs has G = -0.0008, under the
#: screen's limit of 0.001, and its mean output moves 0.05 % between h = 0.1 µs and
#: 0.025 µs, where with one segment it moves 1e-7)
SEGMENT_STEP_MARGIN = 1e4


def fitted_circuit(circuit: Circuit, i_max: dict, drives: dict, pwl: dict | None = None,
                   charged: Collection[str] = (), **kw) -> tuple[Circuit, list]:
    """:func:`netlist.pwl.pwl_circuit`, with one segment for the diodes whose segments would
    cost the run's θ accuracy (see :func:`_segments_theta_allows`).

    ``charged``: the diodes whose depletion charge the run models (their fit lines say so).
    ``kw``: the run's ``theta``, ``method``, ``tstop`` and ``step`` (others ignored)."""
    run_circuit, fits = pwl_circuit(circuit, i_max, drives, pwl, charged=charged)
    return _segments_theta_allows(circuit, run_circuit, fits, i_max, drives, pwl, kw,
                                  charged)


def _theta_pairs(run_circuit: Circuit, kw: dict, margin: float = 1.0) -> set[str] | None:
    """The pairs :func:`lcs.integrators.moreau.theta_screen.screen_theta` finds cancelling a
    stiff part of the dynamics at the run's θ (default 1/2) and ``margin`` times its step
    (names; empty: θ is reliable), or None for θ = 1 or another method than Moreau's."""
    from .transient import DEFAULT_THETA, transient_setup

    theta = DEFAULT_THETA if kw.get("theta") is None else float(kw["theta"])
    if theta >= 1.0 or kw.get("method", "moreau") != "moreau":
        return None
    from lcs.integrators.moreau.theta_screen import screen_theta

    with passivity_unreported():  # (not the circuit simulated: the junction charge is not in)
        setup = transient_setup(run_circuit, tstop=kw.get("tstop"), step=kw.get("step"))
    risks = screen_theta(setup.system, margin * setup.h, theta, energy=setup.energy)
    return {p for r in risks for p in r.pairs} | ({"?"} if risks else set())


def _segments_theta_allows(circuit: Circuit, run_circuit: Circuit, fits: list,
                           i_max: dict, drives: dict, pwl: dict | None, kw: dict,
                           charged: Collection[str] = ()) -> tuple[Circuit, list]:
    """The piecewise-linear circuit with one segment for the diodes whose segments would
    make θ = 1/2 less accurate (:func:`netlist.studies.transient.choose_theta`).

    A segment's diode lowers the resistance in series when it turns on; where an inductor's
    current runs through the diode (a converter's freewheeling diode), that cancels a stiff
    part of the dynamics, which θ < 1 integrates explicitly: the run would lose accuracy, or
    fall back to θ = 1 (first order). Such a diode turns off at its load current rather than
    letting a current decay through decades, which is what the segments are for. The screen
    runs at :data:`SEGMENT_STEP_MARGIN` times the step. A circuit that needs θ = 1 with one
    segment a diode keeps its segments (they cost no accuracy there)."""
    segmented = {f.element.lower(): f.element for f in fits if f.branches}

    def flagged(pairs):  # the diodes whose segments' own diodes (<element>#d<k>) it names
        return {segmented[p.split("#")[0].lower()] for p in pairs or ()
                if "#d" in p and p.split("#")[0].lower() in segmented}

    if not segmented:
        return run_circuit, fits
    single = flagged(_theta_pairs(run_circuit, kw, SEGMENT_STEP_MARGIN))
    if not single:
        return run_circuit, fits
    one, one_fits = pwl_circuit(circuit, i_max, drives, pwl, set(segmented.values()),
                                charged=charged)
    if _theta_pairs(one, kw):
        return run_circuit, fits
    for _ in range(len(segmented)):  # each round keeps at least one more at one segment
        run_circuit, fits = pwl_circuit(circuit, i_max, drives, pwl, single, charged=charged)
        more = flagged(_theta_pairs(run_circuit, kw, SEGMENT_STEP_MARGIN)) - single
        if not more:
            break
        single |= more
    return run_circuit, fits
