"""The mathematics of pelcs: LCS models, LCP solvers, passivity, well-posedness, GDCM,
integrators, controllers and analysis (``docs/architecture.md``). Knows nothing of netlists."""

from __future__ import annotations

import os
from pathlib import Path

# Packages whose numba functions call (and inline) each other's.
_KERNEL_PACKAGES = ("lcp", "stepping")


def _sync_kernel_stamps() -> None:
    """Numba's on-disk cache keys a compiled function on the mtime of its own source file only,
    while a kernel contains the code of the functions it calls from other files: a change to
    one of them would leave stale compiled kernels. Give every kernel source file the newest
    mtime among them, before any of them is imported (a change anywhere then recompiles all)."""
    here = Path(__file__).parent
    try:
        files = [here / "jit.py"]
        files += [f for pkg in _KERNEL_PACKAGES for f in (here / pkg).glob("*.py")]
        stamps = {f: f.stat().st_mtime for f in files}
        newest = max(stamps.values())
        for f, t in stamps.items():
            if t < newest:
                os.utime(f, (newest, newest))
    except (OSError, ValueError):  # read-only install (nothing is edited there anyway)
        pass


_sync_kernel_stamps()
