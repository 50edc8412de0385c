"""``examples/bifurcation_vm_buck.py`` in its ``--fast`` form: files written and the
bifurcations it reports (first flip of the period-1 orbit near 24.5 V, second flip on the
period-2 branch near 31 V)."""

from __future__ import annotations

import importlib.util
import re
import sys
import time
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow  # (a few seconds: outside the fast subset)
def test_bifurcation_vm_buck_fast(tmp_path, capsys):
    t0 = time.perf_counter()
    res = load("bifurcation_vm_buck").main(["--fast", "--out", str(tmp_path)])
    assert time.perf_counter() - t0 < 60.0  # (as every example's --fast, test_examples.py)
    printed = capsys.readouterr().out
    assert not re.search(r"\bnan\b", printed, re.IGNORECASE), printed
    for name in ("vm_buck_diagram.png", "vm_buck_diagram.npz", "vm_buck_continuation.json",
                 "vm_buck_basins.png", "vm_buck_basins.npz"):
        assert (tmp_path / name).stat().st_size > 0, name
    flips = [b.param for b in res["period1"].bifurcations if b.type == "flip"]
    assert len(flips) == 1 and 24.0 < flips[0] < 25.0
    flips2 = [b.param for b in res["period2"].bifurcations if b.type == "flip"]
    assert flips2 and 30.0 < flips2[0] < 32.0
    periods = dict(zip(res["diagram"]["values"], res["diagram"]["periods"], strict=True))
    assert periods[20.0] == 1 and periods[27.0] == 2
    assert abs(res["orbit20"].multipliers[0].imag) > 0.1
