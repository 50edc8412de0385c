"""numba's cache of each kernel module is stamped with what its compiled code can contain
(:func:`lcs.build.kernels.kernel_closure`): sound, so that no edit leaves a stale kernel in
use, and narrow, so that an edit recompiles only the kernels that can contain it."""

from __future__ import annotations

import importlib
import inspect
import os
import sys
from pathlib import Path

import pytest

from lcs.build import kernels

LCS = Path(kernels.__file__).resolve().parents[1]
ROOT = LCS.parent


def _module_name(path: Path) -> str:
    return ".".join(path.relative_to(ROOT).with_suffix("").parts)


def _defining_file(value) -> Path | None:
    """The source file of a kernel, function or class value, or None."""
    fn = getattr(value, "py_func", value)
    module = getattr(fn, "__module__", None)
    mod = sys.modules.get(module) if module else None
    f = getattr(mod, "__file__", None)
    return Path(f).resolve() if f else None


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("path", [f for f in kernels._kernel_files() if f.suffix == ".py"],
                         ids=lambda f: str(f.relative_to(LCS)))
def test_the_closure_holds_every_kernel_source_a_module_reaches(path):
    # Independent of the import parser: the kernel sources that define the values a module's
    # globals hold after Python imported it (functions, kernels, named tuples, modules), and
    # theirs in turn, must all be in its closure.
    files = set(kernels._kernel_files())
    closure = kernels.kernel_closure(path)
    todo, seen = [path], {path}
    while todo:
        mod = importlib.import_module(_module_name(todo.pop()))
        for value in vars(mod).values():
            f = (Path(value.__file__).resolve() if inspect.ismodule(value)
                 and getattr(value, "__file__", None) else _defining_file(value))
            if f in files and f not in seen:
                seen.add(f)
                todo.append(f)
    assert seen <= closure, sorted(str(f.relative_to(LCS)) for f in seen - closure)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_an_edit_recompiles_only_the_kernels_that_can_contain_it():
    dense = LCS / "integrators" / "moreau" / "dense"
    sparse = LCS / "integrators" / "moreau" / "sparse"
    grid = kernels.kernel_closure(dense / "grid.py")
    # The grid loop contains the step, the LCP solvers, the bit sets, the compiler's passes...
    assert {dense / "step.py", LCS / "lcp" / "compiled.py", LCS / "bits.py",
            LCS / "jit_passes.py"} <= grid
    # ... and nothing of the sparse kernel or the source-switching planner.
    assert not any(sparse in f.parents for f in grid)
    assert LCS / "simulation" / "source_switching.py" not in grid
    # The sparse kernel and the planner contain no dense code.
    for other in (sparse / "grid.py", LCS / "simulation" / "source_switching.py"):
        assert not any(dense / name in kernels.kernel_closure(other)
                       for name in ("grid.py", "step.py", "locate.py"))
    # The step does not contain the grid loop, which imports it.
    assert dense / "grid.py" not in kernels.kernel_closure(dense / "step.py")


def test_the_stamp_follows_the_closures_contents(tmp_path, monkeypatch):
    # A copy of the kernel sources: an edit of a file in a module's closure changes its stamp,
    # an edit elsewhere does not.
    import shutil

    copy = tmp_path / "lcs"
    shutil.copytree(LCS, copy, ignore=shutil.ignore_patterns("__pycache__", "prebuilt"))
    sources = tuple(copy / s.relative_to(LCS) for s in kernels.KERNEL_SOURCES)
    monkeypatch.setattr(kernels, "KERNEL_SOURCES", sources)
    monkeypatch.setattr(kernels, "_LCS", copy)
    for fn in (kernels.kernel_closure, kernels.module_stamp):
        fn.cache_clear()
    try:
        grid = copy / "integrators" / "moreau" / "dense" / "grid.py"
        before = kernels.module_stamp(grid)
        sparse_step = copy / "integrators" / "moreau" / "sparse" / "step.py"
        sparse_step.write_text(sparse_step.read_text() + "\n# edited\n")
        kernels.module_stamp.cache_clear()
        assert kernels.module_stamp(grid) == before
        step = copy / "integrators" / "moreau" / "dense" / "step.py"
        step.write_text(step.read_text() + "\n# edited\n")
        kernels.module_stamp.cache_clear()
        assert kernels.module_stamp(grid) != before
    finally:
        for fn in (kernels.kernel_closure, kernels.module_stamp):
            fn.cache_clear()


def test_the_stamp_record_serves_unchanged_sources_and_follows_an_edit(tmp_path, monkeypatch):
    # A start reads the AOT stamp from the machine's record while the sources' sizes and times
    # are those it was computed for; an edit (a new time and size) hashes them again, and a
    # damaged record is computed again and rewritten.
    import shutil

    copy = tmp_path / "lcs"
    shutil.copytree(LCS, copy, ignore=shutil.ignore_patterns("__pycache__", "prebuilt"))
    monkeypatch.setattr(kernels, "KERNEL_SOURCES",
                        tuple(copy / s.relative_to(LCS) for s in kernels.KERNEL_SOURCES))
    monkeypatch.setattr(kernels, "AOT_SOURCES",
                        tuple(copy / s.relative_to(LCS) for s in kernels.AOT_SOURCES))
    monkeypatch.setenv("PELCS_CACHE_DIR", str(tmp_path / "cache"))
    hashed = []
    real_digest = kernels._digest
    monkeypatch.setattr(kernels, "_digest",
                        lambda files, start=b"": hashed.append(len(files)) or
                        real_digest(files, start))

    def stamp() -> bytes:
        for fn in (kernels.aot_stamp, kernels.kernel_stamp, kernels._stamp_records):
            fn.cache_clear()
        return kernels.aot_stamp()

    try:
        first = stamp()
        assert hashed and (tmp_path / "cache" / kernels.STAMP_RECORD).is_file()
        hashed.clear()
        assert stamp() == first and not hashed  # read from the record, nothing hashed
        step = copy / "integrators" / "moreau" / "dense" / "step.py"
        step.write_text(step.read_text() + "\n# edited\n")
        edited = stamp()
        assert hashed and edited != first
        # The same size and modification time, other contents (an archive, `cp -p`): hashed.
        before = step.stat()
        step.write_text(step.read_text().replace("# edited", "# edit!d"))
        os.utime(step, ns=(before.st_atime_ns, before.st_mtime_ns))
        assert step.stat().st_size == before.st_size
        hashed.clear()
        assert stamp() not in (first, edited) and hashed
        step.write_text(step.read_text().replace("# edit!d", "# edited"))
        edited = stamp()
        # The record's value is the hash of the sources: the same as computing it afresh.
        hashed.clear()
        assert stamp() == edited == real_digest(kernels.AOT_SOURCES, real_digest(
            kernels._kernel_files())) and not hashed
        (tmp_path / "cache" / kernels.STAMP_RECORD).write_bytes(b"not a record")
        assert stamp() == edited and hashed
        hashed.clear()
        assert stamp() == edited and not hashed  # rewritten whole
    finally:
        for fn in (kernels.aot_stamp, kernels.kernel_stamp, kernels._stamp_records):
            fn.cache_clear()
