"""The ``pelcs`` command line. Nothing imports this module.

Each subcommand lives in ``pelcs/commands/<name>.py`` and provides ``register(subparsers)``,
which adds its parser and sets ``func`` to a callable ``func(args) -> int``.

Exit status: 0 success, 1 a check failed (e.g. ``pelcs check`` out of tolerance), 2 an input
error (printed gcc-style on stderr, never a traceback), 3 a numerical failure.
"""

from __future__ import annotations

import argparse
import gc
import importlib
import os
import sys

from pelcs import __version__  # (imports nothing: numpy is not loaded yet)
from pelcs.argparsing import Parser
from pelcs.code_cache import cached_code

# One BLAS thread: the matrices of a formulation are small, and OpenBLAS's second thread only
# spins beside the single-threaded kernels (15-30 % of a core measured on the scaling
# benchmark). Set before numpy is imported; a user's own setting wins.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

COMMANDS = ["info", "lcs", "simulate", "check", "bifurcation", "orbit", "continue", "basins",
            "sweep", "ac", "compile"]


def _wanted(argv: list[str] | None) -> list[str]:
    """The subcommands whose modules the parser needs: the one named on the command line, or
    all of them (for help, a mistyped command or none). Importing one command module instead
    of ten saves about 0.1 s of every run."""
    args = sys.argv[1:] if argv is None else argv
    first = next((a for a in args if not a.startswith("-")), None)
    if first in COMMANDS and not any(a in ("-h", "--help") for a in args[:args.index(first)]):
        return [first]
    if first is None and "--version" in args and not {"-h", "--help"} & set(args):
        return []  # (argparse acts on --version before it needs any command)
    return COMMANDS


def installed_version() -> str:
    """The version of the installed ``pelcs`` distribution (its metadata) when that is the
    pelcs running, else :data:`pelcs.__version__` (a checkout on the path, an editable
    installation: the same number, from the source). Imports ``importlib.metadata`` (about
    10 ms): only ``--version`` asks."""
    import importlib.metadata
    from pathlib import Path

    import pelcs

    try:
        dist = importlib.metadata.distribution("pelcs")
    except importlib.metadata.PackageNotFoundError:
        return __version__
    here = Path(pelcs.__file__).resolve()
    try:
        if Path(dist.locate_file("pelcs/__init__.py")).resolve() == here:
            return dist.version
    except (OSError, ValueError):
        pass
    return __version__


class _VersionAction(argparse.Action):
    """``--version``: the version read only when asked (argparse's own action formats a
    string built before parsing, for every command)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS,
                 help=None):
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0,
                         help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(f"pelcs {installed_version()}")
        parser.exit()


def build_parser(argv: list[str] | None = None, commands: list[str] | None = None
                 ) -> argparse.ArgumentParser:
    """The argument parser with the subcommands ``commands`` (default: those :func:`_wanted`
    finds in ``argv``)."""
    commands = _wanted(argv) if commands is None else commands
    parser = Parser(
        prog="pelcs",
        description="Power-electronics netlists with ideal diodes and switches as linear "
        "complementarity systems.",
    )
    parser.add_argument("--version", action=_VersionAction,
                        help="print pelcs's version (of the installed distribution) and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in commands:
        # "continue" is a Python keyword, so its module is named continuation.
        module = importlib.import_module(
            f"pelcs.commands.{name.replace('continue', 'continuation')}")
        module.register(sub)
    for name in commands:
        if name in ("info", "lcs", "compile"):
            continue  # they simulate nothing (lcs gives the full passivity verdict)
        sub.choices[name].add_argument(
            "--strict", action="store_true",
            help="refuse a circuit that is not passive, and transistors (M, Q) and device "
            "macro-models idealised as switches and diodes (default: warn and run the ideal "
            "model, which may grow without bound)")
    return parser


def bundled_netlist(path: str) -> str | None:
    """The installed copy of a bundled netlist named as in the checkout
    (``converters/netlists/buck.cir``) when ``path`` is such a name and no such file is
    in the current directory (pelcs installed by pip, run elsewhere), else None."""
    import importlib.util
    from pathlib import Path, PurePosixPath

    parts = PurePosixPath(path.replace("\\", "/")).parts
    if (len(parts) < 3 or parts[:2] != ("converters", "netlists") or ".." in parts
            or Path(path).exists()):
        return None
    spec = importlib.util.find_spec("converters")
    for root in (spec.submodule_search_locations or []) if spec else []:
        candidate = Path(root, *parts[1:])
        if candidate.is_file():
            return str(candidate)
    return None


#: the warnings a command has printed: each text once (the "once" filter alone is not enough:
#: Python forgets what it showed whenever a library changes the filters, as imports do)
_SHOWN: set[str] = set()


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    # A user-facing one-liner, not Python's "file:line: Category: ..." with a source line.
    text = str(message)
    if text not in _SHOWN:
        _SHOWN.add(text)
        print(f"warning: {text}", file=sys.stderr)


#: The cyclic garbage collector's first threshold during a command (Python's default is 700
#: allocations): a command creates its modules, classes and circuit (objects that all stay
#: alive) at start-up, through which the default runs some 80 collections, 5 % of a short
#: command's CPU time. Garbage cycles are still collected, every 100,000 allocations.
GC_THRESHOLD = 100_000


def main(argv: list[str] | None = None) -> int:
    thresholds = gc.get_threshold()
    gc.set_threshold(GC_THRESHOLD, *thresholds[1:])
    try:
        # (the command's modules are imported inside: their dataclasses' methods and the
        # kernels' argument checks are compiled once per machine, not at every start)
        wanted = _wanted(argv)
        with cached_code(wanted[0] if len(wanted) == 1 else ""):
            return _main(argv)
    finally:
        gc.set_threshold(*thresholds)


def _main(argv: list[str] | None) -> int:
    from netlist.errors import NetlistError

    parser = build_parser(argv)
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    file = getattr(args, "file", None)
    if isinstance(file, str) and (copy := bundled_netlist(file)) is not None:
        print(f"pelcs: {file} is not in this directory: running pelcs's bundled copy {copy}",
              file=sys.stderr)
        args.file = copy
    import warnings

    from lcs.notices import IdealisedDeviceWarning, NonPassiveWarning

    _SHOWN.clear()
    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        for category in (NonPassiveWarning, IdealisedDeviceWarning):
            warnings.simplefilter("error" if getattr(args, "strict", False) else "once",
                                  category)
        if args.command not in _OWN_COMPILE_NOTE:
            _announce_compiles()
        try:
            return int(args.func(args) or 0)
        except IdealisedDeviceWarning as exc:
            from netlist.errors import Diagnostic

            location = getattr(exc, "location", None)
            message = getattr(exc, "what", None) if location is not None else None
            print(Diagnostic(message or str(exc), location,
                             "--strict refuses transistors (M, Q) and device macro-models; "
                             "drop it to simulate them as ideal switches and diodes").format(),
                  file=sys.stderr)
            # each of the others where it is (a line once: a subcircuit's device in many
            # instances), the first few
            shown = {location}
            for element, loc in getattr(exc, "locations", [])[:8]:
                if loc is not None and loc not in shown:
                    shown.add(loc)
                    print(Diagnostic(f"{element}: idealised (refused by --strict)",
                                     loc).format(), file=sys.stderr)
            return 2
        except NonPassiveWarning as exc:
            text = str(exc).split("; the run follows the ideal model")[0]
            print(f"error: {text}\n  hint: --strict refuses a circuit that is not passive; "
                  "drop it to run the ideal model anyway (`pelcs lcs FILE` checks every mode)",
                  file=sys.stderr)
            return 2
        except NetlistError as exc:
            print(exc.format(), file=sys.stderr)
            return 2
        except KeyboardInterrupt:
            print("pelcs: interrupted", file=sys.stderr)
            return 130
        except BrokenPipeError:
            return 0
        finally:
            if args.command != "compile":
                _after_run()


# Commands that say themselves that they compile the kernels (simulate before it loads them),
# or that run none.
_OWN_COMPILE_NOTE = ("simulate", "compile", "info")


def _announce_compiles() -> None:
    """Have the first compile of a kernel in this process said on stderr (after a ``pip
    install``, the first command compiles the kernels: minutes)."""
    from lcs.build.kernel_setup import announce_compiles

    announce_compiles(lambda text: print(text, file=sys.stderr, flush=True))


def _after_run() -> None:
    """After a command that ran the kernels from numba's cache: the ahead-of-time module's
    background build, said in one line (:func:`lcs.build.kernel_setup.after_run`)."""
    jit = sys.modules.get("lcs.jit")
    if jit is None or not jit.materialized():
        return  # (no numba in this process: nothing to link, and nothing imported here)
    from lcs.build.kernel_setup import after_run

    line = after_run()
    if line is not None:
        print(line, file=sys.stderr, flush=True)


if __name__ == "__main__":
    sys.exit(main())
