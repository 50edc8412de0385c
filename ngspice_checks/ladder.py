"""The ngspice settings ladder: the rungs :func:`ngspice_checks.runner.run_ngspice` tries in
turn, each a text edit of the netlist (see *The ladder* in :mod:`ngspice_checks.runner` for
the order and the survey behind it)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace

from . import deck

__all__ = ["DEFAULT_LADDER", "NgspiceSettings", "SwitchModel", "apply_settings", "ladder_for"]



@dataclass(frozen=True)
class SwitchModel:
    """Replacement parameters for every SW model; VT is always kept.

    Attributes
    ----------
    ron, roff : float
        On and off resistance (ohm).
    vh_min : float
        The hysteresis half-width VH is raised to at least this (V); larger VH are kept.
    """

    ron: float = 1e-3
    roff: float = 1e9
    vh_min: float = 1e-3


@dataclass(frozen=True)
class NgspiceSettings:
    """One rung of the ladder: how the netlist is adjusted before ngspice runs it.

    Attributes
    ----------
    name : str
        Short identifier (``"as-written"``, ``"shunts"``, ...).
    description : str
        One line on what the rung changes.
    options : dict
        ``.options`` added after the user's own (ours win); value None is a bare flag.
    pulse_min_edge : float or None
        Smallest PW and nonzero TR/TF of PULSE sources (s); None leaves them.
    diode_model : dict or None
        Parameters given to every D model (replacing the user's); None keeps them.
    switch_model : SwitchModel or None
        RON/ROFF/VH floor for every SW model; None keeps the user's.
    initial_voltages : bool
        Add ``.ic`` lines with the node voltages given to :func:`run_ngspice`
        (``initial_voltages=``: pelcs' consistent state at t = 0+).
    """

    name: str
    description: str = ""
    options: dict[str, str | None] = field(default_factory=dict)
    pulse_min_edge: float | None = None
    diode_model: dict[str, str] | None = None
    switch_model: SwitchModel | None = None
    initial_voltages: bool = False


_AS_WRITTEN = NgspiceSettings("as-written", "the netlist unchanged")
_EDGES = replace(
    _AS_WRITTEN,
    name="finite-edges",
    description="PULSE PW and nonzero TR/TF >= 1 ns",
    pulse_min_edge=1e-9,
)
_GEAR = replace(
    _EDGES,
    name="gear",
    description="+ Gear (BDF2) integration",
    options={"method": "gear"},
)
_SHUNTS = replace(
    _GEAR,
    name="shunts",
    description="+ cshunt=1 pF, rshunt=1 TOhm from every node to ground",
    options={**_GEAR.options, "cshunt": "1e-12", "rshunt": "1e12"},
)
_RELAXED = replace(
    _SHUNTS,
    name="relaxed",
    description="+ reltol=1e-2 abstol=1e-9 vntol=1e-4 chgtol=1e-14 itl4=100 gmin=1e-10",
    options={
        **_SHUNTS.options,
        "reltol": "1e-2",
        "abstol": "1e-9",
        "vntol": "1e-4",
        "chgtol": "1e-14",
        "itl4": "100",
        "gmin": "1e-10",
    },
)
_SMOOTH = replace(
    _RELAXED,
    name="smooth-models",
    description="+ D(IS=1e-12 N=0.05 RS=1m), SW RON=1m ROFF=1e9 VH>=1m",
    diode_model={"is": "1e-12", "n": "0.05", "rs": "1e-3"},
    switch_model=SwitchModel(ron=1e-3, roff=1e9, vh_min=1e-3),
)

#: rung 1 when :func:`run_ngspice` is given ``initial_voltages`` (see the module docstring)
_INITIAL = replace(
    _AS_WRITTEN,
    name="initial-state",
    description=".ic with the consistent node voltages at t = 0+ (pelcs')",
    initial_voltages=True,
)

#: the rungs tried by :func:`run_ngspice`, least invasive first (see the module docstring)
DEFAULT_LADDER: tuple[NgspiceSettings, ...] = (
    _AS_WRITTEN,
    _EDGES,
    _GEAR,
    _SHUNTS,
    _RELAXED,
    _SMOOTH,
)


def apply_settings(netlist: str, settings: NgspiceSettings,
                   initial_voltages: Mapping[str, float] | None = None) -> str:
    """The netlist text adjusted as ``settings`` says (pure text edit, see :mod:`.deck`)."""
    text = netlist
    if settings.initial_voltages and initial_voltages:
        text = deck.add_initial_conditions(text, initial_voltages)
    if settings.pulse_min_edge:
        text = deck.finite_pulse_edges(text, settings.pulse_min_edge)
    if settings.diode_model is not None:
        text = deck.replace_diode_models(text, settings.diode_model)
    if settings.switch_model is not None:
        sw = settings.switch_model
        text = deck.replace_switch_models(text, sw.ron, sw.roff, sw.vh_min)
    if settings.options:
        text = deck.add_options(text, settings.options)
    return text


def ladder_for(
    settings: NgspiceSettings | Sequence[NgspiceSettings] | None,
    initial: bool = False,
) -> tuple[NgspiceSettings, ...]:
    """The rungs to try: ``settings`` as given (one or a sequence), or the default ladder,
    with the initial-state rung when ``initial`` (the caller has consistent node voltages).
    """
    if settings is None:
        if not initial:
            return DEFAULT_LADDER
        # The initial-state rung right after the netlist as written, then the classic rungs
        # without it (kept in them, the .ic made the boost's diode audit fail at every rung:
        # a start on the orbit pins the switch node where ngspice's first step needs
        # freedom), and last everything together.
        first, *rest = DEFAULT_LADDER
        last = replace(rest[-1], name=rest[-1].name + "+initial-state", initial_voltages=True,
                       description=rest[-1].description + " + the rung-1 .ic")
        return (first, _INITIAL, *rest, last)
    if isinstance(settings, NgspiceSettings):
        return (settings,)
    ladder = tuple(settings)
    if not ladder or not all(isinstance(s, NgspiceSettings) for s in ladder):
        raise TypeError("settings must be None, an NgspiceSettings or a sequence of them")
    return ladder
