"""A θ step whose λ is not unique but whose next state is (lcs.theory.step_uniqueness): the proof,
an independent check of it by enumerating every complementary basis with numpy, and the dense
kernel taking such steps (a diode bridge of macro-models, the 12-pulse rectifier) where it
used to look for a second solution, with the sparse kernel as the reference; a step with two
genuinely different next states still stops the run."""

from __future__ import annotations

import numpy as np
import pytest
from test_lcp import brute_force

from converters.scaling import rectifier_12pulse
from lcs.integrators.moreau.dense.discretise import discretise
from lcs.integrators.moreau.integrator import MoreauOptions, simulate_lcs
from lcs.model import LCS, ComplementarityPair
from lcs.theory.step_uniqueness import unique_next_state
from netlist.parser import parse_string
from netlist.studies.transient import run_setup, transient_setup

# Each diode of the bridge is a macro-model: an ideal diode, a 0.7 V source and 10 mΩ in
# series. With the output inductor carrying current while the input is small, all four
# conduct and the split between the legs is not determined (D is singular: pelcs lcs reports
# λ ~ {X1.D1: -1, X3.D1: +1} as not unique), the next state is.
MACRO_BRIDGE = """Diode bridge of macro-models into an LC filter
.subckt DMAC a k
D1 a x DIDEAL
V1 x y DC 0.7
R1 y k 10m
.ends
Vs ac1 0 SIN(0 12 50)
X1 ac1 p DMAC
X2 0 p DMAC
X3 n ac1 DMAC
X4 n 0 DMAC
L1 p q 1m
C1 q n 1000u IC=0
R1 q n 10
.model DIDEAL D
.tran 10u 40m 0 10u UIC
.end
"""


def _solutions(M, q):
    """Every complementary basis solution λ of ``w = M λ + q`` (numpy, by brute force; the
    step's blocks are worse conditioned than test_lcp's problems: 1e10 is singular here)."""
    return [lam for lam, _ in brute_force(M, q, cond_limit=1e10)]


def _image_spread(disc, q):
    """Largest difference between the next states of the step's LCP solutions (relative to
    their size), and their number."""
    sols = _solutions(disc.M, q)
    if not sols:
        return None, 0
    xs = np.array([disc.K @ lam for lam in sols])
    return np.abs(xs - xs[0]).max() / max(np.abs(xs).max(), 1e-300), len(sols)


def _mode(text):
    circuit = parse_string(text)
    setup = transient_setup(circuit)
    system = setup.system
    return setup, system, system.mode(system.all_keys()[0])


def _q_samples(lcs, disc, rng, count):
    for _ in range(count):
        x = rng.normal(size=lcs.n) * 10.0
        u = rng.normal(size=lcs.p) * 100.0
        xf = disc.Phi @ x + (disc.G0 + disc.G1) @ u
        yield lcs.C @ xf + lcs.F @ u


@pytest.mark.slow  # (a few seconds: outside the fast subset)
def test_12_pulse_rectifier_step_is_unique_at_theta_1_and_not_at_one_half():
    """θ = 1: every λ of the step (m = 12, λ not unique) gives the same next state; θ = 1/2 at
    the same step: the proof fails, and rightly so: some steps have several next states."""
    setup, system, lcs = _mode(rectifier_12pulse(periods=1))
    h = setup.h
    assert unique_next_state(lcs, system.storage, h, 1.0)
    assert not unique_next_state(lcs, system.storage, h, 0.5)
    rng = np.random.default_rng(5)
    one = discretise(lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, h, 1.0)
    several = 0
    for q in _q_samples(lcs, one, rng, 12):
        spread, count = _image_spread(one, q)
        assert count >= 1 and spread <= 1e-9
        several += count > 1
    assert several >= 1  # (λ was not unique in some of them)
    half = discretise(lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, h, 0.5)
    spreads = [_image_spread(half, q)[0] for q in _q_samples(lcs, half, rng, 12)]
    assert max(s for s in spreads if s is not None) > 1e-3


def test_macro_model_bridge_step_is_unique():
    setup, system, lcs = _mode(MACRO_BRIDGE)
    assert lcs.m == 4 and np.linalg.matrix_rank(np.vstack([lcs.B, lcs.D + lcs.D.T])) < 4
    assert unique_next_state(lcs, system.storage, setup.h, 0.5)
    disc = discretise(lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, setup.h, 0.5)
    rng = np.random.default_rng(2)
    several = 0
    for q in _q_samples(lcs, disc, rng, 30):
        spread, count = _image_spread(disc, q)
        assert count >= 1 and spread <= 1e-9
        several += count > 1
    assert several >= 1


def _indefinite_lcs():
    """``x' = λ1``, ``w = D λ - u`` with ``D = [[1, 2], [2, 1]]`` (indefinite: not passive).
    For u > 0 its LCP has three solutions, λ = (u/3, u/3), (u, 0) and (0, u), whose next
    states x + h u/3, x + h u and x differ; for u < 0 only λ = 0."""
    D = np.array([[1.0, 2.0], [2.0, 1.0]])
    return LCS(A=np.zeros((1, 1)), B=np.array([[1.0, 0.0]]), C=np.zeros((2, 1)), D=D,
               E=np.zeros((1, 1)), F=-np.ones((2, 1)), states=("x",),
               pairs=(ComplementarityPair("Da"), ComplementarityPair("Db")), inputs=("u",))


def test_two_different_next_states_still_stop_the_run():
    lcs = _indefinite_lcs()
    assert not unique_next_state(lcs, np.eye(1), 1e-3, 1.0)
    disc = discretise(lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, 1e-3, 1.0)
    spread, count = _image_spread(disc, np.array([-1.0, -1.0]))
    assert count == 3 and spread == pytest.approx(1.0)
    # u crosses zero at 2.5 ms: the previous step's λ = 0 stops being a solution, and the one
    # pivoting finds is one of three.
    res = simulate_lcs(lcs, [lambda t: t - 2.5e-3], np.zeros(1), 1e-2, 1e-3, theta=1.0,
                       options=MoreauOptions(kernel="dense"))
    assert res.error is not None and res.error.kind == "non_unique"
    assert 2.5e-3 <= res.error.time <= 4e-3
    assert set(res.error.pairs) <= {"Da", "Db"} and res.error.pairs


def test_dense_kernel_runs_the_macro_model_bridge_as_the_sparse_kernel_does():
    setup = transient_setup(parse_string(MACRO_BRIDGE))
    runs = {k: run_setup(setup, options=MoreauOptions(kernel=k)) for k in ("dense", "sparse")}
    d, s = runs["dense"], runs["sparse"]
    assert d.error is None and s.error is None
    assert d.stats.kernel == "dense" and s.stats.kernel == "sparse"
    # Every mode's steps are proven unique: no enumeration of other solutions.
    assert d.stats.uniqueness_checks == 0
    assert np.array_equal(d.t, s.t)
    assert np.abs(d.y - s.y).max() <= 1e-9 * np.abs(d.y).max()


def test_12_pulse_rectifier_at_theta_one_half_has_no_first_step_and_says_why():
    """The first θ = 1/2 step of the 12-pulse rectifier (h = 10 µs) has no solution: every one
    of its 4096 complementary bases fails (numpy). The circuit is passive; the message says
    that θ < 1 at this step, not the circuit, is the cause."""
    setup, system, lcs = _mode(rectifier_12pulse(periods=1))
    h = setup.h
    disc = discretise(lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, h, 0.5)
    u0 = np.array([float(sig(0.0)) for sig in setup.signals])
    u1 = np.array([float(sig(h)) for sig in setup.signals])
    xf = disc.Phi @ setup.x0 + disc.G0 @ u0 + disc.G1 @ u1
    assert _solutions(disc.M, lcs.C @ xf + lcs.F @ u1) == []
    for kernel in ("dense", "sparse"):
        res = run_setup(setup, theta=0.5, options=MoreauOptions(kernel=kernel))
        assert res.error is not None and res.error.kind == "no_solution"
        assert res.error.time == pytest.approx(h)
        text = str(res.error)
        assert "passive in this mode" in text and "Use θ = 1" in text


def test_12_pulse_rectifier_dense_and_sparse_kernels_agree_at_theta_1():
    setup = transient_setup(parse_string(rectifier_12pulse(periods=2)))
    runs = {k: run_setup(setup, options=MoreauOptions(kernel=k)) for k in ("dense", "sparse")}
    d, s = runs["dense"], runs["sparse"]
    assert d.theta == 1.0 and d.error is None and s.error is None
    assert np.array_equal(d.t, s.t)
    assert np.abs(d.y - s.y).max() <= 1e-9 * np.abs(d.y).max()
