"""The ``pelcs`` command line. Nothing imports this module.

Each subcommand lives in ``pelcs/commands/<name>.py`` and provides ``register(subparsers)``,
which adds its parser and sets ``func`` to a callable ``func(args) -> int``.

Exit status: 0 success, 1 a check failed (e.g. ``pelcs check`` out of tolerance), 2 an input
error (printed gcc-style on stderr, never a traceback), 3 a numerical failure.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from pelcs import __version__

COMMANDS = ["info", "lcs", "simulate", "check", "bifurcation", "orbit", "continue", "basins",
            "sweep", "ac"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="pelcs",
        description="Power-electronics netlists with ideal diodes and switches as linear "
        "complementarity systems.",
    )
    parser.add_argument("--version", action="version", version=f"pelcs {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        # "continue" is a Python keyword, so its module is named continuation.
        module = importlib.import_module(
            f"pelcs.commands.{name.replace('continue', 'continuation')}")
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    from netlist.errors import NetlistError

    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except NetlistError as exc:
        print(exc.format(), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pelcs: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
