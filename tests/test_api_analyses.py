"""The Python API's analyses (``pelcs.check``, ``orbit``, ``continuation``, ``bifurcation``,
``basins``, ``sweep``) against the command line on the same netlist and options: the same
numbers as the command's ``--json``; and what a notebook shows of their results (a short
repr, a small HTML summary, a figure with labelled axes, a DataFrame)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure
from test_analysis_maps import netlists  # noqa: F401 - fixture

import pelcs
from pelcs.cli import main

ROOT = Path(__file__).resolve().parents[1]
BUCK = str(ROOT / "converters" / "netlists" / "buck.cir")

#: Bounds on what a notebook shows: a repr of a few lines, an HTML summary with a small PNG.
MAX_REPR = 800
MAX_HTML = 150_000


def cli_json(capsys, *argv: str) -> tuple[int, dict]:
    code = main(list(argv))
    return code, json.loads(capsys.readouterr().out)


def cli_text(capsys, *argv: str) -> tuple[int, str]:
    code = main(list(argv))
    return code, capsys.readouterr().out


def shown(result, *, lines: int = 12) -> None:
    """The repr is short, the HTML summary small with an inline PNG, the figure labelled."""
    text = repr(result)
    assert len(text) <= MAX_REPR and text.count("\n") < lines, text
    page = result._repr_html_()
    assert "<table>" in page and "data:image/png;base64," in page
    assert len(page) < MAX_HTML, len(page)
    fig = result.plot()
    assert isinstance(fig, Figure)
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    # every row's y axis (a zoom beside a panel shares its unit), and the x axis (shared by
    # a column: labelled at its foot)
    rows = {round(ax.get_position().y0, 3) for ax in panels if ax.get_ylabel()}
    assert all(round(ax.get_position().y0, 3) in rows for ax in panels), \
        [ax.get_ylabel() for ax in panels]
    assert panels[-1].get_xlabel(), panels[-1]


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_orbit_is_the_commands(netlists, capsys):  # noqa: F811
    code, r = cli_json(capsys, "orbit", netlists["boost"], "--period", "ts", "--param",
                       "duty=0.4", "--x0", "v(C1)=20", "--json")
    assert code == 0
    res = pelcs.orbit(netlists["boost"], period="ts", param={"duty": 0.4},
                      x0={"v(C1)": 20})
    assert res.converged and res.stability == r["stability"] == "stable"
    np.testing.assert_array_equal(res.points, r["points"])
    np.testing.assert_array_equal(res.multipliers,
                                  [complex(a, b) for a, b in r["multipliers"]])
    assert res.text == cli_text(capsys, "orbit", netlists["boost"], "--period", "ts",
                                "--param", "duty=0.4", "--x0", "v(C1)=20")[1].rstrip("\n")
    df = res.to_pandas()
    assert list(df.columns) == ["k", "i(L1)", "v(C1)"] and df.shape == (1, 3)
    shown(res)
    fig = res.plot()
    assert fig.axes[0].get_legend() is not None and fig.axes[1].get_legend() is not None
    assert "[A]" in fig.axes[1].get_xlabel() and "[V]" in fig.axes[1].get_ylabel()


def test_orbit_period_inferred_as_in_the_command(capsys):
    path = str(ROOT / "converters" / "netlists" / "boost.cir")
    code, r = cli_json(capsys, "orbit", path, "--json")
    res = pelcs.orbit(path)
    assert code == 0 and res.report["period"] == r["period"] > 0
    assert res.report["notes"] == r["notes"]
    np.testing.assert_array_equal(res.points, r["points"])


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_unconverged_orbit_says_so_and_has_no_multipliers(capsys):
    path = str(ROOT / "tests" / "netlists" / "sim" / "tunnel_nonpassive.cir")
    code, r = cli_json(capsys, "orbit", path, "--period", "16.2m", "--transient", "0",
                       "--json")
    res = pelcs.orbit(path, period="16.2m", transient=0)
    assert code == 3 and not res.converged and res.multipliers is None
    assert res.stability == r["stability"] and res.stability.startswith("unknown")
    np.testing.assert_array_equal(res.points, r["points"])
    text = repr(res)
    assert "NO period-1 orbit found" in text and "Newton did not converge" in text
    assert "max |μ|" not in text
    shown(res)


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_continuation_is_the_commands(netlists, capsys):  # noqa: F811
    argv = ["continue", netlists["boost_dcm"], "--period", "ts", "--param", "duty=0.74:0.8:4",
            "--locate-tol", "1e-3", "--x0", "v(C1)=45", "--transient", "0", "--json"]
    code, r = cli_json(capsys, *argv)
    assert code == 0
    res = pelcs.continuation(netlists["boost_dcm"], period="ts", param={"duty": (0.74, 0.8, 4)},
                             locate_tol=1e-3, x0={"v(C1)": 45}, transient=0)
    assert res.complete
    drop = ("wall_time",)
    assert {k: v for k, v in json.loads(json.dumps(res.report)).items() if k not in drop} == \
        {k: v for k, v in r.items() if k not in drop}
    assert [b["type"] for b in res.bifurcations] == [b["type"] for b in r["bifurcations"]]
    df = res.to_pandas()
    assert df.shape == (len(r["branch"]), 5)
    assert list(df.columns) == ["duty", "i(L1)", "v(C1)", "max_abs_multiplier", "stability"]
    shown(res)
    assert all(ax.get_legend() is not None for ax in res.plot().axes)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_bifurcation_is_the_commands(netlists, capsys, tmp_path):  # noqa: F811
    csv_path = tmp_path / "d.csv"
    code, out = cli_text(capsys, "bifurcation", netlists["buck"], "--period", "ts",
                         "--param", "duty=0.3:0.6:4", "--transient", "40", "--record", "3",
                         "--probe", "v(out)", "--probe", "i(L1)", "-o", str(csv_path),
                         "--workers", "1")
    assert code == 0
    res = pelcs.bifurcation(netlists["buck"], period="ts", param={"duty": "0.3:0.6:4"},
                            transient=40, record=3, probe=["v(out)", "i(L1)"], workers=1)
    df = res.to_pandas()
    cli = pd.read_csv(csv_path)
    assert list(df.columns) == ["direction", "duty", "k", "v(out)", "i(L1)"]
    assert df.shape == cli.shape == (12, 5)
    pd.testing.assert_frame_equal(df, cli, check_exact=True)
    # the summary's attractor periods are the command's
    for _direction, lo, hi, label in res.runs:
        span = f"{lo:.6g}" if lo == hi else f"{lo:.6g} .. {hi:.6g}"
        assert f"{span:>24}: {label}" in out
    shown(res)


def test_bifurcation_explicit_values_are_its_range(netlists):  # noqa: F811
    a = pelcs.bifurcation(netlists["buck"], period="ts", param={"duty": [0.3, 0.4, 0.5]},
                          transient=5, record=1, workers=1)
    b = pelcs.bifurcation(netlists["buck"], period="ts", param=["duty=0.3:0.5:3"],
                          transient=5, record=1, workers=1)
    pd.testing.assert_frame_equal(a.to_pandas(), b.to_pandas(), check_exact=True)
    with pytest.raises(ValueError, match="evenly spaced"):
        pelcs.bifurcation(netlists["buck"], period="ts", param={"duty": [0.3, 0.35, 0.5]},
                          transient=5, record=1)


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_basins_are_the_commands(netlists, capsys, tmp_path):  # noqa: F811
    npz = tmp_path / "b.npz"
    code, out = cli_text(capsys, "basins", netlists["buck"], "--period", "ts", "--grid",
                         "v(C1)=0:24:12,i(L1)=0:24:10", "-o", str(npz), "--workers", "1")
    assert code == 0
    res = pelcs.basins(netlists["buck"], period="ts",
                       grid={"v(C1)": (0, 24, 12), "i(L1)": (0, 24, 10)}, workers=1)
    z = np.load(npz)
    np.testing.assert_array_equal(res.basins.group, z["group"])
    np.testing.assert_array_equal(res.basins.steps, z["steps"])
    # (the summary line but its wall time)
    assert res.summary_text.splitlines()[2:] == out.splitlines()[2:-1]  # (no "wrote")
    df = res.to_pandas()
    assert list(df.columns) == ["v(C1)", "i(L1)", "group", "steps"] and df.shape == (120, 4)
    shown(res)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_sweep_is_the_commands(capsys):
    code, r = cli_json(capsys, "sweep", BUCK, "--param", "duty=0.3,0.5", "--measure",
                       "mean(v(out))", "--json", "--workers", "1")
    assert code == 0
    res = pelcs.sweep(BUCK, param={"duty": [0.3, 0.5]}, measure="mean(v(out))", workers=1)
    assert [row["duty"] for row in res.report["rows"]] == [0.3, 0.5]
    assert res.report["rows"] == r["rows"] and set(res.report) == set(r)
    df = res.to_pandas()
    assert list(df.columns) == ["duty", "mean(v(out))", "ok", "settled", "message"]
    assert df.shape == (2, 5)
    assert df["mean(v(out))"].tolist() == [row["mean(v(out))"] for row in r["rows"]]
    shown(res)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_monte_carlo_sweep_is_the_commands(capsys):
    argv = ["--tolerance", "R1=5%", "--runs", "3", "--seed", "1", "--measure",
            "mean(v(out))", "--tstop", "1m", "--workers", "1"]
    code, r = cli_json(capsys, "sweep", BUCK, *argv, "--json")
    res = pelcs.sweep(BUCK, tolerance={"R1": "5%"}, runs=3, seed=1, measure=["mean(v(out))"],
                      tstop="1m", workers=1)
    assert code == 0 and res.report["rows"] == r["rows"]
    assert res.report["statistics"] == r["statistics"]
    assert len(res.to_pandas()) == len(r["rows"])
    shown(res)


def test_options_are_the_commands():
    with pytest.raises(TypeError, match="unexpected keyword argument 'perod'"):
        pelcs.orbit(BUCK, perod="ts")
    with pytest.raises(ValueError, match="invalid choice"):
        pelcs.orbit(BUCK, method="euler")
    with pytest.raises(TypeError, match="path of a netlist file"):
        pelcs.orbit(pelcs.load(BUCK))
    with pytest.raises(pelcs.api.NetlistError, match="--order 0"):
        pelcs.orbit(BUCK, order=0)


def test_plot_into_a_given_axes():
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    res = pelcs.orbit(BUCK)
    fig = Figure()
    FigureCanvasAgg(fig)
    ax = fig.subplots(1, 2)[1]
    assert res.plot(ax=ax) is fig
    assert len(fig.axes) == 3 and ax not in fig.axes


def test_simulation_result_repr_is_short():
    res = pelcs.simulate(BUCK, tstop="1m")
    assert len(res.t) > 1000
    text = repr(res)
    assert len(text) <= MAX_REPR and "SimulationResult" in text, text


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_check_is_the_commands(ngspice, capsys):
    code, r = cli_json(capsys, "check", BUCK, "--tstop", "1m", "--json")
    code_text, out = cli_text(capsys, "check", BUCK, "--tstop", "1m")
    res = pelcs.check(BUCK, tstop="1m")
    assert code == code_text == 0 and res.verdict == r["verdict"] == "ok" and res.ok
    assert res.verdict_line == out.rstrip("\n").splitlines()[-1] == "within tolerance"
    for mine, theirs in zip(res.report["probes"], r["probes"], strict=True):
        assert mine["probe"] == theirs["probe"]
        assert mine["nrms"] == pytest.approx(theirs["nrms"], rel=1e-9)
        assert mine["mean_pelcs"] == theirs["mean_pelcs"]
    df = res.to_pandas()
    assert df.shape == (2, 14) and df["probe"].tolist() == ["i(L1)", "v(C1)"]
    assert df["verdict"].tolist() == ["ok", "ok"]
    for probe in df["probe"]:  # the table's verdict word of each probe
        line = next(ln for ln in out.splitlines() if ln.startswith(probe + " "))
        assert line.rstrip().endswith("ok")
    assert "within tolerance" in repr(res) and "i(L1) ok" in repr(res)
    shown(res)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_check_out_of_tolerance_says_so(ngspice, capsys):
    code, out = cli_text(capsys, "check", BUCK, "--tstop", "1m", "--pelcs-param", "duty=0.52")
    res = pelcs.check(BUCK, tstop="1m", pelcs_param={"duty": 0.52})
    assert code == 1 and res.verdict == "fail" and not res.ok
    assert res.verdict_line == out.rstrip("\n").splitlines()[-1]
    assert res.verdict_line.startswith("OUT OF TOLERANCE")
    assert "OUT OF TOLERANCE" in repr(res)
    df = res.to_pandas()
    assert "FAIL" in df["verdict"].tolist()
    for probe, verdict in zip(df["probe"], df["verdict"], strict=True):
        line = next(ln for ln in out.splitlines() if ln.startswith(probe + " "))
        assert verdict in line, (verdict, line)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_continuation_from_many_starts_is_the_commands(netlists, capsys):  # noqa: F811
    code, r = cli_json(capsys, "continue", netlists["boost"], "--period", "ts", "--param",
                       "duty=0.3:0.35:3", "--start", "v(C1)=10:30:2", "--json",
                       "--workers", "1")
    results = pelcs.continuation(netlists["boost"], period="ts", param={"duty": (0.3, 0.35, 3)},
                                 start="v(C1)=10:30:2", workers=1)
    assert code == 0 and len(results) == len(r["continuations"]) == 2
    for res, c in zip(results, r["continuations"], strict=True):
        assert res.report["x0"] == c["x0"] and res.report["same_as"] == c["same_as"]
        assert json.loads(json.dumps(res.report["branch"])) == c["branch"]
    assert results[1].report["same_as"] == 0


def test_frequency_response_repr_is_short():
    bucks = ROOT / "converters" / "netlists" / "ac" / "buck_vc.cir"
    fr = pelcs.ac(str(bucks), period="ts", inject="Vc", probes=["v(out)"], freq="100:10k:3")
    text = repr(fr)
    assert len(text) <= MAX_REPR and "3 frequencies, 100 .. 1e+04 Hz" in text, text


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_a_simulation_shows_as_the_commands_plot(tmp_path):
    res = pelcs.simulate(BUCK, tstop="1m", probes=["v(out)", "i(L1)"])
    assert isinstance(res, pelcs.api.SimulationResult)
    shown(res, lines=4)
    fig = res.plot()
    # the whole run and the last switching periods, one row per probe, as --plot draws it
    assert len(fig.axes) == 4 and "[V]" in fig.axes[0].get_ylabel()
    assert "[A]" in fig.axes[2].get_ylabel()
    assert any("mean" in ax.get_title(loc="right") for ax in fig.axes)
    outer = Figure()
    left, right = outer.subplots(1, 2)
    assert res.plot(ax=right) is outer
    rows = dict(res.summary())
    assert rows["points"] == len(res.t) and rows["switchings"] == res.switchings
    # a failed run, returned or raised, is shown the same way with its error
    failing = str(ROOT / "tests" / "netlists" / "sim" / "negative_r.cir")
    with pytest.warns(UserWarning):
        bad = pelcs.simulate(failing, probes=["v(in)"], check=False)
    assert bad.error is not None and "error" in dict(bad.summary())
    shown(bad, lines=4)
    with pytest.raises(pelcs.SimulationError) as exc, pytest.warns(UserWarning):
        pelcs.simulate(failing, probes=["v(in)"])
    assert isinstance(exc.value.result, type(res))


INCLUDED_LOAD_BUCK = """buck with its load in an include
Vin in 0 12
S1 in sw g 0 sm
D1 0 sw DI
Vg g 0 PULSE(0 1 0 1n 1n 5u 10u)
L1 sw out 47u
C1 out 0 10u
{load}
.model sm SW(VT=0.5 RON=1m ROFF=1meg)
.model DI D
.tran 50n 1m
.end
"""


def test_an_edited_include_is_read_again(tmp_path):
    # the maps of a file were kept by the top file's stamp only: with the load edited in its
    # include from 3 to 30 ohm, the second orbit was the first's (i(L1) 1.680 A, v(C1)
    # 5.999 V) where the 30 ohm buck is discontinuous (i(L1) 0 A at the period's start)
    top = tmp_path / "top.cir"
    top.write_text(INCLUDED_LOAD_BUCK.format(load=".include load.inc"))
    (tmp_path / "load.inc").write_text("R1 out 0 3\n")
    first = np.asarray(pelcs.orbit(top).points)
    (tmp_path / "load.inc").write_text("R1 out 0 30\n")
    second = np.asarray(pelcs.orbit(top).points)
    inline = tmp_path / "inline.cir"
    inline.write_text(INCLUDED_LOAD_BUCK.format(load="R1 out 0 30"))
    want = np.asarray(pelcs.orbit(inline).points)
    assert first[0, 0] == pytest.approx(1.68, abs=0.01)
    assert second == pytest.approx(want, rel=1e-9, abs=1e-12)
    assert second[0, 0] == pytest.approx(0.0, abs=1e-9)


def test_a_sweep_reads_an_edited_include_again(tmp_path):
    # its parsed netlists were kept by the top file's text: with the divider's lower
    # resistor edited in its include from 1k to 3k, the second sweep repeated the first's
    # 5 V and 10 V where the divider gives 7.5 V and 15 V
    top = tmp_path / "sw.cir"
    top.write_text("divider, its load included\n.param vin=10\nV1 in 0 {vin}\nR1 in out 1k\n"
                   ".include load.inc\n.tran 1u 100u\n.end\n")
    (tmp_path / "load.inc").write_text("R2 out 0 1k\n")

    def run():
        return pelcs.sweep(top, measure="mean(v(out))", param={"vin": [10, 20]},
                           workers=1).table.values[:, 0]

    assert run() == pytest.approx([5.0, 10.0])
    (tmp_path / "load.inc").write_text("R2 out 0 3k\n")
    assert run() == pytest.approx([7.5, 15.0])
