"""The options that several commands share, each declared here once, and the one range
syntax of every command that sweeps a parameter or a state: ``NAME=START:STOP[:N]``, N values
from START to STOP, N defaulting per command (:data:`RANGE_COUNTS`).

Every command that takes ``--param``, ``--probe``, ``--step``, ``--theta``, ``--method``,
``--period``, ``--json``, ``--scheduler``, ``--tol`` or ``-o`` adds it with the function of
that name: the name, the kind of value, the repetition and the default kind are the same in every
command; only the help text (what the option means for that command) and, for ``--method``,
the choices and, for ``--theta``, the default may differ.
"""

from __future__ import annotations

import argparse
import sys

#: The number of values of a range ``NAME=START:STOP`` given without ``:N``, per command.
RANGE_COUNTS = {"continue": 41, "bifurcation": 200, "sweep": 11, "basins": 100}


def range_help(command: str, name: str = "NAME", what: str = "values") -> str:
    """The sentence every command's help gives for a range."""
    return (f"{name}=START:STOP[:N] is N {what} from START to STOP (default N = "
            f"{RANGE_COUNTS[command]})")


def deprecated(command: str, old: str, new: str) -> None:
    """Say on stderr that ``old`` (still accepted) is deprecated, and its replacement."""
    print(f"pelcs {command}: note: {old} is deprecated and will be removed: {new}",
          file=sys.stderr)

PARAM_HELP = "override a global .param (repeatable; SPICE suffixes allowed)"
JSON_HELP = "print one JSON object (NaN and infinities as null)"
THETA_HELP = ("Moreau θ in [0.5, 1] (default 0.5, or 1 where θ < 1 is found unreliable, with "
              "a note)")


def add_param(p: argparse.ArgumentParser, help: str = PARAM_HELP,
              metavar: str = "NAME=VALUE") -> None:
    """``--param NAME=VALUE`` (repeatable): a ``.param`` override, or a swept range."""
    p.add_argument("--param", action="append", default=[], metavar=metavar, help=help)


def add_probe(p: argparse.ArgumentParser, help: str) -> None:
    """``--probe EXPR`` (repeatable, or comma-separated): ``v(out)``, ``i(L1)``..."""
    p.add_argument("--probe", action="append", default=[], metavar="EXPR", help=help)


def add_step(p: argparse.ArgumentParser,
             help: str = "time step (default: the .tran step)") -> None:
    """``--step H``: the time step, s (SPICE text)."""
    p.add_argument("--step", metavar="H", help=help)


def add_theta(p: argparse.ArgumentParser, help: str = THETA_HELP,
              default: str | None = None) -> None:
    """``--theta TH``: the θ of the Moreau time-stepping."""
    p.add_argument("--theta", metavar="TH", default=default, help=help)


def add_method(p: argparse.ArgumentParser, choices: tuple[str, ...], default: str,
               help: str) -> None:
    """``--method``: how the command computes (its choices are the command's)."""
    p.add_argument("--method", choices=choices, default=default, help=help)


def add_period(p: argparse.ArgumentParser, help: str) -> None:
    """``--period T``: seconds (SPICE text) or a ``.param`` name; optional everywhere (the
    commands find the netlist's own period without it)."""
    p.add_argument("--period", metavar="T", help=help)


def add_json(p: argparse.ArgumentParser, help: str = JSON_HELP) -> None:
    """``--json``: print the result as strict JSON on stdout."""
    p.add_argument("--json", action="store_true", help=help)


def add_scheduler(p: argparse.ArgumentParser) -> None:
    """``--scheduler ADDRESS``: run the tasks on a Dask cluster."""
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the tasks on the workers of a Dask scheduler (tcp://HOST:8786 "
                   "or HOST:8786; TLS and other schemes: through the Python API with a "
                   "distributed.Client), or 'local' for a Dask cluster on this machine; "
                   "default: local processes")


#: The default ``--tol``: Newton's tolerance on the scaled residual of a periodic orbit.
NEWTON_TOL = "1e-10"


def add_tol(p: argparse.ArgumentParser) -> None:
    """``--tol TOL``: the Newton tolerance on the scaled residual of a periodic orbit, the
    same in ``orbit`` and ``continue`` (:func:`lcs.analysis.orbits.find_orbit`'s ``tol``)."""
    p.add_argument("--tol", default=NEWTON_TOL, metavar="TOL",
                   help=f"Newton tolerance on the scaled residual of the orbit (default "
                   f"{NEWTON_TOL})")


def add_output(p: argparse.ArgumentParser, metavar: str, help: str) -> None:
    """``-o/--output FILE``: the file the command writes (its formats are the command's)."""
    p.add_argument("-o", "--output", metavar=metavar, help=help)
