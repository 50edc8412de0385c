"""What a user of ``pip install`` gets: the first and the second ``pelcs simulate`` after
installing the checkout into a fresh virtual environment.

Creates a virtual environment in a temporary directory, ``pip install``s this checkout into it
(dependencies from the package index; ``--no-build-isolation`` builds with the environment's
own setuptools, upgraded first), then, from an empty directory (the bundled netlist is found
in the installed package), measures:

* the install itself (``setup.py`` puts the prebuilt kernels' module into the wheel where it
  serves the machine, or else compiles one into it: minutes of one core), CPU and wall;
* ``pelcs --version``;
* the first ``pelcs simulate converters/netlists/buck.cir --tstop 1m``: it loads the module
  the wheel carries (or, where it could not be built, compiles the kernels from an empty
  cache, minutes of one core); CPU is user + system of the command (a background build it
  starts is detached, not counted), with when its first line on stderr came;
* the wait for the background build of the ahead-of-time module (wall);
* the second ``pelcs simulate`` (the module loaded) and ``python -c "import numpy"`` for
  scale.

Run: ``python benchmarks/bench_install.py [--no-build-isolation] [--keep]``. It takes
minutes (the compile) and needs the package index.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMAND = ["simulate", "converters/netlists/buck.cir", "--tstop", "1m"]


def _env() -> dict:
    # Nothing of the caller's pelcs or numba set-up: the fresh environment alone.
    return {k: v for k, v in os.environ.items()
            if k != "PYTHONPATH" and not k.startswith(("PELCS_", "NUMBA_"))}


def _children_cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def timed(argv: list[str], cwd: Path) -> dict:
    """Run ``argv``: CPU (user + sys) and wall seconds, output, and the second of each
    stderr line."""
    cpu0, t0 = _children_cpu(), time.perf_counter()
    p = subprocess.Popen(argv, cwd=cwd, env=_env(), stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    lines: list[tuple[float, str]] = []

    def read_err():
        for line in p.stderr:
            lines.append((time.perf_counter() - t0, line.rstrip("\n")))

    reader = threading.Thread(target=read_err)
    reader.start()
    out = p.stdout.read()
    p.wait()
    reader.join()
    return {"rc": p.returncode, "cpu": _children_cpu() - cpu0,
            "wall": time.perf_counter() - t0, "out": out, "err": lines}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--no-build-isolation", action="store_true",
                    help="build with the environment's setuptools (upgraded first)")
    ap.add_argument("--keep", action="store_true", help="keep the temporary directory")
    args = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="pelcs-install-"))
    venv, work = tmp / "venv", tmp / "work"
    work.mkdir()
    py, pelcs = venv / "bin" / "python", venv / "bin" / "pelcs"
    try:
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, env=_env())
        pip = [str(py), "-m", "pip", "install", "-q"]
        if args.no_build_isolation:
            subprocess.run(pip + ["--upgrade", "pip", "setuptools>=77", "wheel"], check=True,
                           env=_env())
            pip.append("--no-build-isolation")
        cpu0, t1 = _children_cpu(), time.perf_counter()
        subprocess.run(pip + [str(ROOT)], check=True, env=_env(), cwd=tmp)
        print(f"pip install: {time.perf_counter() - t1:.0f} s wall, "
              f"{_children_cpu() - cpu0:.0f} s CPU (the build of the wheel, the kernels' "
              f"module compiled into it, the dependencies); with the venv "
              f"{time.perf_counter() - t0:.0f} s wall")
        module = subprocess.run([str(py), "-c", "import lcs.build.kernels as k; "
                                 "print(k.module_path())"], env=_env(), cwd=work,
                                capture_output=True, text=True)
        print(f"the kernels' module the installed pelcs loads (built into the wheel, or "
              f"prebuilt): {module.stdout.strip()}")
        version = timed([str(pelcs), "--version"], work)
        print(f"pelcs --version: {version['out'].strip()!r} (rc {version['rc']}, "
              f"{version['cpu']:.2f} s CPU)")
        numpy = timed([str(py), "-c", "import numpy"], work)
        print(f"python -c 'import numpy': {numpy['cpu']:.2f} s CPU, {numpy['wall']:.2f} s")
        runs = []
        for label in ("first", "second"):
            if label == "second":
                t1 = time.perf_counter()
                code = ("import time, lcs.build.kernels as k, lcs.build.kernel_setup as s\n"
                        "t0 = time.time()\n"
                        "while (not k.aot_path().is_file() and s.build_failure() is None\n"
                        "       and (s.build_running() or time.time() < t0 + 5)):\n"
                        "    time.sleep(1)\n"
                        "print(k.aot_path(), k.aot_path().is_file(), s.build_failure() or '')")
                waited = subprocess.run([str(py), "-c", code], env=_env(), cwd=work,
                                        capture_output=True, text=True, timeout=1800)
                print(f"background build of the ahead-of-time module: done "
                      f"{time.perf_counter() - t1:.0f} s after the first run ended: "
                      f"{waited.stdout.strip()}")
            run = timed([str(pelcs), *COMMAND], work)
            runs.append(run)
            first_err = f"{run['err'][0][0]:.2f} s" if run["err"] else "never"
            print(f"{label} pelcs {' '.join(COMMAND)}: rc {run['rc']}, {run['cpu']:.2f} s "
                  f"CPU, {run['wall']:.2f} s wall; first stderr line after {first_err}")
            for t, line in run["err"]:
                print(f"    stderr {t:7.2f} s: {line}")
            for line in run["out"].splitlines()[:2]:
                print(f"    stdout: {line}")
    finally:
        if args.keep:
            print(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
