"""``.tran TSTEP`` is ngspice's print interval, not its step: the step of a run is bounded as
ngspice bounds its own (TMAX, else ``min(TSTEP, (TSTOP - TSTART)/50)``) and resolves the
smooth sources; a TSTEP too coarse to show the sources writes every step."""

import numpy as np
import pytest

from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit, transient_setup

# eSim's deck for a 50 Hz source: TSTEP = 10 ms, half the period (the zero crossings)
ESIM = """half-wave rectifier
V1 in 0 SIN(0 10 50)
D1 in out DM
R1 out 0 1k
.model DM D
.tran 10e-03 100e-03
.end
"""


def _setup(text):
    return transient_setup(parse_string(text))


def test_coarse_tstep_is_not_the_step():
    setup = _setup(ESIM)
    # ngspice's bound is 100 ms / 50 = 2 ms; the sine needs 1/100 of its period
    assert setup.h == pytest.approx(0.2e-3)
    assert any("print interval" in n for n in setup.notes)
    assert setup.print_step is None and "too coarse" in setup.print_note


@pytest.mark.parametrize("tran, h, shown", [
    (".tran 1m 10m", 0.2e-3, 1e-3),  # (TSTOP - TSTART) / 50
    (".tran 1m 10m 5m", 0.1e-3, 1e-3),  # (TSTOP - TSTART) / 50
    (".tran 0.1m 10m", 0.1e-3, 0.1e-3),  # TSTEP already fine: kept
    (".tran 1m 10m 0 0.3m", 0.3e-3, 1e-3),  # TMAX
])
def test_step_bound_without_smooth_sources(tran, h, shown):
    setup = _setup(f"rc\nV1 a 0 DC 1\nR1 a b 1k\nC1 b 0 1u\n{tran}\n.end\n")
    assert setup.h == pytest.approx(h)
    assert setup.print_step == pytest.approx(shown)


def test_smooth_sources_bound_the_step():
    # a 1 kHz sine with TMAX = 100 us: 1/100 of its period; an EXP: 1/20 of its tau
    setup = _setup("s\nV1 a 0 SIN(0 1 1k)\nR1 a 0 1k\n.tran 1u 1m 0 100u\n.end\n")
    assert setup.h == pytest.approx(10e-6)
    setup = _setup("e\nV1 a 0 EXP(0 1 0 20u 1m 20u)\nR1 a 0 1k\n.tran 10u 2m\n.end\n")
    assert setup.h == pytest.approx(1e-6)
    # a PULSE needs no bound (its corners are steps): the buck's TSTEP stays
    setup = _setup("p\nV1 a 0 PULSE(0 1 0 10n 10n 10u 20u)\nR1 a 0 1k\n"
                   ".tran 0.2u 5m 0 0.2u UIC\n.end\n")
    assert setup.h == pytest.approx(0.2e-6) and setup.print_step == pytest.approx(0.2e-6)


def test_rectifier_follows_the_sine():
    # Before: 10 steps of 10 ms on the zero crossings, v(out) = 1e-14 V throughout. Now the
    # output is the positive half-waves of 10 V (analytic, ideal diode).
    res = simulate_circuit(parse_string(ESIM), probes=["v(out)"])
    exact = np.maximum(0.0, 10 * np.sin(2 * np.pi * 50 * res.t))
    assert res["v(out)"].max() == pytest.approx(10.0, rel=1e-3)
    assert np.max(np.abs(res["v(out)"] - exact)) < 1e-6
