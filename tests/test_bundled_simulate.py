"""Every bundled converter runs through `pelcs simulate` with its own .tran."""

from pathlib import Path

import numpy as np
import pytest

from netlist.parser import parse_file
from pelcs.cli import main

NETLISTS = sorted((Path(__file__).parents[1] / "converters" / "netlists").glob("*.cir"))


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("path", NETLISTS, ids=lambda p: p.stem)
def test_bundled_netlist_simulates_to_its_tstop(path, tmp_path, capsys):
    out = tmp_path / "run.csv"
    assert main(["simulate", str(path), "-o", str(out), "--every", "50"]) == 0
    capsys.readouterr()
    header = out.read_text().splitlines()[0].split(",")
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert header[0] == "time" and len(header) == data.shape[1]
    assert np.isfinite(data).all()
    tstop = parse_file(path).tran.tstop
    assert data[-1, 0] == pytest.approx(tstop, rel=1e-12)


def test_all_bundled_converters_are_present():
    # The converter library the project promises, as bundled netlists.
    names = {p.stem for p in NETLISTS}
    assert {"boost", "buck", "buck_boost", "cuk", "prc", "vm_buck", "boost_smc",
            "bridge_rectifier"} <= names
