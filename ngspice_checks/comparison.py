"""What :func:`ngspice_checks.compare.compare` returns: the tolerances it applies and the
per-probe, per-switch and overall comparison records (presented by
``pelcs.check_report``, serialised by ``to_dict``)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from lcs.results import SimulationResult

from .measures import NonIdeality
from .runner import NgspiceResult, NgspiceSettings

__all__ = ["Comparison", "ProbeComparison", "SwitchingComparison", "Tolerances"]



@dataclass(frozen=True)
class Tolerances:
    """How far ngspice may be from pelcs (see the module docstring for the reasons).

    Attributes
    ----------
    nrms : float
        NRMS floor (fraction of the probe's scale); k·δ is added.
    mean : float
        Floor of the mean tolerance (fraction of the scale); the tolerance is max(mean, k·δ).
    ripple_rel : float
        Part of the ripple tolerance proportional to pelcs' ripple.
    ripple_floor : float
        Part of the ripple tolerance proportional to the scale (k·δ is added).
    k_nonideal : float
        Multiplier of the relative non-ideal drop δ.
    switching_steps : float
        Switching-instant tolerance in ngspice steps (TMAX).
    frequency : float
        Relative tolerance of the switching frequency of free-running switches.
    conclusive : float
        The widest relative tolerance that still decides anything: a comparison whose NRMS
        or mean tolerance exceeds it (model drops that pelcs does not represent) is
        *inconclusive*, never agreement.
    """

    nrms: float = 0.03
    mean: float = 0.01
    ripple_rel: float = 0.10
    ripple_floor: float = 0.005
    k_nonideal: float = 2.0
    switching_steps: float = 3.0
    frequency: float = 0.10
    conclusive: float = 0.10


@dataclass
class ProbeComparison:
    """The metrics of one probe (SI units of the probe: V or A).

    Attributes
    ----------
    probe : str
        The probe as given (pelcs syntax).
    ngspice_probe : str
        What ngspice measured for it (``v(C1)`` becomes ``v(out)`` or ``v(a,b)``).
    scale : float
        max(RMS, ½ peak-to-peak) of the pelcs waveform over the run.
    nrms, nrms_tol : float
        RMS difference on the common grid / scale, and its tolerance.
    mean_pelcs, mean_ngspice, mean_tol : float
        Averages over the steady-state window and the allowed |difference| (absolute).
    ripple_pelcs, ripple_ngspice, ripple_tol : float
        Peak-to-peak over the window and the allowed |difference| (absolute).
    excluded : float
        Fraction of grid points left out of the NRMS (near switching instants).
    nrms_over : str
        Where the NRMS was taken: ``"run"`` (the common run) or ``"steady state"`` (the
        window only: pelcs' own transient is not converged, ``Comparison.transient``).
    transient_nrms : float
        With ``nrms_over == "steady state"``: the NRMS over the transient before the window,
        (NaN otherwise); it fails only past ``transient_tol``.
    transient_tol : float
        The transient's NRMS tolerance widened by pelcs' own sensitivity there (the NRMS
        tolerance + 4 × pelcs' h-vs-h/2 difference): wide, it shows no agreement, it can
        only fail (NaN when the whole run is compared).
    self_nrms : float
        RMS difference of pelcs' runs at h and h/2 over the span the NRMS was taken on /
        scale (NaN when no second run was made: source-driven switching).
    pointwise : str
        Why the pointwise NRMS is not judged (the orbit is sensitive to perturbations:
        ``Comparison.sensitivity``); empty when it is.
    unjudged : str
        Why none of the run's metrics is judged: the two runs end on different orbits while
        pelcs restarted from ngspice's state follows it (``Comparison.orbit``); empty
        otherwise.
    restart_nrms, restart_mean_error : float
        That restart against ngspice over the window: NRMS (/ scale) and the mean
        difference (ngspice - restart, absolute); NaN when not run.
    """

    probe: str
    ngspice_probe: str
    scale: float
    nrms: float
    nrms_tol: float
    mean_pelcs: float
    mean_ngspice: float
    mean_tol: float
    ripple_pelcs: float
    ripple_ngspice: float
    ripple_tol: float
    excluded: float
    nrms_over: str = "run"
    transient_nrms: float = float("nan")
    transient_tol: float = float("nan")
    self_nrms: float = float("nan")
    pointwise: str = ""
    unjudged: str = ""
    restart_nrms: float = float("nan")
    restart_mean_error: float = float("nan")

    @property
    def mean_error(self) -> float:
        """ngspice mean - pelcs mean."""
        return self.mean_ngspice - self.mean_pelcs

    @property
    def ripple_error(self) -> float:
        """ngspice ripple - pelcs ripple."""
        return self.ripple_ngspice - self.ripple_pelcs

    @property
    def failures(self) -> list[str]:
        """Names of the metrics out of tolerance (empty: the probe passes)."""
        out = []
        # the window's metrics are set aside only when a restart from ngspice's state
        # agreed (Comparison.orbit); a transient or whole-run NRMS stays judged
        window_only = self.unjudged and self.nrms_over != "run"
        if not self.pointwise and not window_only and not self.nrms <= self.nrms_tol:
            out.append("nrms")
        if self.nrms_over != "run" and self.transient_nrms > self.transient_tol:
            out.append("transient nrms")
        if self.unjudged:
            return out
        if not abs(self.mean_error) <= self.mean_tol:
            out.append("mean")
        if not abs(self.ripple_error) <= self.ripple_tol:
            out.append("ripple")
        return out

    @property
    def ok(self) -> bool:
        return not self.failures

    @property
    def widest(self) -> float:
        """The widest of its NRMS and mean tolerances, relative to the scale."""
        return max(self.nrms_tol, self.mean_tol / self.scale)


@dataclass
class SwitchingComparison:
    """Switching instants of one switch in both simulators.

    Attributes
    ----------
    switch : str
    driven : str
        How pelcs drove it (``source``, ``implicit``, ``hysteresis``, ...).
    control : str
        The ngspice probe of its control voltage, ``v(nc+,nc-)``.
    method : str
        ``"instants"`` (instants compared), ``"frequency"`` (free-running: frequency
        compared) or ``"none"`` (not comparable; ``reason`` says why).
    n_pelcs, n_ngspice : int
        Switchings counted over the compared span.
    max_offset : float
        Largest distance from an instant of one simulator to the nearest instant of the
        same direction in the other (s); NaN when not compared by instants.
    tol : float
        Its tolerance (s), or the relative frequency tolerance for ``"frequency"``.
    freq_pelcs, freq_ngspice : float
        Turn-on frequency over the steady-state window (Hz); NaN if too few switchings.
    span : tuple of float
        The time span compared (s).
    reason : str
        Why nothing was compared, or a remark.
    note : str
        What the instants' comparison left out, if anything (an instant at an end of the
        run whose partner would lie past it).
    self_offset : float
        The same offset between pelcs' runs at h and h/2 (s; NaN when not measured).
    inconclusive : str
        Why the instants decide nothing (pelcs' own instants move by more than half the
        tolerance when the step is halved: a sensitive orbit); empty when they decide.
    """

    switch: str
    driven: str
    control: str
    method: str
    n_pelcs: int
    n_ngspice: int
    max_offset: float
    tol: float
    freq_pelcs: float
    freq_ngspice: float
    span: tuple[float, float]
    reason: str = ""
    note: str = ""
    self_offset: float = float("nan")
    inconclusive: str = ""

    @property
    def ok(self) -> bool:
        if self.inconclusive:
            return True  # not judged: Comparison.verdict says inconclusive
        if self.method == "instants":
            return self.max_offset <= self.tol
        if self.method == "frequency":
            return abs(self.freq_ngspice - self.freq_pelcs) <= self.tol * abs(self.freq_pelcs)
        return True


@dataclass
class Comparison:
    """Everything :func:`compare` found; ``pelcs.check_report`` presents it.

    Attributes
    ----------
    file, title : str
        Netlist file (or ``"<string>"``) and its title line.
    params, pelcs_params : dict
        ``.param`` overrides for both sides, and those applied to pelcs only (a deliberate
        difference: ``pelcs check --pelcs-param``).
    probes : list of ProbeComparison
    switches : list of SwitchingComparison
    tstop, step : float
        Stop time and pelcs step (s).
    theta : float
    span : tuple of float
        Common time span of both results (s).
    period : float or None
        Period used for the steady-state window (s), and ``period_source`` says where from.
    window : tuple of float
        The steady-state window (s); ``n_periods`` whole periods in it (0 without a period).
    nonideal : NonIdeality
    tolerances : Tolerances
    rung : int
        Ladder rung ngspice needed (0 = the netlist as written).
    settings : NgspiceSettings
        The rung's settings.
    attempts : list of (int, str, str)
        Failed rungs before it: (rung, name, reason).
    pelcs_wall, pelcs_load : float
        pelcs run time, and the one-off kernel loading before it (s).
    pelcs_steps : int
    ngspice_wall, ngspice_total : float
        ngspice load+run time of the successful rung, and the whole call with failed rungs
        and process start-up (s).
    ngspice_points : int
    notes : list of str
    pelcs_result : SimulationResult
    ngspice_result : NgspiceResult
    devices : str
        pelcs' devices: ``"ideal"`` or ``"pwl"`` (fitted to ngspice's models).
    device_fits : list of netlist.pwl.PwlFit
        The fits, with ``"pwl"``.
    transient : str
        Switching that follows the state and a transient pelcs' own step halving moves by
        more than half the NRMS tolerance: why the waveforms were compared pointwise over
        the steady-state window only (empty otherwise).
    sensitivity : str
        Why no pointwise comparison decides anything: pelcs' own runs at h and h/2 part in
        the steady-state window (a sensitive, e.g. chaotic, orbit). The verdict is then at
        best inconclusive.
    orbit : str
        Why the runs' metrics decide nothing: they end on different orbits (or phases of a
        subharmonic one) while pelcs restarted from ngspice's state at the window's start
        follows ngspice. The verdict is then inconclusive.
    """

    file: str
    title: str
    params: dict[str, Any]
    pelcs_params: dict[str, Any]
    probes: list[ProbeComparison]
    switches: list[SwitchingComparison]
    tstop: float
    step: float
    theta: float
    span: tuple[float, float]
    period: float | None
    period_source: str
    window: tuple[float, float]
    n_periods: int
    nonideal: NonIdeality
    tolerances: Tolerances
    rung: int
    settings: NgspiceSettings
    attempts: list[tuple[int, str, str]]
    pelcs_wall: float
    pelcs_load: float
    pelcs_steps: int
    ngspice_wall: float
    ngspice_total: float
    ngspice_points: int
    notes: list[str] = field(default_factory=list)
    pelcs_result: SimulationResult | None = field(default=None, repr=False)
    ngspice_result: NgspiceResult | None = field(default=None, repr=False)
    devices: str = "ideal"
    device_fits: list = field(default_factory=list)
    transient: str = ""
    sensitivity: str = ""
    orbit: str = ""

    @property
    def within(self) -> bool:
        """True when every probe and every switch is within its tolerance."""
        return all(p.ok for p in self.probes) and all(s.ok for s in self.switches)

    @property
    def inconclusive(self) -> list[str]:
        """The probes whose tolerance is too wide to decide anything (over
        ``Tolerances.conclusive``) or whose pointwise comparison decides nothing (a
        sensitive orbit, ``sensitivity``), and the switches whose instants decide nothing."""
        return ([p.probe for p in self.probes
                 if p.widest > self.tolerances.conclusive or p.pointwise or p.unjudged]
                + [f"{s.switch} (instants)" for s in self.switches if s.inconclusive])

    @property
    def verdict(self) -> str:
        """``"ok"`` (every metric within tolerances that decide), ``"fail"`` (something out
        of tolerance, however wide) or ``"inconclusive"`` (within tolerances wider than
        ``Tolerances.conclusive``: no agreement shown)."""
        if not self.within:
            return "fail"
        return "inconclusive" if self.inconclusive else "ok"

    @property
    def ok(self) -> bool:
        """True when the verdict is agreement (within tolerances that decide)."""
        return self.verdict == "ok"

    @property
    def failures(self) -> list[str]:
        """``"v(out): mean"``-style names of everything out of tolerance."""
        out = [f"{p.probe}: {', '.join(p.failures)}" for p in self.probes if not p.ok]
        out += [f"{s.switch}: switching {s.method}" for s in self.switches if not s.ok]
        return out

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (SI units; the waveforms are not included)."""
        s = self.settings
        return {
            "file": self.file,
            "title": self.title,
            "ok": self.ok,
            "verdict": self.verdict,
            "failures": self.failures,
            "inconclusive": self.inconclusive,
            "devices": self.devices,
            "device_fits": [{"element": f.element, "vf": f.vf, "ron": f.ron, "how": f.how,
                             "branches": [list(b) for b in f.branches], "error": f.error}
                            for f in self.device_fits],
            "params": _jsonable(self.params),
            "pelcs_params": _jsonable(self.pelcs_params),
            "tstop": self.tstop,
            "step": self.step,
            "theta": self.theta,
            "span": list(self.span),
            "period": self.period,
            "period_source": self.period_source,
            "window": list(self.window),
            "n_periods": self.n_periods,
            "ngspice": {
                "rung": self.rung,
                "settings": {
                    "name": s.name,
                    "description": s.description,
                    "options": dict(s.options),
                    "pulse_min_edge": s.pulse_min_edge,
                    "diode_model": s.diode_model,
                    "switch_model": None if s.switch_model is None
                    else vars(s.switch_model).copy(),
                },
                "failed_rungs": [
                    {"rung": r, "name": n, "reason": why} for r, n, why in self.attempts
                ],
                "wall_time": self.ngspice_wall,
                "total_time": self.ngspice_total,
                "points": self.ngspice_points,
            },
            "pelcs": {
                "wall_time": self.pelcs_wall,
                "kernel_load_time": self.pelcs_load,
                "steps": self.pelcs_steps,
            },
            "nonideal": {
                "diode_drops": self.nonideal.diode_drops,
                "switch_drops": self.nonideal.switch_drops,
                "v_ref": self.nonideal.v_ref,
                "delta": self.nonideal.delta,
            },
            "tolerances": vars(self.tolerances).copy(),
            "probes": [
                {**vars(p).copy(), "mean_error": p.mean_error, "ripple_error": p.ripple_error,
                 "ok": p.ok, "failures": p.failures,
                 "conclusive": (p.widest <= self.tolerances.conclusive and not p.pointwise
                                and not p.unjudged)}
                for p in self.probes
            ],
            "switches": [
                {**{k: v for k, v in vars(w).items()}, "span": list(w.span), "ok": w.ok}
                for w in self.switches
            ],
            "transient": self.transient,
            "sensitivity": self.sensitivity,
            "orbit": self.orbit,
            "notes": list(self.notes),
        }


def _jsonable(d: Mapping[str, Any]) -> dict[str, Any]:
    return {str(k): (v if isinstance(v, (int, float, str)) else str(v)) for k, v in d.items()}
