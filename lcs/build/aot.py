"""Ahead-of-time compilation of the Moreau kernels into an extension module (numba's ``pycc``).

A short simulation spends most of its time before the first step: importing numba (about
0.2 s), numba's first-use set-up of its typing and target contexts (about 0.2 s) and loading
each cached kernel from disk (about 0.03 s each). The extension module built here contains
the same compiled kernels (the cached numba libraries, linked in as LLVM bitcode, so the code
is the one the JIT runs) behind flat entry points that take every array as an argument;
loading it takes milliseconds and imports nothing but numpy. :mod:`lcs.build.kernels` loads it when
it was built from the current kernel sources (:func:`lcs.build.kernels.kernel_stamp`) and falls back
to numba otherwise.

Build it with ``python -m lcs.build.aot`` (``scripts/setup`` does, after compiling the kernels).
The kernels' argument types do not depend on the circuit (:mod:`lcs.build.warmup`), so
the signatures exported are those :func:`~lcs.build.warmup.warm_up` compiles.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import sys
import tempfile
import time
import warnings
from pathlib import Path

from numba.core import types

from . import kernels

__all__ = ["build", "build_prebuilt", "flat_wrapper", "stale_modules"]


def _leaves(ty, names: list[str], out: list):
    """Source text building a value of numba type ``ty`` from new leaf arguments appended to
    ``out`` (their types), with namedtuple classes recorded in ``names``."""
    if isinstance(ty, (types.NamedTuple, types.NamedUniTuple)):
        cls = ty.instance_class
        if cls not in names:
            names.append(cls)
        inner = ", ".join(_leaves(t, names, out) for t in ty.types)
        return f"_C{names.index(cls)}({inner})"
    if isinstance(ty, types.NoneType):
        return "None"
    out.append(ty)
    return f"a{len(out) - 1}"


def flat_wrapper(dispatcher, sig):
    """A jitted function taking the leaves of ``sig`` (arrays and scalars, depth first) and
    calling ``dispatcher`` with the named tuples rebuilt; returns (function, leaf types)."""
    from numba import njit

    classes: list = []
    leaf_types: list = []
    call = ", ".join(_leaves(t, classes, leaf_types) for t in sig)
    params = ", ".join(f"a{i}" for i in range(len(leaf_types)))
    src = f"def _flat({params}):\n    return _target({call})\n"
    env = {"_target": dispatcher, **{f"_C{i}": c for i, c in enumerate(classes)}}
    exec(compile(src, f"<flat {dispatcher.__name__}>", "exec"), env)
    return njit(env["_flat"]), leaf_types


def leaf_spec(ty) -> list:
    """A JSON-able description of a leaf argument type, checked by
    :func:`lcs.build.kernels.aot_function` before every call: ``["array", dtype, ndim, layout,
    mutable]``, ``["int"]``, ``["float"]`` or ``["bool"]``."""
    if isinstance(ty, types.Array):
        return ["array", str(ty.dtype), int(ty.ndim), str(ty.layout), bool(ty.mutable)]
    if isinstance(ty, types.Boolean):
        return ["bool"]
    if isinstance(ty, types.Integer):
        return ["int"]
    if isinstance(ty, types.Float):
        return ["float"]
    raise TypeError(f"no ahead-of-time argument check for numba type {ty}")


def build(out_dir: Path | None = None, verbose: bool = False, cpu: str | None = None) -> Path:
    """Compile (or load from numba's cache) every kernel specialisation, then link them into
    the extension module of :func:`lcs.build.kernels.aot_path` (or ``out_dir``); returns its
    path. ``cpu``: LLVM's name of the processor to compile for (default: this one), which
    numba's JIT must also have compiled the kernels for (:func:`build_prebuilt`)."""
    from numba.core.errors import NumbaPendingDeprecationWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaPendingDeprecationWarning)
        from numba.pycc import CC

    from .warmup import warm_up

    t0 = time.perf_counter()
    with _through_numba():
        warm_up(parallel=True)
    target = kernels.aot_path() if out_dir is None else Path(out_dir) / kernels.aot_filename()
    name = kernels.AOT_MODULE
    cc = CC(name)
    cc.verbose = verbose
    # For this processor, as numba's JIT compiles (the module's path names its extensions,
    # kernels.cpu_tag); the portable generic target only where they cannot be told.
    host = cpu is None and kernels.cpu_tag() != "generic"
    cc.target_cpu = "host" if host else (cpu or "")
    specs = {}
    for export, dispatcher in kernels.exported_dispatchers():
        sigs = dispatcher.signatures
        if len(sigs) != 1:
            raise RuntimeError(f"{dispatcher.__name__}: {len(sigs)} signatures after warm_up "
                               f"(want 1)")
        sig = sigs[0]
        fn, leaf_types = flat_wrapper(dispatcher, sig)
        specs[export] = [leaf_spec(t) for t in leaf_types]
        ret = dispatcher.overloads[sig].signature.return_type
        cc.export(export, ret(*leaf_types))(fn.py_func)
    tmp = Path(tempfile.mkdtemp(prefix="pelcs-aot-"))
    try:
        cc.output_dir = str(tmp)
        with _host_features(host), _no_second_optimisation():
            cc.compile()
        built = tmp / Path(cc._output_file).name
        target.parent.mkdir(parents=True, exist_ok=True)
        part = target.with_suffix(".part")
        types_file = target.with_name(name + ".types.json")
        types_file.write_text(json.dumps(specs))
        shutil.copyfile(built, part)
        os.replace(part, target)
        if out_dir is None:
            for old in stale_modules(target.parent):
                shutil.rmtree(old, ignore_errors=True)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if verbose:
        print(f"built {target} in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return target


def build_prebuilt(verbose: bool = False) -> Path:
    """Build the module shipped in the package (:data:`lcs.build.kernels.PREBUILT`) for the
    processor level :data:`~lcs.build.kernels.PREBUILT_CPU` and this interpreter, from an
    empty numba cache, beside the modules other interpreters built from the same sources
    (``scripts/prebuild`` runs it with each of :data:`~lcs.build.kernels.PREBUILT_PYTHONS`),
    and remove the prebuilt modules of other kernel sources; returns its path.

    The kernels are compiled in a child process whose numba JIT targets that level with no
    other extension (``NUMBA_CPU_NAME``, ``NUMBA_CPU_FEATURES``), the code the module links;
    the module's stamp is the sources' (:func:`lcs.build.kernels.aot_stamp`), so a kernel
    edit makes it stale until this is run again (``tests/test_prebuilt.py`` says so)."""
    import subprocess

    target_dir = kernels.prebuilt_dir()
    with tempfile.TemporaryDirectory(prefix="pelcs-prebuilt-") as tmp:
        env = {k: v for k, v in os.environ.items() if not k.startswith(("PELCS_", "NUMBA_"))}
        env.update(NUMBA_CPU_NAME=kernels.PREBUILT_CPU, NUMBA_CPU_FEATURES="",
                   NUMBA_CACHE_DIR=str(Path(tmp) / "numba"), PELCS_AOT="0",
                   PELCS_CACHE_DIR=str(Path(tmp) / "cache"))
        out = Path(tmp) / "out"
        script = ("import sys; from lcs.build.aot import build; "
                  f"build(out_dir={str(out)!r}, verbose={verbose!r}, "
                  f"cpu={kernels.PREBUILT_CPU!r})")
        subprocess.run([sys.executable, "-c", script], env=env, check=True,
                       cwd=kernels.PREBUILT.parents[2])
        part = target_dir.with_name(target_dir.name + ".part")
        shutil.rmtree(part, ignore_errors=True)
        # (the modules other interpreters built from the same sources stay beside this one;
        # the argument types are the kernels', the same for every interpreter)
        if target_dir.is_dir():
            shutil.copytree(target_dir, part)
        else:
            part.mkdir(parents=True)
        types_file = kernels.AOT_MODULE + ".types.json"
        if (part / types_file).is_file() and \
                (part / types_file).read_bytes() != (out / types_file).read_bytes():
            raise RuntimeError(f"{sys.executable}: the kernels' argument types differ from "
                               f"those of the modules already in {target_dir}")
        for f in out.iterdir():
            shutil.copyfile(f, part / f.name)
        shutil.rmtree(target_dir, ignore_errors=True)
        os.replace(part, target_dir)
    for old in kernels.PREBUILT.glob("aot-*"):
        if old != target_dir:
            shutil.rmtree(old, ignore_errors=True)
    return target_dir / kernels.aot_filename()


def stale_modules(current: Path) -> list[Path]:
    """The directories of modules of other kernel versions for the same machine, processor
    and numba as ``current`` (``aot-STAMP-MACHINE-cpuTAG-numbaVERSION``) beside it: stale for
    good. Another processor's, in a home directory a cluster shares, are that node's."""
    suffix = current.name.split("-", 2)[2]
    return sorted(p for p in current.parent.glob(f"aot-*-{suffix}") if p != current)


@contextlib.contextmanager
def _through_numba():
    """Run the kernels through numba's dispatchers, not an extension module already built
    (rebuilding it: the warm-up must make the dispatchers' signatures, which the module's
    functions would bypass)."""
    before = os.environ.get("PELCS_AOT")
    os.environ["PELCS_AOT"] = "0"
    kernels.aot_module.cache_clear()
    try:
        yield
    finally:
        if before is None:
            os.environ.pop("PELCS_AOT", None)
        else:
            os.environ["PELCS_AOT"] = before
        kernels.aot_module.cache_clear()


@contextlib.contextmanager
def _no_second_optimisation():
    """Link the kernels as the JIT optimised them, without optimising the whole module again.

    pycc runs LLVM's module pipeline (-O3) over the extension's module, which holds a copy of
    every kernel's already optimised code: about 10 s of the link's CPU, for code the JIT
    cache already holds optimised. The flat wrappers it adds were optimised function by
    function when they were lowered.
    """
    from numba.core import codegen

    cls = getattr(codegen, "AOTCodeLibrary", None)
    if cls is None or not hasattr(cls, "_optimize_final_module"):
        yield
        return
    original = cls._optimize_final_module
    cls._optimize_final_module = lambda self: None
    try:
        yield
    finally:
        cls._optimize_final_module = original


@contextlib.contextmanager
def _host_features(host: bool):
    """Compile for the host's instruction-set extensions as LLVM reports them, as numba's JIT
    does: pycc's ``target_cpu = "host"`` alone takes the processor model's name and every
    extension that model implies, which a virtual machine may mask (an illegal instruction
    at the first call)."""
    from numba.core import codegen

    cls = getattr(codegen, "AOTCPUCodegen", None)
    if not host or cls is None or not hasattr(cls, "_customize_tm_features"):
        yield
        return
    features = codegen.get_host_cpu_features()
    original = cls._customize_tm_features
    cls._customize_tm_features = lambda self: features
    try:
        yield
    finally:
        cls._customize_tm_features = original


if __name__ == "__main__":
    if "--prebuilt" in sys.argv[1:]:
        print(build_prebuilt(verbose="-v" in sys.argv[1:]))
    else:
        print(build(verbose="-v" in sys.argv[1:]))
