"""Whether Moreau's θ scheme with θ < 1 can be trusted on a switched LCS at a step h.

Moreau's scheme (Siconos ``EulerMoreauOSI``) weights ``A x`` with θ and takes ``λ`` fully
implicit. That is consistent as long as the diodes do not cancel a stiff part of ``A``. They
do when the ``λ = 0`` configuration of a mode (current-type pairs open, voltage-type pairs
shorted) routes a current through a path that conducting diodes short out: a 12-pulse
rectifier's star-point resistors in series with its output inductor, say. For pairs ``R`` of
relative degree 0 (``D_RR ≠ 0``) that conduct, ``λ_R ≈ -D_RR^+ (C_R x + ...)`` and the actual
dynamics are ``A_eff = A - B_R D_RR^+ C_R``. On one scalar mode, a step multiplies the state by

    (1 + h (1-θ) a_eff + G) / (1 - h θ a_eff + G),     G = h (1-θ) (a - a_eff):

with ``G <= -1`` the rate changes sign (the step's LCP may even have no solution), and for
``-1 < G < 0`` the dynamics are distorted by ``1/(1 + G)``. θ = 1 has ``G = 0``.

:func:`screen_theta` takes ``P = B_R D_RR^+ C_R`` (``R``: every pair with ``D_ii > 0``) per
mode, in energy coordinates, and reports a mode where ``h (1-θ)`` times the most negative
eigenvalue of its symmetric part is below ``-``:data:`G_LIMIT` (for a normal ``P`` that is
its most negative eigenvalue; the symmetric part also catches a cancellation ``P`` does not
show in its eigenvalues: a snubbered diode), with the pairs, the cancelled time constant and
the largest step at which θ would be safe. A heuristic on the worst case (all of ``R``
conducting), cheap and silent on every bundled converter.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

__all__ = ["G_LIMIT", "ThetaRisk", "screen_theta"]

#: |G| above which the θ scheme is reported. Small on purpose: where a cancellation exists,
#: θ < 1 converges at first order with a large constant (a buck whose freewheeling diode has
#: an RC snubber of 1 µs: at h = 0.1 µs (G = -0.05) θ = 1/2 leaves the mean output 2 % off,
#: θ = 1 0.006 %; at h = 0.025 µs still 0.5 % against 0.001 %; a 12-pulse rectifier at
#: |G| = 0.2: 19 % off in the output current), while θ = 1 is consistent.
G_LIMIT = 0.001

_SCREENED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

#: modes screened: every mode up to this many switches, else all-off and all-on
SCREEN_MAX_SWITCHES = 4


@dataclass(frozen=True)
class ThetaRisk:
    """A mode where θ < 1 integrates a stiff cancellation explicitly.

    Attributes
    ----------
    switches : str
        ``"S1 on, S2 off"`` or ``"no switches"``.
    pairs : tuple of str
        The relative-degree-0 diodes whose conduction cancels the stiff part.
    tau : float
        Time constant of the cancelled dynamics, s (``1/|Re μ|`` of ``B_R D_RR^+ C_R``).
    g : float
        The most negative ``Re G`` at the run's step and θ.
    h_max : float
        The largest step with ``|G| <= G_LIMIT`` at this θ, s.
    """

    switches: str
    pairs: tuple[str, ...]
    tau: float
    g: float
    h_max: float

    def message(self, h: float, theta: float) -> str:
        where = "" if self.switches == "no switches" else f" (mode {self.switches})"
        return (f"θ = {theta:g} is not reliable at h = {h:.3g} s{where}: with every diode at "
                f"λ = 0 the circuit has a time constant of {self.tau:.3g} s that conduction of "
                f"{', '.join(self.pairs)} cancels; Moreau's scheme takes λ implicitly and the "
                f"rest with θ, so that cancellation is integrated explicitly (G = "
                f"{self.g:.3g}, at most -{G_LIMIT:g} wanted)")


def _risk(lcs, h: float, theta: float, energy: np.ndarray | None
          ) -> tuple[float, float, tuple[str, ...]] | None:
    D = np.asarray(lcs.D, dtype=float)
    m = D.shape[0]
    n = np.asarray(lcs.A).shape[0]
    if m == 0 or n == 0 or theta >= 1.0:
        return None
    scale = max(1.0, float(np.abs(D).max()))
    R = [i for i in range(m) if D[i, i] > 1e-12 * scale]
    if not R:
        return None
    B = np.asarray(lcs.B, dtype=float)[:, R]
    C = np.asarray(lcs.C, dtype=float)[R, :]
    P = B @ np.linalg.pinv(D[np.ix_(R, R)]) @ C
    # In energy coordinates (x~ = L' x, the stored energy ½ x' E x = ½ |x~|², E = L L'), the
    # symmetric part of P: a P that is not normal (a snubber's diode feeding a state it does
    # not read) has zero eigenvalues and still a large cancellation, which the most negative
    # eigenvalue of the symmetric part measures; a P that only damps (a diode charging a
    # capacitor through a resistor) has none.
    if energy is not None and energy.shape == (n, n):
        try:
            L = np.linalg.cholesky(energy)
            P = L.T @ P @ np.linalg.inv(L.T)
        except np.linalg.LinAlgError:
            pass
    Sym = 0.5 * (P + P.T)
    mu, vec = np.linalg.eigh(Sym)
    worst = float(mu[0])
    if worst >= 0.0:
        return None
    # The pairs that carry the cancellation: those whose columns of B meet its eigenvector.
    weight = np.abs(vec[:, 0] @ B)
    names = tuple(lcs.pairs[R[j]].name for j in range(len(R))
                  if weight[j] > 1e-6 * max(weight.max(), 1e-300))
    return worst, h * (1.0 - theta) * worst, names


def screen_theta(system, h: float, theta: float, keys=None, energy: np.ndarray | None = None
                 ) -> list[ThetaRisk]:
    """The modes of a switched LCS where θ < 1 is not reliable at step ``h`` (see the module
    docstring); empty for θ = 1.

    Parameters
    ----------
    system : lcs.model.SwitchedLCS
    h : float
        Step, s.
    theta : float
        θ of the run.
    keys : sequence of mode keys, optional
        Default: every mode up to :data:`SCREEN_MAX_SWITCHES` switches, else all off and all
        on.
    energy : ndarray (n, n), optional
        The storage matrix (``½ x' E x`` J, :func:`lcs.theory.passivity.energy_matrix`): the
        coordinates in which the cancellation is measured (default the states' own).

    Returns
    -------
    list of ThetaRisk
    """
    if theta >= 1.0:
        return []
    # (kept with the system: repeated runs of one system at one step ask again)
    memo_key = (float(h), float(theta), None if keys is None else tuple(map(tuple, keys)),
                None if energy is None else np.asarray(energy, dtype=float).tobytes())
    try:
        memo = _SCREENED.setdefault(system, {})
    except TypeError:  # not weak-referenceable: not kept
        memo = {}
    if memo_key in memo:
        return list(memo[memo_key])
    memo[memo_key] = out = _screen(system, h, theta, keys, energy)
    return list(out)


def _screen(system, h: float, theta: float, keys, energy) -> list[ThetaRisk]:
    if keys is None:
        k = len(system.switches)
        keys = system.all_keys() if k <= SCREEN_MAX_SWITCHES else [
            tuple(False for _ in range(k)), tuple(True for _ in range(k))]
    out = []
    for key in keys:
        try:
            lcs = system.mode(tuple(bool(v) for v in key))
        except Exception:  # noqa: BLE001  (a degenerate mode is the run's to report)
            continue
        r = _risk(lcs, h, theta, energy)
        if r is None or r[1] > -G_LIMIT:
            continue
        worst, g, names = r
        sw = ", ".join(f"{s.name} {'on' if on else 'off'}"
                       for s, on in zip(system.switches, key, strict=True))
        out.append(ThetaRisk(sw or "no switches", names, 1.0 / abs(worst), g,
                             G_LIMIT / ((1.0 - theta) * abs(worst))))
    return out
