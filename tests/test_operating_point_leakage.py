"""The operating point where pwl diodes alone reach a capacitor (their junction capacitors
among them): the diodes' leakage balance (lcs.theory.operating_point._leak_balanced).

A diode of several pwl segments shares its current among parallel branches, one pair each;
in exact arithmetic the segments' currents enter no capacitor's equation, but the
formulation's matrices give them round-off there (1.7e-9 of the diode's own entry in its
junction capacitor's row), which counted as diodes acting on the capacitor's charge, with
random signs: pelcs said it found no operating point and started from the initial
conditions. The starts are checked against a hand derivation and against ngspice's ``.op``.
"""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import numpy as np
import pytest
from ngspice_helpers import ngspice_print

from lcs.theory.operating_point import dc_point
from netlist.parser import parse_file, parse_string
from netlist.studies.realistic import simulate_devices

CORPUS = Path(__file__).parent / "corpus"

DECK = """diode from a source into a capacitor with no other path
V1 in 0 SIN(2 1 1k)
D1 in a DX
C1 a 0 10n
.model DX D(IS=2.495E-09 RS=4.755E-01 N=1.679 CJO=1.7E-12 M=0.1959)
.tran 1u 3m
.end
"""


def _pwl_run(circuit, probes):
    with contextlib.redirect_stderr(io.StringIO()):
        return simulate_devices(circuit, devices="pwl", probes=probes)


def test_a_segmented_diode_into_a_lone_capacitor_starts_at_its_source(tmp_path, ngspice):
    # By hand: at t = 0 V1 is 2 V; C1 is open at DC and reached only through D1 (its
    # junction capacitor behind RS), so D1 carries nothing: any v(a) at which it blocks
    # holds, v(a) >= 2 V - Vf1 (below its lowest segment's knee Vf1 the pwl diode carries
    # nothing). Its leakage across the junction (ngspice's GMIN) takes the least junction
    # voltage: v(a) = 2 V. (Before: "pelcs finds no DC operating point", start at v(a) = 0 V;
    # with the leak on w instead of the junction, the knee 2 V - Vf1 = 1.873 V)
    res = _pwl_run(parse_string(DECK), ["v(a)", "v(in)"])
    assert not any("DC operating point" in n for n in res.notes), res.notes
    fit = next(f for f in res.device_fits if f.element == "D1")
    assert len(fit.branches) >= 2  # (a diode of several segments: the structure at issue)
    assert res.y[0] == pytest.approx([2.0, 2.0], abs=1e-9)
    ng = ngspice_print(DECK.replace(".tran 1u 3m", ".op"), ["v(a)"], tmp_path)
    assert res.y[0][0] == pytest.approx(ng["v(a)"], abs=1e-4)  # ngspice 1.999993 V


def _segmented_lcs(eps: float):
    """x = v(Cj); one diode of two segments: the main pair (total current λ0 into Cj) and a
    segment λ1 that only shares λ0 between branches, its entry in B ``eps`` of λ0's.
    w0 = -x + R (λ0 - λ1) + Vf, w1 = R (λ1 - λ0) + R1 λ1 + (Vf2 - Vf); inputs (Vf, Vf2)."""
    c, r, r1 = 1e-12, 5e6, 2e6
    return (np.zeros((1, 1)), np.array([[-1.0 / c, eps / c]]), np.array([[-1.0], [0.0]]),
            np.array([[r, -r], [-r, r + r1]]), np.zeros((1, 2)),
            np.array([[1.0, 0.0], [-1.0, 1.0]]))


def test_round_off_in_a_segments_column_does_not_act_on_the_capacitor():
    # the capacitor, reached only by the diode, is free at DC: any x <= Vf with both
    # currents zero. Its leakage across the junction (the diode's own offsets Vf, Vf2 left
    # out of w) puts it at 0 V; on w itself, at the knee x = Vf. The segment's B entry of
    # 3e-9 is the formulation's round-off (before: counted as acting, no point found)
    vf, vf2 = 0.1, 0.2
    arrays = _segmented_lcs(3e-9)
    u = np.array([vf, vf2])
    p = dc_point(*arrays, u, np.zeros(1), offsets=np.ones((2, 2), bool))
    assert p.ok, p.reason
    assert p.x == pytest.approx([0.0], abs=1e-12)
    assert p.lam == pytest.approx([0.0, 0.0], abs=1e-15)
    knee = dc_point(*arrays, u, np.zeros(1))
    assert knee.ok and knee.x == pytest.approx([vf], abs=1e-12)


def _op_deck(path: Path) -> str:
    """The corpus file as an ngspice ``.op`` deck: its includes inlined (a ``.net``) or made
    absolute, its ``.tran``, ``.plot`` and ``.control`` blocks dropped."""

    def include(m):
        inc = (path.parent / m.group(2)).resolve()
        return _inline(inc) if inc.suffix == ".net" else m.group(1) + str(inc)

    def _inline(p: Path) -> str:
        return re.sub(r"(?im)^(\.include\s+)\"?([^\"\s]+)\"?",
                      lambda m: m.group(1) + str((p.parent / m.group(2)).resolve()),
                      p.read_text())

    text = re.sub(r"(?im)^(\.include\s+)\"?([^\"\s]+)\"?", include, path.read_text())
    text = re.sub(r"(?ims)^\.control.*?^\.endc\s*$", "", text)
    text = re.sub(r"(?im)^\.(plot|end|tran)\b.*$", "", text)
    return text + "\n.op\n.end\n"


# file -> the probes compared, and the bound on |pelcs - ngspice| beyond 1 % (V)
STARTS = {
    # every node at 0 V (1e-18 V in ngspice, 0 V in pelcs)
    "esim/Examples/Fullwavebridgerectifier/Fullwavebridgerectifier.cir.out":
        (["v(out)", "v(in1)", "v(in2)"], 0.01),
    "ece3410/diodos/kk/exercise4.sp": (["v(nout)", "v(n2)", "v(n3)"], 0.01),
    # the star point of the sources at -max(phase) + Vf: ngspice -281.505 V, pelcs
    # -281.143 V (0.13 %); the phase that holds it, v(net_d5_a), at the pwl diode's knee
    # (0.655 V, below which the pwl diode carries nothing), where ngspice's exponential diode
    # passes the others' leakage at 0.293 V: 0.36 V apart, the fit's, not the point's
    "pess/simulations/rectifiers/3Phase/rectifier_3P.cir":
        (["v(n)", "v(rs_)", "v(net_d2_a)", "v(net_d5_a)"], 0.37),
    # every node at 0 V: the diodes (five segments of a 1N4148, three of a BAR42) leak
    # across their junctions, as ngspice's GMIN does (at their lowest knee, w = 0, the
    # capacitors would start 16.6 mV and up to 19 mV away)
    "esim/Examples/Clampercircuit/Clampercircuit.cir.out": (["v(out_neg)", "v(out_pos)"], 0.01),
    "python_ngspice/archive/vDubMult.net": (["v(v1)", "v(v2)", "v(v3)", "v(v4)"], 0.01),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(STARTS))
def test_the_corpus_starts_at_ngspices_operating_point(name, tmp_path, ngspice):
    path = CORPUS / name
    probes, bound = STARTS[name]
    res = _pwl_run(parse_file(path), probes)
    assert not any("no DC operating point" in n for n in res.notes), res.notes
    ng = ngspice_print(_op_deck(path), probes, tmp_path)
    want = np.array([ng[p] for p in probes])
    assert np.all(np.abs(res.y[0] - want) <= np.maximum(0.01 * np.abs(want), bound)), (
        res.y[0], want)
