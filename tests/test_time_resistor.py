"""Resistors whose value is a piecewise-constant function of ``time`` (:mod:`netlist.time_value`):
the intervals read from the expression, the elements they become, the response against its
analytic value and side by side with ngspice, where ngspice lands the change, what the
other parts of pelcs make of the parts (``--devices pwl``, losses, the writer), and the
refusals with their line and column."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from netlist.behavioural_expr import parse_behavioural
from netlist.circuit import Resistor, Switch, VoltageSource
from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.pwl import pwl_circuit
from netlist.time_function import TimeValue
from netlist.time_value import time_value
from netlist.writer import write_circuit
from pelcs.api import simulate

DCDC = Path(__file__).parent / "corpus" / "ngspice" / "examples" / "vdmos" / "dcdc.sp"
# the load of ngspice's examples/vdmos/dcdc.sp, as written there (unquoted)
DCDC_R4 = "(time<12ms ? {Rload} : time<20ms ? {Rload/2} : {2*Rload})"


def test_the_intervals_of_the_dcdc_load_by_hand():
    # Rload = 100: 100 Ω until 12 ms, Rload/2 = 50 Ω until 20 ms, 2*Rload = 200 Ω after
    tv = time_value(parse_behavioural(DCDC_R4), DCDC_R4, {"rload": 100.0})
    assert tv == TimeValue((12e-3, 20e-3), (100.0, 50.0, 200.0))
    assert [tv.at(t) for t in (0.0, 11.9e-3, 12e-3, 19.9e-3, 20e-3, 1.0)] == [
        100.0, 100.0, 50.0, 50.0, 200.0, 200.0]
    # combinations: a window by &&, its complement by ||, !, u(), an affine function of time
    for text, want in [
            ("time > 1m && time < 2m ? 1k : 2k", ((1e-3, 2e-3), (2e3, 1e3, 2e3))),
            ("2*time - 2m < 0 || time > 3m ? 3k : 1k", ((1e-3, 3e-3), (3e3, 1e3, 3e3))),
            ("!(time < 1m) ? 1k : 2k", ((1e-3,), (2e3, 1e3))),
            ("1k + 1k*u(time - 1m)", ((1e-3,), (1e3, 2e3))),
            # an instant where the value does not change is no instant
            ("time < 1m ? 1k : time < 2m ? 1k : 3k", ((2e-3,), (1e3, 3e3))),
            ("time > -1 ? 1k : 2k", ((), (1e3,))),
            # one instant written two ways (0.3 and 0.1*3 differ by round-off): one instant
            ("time < 0.3 ? 1k : time < 0.1*3 ? 2k : 3k", ((0.3,), (1e3, 3e3)))]:
        assert time_value(parse_behavioural(text), text, {}) == TimeValue(*want), text


def test_the_dcdc_line_becomes_its_least_value_and_bypassed_segments():
    c = parse_string(f"t\n.param Rload=100\nV4 out2 0 0\nV1 OUT 0 5\nR4 out2   OUT    R = "
                     f"{DCDC_R4}\n.tran 1u 30m\n.end\n")
    els = {el.name: el for el in c.elements}
    r4 = els["R4"]
    assert isinstance(r4, Resistor) and r4.value == 50.0 and r4.nodes == ("out2", "r4#m1")
    assert r4.time_value == TimeValue((12e-3, 20e-3), (100.0, 50.0, 200.0))
    # 50 Ω + 50 Ω (bypassed while R < 100 Ω) + 100 Ω (bypassed while R < 200 Ω)
    assert (els["R4#r2"].value, els["R4#r3"].value) == (50.0, 100.0)
    assert els["R4#r2"].nodes == ("r4#m1", "r4#m2") and els["R4#r3"].nodes == ("r4#m2", "out")
    for j, on in ((2, (False, True, False)), (3, (True, True, False))):
        sw, src = els[f"R4#s{j}"], els[f"R4#v{j}"]
        assert isinstance(sw, Switch) and sw.built_for == "R4" and sw.nodes == els[
            f"R4#r{j}"].nodes and sw.control == (f"r4#c{j}", "0")
        assert isinstance(src, VoltageSource) and src.built_for == "R4"
        # the control is +1 V where the switch is on, -1 V where off, 0 V at an instant
        # where it turns
        wave = src.waveform
        assert [float(np.sign(wave(t))) for t in (6e-3, 16e-3, 25e-3)] == [
            1.0 if s else -1.0 for s in on]
        turns = [t for k, t in enumerate((12e-3, 20e-3)) if on[k] != on[k + 1]]
        assert [wave(t) for t in turns] == [0.0] * len(turns)
    assert c.models["r4#sw"].params == {"vt": 0.0, "vh": 0.0}
    note = next(n for n in c.notes if n.startswith("R4:"))
    assert "100 Ω until 12 ms, 50 Ω until 20 ms, 200 Ω after" in note
    assert "no breakpoint at the instants" in note
    from pelcs.commands.info import describe

    assert f"note: {note}" in describe(c)  # (pelcs info: the elements and the note)


def test_the_dcdc_file_reads_its_load_stepped_in_time_and_its_clamp_as_a_limiter():
    import warnings

    from lcs.notices import IdealisedDeviceWarning

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)  # (its VDMOS: a switch)
        c = parse_file(DCDC)
    r4 = c.element("R4")
    assert isinstance(r4, Resistor) and r4.time_value is not None
    assert any(n.startswith("B1: clamp") and "ideal limiter" in n for n in c.notes), c.notes


# An RC charged through a resistor stepped at 1 ms and 2 ms: 1 kΩ, 500 Ω, then 2 kΩ.
RC = """RC charged through a resistor stepped in time
.param Rl=1k
V1 in 0 1
R1 in out R = '(time<1ms ? {Rl} : time<2ms ? {Rl/2} : {2*Rl})'
C1 out 0 1u ic=0
.tran 10u 3m 0 1u uic
.end
"""


def _rc_exact(t: np.ndarray) -> np.ndarray:
    """v(out) of RC (V): time constants 1 ms, 0.5 ms, 2 ms over the three intervals."""
    v1 = 1 - math.exp(-1.0)
    v2 = 1 - (1 - v1) * math.exp(-2.0)
    return np.where(t < 1e-3, 1 - np.exp(-t / 1e-3),
                    np.where(t < 2e-3, 1 - (1 - v1) * np.exp(-(t - 1e-3) / 0.5e-3),
                             1 - (1 - v2) * np.exp(-(t - 2e-3) / 2e-3)))


def test_the_rc_response_is_the_analytic_one():
    res = simulate(RC, probes=["v(out)", "i(R1)"])
    # the bypasses turn exactly at the instants
    assert [t for t, _ in res.events] == [1e-3, 2e-3]
    assert res.switching == {"R1#s2": "source", "R1#s3": "source"}
    t, v = np.asarray(res.t), np.asarray(res["v(out)"])
    assert np.max(np.abs(v - _rc_exact(t))) < 1e-7  # (θ = 1/2, h = 1 µs: 5.8e-8 V)
    # i(R1) is the resistor's current: (1 - v) / R(t)
    r = np.where(t < 1e-3, 1e3, np.where(t < 2e-3, 500.0, 2e3))
    inside = (np.abs(t - 1e-3) > 1e-9) & (np.abs(t - 2e-3) > 1e-9)
    assert np.allclose(np.asarray(res["i(R1)"])[inside], ((1 - v) / r)[inside], rtol=0,
                       atol=1e-12)


def test_the_exact_method_switches_at_the_instants():
    from netlist.studies.transient import simulate_circuit

    res = simulate_circuit(parse_string(RC), method="exact", probes=["v(out)"])
    t, v = np.asarray(res.t), np.asarray(res["v(out)"])
    # (exact between events: the round-off of the matrix exponentials only)
    assert np.max(np.abs(v - _rc_exact(t))) < 1e-12


def test_an_inductor_in_series_keeps_its_current_through_the_steps():
    # RL: 1 V through R(t) into 1 mH; i = V/R (1 - exp(-R t/L)) piecewise; the path never
    # opens at an instant (a decrease and an increase of R)
    deck = ("RL\nV1 in 0 1\nR1 in x R = 'time < 2u ? 1k : time < 4u ? 250 : 4k'\n"
            "L1 x 0 1m ic=0\n.tran 2n 6u 0 2n uic\n.end\n")
    res = simulate(deck, probes=["i(L1)"])
    t, i = np.asarray(res.t), np.asarray(res["i(L1)"])
    want = np.empty_like(t)
    i0 = 0.0
    for (a, b), r in zip(((0, 2e-6), (2e-6, 4e-6), (4e-6, 6e-6 + 1e-12)), (1e3, 250.0, 4e3),
                         strict=True):
        k = (t >= a) & (t < b)
        want[k] = 1 / r + (i0 - 1 / r) * np.exp(-r * (t[k] - a) / 1e-3)
        i0 = 1 / r + (i0 - 1 / r) * math.exp(-r * (b - a) / 1e-3)
    # (θ = 1/2, h = 2 ns against time constants down to 0.25 µs)
    assert np.max(np.abs(i - want)) < 1e-5 * np.max(np.abs(want))


def test_the_rc_side_by_side_with_ngspice_on_the_written_deck(tmp_path, ngspice):
    circuit = parse_string(RC)
    written = write_circuit(circuit)
    assert "R1 in out R = 'time < 1m ? 1k : time < 2m ? 500 : 2k'" in written
    assert parse_string(written).elements == circuit.elements  # (read back: the same)
    res = simulate(RC, probes=["v(out)"])
    ng = ngspice_wrdata(written, ["v(out)"], tmp_path)
    t_ng, v_ng = ng[:, 0], ng[:, 1]
    mine = np.interp(t_ng, np.asarray(res.t), np.asarray(res["v(out)"]))
    # ngspice (TMAX = 1 µs) lands each change inside its step that straddles the instant;
    # here its time points 0.9995 and 1.0005 ms (1.9995, 2.0005 ms) straddle the instants
    # evenly, so its trapezoidal step acts about at the instant: 1.1e-7 V from pelcs at most
    # and 2.5e-9 V at the end, 1.1e-7 V from the analytic values (measured; pelcs 5.8e-8)
    assert np.max(np.abs(mine - v_ng)) < 1e-6
    assert abs(mine[-1] - v_ng[-1]) < 1e-7
    assert np.max(np.abs(v_ng - _rc_exact(t_ng))) < 1e-6


def test_ngspice_lands_the_change_inside_its_step_past_the_instant(tmp_path, ngspice):
    # 1 kΩ then 2 kΩ at 1 ms, 1 µF: after the change v = 1 - exp(-tc/1ms) exp(-(t - tc)/2ms),
    # so v(3 ms) tells where the change acted: tc = -2 ms (ln(1 - v(3 ms)) + 1.5)
    deck = ("RC\nV1 in 0 1\nR1 in out R = 'time < 1m ? 1k : 2k'\nC1 out 0 1u ic=0\n"
            ".tran 10u 3m 0 200u uic\n.end\n")

    def landed(v3: float) -> float:
        return -2e-3 * (math.log(1 - v3) + 1.5)

    res = simulate(deck.replace("200u uic", "1u uic"), probes=["v(out)"])
    assert landed(float(res["v(out)"][-1])) == pytest.approx(1e-3, abs=2e-9)
    ng = ngspice_wrdata(deck, ["v(out)"], tmp_path)
    t = ng[:, 0]
    before, after = t[t < 1e-3][-1], t[t >= 1e-3][0]
    tc = landed(float(ng[-1, 1]))
    # its time points 0.937 ms and 1.137 ms: the change acts at 1.05 ms (trapezoidal),
    # inside that step, 52 µs late (measured with ngspice 39)
    assert before < 1e-3 < after and before < tc < after
    assert tc - 1e-3 > 20e-6


def test_devices_pwl_leaves_the_bypasses_ideal():
    c = parse_string(RC)
    out, fits = pwl_circuit(c, {}, {})
    assert fits == [] and out.elements == c.elements


def test_losses_count_the_segments_as_the_resistors_power():
    # 1 V across R(t) = 1 kΩ then 2 kΩ from 2.5 ms: over the window [a, b] the losses take
    # (whole periods of 0.2 ms at the end) the mean power is 1 mW before 2.5 ms, 0.5 mW after
    from netlist.studies.losses import loss_probes, losses

    deck = ("R\nV1 in 0 1\nR1 in 0 R = 'time < 2.5m ? 1k : 2k'\nR2 in 0 10k\n"
            ".tran 1u 3m 0 1u\n.end\n")
    c = parse_string(deck)
    probes = loss_probes(c)
    assert "i(R1#r2)" in probes and not any("#s" in p or "#v" in p for p in probes)
    res = simulate(deck, probes=probes)
    rep = losses(res, c, period=0.2e-3, load="R1")
    a, b = rep.window
    assert a < 2.5e-3 < b
    want = (1e-3 * (2.5e-3 - a) + 0.5e-3 * (b - 2.5e-3)) / (b - a)
    assert rep.load == "R1" and rep.p_out == pytest.approx(want, rel=1e-3)
    assert rep.resistors == pytest.approx({"R2": 0.1e-3})
    assert rep.devices == {}  # (its bypass switches are no devices)
    assert rep.p_in == pytest.approx(want + 0.1e-3, rel=1e-3)


def _error(line: str) -> str:
    with pytest.raises(NetlistError) as err:
        parse_string(f"t\nV1 a 0 1\n{line}\n.tran 1u 1m\n.end\n", "n.cir")
    return str(err.value)


@pytest.mark.parametrize(("line", "where", "what"), [
    ("R1 a 0 R = 'time < 1m ? 0 : 1k'", "3:13", "is 0 Ω from t = 0 to 1 ms: a resistance "
                                                "must be positive"),
    ("R1 a 0 R = 'time < 1m ? 1k : time < 2m ? -5 : 1k'", "3:13",
     "is -5 Ω from 1 ms to 2 ms: a resistance must be positive"),
    ("R1 a 0 R = 'time < 1m ? v(a) : 2k'", "3:13",
     "has a value that depends on v(a): a nonlinear resistor"),
    ("R1 a 0 R = '1k + time*1k'", "3:18", "'time' outside a comparison"),
    ("R1 a 0 R = 'sin(time) < 0.5 ? 1k : 2k'", "3:13",
     "'sin(time) < 0.5' does not compare an affine function of time with constants"),
    ("R1 a 0 R = 'time == 1m ? 1k : 2k'", "3:13", "an equality of time"),
    ("R1 a 0 R = '" + " + ".join(f"(time > {k}m)*{k}k" for k in range(1, 10)) + " + 1k'",
     "3:13", "changes 9 times over t > 0 (10 intervals): more than pelcs expands"),
    ("R1 a 0 R = 'time < 1m ? {Rx} : 2k'", "3:25", "unknown parameter 'rx'"),
    # unquoted with blanks: ngspice's value is 'time' alone
    ("R1 a 0 R = time < 1m ? 1k : 2k", "3:12",
     "written unquoted: ngspice reads an unquoted value only up to its first blank outside "
     "parentheses: R = time"),
])
def test_refusals_name_the_line_column_and_the_accepted_form(line, where, what):
    msg = _error(line)
    assert f"n.cir:{where}: error: resistor 'R1'" in msg and what in msg
    if "unknown parameter" not in what:
        assert "piecewise-constant function of time" in msg  # (the hint: what pelcs reads)


def test_positional_and_braced_values_are_read_as_ngspice_reads_them():
    for value in ("{time<1m ? 1k : 2k}", "'time<1m ? 1k : 2k'", "r={time<1m ? 1k : 2k}",
                  "R = (time<1m)?{1k}:{2k}"):
        c = parse_string(f"t\nV1 a 0 1\nR1 a 0 {value}\n.tran 1u 2m\n.end\n")
        assert c.element("R1").time_value == TimeValue((1e-3,), (1e3, 2e3)), value


# A buck whose load steps from 5 Ω to 10 Ω at 1 ms (dcdc.sp's load step, on a converter
# ngspice and pelcs both run as written).
BUCK = """buck with a load stepped in time
Vin in 0 DC 12
Vg g 0 PULSE(0 1 0 10n 10n 4.99u 10u)
S1 in sw g 0 sm
.model sm SW(VT=0.5 RON=10m)
D1 0 sw dm
.model dm D(IS=1e-14 RS=10m)
L1 sw out 100u
C1 out 0 100u
R1 out 0 R = 'time < 1ms ? 5 : 10'
.tran 0.1u 2m 0 0.1u uic
.end
"""


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_pelcs_check_compares_a_buck_with_a_load_step(tmp_path, ngspice):
    import pelcs

    path = tmp_path / "buck.cir"
    path.write_text(BUCK)
    res = pelcs.check(path, probe=["v(out)", "i(R1)", "i(L1)"])
    # (measured: means 5.726 V and 5.713 V, 572.6 mA and 571.3 mA; S1's 400 switchings)
    assert res.verdict == "ok", res.verdict_line
    # the bypass is pelcs' model of R1, not a switch of the circuit ngspice runs
    assert "switch S1" in res.table and "R1#s2" not in res.table


def test_a_subcircuit_instance_and_a_parameter_override():
    deck = """sub
.param Rl=1k
.subckt load a b R0=1k
R4 a b R = 'time < 1m ? {R0} : {2*R0}'
.ends
V1 in 0 1
R1 in out 1k
X1 out 0 load R0={Rl}
C1 out 0 1u ic=0
.tran 10u 3m 0 1u uic
.end
"""
    c = parse_string(deck)
    assert c.element("X1.R4").time_value == TimeValue((1e-3,), (1e3, 2e3))
    assert c.element("X1.R4#s2").nodes == ("x1.r4#m1", "0")
    written = write_circuit(c)
    assert "R.X1.R4 out 0 R = 'time < 1m ? 1k : 2k'" in written
    assert parse_string(written).elements == c.elements
    # 1 V through 1 kΩ into 1 µF || R(t): v = 0.5 (1 - exp(-t/0.5 ms)) until 1 ms, then
    # towards 2/3 V with 1 kΩ || 2 kΩ = 2/3 kΩ: v(3 ms) = 0.6550000 V (ngspice 39 on the
    # written deck: 0.6549999 V)
    v1 = 0.5 * (1 - math.exp(-2.0))
    want = 2 / 3 + (v1 - 2 / 3) * math.exp(-2e-3 / (2e-3 / 3))
    res = simulate(deck, probes=["v(out)"])
    assert float(res["v(out)"][-1]) == pytest.approx(want, abs=1e-6)
    over = simulate(deck, probes=["v(out)"], params={"rl": 2000.0})
    v1 = 2 / 3 * (1 - math.exp(-1e-3 / (2e-3 / 3)))  # 1 kΩ || 2 kΩ until 1 ms
    want = 0.8 + (v1 - 0.8) * math.exp(-2e-3 / 0.8e-3)  # then 1 kΩ || 4 kΩ
    assert float(over["v(out)"][-1]) == pytest.approx(want, abs=1e-6)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_a_periodic_steady_state_takes_the_resistor_at_its_value_at_t0():
    # A periodic orbit (pelcs orbit, continue, basins, bifurcation) or a small-signal response
    # around it (pelcs ac) has one load: the resistor's value at the map's t0, said in the
    # notes, and the same orbit and response as that constant resistor
    from lcs.analysis.orbits import find_orbit
    from netlist.studies.ac import ac_analysis
    from netlist.studies.sweep import circuit_map

    for t0, ohms in ((0.0, 5), (1.5e-3, 10)):
        m = circuit_map(parse_string(BUCK), None, t0=t0)
        const = circuit_map(parse_string(BUCK.replace("R = 'time < 1ms ? 5 : 10'",
                                                      str(ohms))), None, t0=t0)
        said = [n for n in m.notes if n.startswith("R1 is stepped in time")]
        assert said and f"R1 = {ohms} Ω here" in said[0], m.notes
        assert not any("is not periodic" in n for n in m.notes)
        orbit = find_orbit(m, m.x0)
        want = find_orbit(const, const.x0)
        assert orbit.points[0] == pytest.approx(want.points[0], rel=1e-9, abs=1e-12)
    fr = ac_analysis(parse_string(BUCK), period=None, inject="Vin", probes=["v(out)"],
                     freqs=[100.0, 1e3])
    const = ac_analysis(parse_string(BUCK.replace("R = 'time < 1ms ? 5 : 10'", "5")),
                        period=None, inject="Vin", probes=["v(out)"], freqs=[100.0, 1e3])
    assert any(n.startswith("R1 is stepped in time") for n in fr.notes), fr.notes
    assert fr["v(out)"] == pytest.approx(const["v(out)"], rel=1e-9)


def test_a_monte_carlo_tolerance_scales_the_whole_resistor_stepped_in_time():
    # R1 is 1 kΩ until 0.5 ms, 2 kΩ after, into 1 kΩ || 10 nF from 10 V: a draw of R1 at
    # (1 + d) of its value makes it (1 + d) 1 kΩ, then (1 + d) 2 kΩ, so that the final
    # v(a) = 10 V · 1k / (1k + 2k (1 + d)). A pattern matches the resistor, not its parts.
    from netlist.studies.param_sweep import run_sweep

    deck = """time R Monte Carlo
V1 in 0 DC 10
R1 in a R = 'time < 0.5ms ? 1k : 2k'
R2 a 0 1k
C1 a 0 10n
.tran 1u 1m
.end
"""
    for tol in ("R1=20%", "R1*=20%"):
        table = run_sweep(deck, ["final(v(a))"], tolerances=[tol], runs=4, seed=3,
                          period=100e-6, workers=1)
        assert table.inputs == ("run", "R1")
        d = table.input_values[:, 1] / 1e3 - 1
        assert np.abs(d).max() > 0.02
        want = 10 * 1e3 / (1e3 + 2e3 * (1 + d))
        assert table.values[:, 0] == pytest.approx(want, rel=1e-6)
