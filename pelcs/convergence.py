"""The convergence study's command: ngspice approaches pelcs as its models approach the ideal.

::

    .venv/bin/python -m pelcs.convergence [--out DIR] [--fast] [--converters buck,boost]

Runs :func:`ngspice_checks.convergence.run_study` (the study and its expected results are
described there), writes its table ``convergence.csv`` (:func:`pelcs.writers.write_table`, 6
significant digits) and its figure ``convergence.png`` into ``--out`` (default
``ngspice_checks/results``), and prints a summary with the order of the mean error in ε.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from ngspice_checks.convergence import (
    FAST_LEVELS,
    FAST_TSTOP,
    LEVELS,
    RESULTS,
    TSTOP,
    ConvergencePoint,
    columns,
    figure,
    order,
    run_study,
)

from .figures import save_figure
from .writers import write_table

__all__ = ["main", "write_study"]

#: significant digits of the table's floats
DIGITS = 6


def write_study(points: Sequence[ConvergencePoint], out: str | Path) -> tuple[Path, Path]:
    """Write the study's table and figure into the folder ``out`` (made if missing):
    ``convergence.csv`` (one row per point, :func:`ngspice_checks.convergence.columns`) and
    ``convergence.png``; returns their paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    csv_path = write_table(out / "convergence.csv", columns(points), digits=DIGITS,
                           format=".csv")
    png_path = save_figure(figure(points), out / "convergence.png")
    return csv_path, png_path


def main(argv: Sequence[str] | None = None) -> int:
    """Run the study, write the CSV and PNG, print a table; returns 0."""
    ap = argparse.ArgumentParser(prog="python -m pelcs.convergence",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=RESULTS, help=f"output folder ({RESULTS})")
    ap.add_argument("--fast", action="store_true", help="two levels, 1 ms runs")
    ap.add_argument("--converters", default="buck,boost", help="comma-separated netlists")
    args = ap.parse_args(argv)
    converters = [c.strip() for c in args.converters.split(",") if c.strip()]
    points = run_study(converters, FAST_LEVELS if args.fast else LEVELS,
                       FAST_TSTOP if args.fast else TSTOP)
    csv_path, png_path = write_study(points, args.out)
    print(f"{'converter':<9} {'eps':>7} {'delta':>9} {'rung':>4} {'mean err':>10} "
          f"{'NRMS v':>10} {'NRMS i':>10} {'ngspice s':>9}")
    for p in points:
        print(f"{p.converter:<9} {p.eps:>7.3g} {p.delta:>9.3g} {p.rung:>4d} "
              f"{p.mean_error:>10.3g} {p.nrms_vout:>10.3g} {p.nrms_il:>10.3g} "
              f"{p.ngspice_wall:>9.3g}")
    for name in converters:
        k = order(points, name)
        if k is not None:
            eps = sorted(p.eps for p in points if p.converter == name)
            print(f"{name}: mean error falls as ε^{k:.2f} from ε = {eps[-1]:g} to {eps[0]:g}")
    print(f"wrote {csv_path}, {png_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
