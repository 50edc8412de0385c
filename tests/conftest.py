"""Shared pytest fixtures."""

import os

import pytest

# No test command starts the ahead-of-time module's background build (a detached process of a
# minute or more, into a temporary PELCS_CACHE_DIR that a test may give a command); the tests
# of that build turn it back on for themselves.
os.environ["PELCS_AOT_BUILD"] = "0"


@pytest.fixture(scope="session")
def ngspice() -> str:
    """The ngspice version; skips the test loudly when ngspice/libngspice is missing, and
    fails it instead under ``PELCS_REQUIRE_NGSPICE=1`` (see ``ngspice_checks.availability``).
    """
    from ngspice_checks import require_ngspice

    return require_ngspice()


def as_from_a_terminal() -> None:
    """``preexec_fn`` of a child that a test interrupts: SIGINT as a terminal leaves it. The
    tests may run with SIGINT ignored (started in the background by a non-interactive shell,
    as CI may), and a child inherits that; pelcs leaves an ignored SIGINT ignored."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)
