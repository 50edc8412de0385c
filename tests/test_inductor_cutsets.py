"""Inductors that Kirchhoff's current law holds at zero current: one end unconnected (every
mode, as ngspice runs it), or in series with an ideal switch that opens (the current jumps to
zero at the opening, the flux and ½ L i² lost, noted)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from netlist.errors import NetlistError
from netlist.formulation import formulate
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit

DANGLING = """dangling inductor
V1 in 0 PULSE(0 10 0 1u 1u 5u 10u)
R1 in a 10
C1 a 0 1u
L1 a b 1m {ic}
.tran 10n 50u uic
.end
"""

# An RL fed through a switch that opens at 50 µs and closes again at 80 µs: before the
# opening i(t) = (V/R)(1 - exp(-t R/L)), then 0 while open, then from 0 again.
RL_SWITCH = """RL through a switch that opens
V1 in 0 10
S1 in a ctl 0 SW1
L1 a b 1m
R1 b 0 10
Vc ctl 0 PULSE(1 0 50u 1n 1n 30u 1)
.model SW1 SW(VT=0.5)
.tran 100n 150u UIC
.end
"""


def test_a_dangling_inductor_is_pinned_at_zero_current():
    c = parse_string(DANGLING.format(ic=""))
    system = formulate(c)
    lcs = system.mode(())
    k = system.states.index("i(L1)")
    # no dynamics, and the state enters nothing else
    assert not lcs.A[k].any() and not lcs.A[:, k].any() and not lcs.E[k].any()
    out = system.outputs((), ["i(L1)", "v(b)", "v(a)"])
    assert not out.Cy[0].any() and not out.Fy[0].any()  # i(L1) = 0
    assert np.array_equal(out.Cy[1], out.Cy[2])  # v(b) = v(a): L di/dt = 0


def test_dangling_inductor_against_ngspice(ngspice):
    from ngspice_checks.runner import run_ngspice

    text = DANGLING.format(ic="")
    res = simulate_circuit(parse_string(text), probes=["v(a)", "v(b)", "i(L1)"])
    assert any("L1: no other branch joins its terminals" in n for n in res.notes)
    ng = run_ngspice(text, ["v(a)", "v(b)", "i(L1)"], timeout=60)
    assert np.max(np.abs(ng["i(L1)"])) == 0.0
    assert np.max(np.abs(res["i(L1)"])) == 0.0
    assert np.array_equal(res["v(a)"], res["v(b)"])
    v_ng = np.interp(res.t, ng.time, ng["v(a)"])
    # the RC charging through R1 (10 Ω, 1 µF, τ = 10 µs): within 1 % of its swing
    assert np.max(np.abs(res["v(a)"] - v_ng)) < 0.01 * np.max(np.abs(v_ng))


def test_a_dangling_inductor_with_an_initial_current_loses_it_at_t0():
    c = parse_string(DANGLING.format(ic="IC=2"))
    res = simulate_circuit(c, probes=["i(L1)"])
    assert res["i(L1)"][0] == 0.0 and res.x_final[formulate(c).states.index("i(L1)")] == 0.0
    # ½ L i² = ½ 1 mH (2 A)² = 2 mJ
    assert any("jumps to 0 at t = 0 and 2 mJ (½ L i²) is lost" in n for n in res.notes)


def test_an_inductor_opened_by_a_switch_loses_its_current():
    c = parse_string(RL_SWITCH)
    system = formulate(c)
    assert system.pinned((False,)) == {0: 1e-3} and system.pinned((True,)) == {}
    res = simulate_circuit(c, probes=["i(L1)", "i(S1)"], step=1e-7)
    t, i = res.t, res["i(L1)"]
    # Vc crosses VT = 0.5 V half-way through its 1 ns edges
    t_off, t_on = 50.0005e-6, 80.0015e-6
    assert [e[0] for e in res.events] == pytest.approx([t_off, t_on], abs=1e-12)
    tau, i_inf = 1e-3 / 10, 1.0
    before = t <= t_off + 1e-12
    exact = i_inf * (1 - np.exp(-t[before] / tau))
    # θ-method error of a 100 ns step on τ = 100 µs
    assert np.max(np.abs(i[before] - exact)) < 1e-4 * i_inf
    i_open = i_inf * (1 - math.exp(-t_off / tau))  # 0.3935 A
    assert abs(i[before][-1] - i_open) < 1e-4
    off = (t > t_off + 1e-12) & (t <= t_on + 1e-12)
    assert off.sum() > 100 and np.all(i[off] == 0.0) and np.all(res["i(S1)"][off] == 0.0)
    # closed again: from 0, i = (V/R)(1 - exp(-(t - t_on)/τ))
    after = t > t_on + 1e-12
    exact_after = i_inf * (1 - np.exp(-(t[after] - t_on) / tau))
    assert np.max(np.abs(i[after] - exact_after)) < 1e-4 * i_inf
    note = next(n for n in res.notes if n.startswith("i(L1): the open switches"))
    # ½ L i(t_off)² = ½ 1 mH (0.3935 A)² = 77.41 µJ
    assert 0.5 * 1e-3 * i_open ** 2 == pytest.approx(77.41e-6, abs=0.005e-6)
    assert "cut it to 0 once (first at t = 5e-05 s, from 0.3935 A): its flux is lost, " \
        "7.741e-05 J (½ L i²) in all" in note


def test_the_exact_method_applies_the_same_jump():
    res = simulate_circuit(parse_string(RL_SWITCH), probes=["i(L1)"], step=1e-7,
                           method="exact")
    assert res.error is None
    t, i = res.t, res["i(L1)"]
    t_off, t_on, tau = 50.0005e-6, 80.0015e-6, 1e-4
    before, after = t <= t_off + 1e-12, t > t_on + 1e-12
    assert np.max(np.abs(i[before] - (1 - np.exp(-t[before] / tau)))) < 1e-12
    assert np.all(i[~before & ~after] == 0.0)
    assert np.max(np.abs(i[after] - (1 - np.exp(-(t[after] - t_on) / tau)))) < 1e-12
    assert any("7.741e-05 J (½ L i²) in all" in n for n in res.notes)


def test_switch_opened_inductor_against_ngspice(ngspice):
    """ngspice's SW is open with ROFF = 1/GMIN = 1e12 Ω: the current decays in L/ROFF = 1 fs
    through a spike of megavolts across the switch, so it too loses the flux at the
    opening, within its step. Compared away from the two switching edges. (RON = 1 µΩ for
    ngspice, whose default is 1 Ω; UIC in the deck: from i = 0, not the operating point.)"""
    from ngspice_checks.runner import run_ngspice

    res = simulate_circuit(parse_string(RL_SWITCH), probes=["i(L1)"], step=1e-7)
    deck = RL_SWITCH.replace("SW(VT=0.5)", "SW(VT=0.5 RON=1e-6)")
    ng = run_ngspice(deck, ["i(L1)", "v(a)"], timeout=60)
    assert ng["v(a)"].min() < -1e5  # (the spike that spends ½ L i² in ROFF)
    far = (np.abs(res.t - 50e-6) > 1e-7) & (np.abs(res.t - 80e-6) > 1e-7)
    i_ng = np.interp(res.t[far], ng.time, ng["i(L1)"])
    assert np.max(np.abs(res["i(L1)"][far] - i_ng)) < 1e-4


def test_coupled_inductor_opened_by_a_switch_is_still_refused():
    text = RL_SWITCH.replace("R1 b 0 10", "R1 b 0 10\nL2 c 0 1m\nR2 c 0 1\nK1 L1 L2 0.9")
    system = formulate(parse_string(text))
    with pytest.raises(NetlistError, match="cutset of inductors with S1=off: L1"):
        system.mode((False,))


def test_a_comparator_opening_the_last_path_stops_the_run():
    # S1 opens when v(ref, c) = 5 V - v(c) falls below VT - VH = 0.9 V, with v(c) the
    # voltage of R1 (10 Ω i(L1)) through a 1 µs RC: when i(L1) has reached about 0.41 A. A
    # comparator's switching, inside a window, where the run cannot apply the jump.
    text = """comparator opens an RL
V1 in 0 10
Vref ref 0 5
S1 in a ref c SW1
L1 a b 1m
R1 b 0 10
R2 b c 1k
C2 c 0 1n
.model SW1 SW(VT=1 VH=0.1)
.tran 100n 100u uic
.end
"""
    res = simulate_circuit(parse_string(text), probes=["i(L1)"])
    assert res.error is not None and res.error.kind == "pinned_jump"
    # i = (1 A)(1 - exp(-t/τ)) reaches 0.41 A at t = -τ ln(0.59) = 52.8 µs, v(c) about
    # 1 µs later
    assert res.error.time == pytest.approx(-1e-4 * math.log(0.59) + 1e-6, rel=1e-2)
    assert res.t[-1] <= res.error.time
    assert "i(L1)" in str(res.error) and "freewheeling" in str(res.error)


def test_a_switch_sliding_against_an_inductor_cut_stops_the_run(tmp_path, capsys):
    # S2, on while v(sw) > 0, meant as a buck's freewheeling diode: when S1 opens, S2 on
    # carries i(L1) with v(sw) = -i RON < 0 (it turns off), and off it leaves L1 no path
    # (the current is cut, then v(sw) = v(out) > 0 turns it on). A Filippov blend of the two
    # held v(sw) at 0 as an ideal diode would: mean v(out) 3.0 V where ngspice gives 0.04 V.
    deck = tmp_path / "self_switch.cir"
    deck.write_text("""self-controlled freewheeling switch
Vin in 0 12
Vgate gate 0 PULSE(0 12 0 10n 10n 5u 10u)
S1 in sw gate 0 SW1
S2 0 sw sw 0 SW2
L1 sw out 10u
C1 out 0 100u
R1 out 0 1
.model SW1 SW(Ron=1m Roff=1meg Vt=0.5)
.model SW2 SW(Ron=1m Roff=1meg Vt=0.0)
.tran 100n 100u
.end
""")
    from pelcs.cli import main

    out = tmp_path / "out.csv"
    code = main(["simulate", str(deck), "--devices", "pwl", "--no-progress", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 3
    assert "pinned_jump" in err and "switch S2 would slide on its threshold" in err
    assert "i(L1) has a path and one where the open switches leave it none" in err
    t = np.genfromtxt(out, delimiter=",", skip_header=1, ndmin=2)[:, 0]
    assert 4.9e-6 < t[-1] < 5.1e-6  # (kept up to S1's opening, where the slide began)


@pytest.mark.parametrize("uic", ["", " uic"])
def test_a_cut_that_a_comparator_switch_would_carry_stops_the_run(tmp_path, capsys, uic):
    # a boost whose output switch is controlled by its own terminals (S2 sw out sw out, on
    # while v(sw) > v(out)): when S1 opens, the inductor's current drives v(sw) up and S2
    # turns on and carries it (ngspice 39: mean v(out) 22.56 V over the last 0.5 ms). The
    # run cut the current at S1's opening instead, before S2 could turn, every period
    # (mean v(out) 5.6 V, exit 0): it now stops there with a pinned_jump error
    deck = tmp_path / "self_boost.cir"
    deck.write_text(f"""boost with a self-controlled output switch
Vin in 0 12
Vg g 0 PULSE(0 5 0 10n 10n 5u 10u)
L1 in sw 100u
S1 sw 0 g 0 SW1
S2 sw out sw out SW2
C1 out 0 100u
R1 out 0 20
.model SW1 SW(RON=1m ROFF=1meg VT=2.5)
.model SW2 SW(RON=1m ROFF=1meg VT=0)
.tran 100n 100u{uic}
.end
""")
    from pelcs.cli import main

    out = tmp_path / "out.csv"
    code = main(["simulate", str(deck), "--devices", "pwl", "--no-progress", "-o", str(out)])
    err = capsys.readouterr().err
    assert code == 3
    assert "pinned_jump" in err and "S2" in err and "i(L1)" in err
    t = np.genfromtxt(out, delimiter=",", skip_header=1, ndmin=2)[:, 0]
    # (kept up to an opening of S1: the first from the operating point; with UIC, from an
    # empty C1, the first that S2 would carry)
    periods = (t[-1] - 5e-6) / 10e-6
    assert abs(periods - round(periods)) < 0.02 and (uic or periods < 0.02)


def test_a_cut_beside_a_comparator_switch_that_does_not_see_it_runs(tmp_path):
    # S3 could give L1 a path, but its control -v(out) never reaches its threshold (nor
    # sees the cut's voltage): the cut stands, as in ngspice (a spike in S1's ROFF)
    deck = tmp_path / "cut.cir"
    deck.write_text("""cut with a comparator switch that never turns on
Vin in 0 12
Vg g 0 PULSE(0 5 0 10n 10n 5u 10u)
S1 in sw g 0 SW1
L1 sw out 10u
R1 out 0 1
C1 out 0 1u
S3 sw 0 0 out SW1
.model SW1 SW(RON=1m ROFF=1meg VT=2.5)
.tran 100n 30u
.end
""")
    from pelcs.cli import main

    out = tmp_path / "out.csv"
    assert main(["simulate", str(deck), "--devices", "pwl", "--no-progress", "-o",
                 str(out)]) == 0
