"""Screening a switched LCS for passivity before a run: cheap, cached, certain when it speaks.

Every mode (or, past :data:`SCREEN_MAX_SWITCHES` switches, all-off and all-on) goes through
the cheap part of :func:`lcs.theory.passivity.check_passivity`: the circuit's energy as a
certificate, then the exact necessary conditions. A mode that fails a necessary condition is
certainly not passive and is reported; the semidefinite program is never run here.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from ..notices import NonPassiveWarning
from . import passivity

__all__ = ["NonPassiveMode", "NonPassiveWarning", "SCREEN_MAX_SWITCHES", "screen_modes"]

@dataclass(frozen=True)
class NonPassiveMode:
    """A switch configuration that failed an exact necessary condition of passivity.

    Attributes
    ----------
    key : tuple of bool
        The mode key (switch states in the system's order).
    switches : str
        ``"S1 on, S2 off"`` (``"no switches"`` for a diode-only circuit).
    reason : str
        Why, as :func:`lcs.theory.passivity.check_passivity` says it (names states and diodes).
    """

    key: tuple
    switches: str
    reason: str

    def message(self) -> str:
        where = "" if self.switches == "no switches" else f" (mode {self.switches})"
        return f"the circuit is not passive{where}: {self.reason}"


# Per system: {mode key: NonPassiveMode or None}; weak, so it lives as long as the
# formulation it belongs to.
_SCREENED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

#: modes screened: every mode up to this many switches, else all-off and all-on
SCREEN_MAX_SWITCHES = 4


def screen_modes(system, energy: np.ndarray | None, keys=None) -> list[NonPassiveMode]:
    """The modes of a switched LCS that are certainly not passive.

    The cheap part of :func:`lcs.theory.passivity.check_passivity` only (``search=False``): the
    circuit's energy as a certificate (an eigenvalue test, microseconds), and when it fails,
    the exact necessary conditions (``D + D' >= 0``, no unstable eigenvalue of A, positive
    realness on a frequency grid). No semidefinite program: a mode that passes both is not
    reported, so every reported mode is non-passive for sure (``pelcs lcs`` gives the full
    verdict). Cached with the system.

    Parameters
    ----------
    system : lcs.model.SwitchedLCS
    energy : ndarray (n, n) or None
        The storage ``blkdiag(L, diag(C))`` (J/A², J/V²).
    keys : sequence of mode keys, optional
        Default: every mode up to :data:`SCREEN_MAX_SWITCHES` switches, else all switches
        off and all on.

    Returns
    -------
    list of NonPassiveMode
        In the order of ``keys``; empty when none fails.
    """
    if keys is None:
        k = len(system.switches)
        if k <= SCREEN_MAX_SWITCHES:
            keys = system.all_keys()
        else:
            keys = [tuple(False for _ in range(k)), tuple(True for _ in range(k))]
    cache = _SCREENED.setdefault(system, {})
    found = []
    for key in keys:
        key = tuple(bool(v) for v in key)
        if key not in cache:
            try:
                # A mode the run may never reach can be degenerate (a shoot-through loop of
                # closed switches): its formulation error is the run's to report if it
                # gets there, not the screen's.
                lcs = system.mode(key)
                rep = passivity.check_passivity(lcs, energy=energy, search=False)
            except Exception:  # noqa: BLE001
                cache[key] = None  # cannot tell cheaply: say nothing
                continue
            if rep.method == "necessary-condition":
                sw = ", ".join(f"{s.name} {'on' if on else 'off'}"
                               for s, on in zip(system.switches, key, strict=True))
                cache[key] = NonPassiveMode(key, sw or "no switches", rep.reason)
            else:
                cache[key] = None
        if cache[key] is not None:
            found.append(cache[key])
    return found
