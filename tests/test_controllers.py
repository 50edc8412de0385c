"""Python controllers driving netlist switches (lcs.controllers): open-loop PWM equals the
PULSE-gate netlist (also with a complementary switch and dead time), a digital PI buck reaches
its reference, and sliding-mode control from coefficients equals the netlist surface."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from lcs.controllers import PIPWM, OpenLoopPWM, SlidingSurface, pwm_commands
from lcs.integrators.moreau.integrator import simulate
from netlist.parser import parse_file
from netlist.studies.transient import transient_setup

ROOT = Path(__file__).parents[1]
BUCK = ROOT / "converters" / "netlists" / "buck.cir"
CL = Path(__file__).parent / "netlists" / "closed_loop"


def test_open_loop_pwm_equals_pulse_gate():
    s = transient_setup(parse_file(BUCK), tstop=2e-3)
    probes = ["i(L1)", "v(out)", "v(sw)"]
    net = simulate(s.system, s.signals, s.x0, 2e-3, 0.2e-6, probes=probes)
    # The gate PULSE crosses VT = 0.5 V in the middle of its 10 ns edges: on at 5 ns, off at
    # duty T + 5 ns.
    ctl = simulate(s.system, s.signals, s.x0, 2e-3, 0.2e-6, probes=probes,
                   controllers=[OpenLoopPWM("S1", 50e3, 0.5, phase=5e-9)])
    assert ctl.ok and ctl.switching == {"S1": "controller"}
    assert [md for _, md in ctl.events] == [md for _, md in net.events]
    np.testing.assert_allclose([t for t, _ in ctl.events], [t for t, _ in net.events],
                               rtol=1e-13)
    np.testing.assert_array_equal(ctl.t.shape, net.t.shape)
    np.testing.assert_allclose(ctl.y, net.y, rtol=0, atol=1e-11 * np.abs(net.y).max())


def test_complementary_pwm_with_dead_time_equals_netlist_gates():
    s = transient_setup(parse_file(CL / "sync_buck.cir"))
    probes = ["i(L1)", "v(out)", "v(sw)", "i(D2)"]
    T = 1e-5
    strobe = T * np.arange(1, 30)
    net = simulate(s.system, s.signals, s.x0, 0.3e-3, 50e-9, probes=probes, save_at=strobe)
    pwm = OpenLoopPWM("S1", 100e3, 0.42, complement="S2", dead_time=200e-9)
    ctl = simulate(s.system, s.signals, s.x0, 0.3e-3, 50e-9, probes=probes, controllers=[pwm],
                   save_at=strobe)
    assert net.ok and ctl.ok
    assert ctl.switching == {"S1": "controller", "S2": "controller"}
    np.testing.assert_allclose([t for t, _ in ctl.events], [t for t, _ in net.events],
                               rtol=1e-9, atol=1e-15)
    assert [md for _, md in ctl.events] == [md for _, md in net.events]
    # The pattern: S1 on [kT, kT + dT), both off for 200 ns, S2 on, both off for 200 ns.
    first = [(round(t / T * 1000) / 1000, md) for t, md in ctl.events[:4]]
    assert first == [(0.42, (False, False)), (0.44, (False, True)), (0.98, (False, False)),
                     (1.0, (True, False))]
    # (The two grids differ by the gate sources' 1 ns edges: compare at the period starts.)
    a = ctl.y[np.isin(ctl.t, strobe)]
    b = net.y[np.isin(net.t, strobe)]
    assert len(a) == len(b) == 29
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-6 * np.abs(b).max())
    # The body diode carries the inductor current during the dead times.
    late = (ctl.t > 0.2e-3) & (ctl["i(D2)"] > 0)
    assert late.any()
    np.testing.assert_allclose(ctl["i(D2)"][late], ctl["i(L1)"][late], rtol=1e-9)


def test_pwm_commands_edge_cases():
    assert pwm_commands(0.0, 1.0, 0.0, "S") == [(0.0, {"S": False})]
    assert pwm_commands(0.0, 1.0, 1.0, "S") == [(0.0, {"S": True})]
    cmds = pwm_commands(2.0, 1.0, 0.25, "S", "Q", 0.1)
    assert cmds == [(2.0, {"S": True}), (2.0, {"Q": False}), (2.25, {"S": False}),
                    (2.35, {"Q": True}), (2.9, {"Q": False})]
    with pytest.raises(ValueError, match="duty"):
        OpenLoopPWM("S", 1e3, 1.5)
    with pytest.raises(ValueError, match="dead_time"):
        OpenLoopPWM("S", 1e3, 0.5, dead_time=1e-3)


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_pi_buck_reaches_reference():
    s = transient_setup(parse_file(BUCK))
    pi = PIPWM("S1", "v(out)", 10.0, kp=0.02, ki=20.0, frequency=50e3, d0=0.4)
    res = simulate(s.system, s.signals, s.x0, 20e-3, 0.2e-6, probes=["v(out)", "d(S1)"],
                   controllers=[pi], every=10, save_at=[19.98e-3])
    assert res.ok and res.switching == {"S1": "controller"}
    t, y, d = np.array(pi.history).T
    assert len(t) == 1000 and np.allclose(np.diff(t), 20e-6)
    # Sampled at the period starts: the measured value is the output there.
    assert t[-1] == 19.98e-3
    np.testing.assert_allclose(y[-1], res["v(out)"][res.t == t[-1]][0], rtol=1e-12)
    late = res.t > 15e-3
    v = res["v(out)"][late]
    assert v.mean() == pytest.approx(10.0, rel=2e-3)
    assert np.abs(y[-50:] - 10.0).max() < 0.02
    # The integral finds the duty of the lossless buck, v / Vin.
    assert d[-1] == pytest.approx(10.0 / 24.0, rel=5e-3)
    # The stored duty probe follows the switch.
    assert set(np.unique(res["d(S1)"])) <= {0.0, 1.0}


def test_pi_delay_and_limits():
    s = transient_setup(parse_file(BUCK))
    pi = PIPWM("S1", "v(out)", 30.0, kp=1.0, ki=1e4, frequency=50e3, d0=0.4, duty_max=0.9,
               delay=1)
    res = simulate(s.system, s.signals, s.x0, 2e-3, 0.5e-6, controllers=[pi], every=100)
    assert res.ok
    d = np.array([h[2] for h in pi.history])
    assert d[0] == pytest.approx(0.4)  # the delayed first period uses d0
    assert d.max() == pytest.approx(0.9)  # unreachable reference: clamped
    # Anti-windup: the integral keeps the unclamped duty at the limit.
    assert 0.4 + pi.integral <= 0.9 + 1e-12


@pytest.mark.parametrize("vh", [0.0, 0.05])
def test_sliding_surface_from_coefficients_equals_netlist(vh):
    s = transient_setup(parse_file(CL / "boost_smc.cir", params={"vh": vh}))
    probes = ["i(L1)", "v(out)", "d(S1)"]
    net = simulate(s.system, s.signals, s.x0, 5e-3, 0.5e-6, probes=probes)
    smc = SlidingSurface("S1", {"i(L1)": 1.0}, offset=-2.0, hysteresis=vh)
    ctl = simulate(s.system, s.signals, s.x0, 5e-3, 0.5e-6, probes=probes, controllers=[smc])
    assert ctl.ok and ctl.switching == net.switching
    assert len(ctl.events) == len(net.events) and len(ctl.sliding) == len(net.sliding)
    for a, b in zip(ctl.sliding, net.sliding, strict=True):
        assert a[0] == b[0] and a[1] == pytest.approx(b[1], rel=1e-12)
    np.testing.assert_allclose(ctl.y, net.y, rtol=0, atol=1e-10 * np.abs(net.y).max())


def test_sliding_surface_positive_and_method():
    s = transient_setup(parse_file(CL / "boost_smc.cir"))
    smc = SlidingSurface("S1", {"i(L1)": -1.0}, offset=2.0, on_when="positive",
                         method="explicit")
    res = simulate(s.system, s.signals, s.x0, 2e-3, 1e-6, controllers=[smc],
                   probes=["i(L1)"])
    assert res.switching == {"S1": "explicit"}
    assert np.abs(res["i(L1)"][res.t > 1e-3] - 2.0).max() < 0.05


def test_controller_errors():
    s = transient_setup(parse_file(BUCK))
    with pytest.raises(KeyError, match="no switch"):
        simulate(s.system, s.signals, s.x0, 1e-4, 1e-6,
                 controllers=[OpenLoopPWM("S9", 50e3, 0.5)])
    with pytest.raises(ValueError, match="two controllers"):
        simulate(s.system, s.signals, s.x0, 1e-4, 1e-6,
                 controllers=[OpenLoopPWM("S1", 50e3, 0.5), OpenLoopPWM("s1", 50e3, 0.3)])

    class Rogue(OpenLoopPWM):
        def decide(self, t, values):
            return [(t, {"S2": True})]

    with pytest.raises(KeyError):
        simulate(s.system, s.signals, s.x0, 1e-4, 1e-6, controllers=[Rogue("S1", 5e4, 0.5)])
