"""The operating point's source-driven switches and the state they carry into the run."""

import numpy as np
import pytest

DECK = """hysteresis at t = 0
Vin in 0 10
Vg g 0 {gate}
S1 in y g 0 SW1
R1 y x 1k
C1 x 0 100n
R2 x 0 10k
.model SW1 SW(RON=0.01 ROFF=1e9 VT=2.5 VH=1)
.tran 1u 2m
.end
"""


def _run(tmp_path, gate):
    from pelcs.cli import main

    deck = tmp_path / "hyst.cir"
    deck.write_text(DECK.format(gate=gate))
    out = tmp_path / "x.csv"
    assert main(["simulate", str(deck), "--no-progress", "--probe", "v(x)", "-o",
                 str(out)]) == 0
    d = np.genfromtxt(out, delimiter=",", skip_header=1)
    return d[:, 0], d[:, 1]


def test_a_switch_on_at_the_operating_point_keeps_its_state_in_its_band(tmp_path):
    # the gate is 5 V (above VT + VH = 3.5 V) at the operating point and 3 V (inside the
    # band) just after: the switch stays on, as in ngspice (9.0909 V all along)
    t, y = _run(tmp_path, "PWL(0 5 0 3 2m 3)")
    assert y == pytest.approx(np.full_like(y, 100 / 11), abs=1e-3)


def test_a_switch_kept_on_in_its_band_turns_off_below_it(tmp_path):
    # on at the operating point, kept on in the band, off when the gate falls to 0 at 1 ms:
    # the RC then discharges with 100n * 10k
    t, y = _run(tmp_path, "PWL(0 5 0 3 1m 3 1.001m 0)")
    on = t <= 1e-3
    assert y[on] == pytest.approx(np.full(on.sum(), 100 / 11), abs=1e-3)
    late = t >= 1.2e-3
    tau = 100e-9 * 10e3
    expect = 100 / 11 * np.exp(-(t[late] - 1.001e-3) / tau)
    assert y[late] == pytest.approx(expect, abs=2e-2)


def test_a_negative_band_entered_from_above_after_the_operating_point_turns_off(tmp_path):
    # VH = -1 V: the gate, 5 V at the operating point (on), enters the band 1.5..3.5 V from
    # above just after t = 0, which turns the switch off (ngspice 39: mean v(x) 3.93032 V);
    # the RC then discharges from 100/11 V with 100n * 10k
    from pelcs.cli import main

    deck = tmp_path / "neg.cir"
    deck.write_text(DECK.format(gate="PWL(0 5 0 3 2m 3)").replace("VH=1", "VH=-1"))
    out = tmp_path / "x.csv"
    assert main(["simulate", str(deck), "--no-progress", "--probe", "v(x)", "-o",
                 str(out)]) == 0
    t, y = np.genfromtxt(out, delimiter=",", skip_header=1).T
    assert y[0] == pytest.approx(100 / 11, abs=1e-6)
    assert y == pytest.approx(100 / 11 * np.exp(-t / 1e-3), abs=2e-3)
