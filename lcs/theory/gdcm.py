"""Generalized discontinuous conduction modes (GDCM) of an LCS.

A complementarity pair is in a *generalized discontinuous conduction mode* on a time interval
when its w, a linear function of state and inputs alone (``D_ii = 0``), is held at zero while
λ > 0. The classical DCM of a boost converter is the example: with the switch open the diode
pair has ``w = i(L)`` (the diode current) and ``λ`` = the diode's reverse voltage; in DCM the
inductor current stays at zero while the diode blocks, so the dynamics lose one dimension.

Derivation (one pair i, the other pairs at λ_j = 0)
---------------------------------------------------
Inputs are taken constant on the interval (u' = 0, DC sources); for time-varying inputs each
derivative below gains ``F_i u^(k)`` and ``C_i A^(k-1-j) E u^(j)`` terms, not modelled here.
With ``x' = A x + B_i λ_i + E u`` and ``y = w_i = C_i x + F_i u``, the *relative degree* r is the
first k with Markov parameter ``h = C_i A^(r-1) B_i ≠ 0``, and for k < r::

    y^(k) = C_i A^k x + C_i A^(k-1) E u        (k >= 1),     y = C_i x + F_i u
    y^(r) = C_i A^r x + C_i A^(r-1) E u + h λ_i

Holding y ≡ 0 on an interval needs ``y = y' = ... = y^(r-1) = 0`` (r linear conditions on
(x, u): the region has codimension r) and ``y^(r) = 0``, i.e. ::

    λ_i = Γ(x, u) = -(C_i A^r x + C_i A^(r-1) E u) / h,

which must be positive (λ_i >= 0 by complementarity; Γ > 0 in the interior of the region).
The reduced dynamics are ::

    x' = (I - B_i h^-1 C_i A^(r-1)) (A x + E u) = P (A x + E u),

P is a projection (``P B_i = 0``, ``C_i A^(r-1) P = 0``), and the manifold
``{y = ... = y^(r-1) = 0}`` is invariant under it. For r = 1 this is the familiar
``Γ = -(C A x + C E u)/(C B)``, ``x' = (I - B (CB)^-1 C)(A x + E u)``.

Sign of h and of y^(r). On the manifold the free motion (λ_i = 0) has
``y^(r) = -h Γ``. If h > 0: Γ > 0 means the free motion would drive w negative, so λ_i = Γ
holds it at zero (GDCM), while Γ < 0 means the free motion leaves into w > 0 with λ_i = 0; the
continuation is unique. If h < 0 both are consistent when Γ > 0 (stay with λ = Γ, or leave with
λ = 0) and neither when Γ < 0 (an impulse would be needed): ``unique`` is False. For a passive
LCS with D = 0, ``CB = B'KB >= 0``, so r = 1 and h > 0 whenever B_i ≠ 0; relative degree two or
more only occurs in non-passive models (controlled sources, hand-made LCS).

On Γ = 0 (the boundary of the region) the required λ_i is zero, so the reduced and the free
vector fields coincide there and the trajectory is C^r. Which side it takes is decided by
``Γ' = dΓ/dt = -h^-1 C_i A^r (A_red x + E_red u)`` (given as ``gamma_rate``): Γ' > 0 enters
(or stays in) GDCM with λ growing from zero; Γ' < 0 exits, because along the common flow
``y^(r+1) = -h Γ' > 0`` and w leaves zero with its (r+1)-th derivative; Γ' = 0 is a grazing
point where higher derivatives (Γ'' along the same flow, etc.) decide — reported as
``"grazing"`` and not resolved further. In the boost converter Γ = v(C) - Vin: DCM ends when
the output voltage has decayed to the input voltage.

Several pairs held together (a set J)
-------------------------------------
With ``D_JJ = 0`` and the pairs outside J at λ = 0, holding ``w_J = C_J x + F_J u = 0`` with
relative degree one needs ``H = C_J B_J`` nonsingular: ``λ_J = Γ_J = -H^-1 (C_J A x + C_J E u)``
(all components > 0) and ``x' = (I - B_J H^-1 C_J)(A x + E u)``. On the manifold
``w_J = 0`` the pairs of J that stay are decided by the LCP ``0 <= λ_J ⊥ C_J(A x + E u) + H λ_J
>= 0``; it has a unique solution for every state iff H is a P-matrix (``unique``). For a
passive LCS ``H = B_J' K B_J`` is positive definite when B_J has full column rank. The pairs
outside J must keep ``w_k = C_k x + D_kJ Γ_J + F_k u >= 0`` (``others``), otherwise they change
state. Higher relative degree for sets (vector relative degree) is not treated.

Detection on trajectories
-------------------------
:func:`detect_gdcm_intervals` marks samples with ``|w| <= tol`` and ``λ > lam_tol`` and
returns the maximal runs per pair (entry = first such sample, exit = last); runs separated by
gaps no longer than ``merge_gap`` (chatter of a time stepper) are merged and counted in
``reentry_count``; separate intervals of the same pair are numbered by ``occurrence``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from lcs.model import LCS
from lcs.theory.wellposed import LinearForm

__all__ = [
    "GdcmCondition",
    "GdcmInterval",
    "gdcm_conditions",
    "gdcm_condition",
    "detect_gdcm_intervals",
]

# Markov parameters below this (relative to ‖C_i‖ ‖A‖^k ‖B_i‖) count as zero.
_MARKOV_RTOL = 1e-10


@dataclass(frozen=True)
class GdcmCondition:
    """The GDCM region and reduced dynamics of a set of pairs held at w = 0.

    Attributes
    ----------
    pairs : tuple of str
        The pairs held (J).
    relative_degree : int
        r (1 for sets of more than one pair).
    y : tuple of LinearForm
        Forms that are zero on the region: ``w_J`` and, for r > 1, its derivatives up to
        ``r - 1`` (free dynamics, constant inputs). Labels ``w(D1)``, ``w(D1)'``...
    gamma : tuple of LinearForm
        ``Γ_J``: λ of each held pair on the region (> 0 inside).
    others : tuple of LinearForm
        ``w_k`` of the other pairs on the region (must stay >= 0).
    gamma_rate : tuple of LinearForm
        ``dΓ_J/dt`` along the reduced dynamics (decides entry/exit on Γ = 0).
    markov : ndarray (|J|, |J|)
        ``C_J A^(r-1) B_J``.
    A_red : ndarray (n, n)
        Reduced state matrix ``P A``.
    E_red : ndarray (n, p)
        Reduced input matrix ``P E``.
    unique : bool
        Markov matrix is a P-matrix (scalar: positive): unique continuation.
    """

    pairs: tuple[str, ...]
    relative_degree: int
    y: tuple[LinearForm, ...]
    gamma: tuple[LinearForm, ...]
    others: tuple[LinearForm, ...]
    gamma_rate: tuple[LinearForm, ...]
    markov: np.ndarray
    A_red: np.ndarray
    E_red: np.ndarray
    unique: bool

    @property
    def dimension_loss(self) -> int:
        """Codimension of the region in state space: ``r |J|``."""
        return self.relative_degree * len(self.pairs)

    @staticmethod
    def _size(f: LinearForm, x: np.ndarray, u: np.ndarray) -> float:
        return float(np.abs(f.cx) @ np.abs(x) + (np.abs(f.cu) @ np.abs(u) if f.cu.size else 0))

    def classify(self, x, u=None, rtol: float = 1e-9, atol: float = 0.0) -> str:
        """Where (x, u) lies with respect to the region.

        Returns
        -------
        str
            ``"off-manifold"`` (some y ≠ 0), ``"other-pair-violated"`` (a pair outside J
            would have w < 0), ``"leaving"`` (some Γ < 0: the free motion leaves with w > 0),
            ``"gdcm"`` (every Γ > 0), or on the boundary Γ_j = 0: ``"entering"`` (Γ' > 0),
            ``"exiting"`` (Γ' < 0), ``"grazing"`` (Γ' = 0).
        """
        x = np.asarray(x, dtype=float).ravel()
        u = np.zeros(self.E_red.shape[1]) if u is None else np.asarray(u, dtype=float).ravel()

        def tol(f):
            return rtol * self._size(f, x, u) + atol

        if any(abs(f(x, u)) > tol(f) for f in self.y):
            return "off-manifold"
        if any(f(x, u) < -tol(f) for f in self.others):
            return "other-pair-violated"
        g = [(f(x, u), tol(f)) for f in self.gamma]
        if any(v < -t for v, t in g):
            return "leaving"
        if all(v > t for v, t in g):
            return "gdcm"
        rates = [(r(x, u), tol(r)) for (v, t), r in zip(g, self.gamma_rate, strict=True)
                 if abs(v) <= t]
        if any(r < -t for r, t in rates):
            return "exiting"
        if all(r > t for r, t in rates):
            return "entering"
        return "grazing"

    def contains(self, x, u=None, rtol: float = 1e-9, atol: float = 0.0) -> bool:
        """Whether (x, u) is in the (open) GDCM region: y = 0, Γ > 0, others >= 0."""
        return self.classify(x, u, rtol, atol) == "gdcm"

    def describe(self) -> str:
        """Readable statement of the region and the reduced dynamics."""
        held = ", ".join(self.pairs)
        lines = [f"GDCM of {held} (relative degree {self.relative_degree}, "
                 f"loses {self.dimension_loss} dimension(s), "
                 f"{'unique' if self.unique else 'NOT unique'} continuation):"]
        for f in self.y:
            lines.append(f"  {f.label} = {f} = 0")
        for f in self.gamma:
            lines.append(f"  {f.label} = {f} > 0")
        for f in self.others:
            lines.append(f"  {f.label} = {f} >= 0")
        states = self.y[0].states if self.y else ()
        for i, nm in enumerate(states):
            row = LinearForm(f"d{nm}/dt", self.A_red[i], self.E_red[i], states,
                             self.y[0].inputs)
            lines.append(f"  d{nm}/dt = {row}")
        return "\n".join(lines)


def _names_to_indices(lcs: LCS, pairs) -> list[int]:
    names = [p.name for p in lcs.pairs]
    lower = [nm.lower() for nm in names]
    idx = []
    for item in pairs:
        if isinstance(item, (int, np.integer)):
            idx.append(int(item))
        else:
            try:
                idx.append(lower.index(str(item).lower()))
            except ValueError:
                raise KeyError(f"unknown pair {item!r}; pairs are {', '.join(names)}") from None
    if len(set(idx)) != len(idx):
        raise ValueError("repeated pair in the held set")
    return idx


def _form(label: str, cx, cu, lcs: LCS) -> LinearForm:
    return LinearForm(label, np.asarray(cx, dtype=float).ravel(),
                      np.asarray(cu, dtype=float).ravel(), tuple(lcs.states), tuple(lcs.inputs))


def _clean(M: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """Zero the entries of M below 1e-13 times their rounding bound."""
    M = M.copy()
    M[np.abs(M) <= 1e-13 * bound] = 0.0
    return M


def _relative_degree(lcs: LCS, i: int) -> int | None:
    """First r with ``C_i A^(r-1) B_i ≠ 0`` (relative tolerance), None if none up to n."""
    A, b, c = lcs.A, lcs.B[:, i], lcs.C[i]
    nA = max(np.linalg.norm(A, 2), 1e-300)
    v = b.copy()
    for k in range(max(lcs.n, 1)):
        h = c @ v
        if abs(h) > _MARKOV_RTOL * np.linalg.norm(c) * np.linalg.norm(b) * nA**k:
            return k + 1
        v = A @ v
    return None


def _p_matrix(H: np.ndarray) -> bool:
    if H.shape == (1, 1):
        return bool(H[0, 0] > 0)
    try:
        from lcs.lcp import is_p_matrix

        res = is_p_matrix(H)
        if res is not None:
            return bool(res)
    except ImportError:  # pragma: no cover
        pass
    return bool(np.all(np.linalg.eigvals(0.5 * (H + H.T)).real > 0))  # sufficient only


def gdcm_condition(lcs: LCS, held: Sequence[str | int]) -> GdcmCondition:
    """The GDCM condition of a set J of pairs held at w_J = 0 (others at λ = 0).

    Parameters
    ----------
    lcs : LCS
    held : sequence of str or int
        Pair names (case-insensitive) or indices forming J.

    Returns
    -------
    GdcmCondition

    Raises
    ------
    ValueError
        If ``D_JJ ≠ 0`` (w_J depends on λ_J), if a single pair has infinite relative degree,
        or if ``C_J B_J`` is singular for a set of several pairs.
    """
    J = _names_to_indices(lcs, held)
    if not J:
        raise ValueError("the held set is empty")
    names = tuple(lcs.pairs[i].name for i in J)
    others_idx = [k for k in range(lcs.m) if k not in J]
    A, B, C, D, E, F = lcs.A, lcs.B, lcs.C, lcs.D, lcs.E, lcs.F
    DJJ = D[np.ix_(J, J)]
    if np.any(np.abs(DJJ) > 1e-12 * max(1.0, np.max(np.abs(D)))):
        raise ValueError(f"D is not zero on the held pairs {', '.join(names)}: w depends on λ")
    n = lcs.n
    if len(J) == 1:
        r = _relative_degree(lcs, J[0])
        if r is None:
            raise ValueError(f"w({names[0]}) does not depend on λ({names[0]}) through the "
                             "dynamics (infinite relative degree)")
    else:
        r = 1
    BJ, CJ = B[:, J], C[J]
    Ar1 = np.linalg.matrix_power(A, r - 1)
    H = CJ @ Ar1 @ BJ
    if len(J) > 1 and np.linalg.matrix_rank(H) < len(J):
        raise ValueError(f"C_J B_J is singular for {', '.join(names)}: the held pairs cannot "
                         "be kept at w = 0 by their λ independently (relative degree > 1 or "
                         "dependent pairs)")
    Hinv = np.linalg.inv(H)
    CAr = CJ @ Ar1 @ A  # C_J A^r
    CEr = CJ @ Ar1 @ E  # C_J A^(r-1) E
    Gx = -Hinv @ CAr
    Gu = -Hinv @ CEr
    # Entries that cancel exactly in exact arithmetic (e.g. di(L)/dt = 0 in DCM) come out as
    # rounding noise; zero them against elementwise bounds of the sums that produced them.
    X = BJ @ Hinv @ CJ @ Ar1
    P = _clean(np.eye(n) - X, np.eye(n) + np.abs(X))
    A_red = _clean(P @ A, np.abs(P) @ np.abs(A))
    E_red = _clean(P @ E, np.abs(P) @ np.abs(E))
    y_forms = []
    for j, nm in zip(J, names, strict=True):
        y_forms.append(_form(f"w({nm})", C[j], F[j], lcs))
        for k in range(1, r):
            y_forms.append(_form(f"w({nm})" + "'" * k,
                                 C[j] @ np.linalg.matrix_power(A, k),
                                 C[j] @ np.linalg.matrix_power(A, k - 1) @ E, lcs))
    gamma = tuple(_form(f"λ({nm})", Gx[a], Gu[a], lcs) for a, nm in enumerate(names))
    rate = tuple(
        _form(f"dλ({nm})/dt", -(Hinv @ CAr)[a] @ A_red, -(Hinv @ CAr)[a] @ E_red, lcs)
        for a, nm in enumerate(names)
    )
    others = tuple(
        _form(f"w({lcs.pairs[k].name})", C[k] + D[k, J] @ Gx, F[k] + D[k, J] @ Gu, lcs)
        for k in others_idx
    )
    return GdcmCondition(names, r, tuple(y_forms), gamma, others, rate, H, A_red, E_red,
                         _p_matrix(H))


def gdcm_conditions(lcs: LCS) -> list[GdcmCondition]:
    """GDCM conditions of every single pair with ``D_ii = 0`` (the other pairs at λ = 0).

    Pairs whose w does not depend on their own λ through the dynamics (infinite relative
    degree) are skipped. Use :func:`gdcm_condition` for sets of pairs.

    Parameters
    ----------
    lcs : LCS

    Returns
    -------
    list of GdcmCondition
        In pair order.
    """
    out = []
    scale = max(1.0, float(np.max(np.abs(lcs.D)))) if lcs.m else 1.0
    for i in range(lcs.m):
        if abs(lcs.D[i, i]) > 1e-12 * scale:
            continue
        try:
            out.append(gdcm_condition(lcs, [i]))
        except ValueError:
            continue
    return out


# --------------------------------------------------------------------------------------------
# Detection on trajectories


@dataclass(frozen=True)
class GdcmInterval:
    """One GDCM interval of one pair along a sampled trajectory.

    Attributes
    ----------
    pair : str
        Pair name (or ``"pair<i>"`` when no names were given).
    index : int
        Column of the pair in w and λ.
    t_start, t_end : float
        Times (s) of the first and last sample in GDCM (entry and exit).
    i_start, i_end : int
        Sample indices of entry and exit (inclusive).
    occurrence : int
        1 for the first interval of this pair, 2 for the first re-entry, ...
    reentry_count : int
        Short drop-outs (gaps <= ``merge_gap``) merged into this interval.
    lam_min, lam_max : float
        Range of λ over the GDCM samples.
    w_absmax : float
        Largest |w| over the GDCM samples.
    open_start, open_end : bool
        The interval touches the first / last sample (entry / exit not observed).
    """

    pair: str
    index: int
    t_start: float
    t_end: float
    i_start: int
    i_end: int
    occurrence: int
    reentry_count: int
    lam_min: float
    lam_max: float
    w_absmax: float
    open_start: bool
    open_end: bool

    @property
    def duration(self) -> float:
        return self.t_end - self.t_start


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs of True as (first, last) inclusive index pairs."""
    if not mask.any():
        return []
    padded = np.concatenate([[False], mask, [False]]).astype(int)
    d = np.diff(padded)
    starts = np.flatnonzero(d == 1)
    ends = np.flatnonzero(d == -1) - 1
    return list(zip(starts.tolist(), ends.tolist(), strict=True))


def detect_gdcm_intervals(
    t,
    w,
    lam,
    tol: float | tuple[float, float] = 1e-9,
    *,
    names: Sequence[str] | None = None,
    merge_gap: float = 0.0,
    min_samples: int = 1,
) -> list[GdcmInterval]:
    """Find the GDCM intervals (w held at 0 with λ > 0) of each pair along a trajectory.

    Parameters
    ----------
    t : array_like (N,)
        Sample times (s), increasing.
    w, lam : array_like (N,) or (N, m)
        The complementarity variables per sample (units of the pair: A or V).
    tol : float or (float, float)
        ``w_tol`` or ``(w_tol, lam_tol)``: a sample is in GDCM when ``|w| <= w_tol`` and
        ``λ > lam_tol`` (``lam_tol`` defaults to ``w_tol``). Absolute, in the pair's units.
    names : sequence of str, optional
        Pair names for the result.
    merge_gap : float
        Runs separated by at most this time (s) are merged and counted as re-entries.
    min_samples : int
        Drop intervals with fewer samples (after merging).

    Returns
    -------
    list of GdcmInterval
        Sorted by start time, then pair.
    """
    t = np.asarray(t, dtype=float).ravel()
    w = np.asarray(w, dtype=float)
    lam = np.asarray(lam, dtype=float)
    if w.ndim == 1:
        w = w[:, None]
    if lam.ndim == 1:
        lam = lam[:, None]
    if w.shape != lam.shape or w.shape[0] != t.size:
        raise ValueError(f"shapes differ: t {t.shape}, w {w.shape}, lam {lam.shape}")
    w_tol, lam_tol = (tol, tol) if np.isscalar(tol) else (float(tol[0]), float(tol[1]))
    m = w.shape[1]
    if names is None:
        names = [f"pair{i}" for i in range(m)]
    if len(names) != m:
        raise ValueError(f"{len(names)} names for {m} pairs")
    N = t.size
    out: list[GdcmInterval] = []
    for i in range(m):
        mask = (np.abs(w[:, i]) <= w_tol) & (lam[:, i] > lam_tol)
        runs = _runs(mask)
        merged: list[list[int]] = []  # [start, end, reentries]
        for s, e in runs:
            if merged and t[s] - t[merged[-1][1]] <= merge_gap:
                merged[-1][1] = e
                merged[-1][2] += 1
            else:
                merged.append([s, e, 0])
        occ = 0
        for s, e, re in merged:
            if e - s + 1 < min_samples:
                continue
            occ += 1
            sel = np.arange(s, e + 1)
            sel = sel[mask[sel]]
            out.append(GdcmInterval(
                str(names[i]), i, float(t[s]), float(t[e]), int(s), int(e), occ, int(re),
                float(lam[sel, i].min()), float(lam[sel, i].max()),
                float(np.abs(w[sel, i]).max()), s == 0, e == N - 1,
            ))
    out.sort(key=lambda iv: (iv.t_start, iv.index))
    return out
