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

    The switch is on while ``control > vt + vh`` and off while ``control < vt - vh``; in the
    band it keeps its state (ngspice's SW model). ``control`` names a probe, e.g.
    ``"v(gate,0)"``, whose output map depends on the mode.
    """

    name: str
    control: str
    vt: float = 0.0
    vh: float = 0.0
    options: dict = field(default_factory=dict)


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
    storage : ndarray (n, n), optional
        A candidate storage function ``½ x' storage x`` of every mode (a circuit's stored
        energy: H on inductor currents, F on capacitor voltages). Where it is verified to be
        one, a time step's next state is known to be unique whatever λ it takes
        (:mod:`lcs.step_uniqueness`) and the integrator does not look for other solutions.
    """

    def __init__(
        self,
        switches: Sequence[SwitchControl],
        states: Sequence[str],
        inputs: Sequence[str],
        diodes: Sequence[str],
        builder: Callable[[ModeKey], ModeModel],
        storage: np.ndarray | None = None,
    ):
        self.switches = tuple(switches)
        self.storage = None if storage is None else np.asarray(storage, dtype=float)
        self.states = tuple(states)
        self.inputs = tuple(inputs)
        self.diodes = tuple(diodes)
        self._builder = builder
        self._modes: dict[ModeKey, ModeModel] = {}
        self._failed: dict[ModeKey, Exception] = {}
        self._outputs: dict[tuple[ModeKey, tuple[str, ...]], OutputMap] = {}

    def key(self, config: dict[str, bool] | ModeKey | None = None) -> ModeKey:
        """Normalise a configuration (a dict by switch name, or a tuple) to a mode key."""
        if config is None:
            return tuple(False for _ in self.switches)
        if isinstance(config, dict):
            lower = {k.lower(): bool(v) for k, v in config.items()}
            unknown = set(lower) - {s.name.lower() for s in self.switches}
            if unknown:
                raise KeyError(f"unknown switch(es): {', '.join(sorted(unknown))}")
            return tuple(lower.get(s.name.lower(), False) for s in self.switches)
        key = tuple(bool(v) for v in config)
        if len(key) != len(self.switches):
            raise ValueError(f"mode key needs {len(self.switches)} entries, got {len(key)}")
        return key

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
