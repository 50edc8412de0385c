"""Small-signal frequency response: the exact method (linearised exact orbit with
saltations) against independent references: averaged models (buck, boost with its
right-half-plane zero), Ridley's current-mode model (the current-loop multiplier, the
sampling double pole at fs/2 and its Q), a closed loop whose loop gain is written by hand,
finite differences of the exact period map, and the time-domain sweep."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from converters.averaged import small_signal_model
from lcs.analysis.exact_orbit import PwlOrbitError, exact_orbit, follow_period
from lcs.integrators.exact.flow import ModeFlowError, mode_flow
from lcs.model import LCS, ComplementarityPair
from lcs.smallsignal.ltp import sampled_data_model
from lcs.smallsignal.response import loop_margins
from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.studies.ac import ac_analysis
from netlist.studies.sweep import circuit_map

AC = Path(__file__).parent / "netlists" / "ac"
TS, TF = 10e-6, 10e-9
# The duty of the trailing-edge comparator against the PULSE ramp (rise ts - 2 tf, high tf,
# fall tf): on while v(con) > ramp, i.e. D = vc (ts - tf)/ts; the modulator gain is k/VM.
K_MOD = (TS - TF) / TS


def _db(h):
    return 20 * np.log10(np.abs(h))


def _deg(h):
    return np.degrees(np.unwrap(np.angle(h)))


def _same_branch(a, b):
    """Phase b (deg) moved by whole turns onto a's branch."""
    return b + 360.0 * np.round((a - b) / 360.0)


# --- mode flows against hand-derived matrices --------------------------------------------

def _series_diode_lcs():
    """L i' = -v + λ, C v' = i - v/R with λ the diode's reverse voltage and w = i (a diode in
    series with the inductor: D = 0). L = 1 mH, C = 10 µF, R = 5 Ω."""
    L, C, R = 1e-3, 10e-6, 5.0
    A = np.array([[0.0, -1 / L], [1 / C, -1 / (R * C)]])
    B = np.array([[1 / L], [0.0]])
    Cm = np.array([[1.0, 0.0]])
    return LCS(A, B, Cm, np.zeros((1, 1)), np.zeros((2, 1)), np.zeros((1, 1)),
               ("i(L1)", "v(C1)"), (ComplementarityPair("D1", "voltage"),), ("V1",)), (L, C, R)


def test_mode_flow_state_constraint_by_hand():
    lcs, (L, C, R) = _series_diode_lcs()
    fl = mode_flow(lcs, [0])
    # Held: i = 0 and i' = 0, so λ = v and the capacitor discharges alone.
    np.testing.assert_allclose(fl.Lx, [[0.0, 1.0]], atol=1e-12)
    np.testing.assert_allclose(fl.Af, [[0.0, 0.0], [1 / C, -1 / (R * C)]], atol=1e-9)
    np.testing.assert_allclose(fl.Kx, [[1.0, 0.0]], atol=1e-12)  # up to sign
    free = mode_flow(lcs, [])
    np.testing.assert_allclose(free.Af, lcs.A)
    np.testing.assert_allclose(free.Wx, lcs.C)


def test_mode_flow_regular_pair_by_hand():
    # x' = -x + λ, w = x + 2 λ + u: held, λ = -(x + u)/2.
    lcs = LCS(np.array([[-1.0]]), np.array([[1.0]]), np.array([[1.0]]), np.array([[2.0]]),
              np.zeros((1, 1)), np.array([[1.0]]), ("x",), (ComplementarityPair("D1"),),
              ("u",))
    fl = mode_flow(lcs, [0])
    np.testing.assert_allclose(fl.Lx, [[-0.5]])
    np.testing.assert_allclose(fl.Lu, [[-0.5]])
    np.testing.assert_allclose(fl.Af, [[-1.5]])
    np.testing.assert_allclose(fl.Ef, [[-0.5]])
    assert fl.Kx.shape == (0, 1)


def test_mode_flow_undetermined_multiplier():
    # w = x does not depend on λ, and x' does not either: λ is free.
    lcs = LCS(np.array([[-1.0]]), np.array([[0.0]]), np.array([[1.0]]), np.zeros((1, 1)),
              np.zeros((1, 1)), np.zeros((1, 1)), ("x",), (ComplementarityPair("D1"),), ("u",))
    with pytest.raises(ModeFlowError, match="not determined"):
        mode_flow(lcs, [0])


# --- exact orbits: multipliers and saltation against finite differences -----------------

def _exact(path, **params):
    c = parse_file(str(path), params=params or None)
    m = circuit_map(c, "ts")
    from lcs.analysis.orbits import find_orbit

    o = find_orbit(m, m.x0, pattern=False)
    key0 = tuple(m.trajectory(o.points[0], 1).modes_visited[0])
    return m, key0, exact_orbit(m.system, m.signals, o.points[0], key0, 0.0, m.period)


@pytest.mark.parametrize("vin,vr", [(12.0, 0.1), (12.0, 0.0), (8.0, 0.0), (8.0, 0.1)])
def test_current_loop_multiplier_is_ridleys(vin, vr):
    """Peak current mode with the output held by a source: the sampled current loop is
    δi[k+1] = -(m2 - mc)/(m1 + mc) δi[k] exactly; |.| > 1 at D > 0.5 without a ramp."""
    _, _, eo = _exact(AC / "cm_buck_current_loop.cir", vin=vin, vr=vr)
    ri, L, vo = 0.1, 20e-6, 5.0
    m1, m2, mc = ri * (vin - vo) / L, ri * vo / L, vr / (TS - 2 * TF)
    expected = -(m2 - mc) / (m1 + mc)
    assert eo.monodromy.shape == (1, 1)
    assert eo.monodromy[0, 0] == pytest.approx(expected, rel=1e-9)
    assert (abs(expected) > 1) == (vin == 8.0 and vr == 0.0)
    # The switch turns off at D T with D = vo/vin (volt-second balance of the ideal buck).
    off = [e for e in eo.events if e.kind == "switch"]
    assert len(off) == 1 and off[0].t / TS == pytest.approx(vo / vin, rel=1e-9)


def test_monodromy_and_input_matrix_against_finite_differences():
    """The saltation-corrected Jacobians of the period map equal central differences of the
    exact (nonlinear) period map, on the DCM buck (a held diode, an event that moves)."""
    m, key0, eo = _exact(AC / "buck_dcm.cir")
    model = sampled_data_model(eo)
    n = eo.x0.size

    def period_map(x, du=None):
        sig = list(m.signals)
        if du is not None:
            j, dv = du
            base = sig[j]

            class Shifted:
                piecewise_linear = True

                def __call__(self, t):
                    return np.asarray(base(t), dtype=float) + dv

                def breakpoints(self, a, b):
                    return base.breakpoints(a, b)

            sig[j] = Shifted()
        return follow_period(m.system, sig, x, key0, 0.0, m.period)[2]

    fd = np.zeros((n, n))
    for i in range(n):
        e = np.zeros(n)
        e[i] = 1e-6 * max(1.0, abs(eo.x0[i]))
        fd[:, i] = (period_map(eo.x0 + e) - period_map(eo.x0 - e)) / (2 * e[i])
    np.testing.assert_allclose(eo.monodromy, fd, rtol=1e-5, atol=1e-7)
    j = [s.lower() for s in m.system.inputs].index("vc")
    dv = 1e-6
    col = (period_map(eo.x0, (j, dv)) - period_map(eo.x0, (j, -dv))) / (2 * dv)
    np.testing.assert_allclose(model.B[:, j], col, rtol=1e-5, atol=1e-7)
    # DCM: the inductor current is held at zero, so one multiplier is 0.
    assert min(abs(eo.multipliers)) < 1e-9
    assert model.dt == pytest.approx(TS)
    assert list(model.input_labels) == list(m.system.inputs)


def test_exact_orbit_rejects_non_pwl_sources():
    text = (AC / "buck_vc.cir").read_text().replace(
        "Vin in 0 DC {vin}", "Vin in 0 EXP({vin} 13 0 1m 2m 1m)")
    c = parse_string(text)
    with pytest.raises(PwlOrbitError, match="piecewise-linear.*Vin.*sweep"):
        ac_analysis(c, period="ts", inject="Vc", probes=["v(out)"], freqs=[1e3])


# --- responses against averaged and Ridley models ----------------------------------------

def test_voltage_mode_buck_against_averaged_model():
    """Control-to-output and line-to-output of the CCM buck equal the averaged model
    (natural-sampling PWM adds nothing at the excitation frequency) below fs/10."""
    c = parse_file(str(AC / "buck_vc.cir"))
    f = np.logspace(1, 4, 13)
    ctl = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)", "i(L1)"], freqs=f)
    line = ac_analysis(c, period="ts", inject="Vin", probes=["v(out)"], freqs=f)
    avg = small_signal_model("buck", 12.0, 0.5 * K_MOD, 1.0, lind=100e-6, cout=100e-6)
    H = avg(2j * np.pi * f)
    for probe, row in (("v(out)", 1), ("i(L1)", 0)):
        ref = H[row, 0, :] * K_MOD  # per volt of Vc: dD/dVc = k/VM, VM = 1
        assert np.max(np.abs(ctl.mag_db(probe) - _db(ref))) < 0.02
        ph = _same_branch(ctl.phase_deg(probe), _deg(ref))
        assert np.max(np.abs(ctl.phase_deg(probe) - ph)) < 0.1
    ref = H[1, 1, :]
    assert np.max(np.abs(line.mag_db("v(out)") - _db(ref))) < 0.02
    assert np.max(np.abs(line.phase_deg("v(out)") - _deg(ref))) < 0.1
    assert ctl.orbit["stable"] and ctl.method == "exact"


def test_boost_control_to_output_right_half_plane_zero():
    c = parse_file(str(AC / "boost_vc.cir"))
    f = np.logspace(1, 4, 13)
    fr = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)"], freqs=f)
    avg = small_signal_model("boost", 12.0, 0.5 * K_MOD, 10.0, lind=200e-6, cout=100e-6)
    ref = avg(2j * np.pi * f)[1, 0, :] * K_MOD
    assert np.max(np.abs(fr.mag_db("v(out)") - _db(ref))) < 0.1
    ph = _same_branch(fr.phase_deg("v(out)"), _deg(ref))
    assert np.max(np.abs(fr.phase_deg("v(out)") - ph)) < 1.0
    # The RHP zero (1.99 kHz) adds 90 degrees of lag on top of the double pole's 180.
    assert fr.phase_deg("v(out)")[-1] - fr.phase_deg("v(out)")[0] < -240


@pytest.mark.parametrize("vr", [0.0, 0.05, 0.1])
def test_current_mode_buck_sampling_double_pole(vr):
    """Ridley's model: the double pole at fs/2 with Q = 1/(π (mc D' - 0.5))."""
    c = parse_file(str(AC / "cm_buck.cir"), params={"vr": vr})
    f = np.array([100.0, 1e3, 1e4, 5e4])
    fr = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)"], freqs=f)
    D = fr.orbit["events"][0]["fraction"]
    vo = fr.orbit["x0"][1]
    ri, L, C, R, vin = 0.1, 20e-6, 50e-6, 2.5, 12.0
    sn, se = ri * (vin - vo) / L, vr / (TS - 2 * TF)
    mc = 1 + se / sn
    q = 1 / (np.pi * (mc * (1 - D) - 0.5))
    wn, wp = np.pi / TS, 1 / (R * C) + TS * (mc * (1 - D) - 0.5) / (L * C)
    s = 2j * np.pi * f
    ref = (R / ri) / (1 + R * TS * (mc * (1 - D) - 0.5) / L) / (1 + s / wp) / (
        1 + s / (wn * q) + s**2 / wn**2)
    err = np.abs(fr.mag_db("v(out)") - _db(ref))
    assert np.all(err[:3] < 0.2)
    assert err[3] < 0.2  # at fs/2: |H| = Q |low-frequency asymptote|, Q from 1.2 to 10
    assert np.max(np.abs(fr.phase_deg("v(out)") - _deg(ref))) < 2.0


def test_closed_loop_margins_by_hand():
    """PI-controlled buck, loop gain by Middlebrook injection against
    T(s) = gm (Rz + 1/(s Cz)) k Vin/VM / (1 + s L/R + s² L C)."""
    c = parse_file(str(AC / "buck_pi_loop.cir"))
    f = np.logspace(1, np.log10(5e4), 40)
    fr = ac_analysis(c, period="ts", loop="Vinj", freqs=f)
    gm, rz, cz, L, C, R = 104.72e-6, 198.94, 1e-6, 100e-6, 100e-6, 1.0

    def hand(fq):
        s = 2j * np.pi * fq
        return gm * (rz + 1 / (s * cz)) * K_MOD * 12.0 / (1 + s * L / R + s * s * L * C)

    fc = brentq(lambda q: abs(hand(q)) - 1, 10, 5e4)
    pm = 180 + np.degrees(np.angle(hand(fc)))
    assert fr.probes[0] == "T"
    assert fr.margins.crossover == pytest.approx(fc, rel=2e-3)
    assert fr.margins.phase_margin == pytest.approx(pm, abs=0.2)
    assert fr.margins.gain_margin is None  # the phase never reaches -180 degrees
    np.testing.assert_allclose(fr.mag_db("T"), _db(hand(f)), atol=0.02)


def test_loop_margins_of_a_known_loop():
    # T = 10/(s (1 + s)^2) (rad/s): phase crossover at 1 rad/s with |T| = 5 (GM -14 dB),
    # crossover where |T| = 1.
    w = np.logspace(-2, 2, 2001)
    s = 1j * w
    T = 10 / (s * (1 + s) ** 2)
    lm = loop_margins(w / (2 * np.pi), T)
    assert lm.phase_crossover == pytest.approx(1 / (2 * np.pi), rel=1e-3)
    assert lm.gain_margin == pytest.approx(-20 * np.log10(5), abs=0.01)
    wc = brentq(lambda x: abs(10 / (1j * x * (1 + 1j * x) ** 2)) - 1, 0.1, 10)
    assert lm.crossover == pytest.approx(wc / (2 * np.pi), rel=1e-3)
    pm = 180 + np.degrees(np.angle(10 / (1j * wc * (1 + 1j * wc) ** 2))) - 360  # unstable
    assert lm.phase_margin == pytest.approx(pm, abs=0.05) and pm < 0


# --- the sweep method against the exact one ----------------------------------------------

@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
@pytest.mark.parametrize("name", ["buck_vc.cir", "buck_dcm.cir"])
def test_sweep_agrees_with_exact_below_half_fs(name):
    c = parse_file(str(AC / name))
    f = [2e3, 2e4, 4.5e4]
    sw = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)", "i(L1)"], freqs=f,
                     method="sweep")
    ex = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)", "i(L1)"],
                     freqs=sw.freq)  # the sweep's snapped frequencies
    for p in ("v(out)", "i(L1)"):
        assert np.max(np.abs(sw.mag_db(p) - ex.mag_db(p))) < 0.1
        assert np.max(np.abs(sw.phase_deg(p) - ex.phase_deg(p))) < 1.0


def test_frd_export():
    c = parse_file(str(AC / "buck_vc.cir"))
    fr = ac_analysis(c, period="ts", inject="Vc", probes=["v(out)", "i(L1)"],
                     freqs=[100.0, 1e3, 1e4])
    frd = fr.to_frd()
    assert list(frd.output_labels) == ["v(out)", "i(L1)"]
    resp = frd(2j * np.pi * 1e3)  # at a measured point
    np.testing.assert_allclose(np.ravel(resp), fr.H[1], rtol=1e-12)


# --- errors and the command line ---------------------------------------------------------

def test_unknown_source_and_probe_are_named():
    c = parse_file(str(AC / "buck_vc.cir"))
    with pytest.raises(NetlistError, match="(?s)no independent source 'Vx'.*Vin, Vc, Vramp"):
        ac_analysis(c, period="ts", inject="Vx", probes=["v(out)"])
    with pytest.raises(NetlistError, match="probe"):
        ac_analysis(c, period="ts", inject="Vc", probes=[])


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_cli_json_csv_plot(tmp_path, capsys):
    from pelcs.cli import main

    out, png = tmp_path / "bode.csv", tmp_path / "bode.png"
    rc = main(["ac", str(AC / "buck_vc.cir"), "--period", "ts", "--inject", "Vc",
               "--probe", "v(out)", "--freq", "100:10k:5", "--json", "-o", str(out),
               "--plot", str(png), "--averaged", "buck:vin=12,d=0.4995,r=1,l=100u,c=100u,"
               "gain=0.999"])
    assert rc == 0
    data = json.loads(capsys.readouterr().out)
    assert len(data["freq"]) == 5 and data["freq"][0] == pytest.approx(100.0)
    assert set(data["probes"]["v(out)"]) == {"mag_db", "phase_deg", "re", "im"}
    assert data["orbit"]["stable"] and data["orbit"]["method"] == "exact"
    rows = out.read_text().splitlines()
    assert rows[0] == "freq,v(out)_mag_db,v(out)_phase_deg" and len(rows) == 6
    assert float(rows[1].split(",")[1]) == pytest.approx(data["probes"]["v(out)"]["mag_db"][0])
    assert png.stat().st_size > 10_000


def test_cli_loop_and_errors(capsys):
    from pelcs.cli import main

    rc = main(["ac", str(AC / "buck_pi_loop.cir"), "--period", "ts", "--loop", "Vinj",
               "--freq", "50:2k:6"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "loop gain: crossover" in text and "phase margin" in text
    assert main(["ac", str(AC / "buck_vc.cir"), "--period", "ts", "--inject", "Vc",
                 "--probe", "v(out)", "--freq", "10k:100:5"]) == 2
    assert "FMIN < FMAX" in capsys.readouterr().err
    assert main(["ac", str(AC / "buck_vc.cir"), "--period", "ts", "--probe", "v(out)"]) == 2
    assert main(["ac", str(AC / "buck_vc.cir"), "--period", "ts", "--inject", "Vc",
                 "--probe", "v(out)", "--averaged", "buck:vin=12"]) == 2
