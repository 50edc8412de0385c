"""Compile (once, into numba's on-disk cache) or load every specialisation of the Moreau
kernels, so that no command compiles later.

The kernels' argument types do not depend on the circuit (every array is float64 or int64,
whatever n, m, p), so a few tiny runs reach every signature a run can use:

* a single LCS over a short run -- :func:`~lcs.integrators.moreau.dense.run_grid`, Lemke and
  enumeration, the source-switching and grid planners;
* the same LCS over a long run with no comparator -- the plain loop
  (:func:`~lcs.integrators.moreau.dense.grid.plain_steps`, what a source-driven PWM converter
  takes);
* a switch driven by a hysteretic comparator -- located switchings, the instant search;
* the same switch without hysteresis on an attractive surface -- Filippov sliding;
* the same switch sampled (explicit method);
* a switch driven by a PWM source (its instants planned before stepping);
* a circuit's network stepped by the sparse KKT kernel (:mod:`lcs.integrators.moreau.sparse`).

``tests/test_warmup.py`` checks, in fresh processes, that after :func:`warm_up` the README's
commands find every kernel signature they use in the cache.
"""

from __future__ import annotations

import time

import numpy as np

from ..model import LCS, ComplementarityPair, ModeModel, OutputMap, SwitchControl, SwitchedLCS
from ..network import NetworkRealisation
from ..signals import Dc, Pulse
from ..sparse_lu import lu_factor, lu_rcond, lu_solve


def _diode_rc() -> LCS:
    """A capacitor charged from a 1 V source through an ideal diode: ``x' = -x + λ``,
    ``w = -x + λ + u`` (one state, one pair, one input)."""
    one = np.ones((1, 1))
    return LCS(A=-one, B=one, C=-one, D=one, E=0 * one, F=one, states=("x",),
               pairs=(ComplementarityPair("D"),), inputs=("u",))


def _gated_rc() -> SwitchedLCS:
    """``x' = -x + s`` with a switch ``s`` driven by the input (a PWM source): its instants
    are computed before stepping (the source-switching planner)."""

    def builder(mode):
        on = 1.0 if mode[0] else 0.0
        one = np.ones((1, 1))
        lcs = LCS(A=-one, B=one, C=-one, D=one, E=np.array([[on, 0.0]]),
                  F=np.zeros((1, 2)), states=("x",), pairs=(ComplementarityPair("D"),),
                  inputs=("one", "gate"))

        def outputs(names):
            rows = {"c": (0.0, [0.0, 1.0]), "x": (1.0, [0.0, 0.0])}
            Cy = np.array([[rows[nm][0]] for nm in names])
            Fy = np.array([rows[nm][1] for nm in names])
            return OutputMap(tuple(names), Cy, np.zeros((len(names), 1)), Fy)

        return ModeModel(lcs, outputs)

    switch = SwitchControl("S", "c", vt=0.5, vh=0.0)
    return SwitchedLCS([switch], ("x",), ("one", "gate"), ("D",), builder)


def _relay_system(vh: float, explicit: bool = False) -> SwitchedLCS:
    """``x' = -x + s u`` with a switch ``s`` on while ``x < 0.5`` (its control is ``-x``,
    threshold -0.5, hysteresis ``vh``), plus the diode pair of :func:`_diode_rc`: with
    hysteresis a relaxation oscillator, without it a sliding mode on ``x = 0.5``."""

    def builder(mode):
        on = 1.0 if mode[0] else 0.0
        one = np.ones((1, 1))
        lcs = LCS(A=-one, B=0 * one, C=-one, D=one, E=on * one, F=0 * one, states=("x",),
                  pairs=(ComplementarityPair("D"),), inputs=("u",))

        def outputs(names):
            rows = {"c": -1.0, "x": 1.0}
            Cy = np.array([[rows[nm]] for nm in names])
            return OutputMap(tuple(names), Cy, np.zeros((len(names), 1)),
                             np.zeros((len(names), 1)))

        return ModeModel(lcs, outputs)

    options = {"explicit": 1} if explicit else {}
    switch = SwitchControl("S", "c", vt=-0.5, vh=vh, options=options)
    return SwitchedLCS([switch], ("x",), ("u",), ("D",), builder)


def _diode_rc_network() -> SwitchedLCS:
    """:func:`_diode_rc`'s circuit with its network (:class:`~lcs.network.NetworkRealisation`:
    nodes a, b, the source's and the capacitor's currents; 1 Ω, 1 F), for the sparse KKT
    kernel: the same LCS ``x' = -x + λ``, ``w = x - u``."""
    i64 = np.int64

    def coo(r, c, v):
        return np.array(r, i64), np.array(c, i64), np.array(v, dtype=float)

    net = NetworkRealisation(
        nz=4, n=1, m=1, p=1,
        Y=coo([0, 1, 1, 2, 3], [2, 1, 3, 0, 1], [1.0, 1.0, 1.0, 1.0, 1.0]),
        S=coo([0, 1, 2, 3], [1, 1, 2, 0], [-1.0, 1.0, 1.0, 1.0]),
        Rx=coo([0], [3], [1.0]), Rw=coo([0, 0], [0, 1], [-1.0, 1.0]))
    A, B, C, D, E, F = net.dense()
    lcs = LCS(A=A, B=B, C=C, D=D, E=E, F=F, states=("x",), pairs=(ComplementarityPair("D"),),
              inputs=("u",))

    def builder(mode):
        def outputs(names):
            return OutputMap(tuple(names), np.ones((len(names), 1)), np.zeros((len(names), 1)),
                             np.zeros((len(names), 1)))

        return ModeModel(lcs, outputs, network=net)

    return SwitchedLCS([], ("x",), ("u",), ("D",), builder)


PARTS = ("dense", "sparse")


def warm_up(parts: tuple[str, ...] = PARTS, parallel: bool = False) -> float:
    """Load (or, the first time, compile) every Moreau kernel specialisation; returns the
    time it took, s.

    Parameters
    ----------
    parts : tuple of str
        Which kernels: ``"dense"`` (the dense kernel's grid loop and steps, the LCP solvers,
        the planners) and ``"sparse"`` (the sparse KKT kernel and the formulation's sparse LU).
    parallel : bool
        Compile the sparse part in a child process while this one compiles the dense part,
        where the machine has more than one processor: the two share no kernel that takes
        long to compile (the sparse part is about a tenth of the whole), so on two cores the
        wall time from an empty cache is the dense part's alone, and this process then loads
        the sparse part from the cache. numba's cache is written per function by an atomic
        rename, so the two processes may write it side by side.
    """
    t0 = time.perf_counter()
    child = None
    if parallel and "sparse" in parts and "dense" in parts and _cpus() > 1:
        import subprocess
        import sys

        child = subprocess.Popen(
            [sys.executable, "-c",
             "from lcs.build.warmup import warm_up; warm_up(parts=('sparse',))"])
    if "dense" in parts:
        _warm_up_dense()
    if child is not None:
        # (then loaded here from the cache the child wrote, in a second or two, so that this
        # process has every kernel, as the ahead-of-time link needs; where the child failed,
        # its traceback is on stderr and the part compiles here)
        child.wait()
    if "sparse" in parts:
        _warm_up_sparse()
    return time.perf_counter() - t0


def _cpus() -> int:
    import os

    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # (not on every platform)
        return os.cpu_count() or 1


def _warm_up_dense() -> None:
    from ..integrators.moreau.integrator import simulate, simulate_lcs

    lcs = _diode_rc()
    simulate_lcs(lcs, [Dc(1.0)], [0.0], 1e-3, 1e-4)
    simulate_lcs(lcs, [Pulse(0.0, 1.0, 0.0, 1e-6, 1e-6, 1e-4, 2e-4)], [0.0], 2e-3, 1e-5)
    gate = Pulse(0.0, 1.0, 0.0, 1e-6, 1e-6, 4e-5, 1e-4)
    simulate(_gated_rc(), [Dc(1.0), gate], [0.0], 2e-3, 1e-6)
    for vh, explicit in ((0.1, False), (0.0, False), (0.1, True)):
        simulate(_relay_system(vh, explicit), [Dc(1.0)], [0.0], 5e-2, 1e-3)


def _warm_up_sparse() -> None:
    from ..integrators.moreau.integrator import MoreauOptions, simulate

    # The sparse KKT kernel (lcs.integrators.moreau.sparse): its grid loop, factorisations,
    # ordering, and the factorisation "auto" makes to estimate its cost.
    from ..integrators.moreau.sparse.integrate import kept

    network = _diode_rc_network()
    simulate(network, [Pulse(0.0, 1.0, 0.0, 1e-4, 1e-4, 2e-4, 5e-4)], [0.0], 2e-3, 1e-5,
             options=MoreauOptions(kernel="sparse"))
    for sparse in kept(network):
        sparse.factor_entries(0, 1)
    # The sparse LU of the formulation (netlist.mna_solve).
    lu = lu_factor(2, np.array([0, 1, 1]), np.array([0, 0, 1]), np.array([2.0, 1.0, 3.0]))
    lu_rcond(lu, 3.0)
    lu_solve(lu, np.eye(2))
