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
open switches' leaks choose one (:func:`_along_lcp`). Where diodes act on the free states
(a capacitor that only diodes charge: ``W^T B != 0``), no DC current may enter them; where
that holds only with those diodes' ``λ = 0``, the diodes' leakage sets the states, as in
ngspice: the least squares of those diodes' voltages within their bounds
(:func:`_leak_balanced`: a diode from 10 V into a lone capacitor charges it to 10 V). Which
diodes act there is judged after the formulation's round-off is taken out of ``B``
(:func:`_round_off_coupling`: a pwl diode's segments, which only share its current among
branches, enter its junction capacitor's row at 1e-9 of the diode's own entry).
The point found is checked: the DC equations and the diodes' complementarity, each within
its tolerance. Where ``A`` is regular but ill-conditioned (a regulator's error amplifier,
its gain of 1e7 before its clamps, leaves a condition number of 1e10 to 1e12), the point
through ``A⁺`` can fail that check though one exists; it is then solved again with the
diodes' pairs as equations, conducting or blocking as the first point has them, each pair
on the wrong side changed in turn (:func:`_active_set_point`), a system that the clamps'
equations make well-conditioned again.
There is no operating point when the DC equations cannot hold (a DC current into a
capacitor with no other path, a voltage across an inductor loop: the state would grow
without bound, proved by a combination of the DC equations that no state and no diode
changes and the sources drive) or when the LCP has no solution; the result says which, and
says where pelcs only found none (:func:`_why_none`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..lcp import LcpOptions, solve_lcp

__all__ = ["DcPoint", "dc_point"]

# The tolerances of the module's three questions, each relative to the sizes of the terms
# that make the quantity asked about (the sum of their absolute values, entry by entry), never
# to a quantity of other units (a pair in amperes beside one in volts):
#: a number this small beside its terms is round-off (1e-16 where exact arithmetic gives 0):
#: made zero (:func:`_zero_round_off`)
ROUND_OFF = 1e-12
#: a ``w`` or ``λ`` this small beside its terms sits on its bound ``0``
#: (:func:`_on_bound`, :func:`_is_lcp_solution`)
ON_BOUND = 1e-9
#: the DC equations ``0 = A x + B λ + E u`` hold where each residual is this small beside its
#: equation's terms (:func:`_dc_holds`)
DC_RESIDUAL = 1e-8
#: a column of ``B`` whose part in the DC equations' combinations that ``A`` cannot satisfy
#: is this small, each equation scaled to its largest coefficient, is the formulation's
#: round-off, not a diode acting on a free state (:func:`_round_off_coupling`)
COUPLING_ROUND_OFF = 1e-8


def _zero_round_off(a: np.ndarray, size) -> np.ndarray:
    """``a`` with the entries no larger than ``ROUND_OFF`` times ``size`` (their terms'
    sizes, V, A or their ratios) made zero: an LCP ``w = -5e-17 λ - 6e-16`` has no solution,
    ``w = 0 λ + 0`` has ``λ = 0``."""
    return np.where(np.abs(a) <= ROUND_OFF * size, 0.0, a)


def _on_bound(w: np.ndarray, size: np.ndarray) -> np.ndarray:
    """Which entries of ``w`` are at zero beside their terms' sizes ``size``."""
    return np.abs(w) <= ON_BOUND * np.maximum(size, 1e-300)


def _is_lcp_solution(lam: np.ndarray, w: np.ndarray, w_size: np.ndarray) -> bool:
    """Whether ``0 <= w ⊥ λ >= 0`` holds within :data:`ON_BOUND`: ``w`` beside its terms'
    sizes ``w_size``, ``λ`` beside the largest multiplier (its own terms are the LCP's)."""
    w_tol = ON_BOUND * np.maximum(w_size, 1e-300)
    lam_tol = ON_BOUND * max(np.abs(lam).max(initial=0.0), 1e-300)
    return not (np.any(lam < -lam_tol) or np.any(w < -w_tol)
                or np.any((lam > lam_tol) & (w > w_tol)))


def _dc_holds(A: np.ndarray, B: np.ndarray, E: np.ndarray, x: np.ndarray, lam: np.ndarray,
              u: np.ndarray) -> bool:
    """Whether ``0 = A x + B λ + E u`` holds within :data:`DC_RESIDUAL`, each equation beside
    its own terms; an equation whose terms are all round-off beside the largest equation's
    (``ROUND_OFF`` times them: a state of 1e-23 V left by a 1e4 V one) is judged beside that
    round-off, which its terms cannot measure."""
    residual = A @ x + B @ lam + E @ u
    size = np.abs(A) @ np.abs(x) + np.abs(B) @ np.abs(lam) + np.abs(E) @ np.abs(u)
    floor = ROUND_OFF * max(size.max(initial=0.0), 1e-300)
    return not np.any(np.abs(residual) > DC_RESIDUAL * np.maximum(size, floor))


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
    proved : bool
        Whether ``reason`` proves that there is none (the DC equations' combination that
        the sources drive and nothing else changes, :func:`_why_none`), or says only that
        pelcs found none.
    """

    ok: bool
    x: np.ndarray
    lam: np.ndarray
    free: np.ndarray
    reason: str = ""
    proved: bool = False


def dc_point(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, E: np.ndarray,
             F: np.ndarray, u: np.ndarray, x0: np.ndarray, lcp: LcpOptions | None = None,
             rtol: float = 1e-12, leaks: tuple[np.ndarray, ...] | None = None,
             offsets: np.ndarray | None = None) -> DcPoint:
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
    offsets : ndarray of bool, shape (m, p), optional
        For each pair, the inputs that are its own device's offset voltages (a pwl diode's
        ``Vf``): where the diodes' leakage sets a state, it leaks across the junction, at
        ``w`` less those inputs' terms (a pwl diode from 2 V into a lone capacitor charges
        it to 2 V, as ngspice's GMIN across the junction does, not to its knee 2 V - Vf);
        without them, at ``w``.
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
    A_in, B_in, E_in = A, B, E
    A, B, E = A * scale_rows[:, None], B * scale_rows[:, None], E * scale_rows[:, None]
    U, s, Vt = np.linalg.svd(A)
    scale = max(float(s[0]), 1e-300)
    rank = int(np.sum(s > rtol * scale))
    inv = np.zeros_like(s)
    inv[:rank] = 1.0 / s[:rank]
    A_pinv = (Vt.T * inv) @ U.T
    # (n, n - rank): the states no DC equation sets; its columns are unit vectors, and an
    # entry of 1e-16 is the SVD's round-off of a state no DC equation leaves free (a line
    # inductor's current, 5e-17 of a free direction that a least squares then moves by 500
    # V, leaves 2.5e-14 A where the junction capacitor's equation multiplies it by 1.2e11)
    null = _zero_round_off(Vt[rank:].T, 1.0)
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
    KA = keep @ A_pinv
    if left_null.size:
        B = _round_off_coupling(B, left_null)
        B_in = B / scale_rows[:, None]
    if left_null.size and np.abs(left_null.T @ B).max(initial=0.0) > rtol * max(
            1.0, np.abs(B).max(initial=0.0)):
        # (a capacitor only diodes reach: any value at which they block holds at DC; their
        # leakage chooses, where that can be made exact)
        found = _leak_balanced(A_in, B_in, C, D, E_in, F, u, x0, lcp, rtol, leaks,
                               left_null.T @ B, left_null.T @ (E @ u), null, KA, B, offsets)
        if found is not None:
            return found
        return DcPoint(False, x0.copy(), np.zeros(m), free,
                       "diodes act on states that no DC equation sets, and pelcs finds no "
                       "point among the values the ideal diodes allow there where their "
                       "leakage balances, as ngspice's operating point does (as where a DC "
                       "current may pass from one diode through such a state into another)")
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
    if _holds(A, B, C, D, E, F, x, lam, u):
        return DcPoint(True, x, lam, free)
    if not null.size:
        # (A regular but ill-conditioned: a regulator's error amplifier, gain 1e7 before
        # its clamps, leaves A⁺ with entries of 1e9, and the LCP built on it a point off by
        # 0.08 V or a DC residual of 6e-4; with the clamps' pairs in the equations the
        # system is well-conditioned again)
        found = _active_set_point(A, B, C, D, E, F, u, x, lam)
        if found is not None:
            return DcPoint(True, found[0], found[1], free)
    return DcPoint(False, x0.copy(), np.zeros(m), free, *_why_none(A, E, u, left_null))


def _round_off_coupling(B: np.ndarray, left_null: np.ndarray) -> np.ndarray:
    """``B`` (its equations scaled to their largest coefficient) without the parts of its
    columns in the combinations ``left_null`` of the DC equations where they are round-off
    (:data:`COUPLING_ROUND_OFF`).

    The formulation solves the circuit's MNA equations by an LU factorisation it accepts down
    to a reciprocal condition of 1e-6 (``netlist.mna_solve``), and cleans the entries below
    1e-12 of their row: what lies between is round-off it leaves. A piecewise-linear diode's
    segments carry currents that only share the diode's total among its parallel branches:
    in exact arithmetic they enter no capacitor's equation, but the formulation's
    matrices give them 1.7e-9 of their junction capacitor's row beside the 0.48 of the
    diode's total current (a 1N4148 of five segments, its 1.2 pF behind 0.48 Ω). Counted
    as diodes acting on the capacitor's charge, these entries of random sign made the
    leakage balance (:func:`_leak_balanced`) see currents that could balance each other,
    and it found no point."""
    Lb = left_null.T @ B
    small = np.abs(Lb).max(axis=0, initial=0.0) <= COUPLING_ROUND_OFF
    if not small.any():
        return B
    B = B.copy()
    B[:, small] -= left_null @ Lb[:, small]
    return B


def _holds(A, B, C, D, E, F, x, lam, u) -> bool:
    """Whether ``(x, λ)`` is an operating point: the DC equations (:func:`_dc_holds`) and
    the diodes' complementarity (:func:`_is_lcp_solution`), each within its tolerance."""
    w = C @ x + D @ lam + F @ u
    w_size = np.abs(C) @ np.abs(x) + np.abs(D) @ np.abs(lam) + np.abs(F) @ np.abs(u)
    return _dc_holds(A, B, E, x, lam, u) and _is_lcp_solution(lam, w, w_size)


def _why_none(A, E, u, left_null) -> tuple[str, bool]:
    """Why no operating point was found, and whether that proves there is none: the DC
    equations' proof where they have one, else that pelcs's solve found none.

    The proof: a combination ``y`` of the DC equations that no state and no diode can
    change (``y^T A = 0``, ``y^T B = 0``: the left null space, where the diodes do not act,
    as :func:`dc_point` has checked before) that the sources drive (``y^T E u != 0``
    beside its terms): a DC current into a capacitor with no other path, or a DC voltage
    across an inductor loop."""
    if left_null.size:
        drive = left_null.T @ (E @ u)
        size = np.abs(left_null.T) @ (np.abs(E) @ np.abs(u))
        if np.any(np.abs(drive) > DC_RESIDUAL * np.maximum(size, 1e-300)):
            return ("the DC equations have no solution (a DC current into a capacitor with "
                    "no other path, or a DC voltage across an inductor loop)", True)
    s = np.linalg.svd(A, compute_uv=False)
    cond = float(s[0] / s[-1]) if s.size and s[-1] > 0 else float("inf")
    return ("pelcs's solve of the DC equations and the diodes' complementarity found no "
            "point that satisfies them within their tolerances (the DC equations' matrix, "
            f"scaled by rows, has condition number {cond:.2g}); this is no proof that none "
            "exists", False)


def _active_set_point(A, B, C, D, E, F, u, x, lam) -> tuple[np.ndarray, np.ndarray] | None:
    """The operating point of a regular ``A`` solved with the diodes' pairs as equations:
    ``(x, λ)`` or None.

    The pairs ``λ > 0`` or ``w = 0`` of the first solution (:func:`dc_point`'s, through
    ``A⁺``) are taken as conducting (``w = 0``), the others as blocking (``λ = 0``); each
    choice is one square linear system in ``(x, λ)``, solved scaled by rows and columns
    and refined. A conducting pair with ``λ < 0`` or a blocking one with ``w < 0`` changes
    side, the least index first (Murty's rule, which ends for a P-matrix LCP); at most
    ``4 (m + 1)`` systems. The point returned is checked (:func:`_holds`)."""
    n, m = A.shape[0], B.shape[1]
    w = C @ x + D @ lam + F @ u
    on = (lam > 0) | _on_bound(w, np.abs(C) @ np.abs(x) + np.abs(D) @ np.abs(lam)
                               + np.abs(F) @ np.abs(u))
    for _ in range(4 * (m + 1)):
        K = np.zeros((n + m, n + m))
        rhs = np.zeros(n + m)
        K[:n, :n], K[:n, n:], rhs[:n] = A, B, -(E @ u)
        K[n:, :n] = np.where(on[:, None], C, 0.0)
        K[n:, n:] = np.where(on[:, None], D, np.eye(m))
        rhs[n:] = np.where(on, -(F @ u), 0.0)
        r = np.abs(K).max(axis=1, initial=0.0)
        r = np.where(r > 0, r, 1.0)
        Ks = K / r[:, None]
        c = np.abs(Ks).max(axis=0, initial=0.0)
        c = np.where(c > 0, c, 1.0)
        Ks = Ks / c[None, :]
        try:
            z = np.linalg.solve(Ks, rhs / r)
            for _ in range(2):  # (iterative refinement)
                z = z + np.linalg.solve(Ks, rhs / r - Ks @ z)
        except np.linalg.LinAlgError:
            return None
        z = z / c
        x, lam = z[:n], z[n:]
        if not np.all(np.isfinite(z)):
            return None
        w = C @ x + D @ lam + F @ u
        w_size = np.abs(C) @ np.abs(x) + np.abs(D) @ np.abs(lam) + np.abs(F) @ np.abs(u)
        lam_tol = ON_BOUND * max(np.abs(lam).max(initial=0.0), 1e-300)
        bad = np.flatnonzero((on & (lam < -lam_tol))
                             | (~on & (w < -ON_BOUND * np.maximum(w_size, 1e-300))))
        if not bad.size:
            lam = np.where(on, np.maximum(lam, 0.0), 0.0)
            return (x, lam) if _holds(A, B, C, D, E, F, x, lam, u) else None
        on[bad[0]] = not on[bad[0]]
    return None


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
    M = _zero_round_off(M, M_size)
    q_size = (c_rows * (np.abs(x_null).max(initial=0.0) + ka * np.abs(E @ u).max(initial=0.0))
              + np.abs(F) @ np.abs(u))
    q = _zero_round_off(q, q_size)
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
    # that blocks would read as an inconsistent start), beside the drive's terms, not what
    # is left of them (a pwl diode's λ = Vf cancelling its source: 1e-16 of 0.8 V). (Beside
    # the largest entry of A⁺: where A is ill-conditioned that zeroes true values too, a
    # 6.1 mV gate-drain voltage beside 2.7e10; the point then fails its check, and
    # dc_point solves it again with the diodes' pairs as equations)
    drive_size = np.abs(B) @ np.abs(lam) + np.abs(E) @ np.abs(u)
    x_size = np.abs(x_null).max(initial=0.0) + ka * drive_size.max(initial=0.0)
    return (_zero_round_off(x, x_size), lam,
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
    S = np.flatnonzero(_on_bound(lcp.w, w_size))
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
        t, unreached = _bounded_least_squares(dv, v, G, h, scale)
        if t is not None:
            x = x - KB[:, S] @ (Kd @ t)
            lam[S] = np.maximum(lam[S] + Kd @ t, 0.0)
            w[N] = w[N] + lcp.M[np.ix_(N, S)] @ (Kd @ t)
        return Kd @ unreached

    if leaks is not None and leaks[0].size:
        Cl, Dl, Fl = leaks
        dv = -Cl @ (KB[:, S] @ K) + Dl[:, S] @ K
        K = move(K, dv, Cl @ x + Dl @ lam + Fl @ u, float(np.linalg.norm(np.hstack([Cl, Dl]), 2)))
    if K.size:
        move(K, K, lam[S], 1.0)  # (K's columns are orthonormal: every one reached)
    # still a solution of the LCP (else the point as first solved)
    w = lcp.M @ lam + (lcp.w - lcp.M @ lam_in)
    if not _is_lcp_solution(lam, w, lcp.M_size @ np.abs(lam) + w_size):
        return x_in, lam_in
    return x, lam


# ngspice's GMIN (1e-12 S) across every diode, as a leak's weight sqrt(conductance): the
# diodes' leaks beside the open switches' 1/sqrt(ROFF)
_DIODE_LEAK = 1e-6


def _bounded_least_squares(dv: np.ndarray, v: np.ndarray, G: np.ndarray, h: np.ndarray,
                           scale: float) -> tuple[np.ndarray | None, np.ndarray]:
    """A ``t`` of least ``|v + dv t|^2`` with ``G t >= h`` (None when no ``t`` keeps the
    bounds), and a basis of the directions ``dv`` does not reach (:func:`_reach`), along
    which every such ``t`` moved keeps ``dv t`` (the least squares' residual is unique).

    Along directions ``dv`` does not reach the QP is only semidefinite, and a bound may need
    a move along them to hold: its KKT conditions with ``t = t+ - t-`` are the monotone LCP
    ``H t + g - G^T μ = 0``, ``0 <= G t - h ⊥ μ >= 0`` (``H = dv^T dv``, ``g = dv^T v``, both
    over ``scale^2``), which Lemke's method solves whenever the bounds can hold."""
    k = dv.shape[1]
    U, s, VT, r = _reach(dv, scale)
    # in the coordinates t = T y of dv's singular directions, each reached one scaled by its
    # singular value (H = diag(1, .., 0, ..)): the least squares then has one size whatever
    # the units of t's components (a state's move in volts beside a multiplier in amperes
    # through a segment of 5.5 MΩ, which left H at 1e-15 of the bounds' entries, below
    # Lemke's pivot tolerance, and the least squares unsolved)
    T = np.hstack([VT[:r].T / s[:r], VT[r:].T])
    H = np.zeros((k, k))
    H[np.arange(r), np.arange(r)] = 1.0
    g = np.concatenate([U[:, :r].T @ v, np.zeros(k - r)])
    GT = G @ T
    # (each bound scaled to its largest entry: the same bound)
    gsize = np.abs(GT).max(axis=1, initial=0.0)
    gsize = np.where(gsize > 0, gsize, 1.0)
    GT, h = GT / gsize[:, None], h / gsize
    b = G.shape[0]
    Mq = np.block([[H, -H, -GT.T], [-H, H, GT.T], [GT, -GT, np.zeros((b, b))]])
    res = solve_lcp(Mq, np.concatenate([g, -g, -h]))
    if not res.ok:
        return None, VT[r:].T
    return T @ (res.z[:k] - res.z[k:2 * k]), VT[r:].T


def _leak_balanced(A, B, C, D, E, F, u, x0, lcp, rtol, leaks, Lb, Le, null, KA, Bs,
                   offsets=None) -> DcPoint | None:
    """The operating point where diodes act on states that no DC equation sets (a
    capacitor that only diodes charge), as ngspice's diode leakage sets it; None where this
    cannot be made exact.

    At DC no current enters those states: ``Lb λ + Le = 0`` (``Lb``, ``Le``: the DC
    equations' combinations that ``A`` cannot satisfy, applied to ``B`` and ``E u``). Where
    ``Le = 0`` and some combination of them has every acting pair's entry positive, that
    holds only with the acting pairs ``J`` at ``λ_J = 0``; else (a current in one acting
    diode could balance another's) ``λ_J = 0`` is tried as one of the points. The point
    without them (the rest's operating point) then leaves the free states anywhere their
    ``w_J >= 0``. The
    diodes' leakage (GMIN beside the open switches' ROFF) takes the least weighted sum of
    squares of ``w_J`` and of the switches' voltages over the states, and the rest's sets
    of LCP solutions, that keep every bound (a diode from 10 V into a capacitor: ``w = v_C -
    10 >= 0``, least at ``v_C = 10 V``; a forward-biased diode is held at ``w = 0``, as
    its exponential holds it); then the least multipliers, as in :func:`_along_lcp`. The
    search keeps the rest's pairs as its LCP solution has them (those at ``w = 0`` stay
    there, the others do not conduct): a balance that would need another of them to
    conduct is not found, and the note stays. The point found is checked against the DC
    equations and the LCP (else None).
    """
    m = B.shape[1]
    cols = np.abs(Lb).max(axis=0, initial=0.0)
    J = np.flatnonzero(cols > rtol * max(np.abs(Bs).max(initial=0.0), 1.0))
    R = np.setdiff1d(np.arange(m), J)
    lam_J = np.zeros(J.size)
    if np.abs(Le).max(initial=0.0) > rtol * max(np.abs(Lb).max(initial=0.0),
                                                np.abs(E @ u).max(initial=0.0), 1.0):
        # a source drives the free combination: the acting pairs' multipliers must take it
        # (an inductor whose only path is a blocking diode, held 8 V from its source: that
        # diode's λ = 8 V, and w = i_L = 0 where λ > 0); where they set them and none is
        # negative, the rest's point with those multipliers as inputs. Where they leave a
        # choice (two diodes in series on that inductor share its 8 V), the least
        # multipliers: ngspice splits the voltage by the junctions' leakage, alike for
        # alike junctions (GMIN across each); the point found is checked as every other
        lam_J = np.linalg.lstsq(Lb[:, J], -Le, rcond=None)[0]
        # (the free combinations' DC equations Lb_J λ_J + Le = 0, with λ_J for x)
        if (not _dc_holds(Lb[:, J], np.zeros((Le.size, 0)), Le[:, None], lam_J, np.zeros(0),
                          np.ones(1))
                or np.any(lam_J < -ON_BOUND * np.abs(lam_J).max())):
            return None
        lam_J = np.maximum(lam_J, 0.0)
    # (else λ_J = 0: where a current in one acting diode could balance another's, a bridge
    # whose floating source only diodes join to the rest, λ_J = 0 is one point among others
    # that may be, and is taken where the search below finds every bound kept with it: the
    # point is checked as every other, and ngspice's leakage, at a source of 0 V, leaves no
    # current in the bridge's diodes either)
    sub = dc_point(A, B[:, R], C[R], D[np.ix_(R, R)], np.hstack([E, B[:, J]]),
                   np.hstack([F[R], D[np.ix_(R, J)]]), np.concatenate([u, lam_J]), x0, lcp,
                   rtol, leaks if leaks is None else
                   (leaks[0], leaks[1][:, R], np.hstack([leaks[2], leaks[1][:, J]])),
                   None if offsets is None else
                   np.hstack([offsets[R], np.zeros((R.size, J.size), bool)]))
    if not sub.ok:
        return None
    x, lam = sub.x.copy(), np.zeros(m)
    lam[R] = sub.lam
    lam[J] = lam_J
    KB = KA @ Bs
    Mf = D - C @ KB
    w = C @ x + D @ lam + F @ u
    w_size = np.abs(C) @ np.abs(x) + np.abs(D) @ np.abs(lam) + np.abs(F) @ np.abs(u)
    S = R[_on_bound(w[R], w_size[R])]
    N = np.setdiff1d(np.arange(m), S)
    # the moves (dz along the null space, dλ_S) that keep w_S = 0
    Q = np.hstack([C[S] @ null, Mf[np.ix_(S, S)]])
    nz = null.shape[1]
    if Q.size:
        rows = np.abs(Q).max(axis=1, initial=0.0)
        Q = Q / np.where(rows > 0, rows, 1.0)[:, None]
        _, sq, Qt = np.linalg.svd(Q)
        rank = int(np.sum(sq > 1e-9 * max(float(sq[0]) if sq.size else 0.0, 1e-300)))
        K = Qt[rank:].T
    else:
        K = np.eye(nz + S.size)
    Kz, Kl = K[:nz], K[nz:]
    dx = null @ Kz - KB[:, S] @ Kl
    dw = C @ null @ Kz + Mf[:, S] @ Kl
    rows_v = [_DIODE_LEAK * dw[J]]
    # (across each junction: w less the diode's own offsets, its pwl Vf, which the leak's
    # conductance, GMIN across ngspice's junction, does not see)
    w_junction = w[J] if offsets is None else w[J] - (F[J] * offsets[J]) @ u
    v = [_DIODE_LEAK * w_junction]
    scale = _DIODE_LEAK * float(np.linalg.norm(np.hstack([C[J], D[J]]), 2))
    if leaks is not None and leaks[0].size:
        Cl, Dl, Fl = leaks
        rows_v.append(Cl @ dx + Dl[:, S] @ Kl)
        v.append(Cl @ x + Dl @ lam + Fl @ u)
        scale = max(scale, float(np.linalg.norm(np.hstack([Cl, Dl]), 2)))
    dv, vv = np.vstack(rows_v), np.concatenate(v)
    # bounds: λ_S + Kl t >= 0, w_N + dw_N t >= 0
    G = np.vstack([Kl, dw[N]])
    h = -np.concatenate([lam[S], w[N]])
    t, rest = _bounded_least_squares(dv, vv, G, h, scale)
    if t is None:
        return None
    # then, in the directions no leak reaches, the least multipliers (as in _along_lcp),
    # and what is left the least move from the rest's point (what the initial conditions
    # kept there stays, where the bounds let it)
    for stage, (target, now) in enumerate(((Kl, lam[S]), (np.eye(t.size), np.zeros(t.size)))):
        if stage == 1:
            free_dirs = rest  # (before the least move: the directions nothing sets)
        if not rest.size:
            continue
        # (the bounds as the move so far keeps them: one it keeps only to round-off, a
        # diode's w of -1.6e-11 V beside 0.66 V, is kept from getting worse, not asked to
        # become exact along directions that may not reach it)
        dt, unreached = _bounded_least_squares(target @ rest, now + target @ t, G @ rest,
                                               np.minimum(h - G @ t, 0.0), 1.0)
        if dt is None:
            return None
        t, rest = t + rest @ dt, rest @ unreached
    # (the round-off of the move made zero, as in _solve: i_L = 1.8 A - 1.8 A = 2e-16 A
    # through a diode the source holds reverse-biased would read as conducting)
    x = _zero_round_off(x + dx @ t, np.abs(x) + np.abs(dx) @ np.abs(t))
    lam = lam.copy()
    lam[S] = lam[S] + Kl @ t
    lam = _zero_round_off(lam, max(np.abs(lam).max(initial=0.0), 1e-300))
    # the point is checked, not assumed: DC equations, bounds and complementarity
    w = C @ x + D @ lam + F @ u
    w_size = np.abs(C) @ np.abs(x) + np.abs(D) @ np.abs(lam) + np.abs(F) @ np.abs(u)
    if not (_is_lcp_solution(lam, w, w_size) and _dc_holds(A, B, E, x, lam, u)):
        return None
    free = np.abs(dx @ free_dirs).max(axis=1, initial=0.0) > 1e-9
    return DcPoint(True, x, np.maximum(lam, 0.0), free)
