"""Shared pytest fixtures."""

import contextlib
import os
from pathlib import Path

import pytest

# No test command starts the ahead-of-time module's background build (a detached process of a
# minute or more, into a temporary PELCS_CACHE_DIR that a test may give a command); the tests
# of that build turn it back on for themselves.
os.environ["PELCS_AOT_BUILD"] = "0"


# The modules that compile kernels with numba or build the ahead-of-time module themselves
# (marked ``numba``: ``-m 'not numba'`` leaves them out on a machine without a compiler).
_NUMBA_MODULES = {"test_aot", "test_warmup", "test_install"}
# The modules whose tests run the kernels through numba's dispatchers: one pytest-xdist group,
# so that under ``--dist loadgroup`` (scripts/test) a single worker compiles numba's kernels for
# the tests marked ``jit`` (minutes from an empty cache) while the other runs the rest, and the
# sparse step that test_kkt calls from Python is compiled once (40 s), not by both workers.
_JIT_MODULES = {"test_aot", "test_prebuilt", "test_warmup", "test_kkt"}


def pytest_addoption(parser):
    parser.addoption("--jit", action="store_true",
                     help="also run the tests marked jit, which compile numba's kernels (a few "
                          "minutes of CPU from an empty cache: after a kernel edit, before "
                          "committing the rebuilt prebuilt module)")


# (first: pytest-xdist's own hook reads the xdist_group marks to send a group to one worker)
@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """Markers from what a test uses: ``ngspice`` for every test that takes the ``ngspice``
    fixture (``-m 'not ngspice'`` runs the rest where ngspice is missing), ``numba`` for the
    modules of :data:`_NUMBA_MODULES`, the xdist group ``numba`` for those of
    :data:`_JIT_MODULES`; the tests marked ``jit`` skip without ``--jit``."""
    skip_jit = pytest.mark.skip(reason="compiles numba's kernels: run with --jit")
    for item in items:
        if "ngspice" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.ngspice)
        module = item.module.__name__.rsplit(".", 1)[-1]
        if module in _NUMBA_MODULES:
            item.add_marker(pytest.mark.numba)
        jit = item.get_closest_marker("jit") is not None
        if module in _JIT_MODULES or jit:
            item.add_marker(pytest.mark.xdist_group("numba"))
        if jit and not config.getoption("--jit"):
            item.add_marker(skip_jit)


# The CLI's cache of generated code in the checkout (pelcs.code_cache): the suite's
# in-process commands add what their many netlists compiled, which every later start of the
# checkout's `pelcs` would read (the smallest command's file grew from 590 to 907 kB). Kept as
# the session found it.
_CODE_CACHES = Path(__file__).resolve().parents[1] / "pelcs" / "__pycache__"


def pytest_sessionstart(session):
    if not hasattr(session.config, "workerinput"):  # (the controller, or a run without xdist)
        session.config.pelcs_code_caches = {
            path: path.read_bytes() for path in _CODE_CACHES.glob("code-cache.*")}


def pytest_sessionfinish(session):
    found = getattr(session.config, "pelcs_code_caches", None)
    if found is None or os.environ.get("PELCS_CACHE_DIR"):
        return
    for path in _CODE_CACHES.glob("code-cache.*"):
        if path not in found:
            path.unlink(missing_ok=True)
    for path, data in found.items():
        with contextlib.suppress(OSError):
            path.write_bytes(data)


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
