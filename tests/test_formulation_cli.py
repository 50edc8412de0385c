"""``pelcs lcs``: mode selection, parameters, the report (JSON and text) and the CLI."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_formulation import PRC, SW_MODEL, boost, gate_switch, parallel_resonant

from netlist.circuit import Resistor
from netlist.errors import NetlistError
from netlist.formulation import formulate, storage_matrix
from pelcs.commands.lcs import build_report, format_report, select_modes


def two_switch_boost():
    c = boost()
    c.elements.append(gate_switch("S2", "out", "x"))
    c.elements.append(Resistor("R9", ("x", "0"), value=100.0))
    c.models = SW_MODEL
    return c


def test_select_modes():
    sys = formulate(two_switch_boost())
    assert select_modes(sys, None) == sys.all_keys()
    assert select_modes(sys, "S1=on,S2=off") == [(True, False)]
    assert select_modes(sys, "s2=ON") == [(False, True), (True, True)]
    with pytest.raises(NetlistError) as exc:
        select_modes(sys, "S3=on")
    assert "S1, S2" in exc.value.diagnostics[0].hint
    with pytest.raises(NetlistError):
        select_modes(sys, "S1=maybe")


def test_report_of_boost():
    c = boost()
    sys = formulate(c)
    report = build_report(sys, sys.all_keys(), storage_matrix(c))
    json.dumps(report)  # serialisable
    assert report["states"] == ["i(L1)", "v(C1)"]
    assert report["lambdas"] == ["D1"]
    assert report["inputs"] == ["Vin", "Vg"]
    assert report["passive"] is True
    off, on = report["modes"]
    assert off["switches"] == {"S1": "off"} and on["switches"] == {"S1": "on"}
    assert off["lambda_kinds"] == {"D1": "voltage"} and on["lambda_kinds"] == {"D1": "current"}
    for mode, key in ((off, (False,)), (on, (True,))):
        lcs = sys.mode(key)
        for name in "ABCDEF":
            np.testing.assert_array_equal(np.asarray(mode[name]).reshape(getattr(lcs, name)
                                                                         .shape),
                                          getattr(lcs, name))
        assert mode["passive"] is True
    text = format_report(report)
    assert "== S1=off ==" in text and "di(L1)/dt" in text and "-v(D1)" in text


def test_storage_matrix_state_order():
    # PRC states i(Lr), v(Cr), i(Lf), v(Cf): diag(Lr, Cr, Lf, Cf).
    K = storage_matrix(parallel_resonant(**PRC))
    np.testing.assert_allclose(K, np.diag([PRC["Lr"], PRC["Cr"], PRC["Lf"], PRC["Cf"]]))


BOOST_NETLIST = """boost for pelcs lcs
.param vin=12
Vin in 0 DC {vin}
L1 in sw 100u
S1 sw 0 gate 0 SWIDEAL
D1 sw out DIDEAL
C1 out 0 100u
R1 out 0 20
Vg gate 0 DC 0
.model SWIDEAL SW(VT=0.5 VH=0)
.model DIDEAL D(IS=1e-12)
.end
"""

def test_cli_json(tmp_path, capsys):
    from pelcs.cli import main

    path = tmp_path / "boost.cir"
    path.write_text(BOOST_NETLIST)
    assert main(["lcs", str(path), "--json", "--mode", "S1=on", "--param", "vin=5"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["states"] == ["i(L1)", "v(C1)"]
    assert report["inputs"] == ["Vin", "Vg"]
    (mode,) = report["modes"]
    assert mode["switches"] == {"S1": "on"}
    assert mode["lambda_kinds"] == {"D1": "current"}
    np.testing.assert_allclose(mode["A"], [[0, 0], [0, -500]])
    assert report["passive"] is True and mode["passive"] is True
    assert "gdcm" in mode and "wellposedness" in mode
    # S1 on: λ = i(D1), w = v(out) - v(sw) = v(C1) (hand derivation)
    (cond,) = mode["gdcm"]
    assert cond["diode"] == "D1"
    assert cond["y"] == pytest.approx({"v(C1)": 1.0})


def test_cli_json_gdcm_boost_switch_open(tmp_path, capsys):
    # S1 off: λ = v(out) - v(sw), w = i(L1). L di/dt = Vin - v(sw) = Vin - v(C1) + λ, so
    # CB = 1/L and Γ = -(C A x + C E u)/(C B) = v(C1) - Vin: the region i(L1) = 0, v(C1) > Vin.
    from pelcs.cli import main

    path = tmp_path / "boost.cir"
    path.write_text(BOOST_NETLIST)
    assert main(["lcs", str(path), "--json", "--mode", "S1=off"]) == 0
    report = json.loads(capsys.readouterr().out)
    (mode,) = report["modes"]
    assert mode["lambda_kinds"] == {"D1": "voltage"}
    (cond,) = mode["gdcm"]
    assert cond["diode"] == "D1"
    assert cond["y"] == pytest.approx({"i(L1)": 1.0})
    assert cond["gamma"] == pytest.approx({"v(C1)": 1.0, "Vin": -1.0})
    assert mode["wellposedness"]["wellposed"] is True


def test_cli_text_and_errors(tmp_path, capsys):
    from pelcs.cli import main

    path = tmp_path / "boost.cir"
    path.write_text(BOOST_NETLIST)
    assert main(["lcs", str(path)]) == 0
    out = capsys.readouterr().out
    assert "== S1=off ==" in out and "== S1=on ==" in out
    # A capacitor across the switch: the S1=on mode is degenerate -> exit 2, named elements.
    bad = tmp_path / "bad.cir"
    bad.write_text(BOOST_NETLIST.replace("R1 out 0 20", "R1 out 0 20\nCsw sw 0 1n"))
    assert main(["lcs", str(bad), "--mode", "S1=on"]) == 2
    err = capsys.readouterr().err
    assert "Csw" in err and "S1=on" in err
    assert main(["lcs", str(path), "--mode", "S9=on"]) == 2


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_cli_large_multiplier_scales(tmp_path, capsys, monkeypatch):
    # A 60-stage multiplier (120 diodes, above GDCM_MAX_PAIRS): the GDCM conditions are left
    # out with a note (their text grows as diodes² x states: a 200-stage multiplier ran for
    # more than 10 minutes); --gdcm lists them, each naming its diode, as below the limit.
    import time

    from converters.scaling import cockcroft_walton
    from pelcs.cli import main
    from pelcs.commands import lcs as lcs_command

    path = tmp_path / "cw60.cir"
    path.write_text(cockcroft_walton(60))
    t0 = time.perf_counter()
    assert main(["lcs", str(path), "--json"]) == 0
    assert time.perf_counter() - t0 < 20
    report = json.loads(capsys.readouterr().out)
    assert report["passive"] is True
    assert "120 diodes" in report["gdcm_skipped"] and "--gdcm" in report["gdcm_skipped"]
    assert report["modes"][0]["gdcm"] is None
    assert main(["lcs", str(path)]) == 0
    assert "note: GDCM conditions not listed: 120 diodes" in capsys.readouterr().out
    small = tmp_path / "cw3.cir"
    small.write_text(cockcroft_walton(3))
    assert main(["lcs", str(small), "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert listed["gdcm_skipped"] is None
    assert [c["diode"] for c in listed["modes"][0]["gdcm"]] == listed["lambdas"]
    monkeypatch.setattr(lcs_command, "GDCM_MAX_PAIRS", 2)
    assert main(["lcs", str(small), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["modes"][0]["gdcm"] is None
    assert main(["lcs", str(small), "--json", "--gdcm"]) == 0
    assert json.loads(capsys.readouterr().out)["modes"][0]["gdcm"] == listed["modes"][0]["gdcm"]


def test_the_report_names_the_capacitors_that_hold_no_state(tmp_path, capsys):
    # C3 closes a loop of capacitors (no state); Cin sits across V1 (no state, DC: exact)
    from pelcs.cli import main

    deck = tmp_path / "loops.cir"
    deck.write_text("capacitors without a state\nV1 a 0 DC 10\nCin a 0 10u\nR1 a p 1k\n"
                    "C1 p m 1u\nC2 m 0 1u\nC3 p 0 1u\nR2 m 0 10k\n.tran 1u 5m\n.end\n")
    assert main(["lcs", str(deck)]) == 0
    text = capsys.readouterr().out
    assert "states (2): v(C1), v(C2)" in text
    assert "note: C3: closes a loop of capacitors and DC sources (C1, C2)" in text
    assert "note: Cin: its terminals are joined by voltage sources alone (V1)" in text
    assert main(["lcs", str(deck), "--json"]) == 0
    notes = json.loads(capsys.readouterr().out)["notes"]
    assert len(notes) == 2 and notes[0].startswith("Cin:") and notes[1].startswith("C3:")
