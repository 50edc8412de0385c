"""The sparse KKT stepping's loop over a chunk of the time grid.

The counterpart of :func:`lcs.integrators.moreau.dense.grid.run_grid` for runs whose switches are
all driven by sources or controllers (their instants are grid points, applied from the schedule):
no comparator, no sliding, no latch. It shares the dense kernel's state, chunk, schedule,
store and counters (:mod:`lcs.integrators.moreau.dense.layout`), so that the integrator can hand a
grid step to the dense kernel (``STEP_FALLBACK``: pivoting found no accepted set, the dense kernel
then runs Lemke) and come back.
"""

from __future__ import annotations

import numpy as np

from lcs.bits import bit, copy_bits, equal_bits, row_equals
from lcs.jit import inline, kernel

from ..dense.layout import (
    FV_FAIL_T0,
    FV_FAIL_T1,
    FV_H,
    FV_TCUR,
    IV_EVPOS,
    IV_FAILMODE,
    IV_GSTEP,
    IV_K,
    IV_NMODES,
    IV_ODD,
    IV_OUTPOS,
    IV_SCHED,
    IV_STEPS,
    OP_SET,
    STEP_FULL,
    STEP_NEED_MODE,
    STEP_OK,
    Actives,
    Ledger,
)
from ..dense.store import find_mode, record
from .layout import NF_OUTSTATE, STEP_FALLBACK, STEP_GROW
from .step import step_body


@inline
def _store_row(net, j, key, duty, x, lam, U, ur, T, Y, pos, t):
    T[pos] = t
    if net.flags[j, NF_OUTSTATE] != 0:
        for i in range(x.shape[0]):
            Y[pos, i] = x[i]
        return
    for r in range(Y.shape[1]):
        sw = duty[r]
        if sw >= 0:
            Y[pos, r] = 1.0 if bit(key, sw) else 0.0
            continue
        v = 0.0
        for i in range(x.shape[0]):
            v += net.Cy[j, r, i] * x[i]
        for i in range(lam.shape[0]):
            v += net.Dy[j, r, i] * lam[i]
        for i in range(U.shape[1]):
            v += net.Fy[j, r, i] * U[ur, i]
        Y[pos, r] = v


@kernel
def run_kkt(net, cache, chunk, sched, state, lim, store, W, stol):
    """Advance the state over the grid chunk (from grid step ``ivars[IV_K]``) by sparse KKT
    steps through the schedule's mode changes.

    Parameters are those of :func:`lcs.integrators.moreau.dense.grid.run_grid` with the mode store
    ``net`` (:class:`~lcs.integrators.moreau.sparse.layout.NetStack`, ``ivars[IV_NMODES]`` modes),
    the factorisation cache ``cache`` (:class:`~lcs.integrators.moreau.sparse.layout.KKTCache`), its
    work space ``W`` (:class:`~lcs.integrators.moreau.sparse.step.KKTWork`) and ``stol``, the
    difference (s) within which two step lengths share factorisations (a step then has the
    factorised length, as the dense kernel's stored shortened steps).

    Returns ``STEP_OK`` (chunk done), ``STEP_NEED_MODE`` (build ``state.need``),
    ``STEP_FULL``, ``STEP_FALLBACK`` (the dense kernel takes grid step ``ivars[IV_K]``, whose
    schedule has been applied: no accepted active set, or a result that is not finite, which
    the dense kernel then reports) or ``STEP_GROW`` (a factorisation needs more room).
    """
    x, lam, key, act = state.x, state.lam, state.key, state.act
    ivars, fvars = state.ivars, state.fvars
    n = x.shape[0]
    m = lam.shape[0]
    tg = chunk.t
    N = tg.shape[0] - 1
    U0, U1 = chunk.U0, chunk.U1
    h = fvars[FV_H]
    every = lim.every
    countdown = every - ivars[IV_GSTEP] % every
    cap_out = store.T.shape[0]
    cap_ev = store.ev_t.shape[0]
    nsched = sched.k.shape[0]
    xn = np.zeros(n)
    lamn = np.zeros(m)
    tkey = np.zeros_like(key)
    # (the step's active set is act[0], its cache slot slot[0]; built once for the call)
    slot = np.full(2, -1, np.int64)
    acts = Actives(act, slot)
    led = Ledger(ivars, fvars, state.fail, lim)
    W.csync[0] = -1  # (C x computed afresh: the state may come from elsewhere)
    j = -1
    js = -1.0
    status = STEP_OK
    kk = ivars[IV_K]
    while kk < N:
        if (ivars[IV_OUTPOS] + 2 > cap_out
                or ivars[IV_EVPOS] + 2 + (nsched - ivars[IV_SCHED]) > cap_ev):
            status = STEP_FULL
            break
        ta = tg[kk]
        tb = tg[kk + 1]
        while ivars[IV_SCHED] < nsched and sched.k[ivars[IV_SCHED]] <= kk:
            sp = ivars[IV_SCHED]
            ivars[IV_SCHED] = sp + 1
            if sched.k[sp] < kk or sched.op[sp] != OP_SET:
                continue
            copy_bits(key, tkey)
            for w in range(key.shape[0]):
                tkey[w] = (tkey[w] & ~sched.a[sp, w]) | sched.b[sp, w]
            if not equal_bits(tkey, key):
                copy_bits(tkey, key)
                record(store, ivars, ta, key, -1)
        if j < 0 or not row_equals(net.key, j, key):
            j = find_mode(net.key, ivars[IV_NMODES], key)
            slot[0] = -1
            W.csync[0] = -1
            if j < 0:
                copy_bits(key, state.need)
                status = STEP_NEED_MODE
                break
        odd = chunk.odd[kk]
        s = tb - ta if odd else h
        if s != js:
            slot[0] = -1
            js = s
        # (inlined: a call would incref and decref every array of net, cache and W each step)
        st = step_body(net, cache, j, s, stol, x, U0[kk], U1[kk], acts, W, xn, lamn, led)
        if st != 0:
            fvars[FV_FAIL_T0] = ta
            fvars[FV_FAIL_T1] = tb
            ivars[IV_FAILMODE] = j
            status = STEP_GROW if st == 3 else STEP_FALLBACK
            break
        for i in range(n):
            x[i] = xn[i]
        for i in range(m):
            lam[i] = lamn[i]
        ivars[IV_STEPS] += 1
        ivars[IV_GSTEP] += 1
        if odd:
            ivars[IV_ODD] += 1
        countdown -= 1
        if countdown == 0 or chunk.force_out[kk]:
            if countdown == 0:
                countdown = every
            _store_row(net, j, key, store.duty, x, lam, U1, kk, store.T, store.Y,
                       ivars[IV_OUTPOS], tb)
            ivars[IV_OUTPOS] += 1
        fvars[FV_TCUR] = tb
        kk += 1
    ivars[IV_K] = kk
    return status

