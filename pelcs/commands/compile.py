"""``pelcs compile``: compile the simulation kernels and link them into their ahead-of-time
module now, instead of on first use.

Where the module prebuilt for x86-64-v3 serves the machine (:data:`lcs.build.kernels.PREBUILT`),
nothing needs compiling. Elsewhere, after a ``pip install`` the first simulation compiles the
kernels (minutes of one core, then cached on disk) and starts the module's build in the
background (:mod:`lcs.build.kernel_setup`).
This command does both in the foreground, says where the module is, and shows why a build
fails (typically: no C compiler; pelcs then runs from numba's cache, about 1.5 s more per
command). ``scripts/setup`` does the same for a checkout.

Exit status: 0 the module is built (or was), 1 the kernels compiled but the module could not be
built.
"""

from __future__ import annotations

import argparse
import sys
import time


def register(subparsers) -> None:
    """Add the ``compile`` subcommand to the CLI's subparsers."""
    p = subparsers.add_parser(
        "compile",
        help="compile the simulation kernels now (otherwise the first simulation does)",
        description="Compile the simulation kernels (numba, cached on disk: a few minutes "
        "once) and link them into the ahead-of-time module that lets every command start in "
        "a fraction of a second (about a minute, needs a C compiler). Where: the installed "
        "package's __pycache__, or $XDG_CACHE_HOME/pelcs (~/.cache/pelcs) when that cannot "
        "be written, or PELCS_CACHE_DIR.",
    )
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from lcs.build import kernel_setup
    from lcs.build.kernels import aot_path, prebuilt_path

    path = aot_path()
    if path.is_file():
        print(f"the kernels are compiled and linked: {path}")
        return 0
    prebuilt = prebuilt_path()
    if prebuilt is not None:
        print(f"pelcs: the prebuilt kernels serve this machine already ({prebuilt}); "
              "compiling them for this processor itself", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    if not kernel_setup.kernels_cached():
        print(kernel_setup.COMPILING_MESSAGE, file=sys.stderr, flush=True)
    from lcs.build.warmup import warm_up

    warm_up(parallel=True)
    what = "compiled" if kernel_setup.compiled_in_process() else "loaded"
    print(f"{what} the kernels in {time.perf_counter() - t0:.3g} s", flush=True)
    if kernel_setup.build_running():
        print("pelcs: waiting for the background build of the module to finish",
              file=sys.stderr, flush=True)
    t1 = time.perf_counter()
    try:
        path = kernel_setup.build_now()
    except Exception as exc:  # the build's own errors (compiler, linker): reported, not raised
        print(f"error: linking the kernels into a module failed: {type(exc).__name__}: "
              f"{exc}\n  hint: it needs a C compiler (Debian: apt-get install gcc); without "
              "it pelcs runs the kernels from numba's cache (about 1.5 s more per command)",
              file=sys.stderr)
        return 1
    print(f"linked them into {path} in {time.perf_counter() - t1:.3g} s")
    return 0
