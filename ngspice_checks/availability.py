"""Is ngspice usable here? One answer for the whole code base and its tests.

:func:`available` says whether PySpice can load libngspice (checked once per process, by
starting the runner's worker: the exact path simulations take). :func:`require_ngspice` is
what tests call: it returns the ngspice version, or skips the test loudly, or fails it when
the environment variable ``PELCS_REQUIRE_NGSPICE=1`` says ngspice must be there (CI).
"""

from __future__ import annotations

import os
import sys
import warnings

from .runner import NgspiceUnavailable, ngspice_version

#: set to "1" to turn a missing ngspice into a test failure instead of a skip
REQUIRE_ENV = "PELCS_REQUIRE_NGSPICE"


class NgspiceMissingWarning(UserWarning):
    """ngspice-based checks were skipped because ngspice cannot be loaded."""


def unavailable_reason() -> str | None:
    """None if ngspice can be used, else why not (with an install hint)."""
    try:
        ngspice_version()
    except NgspiceUnavailable as exc:
        return str(exc)
    return None


def available() -> bool:
    """True if PySpice can load libngspice and initialise it."""
    return unavailable_reason() is None


def require_ngspice() -> str:
    """The ngspice version, or skip (fail under ``PELCS_REQUIRE_NGSPICE=1``) the caller's test.

    The skip is loud on purpose: a warning (shown in pytest's summary), a line on stderr
    and the reason in ``-ra``'s skip list, so that nobody mistakes skipped cross-checks
    for passed ones.
    """
    import pytest

    reason = unavailable_reason()
    if reason is None:
        return ngspice_version()
    message = f"NGSPICE MISSING - ngspice cross-checks not run: {reason}"
    if os.environ.get(REQUIRE_ENV) == "1":
        pytest.fail(f"{message} ({REQUIRE_ENV}=1 requires ngspice)", pytrace=False)
    warnings.warn(message, NgspiceMissingWarning, stacklevel=2)
    print(message, file=sys.stderr)
    pytest.skip(message)
    raise AssertionError("unreachable")  # pytest.skip raises
