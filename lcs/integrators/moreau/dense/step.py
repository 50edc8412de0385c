"""One θ step of one mode: the free state, the step's LCP, the impulse.

The arithmetic of a step is written once here and inlined (``inline="always"``) wherever a
loop takes a step, so that the hot loops pay no call overhead:

* :func:`regular_cached_step` -- a regular step (length h, stored matrices) by the cached
  factorisation of the previous active set: the fast path of almost every step;
* :func:`odd_basis_step` -- a step of another length by a direct solve of the previous
  active set; :func:`odd_cached_step` the same with the discretisation of that length
  stored (shortened steps at recurring offsets from the grid);
* :func:`mode_step` -- the general step: the two above, then Lemke and enumeration
  (:func:`lcs.lcp.compiled.solve_pivoting`), and the uniqueness check of a pivoting solution
  (none in a mode whose next state is proven unique whatever λ the step takes).
"""

from __future__ import annotations

from lcs.bits import copy_bits
from lcs.jit import inline, kernel
from lcs.lcp.compiled import (
    distinct_images,
    lookup,
    negative_q_mask,
    solve_basis,
    solve_cached,
    solve_pivoting,
    solve_warm,
    solve_warm_direct,
)

from .discretise import COLUMN_MIN, discretise_nb, free_odd, free_regular, free_state
from .layout import (
    FV_FEAS_TOL,
    FV_H,
    FV_LEX_TOL,
    FV_PIVOT_TOL,
    FV_RTOL,
    FV_THETA,
    FV_UNIQ_TOL,
    IV_FALLBACKS,
    IV_LEMKE,
    IV_ODDHIT,
    IV_ODDMISS,
    IV_PIVOTS,
    IV_UNIQ,
    IV_WARM,
    MF_FAST,
    MF_IMAGE,
    MF_UNIQ,
    STEP_LCP_FAILED,
    STEP_NONFINITE,
    STEP_NONUNIQUE,
    STEP_OK,
)

# What :func:`odd_cached_step` did: took the step, left it to :func:`mode_step`, or left it to
# :func:`odd_basis_step` (stored lengths that do not recur, or no store).
ODD_NOT = 0
ODD_TAKEN = 1
ODD_BASIS = 2


@inline
def scatter_active(idx, j, slot, na, za, lamn):
    """``lamn`` = λ with the cached active set's ``λ_a`` (``za[:na]``, in the order
    ``idx[j, slot, :na]``) and zeros elsewhere."""
    for i in range(lamn.shape[0]):
        lamn[i] = 0.0
    for jj in range(na):
        lamn[idx[j, slot, jj]] = za[jj]


@inline
def impulse_cached(xf, K, j, sets, slot, na, za, lamn, xn):
    """``λ`` from the cached active set's ``λ_a`` (``za[:na]``) into ``lamn``, and
    ``xn = xf + K[j] λ`` over the active pairs only. Returns False when ``xn`` is not
    finite."""
    n = xf.shape[0]
    idx = sets.idx
    scatter_active(idx, j, slot, na, za, lamn)
    chk = 0.0
    for i in range(n):
        v = xf[i]
        for jj in range(na):
            v += K[j, i, idx[j, slot, jj]] * za[jj]
        xn[i] = v
        chk += v
    return chk - chk == 0.0


@inline
def impulse_cached_t(xf, K, KT, j, sets, slot, na, za, lamn, xn):
    """:func:`impulse_cached`, with the transposes ``KT`` of the stored ``K`` a column at a
    time from :data:`~lcs.integrators.moreau.dense.discretise.COLUMN_MIN` states on (see
    :class:`~lcs.integrators.moreau.dense.layout.ModeArrays`): the same numbers."""
    if xf.shape[0] < COLUMN_MIN:
        return impulse_cached(xf, K, j, sets, slot, na, za, lamn, xn)
    return impulse_columns(xf, KT, j, sets, slot, na, za, lamn, xn)


@inline
def impulse_kt(xf, KT, j, sets, slot, na, za, lamn, xn):
    """:func:`impulse_cached` from the transposes ``KT`` alone (the stored shortened steps
    keep ``K`` transposed): row by row below
    :data:`~lcs.integrators.moreau.dense.discretise.COLUMN_MIN` states, a column at a time from
    there; the same numbers either way."""
    n = xf.shape[0]
    if n >= COLUMN_MIN:
        return impulse_columns(xf, KT, j, sets, slot, na, za, lamn, xn)
    idx = sets.idx
    scatter_active(idx, j, slot, na, za, lamn)
    chk = 0.0
    for i in range(n):
        v = xf[i]
        for jj in range(na):
            v += KT[j, idx[j, slot, jj], i] * za[jj]
        xn[i] = v
        chk += v
    return chk - chk == 0.0


@inline
def impulse_columns(xf, KT, j, sets, slot, na, za, lamn, xn):
    """``xn = xf + K[j] λ`` over the active pairs, a column of ``KT[j]`` at a time."""
    n = xf.shape[0]
    idx = sets.idx
    scatter_active(idx, j, slot, na, za, lamn)
    for i in range(n):
        xn[i] = xf[i]
    for jj in range(na):
        c = idx[j, slot, jj]
        z = za[jj]
        for i in range(n):
            xn[i] += KT[j, c, i] * z
    chk = 0.0
    for i in range(n):
        chk += xn[i]
    return chk - chk == 0.0


@inline
def impulse_dense(xf, K, lamn, xn):
    """``xn = xf + K λ``. Returns False when ``xn`` or ``λ`` is not finite."""
    n = xf.shape[0]
    m = lamn.shape[0]
    chk = 0.0
    for i in range(n):
        v = xf[i]
        for jj in range(m):
            v += K[i, jj] * lamn[jj]
        xn[i] = v
        chk += v
    for i in range(m):
        chk += lamn[i]
    return chk - chk == 0.0


@inline
def regular_cached_step(stack, j, x, U0, U1, kk, slot, W, xn, lamn, rtol):
    """A regular step of mode ``j`` of ``stack`` from ``x`` (inputs ``U0[kk]`` to
    ``U1[kk]``) into ``xn``, ``lamn`` by the active set of cache ``slot``
    (:func:`lcs.lcp.compiled.lookup`: the caller looks it up, since a call inside an inlined
    function costs reference counting on every step).

    Returns False when the step is not taken this way (active set not accepted, singular, or a
    non-finite result); :func:`mode_step` then decides.
    """
    mats = stack.mats
    if not free_regular(stack, j, x, U0, U1, kk, W):
        return False
    if W.q.shape[0] == 0:
        for i in range(x.shape[0]):
            xn[i] = W.xf[i]
        return True
    na = solve_cached(mats.M, mats.MT, W.q.shape[0] >= COLUMN_MIN, j, W.q, stack.sets, slot,
                      W.lcp.za, rtol, W.lcp.wv, W.lcp.ws)
    if na < 0:
        return False
    return impulse_cached_t(W.xf, mats.K, mats.KT, j, stack.sets, slot, na, W.lcp.za, lamn,
                            xn)


@inline
def odd_basis_step(stack, j, s, theta, x, u0, u1, mask, W, xn, lamn, rtol):
    """A step of length ``s`` (discretised on the fly) of mode ``j`` by the active set
    ``mask``; False when not taken this way."""
    if not free_odd(stack.mats, stack.inp, j, s, theta, x, u0, u1, W.xf, W.q, W.Ko, W.Mo,
                    W.augn):
        return False
    if W.q.shape[0] > 0 and not solve_basis(W.Mo, W.q, mask, W.lcp, lamn, rtol):
        return False
    return impulse_dense(W.xf, W.Ko, lamn, xn)


@inline
def odd_cached_step(stack, j, s, x, u0, u1, mask, slots, W, xn, lamn, led):
    """A shortened step of length ``s`` of mode ``j`` by the active set ``mask``, with the
    discretisation of that length and the factorisations of its active sets stored in
    ``stack.odd`` (made on the first step of a length within 1e-9 h of it); when the set is
    not accepted, by block principal pivoting from it through the same store (``mask`` is
    then updated and ``slots[0]`` forgotten): a PWM edge changes the same pairs at the same
    offset every period, so the new set is factorised once. Falls back to
    :func:`odd_basis_step` once stored lengths do not recur (more evictions than hits after
    64 evictions). h, θ, the acceptance tolerance and the limits are those of ``led``
    (:class:`~lcs.integrators.moreau.dense.layout.Ledger`), whose ``ivars`` count the stored
    lengths' hits and misses.

    Returns :data:`ODD_TAKEN`, :data:`ODD_BASIS` (take :func:`odd_basis_step` instead: the
    caller does, so that its code is inlined once) or :data:`ODD_NOT` (not taken this way:
    :func:`mode_step` decides, Lemke, uniqueness)."""
    ivars = led.ivars
    fvars = led.fvars
    lim = led.lim
    h = fvars[FV_H]
    theta = fvars[FV_THETA]
    rtol = fvars[FV_RTOL]
    odd = stack.odd
    mats = stack.mats
    nslots = odd.s.shape[1]
    if nslots == 0:
        return ODD_BASIS
    n = x.shape[0]
    slot = -1
    tol = 1e-9 * h
    for sl in range(nslots):
        if abs(odd.s[j, sl] - s) <= tol:
            slot = sl
            break
    if slot < 0:
        # Evictions (misses on a mode whose slots are all in use) mean lengths that do not
        # recur, or more of them than the slots: then stop storing (the counters[0] entry of
        # the odd caches is free, see OddSteps).
        evictions = odd.counters[0]
        if evictions > 64 and evictions > ivars[IV_ODDHIT]:
            return ODD_BASIS
        slot = odd.next[j]
        odd.next[j] = (slot + 1) % nslots
        if odd.s[j, slot] >= 0.0:
            odd.counters[0] = evictions + 1
        jj = j * nslots + slot
        odd.s[j, slot] = -1.0
        for k in range(odd.sets.na.shape[1]):
            odd.sets.na[jj, k] = -2
        Ko = W.Ko
        if not discretise_nb(mats.A[j], mats.B[j], mats.C[j], mats.D[j], mats.E[j], s, theta,
                             odd.Phi[jj], odd.G0[jj], odd.G1[jj], Ko, odd.M[jj]):
            return ODD_NOT
        if n >= COLUMN_MIN:
            transpose_square(odd.Phi[jj])
        KT = odd.KT[jj]
        for i in range(n):
            for c in range(Ko.shape[1]):
                KT[c, i] = Ko[i, c]
        odd.s[j, slot] = s
        ivars[IV_ODDMISS] += 1
    else:
        ivars[IV_ODDHIT] += 1
    jj = j * nslots + slot
    if not odd_free(stack, j, jj, x, u0, u1, W):
        return ODD_NOT
    xf = W.xf
    q = W.q
    m = q.shape[0]
    if m == 0:
        for i in range(n):
            xn[i] = xf[i]
        return ODD_TAKEN
    so = lookup(odd.M, jj, mask, odd.sets, odd.counters)
    na = solve_cached(odd.M, odd.M, False, jj, q, odd.sets, so, W.lcp.za, rtol, W.lcp.wv,
                      W.lcp.ws)
    if na < 0:
        # A switching changes the active set: pivot from the previous one here, through the
        # stored factorisations, rather than discretise again in mode_step (unless its
        # solutions must be checked for uniqueness, which mode_step does).
        if lim.warm_iter <= 0 or m <= stack.flags[j, MF_UNIQ]:
            return ODD_NOT
        copy_bits(mask, W.lcp.mask)
        ivars[IV_WARM] += 1
        so, na = solve_warm(odd.M, odd.M, False, jj, q, W.lcp.mask, odd.sets, odd.counters,
                            rtol, lim.warm_iter, W.lcp)
        if so < 0:
            return ODD_NOT
        copy_bits(W.lcp.mask, mask)
        slots[0] = -1
    # (one impulse for both ways: its code is inlined once)
    if impulse_kt(xf, odd.KT, jj, odd.sets, so, na, W.lcp.za, lamn, xn):
        return ODD_TAKEN
    return ODD_NOT


@inline
def transpose_square(a):
    """Transpose the square matrix ``a`` in place."""
    for i in range(a.shape[0]):
        for k in range(i + 1, a.shape[0]):
            t = a[i, k]
            a[i, k] = a[k, i]
            a[k, i] = t


@inline
def odd_free(stack, j, jj, x, u0, u1, W):
    """Free state ``W.xf`` and ``W.q`` of a shortened step of mode ``j`` from the stored
    discretisation ``jj`` of :class:`~lcs.integrators.moreau.dense.layout.OddSteps` (its ``Phi``
    holds the row form below :data:`~lcs.integrators.moreau.dense.discretise.COLUMN_MIN` states, the
    transpose from there), inputs ``u0`` to ``u1``:
    :func:`~lcs.integrators.moreau.dense.discretise.free_state`. Returns False when they are not
    finite."""
    p = u0.shape[0]
    odd = stack.odd
    return free_state(odd.Phi, odd.Phi, odd.G0, odd.G1, jj, False, stack, j, x,
                      u0.reshape((1, p)), u1.reshape((1, p)), 0, W)


@kernel
def mode_step(stack, j, step, x, io, acts, ai, W, xn, lamn, led):
    """One θ step of mode ``j`` of ``stack`` from ``x`` into ``xn``, ``lamn``.

    ``step`` (:class:`~lcs.integrators.moreau.dense.layout.Step`): its length ``s``; a
    ``regular`` step (length h from a grid point) uses the stored matrices and the inputs
    ``U0[kk]``, ``U1[kk]`` of ``io`` (:class:`~lcs.integrators.moreau.dense.layout.Inputs`),
    others are discretised for ``s`` with inputs ``io.u0`` to ``io.u1``. ``acts.act[ai]`` is
    the active set (bitset) to try first and ``acts.slots[ai]`` its cache slot (-1: unknown);
    both are updated. With ``step.commit``, a pivoting solution is checked for a unique next
    state, unless the mode's flag ``MF_IMAGE`` says that every solution gives the same one
    (:mod:`lcs.theory.step_uniqueness`: then any λ will do). On failure, ``led.fail`` receives
    the pairs involved. Returns a ``STEP_*`` status.
    """
    s = step.s
    regular = step.regular
    commit = step.commit
    u0 = io.u0
    u1 = io.u1
    kk = io.kk
    U0 = io.U0
    U1 = io.U1
    act = acts.act
    slots = acts.slots
    fail = led.fail
    ivars = led.ivars
    fvars = led.fvars
    lim = led.lim
    theta = fvars[FV_THETA]
    mats = stack.mats
    fast = stack.flags[j, MF_FAST] != 0
    if regular:
        finite = free_regular(stack, j, x, U0, U1, kk, W)
        Kk = mats.K[j]
        Mk = mats.M[j]
    else:
        finite = free_odd(mats, stack.inp, j, s, theta, x, u0, u1, W.xf, W.q, W.Ko, W.Mo,
                          W.augn)
        Kk = W.Ko
        Mk = W.Mo
    if not finite:
        return STEP_NONFINITE
    xf = W.xf
    q = W.q
    n = x.shape[0]
    m = q.shape[0]
    if m == 0:
        for i in range(n):
            xn[i] = xf[i]
        return STEP_OK
    rtol = fvars[FV_RTOL]
    mask = act[ai]
    check = commit and m <= stack.flags[j, MF_UNIQ] and stack.flags[j, MF_IMAGE] == 0
    if regular and fast:
        slot = slots[ai]
        if slot < 0:
            slot = lookup(mats.M, j, mask, stack.sets, ivars)
            slots[ai] = slot
        na = solve_cached(mats.M, mats.MT, q.shape[0] >= COLUMN_MIN, j, q, stack.sets, slot,
                          W.lcp.za, rtol, W.lcp.wv, W.lcp.ws)
        if na >= 0:
            if impulse_cached_t(xf, mats.K, mats.KT, j, stack.sets, slot, na, W.lcp.za, lamn,
                                xn):
                return STEP_OK
            return STEP_NONFINITE
        if lim.warm_iter > 0:
            slot, na = solve_warm(mats.M, mats.MT, m >= COLUMN_MIN, j, q, mask, stack.sets,
                                  ivars, rtol, lim.warm_iter, W.lcp)
            ivars[IV_WARM] += 1
            if slot >= 0:
                slots[ai] = slot
                if not impulse_cached_t(xf, mats.K, mats.KT, j, stack.sets, slot, na, W.lcp.za,
                                        lamn, xn):
                    return STEP_NONFINITE
                if check:
                    ivars[IV_UNIQ] += 1
                    if distinct_images(Mk, q, Kk, xf, lamn, fvars[FV_UNIQ_TOL], 1e-9,
                                       W.lcp.w, W.lcp.aug, W.lcp.mask, fail):
                        return STEP_NONUNIQUE
                return STEP_OK
            slots[ai] = -1
    elif fast:
        if solve_basis(Mk, q, mask, W.lcp, lamn, rtol):
            if impulse_dense(xf, Kk, lamn, xn):
                return STEP_OK
            return STEP_NONFINITE
        if lim.warm_iter > 0:
            copy_bits(mask, W.lcp.mask)
            ivars[IV_WARM] += 1
            if solve_warm_direct(Mk, q, W.lcp.mask, W.lcp, lamn, rtol, lim.warm_iter,
                                 W.lcp.basis):
                if not impulse_dense(xf, Kk, lamn, xn):
                    return STEP_NONFINITE
                if check:
                    ivars[IV_UNIQ] += 1
                    if distinct_images(Mk, q, Kk, xf, lamn, fvars[FV_UNIQ_TOL], 1e-9,
                                       W.lcp.w, W.lcp.aug, fail, fail):
                        return STEP_NONUNIQUE
                copy_bits(W.lcp.mask, mask)
                slots[ai] = -1
                return STEP_OK
    new = W.lcp.mask
    ok, piv, lstat = solve_pivoting(Mk, q, W.lcp, lim.max_piv, fvars[FV_PIVOT_TOL],
                                    fvars[FV_LEX_TOL], fvars[FV_FEAS_TOL], lim.enum_max_m,
                                    lamn, new)
    ivars[IV_FALLBACKS] += 1
    ivars[IV_PIVOTS] += piv
    if not ok:
        ivars[IV_LEMKE] = lstat
        negative_q_mask(q, fail)
        return STEP_LCP_FAILED
    copy_bits(new, mask)
    if check:
        ivars[IV_UNIQ] += 1
        if distinct_images(Mk, q, Kk, xf, lamn, fvars[FV_UNIQ_TOL], 1e-9, W.lcp.w, W.lcp.aug,
                           new, fail):
            return STEP_NONUNIQUE
    if regular and fast:
        slots[ai] = lookup(mats.M, j, mask, stack.sets, ivars)
    else:
        slots[ai] = -1
    if impulse_dense(xf, Kk, lamn, xn):
        return STEP_OK
    return STEP_NONFINITE
