"""The kernels' first use after an installation: whether they are compiled, and building their
ahead-of-time module in the background.

``scripts/setup`` compiles the kernels and builds the ahead-of-time module
(:mod:`lcs.build.aot`) of a checkout once; a wheel built by ``pip install .`` carries the
module (``setup.py``). An editable install, or a wheel whose module does not match this
machine, has neither: the first simulation compiles the kernels (minutes of one core, cached
by numba on disk), and every later command would load them from
numba's cache (about 1.5 s more per command than the ahead-of-time module). So ``pelcs
simulate`` asks :func:`kernels_cached` before it loads them and says when it is about to
compile (the other commands say so at numba's first compile event, :func:`announce_compiles`);
after a command numba served, :func:`after_run` calls :func:`start_background_build`: a
detached, lowest-priority ``python -m lcs.build.kernel_setup`` that builds the module into the cache
(:func:`lcs.build.kernels.aot_path`: the installed package's ``__pycache__``, or the per-user cache
when that cannot be written). A lock file keeps it to one build at a time; a build that failed
(no C compiler) leaves a note beside the module's path and is not retried in the background
(``pelcs compile`` retries it and shows why it fails). ``PELCS_AOT_BUILD=0`` turns the
background build off.

:func:`kernels_cached` and :func:`announce_compiles` import numba only when there is no
ahead-of-time module (when the run imports it anyway); the rest imports nothing heavy.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from pathlib import Path

from . import kernels

__all__ = ["COMPILING_MESSAGE", "after_run", "announce_compiles", "build_failure", "build_now",
           "build_running", "build_wanted", "compiled_in_process", "kernels_cached",
           "start_background_build"]

#: What a command prints on stderr before the kernels compile.
COMPILING_MESSAGE = ("pelcs: compiling the simulation kernels once (up to a few minutes on "
                     "first use; later runs load them)")

_LOCK = "build.lock"
_LOG = "build.log"
_FAILED = "build.failed"


def kernels_cached() -> bool:
    """Whether a run finds every kernel Python calls compiled: in the ahead-of-time module, or
    in numba's on-disk cache for this machine, this numba and the current kernel sources
    (false for any exported kernel whose cache index lacks its specialisation).
    Reads numba's cache indexes; compiles nothing."""
    if kernels.using_aot():
        return True
    if _none_beside_the_sources():
        return False
    from numba.core.registry import cpu_target

    codegen = cpu_target.target_context.codegen()
    for _, dispatcher in kernels.exported_dispatchers():
        cache = getattr(dispatcher, "_cache", None)
        if cache is None or not hasattr(cache, "_cache_file"):
            return False
        # (the key of an entry: signature, then machine and numba's magic, then the
        # function's bytecode hash: all but the signature must be this process's)
        want = cache._index_key(None, codegen)[1:]
        index = cache._cache_file._load_index()
        if not any(tuple(key[1:]) == want for key in index):
            return False
    return True


def _none_beside_the_sources() -> bool:
    """Whether numba caches the kernels beside their sources (no ``NUMBA_CACHE_DIR``, a
    writable package: numba's first choice) and the grid loop has no cache index there: then
    nothing is compiled, told without importing numba (0.5 s sooner on a first run). False
    when that cannot be told so (then :func:`kernels_cached` asks numba)."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return False
    pycache = (Path(kernels.__file__).resolve().parents[1] / "integrators" / "moreau" / "dense"
               / "__pycache__")
    if not kernels._writable(pycache):
        return False
    # (lcs.jit_passes.KernelCacheLocator's directory; numba's index name for run_grid)
    grid = pycache.parent / "grid.py"
    stamped = pycache / f"kernels-grid-{kernels.module_stamp(grid).hex()[:16]}"
    return not any(stamped.glob("grid.run_grid-*.nbi"))


def compiled_in_process() -> int:
    """How many kernel specialisations this process compiled (numba's cache misses) rather
    than loaded; 0 when numba was never imported (the ahead-of-time module served the run)."""
    from .. import jit

    if not jit.materialized():
        return 0
    total = 0
    for k in jit._KERNELS:
        dispatcher = k._dispatcher
        stats = getattr(dispatcher, "stats", None)
        if stats is not None:
            total += sum(stats.cache_misses.values())
    return total


def announce_compiles(write: Callable[[str], object]) -> bool:
    """Call ``write(COMPILING_MESSAGE)`` when this process first starts compiling a kernel
    (numba's ``numba:compile`` event, which a kernel loaded from the cache does not raise);
    not in the workers a process pool forks. Installs nothing, and imports no numba, when the
    ahead-of-time module serves the kernels; returns whether it installed the listener."""
    if kernels.using_aot():
        return False
    _WATCH["write"] = write
    if _WATCH["pid"] is None:  # (one listener per process, however many commands it runs)
        from numba.core import event

        class _FirstCompile(event.Listener):
            def on_start(self, ev):
                if not _WATCH["said"] and os.getpid() == _WATCH["pid"]:
                    _WATCH["said"] = True
                    _WATCH["write"](COMPILING_MESSAGE)

            def on_end(self, ev):
                pass

        _WATCH["pid"] = os.getpid()
        event.register("numba:compile", _FirstCompile())
    return True


_WATCH: dict = {"pid": None, "said": False, "write": None}


def after_run() -> str | None:
    """After a command that ran kernels: start the module's background build when numba
    served them (:func:`start_background_build`); the line to print about it, or None (the
    module serves the kernels, no build is wanted, the kernels are not all compiled yet: an
    interrupted first run, whose successor compiles the rest first)."""
    from .. import jit

    if not jit.materialized() or kernels.using_aot() or not build_wanted():
        return None
    if not kernels_cached():
        return None
    log = start_background_build()
    if log is not None:
        return ("pelcs: linking the compiled kernels into a module in the background (low "
                "priority, a minute or two; later commands then start in a fraction of a "
                f"second; log: {log})")
    if build_failure() is not None:
        return ("pelcs: the compiled kernels could not be linked into a module (`pelcs "
                "compile` says why): each command loads them from numba's cache, about 1.5 s "
                "more (PELCS_AOT_BUILD=0 silences this)")
    return None


def _paths() -> tuple[Path, Path, Path]:
    directory = kernels.aot_path().parent
    return directory / _LOCK, directory / _LOG, directory / _FAILED


def build_running() -> bool:
    """Whether a build of the current module holds its lock (another process is building)."""
    lock, _, _ = _paths()
    if not lock.is_file():
        return False
    import fcntl

    try:
        with open(lock, "a") as fh:
            try:
                fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                return True
            fcntl.flock(fh, fcntl.LOCK_UN)
    except OSError:
        return False
    return False


def build_failure() -> str | None:
    """The end of the log of a failed background build of the current module, or None."""
    _, _, failed = _paths()
    try:
        return failed.read_text(errors="replace")
    except OSError:
        return None


def build_wanted() -> bool:
    """Whether the module is to be built in the background (not ``PELCS_AOT=0``, which
    forces numba, nor ``PELCS_AOT_BUILD=0``)."""
    return (os.environ.get("PELCS_AOT", "1") != "0"
            and os.environ.get("PELCS_AOT_BUILD", "1") != "0")


def start_background_build() -> Path | None:
    """Start building the ahead-of-time module in a detached process at the lowest priority,
    unless it exists, is not wanted (``PELCS_AOT=0``, ``PELCS_AOT_BUILD=0``), is being built,
    or failed before; returns the build's log file when a build was started."""
    if not build_wanted():
        return None
    if kernels.aot_path().is_file() or build_running() or build_failure() is not None:
        return None
    lock, log, _ = _paths()
    try:
        lock.parent.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ)
        # The same pelcs as this process, wherever it was imported from.
        root = str(Path(kernels.__file__).resolve().parents[2])
        env["PYTHONPATH"] = os.pathsep.join(
            [root] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
        import subprocess  # (2 ms of imports, only for a run that starts a build)

        with open(log, "w") as out:
            subprocess.Popen([sys.executable, "-m", "lcs.build.kernel_setup"], env=env,
                             stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                             start_new_session=True, close_fds=True)
    except OSError:
        return None
    return log


def build_now() -> Path:
    """Build the ahead-of-time module in this process (after a background build of it, if one
    is running: the lock is waited for); returns its path. Raises what the build raises; a
    success clears the note of an earlier failure."""
    import fcntl

    lock, _, failed = _paths()
    lock.parent.mkdir(parents=True, exist_ok=True)
    with open(lock, "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        path = kernels.aot_path()
        if not path.is_file():
            from . import aot

            path = aot.build()
        failed.unlink(missing_ok=True)
    return path


def _build_main() -> int:
    """The background build: lowest priority, one at a time, a note when it fails."""
    import fcntl
    import traceback

    try:
        os.nice(19)
    except OSError:
        pass
    lock, log, failed = _paths()
    lock.parent.mkdir(parents=True, exist_ok=True)
    with open(lock, "a") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            return 0  # another process is building it
        if kernels.aot_path().is_file():
            return 0
        from . import aot

        try:
            print(aot.build(verbose=True), flush=True)
        except BaseException:  # noqa: B036  (any failure: note it, never retry in a loop)
            text = traceback.format_exc()
            print(text, file=sys.stderr, flush=True)
            failed.write_text(text[-4000:] + f"\n(full log: {log})\n")
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(_build_main())
