"""The DC operating point of one mode of an LCS: the state where nothing moves.

ngspice starts a ``.tran`` without ``UIC`` from its DC operating point: capacitors open,
inductors shorted, sources at their ``t = 0`` values. For a mode ``x' = Ax + Bλ + Eu``,
``w = Cx + Dλ + Fu``, ``0 <= w ⊥ λ >= 0`` that point solves the mixed complementarity problem

    0 = A x + B λ + E u,    w = C x + D λ + F u,    0 <= w ⊥ λ >= 0.

The DC equations leave free the states in the null space of ``A`` (the voltage of a
capacitor that only open switches and other capacitors reach, the current around a loop of
inductors). What the dynamics never change there is kept from the given state ``x0`` (zero
unless ``IC=`` sets it): the combinations ``W^T x`` with ``W^T A = 0`` (the charge of a node
that only capacitors reach, the flux around a loop of inductors), whose derivative
``W^T (Bλ + Eu)`` is zero at the point. With ``P = N (W^T N)^{-1} W^T`` the projector onto the
null space ``N`` of ``A`` along its range, and ``A⁺`` the pseudo-inverse,
``x = P x0 + (I - P) x_p`` with ``x_p = -A⁺(Bλ + Eu)``: ``A x = A x_p`` and ``W^T x = W^T x0``.
(Where ``W^T N`` is singular, a zero eigenvalue of ``A`` with a Jordan chain, ``P`` is the
orthogonal projector onto ``N``.) Then ``λ`` solves the LCP
``w = (D - C (I - P) A⁺ B) λ + C (P x0 - (I - P) A⁺ E u) + F u``; where its solutions form
a set along which the state moves (a diode voltage that only the blocking diode bounds), the
open switches' leaks choose one (:func:`_along_lcp`). There is no operating
point when the DC equations cannot hold (a DC current into a capacitor with no other path,
a voltage across an inductor loop: the state would grow without bound) or when the LCP has
no solution; the result says which.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..lcp import LcpOptions, solve_lcp

__all__ = ["DcPoint", "dc_point"]


@dataclass
class DcPoint:
    """An operating point, or why there is none.

    Attributes
    ----------
    ok : bool
    x : ndarray, shape (n,)
        The state (``x0`` when not ``ok``).
    lam : ndarray, shape (m,)
        The multipliers (zeros when not ``ok``).
    free : ndarray of bool, shape (n,)
        The states that no DC equation sets (kept at their given values).
    reason : str
        Why there is no operating point ("" when ``ok``).
    """

    ok: bool
    x: np.ndarray
    lam: np.ndarray
    free: np.ndarray
    reason: str = ""


def dc_point(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, E: np.ndarray,
             F: np.ndarray, u: np.ndarray, x0: np.ndarray, lcp: LcpOptions | None = None,
             rtol: float = 1e-12, leaks: tuple[np.ndarray, ...] | None = None) -> DcPoint:
    """The operating point of one mode (module docstring).

    Parameters
    ----------
    A, B, C, D, E, F : ndarray
        The mode's matrices, shapes (n, n), (n, m), (m, n), (m, m), (n, p), (m, p).
    u : ndarray, shape (p,)
        The inputs at the start.
    x0 : ndarray, shape (n,)
        The given state: its values along the states that no DC equation sets are kept.
    lcp : LcpOptions, optional
    rtol : float
        Relative size below which a singular value of ``A`` counts as zero, and below which
        the residual of the DC equations counts as zero.
    leaks : tuple of ndarray, optional
        ``(Cl, Dl, Fl)``, shapes (r, n), (r, m), (r, p): voltages ``Cl x + Dl λ + Fl u`` across
        vanishing conductances (the open switches' ROFF, weighted by ``1/sqrt(ROFF)``). The
        states the DC equations leave free and these voltages reach take the limit of
        ngspice's operating point as the conductances vanish: the least sum of squares of
        the voltages (a capacitor that only an open switch reaches charges to the voltage
        on the switch's other side); the others keep their conserved values. The same
        least squares chooses among the diodes' LCP solutions where they move the state.
    """
    n, m = A.shape[0], B.shape[1]
    x0 = np.asarray(x0, dtype=float)
    u = np.asarray(u, dtype=float)
    if n == 0:
        res = solve_lcp(D, F @ u, lcp) if m else None
        if res is not None and not res.ok:
            return DcPoint(False, x0.copy(), np.zeros(m), np.zeros(0, bool),
                           "the diodes' LCP at the start has no solution")
        return DcPoint(True, x0.copy(), res.z.copy() if res is not None else np.zeros(m),
                       np.zeros(0, bool))
    # each state equation scaled by its largest coefficient: the rank is then judged on
    # equations of one size, not across time constants 1e17 apart (a MOSFET's gate RC beside
    # an integrator)
    rows = np.abs(np.hstack([A, B, E])).max(axis=1, initial=0.0)
    scale_rows = 1.0 / np.where(rows > 0, rows, 1.0)
    A, B, E = A * scale_rows[:, None], B * scale_rows[:, None], E * scale_rows[:, None]
    U, s, Vt = np.linalg.svd(A)
    scale = max(float(s[0]), 1e-300)
    rank = int(np.sum(s > rtol * scale))
    inv = np.zeros_like(s)
    inv[:rank] = 1.0 / s[:rank]
    A_pinv = (Vt.T * inv) @ U.T
    null = Vt[rank:].T  # (n, n - rank): the states no DC equation sets
    left_null = U[:, rank:]  # the DC equations' combinations that A cannot satisfy
    # the conserved combinations W^T x of the unscaled equations (W^T A = 0): W = S W_s
    conserved = left_null * scale_rows[:, None]
    P = null @ null.T  # (orthogonal: where W^T N is singular)
    free = np.zeros(n, bool)
    if null.size:
        free = np.abs(null).max(axis=1) > 1e-9
        WN = conserved.T @ null
        sv = np.linalg.svd(WN, compute_uv=False)
        if sv.min() > 1e-9 * max(sv.max(), 1e-300):
            # the projector onto null(A) along range(A): keeps W^T x0 (the charges and
            # fluxes the run could never change), not the part of x0 orthogonal to range(A^T)
            P = null @ np.linalg.solve(WN, conserved.T)
    x_null = P @ x0
    keep = np.eye(n) - P
    if left_null.size and np.abs(left_null.T @ B).max(initial=0.0) > rtol * max(
            1.0, np.abs(B).max(initial=0.0)):
        # (a capacitor only diodes reach: any value at which they block holds at DC)
        return DcPoint(False, x0.copy(), np.zeros(m), free,
                       "diodes act on states that no DC equation sets, as on a capacitor "
                       "only diodes charge: pelcs does not choose among the values the ideal "
                       "diodes allow there, which ngspice's operating point sets through the "
                       "diodes' leakage")
    KA = keep @ A_pinv
    M = D - C @ KA @ B
    solved = _solve(M, C, D, F, KA, B, E, u, x_null, lcp)
    if solved is None:
        return DcPoint(False, x0.copy(), np.zeros(m), free,
                       "the diodes' LCP at the operating point has no solution")
    x, lam, solution = solved
    if leaks is not None and null.size and leaks[0].size:
        Cl, Dl, Fl = leaks
        Ug, sG, VGt, reached = _reach(Cl @ null, float(np.linalg.norm(Cl, 2)))
        if reached:
            # the free directions the leaks reach: least squares of the leak voltages (the
            # vanishing-conductance limit); minimal norm leaves the others as they are
            v = Cl @ x + Dl @ lam + Fl @ u
            z = -VGt[:reached].T @ ((Ug[:, :reached].T @ v) / sG[:reached])
            x_null = x_null + null @ z
            solved = _solve(M, C, D, F, KA, B, E, u, x_null, lcp)
            if solved is None:
                return DcPoint(False, x0.copy(), np.zeros(m), free,
                               "the diodes' LCP at the operating point has no solution")
            x, lam, solution = solved
            rest = null @ VGt[reached:].T
            free = np.abs(rest).max(axis=1, initial=0.0) > 1e-9
    if m:
        # (a set of LCP solutions along which the state moves: the leaks choose)
        x, lam = _along_lcp(solution, lam, KA @ B, leaks, x, u)
    residual = A @ x + B @ lam + E @ u
    size = max(np.abs(A).max(initial=0.0) * np.abs(x).max(initial=0.0),
               np.abs(E @ u).max(initial=0.0), np.abs(B @ lam).max(initial=0.0), 1e-300)
    if np.abs(residual).max(initial=0.0) > 1e-8 * size:
        return DcPoint(False, x0.copy(), np.zeros(m), free,
                       "the DC equations have no solution (a DC current into a capacitor "
                       "with no other path, or a DC voltage across an inductor loop)")
    return DcPoint(True, x, lam, free)


def _solve(M, C, D, F, KA, B, E, u, x_null, lcp):
    """``(x, λ, the LCP as solved)`` of the operating point with the free part ``x_null``,
    or None when the diodes' LCP has no solution."""
    m = M.shape[0]
    q = C @ (x_null - KA @ (E @ u)) + F @ u
    # round-off of the inverse (1e-16 where the DC equations give an exact 0) made zero,
    # relative to the sizes of the factors: an LCP w = -5e-17 λ - 6e-16 has no solution,
    # w = 0 λ + 0 has λ = 0 (an inductor in series with a diode, both at zero)
    c_rows = np.abs(C).max(axis=1, initial=0.0)
    ka = np.abs(KA).max(initial=0.0)
    M_size = np.abs(D) + np.outer(c_rows, np.abs(B).max(axis=0, initial=0.0)) * ka
    M = np.where(np.abs(M) <= 1e-12 * M_size, 0.0, M)
    q_size = (c_rows * (np.abs(x_null).max(initial=0.0) + ka * np.abs(E @ u).max(initial=0.0))
              + np.abs(F) @ np.abs(u))
    q = np.where(np.abs(q) <= 1e-12 * q_size, 0.0, q)
    if m:
        res = solve_lcp(M, q, lcp)
        if not res.ok:
            return None
        lam = res.z.copy()
    else:
        lam = np.zeros(0)
    drive = B @ lam + E @ u
    x = x_null - KA @ drive
    # (the same round-off in the state: an inductor current of -1e-16 A against a diode
    # that blocks would read as an inconsistent start)
    x_size = np.abs(x_null).max(initial=0.0) + ka * np.abs(drive).max(initial=0.0)
    return (np.where(np.abs(x) <= 1e-12 * x_size, 0.0, x), lam,
            _Lcp(M, M_size, M @ lam + q, q_size))


def _reach(dv: np.ndarray, scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The SVD ``U, s, V^T`` of how the leak voltages move along some directions, and how
    many of its directions they reach: singular values above 1e-9 of the leaks' own size
    ``scale`` (not of the largest singular value: a leak that reaches none gives round-off,
    1e-21, that would count as reached and move the state by its voltage over that
    round-off, 1e18 V)."""
    U, s, Vt = np.linalg.svd(dv)  # (full: the rows of V^T past the reached ones are the rest)
    return U, s, Vt, int(np.sum(s > 1e-9 * max(scale, 1e-300)))


@dataclass
class _Lcp:
    """The diodes' LCP at the point as solved (round-off made zero) and its entries' sizes."""

    M: np.ndarray
    M_size: np.ndarray
    w: np.ndarray
    q_size: np.ndarray


def _along_lcp(lcp: _Lcp, lam: np.ndarray, KB: np.ndarray, leaks, x: np.ndarray,
               u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Where the diodes' LCP has a set of solutions that move the state, the one ngspice's
    operating point tends to: nearest the open switches' leaks, then with the least
    multipliers.

    At the solution ``λ``, the pairs with ``w = 0`` (``S``) may move along the null space
    ``K`` of ``M[S, S]`` without changing ``w[S]``: ``λ[S] + K z`` solves the LCP while it
    stays ``>= 0`` and keeps ``w`` of the other pairs ``>= 0``; the state moves by
    ``-KA B[:, S] K z`` (``KB = KA B``). An inductor whose only path at DC is a blocking
    diode leaves the diode's voltage, and the capacitor behind the inductor, anywhere the
    diode blocks (a buck with its switch open and no load: ngspice's point puts the output at
    the input through the switch's ROFF). ``z`` minimises the leak voltages' sum of squares
    under those bounds; in the directions no leak reaches, ``|λ[S]|`` (ngspice's diodes
    leak too, through GMIN: a diode's voltage, and with it its current, as near zero as the
    circuit lets it).

    Returns
    -------
    x, lam : ndarray
        The moved point.
    """
    m = lam.shape[0]
    w_size = lcp.M_size @ np.abs(lam) + lcp.q_size
    S = np.flatnonzero(np.abs(lcp.w) <= 1e-9 * np.maximum(w_size, 1e-300))
    if not S.size:
        return x, lam
    # the rank judged on M[S, S] scaled by its entries' sizes, row and column (pairs in
    # volts beside pairs in amperes), not on its largest entry
    size = lcp.M_size[np.ix_(S, S)]
    rs, cs = size.max(axis=1, initial=0.0), size.max(axis=0, initial=0.0)
    rs, cs = np.sqrt(np.where(rs > 0, rs, 1.0)), np.sqrt(np.where(cs > 0, cs, 1.0))
    _, s, Vt = np.linalg.svd(lcp.M[np.ix_(S, S)] / rs[:, None] / cs[None, :])
    rank = int(np.sum(s > 1e-9 * max(float(s[0]), 1e-300)))
    if rank == S.size:
        return x, lam
    K = np.linalg.qr(Vt[rank:].T / cs[:, None])[0]  # (|S|, k), orthonormal
    # the directions that move the state (the others change only multipliers)
    kb = max(float(np.abs(KB).max(initial=0.0)), 1e-300)
    _, sx, Vxt = np.linalg.svd(KB[:, S] @ K, full_matrices=False)
    moving = int(np.sum(sx > 1e-9 * kb))
    if not moving:
        return x, lam
    K = K @ Vxt[:moving].T
    N = np.setdiff1d(np.arange(m), S)
    x_in, lam_in = x, lam
    lam, w = lam.copy(), lcp.w.copy()

    def move(Kd, dv, v, scale):
        """Move along ``Kd`` to the least ``|v + dv t|^2`` within the bounds; the
        directions of ``Kd`` that ``dv`` does not reach."""
        nonlocal x
        # bounds G t >= h: λ[S] + Kd t >= 0, w[N] + M[N, S] Kd t >= 0
        G = np.vstack([Kd, lcp.M[np.ix_(N, S)] @ Kd])
        h = -np.concatenate([lam[S], w[N]])
        U, sg, VT, r = _reach(dv, scale)
        if r:
            # in y = Σ V^T t: the least |y + U^T v|^2 with G V Σ^-1 y >= h; its dual:
            # y = c + Gy^T μ, 0 <= Gy Gy^T μ + (Gy c - h) ⊥ μ >= 0
            V, sig = VT[:r].T, sg[:r]
            c = -(U[:, :r].T @ v)
            Gy = (G @ V) / sig
            res = solve_lcp(Gy @ Gy.T, Gy @ c - h)
            if res.ok:
                t = V @ ((c + Gy.T @ res.z) / sig)
                x = x - KB[:, S] @ (Kd @ t)
                lam[S] = np.maximum(lam[S] + Kd @ t, 0.0)
                w[N] = w[N] + lcp.M[np.ix_(N, S)] @ (Kd @ t)
        return Kd @ VT[r:].T

    if leaks is not None and leaks[0].size:
        Cl, Dl, Fl = leaks
        dv = -Cl @ (KB[:, S] @ K) + Dl[:, S] @ K
        K = move(K, dv, Cl @ x + Dl @ lam + Fl @ u, float(np.linalg.norm(np.hstack([Cl, Dl]), 2)))
    if K.size:
        move(K, K, lam[S], 1.0)  # (K's columns are orthonormal: every one reached)
    # still a solution of the LCP (else the point as first solved)
    w = lcp.M @ lam + (lcp.w - lcp.M @ lam_in)
    tol = 1e-9 * (lcp.M_size @ np.abs(lam) + w_size)
    if np.any(w < -tol) or np.any(np.minimum(lam, w) > tol):
        return x_in, lam_in
    return x, lam
