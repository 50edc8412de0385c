"""Where the compiled kernels come from: the ahead-of-time extension module when it was built
from the current kernel sources, numba otherwise.

A :class:`lcs.jit.Kernel` called from Python asks :func:`aot_function` first. The extension
module (:mod:`lcs.build.aot`, built by ``scripts/setup``, by ``pelcs compile``, or in the
background after a run served by numba: :mod:`lcs.build.kernel_setup`) holds the kernels that Python
calls directly (the grid loop, the discretisation, the grid plan, the source switching
instants), compiled from the same numba code; loading it takes milliseconds and imports nothing
but numpy, so a short run never imports numba (measured in ``benchmarks/bench_command.py``).
Without it, or when its stamp does not match the sources (an edited kernel), the numba
dispatchers are used, compiled or loaded from numba's cache. ``PELCS_AOT=0`` forces numba (the
tests of the AOT module compare the two).

The checkout and the wheel also ship the module prebuilt for x86-64 processors with AVX2
(:data:`PREBUILT`, built by ``scripts/prebuild`` for each interpreter whenever the kernel sources
change): where no module was built on this machine, it is loaded when its stamp matches the
sources and the processor has every extension it was compiled for, so that a fresh checkout
or install runs at once instead of compiling for minutes. ``PELCS_PREBUILT=0`` ignores it.

Nothing here imports numba.
"""

from __future__ import annotations

import functools
import importlib
import importlib.machinery
import importlib.util
import marshal
import os
import platform
import sysconfig
from collections.abc import Callable
from pathlib import Path

__all__ = ["AOT_MODULE", "AOT_SOURCES", "KERNEL_SOURCES", "PREBUILT", "PREBUILT_CPU",
           "PREBUILT_PYTHONS",
           "aot_function", "aot_module", "aot_path", "aot_stamp", "aot_types_path",
           "cache_roots", "cpu_tag", "kernel_closure", "kernel_stamp", "module_path",
           "module_stamp", "prebuilt_dir",
           "prebuilt_path", "user_cache_dir", "using_aot"]

_LCS = Path(__file__).resolve().parent.parent
# The packages whose compiled functions call or inline each other's, the other files with
# compiled functions, and the compiler passes: a change to one of them recompiles the kernels
# of the modules that import it (module_stamp), and makes the prebuilt module stale.
_MOREAU = _LCS / "integrators" / "moreau"
KERNEL_SOURCES = (_LCS / "jit.py", _LCS / "jit_passes.py", _LCS / "bits.py", _LCS / "lcp",
                  _MOREAU / "dense", _MOREAU / "sparse",
                  _LCS / "simulation" / "source_switching.py", _LCS / "simulation" / "codes.py")
# What the ahead-of-time module also depends on: the export table and argument flattening
# here, the flat wrappers of aot.py, the signatures warmup.py compiles.
AOT_SOURCES = (_LCS / "build" / "kernels.py", _LCS / "build" / "aot.py",
               _LCS / "build" / "warmup.py", _LCS / "sparse_lu.py")
# Files in those packages that no kernel compiles or reads (Python only): editing them must
# not recompile kernels.
PYTHON_ONLY = frozenset({"__init__.py", "driver.py", "enumeration.py", "modes.py",
                         "stack.py", "integrate.py"})
AOT_MODULE = "pelcs_kernels"
# The module prebuilt for a processor level (LLVM's name), shipped in the package, and the
# extensions that level implies, as /proc/cpuinfo names them (x86-64-v3: Haswell, Zen and
# later; a processor without one of them would stop at an illegal instruction).
PREBUILT = _LCS / "build" / "prebuilt"
PREBUILT_CPU = "x86-64-v3"
# The interpreters it is prebuilt for (their extension modules' tags; scripts/prebuild).
PREBUILT_PYTHONS = ("cpython-310", "cpython-311", "cpython-312", "cpython-313")
_PREBUILT_FLAGS = frozenset({"avx", "avx2", "bmi1", "bmi2", "f16c", "fma", "abm", "movbe",
                             "xsave", "cx16", "lahf_lm", "popcnt", "pni", "sse4_1", "sse4_2",
                             "ssse3"})

# export name -> (module, attribute): each kernel has one specialisation (lcs.build.warmup).
_EXPORTS = {
    "run_grid": ("lcs.integrators.moreau.dense.grid", "run_grid"),
    "discretise_nb": ("lcs.integrators.moreau.dense.discretise", "discretise_nb"),
    "plan_grid_nb": ("lcs.integrators.moreau.dense.gridplan", "_plan_nb"),
    "fill_grid_nb": ("lcs.integrators.moreau.dense.gridplan", "_fill_grid"),
    "linear_switch_events_nb": ("lcs.simulation.source_switching", "_linear_switch_events"),
    "merge_keys_nb": ("lcs.simulation.source_switching", "_merge_keys"),
    "lu_factor_nb": ("lcs.sparse_lu", "_factor"),
    "lu_count_nb": ("lcs.sparse_lu", "_count"),
    "lu_compress_nb": ("lcs.sparse_lu", "_compress"),
    "lu_solve_rows_nb": ("lcs.sparse_lu", "_solve_rows"),
    "lu_inv_norm1_nb": ("lcs.sparse_lu", "_inv_norm1"),
    "run_kkt": ("lcs.integrators.moreau.sparse.grid", "run_kkt"),
    "kkt_lookup": ("lcs.integrators.moreau.sparse.step", "lookup"),
    "kkt_factor": ("lcs.integrators.moreau.sparse.lu", "factor"),
    "kkt_min_degree": ("lcs.integrators.moreau.sparse.ordering", "_minimum_degree"),
}


def _kernel_files() -> list[Path]:
    files = []
    for src in KERNEL_SOURCES:
        if src.is_dir():
            files.extend(f for f in sorted(src.glob("*.py")) if f.name not in PYTHON_ONLY)
        else:
            files.append(src)
    return files


def _module_files(parts: list[str], kernel_files: frozenset[Path]) -> set[Path]:
    """The kernel source files of the module or package of dotted ``parts`` (a package: every
    kernel file in it, since its ``__init__`` may re-export any of them)."""
    base = _LCS.parent.joinpath(*parts)
    if base.is_dir():
        return {f for f in kernel_files if f.parent == base}
    f = base.with_suffix(".py")
    return {f} if f in kernel_files else set()


def _kernel_imports(path: Path, kernel_files: frozenset[Path]) -> set[Path]:
    """The kernel source files ``path`` imports (``import``, ``from ... import``, relative or
    absolute; a name imported from a package may be a module of it)."""
    import ast

    try:
        rel = path.relative_to(_LCS.parent)
    except ValueError:
        return set()
    package = list(rel.parts[:-1])
    out: set[Path] = set()
    for node in ast.walk(ast.parse(path.read_bytes())):
        if isinstance(node, ast.ImportFrom):
            base = package[:len(package) - node.level + 1] if node.level else []
            mod = base + (node.module.split(".") if node.module else [])
            out |= _module_files(mod, kernel_files)
            for alias in node.names:
                out |= _module_files(mod + [alias.name], kernel_files)
        elif isinstance(node, ast.Import):
            for alias in node.names:
                out |= _module_files(alias.name.split("."), kernel_files)
    return out


@functools.cache
def kernel_closure(path: Path) -> frozenset[Path]:
    """What a kernel module's compiled code can depend on: the module itself, the kernel
    sources it imports, transitively (numba compiles a kernel's callees and inlined pieces
    through its module's globals, so everything it can reach is imported), and the compiler
    (``lcs/jit.py``, ``lcs/jit_passes.py``)."""
    path = Path(path).resolve()
    files = frozenset(_kernel_files())
    seen = {path}
    todo = [path]
    while todo:
        for f in _kernel_imports(todo.pop(), files):
            if f not in seen:
                seen.add(f)
                todo.append(f)
    return frozenset(seen | {_LCS / "jit.py", _LCS / "jit_passes.py"})


@functools.cache
def module_stamp(path: Path) -> bytes:
    """SHA-256 of the files of :func:`kernel_closure`, which numba's cache of that module's
    kernels is stamped with (:class:`lcs.jit_passes.KernelCacheLocator`): an edit of the
    dense grid loop recompiles the modules that import it, not the sparse kernel nor the LCP
    solvers they call."""
    return _digest(sorted(kernel_closure(Path(path).resolve())))


def _digest(files, start: bytes = b"") -> bytes:
    """SHA-256 of ``start`` and each file's name and contents, in order."""
    import hashlib  # (4 ms of OpenSSL's loading: not on a start that finds its record)

    h = hashlib.sha256(start)
    for f in files:
        h.update(f.name.encode())
        h.update(f.read_bytes())
    return h.digest()


@functools.lru_cache(maxsize=1)
def kernel_stamp() -> bytes:
    """SHA-256 of every kernel source file (names and contents), once per process."""
    return _digest(_kernel_files())


def aot_filename() -> str:
    return AOT_MODULE + (sysconfig.get_config_var("EXT_SUFFIX") or ".so")


def user_cache_dir() -> Path:
    """The per-user cache of pelcs: ``$XDG_CACHE_HOME/pelcs``, else ``~/.cache/pelcs``
    (``PELCS_CACHE_DIR`` replaces every cache location when set)."""
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".cache"
    return base / "pelcs"


def cache_roots(package_cache: Path | None = None) -> tuple[Path, ...]:
    """Where pelcs' caches (this module's extension module, the grammar's parser) are looked
    for, in order: ``PELCS_CACHE_DIR`` alone when set, else the installed package's
    ``package_cache`` (default ``lcs/__pycache__``: a checkout, a virtual environment) and the
    per-user cache (a package directory the user may not write: a system-wide
    installation)."""
    env = os.environ.get("PELCS_CACHE_DIR")
    if env:
        return (Path(env),)
    return (_LCS / "__pycache__" if package_cache is None else package_cache,
            user_cache_dir())


def _writable(directory: Path) -> bool:
    """Whether a file can be created in ``directory`` (made if missing), tried as numba's
    cache does: permission bits say nothing for root or on a read-only file system."""
    import tempfile

    try:
        directory.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=directory).close()
    except OSError:
        return False
    return True


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


#: The file, in the cache roots, that keeps the stamps a start needs (:func:`_recorded`).
STAMP_RECORD = "kernel-stamps"


@functools.lru_cache(maxsize=1)
def _stamp_records() -> list[tuple[Path, dict]]:
    """(cache root, its :data:`STAMP_RECORD`) of each cache root, in order; empty for a
    missing or unreadable file."""
    records = []
    for root in cache_roots():
        try:
            loaded = marshal.loads((root / STAMP_RECORD).read_bytes())
        except (OSError, ValueError, EOFError, TypeError):
            loaded = {}
        records.append((root, loaded if isinstance(loaded, dict) else {}))
    return records


def _recorded(name: str, key, compute: Callable[[], object], kind: type):
    """``compute()``, kept under ``name`` in this machine's :data:`STAMP_RECORD` with the
    ``key`` it was computed for, and read from there while the key is the same.

    A start that finds the AOT stamp, the processor tag and the kernels' argument types
    recorded neither hashes the sources (some 400 kB), nor imports hashlib and json: 8 ms, a
    tenth of what a 100-step command costs beyond numpy. The record is a cache only: a value
    that no cache root's record holds for ``key`` (as a ``kind``) is computed again, and
    written to the first cache root that takes it (none when no root is writable: then
    computed on every start; a read-only package's record, written by its installer, is read
    before the user's)."""
    records = _stamp_records()
    for _, record in records:
        entry = record.get(name)
        if (isinstance(entry, tuple) and len(entry) == 2 and entry[0] == key
                and isinstance(entry[1], kind)):
            return entry[1]
    value = compute()
    from lcs.atomic import atomic_path

    for root, record in records:
        record[name] = (key, value)
        try:
            root.mkdir(parents=True, exist_ok=True)
            with atomic_path(root / STAMP_RECORD) as tmp:  # (whole, for a concurrent start)
                tmp.write_bytes(marshal.dumps(record))
        except (OSError, ValueError):
            del record[name]
            continue
        break
    return value


def _file_key(files) -> tuple:
    """What identifies the contents of ``files`` without reading them: each one's path,
    inode, size, and modification and change times (the change time cannot be set back by
    a tool that keeps or normalises modification times: an archive, ``cp -p``, a
    reproducible build), as nanoseconds. Raises OSError for a missing file."""
    return tuple((str(f), st.st_ino, st.st_size, st.st_mtime_ns, st.st_ctime_ns)
                 for f in files for st in [os.stat(f)])


@functools.cache
def aot_stamp() -> bytes:
    """SHA-256 of the kernel stamp and the sources the ahead-of-time module depends on.

    Recorded per machine with what identifies each source file (:func:`_file_key`): an
    edit, a checkout or an installation changes it and hashes the sources again."""
    try:
        key = _file_key([*_kernel_files(), *AOT_SOURCES])
    except OSError:
        return _digest(AOT_SOURCES, kernel_stamp())
    return _recorded("aot_stamp", key, lambda: _digest(AOT_SOURCES, kernel_stamp()), bytes)


@functools.lru_cache(maxsize=1)
def _cpu_flags_line() -> str | None:
    """The first processor's ``flags`` line of ``/proc/cpuinfo``, or None."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as fh:
            for line in fh:
                if line.startswith("flags"):
                    return line
                if not line.strip():
                    break
    except OSError:
        pass
    return None


def cpu_tag() -> str:
    """The instruction-set extensions of this machine's processor, hashed (8 hex digits), from
    the first processor's ``flags`` in ``/proc/cpuinfo``; ``"generic"`` where there is no
    such file. The ahead-of-time module is compiled for the host processor (AVX2, AVX-512:
    the multiplier's step 25 % faster than with the generic x86-64 target), so a machine with
    other extensions (a cluster node sharing the home directory) must not load it: it finds
    no module under its own tag and builds or falls back to numba."""
    line = _cpu_flags_line()
    if line is None:
        return "generic"
    return _recorded("cpu_tag", line, lambda: _digest([], line.encode()).hex()[:8], str)


def prebuilt_dir() -> Path:
    """Where the prebuilt module of the current sources is (or is to be built)."""
    return PREBUILT / f"aot-{aot_stamp().hex()[:16]}-x86_64-{PREBUILT_CPU}"


def prebuilt_path() -> Path | None:
    """The prebuilt module of the current sources when it is shipped, this processor runs its
    code, and ``PELCS_PREBUILT`` is not ``0``; else None."""
    if os.environ.get("PELCS_PREBUILT", "1") == "0" or platform.machine() != "x86_64":
        return None
    line = _cpu_flags_line()
    if line is None or not _PREBUILT_FLAGS <= set(line.split(":", 1)[-1].split()):
        return None
    path = prebuilt_dir() / aot_filename()
    return path if path.is_file() else None


def _aot_tag() -> str:
    return (f"aot-{aot_stamp().hex()[:16]}-{platform.machine()}-cpu{cpu_tag()}"
            f"-numba{_numba_version()}")


def _built_path() -> Path | None:
    """The extension module built on this machine from the current sources, or None."""
    tag = _aot_tag()
    for root in cache_roots():
        path = root / tag / aot_filename()
        if path.is_file():
            return path
    return None


def aot_path() -> Path:
    """Where the extension module built from the current sources is, or else where it is to
    be built (the first cache root that can be written, :func:`cache_roots`)."""
    path = _built_path()
    if path is not None:
        return path
    roots = cache_roots()
    root = next((r for r in roots if _writable(r)), roots[-1])
    return root / _aot_tag() / aot_filename()


def module_path() -> Path | None:
    """The extension module a run loads: the one built on this machine for the current
    sources (:func:`aot_path`), else the prebuilt one (:func:`prebuilt_path`); None when
    there is neither or ``PELCS_AOT=0``."""
    if os.environ.get("PELCS_AOT", "1") == "0":
        return None
    # (no test whether a cache root can be written: a command served by the prebuilt module
    # must not create files to find it)
    return _built_path() or prebuilt_path()


def aot_types_path() -> Path:
    """The argument types of the module a run loads (JSON, written by
    :func:`lcs.build.aot.build` beside it)."""
    return (module_path() or aot_path()).with_name(AOT_MODULE + ".types.json")


@functools.lru_cache(maxsize=1)
def aot_module():
    """The extension module of the current kernel sources (:func:`module_path`), or None (not
    built, stale, or ``PELCS_AOT=0``)."""
    path = module_path()
    if path is None:
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
    """(export name, numba dispatcher) of every exported kernel (imports numba)."""
    out = []
    for export, (module, attr) in _EXPORTS.items():
        disp = getattr(importlib.import_module(module), attr)
        out.append((export, getattr(disp, "dispatcher", disp)))
    return out


@functools.cache
def _export_of(module: str, attr: str) -> str | None:
    return next((export for export, (m, a) in _EXPORTS.items() if m == module and a == attr),
                None)


def aot_function(module: str, attr: str, args: tuple) -> Callable | None:
    """The ahead-of-time function of kernel ``module.attr`` bound to ``args`` (named tuples
    flattened), ready to call with no arguments; None when there is no ahead-of-time module,
    it does not export that kernel, or ``args`` do not have exactly the types it was
    compiled for (numba's dispatcher then compiles or loads the right specialisation; the
    extension module would reinterpret the memory of a wrong dtype or a strided array)."""
    export = _export_of(module, attr)
    if export is None:
        return None
    mod = aot_module()
    if mod is None:
        return None
    fn = getattr(mod, export, None)
    check = _checker(export)
    if fn is None or check is None:
        return None
    flat = _flatten(args, [])
    if not check(flat):
        return None
    return functools.partial(fn, *flat)


@functools.cache
def _aot_types() -> dict:
    """The argument types of each kernel the module exports (:func:`aot_types_path`),
    recorded per machine with what identifies the file (:func:`_file_key`); empty when it
    cannot be read."""
    path = aot_types_path()

    def read() -> dict:
        import json

        types = json.loads(path.read_text())
        if not isinstance(types, dict):
            raise ValueError(f"{path}: not a table of kernels")
        return types

    try:
        return _recorded("aot_types", _file_key([path]), read, dict)
    except (OSError, ValueError):
        return {}


@functools.cache
def _checker(export: str) -> Callable[[list], bool] | None:
    """A function telling whether a list of leaf arguments has exactly the leaf types of
    ``export`` (:func:`lcs.build.aot.leaf_spec`), or None when the module does not record them.

    Written out as one expression per export, built once: a run checks about 110 leaves, and a
    generic per-leaf test (a call, a tuple unpacking and a dtype comparison each) was a tenth
    of what a short run costs outside the stepping. An array's dtype is compared by identity
    (numpy's native dtypes are singletons; any other, e.g. byte-swapped, falls back to numba),
    its class exactly (a subclass falls back too), so the test is never looser than numba's
    typing of the same value."""
    import numpy as np

    specs = _aot_types().get(export)
    if specs is None:
        return None
    env: dict = {"ndarray": np.ndarray, "np_bool": np.bool_, "np_int": np.integer,
                 "np_float": np.floating}
    terms = [f"len(a) == {len(specs)}"]
    for i, spec in enumerate(specs):
        v = f"a[{i}]"
        kind = spec[0]
        if kind == "array":
            _, dtype, ndim, layout, mutable = spec
            env[f"d{i}"] = np.dtype(dtype)
            term = f"type({v}) is ndarray and {v}.dtype is d{i} and {v}.ndim == {int(ndim)}"
            if layout == "C":
                term += f" and {v}.flags.c_contiguous"
            elif layout == "F":
                term += f" and {v}.flags.f_contiguous"
            if mutable:
                term += f" and {v}.flags.writeable"
        elif kind == "bool":
            term = f"(type({v}) is bool or type({v}) is np_bool)"
        elif kind == "int":
            term = f"(type({v}) is int or isinstance({v}, np_int))"
        elif kind == "float":
            term = (f"(type({v}) is float or type({v}) is int"
                    f" or isinstance({v}, (np_int, np_float)))")
        else:
            return None
        terms.append(f"({term})")
    src = "def check(a):\n    return (" + "\n            and ".join(terms) + ")\n"
    # (from source text, which the CLI's cache of compiled code (pelcs.code_cache) serves
    # instead of compiling it: the checks take 7 ms to compile; they hold no annotation, so
    # this module's __future__ import changes nothing in them)
    exec(src, env)
    return env["check"]
