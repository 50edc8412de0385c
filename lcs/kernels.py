"""Where the compiled kernels come from: the ahead-of-time extension module when it was built
from the current kernel sources, numba otherwise.

A :class:`lcs.jit.Kernel` called from Python asks :func:`aot_function` first. The extension
module (:mod:`lcs.aot`, built by ``scripts/setup``) holds the kernels that Python calls
directly (the grid loop, the discretisation, the grid plan, the source switching instants),
compiled from the same numba code; loading it takes milliseconds and imports nothing but
numpy, so a short run never imports numba (measured in ``benchmarks/bench_command.py``).
Without it, or when its stamp does not match the sources (an edited kernel), the numba
dispatchers are used, compiled or loaded from numba's cache. ``PELCS_AOT=0`` forces numba (the
tests of the AOT module compare the two).

Nothing here imports numba.
"""

from __future__ import annotations

import functools
import hashlib
import importlib
import importlib.machinery
import importlib.util
import os
import platform
import sysconfig
from collections.abc import Callable
from pathlib import Path

__all__ = ["AOT_MODULE", "KERNEL_SOURCES", "aot_function", "aot_module", "aot_path",
           "kernel_stamp", "using_aot"]

_LCS = Path(__file__).resolve().parent
# The packages whose compiled functions call or inline each other's, the other files with
# compiled functions, and the compiler passes: a change to any of them recompiles every kernel.
KERNEL_SOURCES = (_LCS / "jit.py", _LCS / "jit_passes.py", _LCS / "bits.py", _LCS / "lcp",
                  _LCS / "stepping", _LCS / "simulation" / "source_switching.py")
# Files in those packages that no kernel compiles or reads (Python only): editing them must
# not recompile every kernel (2-3 minutes).
PYTHON_ONLY = frozenset({"__init__.py", "driver.py", "enumeration.py", "modes.py",
                         "warmup.py"})
AOT_MODULE = "pelcs_kernels"

# export name -> (module, attribute, which signature: "plain" = run_grid's plain-loop
# specialisation, "none" = the one without, "" = the only one).
_EXPORTS = {
    "run_grid_none": ("lcs.stepping.grid", "run_grid", "none"),
    "run_grid_plain": ("lcs.stepping.grid", "run_grid", "plain"),
    "discretise_nb": ("lcs.stepping.discretise", "discretise_nb", ""),
    "plan_grid_nb": ("lcs.stepping.gridplan", "_plan_nb", ""),
    "fill_grid_nb": ("lcs.stepping.gridplan", "_fill_grid", ""),
    "linear_switch_events_nb": ("lcs.simulation.source_switching", "_linear_switch_events", ""),
    "merge_keys_nb": ("lcs.simulation.source_switching", "_merge_keys", ""),
}


def _kernel_files() -> list[Path]:
    files = []
    for src in KERNEL_SOURCES:
        if src.is_dir():
            files.extend(f for f in sorted(src.glob("*.py")) if f.name not in PYTHON_ONLY)
        else:
            files.append(src)
    return files


@functools.lru_cache(maxsize=1)
def kernel_stamp() -> bytes:
    """SHA-256 of every kernel source file (names and contents), once per process."""
    h = hashlib.sha256()
    for f in _kernel_files():
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.digest()


def aot_filename() -> str:
    return AOT_MODULE + (sysconfig.get_config_var("EXT_SUFFIX") or ".so")


def _cache_root() -> Path:
    env = os.environ.get("PELCS_CACHE_DIR")
    if env:
        return Path(env)
    return _LCS / "__pycache__"


@functools.lru_cache(maxsize=1)
def _numba_version() -> str:
    # From the installed distribution's directory name: importlib.metadata costs 12 ms of
    # imports, and importing numba to ask it is what this module avoids.
    spec = importlib.util.find_spec("numba")
    if spec is None or spec.origin is None:
        return "none"
    site = Path(spec.origin).resolve().parent.parent
    names = sorted(d.name for d in site.glob("numba-*.dist-info"))
    return names[-1][len("numba-"):-len(".dist-info")] if names else "unknown"


def aot_path() -> Path:
    """Where the extension module built from the current sources lives (it may not exist)."""
    tag = f"aot-{kernel_stamp().hex()[:16]}-{platform.machine()}-numba{_numba_version()}"
    return _cache_root() / tag / aot_filename()


@functools.lru_cache(maxsize=1)
def aot_module():
    """The extension module of the current kernel sources, or None (not built, stale, or
    ``PELCS_AOT=0``)."""
    if os.environ.get("PELCS_AOT", "1") == "0":
        return None
    path = aot_path()
    if not path.is_file():
        return None
    loader = importlib.machinery.ExtensionFileLoader(AOT_MODULE, str(path))
    spec = importlib.util.spec_from_file_location(AOT_MODULE, str(path), loader=loader)
    if spec is None:
        return None
    try:
        mod = importlib.util.module_from_spec(spec)
        loader.exec_module(mod)
    except ImportError:
        return None
    return mod


def using_aot() -> bool:
    """Whether the kernels run from the ahead-of-time module."""
    return aot_module() is not None


def _flatten(args, out: list) -> list:
    for a in args:
        if a is None:
            continue
        if isinstance(a, tuple):
            _flatten(a, out)
        else:
            out.append(a)
    return out


def exported_dispatchers():
    """(export name, numba dispatcher, signature selector) of every exported kernel (imports
    numba)."""
    out = []
    for export, (module, attr, which) in _EXPORTS.items():
        disp = getattr(importlib.import_module(module), attr)
        disp = getattr(disp, "dispatcher", disp)
        if which == "none":
            def select(s):
                return str(s[-1]) == "none"
        elif which == "plain":
            def select(s):
                return str(s[-1]) != "none"
        else:
            def select(s):
                return True
        out.append((export, disp, select))
    return out


@functools.cache
def _exports_of(module: str, attr: str) -> tuple[tuple[str, str], ...]:
    return tuple((export, which) for export, (m, a, which) in _EXPORTS.items()
                 if m == module and a == attr)


def aot_function(module: str, attr: str, args: tuple) -> Callable | None:
    """The ahead-of-time function for a call of kernel ``module.attr`` with ``args``, taking
    the same arguments as the numba one (named tuples are flattened on the way), or None when
    there is no ahead-of-time module or it does not export that kernel."""
    exports = _exports_of(module, attr)
    if not exports:
        return None
    mod = aot_module()
    if mod is None:
        return None
    for export, which in exports:
        if which == "none" and args[-1] is not None:
            continue
        if which == "plain" and args[-1] is None:
            continue
        return _aot_call(mod, export)
    return None


@functools.cache
def _aot_call(mod, export: str) -> Callable:
    fn = getattr(mod, export)
    if export.startswith("run_grid"):
        def call(*args):
            return fn(*_flatten(args, []))
        return call
    return fn
