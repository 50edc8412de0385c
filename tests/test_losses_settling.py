"""Losses and efficiency only as a steady state's: PySpice's buck at its own 375 µs (the LC
has not settled: part of the input still charges the output capacitor) is reported as not
settled; run long enough, the window settles and the figures close the energy balance."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import pelcs
from lcs.notices import IdealisedDeviceWarning

DEV = Path(__file__).parent / "netlists" / "devices"


def _buck_losses(tstop: str):
    pytest.importorskip("PySpice")
    from converters.pyspice_examples import pyspice_buck

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        return pelcs.simulate(pyspice_buck(DEV / "vendor"), tstop=tstop, losses=True,
                              probes=["i(L1)", "v(out)"])


def _stored_rate(res) -> float:
    """Mean rate of change of the stored energy over the losses' window, W (L1 and C1; Cin
    is across the source, with no state), from the states at the window's ends."""
    from converters.pyspice_examples import pyspice_buck

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", IdealisedDeviceWarning)
        circuit = pelcs.load(pyspice_buck(DEV / "vendor"))
    L, C = circuit.element("L1").value, circuit.element("C1").value
    a, b = res.losses.window

    def energy(t):
        i = np.interp(t, res.t, res["i(L1)"])
        v = np.interp(t, res.t, res["v(out)"])
        return 0.5 * L * i * i + 0.5 * C * v * v

    return (energy(b) - energy(a)) / (b - a)


def test_losses_of_an_unsettled_window_are_flagged():
    res = _buck_losses("375u")
    rep = res.losses
    assert rep.checked and not rep.settled
    line = rep.lines()[-1]
    assert line.startswith("efficiency: ") and "(not settled: " in line and "run longer" in line
    assert any(n.startswith("losses: the window") and "not a steady state" in n
               for n in res.notes)
    assert rep.to_dict()["settled"] is False
    # the missing input is the energy still going into storage
    assert _stored_rate(res) > 0.02 * rep.p_in


def test_losses_of_a_settled_window_close_the_energy_balance():
    res = _buck_losses("3m")
    rep = res.losses
    assert rep.settled, rep.settling_text()
    assert rep.lines()[-1] == f"efficiency: {100 * rep.efficiency:.2f} %"
    assert not any(n.startswith("losses: the window") for n in res.notes)
    assert abs(_stored_rate(res)) < 1e-3 * rep.p_in
    # input = output + losses + the stored energy's change
    assert rep.efficiency == pytest.approx(rep.p_out / rep.p_in)
