"""Warning categories that runs emit (kept free of heavy imports: the CLI filters on them
before anything numerical loads)."""

from __future__ import annotations

__all__ = ["IdealisedDeviceWarning", "NonPassiveWarning"]


class NonPassiveWarning(UserWarning):
    """A simulated circuit is not passive: its ideal model may grow without bound (the run
    goes on, unless asked to be strict). See :func:`lcs.theory.passivity.screen_modes`."""


class IdealisedDeviceWarning(UserWarning):
    """Transistors (M, Q) of a netlist were replaced by ideal switches (and body diodes);
    ``circuit.replacements`` lists each. ``--strict`` refuses such netlists."""
