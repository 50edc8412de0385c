"""Cross-checks against ngspice: run netlists through PySpice's shared-library interface.

``run_ngspice(text, probes)`` is the entry point (see :mod:`ngspice_checks.runner` for the
settings ladder that makes near-ideal switching circuits converge); ``available()`` and
``require_ngspice()`` answer whether ngspice can be used here (tests use the latter through
the ``ngspice`` fixture of ``tests/conftest.py``).
"""

from .availability import REQUIRE_ENV, available, require_ngspice, unavailable_reason
from .runner import (
    DEFAULT_LADDER,
    NgspiceAttempt,
    NgspiceError,
    NgspiceFailed,
    NgspiceResult,
    NgspiceSettings,
    NgspiceUnavailable,
    ProbeError,
    SwitchModel,
    apply_settings,
    ngspice_version,
    run_ngspice,
)

__all__ = [
    "DEFAULT_LADDER",
    "REQUIRE_ENV",
    "NgspiceAttempt",
    "NgspiceError",
    "NgspiceFailed",
    "NgspiceResult",
    "NgspiceSettings",
    "NgspiceUnavailable",
    "ProbeError",
    "SwitchModel",
    "apply_settings",
    "available",
    "ngspice_version",
    "require_ngspice",
    "run_ngspice",
    "unavailable_reason",
]
