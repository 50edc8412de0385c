"""Converter factories: same LCS as the bundled netlists, accepted by ngspice, passive and
well-posed (``pelcs lcs``), parameter handling; the hand-written averaged models."""

from __future__ import annotations

import contextlib
import io
import json
import subprocess

import numpy as np
import pytest
from ngspice_helpers import ngspice_executable

from converters import factories as F
from converters.averaged import averaged_model, effective_k, ripple
from converters.design import conversion_ratio, design
from netlist.formulation import formulate
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import initial_state

BUNDLED = sorted(F.BUNDLED)


def _signature(system):
    return (system.states, system.inputs, system.diodes,
            [(s.name, s.control, s.vt, s.vh) for s in system.switches])


@pytest.mark.parametrize("filename", BUNDLED)
def test_factory_defaults_formulate_to_the_bundled_lcs(filename):
    name, kwargs = F.BUNDLED[filename]
    bundled = formulate(parse_file(F.netlist_path(filename)))
    made = formulate(F.circuit(name, **kwargs))
    assert _signature(made) == _signature(bundled)
    for key in bundled.all_keys():
        a, b = bundled.mode(key), made.mode(key)
        assert a.pairs == b.pairs, key
        for m in "ABCDEF":
            # Same numbers up to round-off of the parameter expressions (e.g. 1/fs).
            np.testing.assert_allclose(getattr(b, m), getattr(a, m), rtol=1e-12, atol=0,
                                       err_msg=f"{filename} mode {key} matrix {m}")


# A short run with the default components: ngspice must parse the text and finish the
# transient (the full default runs are the ngspice cross-checks' business; the bundled
# bridge rectifier, for one, needs the runner's settings ladder past 5 ms in plain ngspice).
SHORT_RUNS = {
    "buck": {"tstop": 0.4e-3}, "boost": {"tstop": 0.4e-3}, "buck-boost": {"tstop": 0.4e-3},
    "cuk": {"tstop": 0.4e-3}, "prc": {"tstop": 0.2e-3}, "vm-buck": {"tstop": 2e-3},
    "boost-smc": {"tstop": 0.2e-3}, "bridge-rectifier": {"tstop": 2e-3},
}


@pytest.fixture(scope="module")
def ngspice_exe() -> str:
    return ngspice_executable()


@pytest.mark.parametrize("name", sorted(F.FACTORIES))
def test_ngspice_batch_mode_accepts_factory_text(name, ngspice_exe, tmp_path):
    text = F.FACTORIES[name](**SHORT_RUNS[name])
    deck = tmp_path / f"{name}.cir"
    deck.write_text(text)
    # -r forces the analyses to run (without a .print line ngspice -b only parses).
    proc = subprocess.run([ngspice_exe, "-b", "-r", str(tmp_path / "out.raw"), str(deck)],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log
    for bad in ("error", "unknown", "too small", "aborted"):
        assert bad not in log.lower(), log
    assert "No. of Data Rows" in log, log


@pytest.mark.parametrize("filename", BUNDLED)
def test_pelcs_lcs_reports_bundled_netlists_passive_and_wellposed(filename):
    from pelcs.cli import main

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["lcs", str(F.netlist_path(filename)), "--json"]) == 0
    report = json.loads(out.getvalue())
    assert report["passive"] is True
    assert report["modes"]
    for mode in report["modes"]:
        assert mode["passive"] is True, mode["switches"]
        assert mode["wellposedness"]["wellposed"] is True, mode["switches"]


def test_params_are_overridable_and_initial_state_is_written():
    text = F.boost(il0=1.5, vc0=20.0)
    c = parse_string(text, params={"duty": 0.3, "rload": 10})
    assert c.element("R1").value == pytest.approx(10)
    system = formulate(c)
    assert list(initial_state(c, system.states)) == [1.5, 20.0]
    assert ".tran" in text and "UIC" in text


def test_held_gate_gives_a_single_switch_mode():
    from netlist.studies.transient import simulate_circuit

    for gate, on in (("on", True), ("off", False)):
        c = F.circuit("boost", gate=gate, tstop=0.2e-3)
        res = simulate_circuit(c)
        assert res.ok
        assert res.modes_visited == [(on,)]
        assert res.events == [] or all(mode == (on,) for _, mode in res.events)


def test_factories_reject_bad_parameters():
    with pytest.raises(ValueError):
        F.boost(duty=1.2)
    with pytest.raises(ValueError):
        F.buck(lind=-1)
    with pytest.raises(ValueError):
        F.cuk(gate="half")
    with pytest.raises(ValueError):
        F.buck(duty=1e-4, fs=1e6)  # on-time shorter than the two gate edges
    with pytest.raises(KeyError):
        F.circuit("flyback")


def test_params_from_design_reproduces_the_design():
    d = design("boost", 12, 24, 50e3, R=20)
    kw = F.params_from_design(d)
    assert kw == {"vin": 12, "duty": pytest.approx(0.5), "fs": 50e3, "rload": 20,
                  "lind": pytest.approx(d.L), "cout": pytest.approx(d.C)}
    c = F.circuit("boost", **kw)
    assert c.element("L1").value == pytest.approx(d.L)
    dc = design("cuk", 12, -12, 100e3, R=12)
    kc = F.params_from_design(dc)
    assert kc["l2"] == pytest.approx(dc.L2) and kc["c1"] == pytest.approx(dc.C1)
    F.circuit("cuk", **kc)


# -- the averaged models against the textbook conversion ratios ------------------------------


@pytest.mark.parametrize("topology", ["buck", "boost", "buck-boost", "cuk"])
@pytest.mark.parametrize("duty", [0.2, 0.5, 0.7])
def test_averaged_equilibrium_gives_ccm_conversion_ratio(topology, duty):
    kw = ({"l1": 1e-4, "c1": 1e-5, "l2": 2e-4, "c2": 1e-4} if topology == "cuk"
          else {"lind": 1e-4, "cout": 1e-4})
    m = averaged_model(topology, 10.0, duty, 7.0, **kw)
    xe = m.equilibrium()
    M = conversion_ratio(topology, duty)
    assert xe[m.states.index("v(C2)" if topology == "cuk" else "v(C1)")] == pytest.approx(10 * M)
    # power balance: vin * (input current) = vout^2 / R
    iin = {"buck": duty * xe[0], "boost": xe[0], "buck-boost": duty * xe[0], "cuk": xe[0]}
    assert 10 * iin[topology] == pytest.approx((10 * M) ** 2 / 7.0)
    if topology == "cuk":
        assert xe[1] == pytest.approx(10 - 10 * M)  # v(C1) = vin - v(out)
    # the response converges to the equilibrium and starts at x0
    t_settle = 30 / min(-np.linalg.eigvals(m.A).real)  # e^-30: settled to round-off
    x = m.response([0.0, t_settle], x0=np.zeros(m.A.shape[0]))
    np.testing.assert_allclose(x[0], 0, atol=1e-12)
    np.testing.assert_allclose(x[1], xe, rtol=1e-6)


def test_ripple_formulas_by_hand():
    # buck 24 V, D = 0.5, 50 kHz, 200 uH, 100 uF: (24-12)*0.5*20us/200uH = 0.6 A; 0.6*20us/800uF
    r = ripple("buck", 24, 0.5, 50e3, 5, lind=200e-6, cout=100e-6)
    assert r["i(L1)"] == pytest.approx(0.6) and r["v(C1)"] == pytest.approx(0.6 * 20e-6 / 800e-6)
    r = ripple("boost", 12, 0.5, 50e3, 20, lind=100e-6, cout=100e-6)
    assert r["i(L1)"] == pytest.approx(1.2) and r["v(C1)"] == pytest.approx(24 * 0.5 * 20e-6 / 2e-3)
    # L_e = 500u || 500u = 250 uH: K = 2 * 250e-6 * 50e3 / 20
    assert effective_k("cuk", 0.5, 50e3, 20, l1=500e-6, l2=500e-6) == pytest.approx(1.25)
