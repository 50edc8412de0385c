"""``pelcs ac`` on every bundled converter: a response (exit 0) or a clear refusal (exit 2,
saying why and what to do), never a failure without a reason.

The self-oscillating sliding-mode boost is checked against its averaged power-balance model,
the rectifier against the physics of full-wave rectification (an additive perturbation of
the AC source reaches the capacitor only at fs +- f, so its response at f is zero).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pelcs.cli import main

NETLISTS = Path(__file__).resolve().parents[1] / "converters" / "netlists"

#: The source perturbed and the probe measured on each bundled converter (fast settings).
RUNS = {
    "boost.cir": ["--inject", "Vin", "--probe", "v(out)"],
    "boost_dcm.cir": ["--inject", "Vin", "--probe", "v(out)"],
    "boost_smc.cir": ["--inject", "Vin", "--probe", "v(out)", "--method", "sweep",
                      "--period", "10u"],
    "bridge_rectifier.cir": ["--inject", "Vs", "--probe", "v(p,n)"],
    "buck.cir": ["--inject", "Vin", "--probe", "v(out)"],
    "buck_boost.cir": ["--inject", "Vin", "--probe", "v(out)"],
    "cuk.cir": ["--inject", "Vin", "--probe", "v(out)"],
    "prc.cir": ["--inject", "Vdrv", "--probe", "v(out)"],
    "vm_buck.cir": ["--inject", "Vin", "--probe", "v(out)"],
    "ac/buck_vc.cir": ["--inject", "Vc", "--probe", "v(out)"],
    "ac/buck_pi_loop.cir": ["--loop", "Vinj"],
}


def test_every_bundled_netlist_has_a_run():
    found = {p.relative_to(NETLISTS).as_posix() for p in NETLISTS.rglob("*.cir")}
    assert found == set(RUNS)


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("name", sorted(RUNS))
def test_ac_runs_on_bundled_converter(name, capsys):
    freq = "100:1k:2" if name != "bridge_rectifier.cir" else "1:20:2"
    rc = main(["ac", str(NETLISTS / name), "--freq", freq, "--json", *RUNS[name]])
    out, err = capsys.readouterr()
    assert rc == 0, err
    data = json.loads(out)
    assert len(data["freq"]) == 2
    for probe in data["probes"].values():
        assert all(m is None or np.isfinite(m) for m in probe["mag_db"])


def test_sliding_mode_boost_refused_without_period_and_with_exact(capsys):
    path = str(NETLISTS / "boost_smc.cir")
    for extra in ([], ["--period", "10u"]):
        rc = main(["ac", path, "--inject", "Vin", "--probe", "v(out)", "--freq", "100:1k:2",
                   *extra])
        err = capsys.readouterr().err
        assert rc == 2
        assert "S1 switches on the circuit's own state" in err
        assert "self-oscillates" in err and "--method sweep --period T" in err
        assert "Traceback" not in err


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_sliding_mode_boost_against_power_balance(capsys):
    """Ideal current control i(L1) = iref: C dv/dt = vin iref / v - v / R, linearised at
    V = sqrt(vin iref R): v/vin = (iref / V) / (s C + 2 / R)."""
    rc = main(["ac", str(NETLISTS / "boost_smc.cir"), "--inject", "Vin", "--probe", "v(out)",
               "--method", "sweep", "--period", "10u", "--freq", "100:1k:2", "--json"])
    data = json.loads(capsys.readouterr().out)
    assert rc == 0
    vin, iref, r, c = 12.0, 2.0, 50.0, 100e-6
    v = np.sqrt(vin * iref * r)
    f = np.asarray(data["freq"])
    h = (iref / v) / (2j * np.pi * f * c + 2.0 / r)
    got = data["probes"]["v(out)"]
    assert np.allclose(got["mag_db"], 20 * np.log10(np.abs(h)), atol=0.1)
    assert np.allclose(got["phase_deg"], np.degrees(np.angle(h)), atol=1.0)


def test_rectifier_has_no_response_at_the_perturbation_frequency(capsys):
    rc = main(["ac", str(NETLISTS / "bridge_rectifier.cir"), "--inject", "Vs",
               "--probe", "v(p,n)", "--probe", "v(p)", "--freq", "1:20:2", "--json"])
    data = json.loads(capsys.readouterr().out)
    assert rc == 0
    # v(p,n) (one probe, not v(p and n)) is the capacitor: zero response at f
    assert all(m is None or m < -150 for m in data["probes"]["v(p,n)"]["mag_db"])
    # v(p) alone follows the source while D1 conducts: a response of a few dB
    assert all(-10 < m < 0 for m in data["probes"]["v(p)"]["mag_db"])


def test_unstable_orbit_refused_by_the_sweep(capsys):
    rc = main(["ac", str(NETLISTS / "vm_buck.cir"), "--inject", "Vin", "--probe", "v(out)",
               "--param", "vin=30", "--method", "sweep", "--freq", "100:1k:2"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "unstable (spectral radius 1.7" in err and "--method exact" in err


def test_exact_on_unstable_orbit_says_so(capsys):
    rc = main(["ac", str(NETLISTS / "vm_buck.cir"), "--inject", "Vin", "--probe", "v(out)",
               "--param", "vin=30", "--freq", "100:1k:2"])
    out = capsys.readouterr().out
    assert rc == 0
    assert "the periodic steady state is unstable" in out


def test_loop_source_must_be_zero_volt(capsys):
    rc = main(["ac", str(NETLISTS / "vm_buck.cir"), "--loop", "Vref"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "not a zero-volt source" in err and "--loop Vinj" in err


def test_period_must_be_a_multiple_of_the_netlists(capsys):
    """A state that returns to itself after 13 µs from t0 is no steady state of a buck
    switched every 20 µs (before, it was linearised and reported as one, fs = 76.9 kHz);
    a multiple of the period is the same orbit, and the same response."""
    base = ["ac", str(NETLISTS / "buck.cir"), "--inject", "Vin", "--probe", "v(out)",
            "--freq", "100:1k:2"]
    assert main([*base, "--period", "13u"]) == 2
    err = capsys.readouterr().err
    assert "--period 13 µs is not a multiple of the period the netlist defines, 20 µs" in err
    responses = []
    for extra in ([], ["--period", "40u"]):
        assert main([*base, *extra, "--json"]) == 0
        responses.append(json.loads(capsys.readouterr().out)["probes"]["v(out)"])
    assert np.allclose(responses[0]["re"], responses[1]["re"], rtol=1e-6, atol=1e-9)
    assert np.allclose(responses[0]["im"], responses[1]["im"], rtol=1e-6, atol=1e-9)
