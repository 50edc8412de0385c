"""Filippov sliding of one comparator-driven switch: the implicit (chattering-free) relay.

While switch ``sw`` slides, each step is taken in both of its modes (``j``: the switch in its
state ``base_on``; ``ja``: toggled) from the same state, and the result is the combination
``x = (1 - d) x_j + d x_ja`` whose on-fraction solves the relay ``o ∈ H(σ)`` with
``σ = c - vt`` affine in ``o`` between the two modes' end values: a complementarity
condition solved in closed form (:func:`relay_fraction`) together with the two modes' LCPs.
"""

from __future__ import annotations

from lcs.jit import inline, kernel

from .comparators import row_value
from .layout import IV_FAILMODE, STEP_OK
from .step import mode_step


@kernel
def relay_fraction(sig_off, sig_on, base_on):
    """On-fraction ``o`` of a relay ``o ∈ H(σ)`` (1 for σ > 0, 0 for σ < 0, [0, 1] at 0) with
    σ affine in o: ``σ(o) = (1 - o) sig_off + o sig_on``.

    This is the LCP ``0 <= o ⊥ -σ(o) + ν >= 0``, ``0 <= ν ⊥ 1 - o >= 0`` in closed form; in
    the repulsive case (several solutions) the switch keeps its state ``base_on``.
    """
    if sig_off > 0.0 and sig_on < 0.0:
        return sig_off / (sig_off - sig_on)
    if sig_off <= 0.0 and sig_on >= 0.0:
        return 1.0 if base_on else 0.0
    if sig_on >= 0.0:
        return 1.0
    return 0.0


@inline
def relay_combine(mats, j, ja, sw, base_on, vt, u, xn, lamn, xa, lama, sg):
    """Combine the end states of the two modes (``xn, lamn`` of mode ``j``; ``xa, lama`` of
    mode ``ja``) into ``xn`` by the relay of switch ``sw`` (on in mode ``j`` when
    ``base_on``, threshold ``vt``) at the inputs ``u``; returns ``d``, the fraction of the step
    in the toggled mode. ``sg = [σ_j, σ_ja, tol]``: the relay values at the two end states and
    their round-off scale. (Its arguments one by one: it is inlined into run_grid's per-step
    loop, which holds them in variables of its own.)"""
    sgb, scb = row_value(mats.Cc, mats.Dc, mats.Fc, j, sw, xn, lamn, u)
    sga, sca = row_value(mats.Cc, mats.Dc, mats.Fc, ja, sw, xa, lama, u)
    sgb -= vt
    sga -= vt
    sg[0] = sgb
    sg[1] = sga
    sg[2] = 1e-9 * (max(scb, sca) + abs(vt))
    if base_on:
        d = 1.0 - relay_fraction(sga, sgb, True)
    else:
        d = relay_fraction(sgb, sga, False)
    for i in range(xn.shape[0]):
        xn[i] = xn[i] + d * (xa[i] - xn[i])
    return d


@kernel
def advance(stack, modes, step, io, acts, W, ends, led):
    """One step ``step`` (:class:`~lcs.integrators.moreau.dense.layout.Step`, inputs ``io``)
    from ``ends.x``: in mode ``modes.j`` of ``stack``, or while switch ``modes.sw`` slides
    (``sw >= 0``) the Filippov combination of modes ``j`` and ``ja`` (``sw`` toggled).

    ``acts``: the active sets (bitsets) of the two modes and their cache slots (updated).
    Returns ``(status, d)`` with ``d`` the fraction of the step in the toggled mode (0 when
    not sliding); the end state is left in ``ends.xn``, the multipliers of each mode in
    ``ends.lamn``, ``ends.lama``.
    """
    j = modes.j
    ja = modes.ja
    x = ends.x
    ivars = led.ivars
    st = mode_step(stack, j, step, x, io, acts, 0, W, ends.xn, ends.lamn, led)
    if st != STEP_OK:
        ivars[IV_FAILMODE] = j
        return st, 0.0
    if modes.sw < 0:
        return STEP_OK, 0.0
    st = mode_step(stack, ja, step, x, io, acts, 1, W, ends.xa, ends.lama, led)
    if st != STEP_OK:
        ivars[IV_FAILMODE] = ja
        return st, 0.0
    return STEP_OK, relay_combine(stack.mats, j, ja, modes.sw, modes.on, modes.vt, io.u1,
                                  ends.xn, ends.lamn, ends.xa, ends.lama, ends.sg)
