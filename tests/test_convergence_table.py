"""The convergence study's files: ngspice_checks.convergence gives the data (columns, figure),
pelcs.convergence writes them through pelcs.writers.write_table; the table is the committed
file byte for byte (it was written by the study's own CSV writer before)."""

from __future__ import annotations

import csv
import math
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

from ngspice_checks import convergence
from ngspice_checks.convergence import ConvergencePoint, columns, order
from pelcs.convergence import write_study

COMMITTED = Path(convergence.__file__).parent / "results" / "convergence.csv"


def _points(path: Path) -> list[ConvergencePoint]:
    """The points of a study table, read back with the types of ConvergencePoint."""
    types = {f.name: {"str": str, "int": int, "float": float}[f.type]
             for f in fields(ConvergencePoint)}
    with open(path, newline="") as fh:
        return [ConvergencePoint(**{k: types[k](v) for k, v in row.items()})
                for row in csv.DictReader(fh)]


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_the_table_is_the_committed_file_byte_for_byte(tmp_path):
    points = _points(COMMITTED)
    assert len(points) == 18  # 2 converters x 9 levels
    csv_path, png_path = write_study(points, tmp_path / "made")
    assert csv_path.read_bytes() == COMMITTED.read_bytes()
    assert png_path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_columns_name_every_field_in_order_with_its_type():
    p = ConvergencePoint("buck", 0.1, 0.08, 3, "gear", 12.0, 11.7, 0.024, 0.035, 0.039,
                         0.16, 0.008)
    cols = columns([p, p])
    assert list(cols) == [f.name for f in fields(ConvergencePoint)]
    assert cols["converter"].tolist() == ["buck", "buck"]
    assert cols["rung"].dtype == np.int64 and cols["rung"].tolist() == [3, 3]
    assert cols["eps"].dtype == float and cols["pelcs_wall"].tolist() == [0.008, 0.008]


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_a_study_table_in_the_format_of_the_study(tmp_path):
    # the reference: the format the study wrote itself (6 significant digits, ints and
    # strings as they are, LF line ends), written out here
    pts = [ConvergencePoint("boost", 1e-4, 1.23456789e-4, 0, "as-written", 24.000012345,
                            23.99, 1.2e-5, 1 / 3, 2 / 3, 0.5, math.pi),
           ConvergencePoint("buck", 0.3, 0.24, 3, "gear, shunts", 12.0, 11.2, 0.067, 0.093,
                            0.099, 0.15, 0.008)]
    text = write_study(pts, tmp_path)[0].read_text(encoding="utf-8")
    assert text == (
        "converter,eps,delta,rung,settings,vout_pelcs,vout_ngspice,mean_error,nrms_vout,"
        "nrms_il,ngspice_wall,pelcs_wall\n"
        "boost,0.0001,0.000123457,0,as-written,24,23.99,1.2e-05,0.333333,0.666667,0.5,"
        "3.14159\n"
        'buck,0.3,0.24,3,"gear, shunts",12,11.2,0.067,0.093,0.099,0.15,0.008\n')


def test_order_is_the_log_log_slope_of_the_mean_error():
    pts = [ConvergencePoint("buck", e, 0.0, 0, "", 1.0, 1.0, 0.2 * e ** 2, 0.0, 0.0, 0.0, 0.0)
           for e in (1.0, 0.1, 0.01)]
    assert abs(order(pts, "buck") - 2.0) < 1e-12
    assert order(pts[:1], "buck") is None  # one point: no slope
    assert order(pts, "boost") is None
    zero = [ConvergencePoint("buck", e, 0.0, 0, "", 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
            for e in (1.0, 0.1)]
    assert order(zero, "buck") is None
