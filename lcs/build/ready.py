"""The compiled kernels loaded before a run, so that its time per step is its own."""

from __future__ import annotations

__all__ = ["load_kernels"]


def load_kernels() -> float:
    """Load the stepper's compiled (numba) kernels; returns the time it took, s.

    The first run in a process pays for loading the kernels from numba's cache (a few tenths
    of a second, more on the very first use after installation, when they are compiled).
    Calling this first lets a caller report the time per step of the run itself. See
    :func:`lcs.build.warmup.warm_up` (every kernel specialisation).
    """
    import time

    from .kernels import using_aot

    t0 = time.perf_counter()
    if using_aot():
        # The ahead-of-time module holds every kernel a run calls from Python: nothing to
        # compile or load from numba's cache.
        return time.perf_counter() - t0
    from .warmup import warm_up as _warm_up

    return _warm_up()
