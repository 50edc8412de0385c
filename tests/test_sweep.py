"""Parameter sweeps and Monte Carlo runs (netlist.studies.param_sweep, netlist.studies.measure,
pelcs sweep).

References: the ideal buck in CCM, whose steady-state mean output is D·Vin exactly; an RC
low-pass filter driven by a square wave, whose periodic steady state is known in closed form
(mean, min, max, ripple, RMS, final value) for every drawn R1, R2, C1, and whose Monte Carlo
mean and standard deviation follow from the analytic first-order propagation of uniform and
gaussian tolerances.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

from lcs.analysis.tables import SweepTable
from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.studies.measure import parse_measurements, steady_state_period, steady_state_window
from netlist.studies.param_sweep import (
    draw_deviations,
    match_tolerances,
    parse_sweep_param,
    parse_tolerance,
    run_sweep,
)
from pelcs.cli import main
from pelcs.sweep_plots import histogram_figure
from pelcs.writers import write_sweep

# sweeps and Monte Carlo runs (5.4 s): in the full suite, not the fast subset
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
BUCK = ROOT / "tests" / "netlists" / "sim" / "buck_ccm.cir"

VS, DUTY, TP = 10.0, 0.5, 100e-6
RC_TEXT = """RC low-pass filter driven by a square wave (Monte Carlo reference)
* Vs: 0 -> vs for d*tp of every period tp (1 ns edges, centred on the ideal instants);
* R1 from in to out, R2 and C1 from out to ground: tau = C1 R1 R2/(R1 + R2) = tp/2.
.param vs=10 d=0.5 tp=100u
Vs in 0 PULSE(0 {vs} 0 1n 1n {d*tp-1n} {tp})
R1 in out 1k
R2 out 0 1k
C1 out 0 100n IC=2.5
* 80 time constants: the start-up transient is down to exp(-80) of the ripple.
.tran 0.5u 4m 0 0.5u UIC
.end
"""


@pytest.fixture(scope="module")
def rc(tmp_path_factory) -> str:
    path = tmp_path_factory.mktemp("sweep") / "rc.cir"
    path.write_text(RC_TEXT)
    return str(path)


def rc_steady_state(r1: float, r2: float, c: float, vs: float = VS, d: float = DUTY,
                    tp: float = TP) -> dict[str, float]:
    """Closed-form periodic steady state of the RC filter (Thevenin source vs·r2/(r1+r2)).

    Over the on-phase v rises from vmin to vmax = V + (vmin - V) a, over the off-phase it
    decays to vmin = vmax b, with a = exp(-d tp/τ), b = exp(-(1-d) tp/τ).
    """
    v = vs * r2 / (r1 + r2)
    tau = c * r1 * r2 / (r1 + r2)
    a, b = math.exp(-d * tp / tau), math.exp(-(1 - d) * tp / tau)
    vmax = v * (1 - a) / (1 - a * b)
    vmin = vmax * b

    def wave(t):
        if t < d * tp:
            return v + (vmin - v) * math.exp(-t / tau)
        return vmax * math.exp(-(t - d * tp) / tau)

    msq = (quad(lambda t: wave(t) ** 2, 0, d * tp, epsabs=1e-13)[0]
           + quad(lambda t: wave(t) ** 2, d * tp, tp, epsabs=1e-13)[0]) / tp
    return {"mean": d * v, "min": vmin, "max": vmax, "ripple": vmax - vmin,
            "rms": math.sqrt(msq), "final": vmin}


# -- parameter sweeps -----------------------------------------------------------------------


def test_buck_duty_sweep_mean_output_is_duty_times_vin():
    duties = np.array([0.2, 0.4, 0.6, 0.8])
    table = run_sweep(BUCK, ["mean(v(out))", "min(i(L1))"], params={"duty": duties}, workers=2)
    assert table.inputs == ("duty",) and table.swept == ("duty",) and table.ok.all()
    np.testing.assert_array_equal(table["duty"], duties)
    # Volt-second balance of the ideal inductor: exact up to the quadrature of the output
    # ripple (see tests/test_simulate_reference.py), 1e-4 V.
    np.testing.assert_allclose(table["mean(v(out))"], duties * 24.0, atol=1e-4)
    assert (table["min(i(L1))"] > 0).all()  # CCM at every duty
    assert "last 10 period(s) of 20 µs (PULSE period of Vg (control of S1))" in table.notes[0]


def test_grid_of_two_parameters_and_fixed_override():
    table = run_sweep(BUCK, ["mean(v(out))"], params={"duty": [0.3, 0.6], "vin": [12, 24],
                                                      "rload": 5.0}, workers=1)
    assert table.inputs == ("duty", "vin") and len(table) == 4
    np.testing.assert_array_equal(table["duty"], [0.3, 0.3, 0.6, 0.6])  # first slowest
    np.testing.assert_array_equal(table["vin"], [12, 24, 12, 24])
    np.testing.assert_allclose(table["mean(v(out))"], table["duty"] * table["vin"], atol=2e-4)


def test_rc_measurements_against_the_closed_form(rc):
    measures = ["mean(v(out))", "avg(v(out))", "rms(v(out))", "ripple(v(out))",
                "pp(v(out))", "min(v(out))", "max(v(out))", "final(v(out))"]
    table = run_sweep(rc, measures, workers=1)
    ref = rc_steady_state(1e3, 1e3, 100e-9)
    got = dict(zip(table.measures, table.values[0], strict=True))
    # θ = 1/2 with h = τ/100: relative error ~ (h/τ)²/12 ~ 1e-5 of the ripple.
    for name, key in (("mean", "mean"), ("avg", "mean"), ("rms", "rms"), ("ripple", "ripple"),
                      ("pp", "ripple"), ("min", "min"), ("max", "max"), ("final", "final")):
        assert got[f"{name}(v(out))"] == pytest.approx(ref[key], abs=2e-4), name
    assert table.units["rms(v(out))"] == "V"


def test_window_and_period_match_pelcs_check():
    """netlist.studies.measure's window is the one of ngspice_checks.compare (its twin)."""
    from ngspice_checks.compare import _window, detect_period
    from pelcs.api import simulate

    for name in ("buck.cir", "boost_smc.cir", "bridge_rectifier.cir", "prc.cir"):
        circuit = parse_file(ROOT / "converters" / "netlists" / name)
        res = simulate(circuit, tstop=circuit.tran.tstop / 10, check=False)
        assert steady_state_period(circuit, res)[0] == detect_period(circuit, res)[0]
        per = steady_state_period(circuit, res)[0]
        for span in ((0.0, 1e-3), (1e-4, 5e-3), (0.0, 3e-5)):
            assert steady_state_window(span, per) == _window(span, per), (name, span)


# -- Monte Carlo ----------------------------------------------------------------------------


def test_monte_carlo_uniform_against_analytic_propagation(rc):
    runs, tol_r, tol_c = 300, 0.05, 0.10
    table = run_sweep(rc, ["mean(v(out))", "ripple(v(out))"], tolerances=["R*=5%", "C1=10%"],
                      runs=runs, seed=11, workers=2)
    assert table.inputs == ("run", "R1", "R2", "C1") and table.ok.all() and len(table) == runs
    np.testing.assert_array_equal(table["run"], np.arange(runs))
    r1, r2, c1 = table["R1"], table["R2"], table["C1"]
    # The draws: uniform within the tolerance, std tol/sqrt(3).
    for x, nom, tol in ((r1, 1e3, tol_r), (r2, 1e3, tol_r), (c1, 100e-9, tol_c)):
        d = x / nom - 1
        assert np.abs(d).max() <= tol and np.abs(d).max() > 0.9 * tol
        assert np.std(d, ddof=1) == pytest.approx(tol / math.sqrt(3), rel=0.12)
    # Every run against the closed form with its own component values.
    for k in range(runs):
        ref = rc_steady_state(r1[k], r2[k], c1[k])
        assert table["mean(v(out))"][k] == pytest.approx(ref["mean"], abs=1e-4)
        assert table["ripple(v(out))"][k] == pytest.approx(ref["ripple"], abs=2e-4)
    # Distribution against first-order propagation: std_f² = Σ (x_i ∂f/∂x_i σ_i)², σ_i the
    # relative std of draw i; the sample mean within 4 standard errors of f(nominal) plus
    # the second-order bias, the sample std within 4 of its standard errors + 2 %.
    sig = np.array([tol_r, tol_r, tol_c]) / math.sqrt(3)
    _check_propagation(table, sig, runs)
    nominal = rc_steady_state(1e3, 1e3, 100e-9)
    assert table.nominal.shape == (1, 2)  # one grid point
    np.testing.assert_allclose(table.nominal[0], [nominal["mean"], nominal["ripple"]],
                               atol=2e-4)
    stats = table.statistics()
    assert stats["ripple(v(out))"]["nominal"] == table.nominal[0, 1]


def _check_propagation(table: SweepTable, sig: np.ndarray, runs: int) -> None:
    x0 = np.array([1e3, 1e3, 100e-9])
    for j, key in enumerate(("mean", "ripple")):
        def f(x, key=key):
            return rc_steady_state(*x)[key]

        grad, hess = np.zeros(3), np.zeros(3)
        for i in range(3):
            e = np.zeros(3)
            e[i] = 1e-4 * x0[i]
            fp, fm, f0 = f(x0 + e), f(x0 - e), f(x0)
            grad[i] = (fp - fm) / 2e-4  # x_i ∂f/∂x_i
            hess[i] = (fp - 2 * f0 + fm) / 1e-8  # x_i² ∂²f/∂x_i²
        std = math.sqrt(np.sum((grad * sig) ** 2))
        mean = f(x0) + 0.5 * np.sum(hess * sig**2)
        v = table.values[:, j]
        assert abs(v.mean() - mean) < 4 * std / math.sqrt(runs), key
        assert v.std(ddof=1) == pytest.approx(std, rel=4 / math.sqrt(2 * runs) + 0.02), key


def test_monte_carlo_gaussian_is_three_sigma(rc):
    runs = 300
    table = run_sweep(rc, ["mean(v(out))", "ripple(v(out))"], tolerances=["R*=6%", "C1=9%"],
                      runs=runs, seed=5, distribution="gaussian", workers=2)
    for name, nom, tol in (("R1", 1e3, 0.06), ("R2", 1e3, 0.06), ("C1", 100e-9, 0.09)):
        d = table[name] / nom - 1
        assert np.std(d, ddof=1) == pytest.approx(tol / 3, rel=0.12)
        assert np.abs(d).max() > tol / 3 * 2  # not truncated to one sigma
    for k in range(0, runs, 37):
        ref = rc_steady_state(table["R1"][k], table["R2"][k], table["C1"][k])
        assert table["ripple(v(out))"][k] == pytest.approx(ref["ripple"], abs=2e-4)
    _check_propagation(table, np.array([0.06, 0.06, 0.09]) / 3, runs)


def test_monte_carlo_is_reproducible_and_independent_of_the_split(rc):
    kw = dict(tolerances=["R1=5%", "c*=0.2n"], runs=12, seed=42)
    a = run_sweep(rc, ["ripple(v(out))"], workers=1, **kw)
    b = run_sweep(rc, ["ripple(v(out))"], workers=2, **kw)
    np.testing.assert_array_equal(a.input_values, b.input_values)
    np.testing.assert_array_equal(a.values, b.values)
    c = run_sweep(rc, ["ripple(v(out))"], workers=2, **{**kw, "seed": 43})
    assert not np.array_equal(a.input_values, c.input_values)
    # 'c*=0.2n' is absolute: C1 = 100 nF ± 0.2 nF; R2 is not drawn.
    assert a.inputs == ("run", "R1", "C1")
    assert np.abs(a["C1"] - 100e-9).max() <= 0.2e-9
    # The matrix of draws is seeded numpy: run-major, netlist order.
    want = np.random.default_rng(42).uniform(-1, 1, size=(12, 2)) * [0.05, 0.2e-9]
    np.testing.assert_allclose(a["R1"], 1e3 * (1 + want[:, 0]), rtol=1e-15)
    np.testing.assert_allclose(a["C1"], 100e-9 + want[:, 1], rtol=1e-15)


def test_monte_carlo_with_a_parameter_grid_uses_common_draws(rc):
    table = run_sweep(rc, ["mean(v(out))"], params={"vs": [5.0, 10.0]},
                      tolerances=["R*=5%"], runs=4, seed=1, workers=2)
    assert table.inputs == ("vs", "run", "R1", "R2") and len(table) == 8
    np.testing.assert_array_equal(table["R1"][:4], table["R1"][4:])
    np.testing.assert_allclose(table["mean(v(out))"][4:], 2 * table["mean(v(out))"][:4],
                               rtol=1e-9)
    # A nominal run per grid point: the RC filter is linear in vs.
    assert table.nominal.shape == (2, 1)
    assert table.nominal[0, 0] == pytest.approx(1.25, abs=2e-4)
    assert table.nominal[1, 0] == pytest.approx(2 * table.nominal[0, 0], rel=1e-9)


def test_tolerance_matching():
    circuit = parse_string(RC_TEXT)
    m = match_tolerances(circuit, [parse_tolerance(t) for t in ("R*=5%", "r2=1%", "*=2%")])
    assert [(n, t.text) for n, t in m] == [("R1", "R*=5%"), ("R2", "r2=1%"), ("C1", "*=2%")]
    tol = parse_tolerance("C1=10%")
    assert tol.relative and tol.amount == pytest.approx(0.1)
    assert parse_tolerance("L1=2u").amount == pytest.approx(2e-6)
    d = draw_deviations(m, 1000, 0, "gaussian")
    assert d.shape == (1000, 3)
    for text in ("Q*=5%", "Vs=5%"):
        with pytest.raises(NetlistError) as exc:
            match_tolerances(circuit, [parse_tolerance(text)])
        assert "elements with a value: R1, R2, C1" in exc.value.format()
    for text in ("R1", "R1=", "R1=-5%", "R1=abc"):
        with pytest.raises(NetlistError):
            parse_tolerance(text)


def test_parse_sweep_param():
    assert parse_sweep_param("duty=0.2")[1] == pytest.approx(0.2)
    name, v = parse_sweep_param("fs=50k:100k:3")
    assert name == "fs" and np.allclose(v, [50e3, 75e3, 100e3])
    assert np.allclose(parse_sweep_param("r=1,2.2k,4.7k")[1], [1, 2200, 4700])
    for bad in ("duty", "duty=0.1:0.2", "duty=0.1:0.2:0", "duty=a:b:3", "=3"):
        with pytest.raises(NetlistError):
            parse_sweep_param(bad)


def test_measurement_errors():
    circuit = parse_string(RC_TEXT)
    for text, words in (("mean(v(nowhere))", "unknown probe"),
                        ("median(v(out))", "unknown measurement function 'median'"),
                        ("v(out)", "expected FUNCTION(PROBE)"),
                        ("mean()", "expected FUNCTION(PROBE)"),
                        ("mean(v(out)),mean(v(out))", "given twice")):
        with pytest.raises(NetlistError) as exc:
            parse_measurements([text], circuit)
        assert words in exc.value.format(), text
    got = parse_measurements(["mean(v(out)),ripple(v(in,out))", "Final(i(C1))"], circuit)
    assert [(m.func, m.probe, m.unit) for m in got] == [
        ("mean", "v(out)", "V"), ("ripple", "v(in,out)", "V"), ("final", "i(C1)", "A")]


def test_failed_runs_are_nan_with_a_message(rc):
    # A gaussian draw far beyond the tolerance: R1 = 1k·(1 + 3·N(0,1)) goes negative.
    table = run_sweep(rc, ["mean(v(out))"], tolerances=["R1=900%"], runs=20, seed=2,
                      distribution="gaussian", workers=1)
    bad = ~table.ok
    assert bad.any() and table.ok.any()
    assert np.isnan(table.values[bad]).all() and np.isfinite(table.values[~bad]).all()
    assert all("the opposite sign of its nominal 1000" in table.messages[i]
               for i in np.flatnonzero(bad))
    assert any("run(s) failed" in n for n in table.notes)


def test_dataframe_and_csv(rc, tmp_path):
    table = run_sweep(rc, ["mean(v(out))", "ripple(v(out))"], params={"d": [0.25, 0.5]},
                      tolerances=["C1=10%"], runs=3, seed=0, workers=1)
    df = table.to_dataframe()
    assert list(df.columns) == ["d", "run", "C1", "mean(v(out))", "ripple(v(out))", "ok",
                                "settled", "message"]
    assert df["run"].dtype.kind == "i" and df["ok"].all() and len(df) == 6
    np.testing.assert_array_equal(df["ripple(v(out))"].to_numpy(), table["ripple(v(out))"])
    path = tmp_path / "t.csv"
    write_sweep(table, path)
    import pandas as pd

    back = pd.read_csv(path)
    np.testing.assert_array_equal(back["mean(v(out))"].to_numpy(), table["mean(v(out))"])
    np.testing.assert_array_equal(back["C1"].to_numpy(), table["C1"])


# -- the command ----------------------------------------------------------------------------


def run_cli(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_cli_sweep_table_csv_plot_json(capsys, tmp_path):
    csv_path, png = tmp_path / "s.csv", tmp_path / "s.png"
    code, out, err = run_cli(capsys, "sweep", str(BUCK), "--param", "duty=0.25:0.75:3",
                             "--measure", "mean(v(out))", "--measure", "ripple(i(L1))",
                             "-o", str(csv_path), "--plot", str(png), "--workers", "2")
    assert code == 0, err
    assert "duty 0.25..0.75 (3 values): 3 run(s), 3 ok" in out
    assert "mean(v(out))" in out and "18 V" in out and "6 V" in out
    lines = csv_path.read_text().splitlines()
    assert lines[0] == "duty,mean(v(out)),ripple(i(L1)),ok,settled,message" and len(lines) == 4
    assert float(lines[2].split(",")[1]) == pytest.approx(12.0, abs=1e-4)
    assert png.stat().st_size > 5000
    code, out, err = run_cli(capsys, "sweep", str(BUCK), "--param", "duty=0.3,0.5",
                             "--measure", "mean(v(out))", "--json", "--workers", "1")
    assert code == 0, err
    r = json.loads(out)
    assert [row["duty"] for row in r["rows"]] == [0.3, 0.5]
    assert r["rows"][1]["mean(v(out))"] == pytest.approx(12.0, abs=1e-4)


def test_cli_monte_carlo_histogram(capsys, tmp_path, rc):
    png = tmp_path / "mc.png"
    code, out, err = run_cli(capsys, "sweep", rc, "--tolerance", "R*=5%", "--tolerance",
                             "C1=10%", "--runs", "30", "--seed", "7", "--measure",
                             "ripple(v(out))", "--plot", str(png), "--workers", "2")
    assert code == 0, err
    assert "Monte Carlo 30 runs, uniform, seed 7" in out
    assert "tolerances: R1 ±5 % (R*=5%), R2 ±5 % (R*=5%), C1 ±10 %" in out
    assert "nominal" in out and "2.311 V" in out  # the closed-form nominal ripple
    assert png.stat().st_size > 5000
    # Without --seed a seed is chosen and printed: giving it back repeats the runs.
    code, out1, _ = run_cli(capsys, "sweep", rc, "--tolerance", "R1=5%", "--runs", "3",
                            "--measure", "mean(v(out))", "--json", "--workers", "1")
    r1 = json.loads(out1)
    code, out2, _ = run_cli(capsys, "sweep", rc, "--tolerance", "R1=5%", "--runs", "3",
                            "--measure", "mean(v(out))", "--json", "--workers", "1",
                            "--seed", str(r1["seed"]))
    assert [row["R1"] for row in json.loads(out2)["rows"]] == [row["R1"] for row in r1["rows"]]


M = ("--measure", "mean(v(out))")


@pytest.mark.parametrize("argv, words", [
    ((*M, "--param", "nope=1:2:3"), "nope"),
    (("--measure", "mean(v(x9))",), "unknown probe"),
    (("--measure", "avgg(v(out))",), "unknown measurement function"),
    ((*M, "--tolerance", "D9=5%", "--runs", "3"), "D9"),
    ((*M, "--runs", "3"), "no tolerance"),
    ((*M, "--tolerance", "R1=5%"), "no runs"),
    ((*M, "--plot", "x.png"), "--plot needs"),
    ((*M, "-o", "x.txt"), "cannot tell the format"),
    ((), "nothing to measure"),
    # Checked before any run (they were failed runs, exit 3):
    ((*M, "--tstop", "0"), "--tstop 0: must be positive"),
    ((*M, "--tstop", "5x"), "--tstop: '5x' is not a number"),
    ((*M, "--theta", "abc"), "--theta: 'abc' is not a number"),
    ((*M, "--step=-1u"), "--step -1u: must be positive"),
    ((*M, "--step", "1"), "--step 1 s exceeds the stop time 4 ms"),
    ((*M, "--tstop", "0.2u"), "the .tran step 500 ns exceeds the stop time 200 ns"),
    # A size that would exhaust memory (it raised _ArrayMemoryError):
    ((*M, "--param", "d=0.1:0.9:1e9"), "1e+09 values, at most 100000 per parameter"),
    ((*M, "--param", "d=0.1:0.9:1e5", "--param", "vs=1:2:20"),
     "2000000 runs (2000000 grid point(s)), at most 1000000"),
    ((*M, "--tolerance", "R1=5%", "--tolerance", "r1=10%", "--runs", "2"),
     "R1 is given twice: --tolerance 'R1=5%' and --tolerance 'r1=10%'"),
    ((*M, "--tolerance", "R*=5%", "--tolerance", "r*=1%", "--runs", "2"),
     "pattern 'R*' is given twice"),
    (("--measure", "mean(v(out)",), "bad measurement 'mean(v(out)': unbalanced parentheses"),
    ((*M, "--param", "vs=1:2:3", "--tolerance", "R1=5%", "--runs", "2", "--plot", "h.png",
      "--param", "d=0.1:0.5:5"), "--plot: 15 grid points, histograms of at most 12"),
])
def test_cli_input_errors(capsys, rc, argv, words):
    code, out, err = run_cli(capsys, "sweep", rc, *argv)
    assert code == 2 and words in err, err
    assert "Traceback" not in err and not out
    # One prefix for the command's own errors; a netlist's errors name the netlist.
    assert err.startswith("pelcs sweep: error: ") or (
        err.startswith(f"{rc}: error: unknown p")), err


def test_cli_unwritable_output_is_found_before_the_runs(capsys, rc, tmp_path, monkeypatch):
    import netlist.studies.param_sweep as ps

    def no_runs(*args, **kwargs):
        raise AssertionError("the sweep ran")

    monkeypatch.setattr(ps, "run_sweep", no_runs)
    blocker = tmp_path / "file"
    blocker.write_text("")
    (tmp_path / "dir.csv").mkdir()
    for option, path in (("-o", blocker / "t.csv"), ("--plot", blocker / "h.png"),
                         ("-o", tmp_path / "dir.csv")):
        code, out, err = run_cli(capsys, "sweep", rc, *M, "--param", "d=0.3,0.5", option,
                                 str(path))
        assert code == 2 and f"pelcs sweep: error: {option}: cannot write {path}" in err, err
    # The check leaves a writable path as it was (no empty file when the sweep then fails).
    code, out, err = run_cli(capsys, "sweep", rc, *M, "--param", "d=0.3,0.5", "-o",
                             str(tmp_path / "t.csv"), "--tstop", "0")
    assert code == 2 and not (tmp_path / "t.csv").exists()


def test_writable_check_takes_links_and_new_folders_and_changes_nothing(tmp_path):
    import os

    from pelcs.commands.sweep import _check_writable

    kept = tmp_path / "kept.csv"
    kept.write_text("old table\n")
    os.utime(kept, (1e9, 1e9))
    dangling = tmp_path / "link.csv"
    dangling.symlink_to(tmp_path / "target.csv")  # (a link to a file not written yet)
    nested = tmp_path / "new" / "deeper" / "t.csv"
    for path in (kept, dangling, nested):
        _check_writable("-o", path)
    assert kept.read_text() == "old table\n" and kept.stat().st_mtime == 1e9
    assert not (tmp_path / "target.csv").exists() and dangling.is_symlink()
    assert not (tmp_path / "new").exists()  # (the writer makes the folders)


def test_a_probe_that_is_not_finite_is_not_settled():
    from netlist.studies.measure import Settling

    for drift, limit in ((float("nan"), float("nan")), (float("inf"), 1.0),
                         (float("nan"), 1.0)):
        assert not Settling("mean(v(out))", "v(out)", drift, limit, "", "").settled
    assert Settling("mean(v(out))", "v(out)", 0.0, 0.0, "", "").settled


# -- Monte Carlo over a grid: per grid point ------------------------------------------------


def _strict_json(text: str):
    def refuse(name):
        raise ValueError(f"not JSON: {name}")

    return json.loads(text, parse_constant=refuse)


def test_monte_carlo_grid_statistics_are_per_grid_point(capsys, rc):
    code, out, err = run_cli(capsys, "sweep", rc, "--param", "vs=5,10", "--tolerance",
                             "R*=5%", "--runs", "5", "--seed", "3", "--measure",
                             "mean(v(out))", "--measure", "ripple(v(out))", "--json",
                             "--workers", "1")
    assert code == 0, err
    r = _strict_json(out)
    rows = r["rows"]
    assert len(rows) == 10 and all(isinstance(row["run"], int) for row in rows)
    assert [e["params"] for e in r["statistics"]] == [{"vs": 5.0}, {"vs": 10.0}]
    for entry in r["statistics"]:
        vs = entry["params"]["vs"]
        for name in ("mean(v(out))", "ripple(v(out))"):
            mine = np.array([row[name] for row in rows if row["vs"] == vs])
            s = entry["statistics"][name]
            assert s["n"] == 5 and isinstance(s["n"], int)
            assert s["mean"] == pytest.approx(mine.mean(), rel=1e-12)
            assert s["std"] == pytest.approx(mine.std(ddof=1), rel=1e-9)
            assert s["min"] == mine.min() and s["max"] == mine.max()
            assert s["p95"] == pytest.approx(np.percentile(mine, 95), rel=1e-12)
        # Each grid point's own nominal run: the filter's mean is vs/4 at d = 0.5.
        assert entry["statistics"]["mean(v(out))"]["nominal"] == pytest.approx(vs / 4,
                                                                               abs=2e-4)
    # The terminal table: one block of rows per grid point, never the mixture.
    code, out, err = run_cli(capsys, "sweep", rc, "--param", "vs=5,10", "--tolerance",
                             "R*=5%", "--runs", "5", "--seed", "3", "--measure",
                             "mean(v(out))", "--workers", "1")
    lines = [ln.split() for ln in out.splitlines()]
    assert ["vs", "measurement", "nominal", "mean", "std", "min", "p5", "p95", "max"] in lines
    assert [ln[:3] for ln in lines if ln[1:2] == ["mean(v(out))"]] == [
        ["5", "mean(v(out))", "1.25"], ["10", "mean(v(out))", "2.5"]]


def test_statistics_of_a_grid_need_a_point(rc):
    table = run_sweep(rc, ["mean(v(out))"], params={"vs": [5.0, 10.0]},
                      tolerances=["R1=5%"], runs=3, seed=4, workers=1)
    assert table.n_points == 2 and list(table.point_index()) == [0, 0, 0, 1, 1, 1]
    with pytest.raises(ValueError, match="2 grid points"):
        table.statistics()
    for k, vs in enumerate((5.0, 10.0)):
        assert table.point_params(k) == {"vs": vs}
        v = table["mean(v(out))"][table["vs"] == vs]
        assert table.statistics(k)["mean(v(out))"]["mean"] == pytest.approx(v.mean(), 1e-12)


def test_histogram_of_a_grid_one_panel_and_colour_per_point(rc):
    table = run_sweep(rc, ["mean(v(out))"], params={"vs": [5.0, 10.0]},
                      tolerances=["R*=5%"], runs=6, seed=2, workers=1)
    fig = histogram_figure(table, title="RC: Monte Carlo")
    axes = [ax for ax in fig.axes if ax.get_visible()]
    assert [ax.get_title(loc="left") for ax in axes] == ["vs = 5", "vs = 10"]
    colours = [ax.patches[0].get_facecolor() for ax in axes]
    assert colours[0] != colours[1]
    for ax, vs in zip(axes, (5, 10), strict=True):
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert labels[0] == f"vs = {vs}: 6 runs"
        # Units on the legend's values and the axis.
        assert labels[1].startswith("mean ") and labels[1].endswith(" V")
        assert labels[2].startswith("±1 std (") and labels[2].endswith("V)")
        assert labels[3].startswith("nominal ") and labels[3].endswith(" V")
        assert ax.get_xlabel() in ("mean(v(out)) (V)", "mean(v(out)) (mV)")
        # The counts are whole numbers.
        fig.canvas.draw()
        assert all(float(t) == int(float(t)) for t in ax.get_yticks())


def test_histogram_title_fits_the_figure(rc):
    table = run_sweep(rc, ["ripple(v(out))"], tolerances=["C1=10%"], runs=4, seed=1,
                      workers=1)
    title = ("RC low-pass filter driven by a square wave (Monte Carlo reference): Monte "
             "Carlo, 4 runs (uniform, seed 1)")
    fig = histogram_figure(table, title=title)
    fig.canvas.draw()
    box = fig._suptitle.get_window_extent(fig.canvas.get_renderer())
    assert box.x0 >= 0 and box.x1 <= fig.bbox.width
    assert fig._suptitle.get_text().replace("\n", " ") == title


# -- the steady state -----------------------------------------------------------------------

BUCK_5MS = ROOT / "converters" / "netlists" / "buck.cir"


def test_unsettled_run_is_noted_5ms_but_not_20ms(capsys):
    code, out, err = run_cli(capsys, "sweep", str(BUCK_5MS), "--measure", "ripple(v(out))",
                             "--json", "--workers", "1")
    assert code == 0, err
    r = _strict_json(out)
    row = r["rows"][0]
    assert row["ok"] and row["settled"] is False
    assert row["message"].startswith("not settled: ripple(v(out)): the averages of v(out)")
    note = next(n for n in r["notes"] if n.startswith("not settled"))
    assert "1 of 1 run(s) (the run)" in note and "10 % of its ripple per period" in note
    assert "simulate longer than 5 ms, e.g. --tstop 10m" in note
    assert row["ripple(v(out))"] == pytest.approx(55.6e-3, abs=0.2e-3)
    # 20 ms: settled, and the ripple is the analytic (1 - D) Vout / (8 L C fs²) = 15 mV.
    code, out, err = run_cli(capsys, "sweep", str(BUCK_5MS), "--measure", "ripple(v(out))",
                             "--tstop", "20m", "--json", "--workers", "1")
    r = _strict_json(out)
    assert r["rows"][0]["settled"] is True and r["rows"][0]["message"] == ""
    assert not any("settled" in n for n in r["notes"])
    assert r["rows"][0]["ripple(v(out))"] == pytest.approx(15.0e-3, rel=0.01)
    # The terminal marks the row and prints the note.
    code, out, err = run_cli(capsys, "sweep", str(BUCK_5MS), "--measure", "ripple(v(out))",
                             "--workers", "1", "--no-progress")
    assert "note: not settled: 1 of 1 run(s)" in out and "(not settled: ripple(v(out)))" in out


def test_settling_names_the_runs_of_a_sweep(tmp_path):
    table = run_sweep(BUCK_5MS, ["mean(v(out))"], params={"duty": [0.3, 0.6]}, tstop=5e-3,
                      workers=1)
    assert not table.settled.any() and table.ok.all()
    assert any(n.startswith("not settled: 2 of 2 run(s) (duty=0.3; duty=0.6)")
               for n in table.notes)
    write_sweep(table, tmp_path / "t.csv")
    lines = (tmp_path / "t.csv").read_text().splitlines()
    assert lines[0] == "duty,mean(v(out)),ok,settled,message"
    assert all(line.split(",")[2:4] == ["1", "0"] for line in lines[1:])


def test_the_settled_reference_runs_are_settled(rc):
    table = run_sweep(rc, ["mean(v(out))", "ripple(v(out))", "final(v(out))"],
                      tolerances=["R*=5%"], runs=4, seed=0, workers=1)
    assert table.settled.all() and all(m == "" for m in table.messages)
    assert not any("settled" in n for n in table.notes)


# -- JSON, grid values, tolerances ----------------------------------------------------------


def test_json_is_strict_with_nan_nominal_and_failed_rows():
    from pelcs.commands.sweep import to_json

    table = SweepTable(inputs=("run", "R1"), input_values=np.array([[0.0, 1.0], [1.0, 2.0]]),
                       measures=("mean(v(out))",), values=np.array([[1.5], [np.nan]]),
                       ok=np.array([True, False]), messages=["", "failed"], runs=2, seed=1,
                       nominal=np.array([np.nan]), distribution="uniform")
    text = json.dumps(to_json(table, "f.cir", "t", []), allow_nan=False)
    r = _strict_json(text)
    assert r["statistics"][0]["statistics"]["mean(v(out))"]["nominal"] is None
    assert r["statistics"][0]["statistics"]["mean(v(out))"]["n"] == 1
    assert r["rows"][1]["mean(v(out))"] is None and r["rows"][1]["settled"] is None
    assert [row["run"] for row in r["rows"]] == [0, 1]
    assert all(type(row["run"]) is int for row in r["rows"])


def test_grid_values_print_as_typed(capsys, tmp_path):
    name, values = parse_sweep_param("duty=0.2:0.8:4")
    assert list(values) == [0.2, 0.4, 0.6, 0.8]
    assert [repr(float(v)) for v in parse_sweep_param("x=0:0.3:4")[1]] == [
        "0.0", "0.1", "0.2", "0.3"]
    with pytest.raises(NetlistError, match="at most 100000"):
        parse_sweep_param("duty=0.1:0.9:1e9")


def test_tolerance_messages():
    only_r1 = parse_string("t\nV1 a 0 DC 1\nR1 a 0 1k\nC1 a 0 1u\n.tran 1u 1m\n.end\n")
    with pytest.raises(NetlistError) as exc:
        match_tolerances(only_r1, [parse_tolerance("R*=5%"), parse_tolerance("R1=10%")])
    assert exc.value.message == ("tolerance 'R*=5%' varies nothing: it matches only R1 "
                                 "(given as 'R1=10%')")
    # With another R the pattern varies it: accepted, R1 keeps its exact tolerance.
    rc_circuit = parse_string(RC_TEXT)
    m = match_tolerances(rc_circuit, [parse_tolerance("R*=5%"), parse_tolerance("R1=10%")])
    assert [(n, t.text) for n, t in m] == [("R1", "R1=10%"), ("R2", "R*=5%")]
    with pytest.raises(NetlistError, match="R1 is given twice"):
        match_tolerances(rc_circuit, [parse_tolerance("R1=5%"), parse_tolerance("r1=10%")])


NEG_TEXT = """RC filter with a negative resistor in series (900 ohm in all)
Vs in 0 PULSE(0 10 0 1n 1n 50u 100u)
R1 in mid 1k
Rneg mid out -100
R2 out 0 1k
C1 out 0 100n
.tran 0.5u 2m 0 0.5u UIC
.end
"""


def test_negative_resistor_keeps_its_sign():
    table = run_sweep(NEG_TEXT, ["mean(v(out))"], tolerances=["Rneg=5%"], runs=6, seed=1,
                      workers=1)
    assert table.ok.all(), table.messages
    assert ((table["Rneg"] < -95) & (table["Rneg"] > -105)).all()
    # Mean of the Thevenin source: 0.5 * 10 V * R2 / (R1 + Rneg + R2).
    want = 5.0 * 1e3 / (1e3 + table["Rneg"] + 1e3)
    np.testing.assert_allclose(table["mean(v(out))"], want, atol=2e-3)
    wide = run_sweep(NEG_TEXT, ["mean(v(out))"], tolerances=["Rneg=150%"], runs=8, seed=1,
                     workers=1)
    bad = np.flatnonzero(~wide.ok)
    # The failed runs' rows show the value drawn (it was NaN).
    assert bad.size and all(wide["Rneg"][i] > 0 for i in bad)
    assert (wide["Rneg"][wide.ok] < 0).all()
    assert all("the opposite sign of its nominal -100" in wide.messages[i] for i in bad)
