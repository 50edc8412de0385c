"""An inductor whose only path is two diodes in series, which the output (held by ``.ic``
above the source) reverse-biases: its DC current is zero and the diodes share the reverse
voltage, which the DC equations do not split. ngspice splits it by the junctions' leakage
(GMIN alike across each); pelcs takes the least multipliers, and the state does not depend
on the split: the point exists, where pelcs said there was none."""

from __future__ import annotations

import numpy as np
import pytest
from ngspice_helpers import ngspice_wrdata

from lcs.theory.operating_point import dc_point
from netlist.parser import parse_string
from netlist.studies.transient import simulate_circuit


def test_diodes_in_series_share_the_reverse_voltage():
    # i_L' = (12 - 20 + λ1 + λ2)/L, w1 = w2 = i_L: DC i_L = 0, λ1 + λ2 = 8 V
    A, B, C, D = np.zeros((1, 1)), np.array([[1e4, 1e4]]), np.ones((2, 1)), np.zeros((2, 2))
    E, F = np.array([[1e4, -1e4]]), np.zeros((2, 2))
    p = dc_point(A, B, C, D, E, F, np.array([12.0, 20.0]), np.array([0.5]))
    assert p.ok and p.x == pytest.approx([0.0]) and p.lam == pytest.approx([4.0, 4.0])
    # (a source on the other side that forward-biases them: no point)
    assert not dc_point(A, B, C, D, E, F, np.array([12.0, 5.0]), np.zeros(1)).ok


DECK = """inductor behind two blocking diodes
V1 in 0 10
L1 in a 1m
D1 a b DM
D2 b out DM
C1 out 0 10u
R1 out 0 100
.model DM D(IS=1e-14)
.ic v(out)=20
.tran 1u 3m
.end
"""


def test_the_run_starts_at_ngspices_point_without_a_note(tmp_path, ngspice):
    probes = ["i(L1)", "v(out)"]
    res = simulate_circuit(parse_string(DECK), probes=probes)
    ng = ngspice_wrdata(DECK, probes, tmp_path)
    assert ng[0, [1, 3]] == pytest.approx([0.0, 20.0], abs=1e-6)
    assert res.y[0] == pytest.approx([0.0, 20.0])
    assert not any("no DC operating point" in n for n in res.notes), res.notes
