"""Shared pytest fixtures."""

import pytest


@pytest.fixture(scope="session")
def ngspice() -> str:
    """The ngspice version; skips the test loudly when ngspice/libngspice is missing, and
    fails it instead under ``PELCS_REQUIRE_NGSPICE=1`` (see ``ngspice_checks.availability``).
    """
    from ngspice_checks import require_ngspice

    return require_ngspice()
