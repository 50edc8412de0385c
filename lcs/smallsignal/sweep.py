"""Frequency response of a switching converter by time-domain sinusoidal perturbation (the
brute-force reference, as a PLECS "AC sweep" measures it).

From the periodic steady state (state ``x_ss`` at ``t0``, switching period T), input
``inject`` gets ``a sin(2π f (t - t0))`` added; after a settling time the probes are recorded
over a window of ``cycles`` excitation periods that is also a whole number of switching
periods (the frequency is snapped to ``cycles / (N T)`` for an integer N), so that the
steady-state ripple (harmonics of 1/T) has no component at f. The response is the probe's
Fourier coefficient at f over the window divided by the input's (``-j a``).

Above fs/2 the response at the excitation frequency is not the whole story (the switching
folds the excitation onto |f - k fs|); the sweep measures the component at f all the same.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .response import FrequencyResponse


class SinePerturbation:
    """``base(t) + amplitude sin(2π freq (t - t0))``: a source with a small sinusoid added
    (vectorised; the base's breakpoints are kept, and the sum is not piecewise linear)."""

    piecewise_linear = False

    def __init__(self, base, amplitude: float, freq: float, t0: float):
        self.base = base
        self.amplitude = float(amplitude)
        self.freq = float(freq)
        self.t0 = float(t0)

    def __call__(self, t):
        t = np.asarray(t, dtype=float)
        return (np.asarray(self.base(t), dtype=float)
                + self.amplitude * np.sin(2 * np.pi * self.freq * (t - self.t0)))

    def breakpoints(self, t0: float, t1: float):
        bp = getattr(self.base, "breakpoints", None)
        return bp(t0, t1) if bp is not None else np.empty(0)


def snap_frequency(f: float, period: float, cycles: int) -> tuple[float, int]:
    """The frequency nearest ``f`` whose ``cycles`` periods are a whole number ``N`` of
    switching periods: ``(cycles / (N T), N)``."""
    n = max(1, int(round(cycles / (f * period))))
    return cycles / (n * period), n


def fourier_coefficient(t: np.ndarray, y: np.ndarray, f: float, t0: float) -> np.ndarray:
    """``(2 / Tw) ∫ y(t) e^{-j 2π f (t - t0)} dt`` over the samples' span (trapezoidal rule),
    per column of ``y`` (shape (N,) or (N, P))."""
    y = np.asarray(y, dtype=float)
    e = np.exp(-2j * np.pi * f * (t - t0))
    g = y * (e[:, None] if y.ndim == 2 else e)
    dt = np.diff(t)
    integral = (0.5 * (g[1:] + g[:-1]) * (dt[:, None] if y.ndim == 2 else dt)).sum(axis=0)
    return 2.0 * integral / (t[-1] - t[0])


def sweep_response(simulate, signals: Sequence, inject_index: int, inject_name: str,
                   x_ss: np.ndarray, t0: float, period: float, freqs: Sequence[float],
                   probes: Sequence[str], *, amplitude: float, cycles: int = 3,
                   settle: float = 0.0, settle_cycles: int = 2) -> FrequencyResponse:
    """The response of ``probes`` to a sinusoidal perturbation of input ``inject_index``.

    Parameters
    ----------
    simulate : callable
        ``simulate(signals, x0, t_start, t_stop, probes) -> SimulationResult`` (every step
        saved), e.g. :func:`lcs.integrators.moreau.integrator.simulate` with the system and options
        bound.
    signals : sequence
        The unperturbed inputs.
    inject_index : int
        Which input is perturbed; ``inject_name`` names it.
    x_ss : ndarray, shape (n,)
        State of the periodic steady state at ``t0`` (s).
    period : float
        Switching period T, s.
    freqs : sequence of float
        Requested frequencies, Hz (each snapped, see :func:`snap_frequency`).
    probes : sequence of str
    amplitude : float
        Perturbation amplitude, in the input's unit (small: the response is linearised).
    cycles : int
        Excitation periods in the measurement window.
    settle, settle_cycles : float, int
        Settling before the window: at least ``settle`` seconds and ``settle_cycles``
        excitation periods, rounded up to whole switching periods.

    Returns
    -------
    FrequencyResponse
    """
    out_f, rows, notes = [], [], []
    probes = list(probes)
    for f in freqs:
        fa, n = snap_frequency(float(f), period, cycles)
        k2 = 2.0 * fa * period
        if abs(k2 - round(k2)) < 1e-9:
            notes.append(f"at {fa:.6g} Hz = {round(k2)} fs/2 the excitation's image at "
                         f"{fa:.6g} - fs folds onto it: the sweep measures their sum (the "
                         "exact method gives the component of the excitation alone)")
        k_settle = int(np.ceil(max(settle, settle_cycles / fa) / period - 1e-9))
        t1 = t0 + k_settle * period
        t2 = t1 + n * period
        sig = list(signals)
        sig[inject_index] = SinePerturbation(signals[inject_index], amplitude, fa, t0)
        res = simulate(sig, x_ss, t0, t2, probes)
        res.raise_if_error()
        keep = res.t >= t1 - 1e-12 * period
        c = fourier_coefficient(res.t[keep], res.y[keep], fa, t0)
        rows.append(c / (-1j * amplitude))
        out_f.append(fa)
    order = np.argsort(out_f)
    return FrequencyResponse(np.asarray(out_f)[order], tuple(probes),
                             np.asarray(rows)[order].reshape(len(out_f), len(probes)),
                             inject_name, "sweep", float(period), notes)
