"""``pelcs check FILE``: simulate a netlist with pelcs and with ngspice, and compare.

::

    pelcs check FILE [--probe EXPR]... [--param NAME=VALUE]... [--tstop T] [--period T]
                     [--report DIR] [--json] [--pelcs-param NAME=VALUE]... [--timeout S]

Both simulators run the same circuit (``ngspice_checks.compare``: ngspice gets the parsed,
flattened circuit written back, with UIC; its settings ladder may add options, finite edges or
smoother models, and the table says which rung ran). Per probe: the normalised RMS difference
over the run, the mean and the ripple over the last whole periods; per switch: the switching
instants (or, for a free-running switch, its frequency). Each against a tolerance that widens
with the drops of ngspice's diode and switch models (see ``ngspice_checks/compare.py``).

Default probes: every state, ``i(L…)`` and ``v(C…)`` (``v(C1)`` is measured in ngspice as the
voltage across C1): they are continuous, so the pointwise comparison is meaningful, and
everything else follows from them.

When the netlist has real device models (transistors, macro-models, diodes or switches whose
drops would widen the tolerances), pelcs runs with ``--devices pwl`` fitted to them, and the
tolerances follow what the fits leave (``--devices ideal|pwl`` forces one; docs/check.md).

Exit status: 0 every probe and switch within tolerances that decide (each at most 10 %); 1
something out of tolerance; 2 input errors (netlist, options, probes); 3 the comparison could
not be made: ngspice is not available (PySpice or libngspice missing), ngspice failed on every
rung of its ladder, or the pelcs run failed; 4 inconclusive: within tolerances wider than
10 % (model drops pelcs does not represent), which shows no agreement; 130 interrupted
(Ctrl-C during the runs: a comparison needs both runs whole, so nothing is compared and no
report is written). The report files are written before the exit status is decided.
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from pathlib import Path

from netlist.errors import Diagnostic, NetlistError

from . import options
from . import simulate as _simulate
from .simulate import split_probes

EXIT_OUT_OF_TOLERANCE = 1
EXIT_CANNOT_COMPARE = 3
EXIT_INCONCLUSIVE = 4
#: Ctrl-C (SIGINT) during the runs (128 + SIGINT, as a shell reports it).
EXIT_INTERRUPTED = 130


def register(subparsers) -> None:
    """Add the ``check`` subcommand to the CLI's subparsers."""
    p = subparsers.add_parser(
        "check",
        help="cross-check a netlist against ngspice (waveforms, means, ripple, switching)",
        description="Simulate a netlist with pelcs and with ngspice, compare the probes and "
        "the switching instants, and say whether they agree within tolerances set by what "
        "pelcs' devices leave of ngspice's models (ideal devices, or piecewise-linear fits "
        "of real models); tolerances over 10 % make the comparison inconclusive.",
        epilog="exit status: 0 within tolerance, 1 out of tolerance, 2 input error, "
        "3 ngspice unavailable or a simulator failed, 4 inconclusive (tolerances over "
        "10 %).  example: pelcs check boost.cir "
        "--probe 'v(out)' --probe 'i(L1)' --report out/check",
    )
    p.add_argument("file", help="netlist file")
    options.add_probe(p,
                   help="v(NODE), v(NODE,NODE), i(ELEMENT) or a state v(C1) (repeatable, or "
                   "comma-separated); default: every state i(L...), v(C...)")
    options.add_param(p, help="override a global .param in both simulators (repeatable)")
    p.add_argument("--tstop", metavar="T", help="stop time of both runs (default: .tran TSTOP)")
    options.add_period(p,
                   help="steady-state period (default: from the sources or the switching)")
    p.add_argument("--report", metavar="DIR",
                   help="write NAME.md, NAME.json, NAME.png and the ngspice deck into DIR")
    options.add_json(p,
                   help="print the JSON report on stdout instead of the table")
    p.add_argument("--pelcs-param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a .param in pelcs only: a deliberate difference, to see "
                   "that the check catches it")
    p.add_argument("--devices", choices=("auto", "ideal", "pwl"), default="auto",
                   help="pelcs' devices: piecewise-linear fits of the models (pwl), ideal "
                   "ones, or auto (default: pwl when the netlist has real device models)")
    p.add_argument("--timeout", metavar="S", default="600",
                   help="ngspice wall-time limit per ladder rung, s (default 600)")
    p.set_defaults(func=run)


def compare(args: argparse.Namespace):
    """The :class:`~ngspice_checks.comparison.Comparison` of the parsed options (shared with
    :func:`pelcs.check`).

    Raises
    ------
    NetlistError
        Input errors, or a netlist construct not supported.
    NgspiceUnavailable, NgspiceFailed, CheckError
        The comparison could not be made (exit status 3 of the command).
    """
    from netlist.parser import parse_overrides
    from ngspice_checks.compare import compare as _compare

    tstop = _number("--tstop", args.tstop, ("", "s"))
    period = _number("--period", args.period, ("", "s"))
    timeout = _number("--timeout", args.timeout, ("", "s"))
    for name, value in (("--tstop", tstop), ("--period", period), ("--timeout", timeout)):
        if value is not None and not value > 0:
            raise _usage_error(f"{name} must be positive", f"e.g. {name} 5m")
    if not Path(args.file).is_file():
        raise _usage_error(f"cannot read {args.file!r}: no such file",
                           "give the path of a netlist file")
    params = parse_overrides(args.param) or None
    pelcs_params = parse_overrides(args.pelcs_param) or None
    probes = split_probes(args.probe) or None
    try:
        return _compare(args.file, probes, params=params, pelcs_params=pelcs_params,
                        tstop=tstop, period=period, timeout=timeout, devices=args.devices)
    except NotImplementedError as exc:
        raise NetlistError(Diagnostic(message=f"not supported: {exc}",
                                      hint="see docs/simulation.md"),
                           file=args.file) from exc


def _usage_error(message: str, hint: str = "") -> NetlistError:
    return NetlistError(Diagnostic(message=message, hint=hint), file="pelcs check")


def _number(option: str, text: str | None, units: tuple[str, ...] = ("",)) -> float | None:
    """``pelcs simulate``'s number parsing, its errors labelled ``pelcs check``."""
    try:
        return _simulate._number(option, text, units)
    except NetlistError as exc:
        raise NetlistError(exc.diagnostics, file="pelcs check") from None


@contextlib.contextmanager
def _term_as_interrupt():
    """SIGTERM raises KeyboardInterrupt, as Ctrl-C does: the ngspice worker is then killed,
    not left running (the default action of SIGTERM ends this process at once)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def run(args: argparse.Namespace) -> int:
    from ngspice_checks.compare import CheckError
    from ngspice_checks.runner import NgspiceFailed, NgspiceUnavailable
    from pelcs.check_report import format_table, to_json, write_report

    try:
        with _term_as_interrupt():
            cmp = compare(args)
    except NgspiceUnavailable as exc:
        print(f"{args.file}: error: ngspice is not available, nothing was compared: {exc}",
              file=sys.stderr)
        return EXIT_CANNOT_COMPARE
    except NgspiceFailed as exc:
        print(f"{args.file}: error: {exc}", file=sys.stderr)
        return EXIT_CANNOT_COMPARE
    except CheckError as exc:
        print(f"{args.file}: error: {exc}", file=sys.stderr)
        return EXIT_CANNOT_COMPARE
    except KeyboardInterrupt:
        # (a comparison needs both runs whole: there is nothing partial to keep)
        print(f"{args.file}: interrupted during the ngspice and pelcs runs: nothing was "
              "compared and no report was written", file=sys.stderr)
        return EXIT_INTERRUPTED

    written = []
    if args.report:
        try:
            written = write_report(cmp, args.report)
        except OSError as exc:
            raise _usage_error(f"cannot write the report into {args.report}: "
                               f"{exc.strerror or exc}",
                               "check the directory and its permissions") from exc
    if args.json:
        print(to_json(cmp))
    else:
        print(format_table(cmp))
        if written:
            print(f"wrote {', '.join(str(w) for w in written)}")
    return {"ok": 0, "inconclusive": EXIT_INCONCLUSIVE}.get(cmp.verdict, EXIT_OUT_OF_TOLERANCE)
