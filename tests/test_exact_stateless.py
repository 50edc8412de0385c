"""The exact method on circuits with no states (no inductor, no capacitor): each output
instant is the complementarity problem of the resistive network at that instant's sources,
and the events are the diodes' and switches' changes. Against closed forms."""

from __future__ import annotations

import numpy as np
import pytest

from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit
from pelcs.cli import main

# An ideal diode clamps v(out) at 0 V while the divider would drive it positive:
# v(out) = min(0, 2/3 · 5 sin(2π·1k·t)).
CLIPPER = """diode clipper
V1 in 0 SIN(0 5 1k)
R1 in out 1k
D1 out 0 DI
R2 out 0 2k
.model DI D(IS=1e-12 N=0.05 RS=1m)
.tran 10u 2m
.end
"""

# S1 (on while v(g) > 0.5 V: from 0.5 ns to 4.0005 µs of every 10 µs) feeds a 1k-1k divider
# from 10 V that the ideal diode to a 3 V source clamps: v(out) = 3 V while on, 0 V while off.
CLAMPED_SWITCH = """switched divider with a clamp
V1 in 0 10
Vg g 0 PULSE(0 1 0 1n 1n 4u 10u)
S1 in a g 0 SWM
R3 a out 1k
R1 out 0 1k
D1 out x DI
V2 x 0 3
.model SWM SW(VT=0.5 RON=1m ROFF=1e9)
.model DI D(IS=1e-12 N=0.05 RS=1m)
.tran 0.1u 30u
.end
"""


def _run(tmp_path, text: str, *args: str) -> tuple[int, np.ndarray | None]:
    path = tmp_path / "c.cir"
    path.write_text(text)
    out = tmp_path / "out.csv"
    code = main(["simulate", str(path), "--method", "exact", "-o", str(out), *args])
    data = np.genfromtxt(out, delimiter=",", names=True) if out.exists() else None
    return code, data


def test_stateless_clipper_runs_exactly(tmp_path, capsys):
    code, data = _run(tmp_path, CLIPPER, "--probe", "v(out)", "--events")
    out = capsys.readouterr().out
    assert code == 0, out
    t, v = data["time"], data["vout"]
    assert t[-1] == 2e-3 and len(t) == 201
    assert np.max(np.abs(v - np.minimum(0.0, 10 / 3 * np.sin(2e3 * np.pi * t)))) < 1e-8
    # the diode changes at the sine's zero crossings
    times = [float(line.split()[1]) for line in out.splitlines() if line.startswith("event")]
    units = [line.split()[2] for line in out.splitlines() if line.startswith("event")]
    assert list(zip(times, units, strict=True)) == [(500, "µs"), (1, "ms"), (1.5, "ms")]


def test_stateless_switch_and_diode_run_exactly(tmp_path, capsys):
    code, data = _run(tmp_path, CLAMPED_SWITCH, "--probe", "v(out)")
    out = capsys.readouterr().out
    assert code == 0, out
    t, v = data["time"], data["vout"]
    on = (np.mod(t, 10e-6) > 0.5e-9) & (np.mod(t, 10e-6) < 4.0005e-6)
    assert np.array_equal(v[on], np.full(on.sum(), 3.0))
    assert np.max(np.abs(v[~on])) < 1e-12
    assert "6 switching events" in out


def test_stateless_ill_posed_mode_is_a_clear_error(tmp_path, capsys):
    # without R3 the closed ideal switch ties out to 10 V against the clamp's 3 V: no
    # diode configuration exists; the error says so (no traceback from the jump rule)
    text = CLAMPED_SWITCH.replace("S1 in a g 0 SWM", "S1 in out g 0 SWM").replace(
        "R3 a out 1k\n", "")
    code, _ = _run(tmp_path, text)
    err = capsys.readouterr().err
    assert code == 3
    assert "no consistent diode configuration at t = 5e-10 s" in err
    assert "Traceback" not in err


def test_stateless_comparator_instants_are_the_sine_crossings():
    # S1 on while 5 sin(ωt) > 2.5 V: ωt = π/6 and 5π/6 (mod 2π); v(out) follows v(in) then
    text = """comparator on a source, no states
V1 in 0 SIN(0 5 1k)
Vr r 0 2.5
S1 in out in r SWM
R1 out 0 1k
D1 0 out DI
.model SWM SW(VT=0 RON=1m ROFF=1e9)
.model DI D(IS=1e-12 N=0.05 RS=1m)
.tran 10u 2m
.end
"""
    res = simulate_circuit(parse_string(text), probes=["v(out)"], method="exact")
    res.raise_if_error()
    w = 2e3 * np.pi
    want = [np.pi / 6 / w, 5 * np.pi / 6 / w, (2 * np.pi + np.pi / 6) / w,
            (2 * np.pi + 5 * np.pi / 6) / w]
    assert [k for _, k in res.events] == [(True,), (False,), (True,), (False,)]
    assert np.allclose([t for t, _ in res.events], want, rtol=1e-9, atol=0)
    # (at an event instant the result holds the values before and after it: left out)
    away = np.min(np.abs(res.t[:, None] - np.array(want)[None, :]), axis=1) > 1e-9
    t, v = res.t[away], res["v(out)"][away]
    vin = 5 * np.sin(w * t)
    assert np.max(np.abs(v - np.where(vin > 2.5, vin, 0.0))) < 1e-8


@pytest.mark.parametrize("args", [
    ["orbit"], ["orbit", "--method", "exact"],
    ["continue", "--param", "a=4:5:2"],
    ["bifurcation", "--param", "a=4:5:2", "--transient", "2", "--record", "2"],
    ["basins", "--grid", "v(in)=0:1:3,v(out)=0:1:3"],
    ["ac", "--inject", "V1", "--probe", "v(out)", "--freq", "100:1k:2"],
], ids=lambda a: "-".join(a[:3:2]))
def test_analyses_of_a_periodic_orbit_refuse_a_stateless_circuit(args, tmp_path, capsys):
    # no state carried from one period to the next: no orbit, no map; said, not a traceback
    path = tmp_path / "c.cir"
    path.write_text(CLIPPER.replace("SIN(0 5 1k)", "SIN(0 {a} 1k)").replace(
        ".tran", ".param a=5\n.tran"))
    code = main([args[0], str(path), *args[1:]])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "error: the circuit has no state (no inductor or capacitor)" in err
    assert "hint: pelcs simulate FILE" in err and "Traceback" not in err
