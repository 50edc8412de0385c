"""A B source whose expression is a smooth function of ``time`` alone, read as the independent
source of that waveform (netlist.time_expression), compared with ngspice 39 point by point."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.circuit import CurrentSource, VoltageSource
from netlist.parser import parse_string
from netlist.writer import write_circuit
from tests.netlist_asserts import refused_at

DECK = """b of time
.param f=1k amp=5
B1 n1 0 V=amp*sin(2*pi*f*time) + 0.5*cos(2*pi*3*f*time)
R1 n1 0 1
B2 n2 0 V=1k*time
R2 n2 0 1
B3 0 n3 I=2m*exp(-time/200u)*(-2)^2
R3 n3 0 1k
B4 n4 0 V=pwr(sin(2*pi*f*time), 3)
R4 n4 a 100
C4 a 0 1u
.tran 1u 2m
.end
"""
PROBES = ["v(n1)", "v(n2)", "v(n3)", "v(a)"]


def _ngspice(tmp_path, deck: str) -> np.ndarray:
    data = ngspice_wrdata(deck, PROBES, tmp_path, before=["set numdgt=15"])
    return np.column_stack([data[:, 0], data[:, 1::2]])


def test_the_sources_and_their_values():
    c = parse_string(DECK)
    b1, b2, b3 = (c.element(n) for n in ("B1", "B2", "B3"))
    assert isinstance(b1, VoltageSource) and isinstance(b3, CurrentSource)
    assert b1.dc == pytest.approx(0.5)
    t = np.array([0.1e-3, 0.25e-3])
    assert b1.waveform(t) == pytest.approx(5 * np.sin(2 * np.pi * 1e3 * t)
                                           + 0.5 * np.cos(2 * np.pi * 3e3 * t), rel=1e-14)
    assert b2.waveform(t) == pytest.approx(1e3 * t, rel=1e-15)
    # ngspice's B-source power: (-2)^2 = |-2|^2 = 4
    assert b3.waveform(0.0) == pytest.approx(8e-3)
    assert b1.waveform.top_frequency() == pytest.approx(3e3)
    assert b2.waveform.top_frequency() is None


def test_against_ngspice(tmp_path, ngspice):
    from pelcs.api import simulate

    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    ng = _ngspice(tmp_path, DECK)
    c = parse_string(DECK)
    # the waveforms at ngspice's own instants: within 2.5e-14 V (B3: its current into 1k)
    for k, (name, scale) in enumerate((("B1", 1.0), ("B2", 1.0), ("B3", 1e3))):
        err = np.abs(scale * c.element(name).waveform(ng[:, 0]) - ng[:, k + 1]).max()
        assert err <= 1e-12, (name, err)
    # a run, ngspice's rows (1 us apart) interpolated onto pelcs's: 1e-5 V measured
    res = simulate(DECK, probes=PROBES)
    for k in range(4):
        want = np.interp(res.t, ng[:, 0], ng[:, k + 1])
        assert np.abs(res.y[:, k] - want).max() < 5e-5, PROBES[k]


def test_the_writer_writes_a_b_line_back():
    c = parse_string(DECK)
    text = write_circuit(c)
    assert "B1 n1 0 V=" in text and "B3 0 n3 I=" in text
    again = parse_string(text)
    t = np.linspace(0, 2e-3, 7)
    for name in ("B1", "B2", "B3", "B4"):
        assert again.element(name).waveform(t) == pytest.approx(c.element(name).waveform(t),
                                                                rel=1e-12, abs=1e-15)


def test_the_step_resolves_its_frequency():
    from pelcs.api import simulate

    res = simulate(DECK.replace(".tran 1u 2m", ".tran 10u 2m"), probes=["v(n1)"])
    assert res.t[1] == pytest.approx(1 / 3e3 / 100)
    assert any("1/100" in n for n in res.notes), res.notes


@pytest.mark.parametrize(("expr", "part"), [
    ("ddt(sin(time))", "ddt(sin(time))"), ("time > 1m ? idt(time) : 0", "idt(time)")])
def test_a_function_of_time_pelcs_does_not_evaluate_is_refused(expr, part):
    refused_at(f"t\nB1 n1 0 V={expr}\nR1 n1 0 1\n.tran 1u 2m\n.end\n", (2, 11 + expr.index(part)),
               [part, "not a function pelcs evaluates"])


# ------------------------------------------------------------------ piecewise functions of time

SAW = "time/10u - floor(time/10u)"


def _wave(expr: str, params: str = ""):
    c = parse_string(f"t\n{params}B1 n1 0 V={expr}\nR1 n1 0 1\n.tran 1u 1m\n.end\n")
    return c.element("B1").waveform


def test_a_sawtooth_jumps_at_each_period():
    w = _wave(SAW)
    assert w.jumps and w.piecewise_linear
    bp = w.breakpoints(0.0, 1e-3)
    # the instants k*10 us, in closed form (the argument is affine between them)
    assert bp.size == 99
    assert np.abs(bp - 1e-5 * np.arange(1, 100)).max() <= 1e-18
    # its one-sided limits there: 1 before, 0 after
    assert w(bp, side=-1) == pytest.approx(np.ones(99), abs=1e-9)
    assert w(bp, side=1) == pytest.approx(np.zeros(99), abs=1e-9)
    assert w.top_frequency() == pytest.approx(1e5)


def test_a_pwm_of_a_sawtooth_and_a_constant():
    w = _wave(f"({SAW}) < 0.3 ? 5 : 0")
    assert w.jumps and w.piecewise_linear
    bp = w.breakpoints(0.0, 1e-4)
    want = np.sort(np.concatenate((1e-5 * np.arange(1, 10), 1e-5 * np.arange(10) + 3e-6)))
    assert bp.size == want.size and np.abs(bp - want).max() <= 1e-18
    t = np.array([1e-6, 2.9e-6, 3.1e-6, 9.9e-6, 10.1e-6])
    assert list(w(t)) == [5, 5, 0, 0, 5]


def test_a_sine_compared_with_a_triangle_crossings_to_round_off():
    """Sine-triangle PWM: the instants against scipy's root finder on each half period."""
    from scipy.optimize import brentq

    tri = "abs(2*(time/50u - floor(time/50u)) - 1)"  # 1 -> 0 -> 1 each 50 us
    w = _wave(f"0.5 + 0.4*sin(2*pi*1k*time) > {tri} ? 12 : 0")
    assert w.jumps and w.piecewise_linear
    bp = w.breakpoints(0.0, 1e-3)

    def g(t):
        x = t / 50e-6 - np.floor(t / 50e-6)
        return 0.5 + 0.4 * np.sin(2 * np.pi * 1e3 * t) - abs(2 * x - 1)

    want = []
    for k in range(20):  # each half period of the triangle is smooth: one crossing in it
        for a, b in ((k * 50e-6, k * 50e-6 + 25e-6), (k * 50e-6 + 25e-6, (k + 1) * 50e-6)):
            a1, b1 = a + 1e-15, b - 1e-15
            if np.sign(g(a1)) != np.sign(g(b1)):
                want.append(brentq(g, a1, b1, xtol=1e-18, rtol=1e-15))
    # the breakpoints also hold the triangle's own corners (its kinks), k*25 us
    crossings = bp[np.abs(bp / 25e-6 - np.round(bp / 25e-6)) > 1e-6]
    assert crossings.size == len(want) == 40
    assert np.abs(crossings - np.array(want)).max() <= 1e-15


def test_a_sine_in_a_comparison_is_found_where_it_turns():
    w = _wave("sin(2*pi*1k*time) > 0.5 ? 1 : 0")
    bp = w.breakpoints(0.0, 2e-3)
    want = np.sort(np.concatenate([np.array([1 / 12, 5 / 12]) * 1e-3 + k * 1e-3
                                   for k in range(2)]))
    assert np.abs(bp - want).max() <= 1e-17


def test_a_sine_modulated_pwm_has_each_instant_once():
    """100 kHz carrier, 50 Hz modulation over 0.1 s: 9,999 carrier jumps and one crossing a
    period, each where the sawtooth meets the level, none twice."""
    w = _wave("(time/10u - floor(time/10u)) < 0.3 + 0.2*sin(2*pi*50*time) ? 1 : 0")
    bp = w.breakpoints(0.0, 0.1)
    jumps = np.abs(bp / 1e-5 - np.round(bp / 1e-5)) < 1e-7
    assert jumps.sum() == 9_999 and (~jumps).sum() == 10_000
    x = bp[~jumps]
    phase = x / 1e-5 - np.floor(x / 1e-5)
    # (where the sine is nearly straight over a period the crossing is the chord's, within
    # the affine test's 1e-9 of the value: 1e-14 s at this carrier's slope)
    assert np.abs(phase - (0.3 + 0.2 * np.sin(2 * np.pi * 50 * x))).max() <= 2e-9
    assert np.diff(bp).min() > 1e-7


def test_piecewise_smooth_is_not_piecewise_linear():
    w = _wave("abs(sin(2*pi*1k*time))")
    assert not w.piecewise_linear and not w.jumps
    assert np.abs(w.breakpoints(0.0, 2e-3) - np.array([0.5, 1.0, 1.5]) * 1e-3).max() <= 1e-17


def test_functions_and_operators_as_ngspice_evaluates_them():
    w = _wave("nint(time/1m - 0.5) + 10*u2(time/1m - 1) + 100*!(time > 1.5m) + "
              "1000*sgn(time - 0.5m) + 10000*uramp(time - 2m) + min(time, 1m)*1e6 + "
              "(time > 0.2m && time < 0.4m) + (time < 0.1m || time > 2.9m)")
    t = np.array([0.05, 0.3, 0.7, 1.2, 1.7, 2.5, 2.95]) * 1e-3
    want = [np.rint(x / 1e-3 - 0.5) + 10 * np.clip(x / 1e-3 - 1, 0, 1)
            + 100 * (not x > 1.5e-3) + 1000 * np.sign(x - 0.5e-3)
            + 1e4 * max(x - 2e-3, 0) + min(x, 1e-3) * 1e6 + (0.2e-3 < x < 0.4e-3)
            + (x < 0.1e-3 or x > 2.9e-3) for x in t]
    assert w(t) == pytest.approx(want, rel=1e-12)


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_too_many_instants_is_an_error():
    from netlist.errors import NetlistError

    w = _wave("floor(time/1f)")
    with pytest.raises(NetlistError, match="over 2,000,000 instants"):
        w.breakpoints(0.0, 1.0)
    # a 1 GHz sine over 1 s: refused, where samples capped per interval aliased it into a
    # few thousand crossings it does not have
    w = _wave("sin(2*pi*1e9*time) > 0 ? 1 : 0")
    with pytest.raises(NetlistError, match="too many to look for the instants"):
        w.breakpoints(0.0, 1.0)
    # a chirp (its frequency no sine's): sampled finer until its crossings are told apart,
    # sin(2 pi 1e7 t^2) turning where 1e7 t^2 is a half-integer: 2e4 over 10 ms
    bp = _wave("sin(2*pi*1e7*time*time) > 0 ? 1 : 0").breakpoints(0.0, 0.01)
    k = np.arange(1, 2000)
    assert bp.size == k.size and np.abs(bp - np.sqrt(k / 2e7)).max() < 1e-15
    # 100 kHz over 1 s: its 200,000 crossings, each at a multiple of 5 us
    bp = _wave("sin(2*pi*1e5*time) > 0 ? 1 : 0").breakpoints(0.0, 1.0)
    assert bp.size == 199_999 and np.abs(bp / 5e-6 - np.round(bp / 5e-6)).max() < 1e-6


PWM_DECK = """pwm of a B sawtooth into an RC, and a buck driven by it
.param T=20u
Bsaw saw 0 V = time/T - floor(time/T)
Bpwm g 0 V = V(saw) < 0.4 ? 1 : 0
Bdrv d 0 V = (time/T - floor(time/T)) < 0.4 ? 5 : 0
R1 d o 1k
C1 o 0 10n
S1 vin sw g 0 SW1
.model SW1 SW(VT=0.5 VH=0 RON=10m ROFF=10meg)
Vin vin 0 12
D1 0 sw DI
.model DI D(IS=1e-14 N=0.01)
L1 sw out 100u
C2 out 0 20u
R2 out 0 5
.tran 0.1u 2m
.end
"""


@pytest.mark.slow
def test_pwm_of_a_b_sawtooth_against_ngspice(tmp_path, ngspice):
    """A B-source sawtooth and PWM (floor of time) in pelcs and ngspice (its step bounded to
    50 ns, as the jumps land inside ngspice's steps): the RC's mean and the buck's."""
    from pelcs.api import simulate

    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    probes = ["v(o)", "v(out)"]
    deck = PWM_DECK.replace(".tran 0.1u 2m", ".tran 0.1u 2m 0 50n")
    data = ngspice_wrdata(deck, probes, tmp_path)
    t, ng = data[:, 0], data[:, 1::2]
    res = simulate(PWM_DECK, probes=probes)
    half = t >= 1e-3
    mask = res.t >= 1e-3
    for k, name in enumerate(probes):
        want = np.trapezoid(ng[half, k], t[half]) / (t[half][-1] - t[half][0])
        got = np.trapezoid(res.y[mask, k], res.t[mask]) / (res.t[mask][-1] - res.t[mask][0])
        assert got == pytest.approx(want, rel=0.01), name
    # the RC's mean is the PWM's: 0.4 * 5 V
    got = np.trapezoid(res.y[mask, 0], res.t[mask]) / (res.t[mask][-1] - res.t[mask][0])
    assert got == pytest.approx(2.0, rel=2e-3)


@pytest.mark.slow
def test_pelcs_check_reports_the_step_its_run_took(ngspice):
    """The B sawtooth's 5 kHz sets a 2 us step under '.tran 20u': the check's report and its
    comparison grid use that step, not the .tran line's (which it printed before)."""
    from ngspice_checks.compare import compare
    from pelcs.check_report import format_table

    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    deck = PWM_DECK.replace(".param T=20u", ".param T=200u").replace(
        ".tran 0.1u 2m", ".tran 20u 4m")
    cmp = compare(deck, ["v(o)"], timeout=120)
    assert cmp.step == pytest.approx(2e-6)
    assert "steps of 2 µs" in format_table(cmp)
    # the RC's mean is the PWM's, 0.4 * 5 V (ngspice as written, its steps up to 20 us with
    # no breakpoint at the jumps, gives 1.889 V: the check fails, as it should)
    assert cmp.probes[0].mean_pelcs == pytest.approx(2.0, rel=1e-3)
    assert not cmp.ok and "v(o): nrms, mean" in cmp.failures
    assert any(n.startswith("Bsaw, Bdrv: a B source of time that jumps")
               and "ngspice puts no breakpoint there" in n for n in cmp.notes), cmp.notes


@pytest.mark.parametrize("expr, at0", [
    ("u(time)*5", 2.5),            # u(0) is 0.5
    ("sgn(time)*5", 0.0),          # (a TimeExpression)
    ("time > 0 ? 5 : 0", 0.0),     # (a stepped source, its PWL)
    ("5*u(-time)", 2.5),
    ("ceil(time/100u)*5", 0.0),
    ("(time == 0)*5", 5.0),        # an equality of time: true at the operating point only
    ("time != 0 ? 5 : 2.5", 2.5),
])
def test_the_operating_point_takes_the_value_at_time_zero(expr, at0):
    # ngspice's operating point evaluates the B source at t = 0 itself (measured in ngspice
    # 39: v(out) at 100 us is 4.0711 V for u(time)*5, 3.1234 V for sgn(time)*5; its mean over
    # 1 ms 1.29999 V for the equality of time (time == 0)*4 + (time != 0)): the
    # capacitor starts there and charges through R in the run, v(out) = v + (at0 - v) e^(-t/RC)
    from pelcs.api import simulate
    deck = f"t0\nB1 g 0 V = {expr}\nR1 g out 1k\nC1 out 0 100n\n.tran 1u 100u\n.end\n"
    res = simulate(deck, probes=["v(out)"])
    v_after = 0.0 if "-time" in expr or "==" in expr else 5.0
    assert res.y[0, 0] == pytest.approx(at0, abs=1e-9)
    assert res.y[-1, 0] == pytest.approx(v_after + (at0 - v_after) * np.exp(-1), abs=1e-4)


def test_a_pwl_that_jumps_at_time_zero_starts_from_its_first_point():
    # ngspice: PWL(0 0 0 5) is 0 at the operating point (the first point of its time)
    from pelcs.api import simulate
    deck = "p\nV1 g 0 PWL(0 0 0 5 1m 5)\nR1 g out 1k\nC1 out 0 100n\n.tran 1u 100u\n.end\n"
    res = simulate(deck, probes=["v(out)"])
    assert res.y[-1, 0] == pytest.approx(5 * (1 - np.exp(-1)), abs=1e-4)


def test_a_narrow_excursion_between_samples_is_found():
    # a sine over a level near its peak: 4.5 us of each 1 ms period, narrower than the
    # samples (32 a period); each of the ten pulses' two instants, where sin = 0.9999
    w = _wave("sin(2*pi*1k*time) > 0.9999 ? 10 : 0")
    half = np.arccos(0.9999) / (2 * np.pi * 1e3)
    peaks = (np.arange(10) + 0.25) * 1e-3
    want = np.sort(np.concatenate([peaks - half, peaks + half]))
    got = w.breakpoints(0.0, 10e-3)
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_a_long_run_of_a_sawtooth_is_not_refused_for_its_samples():
    # 100 kHz over 2.5 s: 499,999 instants, under the bound (the samples, 34 per period,
    # are not what the bound counts)
    w = _wave("time/10u - floor(time/10u) > 0.5 ? 1 : 0")
    got = w.breakpoints(0.0, 2.5)
    assert got.size == 499_999
    np.testing.assert_allclose(got[:3], [5e-6, 10e-6, 15e-6], rtol=1e-12)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_a_staircase_crossing_hundreds_of_levels_between_samples():
    # floor(exp(time/1m)) over 10 ms: 22,025 steps, at t = ln(n) ms, up to ~215 of them
    # between two of its samples near the end
    w = _wave("floor(exp(time/1m))")
    got = w.breakpoints(0.0, 10e-3)
    want = np.log(np.arange(2, int(np.exp(10)) + 1)) * 1e-3
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)


def test_a_sine_of_a_sawtooth_phase_is_sampled_at_its_own_frequency():
    # the argument is not affine (its phase restarts each 1 ms), so no frequency is read from
    # the expression; its slope is 2 pi 100 kHz: 2000 instants where it crosses 0.5 over
    # 10 ms (with --method exact, 69 were found and the RC's final value was 4.80 V, not
    # 3.3248 V as the analytic one and pelcs now)
    w = _wave("sin(2*pi*100k*(time - floor(time/1m)*1m)) > 0.5 ? 10 : 0")
    got = w.breakpoints(0.0, 10e-3)
    k = np.arange(1000) * 1e-5
    want = np.sort(np.concatenate([k + 1e-5 / 12, k + 5e-5 / 12]))
    jumps = np.arange(1, 10) * 1e-3  # (where the phase restarts)
    assert got.size == want.size + jumps.size
    near = np.abs(got[:, None] - want[None, :]).min(axis=0)
    assert near.max() < 1e-15


def test_the_step_resolves_a_sine_whose_argument_is_not_affine():
    # a 100 kHz sine whose phase restarts each 1 ms: 1/100 of its period (at 1 us, the .tran
    # bound, the RC's output was 6 % of its amplitude off); at 3 ms the steady state
    # -sin(phi)/sqrt(1 + (wRC)^2), phi = atan(wRC): -0.45053 V (ngspice -0.45048 V)
    from pelcs.api import simulate
    deck = ("t\nB1 g 0 V = sin(2*pi*100k*(time - floor(time/1m)*1m))\nR1 g out 1k\n"
            "C1 out 0 1n\n.tran 1u 3m\n.end\n")
    res = simulate(deck, probes=["v(out)"])
    assert res.step == pytest.approx(1e-7)
    wrc = 2 * np.pi * 1e5 * 1e-6
    want = -np.sin(np.arctan(wrc)) / np.sqrt(1 + wrc ** 2)
    assert res.y[-1, 0] == pytest.approx(want, abs=2e-4)


@pytest.mark.slow  # (over 0.7 s: outside the fast subset)
def test_a_sine_over_many_periods_in_one_interval_is_sampled_in_pieces():
    # 100 kHz over 1 s, no other breakpoint: 200,000 instants (62,144 were found, the
    # samples of one interval capped)
    w = _wave("sin(2*pi*100k*time) > 0.5 ? 1 : 0")
    got = w.breakpoints(0.0, 1.0)
    k = np.arange(100_000) * 1e-5
    want = np.sort(np.concatenate([k + 1e-5 / 12, k + 5e-5 / 12]))
    assert got.shape == want.shape
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-15)


def test_a_step_beside_a_fast_sine_is_sampled_as_its_own_argument():
    # u(time - 1m) beside a 1 MHz sine over 10 s: its argument has no sine, its one instant
    # is found at once (sampled at the sine's rate it was refused as too fast)
    w = _wave("sin(2*pi*1meg*time) + u(time-1m)")
    np.testing.assert_allclose(w.breakpoints(0.0, 10.0), [1e-3], rtol=1e-15)


def test_a_source_out_of_its_domain_is_named_where_the_run_stops():
    # sqrt(500u - time) is NaN past 500 us (ngspice: 'out of range for sqrt'): the run keeps
    # its points up to there, and the error names the source, not an unstable mode
    from lcs.results import SimulationError
    from pelcs.api import simulate

    with pytest.raises(SimulationError) as info:
        simulate("t\nB1 g 0 V=sqrt(500u - time)\nR1 g out 1k\nC1 out 0 100n\n"
                 ".tran 1u 1m\n.end\n", probes=["v(out)"])
    res = info.value.result
    assert res.error.kind == "non_finite"
    assert "the input B1 is not a finite number there" in str(res.error)
    assert res.t[-1] == pytest.approx(500e-6) and np.isfinite(res.y).all()


def test_ltspice_limit_of_time_is_refused_with_the_clamp_to_write():
    # LTspice's limit(x, lo, hi): refused where it stands, naming the max/min form instead
    expr = "6+2*limit((time-1m)/0.1m,0,1)"
    refused_at(f"t\nB1 n1 0 V={expr}\nR1 n1 0 1\n.tran 1u 2m\n.end\n",
               (2, 11 + expr.index("limit")),
               ["limit(x, lo, hi)", "not a function of ngspice's B sources",
                "max(lo, min(hi, x))"])


def test_the_clamp_written_with_max_and_min_is_the_ramp_it_clamps():
    # the rewrite the refusal suggests: 6 V before 1 ms, a ramp to 8 V over 0.1 ms, then 8 V
    w = _wave("6+2*max(0, min(1, (time-1m)/0.1m))")
    t = np.array([0.0, 0.5e-3, 1e-3, 1.05e-3, 1.1e-3, 1.5e-3])
    np.testing.assert_allclose(w(t), [6, 6, 6, 7, 8, 8], atol=1e-12)


@pytest.mark.parametrize("gate", ["V1 c 0 PWL(0 0 0 5 1m 5)", "B1 c 0 V=time > 0 ? 5 : 0"])
def test_a_switch_whose_gate_jumps_at_time_zero_is_off_in_the_operating_point(gate):
    # ngspice's operating point takes the gate at t = 0 itself (0 V): the switch is off
    # there, the capacitor uncharged, and the switch turns on in the first step (ngspice 39:
    # mean v(y) over 2 ms 8.67653 V); pelcs had it on, the capacitor at 9.09 V from the start
    from pelcs.api import simulate
    deck = (f"t\n{gate}\nS1 in x c 0 swm\n.model swm sw vt=2.5 ron=1 roff=1e9\nV2 in 0 10\n"
            "R1 x y 1k\nC1 y 0 100n\nR2 y 0 10k\n.tran 1u 2m\n.end\n")
    res = simulate(deck, probes=["v(y)"])
    t, y = res.t, res.y[:, 0]
    assert y[0] == pytest.approx(0.0, abs=1e-9)
    # switched on at 0+, RON left out: 10 V through 1k into 100n || 10k
    final, tau = 10 * 10e3 / 11e3, 100e-9 * 1e3 * 10e3 / 11e3
    assert y == pytest.approx(final * (1 - np.exp(-t / tau)), abs=1e-4)


def test_a_source_out_of_its_domain_stops_a_run_with_no_state(tmp_path, capsys):
    # no capacitor or inductor: the outputs are the inputs', so no state turns NaN for the
    # kernel to stop at; sqrt(sin(2 pi 1k t)) leaves its domain after 0.5 ms
    from pelcs.cli import main

    deck = tmp_path / "nan.cir"
    deck.write_text("t\nB1 a 0 V=sqrt(sin(2*pi*1k*time))\nR1 a 0 1k\n.tran 10u 2m\n.end\n")
    out = tmp_path / "a.csv"
    code = main(["simulate", str(deck), "--no-progress", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 3
    assert "non_finite" in err and "the input B1 is not a finite number there" in err
    data = np.genfromtxt(out, delimiter=",", skip_header=1, ndmin=2)
    assert np.isfinite(data).all() and 0.49e-3 < data[-1, 0] <= 0.5e-3
    # (up to there, the source itself: sqrt(sin(2 pi 1k t)))
    np.testing.assert_allclose(data[:, 1], np.sqrt(np.sin(2 * np.pi * 1e3 * data[:, 0])),
                               rtol=1e-8, atol=1e-6)  # (10 digits written)
