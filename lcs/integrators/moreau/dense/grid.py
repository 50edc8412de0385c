"""The kernel's loop over a chunk of the time grid, through every switch-mode change.

One call of :func:`run_grid` advances the state over a chunk of the grid without returning to
Python except when it needs a mode whose matrices are not built yet (``STEP_NEED_MODE``),
when an output buffer is full (``STEP_FULL``), or on failure. Per grid step:

1. the schedule's switchings at its start (source- and controller-driven switches, latch
   re-arms);
2. sub-steps up to its end: a θ step (:mod:`.step`; both modes and the relay while a switch
   slides, :mod:`.sliding`), the located comparators checked at its end
   (:mod:`.comparators`), and on a crossing the instant located (:mod:`.locate`), the step
   split there and the mode changed;
3. the output row (:mod:`.store`) and the sampled comparators.

Runs with no comparator take their regular steps in :func:`plain_steps`, the same arithmetic
without the switching machinery.
"""

from __future__ import annotations

import numpy as np

from lcs.bits import (
    bit,
    clear_bit,
    clear_bits,
    copy_bits,
    copy_row,
    equal_bits,
    flip_bit,
    row_equals,
    set_bit,
)
from lcs.jit import kernel
from lcs.lcp.compiled import LcpWork, lookup

from .comparators import crossing, row_value, sample_switches, sampled_controls
from .layout import (
    EV_SLIDE_END,
    EV_SLIDE_START,
    FV_DUTY,
    FV_FAIL_T0,
    FV_FAIL_T1,
    FV_H,
    FV_LASTT,
    FV_RTOL,
    FV_TCUR,
    FV_THETA,
    IV_EVPOS,
    IV_FAILMODE,
    IV_FAILSW,
    IV_GSTEP,
    IV_INIT,
    IV_K,
    IV_LASTSW,
    IV_LOCATED,
    IV_NMODES,
    IV_NSW,
    IV_ODD,
    IV_OUTPOS,
    IV_SCHED,
    IV_SLIDE,
    IV_SLIDESTEPS,
    IV_STEPS,
    MF_FAST,
    OP_SET,
    PLAIN_MIN,
    STEP_CHATTER,
    STEP_FULL,
    STEP_NEED_MODE,
    STEP_OK,
    STEP_SLIDING,
    SW_LOCATED,
    SW_SAMPLED,
    SWF_RELAY,
    Actives,
    Blend,
    Crossings,
    Ends,
    Inputs,
    Ledger,
    LocateWork,
    Modes,
    Step,
    StepWork,
)
from .locate import locate, u_interp
from .sliding import advance, relay_combine
from .step import (
    ODD_BASIS,
    ODD_TAKEN,
    mode_step,
    odd_basis_step,
    odd_cached_step,
    regular_cached_step,
)
from .store import find_mode, record, store_row


@kernel
def _work(n, m, k, p):
    W = StepWork(np.zeros(n), np.zeros(m), np.zeros((n, m)), np.zeros((m, m)),
                 np.zeros((n, n + 1 + m)),
                 LcpWork(np.zeros(m), np.zeros(m), np.zeros(m, np.bool_),
                         np.zeros((m, 2 * m + 2)), np.zeros(m, np.int64), np.zeros((m, m + 1)),
                         np.zeros(max(1, (m + 63) // 64), np.int64),
                         np.zeros(max(1, (m + 63) // 64), np.int64), np.zeros(m), np.zeros(m),
                         np.zeros(m)))
    S = LocateWork(np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(k), np.zeros(p), np.zeros(n),
                   np.zeros(p), np.zeros(n), np.zeros(m), np.zeros(m), np.zeros(n), np.zeros(k),
                   np.zeros(k), np.zeros(n), np.zeros(m), np.zeros(m), np.zeros(3),
                   np.zeros((2, max(1, (m + 63) // 64)), np.int64), np.zeros(2, np.int64))
    return W, S


@kernel
def plain_steps(stack, j, key, chunk, kk, kstop, ends, acts, W, store, led, countdown, cap_row):
    """Regular grid steps ``kk .. kstop-1`` of mode ``j`` with no comparator, no sliding and
    no schedule entry: :func:`run_grid`'s regular step without its per-step switching
    machinery (the same arithmetic, so the same numbers), from ``ends.x``, ``ends.lam``
    (updated; ``ends.xn``, ``ends.lamn`` are scratch). Stops at the first step it cannot take
    (shortened, output row ``cap_row`` reached, or failed), which :func:`run_grid` then
    takes; returns ``(kk, countdown, status)`` (``status`` of a failed step)."""
    x = ends.x
    lam = ends.lam
    xn = ends.xn
    lamn = ends.lamn
    act = acts.act
    slots = acts.slots
    ivars = led.ivars
    fvars = led.fvars
    lim = led.lim
    n = x.shape[0]
    m = lam.shape[0]
    U0 = chunk.U0
    U1 = chunk.U1
    rtol = fvars[FV_RTOL]
    every = lim.every
    pos = ivars[IV_OUTPOS]
    steps = 0
    st = STEP_OK
    while kk < kstop:
        if chunk.odd[kk] or pos > cap_row:
            break
        if m > 0 and slots[0] < 0:
            slots[0] = lookup(stack.mats.M, j, act[0], stack.sets, ivars)
        if not regular_cached_step(stack, j, x, U0, U1, kk, slots[0], W, xn, lamn, rtol):
            # (the general step, as run_grid would take it: Lemke, uniqueness check)
            st = mode_step(stack, j, Step(chunk.t[kk], fvars[FV_H], True, True), x,
                           Inputs(U0[kk], U1[kk], U0, U1, kk, 0.0), acts, 0, W, xn, lamn, led)
            if st != STEP_OK:
                break
        for i in range(n):
            x[i] = xn[i]
        for i in range(m):
            lam[i] = lamn[i]
        steps += 1
        countdown -= 1
        if countdown == 0 or chunk.force_out[kk]:
            if countdown == 0:
                countdown = every
            store_row(stack, Blend(j, j, -1, 0.0), key, 0.0, x, lam, lam, U1, kk, store, pos,
                      chunk.t[kk + 1])
            pos += 1
        kk += 1
    ivars[IV_OUTPOS] = pos
    ivars[IV_STEPS] += steps
    ivars[IV_GSTEP] += steps
    return kk, countdown, st


@kernel
def _rearm(mats, j, sws, i, key, x, lam, u):
    """Re-arm latched switch ``i`` in ``key``: on iff its control >= vt - vh."""
    c, sc = row_value(mats.Cc, mats.Dc, mats.Fc, j, i, x, lam, u)
    if c >= sws.vt[i] - sws.vh[i]:
        set_bit(key, i)
    else:
        clear_bit(key, i)


@kernel
def run_grid(stack, sws, chunk, sched, state, lim, store):
    """Advance ``x`` over the grid chunk through every mode change.

    Parameters
    ----------
    stack : ModeStack
        The modes built so far (rows ``< ivars[IV_NMODES]`` valid).
    sws : SwitchArrays
        How each switch is driven, its threshold and hysteresis.
    chunk : Chunk
        The grid chunk and its inputs.
    sched : Schedule
        Switchings at known grid steps of the chunk.
    state : State
        The kernel's state, updated in place: ``x (n,)``, ``lam (m,)``, ``lama (m,)`` (the
        other mode's multipliers while a switch slides), the switch key ``key (Wk,)``, the
        active sets ``act (2, W)``, ``fail``, ``need`` (the key of a mode to build), counters
        and options ``ivars``, ``fvars`` (``IV_*``, ``FV_*``).
    lim : Limits
    store : Store
        Output and event buffers.

    Returns
    -------
    status : int
        ``STEP_OK`` (chunk done) or another ``STEP_*``; ``ivars[IV_K]`` and
        ``fvars[FV_TCUR]`` say where the kernel stopped (x, lam hold the state there).
    """
    x = state.x
    lam = state.lam
    lama = state.lama
    key = state.key
    act = state.act
    fail = state.fail
    ivars = state.ivars
    fvars = state.fvars
    n = x.shape[0]
    m = lam.shape[0]
    p = chunk.U0.shape[1]
    k = sws.kind.shape[0]
    tgrid = chunk.t
    odd = chunk.odd
    U0 = chunk.U0
    U1 = chunk.U1
    N = tgrid.shape[0] - 1
    theta = fvars[FV_THETA]
    h = fvars[FV_H]
    every = lim.every
    max_sw = lim.max_sw
    W, S = _work(n, m, k, p)
    ut2 = S.ut.reshape((1, p))  # (the interpolated inputs as a row, for store_row)
    sg = np.zeros(3)
    xn = np.zeros(n)
    lamn = np.zeros(m)
    xa = np.zeros(n)
    lamna = np.zeros(m)
    c = np.zeros(k)
    cs = np.zeros(k)
    g = np.zeros(k)
    gt = np.zeros(k)
    ua = np.zeros(p)
    # Cache slots of the active sets act[0] (mode j) and act[1] (mode ja); the active sets and
    # slots at the start of a step, for the instant search.
    slots = np.full(2, -1, np.int64)
    slots0 = np.zeros(2, np.int64)
    act0 = np.zeros_like(act)
    Wk = key.shape[0]
    akey = np.zeros(Wk, np.int64)
    # (the arguments of the steps and of the instant search that stay the same arrays for
    # the whole call)
    led = Ledger(ivars, fvars, fail, lim)
    acts = Actives(act, slots)
    ends = Ends(x, lam, xn, lamn, xa, lamna, sg)
    cross = Crossings(sws, key, c, cs, g, gt)
    tkey = np.zeros(Wk, np.int64)
    flips = np.zeros(Wk, np.int64)
    has_located = False
    has_sampled = False
    for i in range(k):
        if sws.kind[i] == SW_LOCATED:
            has_located = True
        elif sws.kind[i] == SW_SAMPLED:
            has_sampled = True
    slide = ivars[IV_SLIDE]
    tcur = fvars[FV_TCUR]
    nsched = sched.k.shape[0]
    min_step = 1e-9 * h
    countdown = every - ivars[IV_GSTEP] % every
    cap_out = store.T.shape[0]
    cap_ev = store.ev_t.shape[0]
    mkey = stack.key
    rtol = fvars[FV_RTOL]
    j = -1
    ja = -1
    d = 0.0
    status = STEP_OK
    # The current mode j (and while a switch slides, the other one, ja) indexes the stacked
    # matrices: no views, so no reference counting in the steps.
    mats = stack.mats
    flags = stack.flags
    plain = not has_located and not has_sampled
    plain_skip = -1
    kk = ivars[IV_K]
    while kk < N:
        ta_grid = tgrid[kk]
        tb = tgrid[kk + 1]
        if tcur < ta_grid:
            tcur = ta_grid
        # Room for this step's rows and events.
        if (ivars[IV_OUTPOS] + max_sw + 3 > cap_out
                or ivars[IV_EVPOS] + 2 * max_sw + k + 6 + (nsched - ivars[IV_SCHED]) > cap_ev):
            status = STEP_FULL
            break
        if (plain and slide < 0 and kk != plain_skip and j >= 0 and row_equals(mkey, j, key)
                and tcur <= ta_grid and ivars[IV_INIT] != kk):
            # No comparator and no sliding: the regular steps up to the next schedule entry
            # by the plain loop; it stops where this loop must take over.
            kstop = N
            sp = ivars[IV_SCHED]
            if sp < nsched and sched.k[sp] < kstop:
                kstop = sched.k[sp]
            # (only for runs of PLAIN_MIN steps or more: a call costs the views of the
            # mode's matrices, more than a few steps gain)
            if kstop - kk >= PLAIN_MIN and (m == 0 or flags[j, MF_FAST] != 0):
                k2, countdown, st = plain_steps(stack, j, key, chunk, kk, kstop, ends, acts, W,
                                                store, led, countdown, cap_out - max_sw - 3)
                plain_skip = k2
                if st != STEP_OK:
                    ivars[IV_FAILMODE] = j
                    tcur = tgrid[k2]
                    status = st
                    fvars[FV_FAIL_T0] = tgrid[k2]
                    fvars[FV_FAIL_T1] = tgrid[k2 + 1]
                    kk = k2
                    break
                if k2 > kk:
                    # (the state the per-step loop leaves after plain steps)
                    for i in range(m):
                        lama[i] = lamna[i]
                    d = 0.0
                    tcur = tgrid[k2]
                    ivars[IV_INIT] = k2 - 1
                    ivars[IV_NSW] = 0
                    kk = k2
                    continue
        if ivars[IV_INIT] != kk:
            ivars[IV_INIT] = kk
            ivars[IV_NSW] = 0
        # Scheduled switchings at the start of the step.
        need = False
        while tcur == ta_grid and ivars[IV_SCHED] < nsched and sched.k[ivars[IV_SCHED]] <= kk:
            sp = ivars[IV_SCHED]
            if sched.k[sp] < kk:  # (an entry before the resume point: already past)
                ivars[IV_SCHED] = sp + 1
                continue
            copy_bits(key, tkey)
            if sched.op[sp] == OP_SET:
                for w in range(Wk):
                    tkey[w] = (tkey[w] & ~sched.a[sp, w]) | sched.b[sp, w]
                info = -1
            else:
                i = sched.a[sp, 0]
                j = find_mode(mkey, ivars[IV_NMODES], key)
                if j < 0:
                    copy_bits(key, state.need)
                    need = True
                    break
                _rearm(mats, j, sws, i, tkey, x, lam, U0[kk])
                info = i
            ivars[IV_SCHED] = sp + 1
            if not equal_bits(tkey, key):
                copy_bits(tkey, key)
                record(store, ivars, ta_grid, key, info)
                if slide >= 0 and info == slide:
                    slide = -1
        if need:
            status = STEP_NEED_MODE
            break
        if j < 0 or not row_equals(mkey, j, key):
            j = find_mode(mkey, ivars[IV_NMODES], key)
            slots[0] = -1
            if j < 0:
                status = STEP_NEED_MODE
                copy_bits(key, state.need)
                break
        if slide >= 0:
            copy_bits(key, akey)
            flip_bit(akey, slide)
            if ja < 0 or not row_equals(mkey, ja, akey):
                ja = find_mode(mkey, ivars[IV_NMODES], akey)
                slots[1] = -1
                if ja < 0:
                    status = STEP_NEED_MODE
                    copy_bits(akey, state.need)
                    break
        else:
            ja = -1
        # Sub-steps: the whole grid step, or its parts between switching instants.
        need = False
        while True:
            if tb - tcur <= min_step:
                # (a switching within round-off of the grid point: nothing left to integrate)
                tcur = tb
                break
            ta = tcur
            s = tb - ta
            regular = (not odd[kk]) and ta == ta_grid
            tau_a = 0.0
            if ta == ta_grid:
                for i in range(p):
                    ua[i] = U0[kk, i]
            else:
                tau_a = (ta - ta_grid) / (tb - ta_grid)
                u_interp(chunk, kk, tau_a, ua)
            ub = U1[kk]
            base_on = slide >= 0 and bit(key, slide) == 1
            vts = sws.vt[slide] if slide >= 0 else 0.0
            copy_row(act, 0, act0, 0)
            copy_row(act, 1, act0, 1)
            slots0[0] = slots[0]
            slots0[1] = slots[1]
            done = False
            st = STEP_OK
            dd = 0.0
            if regular and (m == 0 or (flags[j, MF_FAST] != 0
                                       and (slide < 0 or flags[ja, MF_FAST] != 0))):
                # A regular step by the cached active set; while a switch slides, both modes'
                # steps, then the relay. (Each step's code is inlined once per call site.)
                if m > 0 and slots[0] < 0:
                    slots[0] = lookup(mats.M, j, act[0], stack.sets, ivars)
                if slide >= 0 and m > 0 and slots[1] < 0:
                    slots[1] = lookup(mats.M, ja, act[1], stack.sets, ivars)
                done = regular_cached_step(stack, j, x, U0, U1, kk, slots[0], W, xn, lamn, rtol)
                if done and slide >= 0:
                    done = regular_cached_step(stack, ja, x, U0, U1, kk, slots[1], W, xa, lamna,
                                               rtol)
                    if done:
                        dd = relay_combine(mats, j, ja, slide, base_on, vts, ub, xn, lamn, xa,
                                           lamna, sg)
            elif slide < 0 and (m == 0 or flags[j, MF_FAST] != 0):
                basis = not (odd[kk] and ta == ta_grid)
                if not basis:
                    # A shortened step onto a boundary: its length recurs every period.
                    taken = odd_cached_step(stack, j, s, x, ua, ub, act[0], slots, W, xn, lamn,
                                            led)
                    done = taken == ODD_TAKEN
                    basis = taken == ODD_BASIS
                if basis:
                    # (inlined once here, not in odd_cached_step too: a shortened step as a
                    # call costs about 2 µs, the reference counts of the stack's arrays)
                    done = odd_basis_step(stack, j, s, theta, x, ua, ub, act[0], W, xn, lamn,
                                          rtol)
            if not done:
                st, dd = advance(stack, Modes(j, ja, slide, base_on, vts),
                                 Step(ta, s, regular, True), Inputs(ua, ub, U0, U1, kk, tau_a),
                                 acts, W, ends, led)
            if st != STEP_OK:
                status = st
                fvars[FV_FAIL_T0] = ta
                fvars[FV_FAIL_T1] = tb
                break
            G = -np.inf
            if has_located:
                G = crossing(mats, Blend(j, ja, slide, dd), cross, xn, lamn, lamna, ub)
            if not (G > 0.0):
                for i in range(n):
                    x[i] = xn[i]
                for i in range(m):
                    lam[i] = lamn[i]
                    lama[i] = lamna[i]
                d = dd
                tcur = tb
                ivars[IV_STEPS] += 1
                if not regular:
                    ivars[IV_ODD] += 1
                if slide >= 0:
                    ivars[IV_SLIDESTEPS] += 1
                    fvars[FV_DUTY] = 1.0 - dd if base_on else dd
                    # Leave the surface when the on-fraction saturates and the relay holds
                    # strictly (beyond round-off) in the saturated mode.
                    tol = sg[2]
                    if dd == 0.0:
                        sgb = sg[0]
                        if (sgb > tol) if base_on else (sgb < -tol):
                            record(store, ivars, tb, key, slide + EV_SLIDE_END)
                            slide = -1
                            ja = -1
                    elif dd == 1.0:
                        sga = sg[1]
                        if (sga < -tol) if base_on else (sga > tol):
                            flip_bit(key, slide)
                            jt = j
                            j = ja
                            ja = jt
                            for w in range(act.shape[1]):
                                mt = act[0, w]
                                act[0, w] = act[1, w]
                                act[1, w] = mt
                            slots[0] = -1
                            slots[1] = -1
                            for i in range(m):
                                lam[i] = lamna[i]
                            d = 0.0
                            record(store, ivars, tb, key, slide + EV_SLIDE_END)
                            slide = -1
                            ja = -1
                break
            # A comparator crossed its threshold inside the step: locate the instant.
            copy_row(act0, 0, act, 0)
            copy_row(act0, 1, act, 1)
            slots[0] = slots0[0]
            slots[1] = slots0[1]
            st, s_star, dstar = locate(stack, Modes(j, ja, slide, base_on, vts),
                                       Step(ta, s, regular, True),
                                       Inputs(ua, ub, U0, U1, kk, tau_a), acts, led, cross, ends,
                                       dd, W, S, chunk)
            if st != STEP_OK:
                status = st
                fvars[FV_FAIL_T0] = ta
                fvars[FV_FAIL_T1] = tb
                break
            clear_bits(flips)
            first = -1
            # The switch that turned at this very instant sits on its threshold: it turns
            # again with the others only if it is clearly past it (a comparator driving
            # another switch's gate turns that one at its own instant, without a zero-time
            # toggle of its own); alone, it is the sliding test below.
            just = -1
            if s_star <= min_step and fvars[FV_LASTT] == tcur:
                just = ivars[IV_LASTSW]
            for i in range(k):
                if g[i] != -np.inf and (g[i] > gt[i] if i == just else g[i] >= -gt[i]):
                    set_bit(flips, i)
                    if first < 0:
                        first = i
            if first < 0:  # (alone: the switch that turned at this instant, or round-off)
                gm = -np.inf
                for i in range(k):
                    if g[i] > gm:
                        gm = g[i]
                        first = i
                set_bit(flips, first)
            if s_star > min_step:
                for i in range(n):
                    x[i] = S.xs[i]
                for i in range(m):
                    lam[i] = S.lams[i]
                    lama[i] = S.lamas[i]
                d = dstar
                tcur = ta + s_star
                ivars[IV_STEPS] += 1
                ivars[IV_ODD] += 1
                if slide >= 0:
                    ivars[IV_SLIDESTEPS] += 1
                if every == 1:
                    u_interp(chunk, kk, (tcur - ta_grid) / (tb - ta_grid), S.ut)
                    pos = ivars[IV_OUTPOS]
                    store_row(stack, Blend(j, ja, slide, d), key, fvars[FV_DUTY], x, lam, lama,
                              ut2, 0, store, pos, tcur)
                    ivars[IV_OUTPOS] = pos + 1
            elif ivars[IV_LASTSW] == first and fvars[FV_LASTT] == tcur:
                # The switch it flipped at this very instant wants to flip back before the
                # state has moved: the trajectory is on an attractive switching surface.
                if (sws.flags[first] & SWF_RELAY) != 0 and slide < 0:
                    slide = first
                    record(store, ivars, tcur, key, slide + EV_SLIDE_START)
                    ivars[IV_LASTSW] = -1
                    copy_bits(key, akey)
                    flip_bit(akey, slide)
                    ja = find_mode(mkey, ivars[IV_NMODES], akey)
                    copy_row(act, 0, act, 1)
                    slots[1] = -1
                    if ja < 0:
                        copy_bits(akey, state.need)
                        need = True
                        break
                    continue
                status = STEP_SLIDING
                ivars[IV_FAILSW] = first
                fvars[FV_FAIL_T0] = tcur
                fvars[FV_FAIL_T1] = tb
                break
            for w in range(Wk):
                key[w] ^= flips[w]
            record(store, ivars, tcur, key, first)
            ivars[IV_LASTSW] = first
            fvars[FV_LASTT] = tcur
            ivars[IV_LOCATED] += 1
            ivars[IV_NSW] += 1
            if ivars[IV_NSW] > max_sw:
                status = STEP_CHATTER
                ivars[IV_FAILSW] = first
                fvars[FV_FAIL_T0] = tcur
                fvars[FV_FAIL_T1] = tb
                break
            j = find_mode(mkey, ivars[IV_NMODES], key)
            slots[0] = -1
            if j < 0:
                copy_bits(key, state.need)
                need = True
                break
            if slide >= 0:
                copy_bits(key, akey)
                flip_bit(akey, slide)
                ja = find_mode(mkey, ivars[IV_NMODES], akey)
                slots[1] = -1
                if ja < 0:
                    copy_bits(akey, state.need)
                    need = True
                    break
        if status != STEP_OK:
            break
        if need:
            status = STEP_NEED_MODE
            break
        # End of the grid step: output, sampled comparators.
        ivars[IV_GSTEP] += 1
        countdown -= 1
        if countdown == 0 or chunk.force_out[kk]:
            if countdown == 0:
                countdown = every
            pos = ivars[IV_OUTPOS]
            store_row(stack, Blend(j, ja, slide, d), key, fvars[FV_DUTY], x, lam, lama, U1, kk,
                      store, pos, tb)
            ivars[IV_OUTPOS] = pos + 1
        if has_sampled:
            sampled_controls(mats, j, ja, d, slide, sws, x, lam, lama, U1[kk], c)
            first = sample_switches(sws, key, c)
            if first >= 0:
                record(store, ivars, tb, key, first)
        kk += 1
    ivars[IV_K] = kk
    ivars[IV_SLIDE] = slide
    fvars[FV_TCUR] = tcur
    return status
