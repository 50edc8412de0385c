"""The ahead-of-time kernel module: built by ``scripts/setup``, it runs
the same compiled code as numba's dispatchers, and a run served by it never imports numba.

Not timed here (``benchmarks/bench_command.py`` times whole commands): these tests check that
the module is there, that results are bit-for-bit those of the kernels' Python run by CPython
(and, with ``--jit``, of numba's compiled kernels) on every kind of run (plain PWM loop,
comparators, Filippov sliding, many pairs with factorisation updates, Lemke fallbacks), and
what a command imports.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from converters.scaling import cockcroft_walton, interleaved_buck, mmc_arm
from lcs.build import kernels

ROOT = Path(__file__).resolve().parents[1]
NETLISTS = ROOT / "converters" / "netlists"

# (label, netlist text or file, stop time): one of each kind of kernel path.
CASES = [
    ("boost", str(NETLISTS / "boost.cir"), "0.5m"),        # source-driven PWM, plain loop
    ("vm_buck", str(NETLISTS / "vm_buck.cir"), "1m"),      # comparator, located switchings
    ("boost_smc", str(NETLISTS / "boost_smc.cir"), "0.2m"),  # implicit sliding mode
    ("prc", str(NETLISTS / "prc.cir"), "0.2m"),            # 4-diode bridge
    ("bridge", str(NETLISTS / "bridge_rectifier.cir"), "5m"),  # SIN source
    ("cw12", cockcroft_walton(12), "1m"),                  # 24 pairs: warm starts, updates
    ("ib4", interleaved_buck(4), "0.2m"),                  # 4 switches, 4 diodes
    ("mmc4", mmc_arm(4), "2m"),                            # 8 switches, 8 diodes
]

_RUN = """
import json, sys, warnings
import numpy as np
warnings.simplefilter("ignore")
import pelcs
out = {}
for label, src, tstop in json.loads(sys.argv[1]):
    r = pelcs.simulate(src, tstop=tstop, check=False)
    out[label] = dict(t=r.t.tolist(), y=r.y.tolist(), steps=r.stats.steps,
                      lemke=r.stats.fallbacks, error=None if r.error is None else r.error.kind)
import lcs.jit
print("NUMBA", "numba" in sys.modules, lcs.jit.materialized())
print("RESULT " + json.dumps(out))
"""


def _run(**env: str) -> tuple[dict, str]:
    p = subprocess.run([sys.executable, "-c", _RUN, json.dumps(CASES)], cwd=ROOT,
                       env={**os.environ, **env}, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr[-3000:]
    line = next(ln for ln in p.stdout.splitlines() if ln.startswith("RESULT "))
    numba = next(ln for ln in p.stdout.splitlines() if ln.startswith("NUMBA "))
    return json.loads(line[len("RESULT "):]), numba


@pytest.fixture(scope="module")
def aot_built():
    path = kernels.module_path()
    if path is None:
        msg = (f"the ahead-of-time kernel module {kernels.aot_path()} is not built, and none is "
               "prebuilt for these sources: run scripts/setup (python -m lcs.build.aot)")
        if os.environ.get("PELCS_REQUIRE_AOT") == "1":
            pytest.fail(msg)
        pytest.skip(msg)
    return path


def _assert_same_runs(got: dict, want: dict) -> None:
    for label, _, _ in CASES:
        a, b = got[label], want[label]
        assert a["error"] is None and b["error"] is None, label
        assert a["steps"] == b["steps"] > 100, label
        assert np.array_equal(np.array(a["t"]), np.array(b["t"])), label
        assert np.array_equal(np.array(a["y"]), np.array(b["y"])), label
    assert got["cw12"]["steps"] > 1000


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_aot_results_equal_the_interpreted_kernels_bit_for_bit(aot_built):
    # The module's machine code against the same kernel sources run by CPython and numpy
    # (NUMBA_DISABLE_JIT: nothing compiled, seconds): another execution of the same
    # arithmetic, operation for operation.
    aot, aot_numba = _run(PELCS_AOT="1")
    interpreted, _ = _run(PELCS_AOT="0", NUMBA_DISABLE_JIT="1")
    assert aot_numba == "NUMBA False False"  # (the module's process never imported numba)
    _assert_same_runs(aot, interpreted)


@pytest.mark.jit
def test_aot_results_equal_numba_bit_for_bit(aot_built):
    aot, aot_numba = _run(PELCS_AOT="1")
    jit, jit_numba = _run(PELCS_AOT="0")
    # The AOT process ran without numba; the other one used it.
    assert aot_numba == "NUMBA False False"
    assert jit_numba == "NUMBA True True"
    _assert_same_runs(aot, jit)


def _simulate_modules(netlist: Path, out: Path, modules: tuple[str, ...]) -> str:
    """Stdout of ``pelcs simulate NETLIST -o OUT`` in a fresh process with the AOT module,
    ending ``MODS <rc> [the modules of ``modules`` it imported]``."""
    code = ("import sys; from pelcs.cli import main; "
            f"rc = main(['simulate', {str(netlist)!r}, '-o', {str(out)!r}, '--no-progress']); "
            f"print('MODS', rc, sorted(m for m in {modules!r} if m in sys.modules))")
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=300, env={**os.environ, "PELCS_AOT": "1"})
    assert p.returncode == 0, p.stderr[-2000:]
    return p.stdout


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_simulate_command_imports_neither_numba_nor_scipy(aot_built, tmp_path):
    out = _simulate_modules(NETLISTS / "boost.cir", tmp_path / "b.csv",
                            ("numba", "scipy", "matplotlib", "pandas", "cvxpy", "control",
                             "numpy.ma"))
    assert "MODS 0 []" in out, out[-2000:]
    assert (tmp_path / "b.csv").stat().st_size > 1000


# The smallest command (benchmarks/bench_startup.py times it against `python -c "import numpy"`).
RC_DECK = (Path(__file__).parent / "netlists" / "sim" / "smallest_rc.cir").read_text()


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_smallest_command_imports_only_what_it_uses(aot_built, tmp_path):
    # 100 steps to a CSV: nearly all of it is start-up. No numba (the AOT module), no lark
    # (its stand-alone parser, cached by the first run), none of the optional libraries, and
    # none of the standard modules only other paths use (hashlib and json: the stamps and the
    # kernels' types read from the record the first run wrote).
    deck = tmp_path / "rc.cir"
    deck.write_text(RC_DECK)
    modules = ("numba", "scipy", "matplotlib", "pandas", "pyarrow", "cvxpy", "control", "dask",
               "tqdm", "lark", "importlib.metadata", "numpy.ma", "decimal", "difflib",
               "secrets", "zipfile", "tempfile", "hashlib", "json", "subprocess")
    for _ in range(2):
        out = _simulate_modules(deck, tmp_path / "rc.csv", modules)
    assert "MODS 0 []" in out, out[-2000:]
    assert len((tmp_path / "rc.csv").read_text().splitlines()) == 102  # header, 101 points


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_large_circuit_run_imports_no_scipy(aot_built, tmp_path):
    # 195 MNA unknowns a mode: the formulation's LU path (lcs.sparse_lu), no scipy.sparse.
    net = tmp_path / "mmc24.cir"
    net.write_text(mmc_arm(24, periods=1))
    out = _simulate_modules(net, tmp_path / "m.npz", ("numba", "scipy"))
    assert "MODS 0 []" in out, out[-2000:]


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_missing_or_stale_module_falls_back_to_numba(tmp_path):
    # Another cache directory holds no module for these sources: numba's dispatchers serve
    # the run (here running the kernels' Python, NUMBA_DISABLE_JIT: the same dispatch, without
    # the minutes of compiling them; the tests marked jit compile them).
    code = ("import lcs.build.kernels as k, pelcs, sys; "
            f"r = pelcs.simulate({str(NETLISTS / 'buck.cir')!r}, tstop='0.1m'); "
            "print('USING', k.using_aot(), 'numba' in sys.modules, r.stats.steps)")
    p = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                       timeout=600, env={**os.environ, "PELCS_CACHE_DIR": str(tmp_path),
                                            "PELCS_PREBUILT": "0", "NUMBA_DISABLE_JIT": "1"})
    assert p.returncode == 0, p.stderr[-2000:]
    words = p.stdout.split("USING ")[1].split()
    assert words[:2] == ["False", "True"] and int(words[2]) > 100


def test_module_path_names_the_sources_and_numba():
    path = kernels.aot_path()
    assert kernels.aot_stamp().hex()[:16] in str(path)
    assert f"numba{kernels._numba_version()}" in str(path)
    assert path.name.startswith(kernels.AOT_MODULE)
    # The stamp covers the kernels and what the module's wrappers depend on.
    names = {f.name for f in kernels._kernel_files()} | {f.name for f in kernels.AOT_SOURCES}
    assert {"grid.py", "step.py", "codes.py", "kernels.py", "aot.py", "warmup.py",
            "sparse_lu.py"} <= names
    assert "modes.py" not in names


def test_module_path_names_the_processor_it_was_compiled_for(monkeypatch):
    # Compiled for the host processor: another processor's extensions give another path.
    tag = kernels.cpu_tag()
    assert f"-cpu{tag}-" in str(kernels.aot_path())
    try:
        flags = next(line for line in open("/proc/cpuinfo") if line.startswith("flags"))
    except (OSError, StopIteration):
        assert tag == "generic"
        return
    assert len(tag) == 8 and int(tag, 16) >= 0
    import builtins
    import io

    real_open = builtins.open

    def fake(path, *a, **kw):
        if path == "/proc/cpuinfo":
            return io.StringIO(flags.replace(" avx2", ""))
        return real_open(path, *a, **kw)

    monkeypatch.setattr(builtins, "open", fake)
    kernels._cpu_flags_line.cache_clear()
    kernels.aot_stamp.cache_clear()
    try:
        other = kernels.cpu_tag()
    finally:
        monkeypatch.undo()
        kernels._cpu_flags_line.cache_clear()
    assert (other != tag) == (" avx2" in flags)


def test_a_rebuild_removes_only_this_processors_stale_modules(tmp_path):
    from lcs.build.aot import stale_modules

    names = ["aot-aaaa-x86_64-cpu11111111-numba0.68.1", "aot-bbbb-x86_64-cpu11111111-numba0.68.1",
             "aot-cccc-x86_64-cpu22222222-numba0.68.1", "aot-dddd-aarch64-cpugeneric-numba0.68.1",
             "aot-eeee-x86_64-cpu11111111-numba0.60.0"]
    for name in names:
        (tmp_path / name).mkdir()
    current = tmp_path / names[1]
    assert stale_modules(current) == [tmp_path / names[0]]


def test_module_is_compiled_for_the_host_extensions_llvm_reports():
    # pycc's "host" alone takes the processor model's name and all it implies, which a
    # virtual machine may mask: the build passes the features numba's JIT would use.
    from numba.core import codegen

    from lcs.build.aot import _host_features

    before = codegen.AOTCPUCodegen._customize_tm_features
    with _host_features(True):
        assert codegen.AOTCPUCodegen._customize_tm_features(None) == \
            codegen.get_host_cpu_features()
    assert codegen.AOTCPUCodegen._customize_tm_features is before
    with _host_features(False):
        assert codegen.AOTCPUCodegen._customize_tm_features is before


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_arguments_of_another_type_go_to_numba_not_the_module(aot_built):
    # The extension module reads the memory of whatever array it is given: an int64 or a
    # strided array where it was compiled for contiguous float64 must not reach it.
    import numpy as np

    bounds = np.array([0.0, 10.0, 25.0])
    args = (bounds, 1.0, 0.5, 0.5, np.empty(2, np.int64), np.empty(2), np.empty(3, np.int64))
    mod = "lcs.integrators.moreau.dense.gridplan"
    assert kernels.aot_function(mod, "_plan_nb", args) is not None
    wrong_dtype = (np.array([0, 10, 25]),) + args[1:]
    strided = (np.array([[0.0, 1], [10, 1], [25, 1]])[:, 0],) + args[1:]
    read_only = args[:5] + (np.empty(2),) + args[6:]
    read_only[5].flags.writeable = False

    class Sub(np.ndarray):
        pass

    swapped = (bounds.astype(">f8"),) + args[1:]  # (the same values, another byte order)
    subclass = (bounds.view(Sub),) + args[1:]
    flag_for_float = (bounds, True) + args[2:]
    one_more = args + (np.empty(1),)
    for bad in (wrong_dtype, strided, read_only, swapped, subclass, flag_for_float, one_more):
        assert kernels.aot_function(mod, "_plan_nb", bad) is None
    # Through the Kernel: the dispatcher takes them and gives the right numbers.
    from lcs.integrators.moreau.dense.gridplan import _plan_nb, plan_grid

    ref = plan_grid(bounds, 1.0)
    n_reg, last, start = np.empty(2, np.int64), np.empty(2), np.empty(3, np.int64)
    _plan_nb(np.array([[0.0, 1], [10, 1], [25, 1]])[:, 0], 1.0, 0.5, 0.5, n_reg, last, start)
    assert np.array_equal(n_reg, ref.n_regular) and np.array_equal(start, ref.start)


def test_a_rebuild_warms_up_through_numba_not_the_module_it_replaces(aot_built, monkeypatch):
    # (rebuilding with the module present: its warm-up must make the dispatchers' signatures,
    # which calls served by the module would bypass; the environment is restored after)
    from lcs.build import aot

    monkeypatch.delenv("PELCS_AOT", raising=False)
    kernels.aot_module.cache_clear()
    assert kernels.aot_module() is not None
    with aot._through_numba():
        assert kernels.aot_module() is None
    assert "PELCS_AOT" not in os.environ
    assert kernels.aot_module() is not None


def test_this_module_runs_in_the_numba_group(request):
    # Under --dist loadgroup (scripts/test) pytest-xdist sends a group's tests to one worker
    # by the "@group" it appends to their ids; a pytest that keeps ids elsewhere (9.2) leaves
    # them without it, and both workers would compile numba's kernels at once.
    if getattr(request.config.option, "loadgroup", False):
        assert request.node.nodeid.endswith("@numba"), request.node.nodeid
