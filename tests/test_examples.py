"""Every example study runs in its ``--fast`` form and shows what it claims.

Each example is a script in ``examples/`` with ``main(argv)`` taking ``--fast`` and
``--out DIR``; it is imported from its file and run into a temporary directory, in under a
minute, printing no bare ``nan`` (a value that does not exist is said in words). Besides the
files it writes, the behaviour it states in its docstring is asserted (GDCM interval counts,
agreement with analytic references). Each runs in 3-17 s with ``--fast`` (measured alone on
one core), 36 s together: the module is marked slow, out of the fast subset (under a minute
as a whole), and runs in the full suite.
"""

from __future__ import annotations

import importlib.util
import math
import re
import sys
import time
from pathlib import Path

import numpy as np
import pytest

pytestmark = pytest.mark.slow

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def load(name: str):
    """Import ``examples/<name>.py`` as a module."""
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


#: The longest an example may take with --fast, s.
FAST_LIMIT = 60.0


def run_fast(name: str, out: Path, capsys):
    """Run ``examples/<name>.py --fast --out OUT``: its module and what ``main`` returned.
    Checks the time limit and that the printed text has no bare ``nan``."""
    mod = load(name)
    t0 = time.perf_counter()
    res = mod.main(["--out", str(out), "--fast"])
    seconds = time.perf_counter() - t0
    printed = capsys.readouterr().out
    assert seconds < FAST_LIMIT, f"{name} --fast took {seconds:.0f} s"
    assert not re.search(r"\bnan\b", printed, re.IGNORECASE), printed
    return mod, res, printed


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.py")), ids=lambda p: p.stem)
def test_every_example_takes_fast_and_out(path, capsys):
    with pytest.raises(SystemExit) as exc:
        load(path.stem).main(["--help"])
    assert exc.value.code == 0
    text = capsys.readouterr().out
    assert "--fast" in text and "--out" in text


def _files(out: Path, *names: str) -> None:
    for n in names:
        f = out / n
        assert f.is_file() and f.stat().st_size > 0, f"missing {f}"


def test_gdcm_studies(tmp_path, capsys):
    mod, res, _ = run_fast("gdcm_studies", tmp_path, capsys)
    for key in ("boost_switch_open", "cuk_switch_closed", "cuk_switch_open"):
        _files(tmp_path, f"gdcm_{key}.png", f"gdcm_{key}.csv")
    _files(tmp_path, "gdcm_intervals.csv")

    # Boost, switch open: exactly one interval, from the first step to the analytic exit
    # t = R C ln(v0/Vin); no re-entry although the run goes on for several ring periods.
    b = res["boost_switch_open"]
    h = b.case.step
    assert len(b.intervals) == 1
    iv = b.intervals[0]
    assert iv.t_start <= h * 1.5 and not iv.open_end
    assert iv.t_end == pytest.approx(b.checks["t_exit analytic [s]"], abs=2 * h)
    assert b.t[-1] > 4 * iv.t_end

    # Čuk, switch closed: several finite intervals (re-entry), each followed by time outside.
    c = res["cuk_switch_closed"]
    assert len(c.intervals) >= 3
    assert all(not iv.open_end for iv in c.intervals[:-1])
    assert c.intervals[0].t_start > 0
    gaps = [b2.t_start - b1.t_end for b1, b2 in zip(c.intervals, c.intervals[1:], strict=False)]
    assert min(gaps) > 10 * c.case.step

    # Čuk, switch open: one interval lasting to the end of the run, and beyond (certificate).
    o = res["cuk_switch_open"]
    assert len(o.intervals) == 1 and o.intervals[0].open_end
    assert o.intervals[0].t_start < 50e-6
    assert o.checks["Γ stays positive after the run"] is True

    # In every GDCM the simulated λ equals Γ(x, u) up to the O(h) offset of a step's λ
    # (it belongs to the whole step: at most h max|dΓ/dt|) and w equals y.
    for r in res.values():
        assert r.checks["max |λ - Γ| inside / (h max|dΓ/dt|)"] <= 1.0
        assert r.checks["max |λ - Γ| inside / max λ"] < 0.02
        assert r.checks["max |w - y|"] < 1e-9 * max(1.0, np.abs(r.w).max())


def test_open_loop_startup(tmp_path, capsys):
    mod, res, _ = run_fast("open_loop_startup", tmp_path, capsys)
    _files(tmp_path, "open_loop_summary.csv")
    for topology, r in res.items():
        key = topology.replace("-", "_")
        _files(tmp_path, f"open_loop_{key}.png", f"open_loop_{key}.csv")
        rows = {row["quantity"]: row for row in r.summary}
        # Steady state against the averaged model: the buck mean is exact (volt-second
        # balance); the others differ by at most half the relative ripples (see
        # tests/test_converters_steady.py); ripples within 2 % of the formulas.
        ratio = rows["conversion ratio v(out)/vin"]["rel_error"]
        assert abs(ratio) < (1e-4 if topology == "buck" else 3e-3), topology
        for s in r.states:
            assert abs(rows[f"ripple {s} (p-p)"]["rel_error"]) < 0.02, (topology, s)
        # The lightly damped start-up overshoot drives the inductor current to zero for a
        # few dozen periods (DCM, where the CCM averaged model does not apply), all of them
        # in the first 2 ms; after them the averaged model restarted from the simulated
        # period average follows it within 0.5 % (about the ripple-induced error).
        assert 5 < len(r.dcm_periods) < 60 and max(r.dcm_periods) * mod.T < 2e-3
        for s in r.states:
            dev = rows[f"max |period average - averaged model| of {s} after the DCM periods "
                       "/ |steady state|"]["rel_error"]
            assert dev < 5e-3, (topology, s)


def test_prc_study(tmp_path, capsys):
    mod, res, _ = run_fast("prc_study", tmp_path, capsys)
    _files(tmp_path, "prc_waveforms.png", "prc_waveforms.csv", "prc_sweep.png",
           "prc_sweep.csv")
    points = res["sweep"]
    assert len(points) == 3
    for p in points:
        assert abs(p.drift) < 1e-4, p  # settled: last 40 periods against the 40 before
        # ideal elements are lossless: input power = load power, up to the O(h) numerical
        # dissipation of the unlocated diode commutations (h = T/400 here)
        assert 0 <= p.p_in / p.p_out - 1 < 5e-3, p
        # FHA is a guide only (15 % off at 40 kHz, where the clamped intervals are long)
        assert abs(p.vout / p.fha - 1) < 0.2, p
    # above resonance the output falls with frequency
    v = [p.vout for p in points]
    assert v[0] > v[1] > v[2]
    # the waveform run (from rest, 2 ms) ends at the sweep's steady state
    w = res["waveforms"]
    T = 1 / 55e3
    sel = w.t >= w.t[-1] - 20 * T
    mean = np.trapezoid(w["v(out,n)"][sel], w.t[sel]) / (w.t[sel][-1] - w.t[sel][0])
    assert mean == pytest.approx(points[1].vout, rel=5e-3)
    # every diode conducts in every period (full-wave bridge) and only forward
    for k in range(1, 5):
        i = w[f"i(D{k})"][sel]
        assert i.min() >= -1e-9 and i.max() > 0.5
    # ngspice, when it is installed: h = T/400 leaves pelcs up to 0.4 % low, and ngspice's
    # near-ideal diodes take about 0.1 % (see the example's docstring)
    ng = points[1].ngspice
    if np.isfinite(ng):
        assert points[1].vout == pytest.approx(ng, rel=6e-3)


def test_boost_smc(tmp_path, capsys):
    mod, runs, _ = run_fast("boost_smc", tmp_path, capsys)
    _files(tmp_path, "boost_smc.png", "boost_smc.csv")
    imp, exp = runs["implicit"], runs["explicit"]
    h = imp.h
    # implicit: one sliding interval from the analytic reaching instant to the end, s = 0 to
    # round-off, v(C1) on the analytic ideal-sliding solution up to the relay's first-order
    # error (0.3 % at h = 1 µs, so about 0.6 % at the fast run's 2 µs)
    assert len(imp.sliding) == 1 and imp.sliding[0][2] is None
    assert imp.sliding[0][1] == pytest.approx(mod.T_REACH, abs=h)
    assert imp.checks["max |s| after reaching [A]"] < 1e-12
    assert imp.checks["max |v - v_ref| / v_ref"] < 1e-2
    # explicit: no sliding mode, chattering in a band of about h times the slope of i(L1)
    # ((v - vin)/L = 23 A/ms at the end: 0.05 A per 2 µs step) with many switchings
    assert exp.sliding == []
    slope = max(mod.VIN, exp.v.max() - mod.VIN) / mod.L
    assert 0.2 * slope * h < exp.checks["max |s| after reaching [A]"] < 1.5 * slope * h
    assert exp.switchings > 1000
    assert exp.checks["max |v - v_ref| / v_ref"] < 1e-2


def test_vm_buck_responses(tmp_path, capsys):
    mod, res, _ = run_fast("vm_buck_responses", tmp_path, capsys)
    _files(tmp_path, "vm_buck_responses.png", "vm_buck_E15.csv", "vm_buck_E25.csv",
           "vm_buck_orbits.csv")
    r15, r25 = res[15.0], res[25.0]
    # E = 15 V: stable period-1 orbit (exact multipliers inside the unit circle), reached by
    # the simulation's stroboscopic samples to O(h^2) (comparator instants located in-step)
    assert r15.checks["stable orbit"] == "P1"
    assert r15.checks["P1 multipliers |max|"] < 1
    assert r15.checks["max rel. distance of the last strobe samples from it"] < 1e-5
    # the averaged model is 0.2 % off (ripple seen by the comparator)
    assert r15.checks["mean v(out) last 10 periods [V]"] == pytest.approx(
        r15.checks["averaged-model v(out) [V]"], rel=5e-3)
    # E = 25 V: period 1 has flipped (a real multiplier below -1), period 2 is stable and
    # the samples alternate between its two points
    assert r25.checks["stable orbit"] == "P2"
    assert r25.checks["P1 multiplier min real"] < -1
    assert r25.checks["P2 multipliers |max|"] < 1
    assert r25.checks["max rel. distance of the last strobe samples from it"] < 1e-5
    assert r25.checks["P2 spread v [V]"] > 1e-3
    v = r25.strobe[-4:, 1]
    assert abs(v[0] - v[2]) < 1e-6 < 1e-3 < abs(v[0] - v[1])
    # CCM on both orbits (the exact reference assumes it)
    assert min(r.checks["min i(L1) last 10 periods [A]"] for r in res.values()) > 0.1


def test_bode_plots(tmp_path, capsys):
    mod, res, _ = run_fast("bode_plots", tmp_path, capsys)
    _files(tmp_path, "bode_vm_buck.png", "bode_cm_buck.png", "bode_plots.csv")
    vm = res["vm_buck"]
    # The buck's response at the excitation frequency is the averaged model's; the sweep
    # agrees with the exact method below fs/2.
    assert vm["exact_vs_averaged_db"] < 0.02
    assert vm["sweep_vs_exact_db"] < 0.1 and vm["sweep_vs_exact_deg"] < 1.0
    # Ridley's sampling double pole: right at fs/2 for every ramp; Q grows as the ramp
    # shrinks.
    qs = [res["cm_buck"][vr]["Q"] for vr in (0.0, 0.05, 0.1)]
    assert qs[0] > qs[1] > qs[2] > 1
    assert all(r["db_at_half_fs_vs_ridley"] < 0.2 for r in res["cm_buck"].values())


def test_real_devices(tmp_path, ngspice, capsys):
    pytest.importorskip("PySpice")
    mod, res, _ = run_fast("real_devices", tmp_path, capsys)
    _files(tmp_path, "real_devices_buck.png")
    ideal, pwl, ng = res["ideal"], res["pwl"], res["ngspice"]
    # ideal devices lose nothing but the inductor's 37 mOhm
    assert ideal["efficiency"] > 0.98
    # pwl devices: the conduction drops and the gate RC's delays bring the output nearer
    # ngspice's (4.859 / 4.912 V; ideal 4.991 V); the MOSFET slides through its linear
    # region at turn-off, where pelcs records no device currents: no efficiency
    assert abs(pwl["vout"] - ng["vout"]) < min(0.015 * ng["vout"],
                                               abs(ideal["vout"] - ng["vout"]))
    assert math.isnan(pwl["efficiency"])


def test_closed_loop_controllers(tmp_path, capsys):
    _, _, printed = run_fast("closed_loop_controllers", tmp_path, capsys)
    _files(tmp_path, "closed_loop_controllers.png")
    nums = {key: [float(x) for x in re.findall(r"[-+]?\d+\.\d+", line)]
            for key, line in (ln.split(":", 1) for ln in printed.splitlines() if ":" in ln)}
    # the PI loop's integral finds the lossless duty v/Vin and the reference
    v, duty, ideal = nums["PI buck"][:3]
    assert v == pytest.approx(10.0, abs=0.01) and duty == pytest.approx(ideal, abs=1e-3)
    # ideal sliding i(L1) = 2 A: the lossless boost's sqrt(R E Iref), duty 1 - E/v
    v, ref, duty, ideal = nums["SMC boost"][1:5]
    assert v == pytest.approx(ref, rel=0.01) and duty == pytest.approx(ideal, abs=1e-3)
