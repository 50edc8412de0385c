"""The build of a wheel (``pip install .``, ``pip wheel .``, an sdist's install): the package as
pyproject.toml declares it, plus the kernels' ahead-of-time extension module compiled once
here, so that the first ``pelcs`` command after the install does not compile for minutes.

The module is built for this machine's processor and numba (its directory says which,
:func:`lcs.build.kernels.aot_path`); where it does not match at run time, or the build fails here
(no C compiler), pelcs compiles on first use as without it. Where the package's prebuilt module
(:data:`lcs.build.kernels.PREBUILT`) matches the sources and runs on this processor, nothing is
compiled: the wheel carries that one. ``PELCS_WHEEL_KERNELS=0`` builds the wheel without a
module of its own (seconds instead of about three minutes of one core). An editable
install (``pip install -e``) compiles nothing here: ``scripts/setup`` or the first use does.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py
from setuptools.dist import Distribution

# What the build runs in the built packages: the module built into their lcs/__pycache__.
_BUILD = "import lcs.build.kernel_setup as k; print(k.build_now())"
# Whether their prebuilt module serves this machine (exit status 0).
_PREBUILT = "import sys, lcs.build.kernels as k; sys.exit(0 if k.prebuilt_path() else 1)"


def _env(lib: Path) -> dict:
    """The build's environment: none of the user's pelcs or numba settings, the built
    packages first on the path (pip's isolated build environment reaches its packages
    through PYTHONPATH)."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PELCS_", "NUMBA_"))}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, (str(lib), env.get("PYTHONPATH"))))
    return env


def prebuilt_serves(lib: Path) -> bool:
    """Whether the prebuilt module in the packages in ``lib`` matches their sources and runs
    on this processor."""
    return subprocess.run([sys.executable, "-c", _PREBUILT], cwd=lib, env=_env(lib),
                          capture_output=True).returncode == 0


def build_kernels(lib: Path, script: str = _BUILD) -> bool:
    """Build the ahead-of-time module into the packages in ``lib`` (running ``script`` there
    with them first on the path); numba's JIT cache of the build is removed, being of no use
    installed (it is keyed by the sources' paths and times). Returns whether it was built; a
    failure is said on stderr and leaves the packages as they were."""
    env = _env(lib)
    # (the module into the built packages' cache, whatever the user's cache holds)
    env["PELCS_CACHE_DIR"] = str(lib / "lcs" / "__pycache__")
    env["PELCS_AOT_BUILD"] = "0"
    print("pelcs: compiling the simulation kernels into the wheel (about 3 minutes of one "
          "core; PELCS_WHEEL_KERNELS=0 skips it)", file=sys.stderr, flush=True)
    proc = subprocess.run([sys.executable, "-c", script], cwd=lib, env=env,
                          capture_output=True, text=True)
    for cache in lib.glob("lcs/**/__pycache__/kernels-*"):
        shutil.rmtree(cache, ignore_errors=True)
    for path in (*lib.glob("lcs/**/__pycache__/*.nb[ic]"),
                 *lib.glob("lcs/__pycache__/aot-*/build.*")):
        path.unlink()
    if proc.returncode != 0:
        print("pelcs: WARNING: the kernels' module could not be built (the first run will "
              "compile them):\n" + proc.stderr[-2000:], file=sys.stderr)
    return proc.returncode == 0


class BuildWithKernels(build_py):
    """``build_py``, then the ahead-of-time module built into the wheel's tree."""

    def run(self) -> None:
        super().run()
        if self.editable_mode or os.environ.get("PELCS_WHEEL_KERNELS", "1") == "0":
            return
        lib = Path(self.build_lib).resolve()
        if prebuilt_serves(lib):
            print("pelcs: the wheel carries the prebuilt kernels' module (nothing to compile)",
                  file=sys.stderr, flush=True)
            return
        build_kernels(lib)


class PlatformDistribution(Distribution):
    """A wheel for this platform: it may carry the compiled module."""

    def has_ext_modules(self) -> bool:
        return True


if __name__ == "__main__":
    setup(cmdclass={"build_py": BuildWithKernels}, distclass=PlatformDistribution)
