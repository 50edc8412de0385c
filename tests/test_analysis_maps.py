"""Stroboscopic and event maps (lcs.analysis.maps) against independent references.

Reference: an open-loop PWM converter in continuous conduction has an affine stroboscopic
map ``P(x) = Φ x + c`` with ``Φ = expm(A_off t3) expm(A_on D T) expm(A_off t1)`` (the gate of
the bundled netlists rises over 10 ns, so the switch is on from 5 ns to D T + 5 ns), computed
here with scipy.linalg.expm from the element values, independently of the formulation.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from lcs.analysis.maps import EventMap, EventSpec, FunctionMap, MapError, StroboscopicMap
from netlist.parser import parse_string
from netlist.studies.sweep import CircuitMapFactory, circuit_map, parse_grid, parse_range

# The netlists are written here (not the bundled ones, whose values may be retuned).
BOOST_TEXT = """Boost converter, open-loop PWM (CCM)
.param vin=12 duty=0.5 fs=50k rload=20
.param ts={1/fs}
Vin in 0 DC {vin}
L1 in sw 100u
S1 sw 0 gate 0 SWIDEAL
D1 sw out DIDEAL
C1 out 0 100u IC=0
R1 out 0 {rload}
Vg gate 0 PULSE(0 1 0 10n 10n {duty*ts-10n} {ts})
.model SWIDEAL SW(VT=0.5 VH=0 RON=1m ROFF=1e9)
.model DIDEAL D(IS=1e-12 N=0.05 RS=1m)
.tran 0.2u 5m 0 0.2u UIC
.end
"""
BOOST_DCM_TEXT = """Boost converter, open-loop PWM (DCM)
.param vin=12 duty=0.3 fs=50k
.param ts={1/fs}
Vin in 0 DC {vin}
L1 in sw 20u
S1 sw 0 gate 0 SWIDEAL
D1 sw out DIDEAL
C1 out 0 100u IC=0
R1 out 0 50
Vg gate 0 PULSE(0 1 0 10n 10n {duty*ts-10n} {ts})
.model SWIDEAL SW(VT=0.5 VH=0 RON=1m ROFF=1e9)
.model DIDEAL D(IS=1e-12 N=0.05 RS=1m)
.tran 0.2u 20m 0 0.2u UIC
.end
"""
# A heavily damped buck (R C = 5 µs against T = 20 µs): the map contracts fast, so cell
# mapping sees a single-cell attractor.
BUCK_TEXT = """Damped buck converter, open-loop PWM
.param vin=24 duty=0.5 fs=50k
.param ts={1/fs}
Vin in 0 DC {vin}
S1 in sw gate 0 SWIDEAL
D1 0 sw DIDEAL
L1 sw out 50u
C1 out 0 5u
R1 out 0 1
Vg gate 0 PULSE(0 1 0 10n 10n {duty*ts-10n} {ts})
.model SWIDEAL SW(VT=0.5 VH=0 RON=1m ROFF=1e9)
.model DIDEAL D(IS=1e-12 N=0.05 RS=1m)
.tran 0.2u 1m 0 0.2u UIC
.end
"""

L, C, R, VIN, DUTY, T = 100e-6, 100e-6, 20.0, 12.0, 0.5, 20e-6
T_ON = 5e-9  # the 0.5 V gate threshold is crossed 5 ns into the 10 ns edges


@pytest.fixture(scope="session")
def netlists(tmp_path_factory) -> dict[str, str]:
    """Paths of the test netlists: ``boost``, ``boost_dcm``, ``buck``."""
    d = tmp_path_factory.mktemp("analysis_netlists")
    out = {}
    for name, text in (("boost", BOOST_TEXT), ("boost_dcm", BOOST_DCM_TEXT),
                       ("buck", BUCK_TEXT)):
        (d / f"{name}.cir").write_text(text)
        out[name] = str(d / f"{name}.cir")
    return out


def _flow(A: np.ndarray, b: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """x(t) = Φ x(0) + c for x' = A x + b (augmented-matrix exponential)."""
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n], M[:n, n] = A, b
    E = expm(M * t)
    return E[:n, :n], E[:n, n]


def boost_reference(duty: float = DUTY) -> tuple[np.ndarray, np.ndarray]:
    """(Φ, c) of the CCM boost over one period from t = 0; states (i(L1), v(C1))."""
    a_on = np.array([[0.0, 0.0], [0.0, -1 / (R * C)]])
    a_off = np.array([[0.0, -1 / L], [1 / C, -1 / (R * C)]])
    b = np.array([VIN / L, 0.0])
    P1 = _flow(a_off, b, T_ON)
    P2 = _flow(a_on, b, duty * T)
    P3 = _flow(a_off, b, T - duty * T - T_ON)
    Phi = P3[0] @ P2[0] @ P1[0]
    c = P3[0] @ (P2[0] @ P1[1] + P2[1]) + P3[1]
    return Phi, c


def buck_reference(duty: float, vin: float = 24.0) -> tuple[np.ndarray, np.ndarray]:
    """(Φ, c) of the damped CCM buck (BUCK_TEXT) over one period from t = 0."""
    Lb, Cb, Rb = 50e-6, 5e-6, 1.0
    a = np.array([[0.0, -1 / Lb], [1 / Cb, -1 / (Rb * Cb)]])
    P1 = _flow(a, np.zeros(2), T_ON)
    P2 = _flow(a, np.array([vin / Lb, 0.0]), duty * T)
    P3 = _flow(a, np.zeros(2), T - duty * T - T_ON)
    return P3[0] @ P2[0] @ P1[0], P3[0] @ (P2[0] @ P1[1] + P2[1]) + P3[1]


def test_boost_map_is_the_affine_reference_map(netlists):
    Phi, c = boost_reference()
    m = CircuitMapFactory(netlists["boost"], period="ts", step=0.05e-6)()
    assert isinstance(m, StroboscopicMap)
    assert m.state_names == ("i(L1)", "v(C1)")
    assert m.notes == []
    for x in ([1.8, 24.0], [3.0, 20.0], [2.5, 26.0]):
        x = np.array(x)
        np.testing.assert_allclose(m(x), Phi @ x + c, rtol=0, atol=2e-6 * 30)


def test_map_error_decreases_at_second_order(netlists):
    Phi, c = boost_reference()
    x = np.array([1.8, 24.0])
    errs = []
    for h in (0.4e-6, 0.2e-6, 0.1e-6):
        m = CircuitMapFactory(netlists["boost"], period="ts", step=h)()
        errs.append(np.max(np.abs(m(x) - (Phi @ x + c))))
    assert errs[0] / errs[1] == pytest.approx(4, rel=0.15)
    assert errs[1] / errs[2] == pytest.approx(4, rel=0.15)


def test_iterate_sample_and_power_agree_with_single_steps(netlists):
    m = CircuitMapFactory(netlists["boost"], period="ts")()
    x = np.array([1.0, 20.0])
    it = m.iterate(x, 5)
    assert it.shape == (6, 2)
    y = x
    for k in range(1, 6):
        y = m(y)
        np.testing.assert_allclose(it[k], y, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(m.power(x, 5), it[5], rtol=1e-12)
    s = m.sample(x, 2, 3, ["v(out)", "i(L1)", "i(D1)"])
    assert s.ok and s.names == ("v(out)", "i(L1)", "i(D1)")
    np.testing.assert_allclose(s.values[:, 0], it[3:6, 1], rtol=1e-12)
    np.testing.assert_allclose(s.values[:, 1], it[3:6, 0], rtol=1e-12)
    np.testing.assert_allclose(s.x_final, it[5], rtol=1e-12)
    # One simulate call for 5 periods, with only the period samples stored.
    n0 = m.evaluations
    m.iterate(x, 50)
    assert m.evaluations == n0 + 1


def test_sampling_when_steps_per_period_vary():
    """A step that does not divide the period: samples are still picked at k T."""
    c = parse_string(BOOST_TEXT)
    m = circuit_map(c, "ts", step=0.3e-6)  # rounded to T / 67
    assert m.h == pytest.approx(T / 67)
    it = m.iterate([1.0, 20.0], 4)
    y = np.array([1.0, 20.0])
    for k in range(1, 5):
        y = m(y)
        np.testing.assert_allclose(it[k], y, rtol=1e-12)


def test_pattern_ccm_and_dcm(netlists):
    m = CircuitMapFactory(netlists["boost"], period="ts")()
    pat = m.pattern(np.array([1.8, 24.0]))
    assert pat.switch_names == ("S1",) and pat.diode_names == ("D1",)
    # 5 ns off (diode on), D T on, rest off: the first and last interval are one.
    assert pat.signature == (((False,), (True,)), ((True,), (False,)))
    on = [s for s in pat.segments if s.switches == (True,)]
    assert on[0].duration == pytest.approx(DUTY * T, rel=1e-9)
    assert sum(s.duration for s in pat.segments) == pytest.approx(T)
    mdcm = CircuitMapFactory(netlists["boost_dcm"], period="ts")()
    pat = mdcm.pattern(np.array([0.0, 25.0]))
    assert ((False,), (False,)) in pat.signature  # everything off: DCM
    assert len(pat.signature) == 3
    assert "S1 on, D1 off" in str(pat)


def test_event_map_at_switch_on_equals_shifted_stroboscopic_map():
    c = parse_string(BOOST_TEXT)
    em = circuit_map(c, "ts", event="S1:on")
    assert isinstance(em, EventMap) and em.event.kind == "switch"
    assert em.state_names == ("i(L1)", "v(C1)", "phase")
    sm = circuit_map(c, "ts", t0=T_ON)
    z = np.array([1.5, 22.0, T_ON])
    z1 = em(z)
    assert z1[2] == pytest.approx(T_ON, abs=1e-15)
    np.testing.assert_allclose(z1[:2], sm(z[:2]), rtol=1e-9)
    it = em.iterate(z, 4)
    np.testing.assert_allclose(it[:, :2], sm.iterate(z[:2], 4), rtol=1e-9)
    # Starting elsewhere in the period: the first image is the state at the next switch-on.
    z = np.array([1.5, 22.0, 0.3 * T])
    times = em.event_times(z, 3)
    np.testing.assert_allclose(times, T + T_ON + T * np.arange(3), rtol=1e-12)


def test_event_map_switch_off_and_diode_events():
    c = parse_string(BOOST_DCM_TEXT)
    off = circuit_map(c, "ts", event="S1:off")
    z = off(np.array([0.0, 25.0, 0.0]))
    assert z[2] == pytest.approx(0.3 * T + T_ON, rel=1e-9)
    # D1 starts conducting when S1 turns off (time resolution: one step).
    don = circuit_map(c, "ts", event="D1:on")
    assert don.event.kind == "diode"
    zd = don(np.array([0.0, 25.0, 0.0]))
    assert abs(zd[2] - z[2]) <= 1.01 * don.h
    # D1 stops conducting (DCM): i(L1) is zero there.
    doff = circuit_map(c, "ts", event="D1:off")
    zo = doff(np.array([0.0, 25.0, 0.0]))
    assert abs(zo[0]) < 1e-9 and z[2] < zo[2] < T
    # A probe crossing: i(L1) rising through 1 A during the on time, interpolated.
    pr = circuit_map(c, "ts", event="i(L1)>1")
    assert pr.event == EventSpec("probe", "i(L1)", True, 1.0)
    zp = pr(np.array([0.0, 25.0, 0.0]))
    assert zp[0] == pytest.approx(1.0, abs=1e-9)
    # di/dt = Vin / L on the on interval: t = 5 ns + L / Vin.
    assert zp[2] == pytest.approx(T_ON + 20e-6 / 12.0, rel=1e-6)


def test_event_spec_parsing_and_errors():
    assert EventSpec.parse("S1:on") == EventSpec("element", "S1", True)
    assert EventSpec.parse("v(out) < 12.5") == EventSpec("probe", "v(out)", False, 12.5)
    with pytest.raises(ValueError):
        EventSpec.parse("S1")
    c = parse_string(BOOST_TEXT)
    with pytest.raises(KeyError):
        circuit_map(c, "ts", event="S9:on")
    em = circuit_map(c, "ts", event="v(out)>1000", max_periods=3)
    with pytest.raises(MapError, match="within 3 periods"):
        em(np.array([1.0, 24.0, 0.0]))


def test_function_map_and_failures():
    m = FunctionMap(lambda x: 2 * x, ("a", "b"), param=1.0, param_name="p")
    assert m.dim == 2
    np.testing.assert_array_equal(m.iterate([1, 1], 3)[-1], [8, 8])
    s = m.sample([1.0, 0.5], 1, 2, ["b"])
    np.testing.assert_array_equal(s.values[:, 0], [2.0, 4.0])
    bad = FunctionMap(lambda x: x / 0.0, ("a",))
    with np.errstate(divide="ignore"):
        with pytest.raises(MapError):
            bad([1.0])
        s = bad.sample([1.0], 0, 3)
    assert not s.ok and np.all(np.isnan(s.values))


def test_non_periodic_sources_are_refused_or_noted():
    from netlist.errors import NetlistError

    c = parse_string(BOOST_TEXT)
    # a circuit's map refuses the period (tests/test_period_multiple.py); a map built on
    # the system directly notes it
    with pytest.raises(NetlistError, match="is not a multiple of the period"):
        circuit_map(c, 1.5 * T)
    m = circuit_map(c, T)
    assert not any("not periodic" in n for n in m.notes)
    m15 = StroboscopicMap(m.system, m.signals, 1.5 * T, m.h)
    assert any("not periodic" in n for n in m15.notes)


def test_range_and_grid_parsing():
    r = parse_range("vin=20:35:301")
    assert (r.name, r.start, r.stop, r.count) == ("vin", 20.0, 35.0, 301)
    assert parse_range("tp=100u:400u").stop == pytest.approx(400e-6)
    np.testing.assert_allclose(parse_range("x=0:1:3").values(), [0, 0.5, 1])
    g = parse_grid("v(C1)=0:24:40, i(L1)=-2:6:30")
    assert g == [("v(C1)", 0.0, 24.0, 40), ("i(L1)", -2.0, 6.0, 30)]
    from netlist.errors import NetlistError

    for bad in ("vin=20", "vin=a:b:3", "vin=1:2:1", "vin=1:1:5"):
        with pytest.raises(NetlistError):
            parse_range(bad)
    with pytest.raises(NetlistError):
        parse_grid("v(C1)=0:1:3")
