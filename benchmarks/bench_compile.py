"""What compiling the kernels costs from an empty cache: the CPU time and peak memory of
``scripts/setup``'s compile step (:func:`lcs.build.warmup.warm_up` in a fresh process with
an empty numba cache, ``PELCS_AOT=0``), and where it goes, function by function.

Usage::

    python benchmarks/bench_compile.py            # the whole warm-up, from an empty cache
    python benchmarks/bench_compile.py --aot      # and the ahead-of-time module's link
    python benchmarks/bench_compile.py --parallel # the sparse part in a second process

The per-function table is numba's ``numba:compile`` events, exclusive of the callees compiled
inside them (a kernel's dispatcher compiles its non-inlined callees while typing it); "count"
is how many specialisations of that function were compiled. The figure of record is the CPU
time (user + system) of the whole process, which includes importing numba and running the
warm-up's tiny simulations.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_CHILD = r"""
import json, sys, time
from collections import defaultdict
from numba.core import event

stack = []
excl = defaultdict(float)
count = defaultdict(int)


class Timer(event.Listener):
    def on_start(self, ev):
        stack.append([time.perf_counter(), 0.0])

    def on_end(self, ev):
        t0, inner = stack.pop()
        dt = time.perf_counter() - t0
        name = ev.data["dispatcher"].py_func.__module__ + "." + \
            ev.data["dispatcher"].py_func.__qualname__
        excl[name] += dt - inner
        count[name] += 1
        if stack:
            stack[-1][1] += dt


event.register("numba:compile", Timer())
t0 = time.perf_counter()
from lcs.build.warmup import warm_up
warm_up(parallel="--parallel" in sys.argv)
wall = time.perf_counter() - t0
if "--aot" in sys.argv:
    t1 = time.perf_counter()
    from lcs.build.aot import build
    build(out_dir=sys.argv[-1])
    aot = time.perf_counter() - t1
else:
    aot = None
print(json.dumps({"wall": wall, "aot": aot, "excl": excl, "count": count}))
"""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--aot", action="store_true", help="also link the ahead-of-time module")
    ap.add_argument("--parallel", action="store_true",
                    help="compile the sparse part in a second process, as scripts/setup does")
    ap.add_argument("--top", type=int, default=15, help="functions listed (default 15)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="pelcs-bench-compile-") as tmp:
        env = {**os.environ, "NUMBA_CACHE_DIR": tmp, "PELCS_AOT": "0",
               "PYTHONPATH": str(ROOT)}
        cmd = [sys.executable, "-c", _CHILD] + (["--parallel"] if args.parallel else []) + (
            ["--aot", tmp] if args.aot else [])
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        out = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tmp)
        wall = time.perf_counter() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if out.returncode != 0:
        print(out.stderr, file=sys.stderr)
        return 1
    data = json.loads(out.stdout.strip().splitlines()[-1])
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    print(f"compile from an empty cache: {cpu:.1f} s CPU, {wall:.1f} s wall, "
          f"peak RSS {after.ru_maxrss / 1024:.0f} MB")
    if data["aot"] is not None:
        print(f"  of which the ahead-of-time module's link: {data['aot']:.1f} s wall")
    excl = sorted(data["excl"].items(), key=lambda kv: -kv[1])
    total = sum(v for _, v in excl)
    print(f"numba compile events: {total:.1f} s in {sum(data['count'].values())} "
          f"specialisations of {len(excl)} functions")
    print(f"{'function':55s} {'s':>7s} {'count':>5s}")
    for name, secs in excl[:args.top]:
        print(f"{name:55s} {secs:7.1f} {data['count'][name]:5d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
