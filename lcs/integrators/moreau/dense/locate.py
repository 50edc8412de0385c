"""Location of the first comparator crossing inside a step (switching instants to O(h²)).

The crossing functions are evaluated along the numerical solution: each trial is a θ step of
the trial length ``s1`` from the start of the step (in both modes while a switch slides), so
the instant is as accurate as the states. First guess: the root of the cubic Hermite
interpolant of each crossing function (values and rates at both ends), the earliest one; then
secant steps inside the bracket, with bisection when the bracket has not halved in three
trials; stop when ``|max g|`` is round-off or the bracket is shorter than ``FV_ROOT_TOL·h``.
"""

from __future__ import annotations

import numpy as np

from lcs.bits import copy_row
from lcs.jit import inline, kernel

from .comparators import control_rates, crossing, hermite_root
from .layout import (
    FV_H,
    FV_ROOT_TOL,
    IV_ROOTEVALS,
    STEP_OK,
    Actives,
    Blend,
    Crossings,
    Ends,
    Inputs,
    Step,
)
from .sliding import advance


@inline
def u_interp(chunk, kk, tau, out):
    """Inputs at the fraction ``tau`` of grid step ``kk``: linear between the step ends (exact
    for piecewise-linear sources), or quadratic through the midpoint values ``chunk.Um`` when
    given (some source is not piecewise linear)."""
    U0 = chunk.U0
    Um = chunk.Um
    U1 = chunk.U1
    if Um.shape[0] == 0:
        for i in range(out.shape[0]):
            out[i] = U0[kk, i] + (U1[kk, i] - U0[kk, i]) * tau
    else:
        for i in range(out.shape[0]):
            a = U0[kk, i]
            b = Um[kk, i]
            c = U1[kk, i]
            out[i] = a + tau * (-3.0 * a + 4.0 * b - c) + tau * tau * (2.0 * a - 4.0 * b + 2.0 * c)


@kernel
def locate(stack, modes, step, io, acts, led, cross, full, dfull, W, S, chunk):
    """Locate the first comparator crossing inside the step ``step`` (``[ta, ta + s]``, in
    the modes ``modes``) of grid step ``io.kk`` (which starts at the fraction ``io.tau`` of
    that grid step of ``chunk``, inputs ``io.u0`` there and ``io.u1`` at its end).

    On entry ``cross.g``/``cross.gt`` hold the crossing functions at the end of the full step
    (some ``g > 0``), ``full`` (:class:`~lcs.integrators.moreau.dense.layout.Ends`) its start
    and result and ``dfull`` its fraction in the toggled mode, and ``acts`` the active sets at
    the start. Returns ``(status, s_star, d_star)``; the state at the instant is in ``S.xs,
    S.lams, S.lamas``, the crossing functions there in ``cross.g``/``cross.gt``, and ``acts``
    holds the active sets of the step that ends there.
    """
    j = modes.j
    ja = modes.ja
    slide = modes.sw
    ta = step.ta
    s = step.s
    x = full.x
    lam = full.lam
    xfull = full.xn
    lamfull = full.lamn
    lamafull = full.lama
    ua = io.u0
    ub = io.u1
    kk = io.kk
    tau_a = io.tau
    act = acts.act
    slots = acts.slots
    ivars = led.ivars
    fvars = led.fvars
    sws = cross.sws
    key = cross.key
    c = cross.c
    cs = cross.cs
    g = cross.g
    gt = cross.gt
    k = g.shape[0]
    n = x.shape[0]
    m = lam.shape[0]
    p = ua.shape[0]
    h = fvars[FV_H]
    stol = max(fvars[FV_ROOT_TOL] * h, 8.9e-16 * abs(ta + s))
    act_t = S.act
    slots_t = S.slots
    # The trial steps: from the same start, inputs up to the trial instant's S.ut, active sets
    # and end states in S.
    io_t = Inputs(ua, S.ut, io.U0, io.U1, kk, tau_a)
    acts_t = Actives(act_t, slots_t)
    trial = Ends(x, lam, S.xt, S.lamt, S.xat, S.lamat, S.sg)
    # Crossing functions at the start (mode j; λ of the previous step, an estimate).
    mats = stack.mats
    Ga = crossing(mats, Blend(j, ja, slide, 0.0), Crossings(sws, key, c, cs, S.ga, S.gta), x,
                  lam, lam, ua)
    for i in range(p):
        S.udot[i] = (ub[i] - ua[i]) / s
    control_rates(mats, j, x, lam, ua, S.udot, S.rate_a, S.xdot)
    control_rates(mats, j, xfull, lamfull, ub, S.udot, S.rate_b, S.xdot)
    Gb = -np.inf
    for i in range(k):
        S.g_hi[i] = g[i]
        S.gt_hi[i] = gt[i]
        if g[i] > Gb:
            Gb = g[i]
    for i in range(n):
        S.xs[i] = xfull[i]
    for i in range(m):
        S.lams[i] = lamfull[i]
        S.lamas[i] = lamafull[i]
    d_hi = dfull
    lo, glo = 0.0, min(Ga, 0.0)
    hi, ghi = s, Gb
    tau = 1.0
    for i in range(k):
        if g[i] > 0.0:
            sgn = -1.0 if (key >> i) & 1 else 1.0
            gai = min(S.ga[i], 0.0) if S.ga[i] != -np.inf else 0.0
            ti = hermite_root(gai, s * sgn * S.rate_a[i], g[i], s * sgn * S.rate_b[i])
            if ti < tau:
                tau = ti
    s1 = tau * s
    if not (lo < s1 < hi):
        s1 = lo + (hi - lo) * (-glo) / (ghi - glo) if ghi != glo else 0.5 * (lo + hi)
    if s1 < stol:
        s1 = stol
    sp, gp = hi, ghi
    width_ref = hi - lo
    use_last = False
    d1 = 0.0
    for it in range(60):
        if s1 >= hi:
            s1 = 0.5 * (lo + hi)
        u_interp(chunk, kk, tau_a + (1.0 - tau_a) * (s1 / s), S.ut)
        for r in range(2):
            copy_row(act, r, act_t, r)
            slots_t[r] = -1
        st, d1 = advance(stack, modes, Step(ta, s1, False, False), io_t, acts_t, W, trial,
                         led)
        ivars[IV_ROOTEVALS] += 1
        if st != STEP_OK:
            return st, s1, 0.0
        G1 = crossing(mats, Blend(j, ja, slide, d1), cross, S.xt, S.lamt, S.lamat, S.ut)
        gtol = 0.0
        for i in range(k):
            if gt[i] > gtol:
                gtol = gt[i]
        if G1 > 0.0:
            hi, ghi = s1, G1
            for i in range(k):
                S.g_hi[i] = g[i]
                S.gt_hi[i] = gt[i]
            for i in range(n):
                S.xs[i] = S.xt[i]
            for i in range(m):
                S.lams[i] = S.lamt[i]
                S.lamas[i] = S.lamat[i]
            d_hi = d1
        else:
            lo, glo = s1, G1
        if abs(G1) <= gtol:
            use_last = True
            break
        if hi - lo <= stol:
            break
        # Secant through the last two trials when it falls inside the bracket, bisection
        # when the bracket has not halved in three trials.
        s2 = -1.0
        if G1 != gp:
            s2 = s1 - G1 * (s1 - sp) / (G1 - gp)
        if it % 3 == 2:
            if hi - lo > 0.5 * width_ref:
                s2 = -1.0
            width_ref = hi - lo
        if not (lo < s2 < hi):
            s2 = lo + (hi - lo) * (-glo) / (ghi - glo) if (it % 3 != 2 and ghi != glo) \
                else 0.5 * (lo + hi)
            if not (lo < s2 < hi):
                s2 = 0.5 * (lo + hi)
        sp, gp = s1, G1
        s1 = s2
    if use_last:
        for i in range(n):
            S.xs[i] = S.xt[i]
        for i in range(m):
            S.lams[i] = S.lamt[i]
            S.lamas[i] = S.lamat[i]
        for r in range(2):
            copy_row(act_t, r, act, r)
            slots[r] = slots_t[r]
        return STEP_OK, s1, d1
    for i in range(k):
        g[i] = S.g_hi[i]
        gt[i] = S.gt_hi[i]
    return STEP_OK, hi, d_hi
