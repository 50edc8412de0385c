"""``--period`` may be omitted where the netlist defines the switching period: the source at
a switch's control, a latched switch's clock, a PWM ramp. None or several: a clear error."""

from __future__ import annotations

import json

import pytest
from test_analysis_maps import netlists  # noqa: F401 - fixture

from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.measure import defined_period
from pelcs.cli import main

LATCHED = """latched switch with a ramp
.param ts=10u
Vin in 0 DC 12
Vc con 0 DC 0.3
S1 in sw con isn SWPWM
D1 0 sw DI
L1 sw a 20u
Vsense a out DC 0
C1 out 0 50u
R1 out 0 2.5
H1 isn ramp Vsense 0.1
Vramp ramp 0 PULSE(0 0.1 0 {ts-20n} 10n 10n {ts})
.model SWPWM SW(VT=0 VH=0 LATCH=1 PERIOD={ts})
.model DI D
.tran 0.05u 1m
.end
"""


def _circuit(text: str):
    return parse_string(text, file="t.cir")


def test_the_source_at_a_switch_control():
    c = _circuit(LATCHED.replace("S1 in sw con isn SWPWM", "S1 in sw g 0 SWPWM\n"
                                 "Vg g 0 PULSE(0 1 0 1n 1n 2u 4u)"))
    assert defined_period(c) == (pytest.approx(4e-6), "PULSE period of Vg (control of S1)")


def test_a_latch_clock_and_a_ramp_that_agree():
    per, origin = defined_period(_circuit(LATCHED))
    assert per == pytest.approx(10e-6)
    assert origin == ("clock of the latched switch S1 (PERIOD=), as PULSE period of Vramp")


def test_several_periods_are_ambiguous():
    text = LATCHED.replace("PERIOD={ts}", "PERIOD=20u")
    with pytest.raises(NetlistError) as exc:
        defined_period(_circuit(text))
    msg = exc.value.format()
    assert "t.cir: error: the switching period is ambiguous" in msg
    assert "2e-05 s (clock of the latched switch S1" in msg and "1e-05 s (PULSE period of " \
        "Vramp)" in msg and "hint: pass --period T" in msg


def test_no_period():
    text = "no clock\nV1 a 0 DC 1\nS1 a b a 0 SW\nR1 b 0 1\n.model SW SW(VT=0.5)\n" \
           ".tran 1u 1m\n.end\n"
    with pytest.raises(NetlistError) as exc:
        defined_period(_circuit(text))
    msg = exc.value.format()
    assert "defines no switching period" in msg and "pass --period T" in msg


def test_orbit_without_period_is_the_orbit_with_it(netlists, capsys):  # noqa: F811
    assert main(["orbit", netlists["boost"], "--period", "ts", "--json"]) == 0
    given = json.loads(capsys.readouterr().out)
    assert main(["orbit", netlists["boost"], "--json"]) == 0
    inferred = json.loads(capsys.readouterr().out)
    assert inferred["period"] == given["period"] == pytest.approx(20e-6)
    assert inferred["points"] == given["points"]
    assert inferred["multipliers"] == given["multipliers"]
    assert inferred["notes"][0] == ("T = 20 µs: the PULSE period of Vg (control of S1) "
                                    "(no --period given)")
    assert not any("no --period" in n for n in given["notes"])


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("argv", [
    ["continue", "{boost_dcm}", "--param", "duty=0.74:0.8:3", "--locate-tol", "1e-3",
     "--x0", "v(C1)=45", "--transient", "0", "--no-progress"],
    ["bifurcation", "{boost}", "--param", "duty=0.4:0.5:2", "--transient", "2", "--record",
     "2", "--no-progress", "--workers", "1"],
    ["basins", "{boost}", "--grid", "i(L1)=0:4:2,v(C1)=0:30:2", "--no-progress",
     "--workers", "1"],
])
def test_the_map_commands_name_the_period_they_took(netlists, capsys, argv):  # noqa: F811
    argv = [a.format(**netlists) for a in argv]
    assert main(argv) in (0, 3)
    out = capsys.readouterr().out
    assert "note: T = 20 µs: the PULSE period of Vg (control of S1) (no --period given)" \
        in out


def test_the_error_without_a_period(tmp_path, capsys):
    path = tmp_path / "dc.cir"
    path.write_text("no clock\nV1 a 0 DC 1\nS1 a b a 0 SW\nR1 b 0 1\nC1 b 0 1u\n"
                    ".model SW SW(VT=0.5)\n.tran 1u 1m\n.end\n")
    assert main(["orbit", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"{path}: error: the netlist defines no switching period" in err
    assert "hint: pass --period T" in err and "Traceback" not in err


def test_ac_without_period_is_ac_with_it(capsys):
    from pathlib import Path

    cir = str(Path(__file__).parent / "netlists" / "ac" / "cm_buck.cir")
    argv = ["ac", cir, "--inject", "Vc", "--probe", "v(out)", "--freq", "1k:10k:2", "--json"]
    assert main(argv + ["--period", "ts"]) == 0
    given = json.loads(capsys.readouterr().out)
    assert main(argv) == 0
    inferred = json.loads(capsys.readouterr().out)
    assert inferred["period"] == given["period"] == pytest.approx(10e-6)
    assert inferred["probes"] == given["probes"]
    assert inferred["notes"][0] == ("T = 10 µs: the clock of the latched switch S1 "
                                    "(PERIOD=), as PULSE period of Vramp (no --period given)")
