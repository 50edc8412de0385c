"""Start-up cost: the smallest whole command against ``python -c "import numpy"``.

    .venv/bin/python benchmarks/bench_startup.py [--repeat N] [--importtime] [--other DIR]

The smallest command is ``pelcs simulate rc.cir -o rc.csv``: a pulsed source, two resistors, a
diode and a capacitor, ``.tran 10u 1m`` (about 100 steps), no plot, a CSV file. For that
command nearly all the time is start-up (interpreter, imports, loading the compiled kernels),
so it is what a user waiting on a short run pays. It is compared with the floor that any
numpy program pays, ``python -c "import numpy"``, on the same machine and interpreter.

Each figure is the CPU time (user + system, from ``os.wait4``) of a fresh process, the
median and the best of ``--repeat`` runs, the two kinds of process interleaved so that a
change of the machine's load hits both alike. ``--importtime`` also prints the slowest
top-level imports of one command (``python -X importtime``, cumulative microseconds).
``--other DIR`` also times the command of another checkout (``PYTHONPATH=DIR``, e.g. an
earlier commit unpacked with ``git archive``, its ``lcs/__pycache__/aot-*`` copied), in the
same interleaved loop: on a loaded machine the only fair comparison.

The machine's ``PYTHONDONTWRITEBYTECODE`` is removed for every process, as on a user's
machine: Python then reads the ``.pyc`` files instead of compiling the modules on each start.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# The smallest command's netlist (tests/test_aot.py checks what that command imports).
DECK = (ROOT / "tests" / "netlists" / "sim" / "smallest_rc.cir").read_text()

# What the installed ``pelcs`` script runs.
_ENTRY = "import sys; from pelcs.cli import main; sys.exit(main())"


def _cpu(cmd: list[str], env: dict, cwd: Path) -> float:
    """CPU time (user + system, s) of one run of ``cmd`` in a fresh process."""
    # (in ``cwd``, not this checkout: ``python -c`` puts the working directory first on
    # sys.path, ahead of PYTHONPATH)
    proc = subprocess.Popen(cmd, env=env, cwd=cwd, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    err = proc.stderr.read()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    proc.stderr.close()
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {err.decode()[-500:]}")
    return usage.ru_utime + usage.ru_stime


def _importtime(cmd: list[str], env: dict, cwd: Path, top: int = 15
                ) -> list[tuple[int, str]]:
    """The ``top`` slowest imports of one run (cumulative microseconds, module)."""
    p = subprocess.run([cmd[0], "-X", "importtime", *cmd[1:]], env=env, cwd=cwd,
                       capture_output=True, text=True, check=True)
    rows = []
    for line in p.stderr.splitlines():
        if not line.startswith("import time:") or "cumulative" in line:
            continue
        _, cumulative, name = line[len("import time:"):].split("|")
        if not name[1:].startswith(" "):  # top level: imported by the command itself
            rows.append((int(cumulative), name.strip()))
    return sorted(rows, reverse=True)[:top]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--importtime", action="store_true",
                    help="also list the slowest top-level imports of the command")
    ap.add_argument("--other", type=Path, metavar="DIR",
                    help="also time the command of the checkout in DIR")
    args = ap.parse_args(argv)
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = os.pathsep.join(
        [str(ROOT), *filter(None, [env.get("PYTHONPATH")])])
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        deck = tmp / "rc.cir"
        deck.write_text(DECK)
        numpy_cmd = [sys.executable, "-c", "import numpy"]
        pelcs_cmd = [sys.executable, "-c", _ENTRY, "simulate", str(deck), "-o",
                     str(Path(d) / "rc.csv")]
        env_other = None
        if args.other is not None:
            env_other = {**env, "PYTHONPATH": os.pathsep.join(
                [str(args.other.resolve()), *filter(None, [os.environ.get("PYTHONPATH")])])}
        # One run of each first: the .pyc files and the grammar's caches are written.
        _cpu(numpy_cmd, env, tmp)
        _cpu(pelcs_cmd, env, tmp)
        if env_other is not None:
            _cpu(pelcs_cmd, env_other, tmp)
        base, cmd, other = [], [], []
        for _ in range(args.repeat):
            base.append(_cpu(numpy_cmd, env, tmp))
            cmd.append(_cpu(pelcs_cmd, env, tmp))
            if env_other is not None:
                other.append(_cpu(pelcs_cmd, env_other, tmp))
        b_med, b_min = statistics.median(base), min(base)
        print(f"CPU s (user + sys), {args.repeat} runs:   median   best   ratio to numpy "
              "(median, best)")
        print(f"python -c 'import numpy'             {b_med:7.3f} {b_min:7.3f}")
        rows = [("pelcs simulate (100 steps, CSV)", cmd)]
        if other:
            rows.append((f"  the same, {args.other.name}", other))
        for label, times in rows:
            med, best = statistics.median(times), min(times)
            print(f"{label:36s} {med:7.3f} {best:7.3f}   {med / b_med:5.2f} {best / b_min:5.2f}")
        if args.importtime:
            print("slowest top-level imports of the command (cumulative ms):")
            for us, name in _importtime(pelcs_cmd, env, tmp):
                print(f"  {us / 1000:7.1f}  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
