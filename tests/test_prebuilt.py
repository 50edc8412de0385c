"""The kernels' module prebuilt for x86-64-v3 and shipped in the package
(:data:`lcs.build.kernels.PREBUILT`): current for the kernel sources, loaded on a fresh
checkout with nothing compiled, the same numbers as numba's kernels, and never loaded by a
processor that lacks one of its extensions.

When the first test fails, a kernel source changed without the module being rebuilt:
``scripts/prebuild`` (every interpreter it ships for), then commit ``lcs/build/prebuilt``.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from lcs.build import kernels

ROOT = Path(__file__).resolve().parents[1]
BUCK = ROOT / "converters" / "netlists" / "buck.cir"
VM_BUCK = ROOT / "converters" / "netlists" / "vm_buck.cir"

pytestmark = pytest.mark.skipif(platform.machine() != "x86_64",
                                reason="the module is prebuilt for x86-64")


def test_the_prebuilt_module_is_current():
    built = sorted(p.name for p in kernels.PREBUILT.glob("aot-*"))
    assert built == [kernels.prebuilt_dir().name], (
        f"lcs/build/prebuilt holds {built}, not the module of the current kernel sources "
        f"{kernels.prebuilt_dir().name}: run scripts/prebuild")
    modules = sorted(p.name for p in kernels.prebuilt_dir().glob(kernels.AOT_MODULE + ".*.so"))
    # one module per interpreter it ships for, all from these sources
    tags = sorted("-".join(name.split(".")[1].split("-")[:2]) for name in modules)
    assert tags == sorted(kernels.PREBUILT_PYTHONS), (
        f"{kernels.prebuilt_dir()} holds modules for {tags}, not for every interpreter of "
        f"{kernels.PREBUILT_PYTHONS}: run scripts/prebuild")
    assert (kernels.prebuilt_dir() / (kernels.AOT_MODULE + ".types.json")).is_file()
    if kernels.aot_filename() not in modules:
        pytest.skip(f"prebuilt for {modules}, not this Python ({kernels.aot_filename()})")


def test_a_processor_without_its_extensions_does_not_load_it(monkeypatch):
    line = kernels._cpu_flags_line()
    if line is None or kernels.prebuilt_path() is None:
        pytest.skip("the prebuilt module does not serve this machine")
    monkeypatch.setattr(kernels, "_cpu_flags_line", lambda: line.replace(" avx2", ""))
    assert kernels.prebuilt_path() is None
    monkeypatch.setattr(kernels, "_cpu_flags_line", lambda: None)
    assert kernels.prebuilt_path() is None
    monkeypatch.undo()
    monkeypatch.setenv("PELCS_PREBUILT", "0")
    assert kernels.prebuilt_path() is None


_RUN = """
import json, sys
import lcs.build.kernels as k, pelcs
out = {}
for src in sys.argv[1:]:
    r = pelcs.simulate(src, tstop="1m")
    out[src] = {"y": r.y.tolist(), "t": r.t.tolist(), "steps": r.stats.steps}
print("RUN", json.dumps({"module": str(k.module_path()), "numba": "numba" in sys.modules,
                         "out": out}))
"""


def _run(tmp_path: Path, **env) -> dict:
    full = {k: v for k, v in os.environ.items() if k != "PELCS_AOT"}
    full.update(PELCS_CACHE_DIR=str(tmp_path / "pelcs"), NUMBA_CACHE_DIR=str(tmp_path / "numba"),
                **env)
    p = subprocess.run([sys.executable, "-c", _RUN, str(BUCK), str(VM_BUCK)], cwd=ROOT,
                       env=full, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    line = next(ln for ln in p.stdout.splitlines() if ln.startswith("RUN "))
    return json.loads(line[4:])


def _assert_same_runs(got: dict, want: dict) -> None:
    for src, res in got["out"].items():
        assert res["steps"] == want["out"][src]["steps"], src
        assert np.array_equal(np.array(res["t"]), np.array(want["out"][src]["t"])), src
        assert np.array_equal(np.array(res["y"]), np.array(want["out"][src]["y"])), src


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_a_fresh_checkout_runs_it_with_the_kernels_numbers(tmp_path):
    if kernels.prebuilt_path() is None:
        pytest.skip("no prebuilt module for these sources on this machine")
    # Empty caches: no module built here, nothing compiled by numba.
    got = _run(tmp_path)
    assert got["module"] == str(kernels.prebuilt_path())
    assert got["numba"] is False
    assert not list((tmp_path / "numba").rglob("*.nbi"))
    # The kernels' sources run by CPython (NUMBA_DISABLE_JIT), the module ignored.
    interpreted = _run(tmp_path / "py", PELCS_PREBUILT="0", PELCS_AOT="0", NUMBA_DISABLE_JIT="1")
    assert interpreted["module"] == "None"
    _assert_same_runs(got, interpreted)


@pytest.mark.jit
def test_a_fresh_checkout_runs_it_with_numbas_numbers(tmp_path):
    if kernels.prebuilt_path() is None:
        pytest.skip("no prebuilt module for these sources on this machine")
    got = _run(tmp_path)
    assert got["module"] == str(kernels.prebuilt_path())
    # numba's kernels, compiled for this processor (this process: the suite's cache).
    import pelcs
    from lcs.build.aot import _through_numba

    with _through_numba():
        runs = {src: pelcs.simulate(src, tstop="1m") for src in got["out"]}
    _assert_same_runs(got, {"out": {src: {"steps": r.stats.steps, "t": r.t, "y": r.y}
                                    for src, r in runs.items()}})


def test_compile_says_the_prebuilt_module_serves(tmp_path, monkeypatch, capsys):
    if kernels.prebuilt_path() is None:
        pytest.skip("the prebuilt module does not serve this machine")
    import lcs.build.warmup as warmup
    from lcs.build import kernel_setup
    from pelcs.cli import main

    # (no module built here; the compile and the link stood in for)
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(kernel_setup, "kernels_cached", lambda: True)
    monkeypatch.setattr(warmup, "warm_up", lambda **_: 0.0)
    monkeypatch.setattr(kernel_setup, "compiled_in_process", lambda: 0)
    monkeypatch.setattr(kernel_setup, "build_now", lambda: tmp_path / "built.so")
    assert main(["compile"]) == 0
    err = capsys.readouterr().err
    assert f"the prebuilt kernels serve this machine already ({kernels.prebuilt_path()})" in err
