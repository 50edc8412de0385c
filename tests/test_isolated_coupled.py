"""A flyback and a forward converter written with coupled inductors (K), against ngspice:
mean v(out) over the second half of the run (pelcs with --devices pwl; ngspice with its
exponential diodes)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.parser import parse_file
from netlist.studies.realistic import simulate_devices

NETLISTS = Path(__file__).parent / "netlists"


def _mean(t: np.ndarray, y: np.ndarray) -> float:
    keep = t >= t[-1] / 2
    return float(np.trapezoid(y[keep], t[keep]) / (t[keep][-1] - t[keep][0]))


@pytest.mark.parametrize("name, tolerance", [
    # ngspice 13.10 V, pelcs 12.90 V (1.5 %): the clamp and output diodes' forward models
    ("flyback_coupled", 0.03),
    # ngspice 7.673 V, pelcs 7.676 V (0.04 %)
    ("forward_coupled", 0.01),
])
@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_coupled_isolated_converter_against_ngspice(name, tolerance, tmp_path, ngspice):
    file = NETLISTS / f"{name}.cir"
    res = simulate_devices(parse_file(file), devices="pwl", probes=["v(out)"])
    res.raise_if_error()
    got = _mean(res.t, res["v(out)"])
    ng = ngspice_wrdata(file, ["v(out)"], tmp_path, timeout=300)
    assert ng[-1, 0] == pytest.approx(float(res.t[-1]))  # ngspice ran to the end
    assert got == pytest.approx(_mean(ng[:, 0], ng[:, 1]), rel=tolerance)
