"""θ discretisation of one LCS mode: the stored matrices of the regular step and the free
state of a step of any length.

For one step of length ``s`` (Siconos ``EulerMoreauOSI(θ)``, ``γ`` unused)::

    W      = (I - s θ A)^-1
    x_free = W [(I + s(1-θ) A) x_k + s((1-θ) E u_k + θ E u_{k+1})]
    w      = (D + s C W B) λ + C x_free + F u_{k+1},      0 <= w ⊥ λ >= 0
    x_k+1  = x_free + s W B λ

written as ``x_free = Phi x_k + G0 u_k + G1 u_k+1``, ``M = D + C K``, ``K = s W B``. Regular
steps (``s = h``) use the stored ``Phi, G0, G1, K, M`` of the mode (:func:`free_regular`);
other steps (shortened steps onto breakpoints, the parts of a step split at a switching
instant, the trial steps of the instant search) are discretised on the fly by a small
Gaussian elimination (:func:`free_odd`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lcs.jit import inline, kernel


@dataclass
class Discretisation:
    """Matrices of one θ step of length ``h`` (s) for one LCS.

    Shapes: ``Phi (n, n)``, ``G0, G1 (n, p)``, ``K (n, m)``, ``M (m, m)``.
    """

    h: float
    theta: float
    Phi: np.ndarray
    G0: np.ndarray
    G1: np.ndarray
    K: np.ndarray
    M: np.ndarray


@kernel
def _gauss(aug, n, nc):
    """Solve ``aug[:, :n] X = aug[:, n:n+nc]`` in place (partial pivoting); X ends up in
    ``aug[:, n:n+nc]``. Returns False for a singular matrix."""
    amax = 0.0
    for i in range(n):
        for j in range(n):
            v = abs(aug[i, j])
            if v > amax:
                amax = v
    for c in range(n):
        p = c
        for r in range(c + 1, n):
            if abs(aug[r, c]) > abs(aug[p, c]):
                p = r
        if abs(aug[p, c]) <= 1e-14 * amax or aug[p, c] == 0.0:
            return False
        if p != c:
            for j in range(c, n + nc):
                tmp = aug[c, j]
                aug[c, j] = aug[p, j]
                aug[p, j] = tmp
        piv = aug[c, c]
        for r in range(c + 1, n):
            f = aug[r, c] / piv
            if f != 0.0:
                for j in range(c + 1, n + nc):
                    aug[r, j] -= f * aug[c, j]
    # Back substitution a row at a time over every right-hand side: the operations of a
    # column-by-column substitution in the same order (so the same numbers), with contiguous
    # inner loops and none for the zeros of U (an MMC arm's mode: 1.5 -> 0.06 ms).
    for i in range(n - 1, -1, -1):
        for j in range(i + 1, n):
            u = aug[i, j]
            if u != 0.0:
                for col in range(n, n + nc):
                    aug[i, col] -= u * aug[j, col]
        d = aug[i, i]
        for col in range(n, n + nc):
            aug[i, col] /= d
    return True


@kernel
def discretise_nb(A, B, C, D, E, h, theta, Phi, G0, G1, K, M):
    """Fill ``Phi, G0, G1, K, M`` for a step ``h`` (see the module docstring).

    Returns False when ``I - h θ A`` is singular (the matrices are then left unchanged).
    """
    n = A.shape[0]
    m = B.shape[1]
    p = E.shape[1]
    aug = np.zeros((n, 2 * n + p + m))
    for i in range(n):
        for j in range(n):
            aug[i, j] = (1.0 if i == j else 0.0) - h * theta * A[i, j]
            aug[i, n + j] = (1.0 if i == j else 0.0) + h * (1.0 - theta) * A[i, j]
        for j in range(p):
            aug[i, 2 * n + j] = E[i, j]
        for j in range(m):
            aug[i, 2 * n + p + j] = B[i, j]
    if n > 0 and not _gauss(aug, n, n + p + m):
        return False
    for i in range(n):
        for j in range(n):
            Phi[i, j] = aug[i, n + j]
        for j in range(p):
            G0[i, j] = h * (1.0 - theta) * aug[i, 2 * n + j]
            G1[i, j] = h * theta * aug[i, 2 * n + j]
        for j in range(m):
            K[i, j] = h * aug[i, 2 * n + p + j]
    # M = D + C K a row at a time, skipping the zeros of C (a diode's w names a few states).
    for i in range(m):
        for j in range(m):
            M[i, j] = D[i, j]
        for k in range(n):
            c = C[i, k]
            if c != 0.0:
                for j in range(m):
                    M[i, j] += c * K[k, j]
    return True


def discretise(A, B, C, D, E, h: float, theta: float) -> Discretisation:
    """Python entry to :func:`discretise_nb` (allocates the matrices).

    Raises
    ------
    ValueError
        If ``I - h θ A`` is singular.
    """
    A, B, C, D, E = (np.ascontiguousarray(a, dtype=float) for a in (A, B, C, D, E))
    n, m, p = A.shape[0], B.shape[1], E.shape[1]
    Phi = np.zeros((n, n))
    G0 = np.zeros((n, p))
    G1 = np.zeros((n, p))
    K = np.zeros((n, m))
    M = np.zeros((m, m))
    if not discretise_nb(A, B, C, D, E, float(h), float(theta), Phi, G0, G1, K, M):
        raise ValueError(f"I - h θ A is singular for h = {h:g} s, θ = {theta:g}")
    return Discretisation(float(h), float(theta), Phi, G0, G1, K, M)


# States from which the regular step's products are taken a column at a time (vectorised);
# below, row by row (fewer passes over tiny arrays). The numbers are the same either way.
COLUMN_MIN = 16


@inline
def free_regular(stack, j, x, U0, U1, kk, W):
    """Free state ``W.xf = Phi x + G0 u0 + G1 u1`` and ``W.q = C xf + F u1`` of a regular step
    of mode ``j`` of ``stack`` (:class:`~lcs.integrators.moreau.dense.layout.ModeStack`), with
    ``u0 = U0[kk]`` and ``u1 = U1[kk]`` (:func:`free_state`). Returns False when they are not
    finite."""
    mats = stack.mats
    return free_state(mats.Phi, mats.PhiT, mats.G0, mats.G1, j, True, stack, j, x, U0, U1, kk,
                      W)


@inline
def free_state(P, PT, G0, G1, ip, p_span, stack, j, x, U0, U1, kk, W):
    """``xf = P[ip] x + G0[ip] u0 + G1[ip] u1`` and ``q = C xf + F u1`` into ``W.xf``, ``W.q``
    (:class:`~lcs.integrators.moreau.dense.layout.StepWork`) with mode ``j``'s ``C``, ``F`` of
    ``stack.mats`` and ``u0 = U0[kk]``, ``u1 = U1[kk]``; the input terms over the mode's input
    columns ``stack.inp[j]`` only (:class:`~lcs.integrators.moreau.dense.layout.ModeStack`).
    Below
    :data:`COLUMN_MIN` states the products run row by row from ``P``, from there a column at
    a time from the transposes ``PT`` and ``mats.CT`` (each entry adds its terms in the same
    order, so the numbers are the same; the inner loops vectorise), each column over the
    rows between its first and last non-zero entries only (``stack.span[j]``, for ``P`` when
    ``p_span``, i.e. ``P`` is the mode's regular ``Phi``; the skipped terms are exact zeros).
    The stacks are indexed (``ip``, ``j``) rather than viewed, which keeps reference counting
    out of the steps; a store that keeps one form of ``P`` only passes it as both. Returns
    False when the results are not finite."""
    mats = stack.mats
    inp = stack.inp
    span = stack.span
    xf = W.xf
    q = W.q
    F = mats.F
    n = x.shape[0]
    m = q.shape[0]
    nu = inp[j, 0]
    if n < COLUMN_MIN:
        C = mats.C
        for i in range(n):
            v = 0.0
            for jj in range(n):
                v += P[ip, i, jj] * x[jj]
            for t in range(nu):
                jj = inp[j, 1 + t]
                v += G0[ip, i, jj] * U0[kk, jj] + G1[ip, i, jj] * U1[kk, jj]
            xf[i] = v
        for i in range(m):
            v = 0.0
            for jj in range(n):
                v += C[j, i, jj] * xf[jj]
            q[i] = v
    else:
        CT = mats.CT
        for i in range(n):
            xf[i] = 0.0
        # (unsigned bounds: a signed index loaded from memory could be negative, and the
        # wrap-around test per element keeps the loop from vectorising: 2-4x slower)
        for jj in range(n):
            xj = x[jj]
            lo = np.uint64(span[j, 0, jj, 0]) if p_span else np.uint64(0)
            hi = np.uint64(span[j, 0, jj, 1]) if p_span else np.uint64(n)
            for i in range(lo, hi):
                xf[i] += PT[ip, jj, i] * xj
        for i in range(n):
            v = xf[i]
            for t in range(nu):
                jj = inp[j, 1 + t]
                v += G0[ip, i, jj] * U0[kk, jj] + G1[ip, i, jj] * U1[kk, jj]
            xf[i] = v
        for i in range(m):
            q[i] = 0.0
        for jj in range(n):
            xj = xf[jj]
            for i in range(np.uint64(span[j, 1, jj, 0]), np.uint64(span[j, 1, jj, 1])):
                q[i] += CT[j, jj, i] * xj
    chk = 0.0
    for i in range(m):
        v = q[i]
        for t in range(nu):
            jj = inp[j, 1 + t]
            v += F[j, i, jj] * U1[kk, jj]
        q[i] = v
        chk += v
    for i in range(n):
        chk += xf[i] + x[i]  # (x too: a column skipped by its span drops a NaN of x)
    # Never a silent NaN: inf - inf and NaN both give NaN.
    return chk - chk == 0.0


@inline
def free_odd(mats, inp, j, s, theta, x, u0, u1, xf, q, Ko, Mo, augn):
    """Free state ``xf``, ``K`` (into ``Ko``), ``M`` (into ``Mo``) and ``q`` of a step of
    length ``s`` (not the stored h) of mode ``j``, from inputs ``u0`` to ``u1`` (over the
    mode's input columns ``inp[j]``).
    Returns False when ``I - s θ A`` is singular or the result is not finite."""
    A, B, C, D, E, F = mats.A, mats.B, mats.C, mats.D, mats.E, mats.F
    n = x.shape[0]
    m = q.shape[0]
    nu = inp[j, 0]
    a1 = s * (1.0 - theta)
    for i in range(n):
        v = x[i]
        for jj in range(n):
            augn[i, jj] = (1.0 if i == jj else 0.0) - s * theta * A[j, i, jj]
            v += a1 * A[j, i, jj] * x[jj]
        for t in range(nu):
            jj = inp[j, 1 + t]
            v += s * E[j, i, jj] * ((1.0 - theta) * u0[jj] + theta * u1[jj])
        augn[i, n] = v
        for jj in range(m):
            augn[i, n + 1 + jj] = B[j, i, jj]
    if n > 0 and not _gauss(augn, n, 1 + m):
        return False
    chk = 0.0
    for i in range(n):
        xf[i] = augn[i, n]
        chk += xf[i]
        for jj in range(m):
            Ko[i, jj] = s * augn[i, n + 1 + jj]
    for i in range(m):
        # (a row at a time, skipping the zeros of C: the sums of discretise_nb)
        for jj in range(m):
            Mo[i, jj] = D[j, i, jj]
        for k in range(n):
            c = C[j, i, k]
            if c != 0.0:
                for jj in range(m):
                    Mo[i, jj] += c * Ko[k, jj]
        v = 0.0
        for jj in range(n):
            v += C[j, i, jj] * xf[jj]
        for t in range(nu):
            jj = inp[j, 1 + t]
            v += F[j, i, jj] * u1[jj]
        q[i] = v
        chk += v
    return chk - chk == 0.0
