"""Linear complementarity systems with named signals.

One switch configuration of a circuit is an :class:`LCS`::

    x' = A x + B λ + E u
    w  = C x + D λ + F u,        0 <= w ⊥ λ >= 0

with n states, m complementarity pairs (one per ideal diode) and p inputs (independent
sources). Every row and column is named, as python-control names the signals of a
``StateSpace``. A :class:`SwitchedLCS` holds one LCS per configuration of the ideal switches,
built lazily by a callback and cached, plus output maps for probes.

This module knows nothing about netlists: the callback that builds a mode comes from
``netlist.formulation``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .network import NetworkRealisation

# What λ stands for in a diode's complementarity pair.
LAMBDA_CURRENT = "current"  # λ = diode current (A), w = reverse voltage (V)
LAMBDA_VOLTAGE = "voltage"  # λ = reverse voltage (V), w = diode current (A)


@dataclass(frozen=True)
class ComplementarityPair:
    """One ideal diode's complementarity pair.

    Parameters
    ----------
    name : str
        The diode's element name, e.g. ``"D1"`` or ``"X1.D2"``.
    lam : str
        ``"current"`` (λ is the forward current, w the reverse voltage) or ``"voltage"``
        (λ is the reverse voltage, w the forward current).
    """

    name: str
    lam: str = LAMBDA_CURRENT

    @property
    def lambda_label(self) -> str:
        return f"i({self.name})" if self.lam == LAMBDA_CURRENT else f"-v({self.name})"

    @property
    def w_label(self) -> str:
        return f"-v({self.name})" if self.lam == LAMBDA_CURRENT else f"i({self.name})"


@dataclass(frozen=True)
class LCS:
    """One linear complementarity system with named states, pairs and inputs.

    Shapes: ``A (n, n)``, ``B (n, m)``, ``C (m, n)``, ``D (m, m)``, ``E (n, p)``, ``F (m, p)``.
    Units are SI: states are amperes (inductor currents) and volts (capacitor voltages).
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    E: np.ndarray
    F: np.ndarray
    states: tuple[str, ...]
    pairs: tuple[ComplementarityPair, ...]
    inputs: tuple[str, ...]

    def __post_init__(self) -> None:
        n, m, p = len(self.states), len(self.pairs), len(self.inputs)
        expected = {
            "A": (n, n), "B": (n, m), "C": (m, n), "D": (m, m), "E": (n, p), "F": (m, p),
        }
        for key, shape in expected.items():
            arr = np.asarray(getattr(self, key), dtype=float).reshape(shape)
            object.__setattr__(self, key, arr)

    @property
    def n(self) -> int:
        return len(self.states)

    @property
    def m(self) -> int:
        return len(self.pairs)

    @property
    def p(self) -> int:
        return len(self.inputs)


@dataclass(frozen=True)
class OutputMap:
    """Probes as linear maps ``y = Cy x + Dy λ + Fy u``.

    Shapes: ``Cy (q, n)``, ``Dy (q, m)``, ``Fy (q, p)`` for q probe names.
    """

    names: tuple[str, ...]
    Cy: np.ndarray
    Dy: np.ndarray
    Fy: np.ndarray


@dataclass(frozen=True)
class SwitchControl:
    """An ideal switch and the comparator that drives it.

    The switch is on while ``control > vt + |vh|`` and off while ``control < vt - |vh|``; in
    the band it keeps its state when ``vh > 0``, and with ``vh <= 0`` it is on when the control
    entered the band from below, off when from above (ngspice's SW model; see
    :func:`lcs.simulation.source_switching.band_rule` for the exact rule and ``options``).
    ``control`` names a probe, e.g. ``"v(gate,0)"``, whose output map depends on the mode.
    """

    name: str
    control: str
    vt: float = 0.0
    vh: float = 0.0
    options: dict = field(default_factory=dict)


#: a switch option (``SwitchControl.options``): the switch stands for an idealised transistor,
#: on only while its control exceeds the threshold (an MOS device at its threshold voltage
#: conducts nothing); see :func:`lcs.simulation.source_switching.band_rule`
IDEALISED_OPTION = "idealised"
#: a switch option: the run stands for ngspice's transient from its DC operating point (no
#: UIC), which decides the state of a VH <= 0 switch whose control starts inside its band
#: (:func:`lcs.simulation.source_switching.initial_sub`)
OPERATING_POINT_OPTION = "operating_point"
#: a switch option: the probe of the voltage across the switch (``"v(a,b)"``), through which
#: ngspice's operating point reaches what an open switch alone joins to the circuit (its
#: ROFF: :func:`lcs.theory.operating_point.dc_point`'s leaks)
TERMINALS_OPTION = "terminals"


# A mode is the tuple of switch states, True = on (short), in the order of
# SwitchedLCS.switches.
ModeKey = tuple[bool, ...]


@dataclass
class ModeModel:
    """What the builder returns for one switch configuration: the LCS, its output maps, and
    where the LCS comes from a sparse network, that network
    (:class:`~lcs.network.NetworkRealisation`, for the sparse KKT stepping; or a function
    building it when first asked for)."""

    lcs: LCS
    output: Callable[[Sequence[str]], OutputMap]
    network: NetworkRealisation | Callable[[], NetworkRealisation] | None = None
    #: States held at zero in this mode, ``{state index: k}`` with the stored energy
    #: ``½ k x²`` (an inductor that the open switches leave with no path: ``k = L``, H). The
    #: LCS gives them no dynamics and takes them into nothing; entering the mode, the run sets
    #: them to zero (an ideal switch cutting an inductor's current) and notes the energy lost.
    pinned: dict = field(default_factory=dict)


def _switch_state(name: str, value) -> bool:
    """One switch's state in a configuration: a boolean (numpy's too) or "on"/"off"."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, str) and value.strip().lower() in ("on", "off"):
        return value.strip().lower() == "on"
    raise ValueError(f"switch {name}: state {value!r} is neither a boolean nor 'on'/'off'")


class SwitchedLCS:
    """One LCS per switch configuration, computed lazily and cached (a configuration the
    builder rejects too: its error is raised again without rebuilding).

    Parameters
    ----------
    switches : sequence of SwitchControl
        The ideal switches, in a fixed order that defines mode keys.
    states, inputs : sequence of str
        State and input names, the same in every mode.
    diodes : sequence of str
        Diode names, one complementarity pair each (what λ stands for may differ per mode).
    builder : callable
        ``builder(mode_key) -> ModeModel``.
    pinnable : sequence of int, optional
        States that some modes hold at zero (:attr:`ModeModel.pinned`); a run applies the
        jumps to zero only when there are some.
    storage : ndarray (n, n), optional
        A candidate storage function ``½ x' storage x`` of every mode (a circuit's stored
        energy: H on inductor currents, F on capacitor voltages). Where it is verified to be
        one, a time step's next state is known to be unique whatever λ it takes
        (:mod:`lcs.theory.step_uniqueness`) and the integrator does not look for other solutions.
    offsets : ndarray of bool (m, p), optional
        For each pair, the inputs that are its own device's offset voltages (a piecewise-linear
        diode's ``Vf`` sources): ``w`` less their terms is the voltage across the device's
        junction while it carries nothing, where ngspice's GMIN leaks
        (:func:`lcs.theory.operating_point.dc_point`).
    shadowed : collection of str, optional
        State names, lower case, that the output maps read as something else when spelled
        otherwise than the state (``v(c1)``, the voltage of a node ``c1``, beside a
        capacitor ``C1``'s state ``v(C1)``): such a probe is not taken for the state.
    """

    def __init__(
        self,
        switches: Sequence[SwitchControl],
        states: Sequence[str],
        inputs: Sequence[str],
        diodes: Sequence[str],
        builder: Callable[[ModeKey], ModeModel],
        pinnable: Sequence[int] = (),
        storage: np.ndarray | None = None,
        offsets: np.ndarray | None = None,
        shadowed: Sequence[str] = (),
    ):
        self.switches = tuple(switches)
        self.shadowed = frozenset(s.lower() for s in shadowed)
        self.storage = None if storage is None else np.asarray(storage, dtype=float)
        self.offsets = None if offsets is None else np.asarray(offsets, dtype=bool)
        self.states = tuple(states)
        self.inputs = tuple(inputs)
        self.diodes = tuple(diodes)
        self._builder = builder
        self.pinnable = tuple(pinnable)
        self._modes: dict[ModeKey, ModeModel] = {}
        self._failed: dict[ModeKey, Exception] = {}
        self._outputs: dict[tuple[ModeKey, tuple[str, ...]], OutputMap] = {}

    def key(self, config: dict[str, bool | str] | Sequence[bool | str] | None = None) -> ModeKey:
        """Normalise a configuration to a mode key.

        Parameters
        ----------
        config : dict, sequence or None
            A dict by switch name (case-insensitive) naming every switch, or a sequence in the
            order of :attr:`switches`; each state is a boolean (``True`` = on, a short) or the
            string ``"on"``/``"off"``. None is every switch off.

        Raises
        ------
        KeyError
            A dict names an unknown switch or leaves one out.
        ValueError
            A state is neither a boolean nor ``"on"``/``"off"`` (``0``, ``"false"`` and ``0.5``
            are refused rather than read by their truth value: ``bool("off")`` is True), or a
            sequence has the wrong length.
        """
        if config is None:
            return tuple(False for _ in self.switches)
        if isinstance(config, dict):
            given = {str(k).lower(): (k, v) for k, v in config.items()}
            known = {s.name.lower() for s in self.switches}
            unknown = sorted(k for k, _ in given.values() if str(k).lower() not in known)
            if unknown:
                raise KeyError(f"unknown switch(es): {', '.join(map(str, unknown))}; "
                               f"the switches are {', '.join(s.name for s in self.switches)}")
            missing = [s.name for s in self.switches if s.name.lower() not in given]
            if missing:
                raise KeyError(f"no state given for switch(es) {', '.join(missing)}: name "
                               "every switch (True/'on' or False/'off')")
            return tuple(_switch_state(*given[s.name.lower()]) for s in self.switches)
        values = tuple(config)
        if len(values) != len(self.switches):
            raise ValueError(f"mode key needs {len(self.switches)} entries, got {len(values)}")
        return tuple(_switch_state(s.name, v) for s, v in zip(self.switches, values, strict=True))

    def all_keys(self) -> list[ModeKey]:
        """Every switch configuration (2**k of them), all-off first."""
        k = len(self.switches)
        return [tuple(bool((i >> j) & 1) for j in range(k)) for i in range(2**k)]

    def mode(self, config=None) -> LCS:
        """The LCS of one switch configuration."""
        return self._mode_model(self.key(config)).lcs

    def network(self, config=None) -> NetworkRealisation | None:
        """The sparse network of one switch configuration's LCS, or None (an LCS given by
        its matrices, or a mode whose network matrix is singular)."""
        model = self._mode_model(self.key(config))
        if callable(model.network):
            model.network = model.network()
        return model.network

    def pinned(self, config=None) -> dict:
        """The states one switch configuration holds at zero, ``{state index: k}`` (energy
        ``½ k x²``; :attr:`ModeModel.pinned`)."""
        return self._mode_model(self.key(config)).pinned

    def outputs(self, config, probes: Sequence[str]) -> OutputMap:
        """Output maps of the given probes in one switch configuration."""
        key = self.key(config)
        probes = tuple(probes)
        cache_key = (key, probes)
        if cache_key not in self._outputs:
            self._outputs[cache_key] = self._mode_model(key).output(probes)
        return self._outputs[cache_key]

    def _mode_model(self, key: ModeKey) -> ModeModel:
        if key not in self._modes:
            # A rejected configuration is asked for again by the next caller (the passivity
            # screen, then the θ screen, each try the all-on mode; a 64-cell MMC arm's
            # shoot-through took 0.12 s to reject): its error is kept and raised again.
            if key in self._failed:
                # (without its old traceback, which a plain re-raise would extend each time)
                raise self._failed[key].with_traceback(None)
            try:
                self._modes[key] = self._builder(key)
            except Exception as exc:
                self._failed[key] = exc
                raise
        return self._modes[key]

    def describe_mode(self, config) -> dict[str, str]:
        key = self.key(config)
        return {s.name: ("on" if on else "off") for s, on in zip(self.switches, key, strict=True)}
