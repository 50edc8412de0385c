"""The integrators' compiled functions (``kernel``, ``inline``, ``jitted``), compiled on first use.

The kernels are written as small functions (a θ step, the step's LCP, a crossing test) that
the loops call; ``inline`` marks them for numba's IR inlining, so that a loop pays no call, and
``kernel`` compiles with the passes of :mod:`lcs.jit_passes` (copies forwarded, tuple fields
hoisted), which make an inlined step compile to the same code as a hand-written loop.

Nothing is compiled, and numba is not even imported, when a module of kernels is imported:
the decorators return a :class:`Kernel`, which

* called from Python, runs the ahead-of-time module's function when that module exists for the
  current sources and exports this kernel (:mod:`lcs.build.kernels`; a short run then never imports
  numba: about 0.6 s less per command);
* otherwise, and on any other use (``.signatures``, ``.py_func``...), calls
  :func:`materialize`, which imports numba and :mod:`lcs.jit_passes`, makes every kernel's
  numba dispatcher (compiled, or loaded from numba's on-disk cache on its first call), and puts
  the dispatchers in place of the :class:`Kernel` objects in the modules that define kernels
  (numba resolves a kernel's callees through its module's globals at compile time). Python
  callers elsewhere keep the :class:`Kernel`, which forwards to the dispatcher.

``PELCS_AOT=0`` forces numba.
"""

from __future__ import annotations

import functools
import sys
import threading
from collections.abc import Callable

from .build import kernels

__all__ = ["Kernel", "inline", "jitted", "kernel", "materialize", "materialized"]

_KERNELS: list[Kernel] = []
_LOCK = threading.RLock()
_STATE = {"numba": False}


def materialized() -> bool:
    """Whether numba has been imported and the kernels' dispatchers made."""
    return _STATE["numba"]


class Kernel:
    """A function compiled by numba on first use, or run from the ahead-of-time module.

    Parameters
    ----------
    fn : callable
        The Python source of the kernel.
    options : dict
        ``njit`` options; ``pipeline="kernel"`` selects
        :class:`lcs.jit_passes.KernelCompiler`.
    """

    def __init__(self, fn: Callable, options: dict):
        self.py_func = fn
        self._options = options
        self._dispatcher = None
        functools.update_wrapper(self, fn)

    def _make(self):
        from numba import njit

        opts = dict(self._options)
        if opts.pop("pipeline", None) == "kernel":
            from .jit_passes import KernelCompiler

            opts["pipeline_class"] = KernelCompiler
        dispatcher = njit(**opts)(self.py_func)
        dispatcher.get_call_template = functools.partial(_call_template, dispatcher)
        self._dispatcher = dispatcher
        return dispatcher

    @property
    def dispatcher(self):
        """The numba dispatcher (imports numba and makes every kernel's dispatcher)."""
        if self._dispatcher is None:
            materialize()
        return self._dispatcher

    def __call__(self, *args):
        bound = kernels.aot_function(self.py_func.__module__, self.py_func.__name__, args)
        if bound is not None:
            return bound()
        return self.dispatcher(*args)

    def __reduce__(self):
        # Pickled by name (process pools): the module defines it again on import.
        return _kernel_by_name, (self.py_func.__module__, self.py_func.__qualname__)

    def __getattr__(self, name):
        # Only reached for attributes a Kernel does not have: the dispatcher's (signatures,
        # overloads, stats, and _numba_type_ when numba types a call to it).
        if name.startswith("__") or name in ("_options", "_dispatcher", "py_func"):
            raise AttributeError(name)
        return getattr(self.dispatcher, name)

    def __repr__(self) -> str:
        return f"<pelcs kernel {self.py_func.__module__}.{self.py_func.__qualname__}>"


def _call_template(dispatcher, args, kws):
    """numba's ``Dispatcher.get_call_template`` for a call from compiled code, with the
    argument types made non-literal.

    numba compiles a callee for the types at the call site, and a constant argument there is
    a literal type (``Literal[int](0)``, ``Literal[bool](True)``): every distinct constant made
    a specialisation of its own, compiled again (``mode_step`` six times, ``factor_update``
    four). A kernel never needs a literal argument; its branches on a flag cost a predictable
    branch at run time, and one specialisation is compiled once.
    """
    from numba.core import types

    args = tuple(types.unliteral(a) for a in args)
    kws = {k: types.unliteral(v) for k, v in kws.items()}
    return type(dispatcher).get_call_template(dispatcher, args, kws)


def _kernel_by_name(module: str, qualname: str):
    import importlib

    return getattr(importlib.import_module(module), qualname)


def _decorate(fn, options):
    k = Kernel(fn, options)
    _KERNELS.append(k)
    # After materialize, a module of kernels imported now gets dispatchers directly.
    return k._make() if _STATE["numba"] else k


def kernel(fn=None, **options):
    """``njit(cache=True)`` with the :class:`lcs.jit_passes.KernelCompiler` pipeline."""
    opts = {"cache": True, "pipeline": "kernel", **options}
    if fn is None:
        return lambda f: _decorate(f, opts)
    return _decorate(fn, opts)


def inline(fn):
    """A small kernel piece inlined at numba's IR level into every kernel that calls it."""
    return _decorate(fn, {"cache": True, "inline": "always"})


def jitted(fn):
    """Plain ``njit(cache=True)``, compiled on first use."""
    return _decorate(fn, {"cache": True})


def materialize() -> None:
    """Import numba, make every kernel's dispatcher and bind the dispatchers in the modules
    that define kernels (idempotent, thread-safe)."""
    with _LOCK:
        if _STATE["numba"]:
            return
        from . import jit_passes  # noqa: F401  (registers the cache locator)

        for k in _KERNELS:
            if k._dispatcher is None:
                k._make()
        _STATE["numba"] = True
        by_module: dict[str, dict] = {}
        for k in _KERNELS:
            by_module.setdefault(k.py_func.__module__, {})
        for name in by_module:
            mod = sys.modules.get(name)
            if mod is None:
                continue
            for attr, value in list(vars(mod).items()):
                if isinstance(value, Kernel):
                    setattr(mod, attr, value._dispatcher)
