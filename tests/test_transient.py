"""netlist.studies.transient and the pelcs Python API: initial conditions, state jumps at t = 0,
.tran defaults, probe checks, partial results of failed runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pelcs
from lcs.results import SimulationError
from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.transient import check_probes, default_step, simulate_circuit, transient_setup

SIM = Path(__file__).parent / "netlists" / "sim"

IC_NETLIST = """initial conditions
V1 in 0 DC 1
R1 in a 1k
C1 a 0 1u
C2 b c 2u
R2 b c 1k
R3 c 0 1k
L1 a d 1m IC=0.25
R4 d 0 10
C3 d e 1u IC=1.5
R5 e 0 1k
.ic v(a)=3 v(b)=5 v(c)=2 v(e)=7
.tran 1u 10u
.end
"""


def test_ic_lines_and_element_ic_reach_the_initial_state():
    circuit = parse_string(IC_NETLIST)
    setup = transient_setup(circuit)
    x0 = dict(zip(setup.system.states, setup.x0, strict=True))
    # .ic node voltages give v(C) = v(n+) - v(n-); an element IC= wins over .ic (C3 would
    # be v(d) - v(e) = -7 V from .ic with d missing).
    assert x0 == {"v(C1)": 3.0, "v(C2)": 3.0, "i(L1)": 0.25, "v(C3)": 1.5}
    # With UIC the run starts there; without it from the operating point with the .ic
    # nodes held (tests/test_operating_point.py), as the notes say.
    res = simulate_circuit(parse_string(IC_NETLIST.replace("10u\n", "10u UIC\n")))
    np.testing.assert_array_equal(res.y[0], setup.x0)
    assert res.t[0] == 0.0
    res = simulate_circuit(circuit)
    assert any("with the .ic nodes held" in note for note in res.notes)


def test_ic_with_one_node_missing_takes_it_as_zero_and_says_so():
    circuit = parse_string("one node\nC1 a b 1u\nR1 a 0 1k\nR2 b 0 1k\n.ic v(a)=2\n"
                           ".tran 1u 10u UIC\n.end\n")
    setup = transient_setup(circuit)
    assert list(setup.x0) == [2.0]
    assert any("node b has no .ic" in note for note in setup.notes)
    # UIC given: no operating-point remark.
    assert not any("UIC" in note for note in setup.notes)


def test_charged_capacitor_against_a_diode_jumps_to_charge_conservation():
    C1, C2, v1, v2 = 1e-6, 3e-6, 10.0, 2.0
    circuit = parse_string(f"""charge sharing
C1 a 0 {C1} IC={v1}
D1 a b DI
C2 b 0 {C2} IC={v2}
R2 b 0 1k
.model DI D
.tran 1u 100u UIC
.end
""")
    res = simulate_circuit(circuit)
    shared = (C1 * v1 + C2 * v2) / (C1 + C2)  # 4 V
    np.testing.assert_allclose(res.y[0], [shared, shared], rtol=1e-12)
    # Afterwards D1 keeps conducting: both capacitors discharge together into R2.
    np.testing.assert_allclose(res["v(C1)"], res["v(C2)"], rtol=1e-12)
    tau = 1e3 * (C1 + C2)
    assert res["v(C1)"][-1] == pytest.approx(shared * np.exp(-res.t[-1] / tau), rel=1e-4)
    note = next(n for n in res.notes if "jumps" in n)
    assert "D1" in note and "charge" in note and "v(C1): 10 -> 4" in note
    # The impulse is the charge moved, C2 (4 - 2) = 6 µC, and the energy lost in it is
    # ½ C1 C2/(C1 + C2) (v1 - v2)² = 24 µJ.
    assert "6e-06 C" in note and "2.4e-05 J" in note
    # The Moreau driver's generic note about the replacement is not repeated.
    assert not any(n.startswith("initial state") for n in res.notes)


def test_consistent_initial_state_does_not_jump():
    circuit = parse_string("no jump\nC1 a 0 1u IC=1\nD1 a b DI\nC2 b 0 1u IC=3\n"
                           "R1 a 0 1k\n.model DI D\n.tran 1u 10u UIC\n.end\n")
    res = simulate_circuit(circuit)
    assert not any("jump" in n for n in res.notes)
    assert list(res.y[0]) == [1.0, 3.0]


def test_tran_defaults_and_tstart():
    circuit = parse_string("tran\nV1 a 0 SIN(0 1 1k)\nR1 a b 1k\nC1 b 0 1u\n"
                           ".tran 2u 1m 0.5m 1u\n.end\n")
    setup = transient_setup(circuit)
    assert (setup.t_stop, setup.h, setup.t_save) == (1e-3, 1e-6, 0.5e-3)  # h = TMAX
    res = simulate_circuit(circuit)
    assert res.t[0] >= 0.5e-3 and res.t[-1] == pytest.approx(1e-3)
    assert len(res.t) == pytest.approx(501, abs=1)
    setup = transient_setup(circuit, tstop=2e-3, step=5e-6)
    assert (setup.t_stop, setup.h) == (2e-3, 5e-6)


def test_without_tran_the_stop_time_is_required_and_the_step_defaults():
    circuit = parse_string("no tran\nV1 a 0 PULSE(0 1 0 1n 1n 5u 10u)\nR1 a b 1k\n"
                           "C1 b 0 1n\n.end\n")
    with pytest.raises(NetlistError, match="no .tran analysis and no stop time") as exc:
        transient_setup(circuit)
    assert "--tstop" in exc.value.format()
    setup = transient_setup(circuit, tstop=1e-3)
    assert setup.h == pytest.approx(10e-6 / 100)  # 1/100 of the PULSE period
    assert any("no .tran step" in n for n in setup.notes)
    assert default_step([], 1.0) == pytest.approx(1.0 / 5000)
    with pytest.raises(NetlistError, match="exceeds the stop time"):
        transient_setup(circuit, tstop=1e-3, step=2e-3)
    with pytest.raises(NetlistError, match="must be positive"):
        transient_setup(circuit, tstop=-1.0)


def test_probe_check():
    circuit = pelcs.load(SIM / "buck_ccm.cir")
    ok = ["v(out)", "V(OUT, 0)", "v(sw,gnd)", "i(L1)", "i(d1)", "v(C1)", " i(Vin) "]
    assert check_probes(circuit, ok)[-1] == "i(Vin)"
    with pytest.raises(NetlistError) as exc:
        check_probes(circuit, ["v(nowhere)", "i(X9)", "out", "v(a,b,c)", "v(out)"])
    err = exc.value
    assert len(err.diagnostics) == 4
    hint = err.diagnostics[0].hint
    assert "nodes: 0, in, sw, gate, out;" in hint and "elements: Vin, S1, D1, L1" in hint
    with pytest.raises(NetlistError, match="unknown probe 'v\\(typo\\)'"):
        simulate_circuit(circuit, probes=["v(typo)"])


# ---------------------------------------------------------------------------------------------
# The pelcs API
# ---------------------------------------------------------------------------------------------


def test_api_load_path_text_and_params():
    text = (SIM / "buck_ccm.cir").read_text()
    a = pelcs.load(SIM / "buck_ccm.cir")
    b = pelcs.load(str(SIM / "buck_ccm.cir"), params={"duty": 0.25, "fs": "100k"})
    c = pelcs.load(text)
    assert a.params["duty"] == c.params["duty"] == 0.4
    assert b.params["duty"] == 0.25 and b.params["fs"] == 100e3
    system = pelcs.formulate(a)
    assert system.states == ("i(L1)", "v(C1)")
    assert [s.name for s in system.switches] == ["S1"]
    with pytest.raises(NetlistError):
        pelcs.load(SIM / "does_not_exist.cir")


def test_api_simulate():
    res = pelcs.simulate(SIM / "buck_ccm.cir", tstop="0.2m", step="0.5u", probes="v(out)",
                         every=4, params={"duty": 0.5})
    assert res.names == ("v(out)",)
    assert res.t[-1] == pytest.approx(0.2e-3)
    assert res["v(out)"].shape == res.t.shape
    assert np.all(np.diff(res.t) > 0)
    full = pelcs.simulate(SIM / "buck_ccm.cir", tstop=0.2e-3, step=0.5e-6, probes=["v(out)"],
                          params={"duty": 0.5})
    assert len(res.t) < len(full.t) / 3
    # The kept points are points of the full run.
    np.testing.assert_allclose(np.interp(res.t, full.t, full["v(out)"]), res["v(out)"],
                               atol=1e-12)
    with pytest.raises(TypeError, match="params"):
        pelcs.simulate(pelcs.load(SIM / "buck_ccm.cir"), params={"duty": 0.3})
    with pytest.raises(NetlistError, match="not a time"):
        pelcs.simulate(SIM / "buck_ccm.cir", tstop="soon")


def test_api_failed_run_raises_with_partial_result_or_returns_it():
    path = SIM / "negative_r.cir"
    with pytest.raises(SimulationError) as exc:
        pelcs.simulate(path, probes=["v(in)", "i(D1)"])
    err = exc.value
    assert err.kind == "no_solution" and err.pairs == ("D1",)
    # The source turns positive at 0.5 ms: the step after it has no solution.
    assert 0.5e-3 <= err.time <= 0.5e-3 + 2e-6
    assert err.result is not None and err.result.t[-1] == pytest.approx(err.t_prev)
    res = pelcs.simulate(path, probes=["v(in)", "i(D1)"], check=False)
    assert res.error is not None and not res.ok
    assert np.all(res["i(D1)"] == 0.0)
