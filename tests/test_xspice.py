"""ngspice's XSPICE A elements (netlist.xspice): reading the lines and model cards, the exact
equivalents (gain, summer, triangle), the idealised ones (limit as a comparator, aswitch as
an ideal switch) against ngspice, and the refusals with their place."""

from __future__ import annotations

import numpy as np
import pytest
from netlist_asserts import refused_at
from ngspice_helpers import ngspice_wrdata

from netlist.circuit import Vcvs, VoltageSource
from netlist.errors import NetlistError
from netlist.parser import parse_string
from netlist.studies.realistic import simulate_devices
from netlist.studies.transient import simulate_circuit

# a buck converter whose PWM is XSPICE: triangle carrier, summer, limit comparator; the
# switch is an S element (BUCK) or an XSPICE aswitch (BUCK_ASWITCH)
PWM = """\
Vd duty 0 DC 0.4
atri duty tri tri1
.model tri1 triangle(cntl_array=[0 1] freq_array=[{fs} {fs}] out_low=0 out_high=1
+ duty_cycle=0.5)
acmp [duty tri] err sum1
.model sum1 summer(in_gain=[1.0 -1.0])
alim err g lim1
.model lim1 limit(gain=1e6 out_lower_limit=0 out_upper_limit=1 fraction=FALSE)
"""
POWER = """\
V1 in 0 DC 12
D1 0 sw dm
.model dm D
L1 sw out 100u
C1 out 0 100u
R1 out 0 5
.param fs=50k
.tran 0.1u 2m uic
.end
"""
BUCK = ("xspice buck\n" + PWM + "S1 in sw g 0 swm\n.model swm SW(VT=0.5 VH=0 RON=0.01)\n"
        + POWER)
BUCK_ASWITCH = ("xspice buck, aswitch\n" + PWM
                + "asw g (in sw) aswm\n.model aswm aswitch(cntl_off=0.0 cntl_on=1.0 r_off=1e9"
                + " r_on=0.01 log=TRUE)\n" + POWER)


def test_exact_equivalents():
    c = parse_string(BUCK)
    tri = c.element("atri")
    assert isinstance(tri, VoltageSource) and tri.nodes == ("tri", "0")
    # ngspice's triangle: out_low at t = 0, out_high at duty_cycle/freq, back at 1/freq
    assert tri.waveform.times == (0.0, 10e-6, 20e-6) and tri.waveform.values == (0.0, 1.0, 0.0)
    assert tri.waveform.repeat == 0.0
    # the summer v(duty) - v(tri): one E source across the difference, no constant
    acmp = [el for el in c.elements if el.name.lower().startswith("acmp")]
    assert len(acmp) == 1 and isinstance(acmp[0], Vcvs)
    assert acmp[0].control == ("duty", "tri") and acmp[0].gain == 1.0
    sw = c.element("S1")
    # the limit's step: gain*v(err) = 0.5, mapped onto the switch (VT 0.5 inside 0..1)
    assert sw.control == ("err", "0")
    assert c.models[sw.model.lower()].params["vt"] == pytest.approx(0.5e-6)
    assert any("XSPICE limit (gain 1e+06) read as a comparator" in n for n in c.notes)
    assert any("alim: XSPICE limit" in n and "mapped onto switch S1" in n for n in c.notes)


def test_aswitch_is_an_ideal_switch_at_the_control_midpoint():
    c = parse_string(BUCK_ASWITCH)
    sw = c.element("asw")
    # the limit's comparator then maps onto the aswitch's switch: on while v(err) > 0.5e-6
    assert sw.nodes == ("in", "sw") and sw.control == ("err", "0")
    params = c.models[sw.model.lower()].params
    assert params["ron"] == 0.01
    assert any("XSPICE aswitch read as an ideal switch on while v(g) is above 0.5 V" in n
               for n in c.notes)
    # reversed: cntl_on below cntl_off turns the switch on below the midpoint
    rev = parse_string(BUCK_ASWITCH.replace("cntl_off=0.0 cntl_on=1.0", "cntl_off=1 cntl_on=0"))
    sw = rev.element("asw")
    assert sw.control == ("0", "err")  # on while the comparison is false


def _ngspice_mean(deck: str, tmp_path, start: float) -> float:
    ng = ngspice_wrdata(deck, ["v(out)"], tmp_path)
    keep = ng[:, 0] >= start
    return float(np.trapezoid(ng[keep, 1], ng[keep, 0]) / (ng[-1, 0] - start))


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("deck", [BUCK, BUCK_ASWITCH], ids=["S", "aswitch"])
def test_xspice_buck_against_ngspice(deck, tmp_path, ngspice):
    """Mean v(out) over the second millisecond (duty cycle 0.4 of 12 V, less the diode):
    ngspice 4.287 V with the S switch and with the aswitch, pelcs (pwl diode) 4.353 V."""
    res = simulate_devices(parse_string(deck), devices="pwl", probes=["v(out)"])
    res.raise_if_error()
    mine = res.t >= 1e-3
    got = np.trapezoid(res["v(out)"][mine], res.t[mine]) / (res.t[-1] - 1e-3)
    want = _ngspice_mean(deck, tmp_path, 1e-3)
    assert got == pytest.approx(want, rel=0.02)


@pytest.mark.parametrize("edit, where, words", [
    # a model pelcs has no equivalent for
    (("alim err g lim1", "alim err g lim1\naint err q int1\n.model int1 int(gain=1)"),
     (9, 12), ["XSPICE code model 'int'", "nonlinear or dynamic"]),
    # a limit of low gain is a clamp
    (("gain=1e6", "gain=10"), (9, 19), ["a limit of gain 10 is a clamp"]),
    # a voltage-controlled oscillator
    (("freq_array=[{fs} {fs}]", "freq_array=[{fs} 2e5]"), (4, 39),
     ["frequency follows its control"]),
    # a current port
    (("acmp [duty tri]", "acmp [duty %i tri]"), (6, 12), ["port 'in' of type %i"]),
    # a parameter the model does not have
    (("fraction=FALSE", "fraktion=FALSE"), (9, 64), ["'fraktion' is not a parameter"]),
    # a vector port written as a scalar
    (("acmp [duty tri] err", "acmp duty err"), (6, 6), ["port 'in' of the summer code model "
                                                        "is a vector"]),
    # an unknown model
    (("alim err g lim1", "alim err g lim2"), (8, 12), ["unknown XSPICE model 'lim2'"]),
    # a digital port
    (("alim err g lim1", "alim ~err g lim1"), (8, 6), ["inverted digital port"]),
])
def test_refusals_name_the_place(edit, where, words):
    deck = BUCK.replace(*edit)
    assert deck != BUCK
    refused_at(deck, where, words)


SQUARE = """xspice square: its default levels, slow edges, inside a subcircuit
.subckt osc out
asq 0 out sq
.model sq square(cntl_array=[0 1] freq_array=[10k 10k] duty_cycle=0.3 rise_time=2u
+ fall_time=5u)
.ends
X1 g osc
R1 g 0 1k
.tran 0.1u 0.3m
.end
"""


def test_square_is_a_pulse_source_as_ngspice_runs_it(tmp_path, ngspice):
    # ngspice's square (cfunc.mod): out_low (default -1) for the first 1 - duty_cycle of the
    # period, up over rise_time, out_high (1) to the period's end, down over fall_time
    c = parse_string(SQUARE)
    sq = c.element("X1.asq")
    assert isinstance(sq, VoltageSource) and sq.nodes == ("g", "0")
    w = sq.waveform
    assert (w.v1, w.v2, w.tr, w.tf, w.per) == (-1.0, 1.0, 2e-6, 5e-6, pytest.approx(1e-4))
    assert w.td == pytest.approx(70e-6) and w.pw == pytest.approx(28e-6)
    data = ngspice_wrdata(SQUARE, ["v(g)"], tmp_path)
    t, v = data[:, 0], data[:, 1]
    run = simulate_circuit(c, probes=["v(g)"])
    np.testing.assert_allclose(np.interp(t, run.t, run.y[:, 0]), v, atol=1e-6)


def test_square_edges_longer_than_its_levels_are_refused():
    with pytest.raises(NetlistError) as exc:
        parse_string(SQUARE.replace("rise_time=2u", "rise_time=40u"))
    assert "do not fit in its high and low times" in str(exc.value)
    assert "<string>:4:" in str(exc.value)


# limits whose input is tied to ground, as a subcircuit's port wired to 0 makes them (a flip-
# flop's unused reset in a PWM latch): the output is a constant, the clamped gain*(0 +
# in_offset); before, pelcs stopped with a traceback
GROUNDED_LIMITS = """\
limits of a grounded input
alim 0 b lim
.model lim limit(gain=1000 out_lower_limit=0 out_upper_limit=5)
R1 b 0 1k
alim2 0 c lim2
.model lim2 limit(gain=1 in_offset=2 out_lower_limit=-1 out_upper_limit=5)
R2 c 0 1k
alim3 0 d lim3
.model lim3 limit(gain=1000 in_offset=1 out_lower_limit=0 out_upper_limit=5)
R3 d 0 1k
.tran 1u 10u
.end
"""


def test_limit_of_a_grounded_input_is_its_clamped_constant(tmp_path, ngspice):
    probes = ["v(b)", "v(c)", "v(d)"]
    c = parse_string(GROUNDED_LIMITS)
    assert any("limit of a constant input" in n for n in c.notes)
    run = simulate_circuit(c, probes=probes)
    data = ngspice_wrdata(GROUNDED_LIMITS, probes, tmp_path)
    # ngspice: 2.5e-7 V (its limit_range smoothing at the lower corner), 2 V, 5 V
    for k in range(3):
        np.testing.assert_allclose(run.y[:, k], data[-1, 2 * k + 1], atol=1e-6)
