"""Numba compiler passes and cache location of the integrators' kernels (imports numba).

Imported by :func:`lcs.jit.materialize` when a kernel is first compiled or loaded from numba's
cache, never on the path of a run served by the ahead-of-time module (:mod:`lcs.build.kernels`).

:class:`ForwardCopies`: numba's inliner binds each parameter of an inlined function by a copy of
the caller's variable (``param = arg``), and a copy of an array (or of a tuple of arrays) is a
reference count increment and decrement, atomic, on every pass through a loop: measured, a
4-pair active-set step went from 5 ns hand-written to 27 ns inlined, and a loop over a mode's
25 arrays to 200 ns. The pass replaces such copies by the variable they copy wherever that is
exact, so that an inlined step compiles to the same code as the hand-written loop.

Cache freshness: numba keys a cached function on the contents of its own source file, while a
compiled kernel contains the code of every function it calls or inlines from other files (and
of this module's passes). Functions defined in :data:`lcs.build.kernels.KERNEL_SOURCES` are
therefore cached under the stamp of their module and every kernel source it imports,
transitively, with the compiler's files (:func:`lcs.build.kernels.module_stamp`,
:class:`KernelCacheLocator`): an edit recompiles the kernels that can contain the edited code,
and only those.
"""

from __future__ import annotations

import copy
import os
import shutil
import tempfile
from pathlib import Path

from numba.core import caching, inline_closurecall, ir, types
from numba.core.analysis import compute_cfg_from_blocks
from numba.core.compiler import CompilerBase, DefaultPassBuilder
from numba.core.compiler_machinery import FunctionPass, register_pass
from numba.core.ir_utils import replace_vars_stmt
from numba.core.typed_passes import InlineOverloads
from numba.core.untyped_passes import InlineInlinables

from .build.kernels import KERNEL_SOURCES, module_stamp

__all__ = ["ForwardCopies", "HoistTupleFields", "KernelCacheLocator", "KernelCompiler",
           "forward_copies"]


class _BlockCopier:
    """What :mod:`numba.core.inline_closurecall` sees as its ``copy`` module: ``deepcopy`` of
    the blocks of one function's IR with one memo for all of them.

    numba's inliner copies a callee's IR block by block (``copy_ir``, the module's only use of
    ``copy``), each with a memo of its own, and every block refers to the function's scope,
    which holds every variable of the function: the scope was copied once per block, a
    callee's copy cost blocks x variables, and with the kernels' nested inlining those copies
    were about a quarter of the whole compile (under the profiler). One memo per function
    (its blocks share one scope) copies the scope once; the copy is the same IR, with the
    sharing the original has.

    The memo is dropped when a block of another scope comes (the next IR) or a block already
    in it (the same IR copied again): two copies never share anything.
    """

    def __init__(self):
        self._memo: dict = {}
        self._scope = None

    def deepcopy(self, x, memo=None):
        if memo is not None or not isinstance(x, ir.Block):
            return copy.deepcopy(x, memo)
        if x.scope is not self._scope or id(x) in self._memo:
            self._memo = {}
            self._scope = x.scope
        return copy.deepcopy(x, self._memo)

    def __getattr__(self, name):
        return getattr(copy, name)


if not isinstance(inline_closurecall.copy, _BlockCopier):
    inline_closurecall.copy = _BlockCopier()

class KernelCacheLocator(caching._CacheLocator):
    """Numba's own cache location for a kernel source file, in a subdirectory named after the
    module and its :func:`~lcs.build.kernels.module_stamp`, which is also the freshness stamp.

    A new subdirectory per version of what the module's kernels contain: numba unpickles a
    cache index before it compares stamps, so an index written by another version (whose
    named-tuple types may no longer exist) must never be read. The module's subdirectories of
    other versions, and those of the single stamp over every kernel source that came before,
    are removed when a new one is made.
    """

    def __init__(self, inner, py_file):
        self._inner = inner
        self._file = Path(py_file).resolve()

    def _name(self) -> str:
        return f"kernels-{self._file.stem}-{module_stamp(self._file).hex()[:16]}"

    def ensure_cache_path(self):
        path = Path(self.get_cache_path())
        if not path.is_dir():
            parent = Path(self._inner.get_cache_path())
            for old in parent.glob("kernels-*"):
                rest = old.name[len("kernels-"):]
                legacy = len(rest) == 16 and "-" not in rest
                if old != path and (legacy or old.name.rsplit("-", 1)[0]
                                    == f"kernels-{self._file.stem}"):
                    shutil.rmtree(old, ignore_errors=True)
        os.makedirs(path, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()

    def get_cache_path(self):
        return os.path.join(self._inner.get_cache_path(), self._name())

    def get_source_stamp(self):
        return module_stamp(self._file)

    def get_disambiguator(self):
        return self._inner.get_disambiguator()

    @classmethod
    def from_function(cls, py_func, py_file):
        path = Path(py_file).resolve()
        if not any(path == s or s in path.parents for s in KERNEL_SOURCES):
            return None
        for other in caching.CacheImpl._locator_classes:
            if other is cls:
                continue
            loc = other.from_function(py_func, py_file)
            if loc is not None:
                return cls(loc, py_file)
        return None


if KernelCacheLocator not in caching.CacheImpl._locator_classes:
    caching.CacheImpl._locator_classes.insert(0, KernelCacheLocator)


def _defs_and_uses(blocks):
    """Per variable name: the (block, index) of its assignments, and of the statements that
    read it."""
    defs: dict[str, list[tuple[int, int]]] = {}
    uses: dict[str, list[tuple[int, int]]] = {}
    for label, blk in blocks.items():
        for i, st in enumerate(blk.body):
            for v in st.list_vars():
                if isinstance(st, ir.Assign) and v.name == st.target.name:
                    continue
                uses.setdefault(v.name, []).append((label, i))
            if isinstance(st, ir.Assign):
                defs.setdefault(st.target.name, []).append((label, i))
    return defs, uses


def _reach(edges, starts, blocked):
    """Blocks reachable from ``starts`` along ``edges`` without entering ``blocked``."""
    seen = set()
    todo = [b for b in starts if b != blocked]
    while todo:
        b = todo.pop()
        if b in seen:
            continue
        seen.add(b)
        todo.extend(n for n in edges.get(b, ()) if n != blocked and n not in seen)
    return seen


class _Graph:
    """The control-flow graph's successors and predecessors, and the reachability sets the
    exactness test asks for, each computed once (the test asks the same sets for many copies:
    computed per copy they made most of a large kernel's compile time)."""

    def __init__(self, blocks):
        cfg = compute_cfg_from_blocks(blocks)
        self.succ = {b: [n for n, _ in cfg.successors(b)] for b in cfg.nodes()}
        self.pred = {b: [n for n, _ in cfg.predecessors(b)] for b in cfg.nodes()}
        self._fwd: dict[int, set] = {}
        self._back: dict[tuple[int, int], set] = {}

    def forward(self, L):
        """Blocks entered after leaving ``L`` before entering it again."""
        got = self._fwd.get(L)
        if got is None:
            got = self._fwd[L] = _reach(self.succ, self.succ.get(L, ()), L)
        return got

    def backward(self, b, L):
        """Blocks from which ``b`` is entered without passing through ``L``."""
        got = self._back.get((b, L))
        if got is None:
            got = self._back[(b, L)] = _reach(self.pred, self.pred.get(b, ()), L)
        return got


def forward_copies(func_ir) -> bool:
    """Apply :class:`ForwardCopies` to ``func_ir`` in place; True when something changed."""
    blocks = func_ir.blocks
    arg_names = set(func_ir.arg_names)
    changed = False
    # (statements are only dropped, never blocks or edges: one graph for every round)
    graph = _Graph(blocks)
    for _ in range(50):  # chains of copies: a few rounds
        defs, uses = _defs_and_uses(blocks)
        repl: dict[str, ir.Var] = {}
        drop: set[tuple[int, int]] = set()
        for label, blk in blocks.items():
            for i, st in enumerate(blk.body):
                if not (isinstance(st, ir.Assign) and isinstance(st.value, ir.Var)):
                    continue
                t, s = st.target.name, st.value.name
                if (t == s or t in arg_names or len(defs.get(t, ())) != 1 or t in repl
                        or s in repl):
                    continue
                if ForwardCopies._exact(graph, defs, uses, label, i, t, s):
                    repl[t] = st.value
                    drop.add((label, i))
        if not repl:
            break
        for label, blk in blocks.items():
            body = []
            for i, st in enumerate(blk.body):
                if (label, i) in drop:
                    continue
                replace_vars_stmt(st, repl)
                body.append(st)
            blk.body = body
        changed = True
    return changed


@register_pass(mutates_CFG=False, analysis_only=False)
class ForwardCopies(FunctionPass):
    """Replace ``t = s`` (variables) by ``s`` in the uses of ``t`` when that is exact.

    Exact when ``t`` is assigned only there, and no assignment of ``s`` can run between that
    statement and a use of ``t`` (checked on the control-flow graph: no definition of ``s`` on
    a path from the copy to a use that does not pass the copy again, nor after the copy in its
    block before a use there).
    """

    _name = "forward_copies"

    def __init__(self):
        FunctionPass.__init__(self)

    def run_pass(self, state):
        return forward_copies(state.func_ir)

    @staticmethod
    def _exact(graph, defs, uses, L, i, t, s):
        """Whether no assignment of ``s`` can run between the copy (block ``L``, statement
        ``i``) and a use of ``t`` without the copy running again."""
        s_defs = defs.get(s, [])
        s_in = {}
        for b, j in s_defs:
            s_in.setdefault(b, []).append(j)
        after_copy = any(j > i for j in s_in.get(L, ()))
        # Blocks entered after the copy before it runs again (entering L runs it again).
        fwd = graph.forward(L)
        # (the definitions of s that can run after the copy: only those can spoil a use)
        s_fwd = [blk for blk in s_in if blk in fwd]
        for b, j in uses.get(t, []):
            if b == L and j > i:
                if any(i < k < j for k in s_in.get(L, ())):
                    return False
                continue
            if b == L:
                # Reached around a loop: L's tail, the blocks back to L, L's head.
                if after_copy or any(k < j for k in s_in.get(L, ())):
                    return False
            else:
                if b not in fwd:
                    continue  # only reached through the copy again
                if after_copy or any(k < j for k in s_in.get(b, ())):
                    return False
            if s_fwd:
                back = graph.backward(b, L)
                if any(blk in back for blk in s_fwd):
                    return False
        return True


@register_pass(mutates_CFG=False, analysis_only=False)
class HoistTupleFields(FunctionPass):
    """Read each field of a named tuple once per assignment of the tuple.

    ``a = t.X`` inside a loop takes a new reference to the field on every pass; the kernels
    bind a mode's named tuple once per mode change and read its fields in every step. This
    pass adds ``t.X`` right after every assignment of ``t`` into a variable of its own and
    turns the reads into copies of it, which :func:`forward_copies` then removes: the field is
    read where the tuple changes, as a hand-written kernel binds its arrays. Exact because
    tuples are immutable.
    """

    _name = "hoist_tuple_fields"

    def __init__(self):
        FunctionPass.__init__(self)

    def run_pass(self, state):
        typemap = state.typemap
        blocks = state.func_ir.blocks
        changed = False
        made: set[str] = set()
        for _ in range(10):  # nested tuples: one level per round
            defs: dict[str, list[tuple[int, int]]] = {}
            reads: dict[tuple[str, object], list[ir.Assign]] = {}
            for label, blk in blocks.items():
                for i, st in enumerate(blk.body):
                    if not isinstance(st, ir.Assign):
                        continue
                    defs.setdefault(st.target.name, []).append((label, i))
                    ex = st.value
                    if (isinstance(ex, ir.Expr) and ex.op == "getattr"
                            and st.target.name not in made
                            and isinstance(typemap.get(ex.value.name), types.BaseTuple)):
                        reads.setdefault((ex.value.name, ex.attr), []).append(st)
            # Outermost tuples first: a tuple that is itself read from a tuple becomes a copy
            # of a hoisted variable this round, and its fields are hoisted from that next.
            inner = {st.target.name for sts in reads.values() for st in sts}
            todo = {k: v for k, v in reads.items() if defs.get(k[0]) and k[0] not in inner}
            if not todo:
                break
            inserts: dict[int, list[tuple[int, ir.Assign]]] = {}
            for (base, key), sts in todo.items():
                first = sts[0]
                var = ir.Var(first.target.scope, f"{base}.{key}$h{len(made)}", first.loc)
                made.add(var.name)
                typemap[var.name] = typemap[first.target.name]
                for label, i in defs[base]:
                    get = ir.Expr.getattr(blocks[label].body[i].target, key, first.loc)
                    inserts.setdefault(label, []).append((i, ir.Assign(get, var, first.loc)))
                for st in sts:
                    st.value = var
            for label, items in inserts.items():
                body = blocks[label].body
                for i, st in sorted(items, key=lambda e: -e[0]):
                    body.insert(i + 1, st)
            # (the reads are copies now; forwarding them exposes the next level's reads on
            # the hoisted variables)
            forward_copies(state.func_ir)
            changed = True
        return changed


class KernelCompiler(CompilerBase):
    """numba's nopython pipeline with :class:`ForwardCopies` after function inlining."""

    def define_pipelines(self):
        pm = DefaultPassBuilder.define_nopython_pipeline(self.state)
        pm.add_pass_after(ForwardCopies, InlineInlinables)
        pm.add_pass_after(HoistTupleFields, InlineOverloads)
        pm.finalize()
        return [pm]
