"""After the set-up's warm-up, the README's commands compile no kernel.

The processes run with ``PELCS_AOT=0``: the ahead-of-time module (``tests/test_aot.py``)
would serve the commands without numba. Not a timed test: numba's own counters say whether
a dispatcher found each signature it was called with in its on-disk cache
(``stats.cache_hits``) or had to compile it (``stats.cache_misses``). A fresh process runs
:func:`lcs.build.warmup.warm_up` (which compiles only when the cache is cold, as right
after a checkout); another fresh process then runs the README's commands (shortened) and
reports every kernel that missed.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

# fresh processes that load every kernel numba compiled (minutes from an empty cache): with
# --jit, not in the fast subset
pytestmark = [pytest.mark.slow, pytest.mark.jit]

ROOT = Path(__file__).resolve().parents[1]

# The README's commands, shortened where a full run would be slow (same code paths).
COMMANDS = [
    ["simulate", "converters/netlists/boost.cir", "--probe", "v(out)", "--probe", "i(L1)",
     "-o", "{out}/boost.csv", "--plot", "{out}/boost.png"],
    ["simulate", "converters/netlists/buck.cir", "--tstop", "2m", "--probe", "v(out),i(L1)"],
    ["info", "converters/netlists/boost.cir", "--param", "duty=0.3"],
    ["lcs", "converters/netlists/boost.cir"],
    ["orbit", "converters/netlists/vm_buck.cir", "--period", "400u", "--param", "vin=20"],
    ["continue", "converters/netlists/vm_buck.cir", "--period", "400u", "--param",
     "vin=20:20.5"],
    ["bifurcation", "converters/netlists/vm_buck.cir", "--period", "400u", "--param",
     "vin=20:21:2", "--transient", "3", "--record", "2", "--probe", "v(out)", "--workers", "1",
     "--no-progress"],
    ["basins", "converters/netlists/vm_buck.cir", "--period", "400u", "--param", "vin=30",
     "--grid", "v(C1)=8:16:3,i(L1)=0:2.5:3", "--workers", "1"],
    ["simulate", "converters/netlists/vm_buck.cir", "--tstop", "2m"],
    ["simulate", "converters/netlists/boost_smc.cir", "--tstop", "0.2m"],
]

_RUNNER = """
import atexit, json, sys, contextlib, io

def report():
    import lcs.jit as jit
    misses, hits = {}, 0
    for k in jit._KERNELS:
        d = k._dispatcher
        if d is None or d._cache is None:
            continue
        hits += sum(d.stats.cache_hits.values())
        n = sum(d.stats.cache_misses.values())
        if n:
            misses[f"{k.py_func.__module__}.{k.__name__}"] = n
    sys.__stdout__.write("MISSES " + json.dumps(misses) + "\\n")
    sys.__stdout__.write(f"HITS {hits}\\n")

atexit.register(report)
from pelcs.cli import main
for args in json.loads(sys.argv[1]):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            main(args)
        except SystemExit:
            pass
"""


def test_readme_commands_compile_nothing_after_warm_up(tmp_path):
    env = {**os.environ, "PELCS_AOT": "0"}
    warm = subprocess.run([sys.executable, "-c",
                           "from lcs.build.warmup import warm_up; warm_up()"],
                          cwd=ROOT, capture_output=True, text=True, timeout=900, env=env)
    assert warm.returncode == 0, warm.stderr
    cmds = [[a.replace("{out}", str(tmp_path)) for a in c] for c in COMMANDS]
    run = subprocess.run([sys.executable, "-c", _RUNNER, json.dumps(cmds)], cwd=ROOT,
                         capture_output=True, text=True, timeout=900, env=env)
    assert run.returncode == 0, run.stderr[-3000:]
    line = [ln for ln in run.stdout.splitlines() if ln.startswith("MISSES ")]
    assert line, run.stdout[-2000:] + run.stderr[-2000:]
    misses = json.loads(line[-1][len("MISSES "):])
    assert misses == {}, f"kernels compiled after warm_up: {misses}"
    hits = [ln for ln in run.stdout.splitlines() if ln.startswith("HITS ")]
    assert int(hits[-1].split()[1]) >= 5  # numba really served the kernels from its cache
    # The commands ran for real (the first one wrote its files).
    assert (tmp_path / "boost.csv").stat().st_size > 1000
    assert (tmp_path / "boost.png").exists()


_SPECIALISATIONS = """
import json
from lcs import jit
from lcs.build.warmup import warm_up
warm_up()
print(json.dumps({f"{k.py_func.__module__}.{k.__name__}": len(k._dispatcher.signatures)
                  for k in jit._KERNELS if k._dispatcher is not None}))
"""


def test_every_kernel_has_one_specialisation():
    # Constants at call sites must not multiply a kernel's specialisations (lcs.jit: the
    # arguments from compiled code are typed non-literal), nor flags passed from Python.
    r = subprocess.run([sys.executable, "-c", _SPECIALISATIONS], capture_output=True,
                       text=True, timeout=600, cwd=ROOT,
                       env={**os.environ, "PYTHONPATH": str(ROOT), "PELCS_AOT": "0"})
    assert r.returncode == 0, r.stderr
    counts = json.loads(r.stdout.strip().splitlines()[-1])
    assert counts["lcs.integrators.moreau.dense.grid.run_grid"] == 1
    assert counts and all(n <= 1 for n in counts.values()), {
        k: n for k, n in counts.items() if n > 1}
