"""The map interface of the analysis: ``x -> P(x)`` on named states, and maps given by a function.

:class:`Map` is what the analysis cores (orbits, continuation, bifurcation sweeps, cell
mapping) work on; :class:`FunctionMap` wraps any Python function, so that the cores can be
tested on maps with known answers. Maps of switched LCS are in :mod:`.stroboscopic` and
:mod:`.event_map`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .jacobians import central_jacobian
from .patterns import SwitchingPattern

__all__ = ["FunctionMap", "Map", "MapError", "Samples"]


class MapError(RuntimeError):
    """A map evaluation failed (simulation error or non-finite state).

    Attributes
    ----------
    x : ndarray or None
        The state the evaluation started from.
    param : float or None
        The parameter value of the map.
    """

    def __init__(self, message: str, x: np.ndarray | None = None, param: float | None = None):
        super().__init__(message)
        self.x = None if x is None else np.array(x, dtype=float)
        self.param = param


@dataclass
class Samples:
    """Probe values at the map's sampling instants.

    Attributes
    ----------
    names : tuple[str, ...]
        Probe names (columns of ``values``).
    values : ndarray, shape (M, q)
        One row per recorded iterate, in the SI unit of each probe.
    x_final : ndarray, shape (dim,)
        Map state after the last iterate (to start the next parameter value from).
    ok : bool
        False if the run failed (diverged, LCP failure); rows not reached are NaN.
    message : str
        Why the run failed, empty otherwise.
    """

    names: tuple[str, ...]
    values: np.ndarray
    x_final: np.ndarray
    ok: bool = True
    message: str = ""



class Map(ABC):
    """A discrete-time map ``x -> P(x)`` on ``dim`` named states, built for one parameter.

    Attributes
    ----------
    state_names : tuple[str, ...]
    param : float or None
        Value of the parameter the map was built for.
    param_name : str or None
    x0 : ndarray or None
        A natural initial state (circuit initial conditions), if known.
    """

    state_names: tuple[str, ...] = ()
    param: float | None = None
    param_name: str | None = None
    # A natural starting state (a circuit's IC= / .ic values), shape (n,), if known.
    x0: np.ndarray | None = None

    @property
    def dim(self) -> int:
        return len(self.state_names)

    @abstractmethod
    def __call__(self, x) -> np.ndarray:
        """One iterate ``P(x)``, shape (dim,). Raises :class:`MapError` on failure."""

    def power(self, x, k: int) -> np.ndarray:
        """``P^k(x)``, shape (dim,)."""
        y = np.asarray(x, dtype=float)
        for _ in range(int(k)):
            y = self(y)
        return y

    def iterate(self, x, n: int) -> np.ndarray:
        """The orbit ``x, P(x), ..., P^n(x)``, shape (n + 1, dim)."""
        out = np.empty((int(n) + 1, self.dim))
        out[0] = np.asarray(x, dtype=float)
        for k in range(1, int(n) + 1):
            out[k] = self(out[k - 1])
        return out

    def sample(self, x, skip: int, record: int, probes: Sequence[str] | None = None
               ) -> Samples:
        """Discard ``skip`` iterates, then record probes at the next ``record`` iterates.

        Parameters
        ----------
        x : array_like, shape (dim,)
        skip, record : int
            Transient iterates discarded, iterates recorded (``P^{skip+1}(x)`` ...
            ``P^{skip+record}(x)``).
        probes : sequence of str, optional
            Names to record; this base implementation knows the state names only.

        Returns
        -------
        Samples
            Never raises for a failing run: ``ok`` is False and missing rows are NaN.
        """
        names = tuple(probes) if probes else self.state_names
        lower = [s.lower() for s in self.state_names]
        try:
            cols = [lower.index(p.lower()) for p in names]
        except ValueError:
            raise KeyError(f"unknown probe(s) in {names}; this map knows "
                           f"{', '.join(self.state_names)}") from None
        values = np.full((int(record), len(names)), np.nan)
        y = np.asarray(x, dtype=float)
        try:
            y = self.power(y, skip)
            for k in range(int(record)):
                y = self(y)
                values[k] = y[cols]
        except MapError as exc:
            return Samples(names, values, np.full(self.dim, np.nan), False, str(exc))
        return Samples(names, values, y, True)

    def pattern(self, x, k: int = 1) -> SwitchingPattern | None:
        """Switching pattern of the k iterates from ``x``; None for maps without switches."""
        return None

    def natural_scale(self) -> np.ndarray | None:
        """Typical magnitude of each state (for finite-difference steps), or None."""
        return None

    def jacobian(self, x, k: int, scale: np.ndarray, rel_step: float = 1e-5) -> np.ndarray:
        """Jacobian of ``P^k`` at ``x``, shape (dim, dim): central differences with steps
        ``rel_step * scale``."""
        return central_jacobian(lambda v: self.power(v, k), np.asarray(x, dtype=float),
                                np.asarray(scale, dtype=float), rel_step)


class FunctionMap(Map):
    """A map given by a Python function (tests, toy models, analytic references).

    Parameters
    ----------
    fn : callable
        ``fn(x) -> x'`` on arrays of shape (dim,). Must be picklable (a module-level function
        or a ``functools.partial`` of one) to be used with worker processes.
    state_names : sequence of str
    param : float, optional
    param_name : str, optional
    scale : array_like, shape (dim,), optional
        Typical state magnitudes.
    """

    def __init__(self, fn: Callable[[np.ndarray], np.ndarray], state_names: Sequence[str],
                 param: float | None = None, param_name: str | None = None,
                 scale=None):
        self.fn = fn
        self.state_names = tuple(state_names)
        self.param = param
        self.param_name = param_name
        self._scale = None if scale is None else np.asarray(scale, dtype=float)

    def __call__(self, x) -> np.ndarray:
        y = np.asarray(self.fn(np.asarray(x, dtype=float)), dtype=float).reshape(self.dim)
        if not np.all(np.isfinite(y)):
            raise MapError(f"non-finite image {y} of {x}", x, self.param)
        return y

    def natural_scale(self) -> np.ndarray | None:
        return self._scale

