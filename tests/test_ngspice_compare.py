"""pelcs against ngspice on every bundled netlist and on the hand-written test netlists.

Each case runs :func:`ngspice_checks.compare.compare` (the engine of ``pelcs check``) and
asserts that every probe (default: every state) and every switch is within tolerance. Runs are
shortened where the full ``.tran`` would cost seconds (``tstop`` on both sides alike), so that
the whole file stays near 20-30 s on two cores.

The hand-written netlists are picked up from ``tests/netlists/`` (every ``.cir`` with a
``.tran`` line); the ones that cannot be compared meaningfully are listed in ``EXCLUDED``
with the reason, and a test checks that every netlist is either run or excluded.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from ngspice_checks.compare import (
    Tolerances,
    _hausdorff,
    _ngspice_instants,
    compare,
    default_probes,
    detect_period,
    ngspice_probe,
)
from pelcs.api import load

# (the slow part of the suite: outside the fast subset that `-m 'not slow'` selects)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]

# Netlists that are not compared, and why (paths relative to the repository).
EXCLUDED = {
    # A parser fixture (nested subcircuits, every source type): its step LCP has no solution
    # at t = 0.6 ns (a current source into an output that only reverse-biased diodes
    # connect), so pelcs stops, as it should; it was never meant to be simulated.
    "tests/netlists/interleaved_boost.cir": "parser fixture, not simulatable",
    # Non-passive on purpose (a diode into a negative resistance): pelcs stops half-way with
    # "no solution", which tests/test_simulate_cli.py checks.
    "tests/netlists/sim/negative_r.cir": "non-passive on purpose, pelcs stops",
    # Non-passive on purpose: the ideal model grows like exp(2.5e4 t) to 1e93 V, which
    # tests/test_nonpassive.py checks; ngspice's diode model departs from it long before.
    "tests/netlists/sim/tunnel_nonpassive.cir": "non-passive on purpose, grows without bound",
    # ngspice's *default* models (`.model DIDEAL D`: 0.8 V drop at 1 A; `SW` without RON:
    # 1 ohm): the relative drop is δ = 113 %, so the tolerances (3 % + 2 δ) exceed 200 % and
    # the check would pass whatever pelcs did. (half_wave.cir also has a default diode, but
    # with δ = 8 % the check still has teeth; it is compared.)
    "tests/netlists/cuk_coupled.cir": "default D/SW models, δ > 100 %: the check says nothing",
    # Diodes at 100 MHz: the 1N4148's charge storage (TT, CJO) is a third of the period and
    # pelcs' devices do not represent it; tests/test_check_devices.py checks that the check
    # does not call this agreement.
    "tests/netlists/devices/multiplier_100meg.cir": "charge storage at 100 MHz: pelcs "
    "does not model it",
    # LATCH=1 PERIOD=... is a pelcs extension of the SW model that ngspice ignores (with a
    # warning): ngspice's comparator toggles several times per period on the noisy control
    # voltage, so the two simulators run different circuits by design.
    "tests/netlists/closed_loop/vm_buck_latched.cir": "latched PWM is pelcs-only",
    # The same pelcs-only LATCH=1 PERIOD=... (peak-current-mode clock): ngspice runs a plain
    # comparator on the sensed current, which chatters instead of holding the switch off
    # until the next clock; these netlists test `pelcs ac` (tests/test_smallsignal.py).
    "tests/netlists/ac/cm_buck.cir": "latched PWM is pelcs-only",
    "tests/netlists/ac/cm_buck_current_loop.cir": "latched PWM is pelcs-only",
    "tests/netlists/exact/cm_buck_issue.cir": "latched PWM is pelcs-only",
    "tests/netlists/orbits/pcm_buck_1mF.cir": "latched PWM is pelcs-only",
    # Resistive loads only: no state to compare by default; its switching instants are
    # checked against the sources' crossings in tests/test_devices.py.
    "tests/netlists/devices/pmos_npn.cir": "no inductor or capacitor: nothing to compare",
    "tests/netlists/devices/igbt_chopper.cir": "no inductor or capacitor: nothing to compare",
    "tests/netlists/devices/vendor_parts.cir": "no inductor or capacitor: nothing to compare",
    # The macro's gate network (RG + 1 ohm with the gate-charge capacitor, ~13 ohm x 3.5 nF)
    # delays ngspice's turn-off by ~80 ns of 2.5 us: 5.6 V out against the ideal 5.02 V. The
    # idealisation drops the gate network by design; tests/test_devices.py
    # checks pelcs against the ideal duty instead.
    "tests/netlists/devices/buck_vendor.cir": "gate-network delay dropped by design",
    # A 220 ohm gate resistor into the macro's gate charge: ngspice's edges trail the ideal
    # switch's by a fraction of a microsecond; tests/test_gate_charge.py compares its pwl run
    # (the gate RC) with ngspice instead.
    "tests/netlists/devices/boost_modpex_like.cir": "gate-network delay dropped by design",
    # Two phases share the load through inductors with no series resistance: the split of
    # the current between L1 and L2 is neutrally stable, so any difference (ngspice's RON,
    # diode drops, its comparator instants landing on time steps) shifts it for good
    # (i(L1) 2.90 A vs 3.37 A, i(L2) 3.58 A vs 3.10 A after 4 ms, the sums and v(out) agree
    # within 0.2 %). Not a pelcs error; the per-phase currents are not comparable.
    "tests/netlists/closed_loop/two_phase_buck.cir": "neutrally stable current sharing",
}

# Shortened runs and parameter overrides (both simulators alike).
RUNS: dict[str, dict] = {
    "converters/netlists/boost.cir": {"tstop": 2e-3},  # starts on its orbit; rung 3, slow
    "converters/netlists/boost_smc.cir": {"tstop": 10e-3},  # 3.7 s in ngspice for 30 ms
    "converters/netlists/cuk.cir": {"tstop": 4e-3},
    "converters/netlists/bridge_rectifier.cir": {"tstop": 60e-3},
    "converters/netlists/vm_buck.cir": {"tstop": 20e-3},
    "tests/netlists/sim/boost_dcm.cir": {"tstop": 5e-3},
    "tests/netlists/closed_loop/vm_buck.cir": {"tstop": 20e-3},
    # VH = 0 is the ideal relay: pelcs slides (Filippov), ngspice's switch has no sliding
    # mode and stops with "timestep too small" on every rung. The netlist's own parameter
    # vh gives the hysteresis version, which both can run.
    "tests/netlists/closed_loop/boost_smc.cir": {"tstop": 10e-3, "params": {"vh": "50m"}},
    # From IC = 0 the LC filter rings and i(L1) goes negative around 0.25 ms; in the dead
    # time the negative current then has no path (S1 has no body diode): pelcs resets it
    # to zero impulsively, ngspice drives it into ROFF = 1 GOhm, and the two runs part
    # ways. Until then the circuit is well defined.
    "tests/netlists/closed_loop/sync_buck.cir": {"tstop": 0.2e-3},
    # The PI controller's integrator v(Cz) is where the loop absorbs ngspice's device drops
    # (0.42 % of 12 V): it settles 1.4 % higher, by design of the loop, while v(out) and
    # i(L1) agree within 0.5 %. The integrator's level is not a pelcs quantity to check.
    "tests/netlists/ac/buck_pi_loop.cir": {"probes": ["i(L1)", "v(C1)"]},
    # The reset clamp's capacitor settles where the leakage energy the clamp diode Dc passes
    # balances Rc: its level follows the diode's drop over a current decaying to zero, where
    # the pwl fit (over 0.24-4.9 A) and the exponential diode part: 40.87 V against 41.84 V
    # (2 %), while every current and the output agree within 0.1 %. The clamp level is a
    # property of the diode model, not of the formulation.
    "tests/netlists/forward_coupled.cir": {"probes": ["i(Lp)", "i(Ls)", "i(Lr)", "i(L1)",
                                                      "v(C1)"]},
}


def _has_tran(path: Path) -> bool:
    return re.search(r"^\s*\.tran\b", path.read_text(), re.M | re.I) is not None


def _cases() -> list[str]:
    bundled = sorted((ROOT / "converters" / "netlists").glob("*.cir"))
    written = sorted(p for p in (ROOT / "tests" / "netlists").rglob("*.cir") if _has_tran(p))
    rel = [str(p.relative_to(ROOT)) for p in bundled + written]
    return [r for r in rel if r not in EXCLUDED]


CASES = _cases()


def test_every_netlist_is_compared_or_excluded_with_a_reason():
    bundled = {str(p.relative_to(ROOT)) for p in (ROOT / "converters" / "netlists").glob("*.cir")}
    assert bundled and bundled <= set(CASES)  # every bundled netlist is compared
    assert len(CASES) >= 15
    assert all(EXCLUDED.values())  # every exclusion says why
    for path in RUNS:
        assert path in CASES, f"{path}: override for a netlist that is not compared"


@pytest.mark.parametrize("path", CASES)
def test_pelcs_agrees_with_ngspice(ngspice, path):
    opts = RUNS.get(path, {})
    cmp = compare(ROOT / path, probes=opts.get("probes"), params=opts.get("params"),
                  tstop=opts.get("tstop"), timeout=120)
    assert cmp.ok, f"{path}: out of tolerance: {cmp.failures}"
    assert cmp.probes  # something was compared
    # the deck ngspice ran is the parsed circuit written back (a rung adds at most options,
    # finite edges and models): same elements in the same order
    deck = cmp.ngspice_result.netlist.lower()
    circuit = load(ROOT / path, opts.get("params"))
    for el in circuit.elements:
        if getattr(el, "body_of", ""):
            continue  # an idealised transistor's body diode: inside its device in ngspice
        group = circuit.built_group(el)
        if group is not None:  # built by pelcs for one line: ngspice is given that line
            assert group.line.lower() in deck
            continue
        # (an element pelcs built, as a comparator's inner E source, is spelled with its own
        # letter: E.S1#c1)
        spelled = rf"^(?:{el.kind.lower()}\.)?{re.escape(el.name.lower())}\s"
        assert re.search(spelled, deck, re.M) or "." in el.name
    # switching instants are compared wherever both define them
    for sw in cmp.switches:
        if sw.method == "instants":
            assert sw.n_pelcs > 0 and sw.max_offset <= sw.tol


# ------------------------------------------------------------------------------------------
# pieces without ngspice


def test_default_probes_and_their_ngspice_names():
    c = load(ROOT / "converters" / "netlists" / "cuk.cir")
    probes = default_probes(c)
    assert probes == ["i(L1)", "v(C1)", "i(L2)", "v(C2)"]
    assert [ngspice_probe(c, p) for p in probes] == ["i(L1)", "v(a,b)", "i(L2)", "v(out)"]
    assert ngspice_probe(c, "v(out)") == "v(out)"


def test_period_detection():
    buck = load(ROOT / "converters" / "netlists" / "buck.cir")
    assert detect_period(buck)[0] == pytest.approx(20e-6)
    assert "Vg" in detect_period(buck)[1]
    rect = load(ROOT / "converters" / "netlists" / "bridge_rectifier.cir")
    assert detect_period(rect)[0] == pytest.approx(20e-3)
    assert detect_period(rect, period=1e-3) == (1e-3, "given (--period)")
    relax = load(ROOT / "tests" / "netlists" / "closed_loop" / "relaxation.cir")
    assert detect_period(relax)[0] is None  # free-running: needs the pelcs run
    import pelcs

    res = pelcs.simulate(relax, tstop=20e-6)
    per, where = detect_period(relax, res)
    assert per == pytest.approx(2.1764e-6, rel=1e-3) and "free-running" in where


def test_switch_instants_from_a_control_voltage():
    t = np.linspace(0.0, 1.0, 1001)
    c = np.sin(2 * math.pi * 2 * t)  # crosses 0 upwards at 0, 0.5, downwards at 0.25, 0.75
    inst = _ngspice_instants(t, c, 0.0, 0.0, None)
    # starts off (c = VT exactly decides nothing) and turns on as c rises from 0
    np.testing.assert_allclose(inst.on, [0.0, 0.5], atol=1e-9)
    np.testing.assert_allclose(inst.off, [0.25, 0.75], atol=1e-9)
    # hysteresis: on above 0.5, off below -0.5
    inst = _ngspice_instants(t, c, 0.0, 0.5, None)
    np.testing.assert_allclose(inst.on, [1 / 24, 0.5 + 1 / 24], atol=1e-4)
    np.testing.assert_allclose(inst.off, [7 / 24, 19 / 24], atol=1e-4)
    # a sample landing exactly on the band edge (ngspice does that) counts as crossed
    inst = _ngspice_instants(np.arange(4.0), np.array([0.0, 0.5 - 1e-12, 0.0, -0.5]), 0, 0.5,
                             False)
    assert len(inst.on) == 1 and len(inst.off) == 1


def test_hausdorff_offsets():
    a = np.array([1.0, 2.0, 3.0])
    assert _hausdorff(a, a + 0.01, 0.0, 4.0) == pytest.approx(0.01)
    assert _hausdorff(a, np.array([1.0, 3.0]), 0.0, 4.0) == pytest.approx(1.0)  # a missing one
    assert _hausdorff(a, np.empty(0), 0.0, 4.0) == 4.0
    # partners outside the window count: 2.99 in [2.5, 4] pairs with 3.01 or 2.98
    assert _hausdorff(np.array([2.49, 2.99]), np.array([2.51, 2.98]), 2.5, 4.0) == \
        pytest.approx(0.02)


def test_tolerances_widen_with_the_model_drops(ngspice):
    # the same circuit, once with near-ideal models, once with ngspice's default diode
    text = (ROOT / "tests" / "netlists" / "sim" / "half_wave.cir").read_text()
    steep = text.replace(".model DIDEAL D", ".model DIDEAL D(IS=1e-12 N=0.05 RS=1m)")
    soft = compare(text, tstop=40e-3, devices="ideal")
    sharp = compare(steep, tstop=40e-3, devices="ideal")
    assert soft.nonideal.delta > 0.05 > 0.01 > sharp.nonideal.delta
    assert soft.probes[0].nrms > 5 * sharp.probes[0].nrms
    assert soft.within and sharp.ok
    assert soft.probes[0].mean_tol > 5 * sharp.probes[0].mean_tol
    # tolerances over 10 % decide nothing: inconclusive, not agreement
    assert soft.probes[0].nrms_tol > 0.10
    assert soft.verdict == "inconclusive" and not soft.ok
    # with the drop-dependent part switched off, the soft diode fails the check
    strict = compare(text, tstop=40e-3, tolerances=Tolerances(k_nonideal=0.0),
                     devices="ideal")
    assert not strict.ok and "mean" in strict.probes[0].failures
    # by default the check runs pelcs with the diode fitted to its model, and the tolerances
    # follow what the fit leaves: sharp, and within them
    fitted = compare(text, tstop=40e-3)
    assert fitted.devices == "pwl" and fitted.ok
    assert fitted.probes[0].nrms_tol < 0.05 and fitted.probes[0].nrms < soft.probes[0].nrms


def test_convergence_study_two_points(ngspice, tmp_path):
    # the fast version of the convergence study (python -m pelcs.convergence): ε = 0.1 and
    # 0.01 on 1 ms runs
    import csv

    from pelcs import convergence

    assert convergence.main(["--fast", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "convergence.png").stat().st_size > 0
    with open(tmp_path / "convergence.csv") as fh:
        rows = list(csv.DictReader(fh))
    for name in ("buck", "boost"):
        soft, sharp = sorted((r for r in rows if r["converter"] == name),
                             key=lambda r: -float(r["eps"]))
        assert float(soft["eps"]) == 0.1 and float(sharp["eps"]) == 0.01
        for key in ("mean_error", "nrms_vout", "nrms_il"):
            # first order: ten times smaller models, about ten times closer to pelcs
            assert float(sharp[key]) < 0.3 * float(soft[key]), (name, key)
