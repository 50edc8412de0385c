"""Well-posedness, consistent initial states and state jumps of passive LCS.

Theory (Camlibel, Heemels & Schumacher, "On linear passive complementarity systems",
European Journal of Control 8, 2002; Heemels, Camlibel & Schumacher, "On the dynamic analysis
of piecewise-linear networks", 2002). For ``x' = A x + B λ + E u``, ``w = C x + D λ + F u``,
``0 <= w ⊥ λ >= 0``:

Existence and uniqueness
    If (A, B, C, D) is passive (a storage ``½ x'Kx``, ``K = K' > 0``, see
    :mod:`lcs.theory.passivity`) and ``col(B, D + D')`` has full column rank, then from every
    initial state there is exactly one solution (x, λ) (with a state jump at t = 0 if the state is
    inconsistent). Passivity alone already makes the *state* trajectory exist and be unique:
    the KYP inequality forces ``K B = C'`` on ``ker(D + D')``, which is the condition under
    which the LCS, in the coordinates ``K^{1/2} x``, is a differential inclusion with a maximal
    monotone right-hand side (Brogliato & Thibault, "Existence and uniqueness of solutions for
    non-autonomous complementarity dynamical systems", J. Convex Analysis 17, 2010; for D = 0
    Brogliato, Systems & Control Letters 51, 2004). Uniqueness of x is also elementary: for two
    solutions, ``d/dt ½|x1 - x2|²_K <= (w1 - w2)'(λ1 - λ2) = -w1'λ2 - w2'λ1 <= 0``.
    So ``wellposed`` below means: the state trajectory exists and is unique; ``lambda_unique``
    says whether λ is unique too (rank condition, or D a P-matrix). An ideal diode bridge
    whose four diodes conduct at once is the typical case of a unique x with a non-unique λ
    (how the current splits between the two legs is not determined). The rank condition says
    that no combination of complementarity variables is invisible both in the dynamics and in
    the dissipation; when it fails, the pairs in the null
    space are reported. As an alternative sufficient condition we also report whether D is a
    P-matrix (then λ is a Lipschitz function of (x, u), there are no jumps and the dynamics
    are a Lipschitz ODE).

The cone SOL(0, D)
    ``SOL(0, D) = {λ >= 0 : Dλ >= 0, λ'Dλ = 0}``. For passive D (``D + D' >= 0``),
    ``λ'Dλ = ½ λ'(D + D')λ = 0`` iff ``(D + D')λ = 0``, so the cone is the polyhedral
    ``𝒦 = {λ >= 0, Dλ >= 0, (D + D')λ = 0}``. We compute its extreme rays R (columns, m x r):
    with N an orthonormal basis of ker(D + D'), ``𝒦 = N {ξ : N ξ >= 0, D N ξ >= 0}``, a
    pointed cone whose rays are the one-dimensional solutions of k - 1 independent active
    constraints (k = dim ker(D + D'); enumeration, fine for the m <= ~10 of circuits). D = 0
    gives R = I (every pair separately); D + D' > 0 gives no rays (𝒦 = {0}).

Consistent states
    ``Q(u) = {x : C x + F u ∈ 𝒦*}`` with the dual cone ``𝒦* = {v : R'v >= 0}``: one linear
    inequality ``r'(C x + F u) >= 0`` per ray r. For D = 0 this is simply ``w(x, u) >= 0``
    for every pair: a diode whose w would be negative (reverse voltage below zero with λ the
    current, or a current forced the wrong way with λ the voltage) needs an impulse.

State jump
    From an inconsistent x⁻ the state jumps to ``x⁺ = x⁻ + B η`` with η in 𝒦 and
    ``𝒦 ∋ η ⊥ C x⁺ + F u ∈ 𝒦*``. Derivation: x⁺ is the K-metric projection of x⁻ onto Q,
    ``x⁺ = argmin {½ (x - x⁻)' K (x - x⁻) : x ∈ Q}``. Its KKT conditions are
    ``K (x⁺ - x⁻) = C' μ`` with ``𝒦 ∋ μ ⊥ C x⁺ + F u ∈ 𝒦*``. Since 𝒦 lies in ker(D + D'),
    where the KYP inequality forces ``K B v = C' v``, we get ``x⁺ - x⁻ = B μ``: η = μ.
    Writing ``η = R α`` turns it into the LCP
    ``0 <= α ⊥ R'(C x⁻ + F u) + (R' C B R) α >= 0`` whose matrix ``R'CBR = R'B'KBR`` is
    symmetric positive semidefinite (so the LCP is solvable and x⁺ unique; η is unique when
    B R has full column rank, which the rank condition gives). For D = 0 it is the familiar
    ``0 <= η ⊥ C (x⁻ + B η) + F u >= 0``. The jump does not need K; K is used for the energy
    bookkeeping.

Energy at the jump
    With ``V = ½ x'Kx``: ``V(x⁺) - V(x⁻) = -η'F u - ½ (x⁺ - x⁻)' K (x⁺ - x⁻)``
    (use ``K B η = C' η`` and ``η'(C x⁺ + F u) = 0``). The second term is the energy lost in
    the impulse (e.g. the classic ``C1 C2 (v1 - v2)² / (2 (C1 + C2))`` when two capacitors are
    connected through a diode); ``-η'F u`` is what the sources deliver during the impulse. With
    u = 0 energy never increases at a jump.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from lcs.model import LCS
from lcs.theory.passivity import PassivityReport, check_passivity

__all__ = [
    "LinearForm",
    "ConsistentSet",
    "WellposednessReport",
    "JumpResult",
    "check_wellposedness",
    "sol_cone_rays",
    "consistent_set",
    "is_consistent",
    "state_jump",
]

# Eigenvalues of D + D' below this (relative) count as zero.
_NULL_RTOL = 1e-10
# Relative rank tolerance of col(B, D + D') after column scaling.
_RANK_RTOL = 1e-9


@dataclass(frozen=True)
class LinearForm:
    """An affine-free linear function ``f(x, u) = cx · x + cu · u`` with named coefficients.

    Attributes
    ----------
    label : str
        What the form stands for, e.g. ``"w(D1)"``.
    cx : ndarray (n,)
        Coefficients of the states (units: unit of f per state unit).
    cu : ndarray (p,)
        Coefficients of the inputs.
    states, inputs : tuple of str
        Names of the coefficients.
    """

    label: str
    cx: np.ndarray
    cu: np.ndarray
    states: tuple[str, ...]
    inputs: tuple[str, ...]

    def __call__(self, x, u=None) -> float:
        x = np.asarray(x, dtype=float).ravel()
        val = float(self.cx @ x)
        if self.cu.size:
            u = np.zeros(self.cu.size) if u is None else np.asarray(u, dtype=float).ravel()
            val += float(self.cu @ u)
        return val

    def as_dict(self, tol: float = 0.0) -> dict[str, float]:
        """Coefficients by name (states then inputs), dropping those with ``|c| <= tol``."""
        names = self.states + self.inputs
        coeffs = np.concatenate([self.cx, self.cu])
        # (the non-zero coefficients found at once: a form of a large circuit has hundreds of
        # names and a handful of terms)
        return {names[i]: float(coeffs[i]) for i in np.flatnonzero(np.abs(coeffs) > tol)}

    def __str__(self) -> str:
        coeffs = self.as_dict()
        big = max((abs(c) for c in coeffs.values()), default=0.0)
        terms = [(nm, c) for nm, c in coeffs.items() if abs(c) > 1e-12 * big]
        if not terms:
            return "0"
        text = ""
        for k, (nm, c) in enumerate(terms):
            sign = "-" if c < 0 else "+"
            mag = abs(c)
            coef = "" if abs(mag - 1.0) <= 1e-12 else f"{mag:.6g} "  # (isclose, 40x faster)
            if k == 0:
                text += ("-" if c < 0 else "") + f"{coef}{nm}"
            else:
                text += f" {sign} {coef}{nm}"
        return text


def _form(label, cx, cu, lcs: LCS) -> LinearForm:
    return LinearForm(label, np.asarray(cx, dtype=float).ravel(),
                      np.asarray(cu, dtype=float).ravel(), tuple(lcs.states), tuple(lcs.inputs))


# --------------------------------------------------------------------------------------------
# SOL(0, D)


def _dd_null(D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues of D + D' and an orthonormal basis of its null space."""
    m = D.shape[0]
    if m == 0:
        return np.zeros(0), np.zeros((0, 0))
    ev, V = np.linalg.eigh(D + D.T)
    tol = _NULL_RTOL * max(1.0, float(np.max(np.abs(ev))))
    return ev, V[:, np.abs(ev) <= tol]


def sol_cone_rays(D: np.ndarray, max_m: int = 12) -> np.ndarray:
    """Extreme rays of ``SOL(0, D) = {λ >= 0 : Dλ >= 0, λ'Dλ = 0}`` for ``D + D' >= 0``.

    Parameters
    ----------
    D : ndarray (m, m)
    max_m : int
        Refuse larger problems (the enumeration is combinatorial).

    Returns
    -------
    ndarray (m, r)
        One ray per column, scaled so that its largest entry is 1. ``r = 0`` when the cone
        is {0}.

    Raises
    ------
    ValueError
        If ``D + D'`` has a negative eigenvalue (the cone is then not the polyhedral one
        used here, and the LCS is not passive).
    """
    D = np.asarray(D, dtype=float)
    m = D.shape[0]
    if m == 0:
        return np.zeros((0, 0))
    ev, N = _dd_null(D)
    if ev[0] < -_NULL_RTOL * max(1.0, float(np.max(np.abs(ev)))):
        raise ValueError("D + D' is not positive semidefinite: SOL(0, D) is not computed")
    k = N.shape[1]
    if k == 0:
        return np.zeros((m, 0))
    scale = max(1.0, float(np.max(np.abs(D))))
    if np.max(np.abs(D)) <= _NULL_RTOL * scale and k == m:
        return np.eye(m)
    if m > max_m:
        raise ValueError(f"SOL(0, D) enumeration refused for m = {m} > {max_m}")
    # Cone {ξ : G ξ >= 0}. Rows of D N that vanish (up to rounding) impose nothing; the rest
    # are normalised so that one tolerance fits all.
    G = np.vstack([N, (D / scale) @ N])
    norms = np.linalg.norm(G, axis=1)
    G = G[norms > 1e-9] / norms[norms > 1e-9, None]
    rows = list(range(G.shape[0]))
    tol = 1e-9
    rays: list[np.ndarray] = []

    def add(d: np.ndarray) -> None:
        for s in (1.0, -1.0):
            v = s * d
            if np.all(G @ v >= -tol) and np.any(np.abs(G @ v) > tol):
                lam = N @ v
                lam[np.abs(lam) < 1e-12 * np.max(np.abs(lam))] = 0.0
                lam = lam / np.max(np.abs(lam))
                if not any(np.allclose(lam, r, atol=1e-8) for r in rays):
                    rays.append(lam)

    if k == 1:
        add(np.ones(1))
    else:
        for subset in itertools.combinations(rows, k - 1):
            Gs = G[list(subset)]
            _, sv, Vt = np.linalg.svd(Gs)
            if sv.size < k - 1 or sv[k - 2] < 1e-9:
                continue
            add(Vt[-1])
    if not rays:
        return np.zeros((m, 0))
    return np.column_stack(rays)


# --------------------------------------------------------------------------------------------
# Consistent set


@dataclass(frozen=True)
class ConsistentSet:
    """The consistent states ``Q(u) = {x : R'(C x + F u) >= 0}`` of a passive LCS.

    Attributes
    ----------
    rays : ndarray (m, r)
        Extreme rays of SOL(0, D), columns.
    inequalities : tuple of LinearForm
        ``r'(C x + F u)`` per ray; x is consistent when all are >= 0.
    pairs : tuple of str
        Pair names (rows of ``rays``).
    """

    rays: np.ndarray
    inequalities: tuple[LinearForm, ...]
    pairs: tuple[str, ...]

    def contains(self, x, u=None, tol: float = 1e-9) -> bool:
        """Whether every inequality holds up to ``tol * (‖cx‖ ‖x‖ + ‖cu‖ ‖u‖)``."""
        x = np.asarray(x, dtype=float).ravel()
        uu = np.zeros(0) if u is None else np.asarray(u, dtype=float).ravel()
        for f in self.inequalities:
            # Cauchy-Schwarz bound of the terms: rounding in any state (e.g. a state that a
            # jump has just set to zero) is covered.
            size = np.linalg.norm(f.cx) * np.linalg.norm(x)
            if f.cu.size and uu.size:
                size += np.linalg.norm(f.cu) * np.linalg.norm(uu)
            if f(x, u) < -tol * max(size, 1e-300):
                return False
        return True

    def describe(self) -> str:
        """One line per inequality, e.g. ``w(D1) = -v(C1) + v(C2) >= 0``."""
        if not self.inequalities:
            return "every state is consistent (SOL(0, D) = {0}: D + D' > 0 on all pairs)"
        lines = ["x is consistent iff"]
        for f in self.inequalities:
            lines.append(f"  {f.label} = {f} >= 0")
        return "\n".join(lines)


def _ray_label(r: np.ndarray, pairs) -> str:
    nz = np.flatnonzero(np.abs(r) > 1e-12)
    if len(nz) == 1 and np.isclose(r[nz[0]], 1.0):
        return f"w({pairs[nz[0]]})"
    terms = []
    for i in nz:
        c = r[i]
        coef = "" if np.isclose(abs(c), 1.0) else f"{abs(c):.4g} "
        terms.append(("-" if c < 0 else "+") + f" {coef}w({pairs[i]})")
    text = " ".join(terms)
    return text[2:] if text.startswith("+ ") else text


def consistent_set(lcs: LCS) -> ConsistentSet:
    """The cone description of the consistent initial states (see module docstring).

    Parameters
    ----------
    lcs : LCS
        Needs ``D + D' >= 0`` (necessary for passivity).

    Returns
    -------
    ConsistentSet
    """
    pairs = tuple(p.name for p in lcs.pairs)
    R = sol_cone_rays(lcs.D)
    forms = tuple(
        _form(_ray_label(R[:, j], pairs), R[:, j] @ lcs.C, R[:, j] @ lcs.F, lcs)
        for j in range(R.shape[1])
    )
    return ConsistentSet(R, forms, pairs)


def is_consistent(lcs: LCS, x, u=None, tol: float = 1e-9) -> bool:
    """Whether x (with inputs u) is a consistent state: ``C x + F u ∈ SOL(0, D)*``.

    Parameters
    ----------
    lcs : LCS
    x : array_like (n,)
        State (A, V).
    u : array_like (p,), optional
        Inputs (V, A); zero if omitted.
    tol : float
        Relative tolerance: each inequality may be violated by ``tol`` times the magnitude
        of its terms.
    """
    return consistent_set(lcs).contains(x, u, tol)


# --------------------------------------------------------------------------------------------
# Well-posedness


@dataclass
class WellposednessReport:
    """Result of :func:`check_wellposedness`.

    Attributes
    ----------
    wellposed : bool
        The state trajectory exists and is unique from every consistent initial state (and
        jumps from an inconsistent one): true when the LCS is passive, or D is a P-matrix.
    lambda_unique : bool
        λ is unique as well: passive with ``col(B, D + D')`` of full column rank
        (Camlibel–Heemels–Schumacher), or D a P-matrix.
    passive : bool
    rank_ok : bool
        ``col(B, D + D')`` has full column rank.
    rank : int
    m : int
        Number of pairs.
    p_matrix : bool or None
        D is a P-matrix (None: not checked, m too large).
    reason : str
        Which condition holds or fails, with pair names.
    null_combinations : list of dict
        Basis of ``ker col(B, D + D')``: pair name -> coefficient (largest 1).
    deficient_pairs : tuple of str
        Pairs involved in those combinations.
    passivity : PassivityReport
    """

    wellposed: bool
    passive: bool
    rank_ok: bool
    rank: int
    m: int
    p_matrix: bool | None
    reason: str
    null_combinations: list[dict[str, float]] = field(default_factory=list)
    deficient_pairs: tuple[str, ...] = ()
    passivity: PassivityReport | None = None
    lambda_unique: bool = False


def _p_matrix(D: np.ndarray) -> bool | None:
    try:
        from lcs.lcp import is_p_matrix
    except ImportError:  # pragma: no cover - lcp.py is part of the package
        return None
    return is_p_matrix(D)


def check_wellposedness(
    lcs: LCS, passivity: PassivityReport | None = None, *, energy: np.ndarray | None = None
) -> WellposednessReport:
    """Check the sufficient conditions for existence and uniqueness of solutions.

    Parameters
    ----------
    lcs : LCS
    passivity : PassivityReport, optional
        A report from :func:`lcs.theory.passivity.check_passivity`; computed when omitted.
    energy : ndarray (n, n), optional
        Energy matrix passed to :func:`check_passivity` when the report is computed here.

    Returns
    -------
    WellposednessReport
    """
    pairs = tuple(p.name for p in lcs.pairs)
    if passivity is None:
        passivity = check_passivity(lcs, energy=energy)
    m = lcs.m
    if m == 0:
        return WellposednessReport(True, passivity.passive, True, 0, 0, True,
                                   "no complementarity pairs: a linear ODE", [], (), passivity,
                                   True)
    Dsym = lcs.D + lcs.D.T
    stack = np.vstack([lcs.B, Dsym])
    # Column scaling makes the rank test unit-free (B in 1/F or 1/H, D + D' in Ω or S).
    colnorm = np.linalg.norm(stack, axis=0)
    scaled = stack / np.where(colnorm > 0, colnorm, 1.0)
    _, sv, Vt = np.linalg.svd(scaled)
    tol = _RANK_RTOL * max(1.0, sv[0] if sv.size else 1.0)
    rank = int(np.sum(sv > tol))
    rank_ok = rank == m
    combos: list[dict[str, float]] = []
    involved: set[str] = set()
    if not rank_ok:
        null = Vt[rank:].T  # in scaled coordinates
        null = null / np.where(colnorm > 0, colnorm, 1.0)[:, None]
        for j in range(null.shape[1]):
            v = null[:, j] / np.max(np.abs(null[:, j]))
            d = {pairs[i]: float(v[i]) for i in range(m) if abs(v[i]) > 1e-9}
            combos.append(d)
            involved.update(d)
    pmat = _p_matrix(lcs.D)
    deficient = tuple(nm for nm in pairs if nm in involved)
    parts = []
    if passivity.passive:
        parts.append(f"passive ({passivity.method})")
    else:
        parts.append(f"not passive: {passivity.reason}")
    if rank_ok:
        parts.append(f"col(B, D + D') has full column rank {m}")
    else:
        combo_text = "; ".join(
            "{" + ", ".join(f"{k}: {v:+.3g}" for k, v in d.items()) + "}" for d in combos
        )
        parts.append(
            f"col(B, D + D') has rank {rank} < {m}: the combinations λ ~ {combo_text} of pairs "
            f"{', '.join(deficient)} change neither x' nor the dissipation, so λ is not unique "
            "there"
        )
    lambda_unique = bool(passivity.passive and rank_ok)
    wellposed = bool(passivity.passive)
    if lambda_unique:
        parts.append("existence and uniqueness of (x, λ) from every initial state "
                     "(Camlibel-Heemels-Schumacher), with a jump from inconsistent states")
    elif pmat:
        wellposed = lambda_unique = True
        parts.append("but D is a P-matrix: λ is a Lipschitz function of (x, u), unique "
                     "solutions without jumps")
    elif wellposed:
        parts.append("the state trajectory still exists and is unique (passivity: maximal "
                     "monotone inclusion, Brogliato-Thibault 2010); only λ is not unique")
    else:
        parts.append("the sufficient conditions do not hold (solutions may still exist and be "
                     "unique, but it is not guaranteed)")
    return WellposednessReport(wellposed, passivity.passive, rank_ok, rank, m, pmat,
                               "; ".join(parts), combos, deficient, passivity, lambda_unique)


# --------------------------------------------------------------------------------------------
# State jump


@dataclass
class JumpResult:
    """Result of :func:`state_jump`.

    Attributes
    ----------
    x_minus, x_plus : ndarray (n,)
        State before and after the jump.
    eta : ndarray (m,)
        The impulse: ``x_plus = x_minus + B @ eta`` (units of λ times seconds: coulombs for
        a current, volt-seconds / webers for a voltage).
    jumped : bool
        False when x_minus was already consistent (then eta = 0).
    energy_before, energy_after : float
        ``½ x'Kx`` with the passivity certificate K (J for circuit energy matrices).
    dissipated : float
        ``½ (x⁺ - x⁻)' K (x⁺ - x⁻)`` >= 0, the energy lost in the impulse.
    supplied : float
        ``-η'F u``, energy delivered by the sources during the impulse;
        ``energy_after - energy_before = supplied - dissipated``.
    states, pairs : tuple of str
    """

    x_minus: np.ndarray
    x_plus: np.ndarray
    eta: np.ndarray
    jumped: bool
    energy_before: float
    energy_after: float
    dissipated: float
    supplied: float
    states: tuple[str, ...]
    pairs: tuple[str, ...]


def _enumerate_psd_lcp(M: np.ndarray, q: np.ndarray, tol: float) -> np.ndarray | None:
    """Fallback enumeration for ``0 <= z ⊥ M z + q >= 0`` (small m)."""
    m = q.size
    scale = max(1.0, float(np.max(np.abs(M))) if M.size else 1.0, float(np.max(np.abs(q))))
    for k in range(m + 1):
        for J in itertools.combinations(range(m), k):
            z = np.zeros(m)
            if k:
                idx = list(J)
                sol, *_ = np.linalg.lstsq(M[np.ix_(idx, idx)], -q[idx], rcond=None)
                z[idx] = sol
            w = M @ z + q
            if np.all(z >= -tol * scale) and np.all(w >= -tol * scale):
                return np.maximum(z, 0.0)
    return None


def _solve_jump_lcp(M: np.ndarray, q: np.ndarray) -> np.ndarray:
    m = q.size
    if m == 0 or np.all(q >= 0):
        return np.zeros(m)
    scale = max(1.0, float(np.max(np.abs(M))), float(np.max(np.abs(q))))
    try:
        from lcs.lcp import solve_lcp

        res = solve_lcp(M, q)
        if res.ok:
            z = np.asarray(res.z, dtype=float)
            w = M @ z + q
            if (np.all(z >= -1e-9 * scale) and np.all(w >= -1e-9 * scale)
                    and abs(z @ w) <= 1e-8 * scale * max(1.0, np.abs(z).sum())):
                return np.maximum(z, 0.0)
    except ImportError:  # pragma: no cover - lcp.py is part of the package
        pass
    z = _enumerate_psd_lcp(M, q, 1e-9)
    if z is None:
        raise RuntimeError("the jump LCP has no solution (is the LCS passive?)")
    return z


def state_jump(
    lcs: LCS,
    x,
    u=None,
    passivity: PassivityReport | None = None,
    *,
    energy: np.ndarray | None = None,
) -> JumpResult:
    """The state jump from x (possibly inconsistent) of a passive LCS.

    Parameters
    ----------
    lcs : LCS
    x : array_like (n,)
        State just before (x⁻), in A and V.
    u : array_like (p,), optional
        Inputs at the jump instant; zero if omitted.
    passivity : PassivityReport, optional
        Supplies the certificate K for the energy bookkeeping; computed when omitted (with
        ``energy`` as candidate).
    energy : ndarray (n, n), optional
        Energy matrix candidate when the report is computed here.

    Returns
    -------
    JumpResult

    Raises
    ------
    ValueError
        When the LCS is not passive (the jump rule is derived for passive LCS only).
    """
    states = tuple(lcs.states)
    pairs = tuple(p.name for p in lcs.pairs)
    if passivity is None:
        passivity = check_passivity(lcs, energy=energy)
    if not passivity.passive or passivity.K is None:
        raise ValueError(f"state_jump needs a passive LCS: {passivity.reason}")
    K = passivity.K
    x = np.asarray(x, dtype=float).ravel()
    u = np.zeros(lcs.p) if u is None else np.asarray(u, dtype=float).ravel()
    R = sol_cone_rays(lcs.D)
    q = R.T @ (lcs.C @ x + lcs.F @ u)
    if R.shape[1] == 0:
        alpha = np.zeros(0)
    else:
        M = R.T @ lcs.C @ lcs.B @ R
        # On span SOL(0, D) C B = B'KB (symmetric); symmetrising removes rounding only.
        M = 0.5 * (M + M.T)
        alpha = _solve_jump_lcp(M, q)
    eta = R @ alpha if R.shape[1] else np.zeros(lcs.m)
    dx = lcs.B @ eta
    x_plus = x + dx
    e0 = 0.5 * float(x @ K @ x)
    e1 = 0.5 * float(x_plus @ K @ x_plus)
    dissipated = 0.5 * float(dx @ K @ dx)
    supplied = -float(eta @ (lcs.F @ u)) if lcs.p else 0.0
    return JumpResult(x, x_plus, eta, bool(np.any(alpha > 0)), e0, e1, dissipated, supplied,
                      states, pairs)
