"""Switch controls and comparator crossings: ``c = Cc x + Dc λ + Fc u`` against thresholds.

A located comparator (``SW_LOCATED``) has crossed when its crossing function
``g = c - (vt + vh)`` (an off switch) or ``g = (vt - vh) - c`` (an on switch) is positive; a
latched off switch never crosses (its re-arm entries of the schedule turn it on). While a
switch slides, controls are the Filippov combination ``(1 - d) c_j + d c_ja`` of the two
modes' values. Every value comes with its floating-point scale (the sum of the magnitudes of
its terms), from which the round-off tolerances of the instant search follow.
"""

from __future__ import annotations

import numpy as np

from lcs.bits import bit, clear_bit, set_bit
from lcs.jit import inline, kernel

from .layout import SW_LOCATED, SW_SAMPLED, SWF_LATCH


@inline
def row_value(Cr, Dr, Fr, j, r, x, lam, u):
    """``Cr[j, r] x + Dr[j, r] λ + Fr[j, r] u`` (row r of mode j of stacked matrices) and
    the sum of the magnitudes of its terms."""
    v = 0.0
    sc = 0.0
    for jj in range(x.shape[0]):
        t = Cr[j, r, jj] * x[jj]
        v += t
        sc += abs(t)
    for jj in range(lam.shape[0]):
        t = Dr[j, r, jj] * lam[jj]
        v += t
        sc += abs(t)
    for jj in range(u.shape[0]):
        t = Fr[j, r, jj] * u[jj]
        v += t
        sc += abs(t)
    return v, sc


@inline
def crossing(mats, blend, cross, x, lam, lama, u):
    """Crossing functions ``cross.g`` of the located comparators (``-inf`` for the others and
    for the sliding switch ``blend.sw``), their round-off scales ``cross.gt``, and the controls
    ``cross.c``, ``cross.cs`` behind them (:class:`~.layout.Crossings`); returns ``max g``.

    The controls are those of mode ``blend.j`` of the stacked matrices ``mats`` at
    ``(x, lam, u)``, or while a switch slides with ``blend.d != 0`` the combination with mode
    ``blend.ja`` at ``(x, lama, u)`` (:class:`~.layout.Blend`).
    """
    j = blend.j
    ja = blend.ja
    slide = blend.sw
    d = blend.d
    sws = cross.sws
    key = cross.key
    c = cross.c
    cs = cross.cs
    g = cross.g
    gt = cross.gt
    Cc, Dc, Fc = mats.Cc, mats.Dc, mats.Fc
    G = -np.inf
    for i in range(sws.kind.shape[0]):
        g[i] = -np.inf
        gt[i] = 0.0
        if sws.kind[i] != SW_LOCATED or i == slide:
            continue
        on = bit(key, i)
        if (not on) and (sws.flags[i] & SWF_LATCH) != 0:
            continue
        v, sc = row_value(Cc, Dc, Fc, j, i, x, lam, u)
        if slide >= 0 and d != 0.0:
            va, sca = row_value(Cc, Dc, Fc, ja, i, x, lama, u)
            v = (1.0 - d) * v + d * va
            sc = (1.0 - d) * sc + d * sca
        c[i] = v
        cs[i] = sc
        if on:
            g[i] = (sws.vt[i] - sws.vh[i]) - v
        else:
            g[i] = v - (sws.vt[i] + sws.vh[i])
        gt[i] = 1e-12 * (sc + abs(sws.vt[i]) + abs(sws.vh[i]))
        if g[i] > G:
            G = g[i]
    return G


@inline
def sampled_controls(mats, j, ja, d, slide, sws, x, lam, lama, u, c):
    """Controls ``c`` of the sampled comparators (``SW_SAMPLED``) at the end of a step in mode
    ``j`` (the Filippov combination with mode ``ja`` while a switch slides with ``d != 0``)."""
    Cc, Dc, Fc = mats.Cc, mats.Dc, mats.Fc
    for i in range(sws.kind.shape[0]):
        if sws.kind[i] != SW_SAMPLED:
            continue
        v, sc = row_value(Cc, Dc, Fc, j, i, x, lam, u)
        if slide >= 0 and d != 0.0:
            va, sca = row_value(Cc, Dc, Fc, ja, i, x, lama, u)
            v = (1.0 - d) * v + d * va
        c[i] = v


@inline
def sample_switches(sws, key, c):
    """Flip in ``key`` the sampled comparators whose controls ``c`` left the hysteresis band;
    returns the first switch that flipped (-1: none)."""
    first = -1
    for i in range(sws.kind.shape[0]):
        if sws.kind[i] != SW_SAMPLED:
            continue
        on = bit(key, i)
        if on and c[i] < sws.vt[i] - sws.vh[i]:
            clear_bit(key, i)
        elif (not on) and c[i] > sws.vt[i] + sws.vh[i]:
            set_bit(key, i)
        else:
            continue
        if first < 0:
            first = i
    return first


@kernel
def control_rates(mats, j, x, lam, u, udot, rate, xdot):
    """``d/dt (Cc x + Fc u)`` in mode ``j`` from ``x' = A x + B λ + E u`` (the ``Dc λ'`` term
    is unknown and ignored: this only seeds the instant search)."""
    A, B, E, Cc, Fc = mats.A[j], mats.B[j], mats.E[j], mats.Cc[j], mats.Fc[j]
    n = A.shape[0]
    for i in range(n):
        v = 0.0
        for jj in range(n):
            v += A[i, jj] * x[jj]
        for jj in range(B.shape[1]):
            v += B[i, jj] * lam[jj]
        for jj in range(E.shape[1]):
            v += E[i, jj] * u[jj]
        xdot[i] = v
    for i in range(Cc.shape[0]):
        v = 0.0
        for jj in range(n):
            v += Cc[i, jj] * xdot[jj]
        for jj in range(Fc.shape[1]):
            v += Fc[i, jj] * udot[jj]
        rate[i] = v


@kernel
def hermite_root(ga, da, gb, db):
    """Root in (0, 1) of the cubic Hermite interpolant of ``g(0) = ga <= 0``, ``g'(0) = da``,
    ``g(1) = gb > 0``, ``g'(1) = db`` (safeguarded Newton from the linear guess)."""
    lo, hi = 0.0, 1.0
    tau = -ga / (gb - ga) if gb != ga else 0.5
    for _ in range(8):
        t2 = tau * tau
        t3 = t2 * tau
        p = ((2 * t3 - 3 * t2 + 1) * ga + (t3 - 2 * t2 + tau) * da + (-2 * t3 + 3 * t2) * gb
             + (t3 - t2) * db)
        dp = ((6 * t2 - 6 * tau) * ga + (3 * t2 - 4 * tau + 1) * da + (-6 * t2 + 6 * tau) * gb
              + (3 * t2 - 2 * tau) * db)
        if p > 0.0:
            hi = tau
        else:
            lo = tau
        if dp > 0.0:
            nt = tau - p / dp
        else:
            nt = 0.5 * (lo + hi)
        if not (lo < nt < hi):
            nt = 0.5 * (lo + hi)
        if abs(nt - tau) <= 1e-14:
            tau = nt
            break
        tau = nt
    return tau
