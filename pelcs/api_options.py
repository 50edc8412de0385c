"""Python arguments as the options of a ``pelcs`` command: the analyses of the Python API
(:mod:`pelcs.api_analyses`) parse their keyword arguments with the command's own parser, so
that the names, the defaults and the checks are the command's.

A keyword argument is the option's name without the dashes, ``-`` as ``_`` (``--locate-tol``
is ``locate_tol``); ``True`` gives a flag (``follow=True`` is ``--follow``). Values may be
Python values as well as the command-line text:

- ``param``: a mapping ``{"vin": 24, "duty": "20:30:41", "r": (1, 10, 5), "c": [1e-6, 2e-6]}``
  (a number or text as on the command line, a tuple ``(START, STOP[, N])`` for a range, a list
  or array of explicit values), or the command-line items ``["vin=24", "duty=0.2:0.3:5"]``;
- ``probe``, ``measure``, ``tolerance``, ``start``: one text or a list of texts
  (``tolerance`` also a mapping ``{"C*": "10%"}``);
- ``x0``: a mapping ``{"v(C1)": 12}`` or text ``"v(C1)=12"``; ``grid``: a mapping of two
  states to ``(LO, HI, N)`` or the text ``"v(C1)=0:24:12,i(L1)=0:4:10"``;
- numbers (``period``, ``tstop``, ``step``, ...): a number (SI units) or SPICE text.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
from collections.abc import Mapping

import numpy as np

#: Options of the commands that write files or print: the API returns the result instead.
_NOT_TAKEN = {"json", "output", "plot", "report", "no_progress", "steps"}


def _number_text(v) -> str:
    """A number as exact text (``repr`` of the float: every digit kept)."""
    if isinstance(v, str):
        return v
    if isinstance(v, (bool, np.bool_)):
        raise TypeError(f"expected a number or text, got {v!r}")
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    return repr(float(v))


def _explicit_values(name: str, values, command: str) -> str:
    """Explicit values: ``V1,V2,...`` for ``sweep``; for the commands that take a range
    only, the range ``START:STOP:N`` they are the values of (else an error)."""
    vals = np.asarray(values, dtype=float).ravel()
    if command == "sweep":
        return f"{name}=" + ",".join(_number_text(v) for v in vals)
    if vals.size >= 2 and np.array_equal(vals, np.linspace(vals[0], vals[-1], vals.size)):
        return f"{name}={_number_text(vals[0])}:{_number_text(vals[-1])}:{vals.size}"
    raise ValueError(f"param {name}: pelcs {command} takes evenly spaced values (a range "
                     "START:STOP:N); give them as (START, STOP, N)")


def param_items(param, command: str) -> list[str]:
    """``param=`` as the command's ``--param`` items."""
    if param is None:
        return []
    if isinstance(param, str):
        return [param]
    if not isinstance(param, Mapping):
        return [str(p) for p in param]
    items = []
    for name, value in param.items():
        if isinstance(value, tuple):
            if len(value) not in (2, 3):
                raise ValueError(f"param {name}: a range is (START, STOP) or (START, STOP, N)")
            items.append(f"{name}=" + ":".join(_number_text(v) for v in value))
        elif isinstance(value, (list, np.ndarray)):
            items.append(_explicit_values(name, value, command))
        else:
            items.append(f"{name}={_number_text(value)}")
    return items


def _assignments(value) -> str:
    """``{"v(C1)": 12}`` as ``v(C1)=12``; text as it is."""
    if isinstance(value, Mapping):
        return ",".join(f"{k}={_number_text(v)}" for k, v in value.items())
    return str(value)


def _grid(value) -> str:
    if isinstance(value, Mapping):
        return ",".join(f"{k}=" + ":".join(_number_text(x) for x in v)
                        for k, v in value.items())
    return str(value)


def _texts(value) -> list[str]:
    if isinstance(value, Mapping):  # (tolerance={"C*": "10%"})
        return [f"{k}={_number_text(v)}" for k, v in value.items()]
    if isinstance(value, (str, os.PathLike)):
        return [str(value)]
    return [str(v) for v in value]


def namespace(command: str, file: str | os.PathLike, options: Mapping,
              *, function: str) -> argparse.Namespace:
    """The parsed options of ``pelcs COMMAND FILE ...`` for the keyword arguments
    ``options`` (None: not given), as the command's parser gives them.

    Raises
    ------
    TypeError
        A keyword the command has no option for, or a file that is not a path.
    ValueError
        A value the command's parser refuses (its message).
    """
    import importlib

    from pelcs.argparsing import Parser

    if not isinstance(file, (str, os.PathLike)):
        raise TypeError(f"{function}: expected the path of a netlist file, got "
                        f"{type(file).__name__} (the analyses read the netlist from its file)")
    # The command's own parser (as ``pelcs.cli`` builds it, without importing the CLI
    # module: that sets the process's BLAS thread variables, a command-line choice).
    parser = Parser(prog="pelcs")
    subparsers = parser.add_subparsers(dest="command")
    importlib.import_module(f"pelcs.commands.{command.replace('continue', 'continuation')}"
                            ).register(subparsers)
    sub = subparsers.choices[command]
    actions = {a.dest: a for a in sub._actions if a.option_strings}  # noqa: SLF001
    argv = [command, os.fspath(file)]
    for key, value in options.items():
        action = actions.get(key)
        if action is None or key in _NOT_TAKEN:
            known = sorted(k for k in actions if k not in _NOT_TAKEN | {"help"})
            raise TypeError(f"{function}() got an unexpected keyword argument {key!r}; "
                            f"options: {', '.join(known)}")
        if value is None or value is False:
            continue
        flag = action.option_strings[-1]
        if action.nargs == 0:  # (store_true)
            argv.append(flag)
            continue
        if key in ("param", "pelcs_param"):
            texts = param_items(value, command)
        elif key == "x0":
            texts = [_assignments(value)]
        elif key == "grid":
            texts = [_grid(value)]
        elif isinstance(action, argparse._AppendAction):  # noqa: SLF001 - argparse's
            texts = _texts(value)
        elif isinstance(value, (int, float, np.number)) and not isinstance(value, bool):
            texts = [_number_text(value)]
        else:
            texts = [str(value)]
        for text in texts:
            argv.append(f"{flag}={text}")
    if "no_progress" in actions:
        argv.append("--no-progress")  # (the API's progress: no bar in a notebook's cell)
    stderr = io.StringIO()
    try:
        with contextlib.redirect_stderr(stderr):
            return parser.parse_args(argv)
    except SystemExit:
        lines = [ln for ln in stderr.getvalue().splitlines() if ln.strip()]
        message = lines[-1].split("error: ", 1)[-1] if lines else "bad options"
        raise ValueError(f"{function}: {message}") from None

