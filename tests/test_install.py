"""What ``pip install`` gives: the wheel's files, ``pelcs --version``, the first-use message
and the ahead-of-time module's background build (:mod:`lcs.build.kernel_setup`), the caches' places
when the installed package cannot be written, the bundled netlists found by their checkout
paths."""

from __future__ import annotations

import fcntl
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from lcs import jit
from lcs.build import kernel_setup, kernels
from pelcs.cli import bundled_netlist, installed_version, main

# (the slow part of the suite: outside the fast subset that `-m 'not slow'` selects)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]


def _readme_netlists() -> list[str]:
    """The netlist paths the README's ``pelcs`` commands name."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    found = []
    for line in text.splitlines():
        if re.match(r"\s*pelcs [a-z]+ ", line):
            found += re.findall(r"(\S+\.cir)\b", line)
    return sorted(set(found))


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> zipfile.ZipFile:
    """A wheel built by pip from a copy of the checkout's sources (no caches, no outputs)."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    skip = shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info")
    for name in ("pyproject.toml", "setup.py", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, src / name if src.exists() else (src.mkdir() or src / name))
    for pkg in ("pelcs", "netlist", "lcs", "converters", "ngspice_checks"):
        shutil.copytree(ROOT / pkg, src / pkg, ignore=skip)
    cmd = [sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(tmp / "dist"),
           str(src)]
    import setuptools

    if int(setuptools.__version__.split(".")[0]) >= 77:
        cmd.insert(4, "--no-build-isolation")  # (else pip fetches setuptools>=77 to build)
    # (without the kernels' module: compiling it takes minutes, bench_install.py measures it)
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300,
                       env={**os.environ, "PELCS_WHEEL_KERNELS": "0"})
    if p.returncode != 0 and "--no-build-isolation" not in cmd and (
            "Could not find a version" in p.stderr or "NewConnectionError" in p.stderr):
        pytest.skip("building the wheel needs setuptools>=77 from the package index, "
                    "unreachable here")
    assert p.returncode == 0, p.stderr[-3000:]
    (path,) = (tmp / "dist").glob("pelcs-*.whl")
    return zipfile.ZipFile(path)


def _setup_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("pelcs_setup", ROOT / "setup.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # (setup() itself runs only as the build's __main__)
    return module


@pytest.mark.xdist_group("wheel")  # (one worker builds the wheel once)
def test_the_wheel_is_for_this_platform(wheel):
    # (it may carry the compiled module: not a pure-Python "none-any" wheel)
    assert not Path(wheel.filename).name.endswith("-none-any.whl")
    assert re.search(r"-cp\d+-cp\d+-\w+\.whl$", Path(wheel.filename).name)


def test_the_build_keeps_the_module_and_drops_numbas_cache(tmp_path, capsys):
    lib = tmp_path / "lib"
    (lib / "lcs" / "__pycache__").mkdir(parents=True)
    # A stand-in for the build: the module, its lock, numba's cache files beside it.
    script = ("from pathlib import Path\n"
              "aot = Path('lcs/__pycache__/aot-x'); aot.mkdir()\n"
              "(aot / 'pelcs_kernels.so').write_bytes(b'so')\n"
              "(aot / 'build.lock').write_text('')\n"
              "k = Path('lcs/stepping/__pycache__/kernels-y'); k.mkdir(parents=True)\n"
              "(k / 'grid.run_grid-1.py311.nbi').write_bytes(b'i')\n"
              "Path('lcs/__pycache__/sparse_lu._link-40.py311.nbc').write_bytes(b'c')\n")
    assert _setup_module().build_kernels(lib, script)
    left = sorted(str(p.relative_to(lib)) for p in lib.rglob("*") if p.is_file())
    assert left == ["lcs/__pycache__/aot-x/pelcs_kernels.so"]
    assert "compiling the simulation kernels" in capsys.readouterr().err


def test_a_failed_kernel_build_leaves_a_wheel_without_them(tmp_path, capsys):
    lib = tmp_path / "lib"
    lib.mkdir()
    assert not _setup_module().build_kernels(lib, "raise SystemExit('no C compiler')")
    assert "could not be built" in capsys.readouterr().err


@pytest.mark.xdist_group("wheel")  # (one worker builds the wheel once)
def test_the_wheel_carries_the_prebuilt_module(wheel):
    files = set(wheel.namelist())
    here = kernels.prebuilt_dir().relative_to(ROOT).as_posix()
    assert f"{here}/{kernels.AOT_MODULE}.types.json" in files
    shipped = [p for p in kernels.prebuilt_dir().glob("*.so")]
    assert shipped and all(f"{here}/{p.name}" in files for p in shipped)


def test_the_readme_names_netlists():
    names = _readme_netlists()
    assert "converters/netlists/boost.cir" in names and len(names) >= 4


@pytest.mark.xdist_group("wheel")  # (one worker builds the wheel once)
def test_the_wheel_carries_every_netlist_the_readme_uses(wheel):
    files = wheel.namelist()
    for path in _readme_netlists():
        # Under its own path, or (a test netlist the README names) under the bundled
        # converters/netlists/ac/: the same bytes as the checkout's file.
        bundled = path if path.startswith("converters/") else (
            "converters/netlists/ac/" + Path(path).name)
        assert bundled in files, path
        assert wheel.read(bundled) == (ROOT / path).read_bytes(), path
    assert "netlist/grammar.lark" in files
    # No cache of this checkout; the only compiled file is the prebuilt kernels' module.
    assert not [f for f in files if "__pycache__" in f or f.endswith((".nbi", ".nbc"))]
    assert all(f.startswith("lcs/build/prebuilt/aot-") for f in files if f.endswith(".so"))
    meta = wheel.read(next(f for f in files if f.endswith(".dist-info/METADATA"))).decode()
    import pelcs

    assert f"\nVersion: {pelcs.__version__}\n" in meta
    entry = wheel.read(next(f for f in files if f.endswith("entry_points.txt"))).decode()
    assert "pelcs = pelcs.cli:main" in entry


def test_the_bundled_ac_netlists_are_the_tests_ones():
    for path in (ROOT / "converters" / "netlists" / "ac").glob("*.cir"):
        assert path.read_bytes() == (ROOT / "tests" / "netlists" / "ac" / path.name).read_bytes()


def test_version(capsys):
    import pelcs

    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out == f"pelcs {pelcs.__version__}\n"
    assert installed_version() == pelcs.__version__
    assert re.fullmatch(r"\d+\.\d+\.\d+\S*", pelcs.__version__)


def test_version_alone_imports_no_command():
    from pelcs.cli import _wanted

    assert _wanted(["--version"]) == []
    assert _wanted(["--version", "--help"]) != []
    code = ("import sys, pelcs.cli\n"
            "try:\n    pelcs.cli.main(['--version'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.startswith('pelcs.commands.')))")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       cwd=ROOT, timeout=60)
    assert p.stdout.splitlines()[-1] == "[]", p.stderr


def test_the_version_is_read_only_for_version():
    code = ("import sys, pelcs.cli\n"
            "pelcs.cli.build_parser(['simulate', 'x.cir'])\n"
            "print('importlib.metadata' in sys.modules)")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       cwd=ROOT, timeout=60)
    assert p.stdout.strip() == "False", p.stderr


@pytest.mark.jit  # (it compiles the checkout's kernels when they are not)
def test_kernels_cached_is_false_with_an_empty_cache_and_true_with_the_checkouts(tmp_path):
    code = "from lcs.build.kernel_setup import kernels_cached; print(kernels_cached())"
    env = {**os.environ, "PELCS_AOT": "0", "NUMBA_CACHE_DIR": str(tmp_path)}
    empty = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           cwd=ROOT, env=env, timeout=120)
    assert empty.stdout.strip() == "False", empty.stderr
    assert list(tmp_path.rglob("*.nbi")) == []  # it compiled nothing
    env.pop("NUMBA_CACHE_DIR")
    if os.environ.get("NUMBA_CACHE_DIR"):
        pytest.skip("NUMBA_CACHE_DIR is set: numba does not cache beside the sources")
    # The checkout's cache, complete (numba's kernels are compiled by the tests that use them,
    # on one worker: scripts/test; a checkout served by a module need not have them yet).
    warm = subprocess.run([sys.executable, "-c",
                           "from lcs.build.warmup import warm_up; warm_up(parallel=True)"],
                          capture_output=True, text=True, cwd=ROOT, env=env, timeout=900)
    assert warm.returncode == 0, warm.stderr[-2000:]
    full = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=120)
    assert full.stdout.strip() == "True", full.stderr
    # The quick answer without numba (numba's cache beside the sources) finds this cache.
    assert not kernel_setup._none_beside_the_sources()


def _simulate_first_use(monkeypatch, capsys, cached: bool, compiled: int, aot: bool):
    """``pelcs simulate`` of the bundled buck with the cache state faked, nothing compiled:
    (stderr lines, stdout, background builds started)."""
    import lcs.build.ready as ready
    import pelcs.commands.simulate  # noqa: F401  (imported before its names are patched)

    events = []

    def fake_warm_up():
        print("<warm_up>", file=sys.stderr)
        return 0.0 if aot else 123.0

    answers = [cached, True]  # (before the run, then after it: compiled)
    monkeypatch.setattr(kernel_setup, "kernels_cached", lambda: answers.pop(0))
    monkeypatch.setattr(kernel_setup, "compiled_in_process", lambda: compiled)
    monkeypatch.setattr(kernel_setup, "start_background_build",
                        lambda: events.append("build") or Path("/cache/build.log"))
    monkeypatch.setattr(ready, "load_kernels", fake_warm_up)
    monkeypatch.setattr(kernels, "using_aot", lambda: aot)
    monkeypatch.setattr(jit, "materialized", lambda: not aot)  # (numba served the run)
    monkeypatch.setattr(kernel_setup, "announce_compiles", lambda write: False)
    monkeypatch.delenv("PELCS_AOT", raising=False)
    monkeypatch.delenv("PELCS_AOT_BUILD", raising=False)
    rc = main(["simulate", str(ROOT / "converters" / "netlists" / "buck.cir"), "--tstop",
               "20u"])
    assert rc == 0
    out, err = capsys.readouterr()
    return err.splitlines(), out, events


def test_the_first_run_says_it_compiles_before_it_does(monkeypatch, capsys):
    err, out, builds = _simulate_first_use(monkeypatch, capsys, cached=False, compiled=9,
                                           aot=False)
    assert err[0] == kernel_setup.COMPILING_MESSAGE
    assert err[1] == "<warm_up>"
    assert "after 123 s compiling the kernels (once: later runs load them)" in out
    assert "loading" not in out
    assert builds == ["build"]
    assert err[2].startswith("pelcs: linking the compiled kernels into a module in the "
                             "background") and err[2].endswith("log: /cache/build.log)")


def test_a_cached_run_says_nothing_and_loads(monkeypatch, capsys):
    err, out, builds = _simulate_first_use(monkeypatch, capsys, cached=True, compiled=0,
                                           aot=False)
    assert err[0] == "<warm_up>" and kernel_setup.COMPILING_MESSAGE not in err
    assert "after 1.2e+02 s loading the compiled kernels" in out
    assert builds == ["build"]  # (numba served it: the module is built in the background)
    err, out, builds = _simulate_first_use(monkeypatch, capsys, cached=True, compiled=0,
                                           aot=True)
    assert err == ["<warm_up>"] and builds == [] and "compiling" not in out


def test_a_failed_build_is_said_on_each_run_served_by_numba(monkeypatch):
    monkeypatch.setattr(kernel_setup, "build_failure", lambda: "cc: not found")
    monkeypatch.setattr(kernel_setup, "start_background_build", lambda: None)
    monkeypatch.setattr(kernel_setup, "kernels_cached", lambda: True)
    monkeypatch.setattr(kernels, "using_aot", lambda: False)
    monkeypatch.setattr(jit, "materialized", lambda: True)
    monkeypatch.delenv("PELCS_AOT", raising=False)
    monkeypatch.delenv("PELCS_AOT_BUILD", raising=False)
    assert "could not be linked into a module (`pelcs compile` says why)" in \
        kernel_setup.after_run()
    monkeypatch.setenv("PELCS_AOT_BUILD", "0")
    assert kernel_setup.after_run() is None


def test_no_build_after_a_run_interrupted_while_compiling_or_without_numba(monkeypatch):
    started = []
    cached = [False]
    monkeypatch.setattr(kernel_setup, "kernels_cached", lambda: cached[0])
    monkeypatch.setattr(kernel_setup, "start_background_build", lambda: started.append(1))
    monkeypatch.setattr(kernels, "using_aot", lambda: False)
    monkeypatch.setattr(jit, "materialized", lambda: True)
    monkeypatch.delenv("PELCS_AOT", raising=False)
    monkeypatch.delenv("PELCS_AOT_BUILD", raising=False)
    assert kernel_setup.after_run() is None
    cached[0] = True
    monkeypatch.setattr(jit, "materialized", lambda: False)  # (a run that used no kernel)
    assert kernel_setup.after_run() is None
    assert started == []


def test_the_first_compile_of_a_process_is_announced_once(tmp_path):
    (tmp_path / "twice.py").write_text(
        "from lcs.jit import jitted\n\n\n@jitted\ndef f(x):\n    return x + 1\n")
    code = ("import sys, lcs.build.kernel_setup as s\n"
            "print(s.announce_compiles(lambda text: print('SAID', text)))\n"
            "print(s.announce_compiles(lambda text: print('SAID', text)))\n"
            f"sys.path.insert(0, {str(tmp_path)!r})\n"
            "from twice import f\n"
            "print(f(1), f(2.0))")
    env = {**os.environ, "PELCS_AOT": "0", "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           cwd=ROOT, env=env, timeout=120) for _ in range(2)]
    said = f"SAID {kernel_setup.COMPILING_MESSAGE}"
    # (two commands in one process: one listener, one message)
    assert runs[0].stdout.splitlines() == ["True", "True", said, "2 3.0"], runs[0].stderr
    assert runs[1].stdout.splitlines() == ["True", "True", "2 3.0"], runs[1].stderr  # loaded


def test_every_command_but_info_watches_for_compiles(monkeypatch, capsys):
    watched = []
    monkeypatch.setattr(kernel_setup, "announce_compiles", lambda write: watched.append(1))
    buck = str(ROOT / "converters" / "netlists" / "buck.cir")
    assert main(["info", buck]) == 0
    assert watched == []
    assert main(["lcs", buck]) == 0
    assert watched == [1]


def test_compiled_in_process_counts_numba_cache_misses(tmp_path):
    (tmp_path / "twice.py").write_text(
        "from lcs.jit import jitted\n\n\n@jitted\ndef f(x):\n    return x + 1\n")
    code = ("import sys, lcs.build.kernel_setup as s\n"
            "print(s.compiled_in_process())\n"
            f"sys.path.insert(0, {str(tmp_path)!r})\n"
            "from twice import f\n"
            "f(1); f(2.0)\n"
            "print(s.compiled_in_process())")
    env = {**os.environ, "PELCS_AOT": "0", "NUMBA_CACHE_DIR": str(tmp_path / "cache")}
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           cwd=ROOT, env=env, timeout=120) for _ in range(2)]
    # Compiled (two specialisations), then loaded from numba's cache.
    assert runs[0].stdout.split() == ["0", "2"], runs[0].stderr
    assert runs[1].stdout.split() == ["0", "0"], runs[1].stderr


@pytest.fixture
def empty_cache(tmp_path, monkeypatch):
    """PELCS_CACHE_DIR in a temporary directory (no module built there, none prebuilt)."""
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    monkeypatch.setenv("PELCS_PREBUILT", "0")
    monkeypatch.delenv("PELCS_AOT", raising=False)
    monkeypatch.delenv("PELCS_AOT_BUILD", raising=False)
    started = []

    def fake_popen(argv, **kw):
        started.append((argv, kw))

    monkeypatch.setattr(subprocess, "Popen", fake_popen)  # (kernel_setup imports it late)
    return tmp_path, started


def test_the_background_build_is_detached_and_started_once(empty_cache):
    tmp, started = empty_cache
    log = kernel_setup.start_background_build()
    assert log is not None and log.parent == kernels.aot_path().parent
    assert tmp in log.parents
    (argv, kw), = started
    assert argv == [sys.executable, "-m", "lcs.build.kernel_setup"]
    assert kw["start_new_session"] and kw["stdin"] == subprocess.DEVNULL
    assert str(ROOT) in kw["env"]["PYTHONPATH"].split(os.pathsep)
    # A build holding the lock: none started beside it.
    lock = log.parent / "build.lock"
    with open(lock, "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        assert kernel_setup.build_running()
        assert kernel_setup.start_background_build() is None
    assert not kernel_setup.build_running()
    # A failed build is not retried in the background.
    (log.parent / "build.failed").write_text("no C compiler")
    assert kernel_setup.build_failure() == "no C compiler"
    assert kernel_setup.start_background_build() is None
    assert len(started) == 1


def test_the_background_build_can_be_turned_off(empty_cache, monkeypatch):
    _, started = empty_cache
    for var in ("PELCS_AOT_BUILD", "PELCS_AOT"):
        monkeypatch.setenv(var, "0")
        assert kernel_setup.start_background_build() is None
        monkeypatch.delenv(var)
    assert started == []


def test_a_failed_build_leaves_a_note(empty_cache, monkeypatch):
    from lcs.build import aot

    def fail(*a, **k):
        raise OSError("cc: not found")

    monkeypatch.setattr(aot, "build", fail)
    monkeypatch.setattr(os, "nice", lambda n: 0)  # (not this test process's priority)
    assert kernel_setup._build_main() == 1
    assert "cc: not found" in kernel_setup.build_failure()


def test_the_module_goes_to_the_user_cache_when_the_package_cannot_be_written(
        tmp_path, monkeypatch):
    pkg = tmp_path / "site" / "lcs"
    pkg.mkdir(parents=True)
    # A file where __pycache__ would be: nothing can be written there, even by root.
    (pkg / "__pycache__").write_text("")
    monkeypatch.setattr(kernels, "_LCS", pkg)
    monkeypatch.delenv("PELCS_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert kernels.user_cache_dir() == tmp_path / "xdg" / "pelcs"
    path = kernels.aot_path()
    assert path.parent.parent == tmp_path / "xdg" / "pelcs"
    assert path.name == kernels.aot_filename()
    # A writable package directory: its __pycache__ (as in a checkout or a venv).
    (pkg / "__pycache__").unlink()
    assert kernels.aot_path().parent.parent == pkg / "__pycache__"
    # A module built in the user cache is found there although the package is writable.
    built = tmp_path / "xdg" / "pelcs" / path.parent.name / path.name
    built.parent.mkdir(parents=True, exist_ok=True)
    built.write_bytes(b"")
    assert kernels.aot_path() == built
    # PELCS_CACHE_DIR replaces both.
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path / "mine"))
    assert kernels.aot_path().parent.parent == tmp_path / "mine"


def test_the_grammar_tables_go_to_the_user_cache_when_the_package_cannot_be_written(
        tmp_path, monkeypatch):
    from netlist import expressions, lark_standalone

    pkg = tmp_path / "site" / "netlist"
    pkg.mkdir(parents=True)
    (pkg / "__pycache__").write_text("")  # (nothing can be written there, even by root)
    monkeypatch.setattr(lark_standalone, "GRAMMAR_FILE", pkg / "grammar.lark")
    monkeypatch.delenv("PELCS_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert expressions._grammar_cache() == str(tmp_path / "xdg" / "pelcs" /
                                               "grammar.lark-tables")


def test_numba_caches_an_unwritable_packages_kernels_user_wide(tmp_path, monkeypatch):
    import numba.core.caching as caching
    import numba.core.config as config

    from lcs import jit_passes

    pkg = tmp_path / "site" / "lcs"
    pkg.mkdir(parents=True)
    (pkg / "__pycache__").write_text("")  # (nothing can be written there, even by root)
    src = pkg / "grid.py"
    src.write_text("def run_grid(x):\n    return x\n")
    namespace: dict = {}
    exec(compile(src.read_text(), str(src), "exec"), namespace)
    monkeypatch.setattr(jit_passes, "KERNEL_SOURCES", (pkg,))
    monkeypatch.setattr(config, "CACHE_DIR", "")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    loc = jit_passes.KernelCacheLocator.from_function(namespace["run_grid"], str(src))
    assert isinstance(loc._inner, caching.UserWideCacheLocator)
    assert Path(loc.get_cache_path()).is_relative_to(tmp_path / "xdg" / "numba")
    assert Path(loc.get_cache_path()).name.startswith("kernels-")


def test_a_bundled_netlist_is_found_by_its_checkout_path(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    found = bundled_netlist("converters/netlists/buck.cir")
    assert found is not None
    assert Path(found).read_bytes() == (ROOT / "converters/netlists/buck.cir").read_bytes()
    assert bundled_netlist("converters/netlists/ac/buck_vc.cir") is not None
    assert bundled_netlist("converters/netlists/nope.cir") is None
    assert bundled_netlist("converters/netlists/../../pyproject.toml") is None
    assert bundled_netlist("mine.cir") is None
    (tmp_path / "converters" / "netlists").mkdir(parents=True)
    (tmp_path / "converters" / "netlists" / "buck.cir").write_text("* mine\n")
    assert bundled_netlist("converters/netlists/buck.cir") is None  # the user's own file


def test_the_cli_runs_the_bundled_copy_and_says_so(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert main(["info", "converters/netlists/buck.cir"]) == 0
    out, err = capsys.readouterr()
    assert "pelcs: converters/netlists/buck.cir is not in this directory: running pelcs's " \
           "bundled copy" in err
    assert "Buck converter" in out


def test_compile_reports_a_failed_link_with_a_hint(tmp_path, monkeypatch, capsys):
    import lcs.build.warmup as warmup

    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(kernel_setup, "kernels_cached", lambda: True)
    monkeypatch.setattr(warmup, "warm_up", lambda **_: 0.0)
    # (numba's cache misses of this process: another test may have compiled a kernel in it)
    monkeypatch.setattr(kernel_setup, "compiled_in_process", lambda: 0)

    def fail():
        raise OSError("cc: not found")

    monkeypatch.setattr(kernel_setup, "build_now", fail)
    assert main(["compile"]) == 1
    out, err = capsys.readouterr()
    assert "loaded the kernels in" in out
    assert "error: linking the kernels into a module failed: OSError: cc: not found" in err
    assert "hint: it needs a C compiler" in err and "Traceback" not in err


def test_compile_with_the_module_built_says_where(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path))
    path = kernels.aot_path()
    path.parent.mkdir(parents=True)
    path.write_bytes(b"")
    assert main(["compile"]) == 0
    assert capsys.readouterr().out == f"the kernels are compiled and linked: {path}\n"


def test_python_dash_m_pelcs_is_the_command():
    import pelcs

    out = subprocess.run([sys.executable, "-m", "pelcs", "--version"], capture_output=True,
                         text=True, cwd=ROOT, timeout=60)
    assert out.returncode == 0 and out.stdout == f"pelcs {pelcs.__version__}\n", out
