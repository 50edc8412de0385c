"""Controllers and switching methods reach the simulator through the circuit-level API."""

import numpy as np

import pelcs
from converters import factories
from lcs.controllers import OpenLoopPWM


def test_controller_through_api_equals_pulse_gate_netlist():
    # Same buck, once with its PULSE gate and once with the gate held at 0 V and the switch
    # driven by a controller. The PULSE crosses VT = 0.5 V in the middle of its 10 ns edges,
    # so the controller's periods start 5 ns late.
    probes = ["i(L1)", "v(out)"]
    net = pelcs.simulate(factories.buck(duty=0.4), tstop="1m", probes=probes)
    held = factories.buck(duty=0.4, gate="off")
    ctl = pelcs.simulate(held, tstop="1m", probes=probes,
                         controllers=[OpenLoopPWM("S1", 50e3, 0.4, phase=5e-9)])
    assert ctl.switching == {"S1": "controller"}
    # The PULSE run also lands on the gate's edge breakpoints (0, 10 ns, ...), so the two
    # step grids differ near each edge: agreement to the local O(h^2) error, not round-off.
    np.testing.assert_allclose(ctl["v(out)"][-1], net["v(out)"][-1], rtol=1e-6)
    np.testing.assert_allclose(ctl["i(L1)"][-1], net["i(L1)"][-1], rtol=1e-6)
    # Held off and not driven, the switch never closes: the output stays at its start.
    off = pelcs.simulate(held, tstop="1m", probes=probes)
    assert off.events == [] or all(not any(md) for _, md in off.events)


def test_switching_method_is_passed_through():
    path = "converters/netlists/boost_smc.cir"
    explicit = pelcs.simulate(path, tstop="2m", switching="explicit")
    assert set(explicit.switching.values()) == {"explicit"}
    hyst = pelcs.simulate(path, tstop="2m", switching="hysteresis")
    assert set(hyst.switching.values()) == {"hysteresis"}
