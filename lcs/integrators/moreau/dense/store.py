"""What the kernel saves: probe rows ``y = Cy x + Dy λ + Fy u`` and event records."""

from __future__ import annotations

from lcs.bits import bit
from lcs.jit import inline, kernel

from .layout import IV_EVPOS, MF_OUTSTATE


@inline
def _row_at(Cr, Dr, Fr, j, r, x, lam, U, ur):
    """``Cr[j, r] x + Dr[j, r] λ + Fr[j, r] U[ur]``."""
    v = 0.0
    for jj in range(x.shape[0]):
        v += Cr[j, r, jj] * x[jj]
    for jj in range(lam.shape[0]):
        v += Dr[j, r, jj] * lam[jj]
    for jj in range(U.shape[1]):
        v += Fr[j, r, jj] * U[ur, jj]
    return v


@inline
def store_row(stack, blend, key, duty_value, x, lam, lama, U, ur, store, pos, t):
    """Write the stored probes at time ``t`` into row ``pos`` of ``store.T``, ``store.Y``; the
    inputs are row ``ur`` of ``U`` (a row index, not a row: a view per stored step costs as
    much as the step).

    A probe row of ``store.duty`` >= 0 is the state of that switch in ``key`` (1 on, 0 off;
    ``duty_value``, the equivalent duty, while it slides). The probes are those of mode
    ``blend.j`` of ``stack``, or while a switch slides with ``blend.d != 0`` the Filippov
    combination with mode ``blend.ja`` (:class:`~.layout.Blend`).
    """
    j = blend.j
    ja = blend.ja
    slide = blend.sw
    d = blend.d
    duty = store.duty
    T = store.T
    Y = store.Y
    T[pos] = t
    sliding = slide >= 0 and d != 0.0
    if stack.flags[j, MF_OUTSTATE] != 0 and not sliding:
        for i in range(x.shape[0]):
            Y[pos, i] = x[i]
        return
    Cy, Dy, Fy = stack.mats.Cy, stack.mats.Dy, stack.mats.Fy
    for r in range(Y.shape[1]):
        sw = duty[r]
        if sw >= 0:
            if sw == slide:
                Y[pos, r] = duty_value
            else:
                Y[pos, r] = 1.0 if bit(key, sw) else 0.0
            continue
        v = _row_at(Cy, Dy, Fy, j, r, x, lam, U, ur)
        if sliding:
            va = _row_at(Cy, Dy, Fy, ja, r, x, lama, U, ur)
            v = (1.0 - d) * v + d * va
        Y[pos, r] = v


@kernel
def record(store, ivars, t, key, info):
    """Append an event record (time, switch key after it, ``switch + EV_*``)."""
    e = ivars[IV_EVPOS]
    store.ev_t[e] = t
    for w in range(key.shape[0]):
        store.ev_key[e, w] = key[w]
    store.ev_info[e] = info
    ivars[IV_EVPOS] = e + 1


@kernel
def find_mode(mkey, nmodes, key):
    """Id of the mode of switch key ``key`` (a bitset) among the first ``nmodes``, or -1."""
    W = key.shape[0]
    for i in range(nmodes):
        same = True
        for w in range(W):
            if mkey[i, w] != key[w]:
                same = False
                break
        if same:
            return i
    return -1
