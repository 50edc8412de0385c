"""An ``.include`` of a file that does not exist: pelcs refuses it, at the include, and its
hint says what ngspice does instead (checked here against ngspice on a tiny deck): in the top
file ngspice loads no circuit; in an included file it drops that whole file, the elements
before the include as well as after it, and simulates what is left."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from ngspice_helpers import ngspice_run

from netlist.errors import NetlistError
from netlist.parser import parse_file

MISSING = "/nonexistent-pelcs-test/models.lib"

# V1 drives 1 V; the included part.net holds R3 (before the missing include) and R2 (after):
# with them, i(V1) = -2 mA.
TOP = "missing include in an included file\nV1 1 0 DC 1\n.include part.net\n.tran 1u 3u\n.end\n"
PART = f"R3 1 0 1k\n.include {MISSING}\nR2 1 0 1k\n"


def _write(tmp_path):
    (tmp_path / "part.net").write_text(PART)
    top = tmp_path / "top.cir"
    top.write_text(TOP)
    return top


def test_pelcs_refuses_a_missing_nested_include(tmp_path):
    with pytest.raises(NetlistError) as info:
        parse_file(_write(tmp_path))
    (d,) = info.value.diagnostics
    assert d.message == f"file not found: '{MISSING}'"
    assert d.location.file.endswith("part.net") and d.location.line == 2
    assert "ngspice drops all of" in d.hint and "part.net" in d.hint


def test_pelcs_refuses_a_missing_top_include(tmp_path):
    top = tmp_path / "top.cir"
    top.write_text(f"t\nV1 1 0 DC 1\n.include {MISSING}\nR1 1 0 1k\n.tran 1u 3u\n.end\n")
    with pytest.raises(NetlistError) as info:
        parse_file(top)
    (d,) = info.value.diagnostics
    assert d.location.line == 3 and "ngspice loads no circuit either" in d.hint


def test_ngspice_drops_the_including_file_whole(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    data, log = ngspice_run(_write(tmp_path), ["i(V1)"], tmp_path, timeout=60)
    assert "Could not find include file" in log
    # neither R3 nor R2 is there: no current at all (with them, -2 mA)
    assert data is not None and np.all(data[:, 1] == 0.0), log[-1000:]
    # the same deck with the include removed: both resistors, -2 mA
    (tmp_path / "part.net").write_text(PART.replace(f".include {MISSING}\n", ""))
    data, log = ngspice_run(tmp_path / "top.cir", ["i(V1)"], tmp_path, timeout=60)
    assert data is not None and np.allclose(data[:, 1], -2e-3), log[-1000:]


def test_ngspice_loads_no_circuit_for_a_missing_top_include(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    top = tmp_path / "top.cir"
    top.write_text(f"t\nV1 1 0 DC 1\n.include {MISSING}\nR1 1 0 1k\n.tran 1u 3u\n.end\n")
    data, log = ngspice_run(top, ["i(V1)"], tmp_path, timeout=60)
    assert data is None and "Could not find include file" in log, log[-1000:]
