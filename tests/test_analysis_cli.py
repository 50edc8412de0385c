"""``pelcs orbit``, ``pelcs continue``, ``pelcs bifurcation``, ``pelcs basins``: output,
JSON, files and exit statuses (0 ok, 2 input error, 3 numerical failure)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_analysis_maps import boost_reference, netlists  # noqa: F401 - fixture

from pelcs.cli import main


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_orbit_text_and_json(netlists, capsys):  # noqa: F811
    code, out, err = run(capsys, "orbit", netlists["boost"], "--period", "ts")
    assert code == 0, err
    assert "period-1 orbit" in out and "Floquet multipliers" in out
    assert "i(L1)" in out and "stability: stable" in out
    assert "switching pattern: [S1 off, D1 on]" in out
    code, out, err = run(capsys, "orbit", netlists["boost"], "--period", "20u", "--json")
    assert code == 0, err
    r = json.loads(out)
    assert r["states"] == ["i(L1)", "v(C1)"]
    Phi, c = boost_reference()
    np.testing.assert_allclose(r["points"][0], np.linalg.solve(np.eye(2) - Phi, c),
                               atol=2e-5)
    mu = np.sort_complex([complex(a, b) for a, b in r["multipliers"]])
    mu_ref = np.sort_complex(np.linalg.eigvals(Phi))
    np.testing.assert_allclose(mu, mu_ref, atol=1e-6)
    assert r["order"] == 1 and r["converged"] and r["pattern"][1]["switches"] == {"S1": "on"}


def test_orbit_options_and_errors(netlists, capsys):  # noqa: F811
    code, out, err = run(capsys, "orbit", netlists["boost"], "--period", "ts", "--param",
                         "duty=0.4", "--order", "2", "--x0", "v(C1)=20", "--json")
    assert code == 0, err
    r = json.loads(out)
    assert r["order"] == 2 and len(r["points"]) == 2 and r["params"] == {"duty": 0.4}
    # A period-1 orbit seen as period 2: both points coincide.
    np.testing.assert_allclose(r["points"][0], r["points"][1], rtol=1e-8)
    for argv in (("--period", "nope"), ("--period", "ts", "--param", "zzz=1"),
                 ("--period", "ts", "--x0", "v(C9)=1"), ("--period", "ts", "--order", "0"),
                 ("--period", "ts", "--theta", "2")):
        code, out, err = run(capsys, "orbit", netlists["boost"], *argv)
        assert code == 2 and "error" in err, argv


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_continue_json_and_text(netlists, capsys):  # noqa: F811
    code, out, err = run(capsys, "continue", netlists["boost_dcm"], "--period", "ts",
                         "--param", "duty=0.74:0.8:4", "--locate-tol", "1e-3",
                         "--x0", "v(C1)=45", "--transient", "0", "--json")
    assert code == 0, err
    r = json.loads(out)
    assert [b["type"] for b in r["bifurcations"]] == ["border"]
    assert 0.76 < r["bifurcations"][0]["param"] < 0.78
    assert r["states"] == ["i(L1)", "v(C1)"] and len(r["branch"]) == 4
    code, out, err = run(capsys, "continue", netlists["boost_dcm"], "--period", "ts",
                         "--param", "duty=0.74:0.8:4", "--locate-tol", "1e-3",
                         "--x0", "v(C1)=45", "--transient", "0", "--no-locate")
    assert code == 0, err
    assert "bifurcations:" in out and "border" in out and "bracket" in out
    code, out, err = run(capsys, "continue", netlists["boost"], "--period", "ts", "--param",
                         "duty=0.4")
    assert code == 2 and "START:STOP" in err


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_bifurcation_outputs(netlists, capsys, tmp_path):  # noqa: F811
    csv_path, png, npz = tmp_path / "d.csv", tmp_path / "d.png", tmp_path / "d.npz"
    code, out, err = run(capsys, "bifurcation", netlists["buck"], "--period", "ts",
                         "--param", "duty=0.3:0.6:4", "--transient", "40", "--record", "3",
                         "--probe", "v(out)", "--probe", "i(L1)", "-o", str(csv_path),
                         "--plot", str(png), "--workers", "2")
    assert code == 0, err
    assert "duty: 4 values, fixed initial state" in out and "period 1" in out
    lines = csv_path.read_text().splitlines()
    assert lines[0] == "direction,duty,k,v(out),i(L1)" and len(lines) == 1 + 4 * 3
    assert png.stat().st_size > 5000
    code, out, err = run(capsys, "bifurcation", netlists["buck"], "--period", "ts",
                         "--param", "duty=0.3:0.6:4", "--transient", "40", "--record", "2",
                         "--follow", "-o", str(npz), "--workers", "1", "--param", "vin=12")
    assert code == 0, err
    z = np.load(npz)
    assert list(z["directions"]) == ["up", "down"] and z["up_samples"].shape == (4, 2, 2)
    np.testing.assert_allclose(z["up_samples"][:, -1], z["down_samples"][::-1, -1],
                               rtol=1e-6)
    for argv in (("--param", "duty=0.3..0.6"), ("--param", "duty=0.3:0.6:4", "--probe",
                                               "v(nowhere)"),
                 ("--param", "duty=0.3:0.6:4", "-o", str(tmp_path / "x.txt"))):
        code, out, err = run(capsys, "bifurcation", netlists["buck"], "--period", "ts",
                             "--transient", "1", "--record", "1", *argv)
        assert code == 2, argv


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_basins_outputs(netlists, capsys, tmp_path):  # noqa: F811
    npz, png = tmp_path / "b.npz", tmp_path / "b.png"
    code, out, err = run(capsys, "basins", netlists["buck"], "--period", "ts", "--grid",
                         "v(C1)=0:24:12,i(L1)=0:24:10", "-o", str(npz), "--plot", str(png),
                         "--workers", "2")
    assert code == 0, err
    assert "1 attractor(s)" in out and "attractor 1:" in out
    z = np.load(npz)
    assert z["group"].shape == (12, 10) and list(z["axis_names"]) == ["v(C1)", "i(L1)"]
    assert png.stat().st_size > 5000
    for grid in ("v(C1)=0:24:12", "v(C9)=0:1:2,i(L1)=0:1:2", "v(C1)=0:1:2,v(C1)=0:1:2"):
        code, out, err = run(capsys, "basins", netlists["buck"], "--period", "ts", "--grid",
                             grid)
        assert code == 2, grid


@pytest.mark.parametrize("command", ["orbit", "continue", "bifurcation", "basins", "sweep"])
def test_help_lists_the_commands(command, capsys):
    with pytest.raises(SystemExit) as exc:
        main([command, "--help"])
    assert exc.value.code == 0
    assert "--period" in capsys.readouterr().out


def test_orbit_of_an_event_map(netlists, capsys):  # noqa: F811
    code, out, err = run(capsys, "orbit", netlists["boost"], "--period", "ts", "--event",
                         "S1:on", "--json")
    assert code == 0, err
    r = json.loads(out)
    assert r["states"] == ["i(L1)", "v(C1)", "phase"] and r["event"] == "S1:on"
    assert r["points"][0][2] == pytest.approx(5e-9, abs=1e-15)  # the gate crosses 0.5 V
    assert min(abs(complex(a, b)) for a, b in r["multipliers"]) < 1e-12
    for ev in ("S9:on", "S1"):
        code, out, err = run(capsys, "orbit", netlists["boost"], "--period", "ts", "--event",
                             ev)
        assert code == 2 and "--event" in err


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_continue_from_many_starts(netlists, capsys):  # noqa: F811
    # The CCM boost has one period-1 orbit: every start finds it (the first, then "the same").
    code, out, err = run(capsys, "continue", netlists["boost"], "--period", "ts", "--param",
                         "duty=0.3:0.35:3", "--start", "v(C1)=10:30:3",
                         "--start", "i(L1)=2,v(C1)=40", "--workers", "2", "--no-progress")
    assert code == 0, err
    assert "4 continuation(s) from different starting states" in out
    assert "start 1 (i(L1) = 0, v(C1) = 10):" in out
    assert "start 4 (i(L1) = 2, v(C1) = 40): the same orbit as start 1" in out
    code, out, err = run(capsys, "continue", netlists["boost"], "--period", "ts", "--param",
                         "duty=0.3:0.35:3", "--start", "v(C1)=20", "--json",
                         "--workers", "1")
    r = json.loads(out)
    assert code == 0 and len(r["continuations"]) == 1
    c = r["continuations"][0]
    assert c["x0"] == [0.0, 20.0] and c["same_as"] is None and len(c["branch"]) == 3
    for bad in ("v(C9)=1", "v(C1)=1:2", "v(C1)=a"):
        code, out, err = run(capsys, "continue", netlists["boost"], "--period", "ts",
                             "--param", "duty=0.3:0.35", "--start", bad)
        assert code == 2 and "error" in err, bad
