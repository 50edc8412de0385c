"""The exact method in the analysis commands: probes of the exact map, failed values with
their reasons, orbits through a sliding motion.

References: circuit facts derived by hand (at the Deane-Hamill buck's sampling instant, the
ramp reset, S1 has just turned off and D1 carries the inductor current: v(sw) = 0,
i(D1) = i(L1), v(out) = v(C1)); the sliding-mode boost's closed form on the surface
(v = sqrt(R Vin Iref), and v^2 relaxing with the rate 2/(R C)).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from lcs.analysis.bifurcation import bifurcation_diagram
from lcs.analysis.orbits import find_orbit
from netlist.studies.sweep import CircuitMapFactory
from pelcs.cli import main

ROOT = Path(__file__).resolve().parents[1]
VM_BUCK = str(ROOT / "converters" / "netlists" / "vm_buck.cir")


@pytest.mark.slow  # (a few seconds: outside the fast subset)
def test_exact_bifurcation_takes_circuit_probes(capsys):
    code = main(["bifurcation", VM_BUCK, "--period", "tp", "--param", "vin=20:26:2",
                 "--transient", "150", "--record", "8", "--method", "exact",
                 "--probe", "v(out)", "--workers", "1", "--no-progress"])
    out, err = capsys.readouterr()
    assert code == 0 and "Traceback" not in err, err
    assert "20: period 1" in out and "26: period 2" in out
    f = CircuitMapFactory(path=VM_BUCK, period="tp", param="vin", method="exact")
    x0 = f(20.0).x0
    probes = ["v(out)", "i(D1)", "v(sw)", "i(L1)", "v(C1)"]
    d = bifurcation_diagram(f, [20.0, 26.0], x0=x0, transient=150, record=8, probes=probes,
                            workers=1, param_name="vin")
    s = d.branches[0].samples  # (2, 8, 5)
    assert d.branches[0].ok.all()
    np.testing.assert_allclose(s[..., 0], s[..., 4], rtol=1e-12)  # v(out) = v(C1)
    np.testing.assert_allclose(s[..., 1], s[..., 3], rtol=1e-9)  # i(D1) = i(L1)
    assert np.max(np.abs(s[..., 2])) < 1e-9  # v(sw) = 0 (ideal diode conducting)
    # the Moreau map's samples of the same probes (second order in h = 1 us)
    fm = CircuitMapFactory(path=VM_BUCK, period="tp", param="vin")
    dm = bifurcation_diagram(fm, [20.0, 26.0], x0=x0, transient=150, record=8,
                             probes=probes, workers=1, param_name="vin")
    np.testing.assert_allclose(dm.branches[0].samples[..., [0, 1, 3]], s[..., [0, 1, 3]],
                               rtol=2e-4)


def test_failed_value_prints_its_reason(tmp_path, capsys):
    """At ton = 1 ms S1 closes a diode path from the charged C1 onto the empty C2: the exact
    map has no state jump, the value fails and the summary says why; at ton = 3 ms nothing
    switches within the 2 ms period and the value runs."""
    text = (ROOT / "tests" / "netlists" / "exact" / "cap_share.cir").read_text()
    text = text.replace("PULSE(0 1 1m 1n 1n 10m 20m)", "PULSE(0 1 {ton} 1n 1n 10m 20m)")
    text = text.replace(".tran 1u 4m", ".param ton=1m\n.tran 1u 4m")
    path = tmp_path / "share.cir"
    path.write_text(text)
    code = main(["bifurcation", str(path), "--period", "2m", "--param", "ton=1m:3m:2",
                 "--transient", "0", "--record", "2", "--method", "exact", "--workers", "1",
                 "--no-progress"])
    out = capsys.readouterr().out
    assert code == 0
    rows = [line for line in out.splitlines() if line.startswith("   ")]
    assert len(rows) == 2, out
    assert rows[0].split(":", 1)[0].strip() == "0.001"
    assert "failed: no consistent diode configuration at t = 0.001" in rows[0]
    assert "use a time-stepping method" in rows[0]
    assert "failed" not in rows[1]
    assert "1 parameter value(s) failed" in out


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_exact_orbit_through_a_sliding_motion(capsys):
    """Boost under the ideal relay s = i(L1) - Iref, sampled every 100 us from rest: the
    period map slides all period on the orbit; its Jacobian (central differences of the exact
    map: no saltation for a Filippov stretch) has the sliding motion's multiplier
    exp(-2 T/(R C)) and a zero one (the surface is reached within the period)."""
    path = str(ROOT / "tests" / "netlists" / "closed_loop" / "boost_smc.cir")
    f = CircuitMapFactory(path=path, period=100e-6, method="exact")
    m = f()
    o = find_orbit(m, m.x0, pattern=False)
    assert o.converged, o.notes
    R_, vin, iref, C_ = 50.0, 12.0, 2.0, 100e-6
    assert abs(o.x[0] - iref) < 1e-9
    assert abs(o.x[1] - math.sqrt(R_ * vin * iref)) < 1e-6
    mu = sorted(abs(o.multipliers))
    assert abs(mu[1] - math.exp(-2 * 100e-6 / (R_ * C_))) < 1e-6 and mu[0] < 1e-6
    assert any("sliding motion" in n for n in m.notes)


def test_sliding_boost_crossing_at_start_up(tmp_path):
    """The relay boost starting on its surface (i(L1) = Iref) with the switch on and the
    output below Vin: both fields carry the state across the surface (i rises in either
    mode), so the switch turns off at t = 0 and no sliding starts; it starts where the off
    mode's LC ring brings i(L1) back to Iref with v(out) > Vin. The instant is computed here
    from the off mode's matrix exponential (L i' = Vin - v, C v' = i - v/R)."""
    from scipy.linalg import expm
    from scipy.optimize import brentq

    import pelcs
    from netlist.studies.transient import simulate_circuit

    text = (ROOT / "tests" / "netlists" / "closed_loop" / "boost_smc.cir").read_text()
    text = text.replace("L1 ls sw 1m\n", "L1 ls sw 1m IC=2\n")
    text = text.replace("C1 out 0 100u IC=0", "C1 out 0 100u IC=5")
    text = text.replace("S1 sw 0 0 s SWSMC", "S1 sw 0 0 s SWSMC ON")
    path = tmp_path / "smc_start.cir"
    path.write_text(text)
    res = simulate_circuit(pelcs.load(path), method="exact", tstop=1e-3, step=10e-6)
    assert res.error is None, res.error
    kinds = [(e.kind, e.mode.get("S1")) for e in res.event_log]
    assert kinds == [("switch", "off"), ("slide", "sliding")], res.event_log
    assert res.event_log[0].t == 0.0
    L_, C_, R_, vin = 1e-3, 100e-6, 50.0, 12.0
    G = np.array([[0, -1 / L_, vin / L_], [1 / C_, -1 / (R_ * C_), 0], [0, 0, 0]])

    def i_minus_iref(t):
        return (expm(G * t) @ np.array([2.0, 5.0, 1.0]))[0] - 2.0

    t_peak = 0.3e-3  # i(L1) rises while v < Vin, then falls back
    assert i_minus_iref(t_peak) > 0 > i_minus_iref(0.7e-3)
    t_slide = brentq(i_minus_iref, t_peak, 0.7e-3, xtol=1e-15)
    assert abs(res.event_log[1].t - t_slide) < 1e-12  # measured 562.2 us
