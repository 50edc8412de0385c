"""Newton shooting converges from the initial state of periodic converters, and a point it does
not converge to is never reported with multipliers.

The peak-current-mode buck with a 1 mF output capacitor (tests/netlists/orbits/) has a slow
multiplier 0.9985; from its start (output 12 V above the 6.64 V set point, no current) the
Jacobian describes another piece of the map (the switch on for 92 % of the period) and the
damped Newton step, accepted whenever the residual's max norm decreased, crawled: 40
iterations, residual 5.6e-4, and a "period-1 orbit" with D = 0.92 and a multiplier -1.43 was
printed. The references are independent of the map's Newton: the closed-form duty of the
peak-current-mode buck, the exact (event-driven) method's orbit, and the settled state of a
long transient.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from lcs.analysis.orbits import find_orbit
from netlist.studies.sweep import CircuitMapFactory
from pelcs.cli import main

ROOT = Path(__file__).resolve().parents[1]
PCM = str(ROOT / "tests" / "netlists" / "orbits" / "pcm_buck_1mF.cir")


def _duty(r: dict) -> float:
    """Fraction of the period with S1 on, from the orbit's switching pattern."""
    on = [s["duration"] for s in r["pattern"] if s["switches"]["S1"] == "on"]
    return sum(on) / r["period"]


def _orbit_json(capsys, *argv: str) -> tuple[int, dict]:
    code = main(["orbit", *argv, "--json"])
    return code, json.loads(capsys.readouterr().out)


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_pcm_buck_orbit_from_the_initial_state_has_the_true_duty(capsys):
    code, r = _orbit_json(capsys, PCM, "--period", "ts", "--transient", "0")
    assert code == 0 and r["converged"] and r["residual"] < 1e-10
    # closed form (CCM, ideal devices): -0.3 D^2 + 1.2504 D = 0.6 (see the netlist)
    d_ref = (1.2504 - np.sqrt(1.2504**2 - 4 * 0.3 * 0.6)) / 0.6
    assert abs(_duty(r) - d_ref) < 1e-3, (_duty(r), d_ref)  # measured 0.5533 vs 0.55328
    # the exact method's orbit, Newton after 400 periods (a start it converged from before)
    code, e = _orbit_json(capsys, PCM, "--period", "ts", "--method", "exact",
                          "--transient", "400")
    assert code == 0 and e["converged"]
    np.testing.assert_allclose(r["points"][0], e["points"][0], rtol=1e-5)
    slow = max(complex(*m).real for m in r["multipliers"])
    assert abs(slow - 0.99847) < 1e-4  # the output capacitor's slow multiplier
    # and the exact map's own Newton from the initial state too
    code, e0 = _orbit_json(capsys, PCM, "--period", "ts", "--method", "exact",
                           "--transient", "0")
    assert code == 0 and e0["converged"]
    np.testing.assert_allclose(e0["points"][0], e["points"][0], rtol=1e-10)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("path, period, params, periods", [
    # Deane-Hamill buck: from rest the Newton steps of the residual test left the orbit's
    # piece of the map (residual 467 and 4.7e8 after 40 iterations)
    ("converters/netlists/vm_buck.cir", "tp", (), 150),
    ("converters/netlists/vm_buck.cir", "tp", (("vin", 24.0),), 150),
    # the parallel resonant converter from an all-zero state: Newton stalls there and
    # converges after a restart from 16 periods of transient
    ("converters/netlists/prc.cir", "ts", (), 600),
])
def test_orbit_from_rest_matches_the_settled_transient(path, period, params, periods):
    m = CircuitMapFactory(path=str(ROOT / path), period=period, overrides=params)()
    o = find_orbit(m, m.x0, pattern=False)
    assert o.converged, o.notes
    # the transient has settled: |mu|^periods < 1e-9 (|mu| = 0.824 and 0.964)
    ref = m.power(m.x0, periods)
    np.testing.assert_allclose(o.x, ref, rtol=0, atol=1e-9 * np.max(np.abs(ref)))


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_unconverged_orbit_prints_no_multipliers(capsys):
    """A circuit whose state grows without bound has no orbit: the last iterate is printed
    as such, without Floquet multipliers or a stability verdict, and the exit status is 3."""
    path = str(ROOT / "tests" / "netlists" / "sim" / "tunnel_nonpassive.cir")
    code = main(["orbit", path, "--period", "16.2m", "--transient", "0"])
    out = capsys.readouterr().out
    assert code == 3
    assert "NO period-1 orbit found" in out and "no periodic orbit" in out
    assert "NOT converged" in out
    assert "Floquet multipliers" not in out and "|μ|" not in out
    assert "stability: unknown" in out
    code, r = _orbit_json(capsys, path, "--period", "16.2m", "--transient", "0")
    assert code == 3 and r["converged"] is False
    assert r["multipliers"] is None and r["stable"] is None and r["jacobian"] is None
