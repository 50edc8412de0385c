"""Passivity of an LCS: the Kalman–Yakubovich–Popov (positive-real) test with a certificate.

An LCS ``x' = A x + B λ + E u``, ``w = C x + D λ + F u`` (u = 0 here: E and F play no part)
is *passive* when a storage ``V(x) = ½ x' K x`` with ``K = K' > 0`` exists such that
``dV/dt <= w'λ`` along every motion, i.e. (the KYP / positive-real lemma)::

    M(K) = [[A'K + KA,  KB - C'],
            [B'K - C,  -(D + D')]]  <= 0,        K = K' > 0.

For a circuit, λ'w is the power the network delivers to the ideal diodes and the circuit's
energy ``K = blkdiag(L, diag(C))`` (inductance matrix, capacitances) is a certificate whenever
all resistors are non-negative and there is no active element. That candidate is tried first
(``energy=``), as is any explicitly given ``K=``.

General solve: why a semidefinite program
-----------------------------------------
Without a candidate we search for K with a small semidefinite program (cvxpy with the Clarabel
interior-point solver, SCS as fallback). The alternatives were considered and rejected:

* A Riccati/Hamiltonian test (positive-real lemma via the ARE) needs D + D' > 0. Circuits
  almost always have D = 0 or a singular D + D', which calls for the iterative
  feedthrough-reduction algorithms (Anderson–Vongpanitlerd); and for lossless parts (an LC
  tank: Hamiltonian eigenvalues on the imaginary axis) no stabilising ARE solution exists, so
  the numerical ARE solvers fail exactly on the cases circuits produce most.
* Frequency-domain positive-realness of ``C (sI - A)^-1 B + D`` says nothing about
  uncontrollable or unobservable parts, which may be unstable or force K to be singular; it
  also gives no certificate.

The LMI handles all of this uniformly and returns a certificate that we then *verify* with an
exact eigenvalue test; the solver's word is never the decision. Two exact refinements make it
robust for circuits:

1. The null space N of D + D' is split off: on it the LMI forces ``K B N = C' N`` exactly
   (the (2,2) block is zero there), so these are imposed as equality constraints and the LMI
   keeps only the range part of λ. After solving, K is projected (least squares, minimum norm
   change) onto these equalities so that they hold to rounding error.
2. The data are rescaled before solving (see ``_normalise``): a diagonal state scaling chosen
   so that ``K`` is close to the identity for energy-like certificates, a time scaling
   ``τ = ω t`` with ``ω = ‖T^-1 A T‖``, and a positive diagonal pair scaling
   ``λ = S λ~, w~ = S w`` (which keeps complementarity and the supply ``w'λ``). Together these
   form a congruence ``M~ = diag(T, S) M(K) diag(T, S)`` with ``K~ = ω T K T``, so the sign of
   every eigenvalue is unchanged; microhenries and millifarads then give O(1) data.

The SDP is solved in stages: (a) minimise s subject to ``M(K) <= s I``, ``0 <= K <= κ I``
(s* <= 0 means a storage K >= 0 exists), then (b) maximise t subject to ``M(K) <= s_a I``,
``t I <= K <= κ I`` with ``s_a = max(s*, 0)`` plus a tiny slack, which finds how positive
definite a certificate can be (``t* ≈ 0`` means every storage is singular along some state
direction, which is reported), and (c) minimise s subject to ``M(K) <= s I``,
``t*/2 I <= K <= κ I``: stage (b) ends where the residual equals the slack, stage (c) moves
K back into the middle of lossless faces. Both are then snapped onto the face of the LMI they
nearly touch (``_face_polish``: the eigenvectors of M(K) with eigenvalues near zero must stay
exact null directions, a linear condition on K; minimum-change solution), which restores full
accuracy when the solver's sqrt(tolerance) accuracy on faces without interior is not enough.
The best verified candidate is returned.

Cheap exact necessary conditions run first and give the human readable reasons for the usual
failures (each is a consequence of ``M(K) <= 0, K > 0``):

* ``D + D' >= 0`` (otherwise the diode ports generate energy at λ alone);
* every eigenvalue of A has ``Re <= 0`` (``A'K + KA <= 0`` with ``K > 0`` is Lyapunov
  stability) — a negative resistance shows up here;
* ``K B N = C' N`` must have a symmetric solution and ``N' C B N`` must be symmetric positive
  semidefinite (it equals ``N' B' K B N``);
* positive realness ``G(jω) + G(jω)^H >= 0`` on a frequency grid.

Tolerances
----------
All decisions are taken in the normalised coordinates, where the data have norm about one:

* ``rtol`` (default 1e-7): the KYP matrix is measured in the metric of K itself,
  ``M^ = W M~ W`` with ``W = blkdiag(K~^-1/2, I)`` (top-left block ``Â + Â'``,
  ``Â = K~^1/2 A~ K~^-1/2``), and the test passes when ``λ_max(M^) <= rtol · scale`` with
  ``scale = 2‖Â‖ + ‖K~^1/2 B~‖ + ‖K~^-1/2 C~'‖ + 2‖D~‖``. The reported ``margin`` is
  ``-λ_max(M^) / scale``: 0 for lossless parts or D = 0, positive for strictly passive ones.
  Measuring in the K metric matters: with a plain norm a problem that is only feasible in the
  limit ``K -> ∞`` would pass as ‖K‖ grows.
* ``ktol`` (default 1e-9): K counts as positive definite when
  ``λ_min(K~) > ktol · λ_max(K~)``; the reported ``k_margin`` is that ratio.
* The SDP bounds ``K~ <= κ I`` with κ = 1e4 (energy-like certificates are about I after the
  normalisation), so a system whose certificates all have a normalised condition number
  beyond about 1e4, or that is passive only in the limit, is reported not passive, with the
  direction along which K would have to grow.
* Eigenvalues of D~ + D~' below ``1e-10 · max(1, ‖D~ + D~'‖)`` in modulus count as zero.
* Re λ(A~) > 1e-6 fails the stability condition (‖A~‖ = 1; eigenvalues of Jordan blocks on the
  imaginary axis carry errors of order sqrt(machine epsilon)).
* Positive realness fails when ``λ_min(G~ + G~^H) < -1e-6 · max(1, ‖G~‖)`` at some grid
  frequency (401 points, ω~ from 1e-4 to 1e4, skipping the imaginary-axis poles).

Exact candidates (energy matrices) pass at rounding level; SDP certificates after face
polishing typically reach margins of 1e-10 or better.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from lcs.model import LCS


def _block_diag(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    # scipy.linalg.block_diag of two blocks, without importing scipy (0.2 s) on the
    # simulate path, where the non-passivity screen runs.
    a, b = np.atleast_2d(a), np.atleast_2d(b)
    out = np.zeros((a.shape[0] + b.shape[0], a.shape[1] + b.shape[1]))
    out[:a.shape[0], :a.shape[1]] = a
    out[a.shape[0]:, a.shape[1]:] = b
    return out

__all__ = ["PassivityReport", "check_passivity", "kyp_matrix", "energy_matrix"]

# Relative threshold below which an eigenvalue of the normalised D + D' counts as zero.
_NULL_RTOL = 1e-10
# Re λ(A~) above this (with ‖A~‖ = 1) means an unstable mode.
_EIG_TOL = 1e-6
# Upper bound on the normalised certificate in the SDP (keeps the problem bounded).
_KAPPA = 1e4
# Slack added to stage (a)'s optimum in stage (b), relative to the normalised data.
_STAGE_SLACK = 1e-12
# Tight interior-point tolerances: on lossless faces (no interior) a residual δ in the LMI lets
# K drift by about sqrt(δ), so the certificate's accuracy is the square root of these.
_SOLVER_OPTIONS = {
    "CLARABEL": {"tol_gap_abs": 1e-12, "tol_gap_rel": 1e-12, "tol_feas": 1e-12,
                 "tol_ktratio": 1e-10, "max_iter": 400},
    "SCS": {"eps_abs": 1e-10, "eps_rel": 1e-10, "max_iters": 200000},
}


@dataclass
class PassivityReport:
    """Result of :func:`check_passivity`.

    Attributes
    ----------
    passive : bool
        True when a certificate ``K = K' > 0`` with ``M(K) <= 0`` was found and verified.
    K : ndarray (n, n) or None
        The certificate in the LCS's own units (storage ``½ x' K x`` in joules when states
        are amperes and volts); None when not passive.
    margin : float
        ``-λ_max(M~) / scale`` in normalised coordinates (see module docstring): >= -rtol when
        passive, 0 for lossless parts or D = 0, negative when the KYP inequality fails.
        ``nan`` when no candidate K was evaluated.
    k_margin : float
        ``λ_min(K~) / λ_max(K~)`` of the (normalised) certificate; ``nan`` if none.
    method : str
        ``"given"`` (the ``K=`` argument), ``"energy"`` (the ``energy=`` candidate), ``"lmi"``
        (semidefinite program) or ``"necessary-condition"`` (an exact necessary condition
        failed, no search needed).
    reason : str
        Human readable explanation, naming states and pairs.
    names : tuple of str
        State names, the row/column order of K.
    pairs : tuple of str
        Pair (diode) names.
    attempts : list of str
        What was tried, in order, and why each failed.
    """

    passive: bool
    K: np.ndarray | None
    margin: float
    k_margin: float
    method: str
    reason: str
    names: tuple[str, ...]
    pairs: tuple[str, ...] = ()
    attempts: list[str] = field(default_factory=list)


def energy_matrix(inductance: np.ndarray, capacitances) -> np.ndarray:
    """The circuit energy matrix ``blkdiag(L, diag(C))``.

    Parameters
    ----------
    inductance : ndarray (nL, nL)
        Inductance matrix (H), symmetric (mutual inductances off the diagonal).
    capacitances : array_like (nC,)
        Capacitances (F).

    Returns
    -------
    ndarray (nL + nC, nL + nC)
        The matrix K with stored energy ``½ x' K x`` (J) for ``x = [i(L); v(C)]``.
    """
    Lm = np.atleast_2d(np.asarray(inductance, dtype=float))
    if Lm.size == 0:
        Lm = np.zeros((0, 0))
    return _block_diag(Lm, np.diag(np.atleast_1d(np.asarray(capacitances, dtype=float))))


def kyp_matrix(A, B, C, D, K) -> np.ndarray:
    """The KYP matrix ``[[A'K + KA, KB - C'], [B'K - C, -(D + D')]]``, shape (n+m, n+m)."""
    A, B, C, D, K = (np.asarray(a, dtype=float) for a in (A, B, C, D, K))
    top = np.hstack([A.T @ K + K @ A, K @ B - C.T])
    bottom = np.hstack([B.T @ K - C, -(D + D.T)])
    M = np.vstack([top, bottom])
    return 0.5 * (M + M.T)


# --------------------------------------------------------------------------------------------
# Normalisation


@dataclass(frozen=True)
class _Normalised:
    """The rescaled data: x = T z, λ = S λ~, w~ = S w, τ = ω t (T, S diagonal, as vectors)."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    T: np.ndarray  # (n,)
    S: np.ndarray  # (m,)
    omega: float

    def to_normalised_K(self, K: np.ndarray) -> np.ndarray:
        """K~ = ω T K T."""
        return self.omega * (self.T[:, None] * K * self.T[None, :])

    def from_normalised_K(self, Kt: np.ndarray) -> np.ndarray:
        """K = T^-1 K~ T^-1 / ω."""
        return Kt / (self.omega * self.T[:, None] * self.T[None, :])


def _normalise(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray) -> _Normalised:
    """Choose a diagonal state scaling, a time scale and a pair scaling (see module docstring).

    State weights: for a state i that both receives a diode current (row i of B) and is seen
    by a diode (column i of C), an energy-like certificate has ``K_ii B_ij ≈ C_ji``, so
    ``k_i = ‖C[:, i]‖ / ‖B[i, :]‖`` estimates ``K_ii`` (C for a capacitor voltage, L for an
    inductor current) and ``T_i = k_i^-1/2`` makes it about one. The remaining states are
    balanced against them by Osborne iterations on A (row and column norms equal).
    """
    n, m = A.shape[0], B.shape[1]
    logt = np.zeros(n)
    fixed = np.zeros(n, dtype=bool)
    for i in range(n):
        bn, cn = np.linalg.norm(B[i, :]), np.linalg.norm(C[:, i])
        if bn > 0 and cn > 0:
            logt[i] = -0.5 * np.log(cn / bn)
            fixed[i] = True
    if n and not fixed.all():
        # States the diodes do not touch start at the mean weight of those they do (same
        # physical units, no better information); Osborne sweeps then balance any coupling.
        logt[~fixed] = np.mean(logt[fixed]) if fixed.any() else 0.0
        off = np.abs(A) - np.diag(np.abs(np.diag(A)))
        for _ in range(20):
            changed = False
            for i in np.flatnonzero(~fixed):
                t = np.exp(logt)
                # Ã_ij = A_ij t_j / t_i: row i scales with 1/t_i, column i with t_i.
                r = np.linalg.norm(off[i, :] * t) / t[i]
                c = np.linalg.norm(off[:, i] / t) * t[i]
                if r > 0 and c > 0:
                    step = 0.5 * np.log(r / c)
                    if abs(step) > 1e-3:
                        logt[i] += step
                        changed = True
            if not changed:
                break
    # With energy-like weights T K T ≈ I already; otherwise only relative scales are known.
    T = np.exp(logt if fixed.any() or not n else logt - np.mean(logt))
    At = A * T[None, :] / T[:, None]
    omega = float(np.linalg.norm(At, 2)) if n else 1.0
    if not np.isfinite(omega) or omega <= 0:
        omega = 1.0
    # Scalar τ on T so that an energy-like K~ = ω τ² T K T is about one (T K T ≈ I above).
    T = T / np.sqrt(omega)
    At = At / omega
    Bt0 = (B / T[:, None]) / omega
    Ct0 = C * T[None, :]
    S = np.ones(m)
    for j in range(m):
        bn, cn = np.linalg.norm(Bt0[:, j]), np.linalg.norm(Ct0[j, :])
        if bn > 0 and cn > 0:
            S[j] = 1.0 / np.sqrt(bn * cn)
        elif bn > 0 or cn > 0:
            S[j] = 1.0 / max(bn, cn)
        elif D[j, j] != 0:
            S[j] = 1.0 / np.sqrt(abs(D[j, j]))
    Bt = Bt0 * S[None, :]
    Ct = Ct0 * S[:, None]
    Dt = S[:, None] * D * S[None, :]
    return _Normalised(At, Bt, Ct, Dt, T, S, omega)


# --------------------------------------------------------------------------------------------
# Helpers


def _fmt_vector(v: np.ndarray, names, tol: float = 1e-3) -> str:
    """Format a direction as ``name: coeff`` for its significant entries (largest = ±1)."""
    v = np.real_if_close(np.asarray(v))
    if np.iscomplexobj(v):
        v = np.abs(v)
    big = np.max(np.abs(v)) if v.size else 0.0
    if big == 0:
        return "0"
    v = v / v[np.argmax(np.abs(v))]
    parts = [f"{nm}: {c:+.3g}" for nm, c in zip(names, v, strict=False) if abs(c) > tol]
    return "{" + ", ".join(parts) + "}"


def _verify(nz: _Normalised, Kt: np.ndarray, rtol: float, ktol: float):
    """Exact check of a normalised candidate K~.

    The KYP matrix is measured in the metric of K itself: with ``W = blkdiag(K~^-1/2, I)``,
    ``M^ = W M~ W`` has top-left block ``Â + Â'`` (``Â = K~^1/2 A~ K~^-1/2``) and off-diagonal
    ``K~^1/2 B~ - K~^-1/2 C~'``. Its largest eigenvalue relative to
    ``scale = 2‖Â‖ + ‖K~^1/2 B~‖ + ‖K~^-1/2 C~'‖ + 2‖D~‖`` does not shrink when K grows, so a
    problem that is only feasible in the limit ``K -> ∞`` is not accepted.

    Returns
    -------
    ok, margin, k_margin, worst, ok_kyp, ok_k
        ``worst`` is the eigenvector of the largest eigenvalue in normalised (x~, λ~)
        coordinates.
    """
    Kt = 0.5 * (Kt + Kt.T)
    n, m = nz.A.shape[0], nz.B.shape[1]
    M = kyp_matrix(nz.A, nz.B, nz.C, nz.D, Kt)
    if n:
        kev, kvec = np.linalg.eigh(Kt)
        k_margin = float(kev[0] / kev[-1]) if kev[-1] > 0 else float(kev[0])
    else:
        kev, kvec, k_margin = np.zeros(0), np.zeros((0, 0)), 1.0
    if n and kev[0] > 0:
        Kh = (kvec * np.sqrt(kev)) @ kvec.T
        Khi = (kvec / np.sqrt(kev)) @ kvec.T
        W = _block_diag(Khi, np.eye(m))
        Mh = W @ M @ W
        Ah = Kh @ nz.A @ Khi
        scale = (2 * np.linalg.norm(Ah, 2) + np.linalg.norm(Kh @ nz.B, 2)
                 + np.linalg.norm(Khi @ nz.C.T, 2) + 2 * np.linalg.norm(nz.D, 2))
    else:
        W = np.eye(n + m)
        Mh = M
        scale = (np.linalg.norm(Kt, 2) * (2 * np.linalg.norm(nz.A, 2) + np.linalg.norm(nz.B, 2))
                 + np.linalg.norm(nz.C, 2) + 2 * np.linalg.norm(nz.D, 2))
    scale = max(float(scale), 1e-300)
    if Mh.size:
        ev, evec = np.linalg.eigh(0.5 * (Mh + Mh.T))
        margin = float(-ev[-1] / scale)
        worst = W @ evec[:, -1]
    else:
        margin, worst = 0.0, np.zeros(0)
    ok_kyp = margin >= -rtol
    ok_k = k_margin > ktol
    return ok_kyp and ok_k, margin, k_margin, worst, ok_kyp, ok_k


def _describe_kyp_failure(nz: _Normalised, worst: np.ndarray, states, pairs) -> str:
    n = len(states)
    x = nz.T * worst[:n]
    lam = nz.S * worst[n:]
    text = "dissipation inequality dV/dt <= w'λ fails along x ~ " + _fmt_vector(x, states)
    if lam.size and np.max(np.abs(lam)) > 1e-3 * max(np.max(np.abs(worst)), 1e-300):
        text += ", λ ~ " + _fmt_vector(lam, pairs)
    return text


def _split_dd(nz: _Normalised):
    """Orthonormal bases of range and null space of D~ + D~', and its eigenvalues."""
    m = nz.D.shape[0]
    if m == 0:
        return np.zeros((0, 0)), np.zeros((0, 0)), np.zeros(0), np.zeros((0, 0))
    Ds = nz.D + nz.D.T
    ev, V = np.linalg.eigh(Ds)
    tol = _NULL_RTOL * max(1.0, float(np.max(np.abs(ev))))
    rng = ev > tol
    null = np.abs(ev) <= tol
    return V[:, rng], V[:, null], ev, V


def _sym_basis(n: int) -> list[np.ndarray]:
    basis = []
    for i in range(n):
        for j in range(i, n):
            E = np.zeros((n, n))
            E[i, j] = E[j, i] = 1.0
            basis.append(E)
    return basis


def _equality_system(nz: _Normalised, N: np.ndarray):
    """Linear system ``G vec_s(K) = h`` for ``K B N = C' N`` over symmetric K."""
    n = nz.A.shape[0]
    basis = _sym_basis(n)
    BN = nz.B @ N
    target = (nz.C.T @ N).ravel()
    G = np.column_stack([(E @ BN).ravel() for E in basis]) if basis else np.zeros((0, 0))
    return G, target, basis


def _project_equalities(nz: _Normalised, N: np.ndarray, Kt: np.ndarray) -> np.ndarray:
    """Minimum-norm symmetric correction of K~ so that ``K~ B~ N = C~' N`` holds exactly."""
    if N.shape[1] == 0 or Kt.size == 0:
        return Kt
    G, h, basis = _equality_system(nz, N)
    if G.size == 0:
        return Kt
    r = h - G @ np.array([Kt[i, j] for i in range(Kt.shape[0]) for j in range(i, Kt.shape[0])])
    # Weight off-diagonal coordinates by √2 so the correction is Frobenius-minimal.
    n = Kt.shape[0]
    w = np.array([1.0 if i == j else np.sqrt(2.0) for i in range(n) for j in range(i, n)])
    dy, *_ = np.linalg.lstsq(G / w[None, :], r, rcond=None)
    dk = dy / w
    return Kt + sum(c * E for c, E in zip(dk, basis, strict=True))


def _face_polish(nz: _Normalised, N: np.ndarray, K0: np.ndarray, rtol: float,
                 ktol: float) -> np.ndarray:
    """Snap an SDP certificate onto the face of the LMI it (nearly) touches.

    Interior-point solutions on a face without interior (lossless parts, D = 0) are accurate
    only to about the square root of the solver tolerance. The eigenvectors V0 of M(K0) with
    eigenvalues near zero span the directions where the dissipation inequality is (nearly)
    tight; we impose ``V0' M(K) V0 = 0`` (linear in K) and take the minimum-change K. Several
    thresholds for "near zero" are tried; the best verified candidate (K0 included) wins.
    """
    n = nz.A.shape[0]
    if n == 0:
        return K0
    basis = _sym_basis(n)
    zero_K = np.zeros((n, n))
    M_const = kyp_matrix(nz.A, nz.B, nz.C, nz.D, zero_K)
    lin = [kyp_matrix(nz.A, nz.B, nz.C, nz.D, E) - M_const for E in basis]
    wts = np.array([1.0 if i == j else np.sqrt(2.0) for i in range(n) for j in range(i, n)])
    y0 = np.array([K0[i, j] for i in range(n) for j in range(i, n)])
    M0 = kyp_matrix(nz.A, nz.B, nz.C, nz.D, K0)
    ev, V = np.linalg.eigh(M0)
    scale = max(1.0, float(np.max(np.abs(ev))))
    best, best_margin = K0, _verify(nz, K0, rtol, ktol)[1]
    G_eq, h_eq = (None, None)
    if N.shape[1]:
        G_eq, h_eq, _ = _equality_system(nz, N)
    for delta in (1e-10, 1e-8, 1e-6, 1e-4, 1e-3):
        act = V[:, ev > -delta * scale]
        if act.shape[1] == 0:
            continue
        k = act.shape[1]
        rows, rhs = [], []
        for a in range(k):
            for b in range(a, k):
                va, vb = act[:, a], act[:, b]
                rows.append([va @ Li @ vb for Li in lin])
                rhs.append(-(va @ M_const @ vb))
        G = np.array(rows)
        h = np.array(rhs)
        if G_eq is not None:
            G = np.vstack([G, G_eq])
            h = np.concatenate([h, h_eq])
        Gw = G / wts[None, :]
        dy, *_ = np.linalg.lstsq(Gw, h - G @ y0, rcond=None)
        y = y0 + dy / wts
        Kc = sum(c * E for c, E in zip(y, basis, strict=True))
        margin = _verify(nz, Kc, rtol, ktol)[1]
        if margin > best_margin and np.linalg.eigvalsh(Kc)[0] > 0:
            best, best_margin = Kc, margin
    return best


# --------------------------------------------------------------------------------------------
# Necessary conditions


def _necessary_conditions(nz: _Normalised, lcs: LCS) -> str | None:
    """Return a reason string when an exact necessary condition fails, else None."""
    states, pairs = lcs.states, tuple(p.name for p in lcs.pairs)
    n, m = lcs.n, lcs.m
    R, N, ev, V = _split_dd(nz)
    if m:
        tol = _NULL_RTOL * max(1.0, float(np.max(np.abs(ev))))
        if ev[0] < -tol:
            direction = nz.S * V[:, 0]
            return (
                f"D + D' is not positive semidefinite: eigenvalue {ev[0]:.3g} (normalised) along "
                f"λ ~ {_fmt_vector(direction, pairs)}; the ports {{λ'w = λ'Dλ < 0}} generate "
                "energy"
            )
    if n:
        eig, evec = np.linalg.eig(nz.A)
        k = int(np.argmax(eig.real))
        if eig[k].real > _EIG_TOL:
            lam_phys = eig[k] * nz.omega
            direction = nz.T * np.abs(evec[:, k])
            return (
                f"A has an unstable eigenvalue {lam_phys:.4g} 1/s (Re > 0), mode ~ "
                f"{_fmt_vector(direction, states)}; a storage K > 0 with A'K + KA <= 0 would "
                "make A Lyapunov stable (negative resistance or active element?)"
            )
    if N.shape[1] and n:
        H = N.T @ nz.C @ nz.B @ N
        Hs = 0.5 * (H + H.T)
        hs = np.linalg.eigvalsh(Hs)
        scale = max(1.0, np.linalg.norm(H, 2))
        if hs[0] < -1e-9 * scale or np.linalg.norm(H - H.T, 2) > 1e-7 * scale:
            w_ev, w_vec = np.linalg.eigh(Hs)
            direction = nz.S * (N @ w_vec[:, 0])
            return (
                "on the null space of D + D' the relative-degree-one gain C B must equal "
                f"B'KB (symmetric, >= 0); it has eigenvalue {w_ev[0]:.3g} (normalised, "
                f"asymmetry {np.linalg.norm(H - H.T, 2):.3g}) along λ ~ "
                f"{_fmt_vector(direction, pairs)}"
            )
        G, h, _ = _equality_system(nz, N)
        sol, *_ = np.linalg.lstsq(G, h, rcond=None)
        res = np.linalg.norm(G @ sol - h)
        if res > 1e-7 * max(1.0, np.linalg.norm(h)):
            involved = [pairs[i] for i in np.flatnonzero(np.abs(N).sum(axis=1) > 1e-9)]
            return (
                "no symmetric K satisfies K B = C' on the null space of D + D' (pairs "
                f"{', '.join(involved)}): a diode sees a state combination that its current "
                f"does not act on in an energy-consistent way (residual {res:.3g})"
            )
    elif N.shape[1] and not n:
        # No states: K B N = C' N is vacuous, the LMI reduces to D + D' >= 0.
        pass
    if m:
        reason = _frequency_check(nz, pairs)
        if reason:
            return reason
    return None


def _frequency_check(nz: _Normalised, pairs) -> str | None:
    """Positive realness of G~(jω) = C~(jωI - A~)^-1 B~ + D~ on a logarithmic grid."""
    n = nz.A.shape[0]
    eig = np.linalg.eigvals(nz.A) if n else np.zeros(0)
    imag_poles = np.abs(eig.imag[np.abs(eig.real) < 1e-6])
    grid = np.concatenate([np.logspace(-4, 4, 401), [0.0]])
    worst = (0.0, None, None, 0.0)
    for wt in grid:
        if n and (
            (wt == 0 and np.any(np.abs(eig) < 1e-9))
            or np.any(np.abs(imag_poles - wt) < 1e-3 * max(wt, 1e-3))
        ):
            continue
        if n:
            G = nz.C @ np.linalg.solve(1j * wt * np.eye(n) - nz.A, nz.B) + nz.D
        else:
            G = nz.D.astype(complex)
        H = G + G.conj().T
        ev, vec = np.linalg.eigh(H)
        rel = ev[0] / max(1.0, np.linalg.norm(G, 2))
        if rel < worst[0]:
            worst = (rel, wt, vec[:, 0], ev[0])
    if worst[1] is not None and worst[0] < -1e-6:
        freq = worst[1] * nz.omega
        direction = nz.S * np.abs(worst[2])
        return (
            f"not positive real: G(jω) + G(jω)^H has eigenvalue {worst[3]:.3g} (normalised) at "
            f"ω = {freq:.4g} rad/s along λ ~ {_fmt_vector(direction, pairs)}"
        )
    return None


# --------------------------------------------------------------------------------------------
# The SDP


def _solve_lmi(nz: _Normalised, rtol: float, ktol: float):
    """Two-stage SDP; returns (K~ or None, stage-a value, dual direction, message)."""
    try:
        import cvxpy as cp
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(
            "the general passivity test needs cvxpy (pip install cvxpy); pass energy= or K= "
            "to check a candidate certificate without it"
        ) from exc

    n = nz.A.shape[0]
    R, N, _, _ = _split_dd(nz)
    r = R.shape[1]
    K = cp.Variable((n, n), symmetric=True)
    At, Bt, Ct, Dt = nz.A, nz.B, nz.C, nz.D
    blocks_top = [At.T @ K + K @ At]
    if r:
        BR, CR = Bt @ R, Ct.T @ R
        Srr = R.T @ (Dt + Dt.T) @ R
        blocks_top.append(K @ BR - CR)
        Mexpr = cp.bmat([blocks_top, [BR.T @ K - CR.T, -Srr]])
    else:
        Mexpr = blocks_top[0]
    Mexpr = 0.5 * (Mexpr + Mexpr.T)
    size = n + r
    eqs = []
    if N.shape[1]:
        eqs.append(K @ (Bt @ N) == Ct.T @ N)

    def solve(problem):
        for solver in ("CLARABEL", "SCS"):
            if solver not in cp.installed_solvers():
                continue
            try:
                with warnings.catch_warnings():
                    # "Solution may be inaccurate": we verify the certificate ourselves.
                    warnings.simplefilter("ignore", UserWarning)
                    problem.solve(solver=solver, **_SOLVER_OPTIONS.get(solver, {}))
            except cp.error.SolverError:
                continue
            if problem.status in ("optimal", "optimal_inaccurate"):
                return True
        return False

    s = cp.Variable()
    cons_a = [Mexpr << s * np.eye(size), K >> 0, K << _KAPPA * np.eye(n), *eqs]
    stage_a = cp.Problem(cp.Minimize(s), cons_a)
    if not solve(stage_a):
        return None, np.inf, None, f"stage (a) SDP status: {stage_a.status}"
    s_star = float(s.value)
    dual = cons_a[0].dual_value
    direction = None
    if dual is not None and np.size(dual):
        dv, dvec = np.linalg.eigh(0.5 * (dual + dual.T))
        direction = dvec[:, -1]
        if r:
            # Map the (x, λ_R) direction back to full λ coordinates.
            direction = np.concatenate([direction[:n], R @ direction[n:]])
    scale = 2 * np.linalg.norm(At, 2) + np.linalg.norm(Bt, 2) + np.linalg.norm(Ct, 2) + 1.0
    if s_star > rtol * scale:
        msg = f"no storage K >= 0 with λ_max(K~) <= {_KAPPA:g} (normalised)"
        return None, s_star, direction, msg
    t = cp.Variable()
    s_allow = max(s_star, 0.0) + _STAGE_SLACK * scale
    cons_b = [Mexpr << s_allow * np.eye(size), K >> t * np.eye(n), K << _KAPPA * np.eye(n), *eqs]
    stage_b = cp.Problem(cp.Maximize(t), cons_b)
    if not solve(stage_b) or K.value is None:
        return None, s_star, direction, f"stage (b) SDP status: {stage_b.status}"
    Kb = _project_equalities(nz, N, 0.5 * (K.value + K.value.T))
    # Stage (c): stage (b) pushes K to where the LMI residual equals the allowed slack; keep
    # half of its λ_min and minimise the residual instead, which centres K on lossless faces.
    t_keep = 0.5 * float(t.value)
    candidates = [Kb]
    if t_keep > 0:
        s_c = cp.Variable()
        cons_c = [Mexpr << s_c * np.eye(size), K >> t_keep * np.eye(n),
                  K << _KAPPA * np.eye(n), *eqs]
        if solve(cp.Problem(cp.Minimize(s_c), cons_c)) and K.value is not None:
            candidates.append(_project_equalities(nz, N, 0.5 * (K.value + K.value.T)))
    candidates = [_face_polish(nz, N, Kc, rtol, ktol) for Kc in candidates]
    best = max(candidates, key=lambda Kc: _verify(nz, Kc, rtol, ktol)[1])
    return best, s_star, direction, "ok"


# --------------------------------------------------------------------------------------------
# Public entry point


def check_passivity(
    lcs: LCS,
    K: np.ndarray | None = None,
    energy: np.ndarray | None = None,
    *,
    rtol: float = 1e-7,
    ktol: float = 1e-9,
    search: bool = True,
) -> PassivityReport:
    """Decide passivity of an LCS and return a verified certificate.

    Parameters
    ----------
    lcs : LCS
        The system; only A (n, n), B (n, m), C (m, n), D (m, m) matter (u = 0).
    K : ndarray (n, n), optional
        A candidate certificate to verify first (units of the LCS: J/A², J/V²...).
    energy : ndarray (n, n), optional
        The circuit's energy matrix ``blkdiag(L, diag(C))`` (see :func:`energy_matrix`),
        tried next.
    rtol : float
        Relative tolerance of the KYP eigenvalue test (see module docstring).
    ktol : float
        Relative tolerance for ``K > 0`` (``λ_min / λ_max`` of the normalised K).
    search : bool
        When False, stop after the candidates (and necessary conditions): no SDP.

    Returns
    -------
    PassivityReport
    """
    states = tuple(lcs.states)
    pairs = tuple(p.name for p in lcs.pairs)
    A, B, C, D = lcs.A, lcs.B, lcs.C, lcs.D
    nz = _normalise(A, B, C, D)
    attempts: list[str] = []
    last_margin, last_kmargin = float("nan"), float("nan")

    for label, cand in (("given", K), ("energy", energy)):
        if cand is None:
            continue
        cand = np.asarray(cand, dtype=float)
        if cand.shape != (lcs.n, lcs.n):
            raise ValueError(f"{label} matrix must be {lcs.n}x{lcs.n}, got {cand.shape}")
        if not np.allclose(cand, cand.T, rtol=1e-12, atol=0.0):
            attempts.append(f"{label}: not symmetric")
            cand = 0.5 * (cand + cand.T)
        Kt = nz.to_normalised_K(cand)
        ok, margin, k_margin, worst, ok_kyp, ok_k = _verify(nz, Kt, rtol, ktol)
        last_margin, last_kmargin = margin, k_margin
        if ok:
            return PassivityReport(
                True, 0.5 * (cand + cand.T), margin, k_margin, label,
                f"{label} matrix is a storage certificate (KYP margin {margin:.3g})",
                states, pairs, attempts,
            )
        why = []
        if not ok_kyp:
            why.append(f"KYP margin {margin:.3g} < -{rtol:g}; "
                       + _describe_kyp_failure(nz, worst, states, pairs))
        if not ok_k:
            kev, kvec = np.linalg.eigh(0.5 * (Kt + Kt.T))
            why.append(f"not positive definite (λ_min/λ_max = {k_margin:.3g}) along "
                       + _fmt_vector(nz.T * kvec[:, 0], states))
        attempts.append(f"{label} matrix fails: " + "; ".join(why))

    reason = _necessary_conditions(nz, lcs)
    if reason is not None:
        attempts.append("necessary condition: " + reason)
        return PassivityReport(
            False, None, last_margin, last_kmargin, "necessary-condition", reason,
            states, pairs, attempts,
        )
    if not search:
        return PassivityReport(
            False, None, last_margin, last_kmargin, "none",
            "no candidate certificate passed and the general search was disabled; "
            + " | ".join(attempts), states, pairs, attempts,
        )

    if lcs.n == 0:
        # No storage: passive iff D + D' >= 0, which the necessary conditions checked.
        return PassivityReport(True, np.zeros((0, 0)), 0.0, 1.0, "lmi",
                               "no states and D + D' >= 0", states, pairs, attempts)

    Kt, s_star, direction, msg = _solve_lmi(nz, rtol, ktol)
    if Kt is None:
        reason = "no storage function: " + msg
        if direction is not None:
            reason += "; " + _describe_kyp_failure(nz, direction, states, pairs)
        attempts.append("lmi: " + reason)
        return PassivityReport(False, None, float(-s_star) if np.isfinite(s_star) else np.nan,
                               float("nan"), "lmi", reason, states, pairs, attempts)
    ok, margin, k_margin, worst, ok_kyp, ok_k = _verify(nz, Kt, rtol, ktol)
    Kphys = nz.from_normalised_K(Kt)
    Kphys = 0.5 * (Kphys + Kphys.T)
    if ok:
        attempts.append("lmi: certificate found and verified")
        return PassivityReport(True, Kphys, margin, k_margin, "lmi",
                               f"certificate found by SDP and verified (KYP margin {margin:.3g}, "
                               f"λ_min/λ_max(K~) = {k_margin:.3g})", states, pairs, attempts)
    if not ok_k:
        kev, kvec = np.linalg.eigh(Kt)
        reason = (
            "a storage K >= 0 exists but none is positive definite: every storage vanishes "
            f"along state direction {_fmt_vector(nz.T * kvec[:, 0], states)} "
            "(an unobservable mode that is not asymptotically damped, or a Jordan block on "
            "the imaginary axis)"
        )
    else:
        kev, kvec = np.linalg.eigh(Kt)
        reason = (
            f"no certificate with λ_max(K~) <= {_KAPPA:g} (normalised) satisfies the KYP "
            f"inequality (best margin {margin:.3g}): it can at most be approached as K grows "
            f"without bound along {_fmt_vector(nz.T * kvec[:, -1], states)} relative to "
            f"{_fmt_vector(nz.T * kvec[:, 0], states)} (a Jordan block on the imaginary axis "
            "or an undamped mode coupled to the ports); "
            + _describe_kyp_failure(nz, worst, states, pairs)
        )
    attempts.append("lmi: " + reason)
    return PassivityReport(False, None, margin, k_margin, "lmi", reason, states, pairs, attempts)
