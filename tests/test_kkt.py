"""The sparse KKT stepping (lcs.integrators.moreau.sparse): its LU and ordering, the networks the
formulation exports, one step against the θ formulas written with numpy, and whole runs against the
dense kernel (an independent implementation of the same scheme, itself checked against Siconos)."""

from __future__ import annotations

import glob

import numpy as np
import pytest

from converters import scaling
from lcs.bits import to_words, words
from lcs.integrators.moreau.dense.layout import (
    FV_LEN,
    FV_RTOL,
    FV_THETA,
    IV_LEN,
    Actives,
    Ledger,
    Limits,
)
from lcs.integrators.moreau.integrator import MoreauOptions
from lcs.integrators.moreau.sparse import integrate
from lcs.integrators.moreau.sparse.lu import (
    FACTOR_FULL,
    FACTOR_OK,
    FACTOR_SINGULAR,
    factor,
    lu_arrays,
    solve,
)
from lcs.integrators.moreau.sparse.ordering import minimum_degree
from lcs.integrators.moreau.sparse.stack import NetStackBuilder, compressed
from lcs.integrators.moreau.sparse.step import inputs_part, kkt_step, sync_c
from lcs.simulation.problem import Problem
from netlist.formulation import formulate
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import run_setup, transient_setup


def _csc(A):
    rows, cols = np.nonzero(A)
    ptr, order = compressed(cols, rows, A.shape[1])
    return ptr, rows[order].astype(np.int64), A[rows, cols][order]


def _factor(A, q=None, cap=None, pivmin=0.0):
    N = A.shape[0]
    Ap, Ai, Ax = _csc(A)
    q = np.arange(N, dtype=np.int64) if q is None else q
    cap = cap or N * N + 1
    arrs = lu_arrays(N, cap, cap)
    return factor(N, Ap, Ai, Ax, q, 0.1, pivmin, *arrs), arrs


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
def test_lu_solves_random_sparse_systems():
    rng = np.random.default_rng(3)
    worst = 0.0
    tried = 0
    for _ in range(300):
        N = int(rng.integers(1, 40))
        A = np.where(rng.random((N, N)) < 3.0 / N, rng.normal(size=(N, N)), 0.0)
        A[np.diag_indices(N)] += rng.normal(size=N) * (rng.random(N) < 0.7)
        if np.linalg.matrix_rank(A) < N:
            continue
        tried += 1
        Ap, Ai, _ = _csc(A)
        q = minimum_degree(N, Ap, Ai)
        assert sorted(q.tolist()) == list(range(N))
        st, arrs = _factor(A, q)
        assert st == FACTOR_OK
        b = rng.normal(size=N)
        x = solve(arrs[0], q, b)
        ref = np.linalg.solve(A, b)
        worst = max(worst, np.abs(x - ref).max() / (np.linalg.cond(A) * np.abs(ref).max()))
    assert tried > 100
    assert worst < 1e-14


def test_lu_reports_singular_and_full():
    st, arrs = _factor(np.array([[1.0, 2.0], [2.0, 4.0]]), pivmin=1e-13)
    assert st == FACTOR_SINGULAR
    A = np.ones((6, 6)) + np.eye(6)
    st, _ = _factor(A, cap=4)
    assert st == FACTOR_FULL


def test_minimum_degree_keeps_a_ladder_sparse():
    """A voltage multiplier's KKT matrix: the order keeps the factors within a few times the
    matrix (the natural order fills 14 times more on 100 stages)."""
    text = scaling.cockcroft_walton(30)
    system = formulate(parse_string(text))
    b = _builder(system)
    net = b.arrays()
    nz, N = net.dims[0]
    mask = to_words((1 << system.mode(()).m) - 1, words(system.mode(()).m))
    from lcs.integrators.moreau.sparse.step import assemble

    Ap = np.zeros(N + 1, np.int64)
    Ai = np.zeros(4 * b.tpl_nnz, np.int64)
    Ax = np.zeros(4 * b.tpl_nnz)
    assert assemble(net, 0, 1e-6, mask, Ap, Ai, Ax, np.ones(N), np.ones(N)) == N
    q = net.ivec[net.vtab[0, 0]:net.vtab[0, 0] + N]
    fill = {}
    for name, order in (("md", q), ("natural", np.arange(N, dtype=np.int64))):
        arrs = lu_arrays(N, N * N, N * N)
        assert factor(N, Ap, Ai, Ax[:], order, 0.1, 1e-13, *arrs) == FACTOR_OK
        fill[name] = arrs[0].Lp[N] + arrs[0].Up[N]
    assert fill["md"] < 3 * Ap[N]
    assert fill["natural"] > 3 * fill["md"]


NETLISTS = sorted(glob.glob("converters/netlists/*.cir"))


@pytest.mark.parametrize("text", [scaling.cockcroft_walton(4), scaling.interleaved_buck(3),
                                  scaling.mmc_arm(3), scaling.rectifier_6pulse(),
                                  scaling.rectifier_12pulse()] + NETLISTS)
def test_networks_reproduce_the_lcs(text):
    """Rx Y⁻¹ S and Rw Y⁻¹ S equal the formulation's A ... F in every mode (up to 8)."""
    circuit = parse_file(text) if text.endswith(".cir") else parse_string(text)
    system = formulate(circuit)
    for key in system.all_keys()[:8]:
        try:
            lcs = system.mode(key)
        except Exception:  # (degenerate modes are rejected by the formulation)
            continue
        net = system.network(key)
        assert net is not None
        for mine, ref in zip(net.dense(), (lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, lcs.F),
                             strict=True):
            scale = max(1.0, np.abs(ref).max()) if ref.size else 1.0
            assert np.abs(mine - ref).max(initial=0.0) <= 1e-12 * scale
        # the pairs said to have w = 0 identically do, in the network itself
        if net.zero_w:
            nz = net.nz
            Y = np.zeros((nz, nz))
            np.add.at(Y, (net.Y[0], net.Y[1]), net.Y[2])
            S = np.zeros((nz, net.n + net.m + net.p))
            np.add.at(S, (net.S[0], net.S[1]), net.S[2])
            Rw = np.zeros((net.m, nz))
            np.add.at(Rw, (net.Rw[0], net.Rw[1]), net.Rw[2])
            w = Rw @ np.linalg.solve(Y, S)
            assert np.abs(w[list(net.zero_w)]).max() <= 1e-9 * max(1.0, np.abs(w).max())


class _Plan:
    names: list = []
    kind = np.zeros(0, np.int64)
    flags = np.zeros(0, np.int64)
    source: list = []


def _builder(system, theta=0.5):
    prob = Problem(system, None)
    prob.control_rows = lambda *a: None
    n, m, p = len(system.states), len(system.diodes), len(system.inputs)
    b = NetStackBuilder(prob, _Plan, theta, n, m, p, n, {}, ())
    b.add(0)
    return b


RC_DIODES = """* diodes with series resistances (D != 0) on an RC ladder
V1 in 0 SIN(0 10 1k)
D1 in a DI
R1 a out 2
D2 0 a DI
C1 out 0 10u IC=0
R2 out 0 50
D3 out o2 DI
R3 o2 0 20
C2 o2 0 22u
.model DI D
.tran 1u 4m UIC
.end
"""


def _dense_step(lcs, x, u0, u1, s, theta):
    """Moreau's θ step by numpy (Siconos's EulerMoreauOSI) with its LCP by enumeration."""
    A, B, C, D, E, F = lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, lcs.F
    n, m = A.shape[0], B.shape[1]
    W = np.linalg.inv(np.eye(n) - s * theta * A)
    xf = W @ ((np.eye(n) + s * (1 - theta) * A) @ x + s * E @ ((1 - theta) * u0 + theta * u1))
    K = s * W @ B
    M = D + C @ K
    q = C @ xf + F @ u1
    for bits in range(1 << m):
        a = [i for i in range(m) if bits >> i & 1]
        lam = np.zeros(m)
        if a:
            try:
                lam[a] = np.linalg.solve(M[np.ix_(a, a)], -q[a])
            except np.linalg.LinAlgError:
                continue
        w = M @ lam + q
        if lam.min() >= -1e-12 * max(1, abs(lam).max()) and w.min() >= -1e-12 * np.abs(q).max():
            return xf + K @ lam, lam
    raise AssertionError("no LCP solution")


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("theta", [0.5, 0.75, 1.0])
@pytest.mark.parametrize("text", [RC_DIODES, scaling.cockcroft_walton(3)])
def test_one_step_equals_the_theta_formulas(text, theta):
    system = formulate(parse_string(text))
    lcs = system.mode(())
    b = _builder(system, theta)
    n, m, p = lcs.n, lcs.m, lcs.p
    from lcs.integrators.moreau.sparse.stack import cache_for

    cache = cache_for(64, b.nmax, 8 * b.tpl_nnz, words(m))
    sr = integrate.SparseRun(b, cache, 1e-5, MoreauOptions())
    W = sr.work()
    rng = np.random.default_rng(7)
    for _ in range(20):
        x = rng.normal(size=n) * 5
        u0, u1 = rng.normal(size=p) * 10, rng.normal(size=p) * 10
        s = 10 ** rng.uniform(-6, -4)
        ref_x, ref_lam = _dense_step(lcs, x, u0, u1, s, theta)
        # (a warm start: the solution's active set with one pair flipped, so that the step
        # pivots)
        start = sum(1 << i for i in range(m) if ref_lam[i] > 0) ^ (1 << int(rng.integers(m)))
        mask = to_words(start, words(m))
        acts = Actives(np.stack([mask, np.zeros_like(mask)]), np.full(2, -1, np.int64))
        fvars = np.zeros(FV_LEN)
        fvars[FV_THETA] = theta
        fvars[FV_RTOL] = 1e-11
        led = Ledger(np.zeros(IV_LEN, np.int64), fvars, np.zeros_like(mask),
                     Limits(100, -1, 1, 10, 32))
        W.csync[0] = -1
        xn, lamn = np.zeros(n), np.zeros(m)
        st = kkt_step(b.arrays(), cache, 0, s, 1e-9 * s, x, u0, u1, acts, W, xn, lamn, led)
        assert st == 0
        assert np.allclose(xn, ref_x, rtol=1e-10, atol=1e-10 * np.abs(ref_x).max())
        assert np.allclose(lamn, ref_lam, rtol=1e-9, atol=1e-9 * max(1, np.abs(ref_lam).max()))
    # C x carried by the step equals C x of the new state
    if theta < 1.0:
        carried = W.c.copy()
        sync_c(b.arrays(), 0, xn, W)
        assert np.allclose(carried, W.c, rtol=1e-9, atol=1e-9 * np.abs(W.c).max())
        assert np.allclose(W.c, lcs.C @ xn, rtol=1e-9, atol=1e-9 * np.abs(W.c).max())
    inputs_part(b.arrays(), 0, theta, u0, u1, W)
    assert np.allclose(W.fu, lcs.F @ u1)


def _runs(text, **kw):
    setup = transient_setup(parse_string(text))
    out = {}
    for kern in ("dense", "sparse"):
        out[kern] = run_setup(setup, options=MoreauOptions(kernel=kern, **kw))
    return out


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.parametrize("text", [
    scaling.cockcroft_walton(10, periods=20), scaling.interleaved_buck(4, periods=20),
    scaling.mmc_arm(4, periods=1), scaling.rectifier_6pulse(periods=2), RC_DIODES])
def test_sparse_runs_equal_dense_runs(text):
    runs = _runs(text)
    d, s = runs["dense"], runs["sparse"]
    assert d.error is None and s.error is None
    assert s.stats.kernel == "sparse" and d.stats.kernel == "dense"
    assert np.array_equal(d.t, s.t)
    assert np.abs(d.y - s.y).max() <= 1e-9 * np.abs(d.y).max()
    assert s.stats.steps == d.stats.steps


def test_theta_one_and_the_carried_cx():
    """Backward Euler, and θ = 1/2 over a long run (C x carried between its fresh
    computations)."""
    text = scaling.cockcroft_walton(6, periods=100)
    setup = transient_setup(parse_string(text))
    for theta in (1.0, 0.5):
        d = run_setup(setup, theta=theta, options=MoreauOptions(kernel="dense"))
        s = run_setup(setup, theta=theta, options=MoreauOptions(kernel="sparse"))
        assert s.error is None and s.stats.kernel == "sparse" and s.stats.dense_steps == 0
        assert np.abs(d.y - s.y).max() <= 1e-9 * np.abs(d.y).max()


SWITCHED = """* shorted and isolated diodes, and a part that floats when S3 is off
V1 in 0 SIN(0 10 1k)
R0 in i2 1
D1 i2 a DI
R1 a out 2
D2 0 a DI
S1 a 0 g 0 SW1
C1 out 0 10u IC=0
R2 out 0 50
D3 out b DI
S2 b o2 g 0 SW1
R3 o2 0 20
C2 o2 0 22u
S3 out f g2 0 SW1
R4 f h 1k
R5 h f 2k
Vg g 0 PULSE(0 1 0.3m 1n 1n 0.4m 1m)
Vg2 g2 0 PULSE(1 0 2.5m 1n 1n 10m 20m)
.model DI D
.model SW1 SW(VT=0.5 VH=0 RON=1m ROFF=1e9)
.tran 1u 4m UIC
.end
"""


def test_zero_w_pairs_and_a_mode_without_network():
    """Diodes shorted by a closed switch or in series with an open one stay inactive; when
    S3 opens, nodes f and h float (no regular network): the dense kernel takes the rest."""
    system = formulate(parse_string(SWITCHED))
    floating = system.key({"S3": False, "S1": False, "S2": False})
    assert system.network(floating) is None
    on = system.key({"S3": True, "S1": True, "S2": False})
    net = system.network(on)
    assert set(net.zero_w) == {1, 2}  # D2 shorted by S1, D3 in series with S2 off
    runs = _runs(SWITCHED)
    d, s = runs["dense"], runs["sparse"]
    assert d.error is None and s.error is None
    assert s.stats.kernel == "sparse"
    assert any("handed the run to the dense one" in note for note in s.notes)
    assert 0 < s.stats.dense_steps < s.stats.steps  # (the last 1.5 of 4 ms)
    assert np.array_equal(d.t, s.t)
    # (shortened steps of 0.5 ns where C1 and C2 share charge: a step's matrix and state
    # update are of one length)
    assert np.abs(d.y - s.y).max() <= 1e-12 * np.abs(d.y).max()


def test_steps_the_pivoting_cannot_take_go_to_the_dense_kernel():
    """With a single basis allowed, every step whose active set changes is handed to the
    dense kernel (Lemke) and the run goes on sparse: the same numbers."""
    text = scaling.cockcroft_walton(5, periods=10)
    setup = transient_setup(parse_string(text))
    d = run_setup(setup, options=MoreauOptions(kernel="dense"))
    s = run_setup(setup, options=MoreauOptions(kernel="sparse", warm_iter=1))
    assert s.stats.dense_steps > 10
    assert s.stats.kernel == "sparse"
    assert np.abs(d.y - s.y).max() <= 1e-9 * np.abs(d.y).max()


def test_a_recurring_commutation_takes_one_more_solve():
    """A multiplier's ladder commutes each half period: from the set before it, block
    pivoting uncovers the conducting diodes a pair or two per basis. Once a step has
    pivoted from a set, the set it ended in is tried first: over a second run, a pivoting
    step takes about one solve more than a step that keeps its set (1.12 here; without the
    remembered set 1.48: 997 extra solves for 675 pivoting steps), and the numbers are the
    dense kernel's."""
    from lcs.integrators.moreau.sparse.layout import C_TRIALS

    text = scaling.cockcroft_walton(10, periods=30)
    setup = transient_setup(parse_string(text))
    d = run_setup(setup, options=MoreauOptions(kernel="dense"))
    run_setup(setup, options=MoreauOptions(kernel="sparse"))
    (kept,) = integrate.kept(setup.system)
    before = int(kept.cache.counters[C_TRIALS])
    s = run_setup(setup, options=MoreauOptions(kernel="sparse"))
    solves = int(kept.cache.counters[C_TRIALS]) - before
    assert s.error is None and s.stats.kernel == "sparse" and s.stats.factorisations == 0
    assert s.stats.warm_solves > 100
    extra = solves - s.stats.steps
    assert s.stats.warm_solves <= extra <= 1.25 * s.stats.warm_solves
    assert np.abs(d.y - s.y).max() <= 1e-9 * np.abs(d.y).max()


def test_factor_storage_grows(monkeypatch):
    monkeypatch.setattr(integrate, "CAP_FACTOR", 0)
    text = scaling.cockcroft_walton(8, periods=5)
    setup = transient_setup(parse_string(text))
    d = run_setup(setup, options=MoreauOptions(kernel="dense"))
    s = run_setup(setup, options=MoreauOptions(kernel="sparse", kkt_bytes=1 << 20))
    assert s.stats.kernel == "sparse" and s.error is None
    (kept,) = integrate.kept(setup.system)
    assert kept.cache.Li.shape[1] > 64  # (from 64 entries a factor)
    # the factorisations of the caches grown out of are counted
    assert s.stats.factorisations >= int(kept.cache.counters[1])
    assert np.abs(d.y - s.y).max() <= 1e-9 * np.abs(d.y).max()


def test_without_pivoting_the_previous_set_is_still_tried():
    """warm_iter = 0, as for the dense kernel: the previous step's set, then Lemke."""
    text = scaling.cockcroft_walton(4, periods=2)
    setup = transient_setup(parse_string(text))
    s = run_setup(setup, options=MoreauOptions(kernel="sparse", warm_iter=0))
    d = run_setup(setup, options=MoreauOptions(kernel="dense", warm_iter=0))
    assert 0 < s.stats.dense_steps < s.stats.steps / 4
    assert np.abs(d.y - s.y).max() <= 1e-9 * np.abs(d.y).max()


def test_a_failure_in_a_handed_step_names_its_mode(monkeypatch):
    """A grid step the sparse kernel hands to the dense one fails there: the error names
    the mode of the dense stack's id (the two kernels number modes differently)."""
    import lcs.integrators.moreau.integrator as moreau
    from lcs.bits import from_words
    from lcs.integrators.moreau.dense.layout import (
        FV_FAIL_T0,
        FV_FAIL_T1,
        IV_FAILMODE,
        IV_NMODES,
        STEP_NONFINITE,
    )

    real = moreau.run_grid

    def failing(stack, sws, chunk, sched, state, lim, store):
        st = real(stack, sws, chunk, sched, state, lim, store)
        key = from_words(state.key)
        rows = [i for i in range(int(state.ivars[IV_NMODES]))
                if from_words(stack.key[i]) == key]
        if st == 0 and chunk.t.shape[0] == 2 and key == 0b110 and rows:
            # (a handed step in the mode S2 and S3 on, built in the dense stack)
            state.ivars[IV_FAILMODE] = rows[0]
            state.fvars[FV_FAIL_T0], state.fvars[FV_FAIL_T1] = chunk.t[0], chunk.t[1]
            return STEP_NONFINITE
        return st

    monkeypatch.setattr(moreau, "run_grid", failing)
    setup = transient_setup(parse_string(scaling.interleaved_buck(3, periods=2)))
    res = run_setup(setup, options=MoreauOptions(kernel="sparse", warm_iter=1))
    assert res.error is not None
    assert "S1 off, S2 on, S3 on" in str(res.error)


def test_auto_picks_the_sparse_kernel_for_a_large_multiplier_only():
    big = run_setup(transient_setup(parse_string(scaling.cockcroft_walton(100, periods=1))))
    assert big.stats.kernel == "sparse"
    small = run_setup(transient_setup(parse_string(scaling.cockcroft_walton(5, periods=1))))
    assert small.stats.kernel == "dense"
    buck = run_setup(transient_setup(parse_string(scaling.interleaved_buck(16, periods=1))))
    assert buck.stats.kernel == "dense"


def test_kernel_option_is_checked():
    with pytest.raises(ValueError, match="kernel must be"):
        run_setup(transient_setup(parse_string(RC_DIODES)),
                  options=MoreauOptions(kernel="fast"))
