"""A switch driven by sources in the initial mode whose control depends on the state in a
mode the source-driven instants reach: refused with the switch and the mode named."""

from __future__ import annotations

import numpy as np
import pytest

from lcs.model import LCS, ComplementarityPair, ModeModel, OutputMap, SwitchControl, SwitchedLCS
from lcs.signals import Dc, Pulse
from lcs.simulation.source_switching import source_switch_events


def _system() -> SwitchedLCS:
    """``x' = -x + s``; the control ``c`` of S is the gate input while S is off and, once
    S is on, also depends on x (a defect of the circuit's description)."""

    def builder(mode):
        one = np.ones((1, 1))
        lcs = LCS(A=-one, B=one, C=-one, D=one, E=np.array([[1.0 if mode[0] else 0.0, 0.0]]),
                  F=np.zeros((1, 2)), states=("x",), pairs=(ComplementarityPair("D"),),
                  inputs=("one", "gate"))

        def outputs(names):
            cy = 1.0 if mode[0] else 0.0
            return OutputMap(tuple(names), np.full((len(names), 1), cy),
                             np.zeros((len(names), 1)), np.tile([0.0, 1.0], (len(names), 1)))

        return ModeModel(lcs, outputs)

    return SwitchedLCS([SwitchControl("S7", "c", vt=0.5, vh=0.0)], ("x",), ("one", "gate"),
                       ("D",), builder)


def test_control_that_becomes_state_dependent_is_refused_by_name():
    gate = Pulse(0.0, 1.0, 1e-4, 1e-6, 1e-6, 4e-4, 1e-3)
    with pytest.raises(NotImplementedError, match=r"switch S7: its control 'c' depends on "
                       r"the circuit state in mode \{'S7': 'on'\}"):
        bps = gate.breakpoints(0.0, 2e-3)
        source_switch_events(_system(), [Dc(1.0), gate], 0.0, 2e-3,
                             np.sort(bps[(bps > 0) & (bps < 2e-3)]), 1e-6)
