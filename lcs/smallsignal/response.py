"""A small-signal frequency response: per probe, the complex ratio of its component at the
excitation frequency to the injected perturbation's, and what designers read from it (dB,
degrees, crossover and margins of a loop gain), with a python-control export."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class FrequencyResponse:
    """Responses ``H[f, probe]`` to a perturbation of one input.

    Attributes
    ----------
    freq : ndarray, shape (F,)
        Excitation frequencies, Hz.
    probes : tuple of str
        Probe names (columns of ``H``).
    H : ndarray of complex, shape (F, P)
        Component of each probe at ``freq`` per unit of the injected input's component (the
        probe's unit per the input's unit: V/V, A/V, V/A, ...).
    inject : str
        The perturbed input (an independent source).
    method : str
        ``"sweep"`` (time-domain sinusoidal perturbation) or ``"exact"``.
    period : float
        The switching (sampling) period T of the steady state, s.
    notes : list of str
    orbit : dict or None
        The periodic steady state the response is taken around (JSON-ready: states, state
        at the sampling instant, multipliers, switching instants).
    margins : LoopMargins or None
        For a loop gain (probe ``"T"``): crossover and margins.
    sampled : lcs.smallsignal.ltp.SampledData or None
        The sampled-data model of the period map (exact method): ``δx_{k+1} = Φ δx_k +
        Γ δu_k``; :attr:`model` gives it as a python-control ``StateSpace``.
    """

    freq: np.ndarray
    probes: tuple[str, ...]
    H: np.ndarray
    inject: str
    method: str
    period: float
    notes: list = field(default_factory=list)
    orbit: dict | None = None
    margins: LoopMargins | None = None
    sampled: object | None = None

    def __repr__(self) -> str:
        # A few lines, not the arrays, the orbit and the sampled-data model.
        f = np.asarray(self.freq)
        span = f"{f.min():.4g} .. {f.max():.4g} Hz" if f.size else "no frequency"
        lines = [f"<FrequencyResponse: {f.size} frequencies, {span}; inject {self.inject}; "
                 f"probes {', '.join(self.probes)}; method {self.method}, "
                 f"T = {self.period:.6g} s>"]
        if self.margins is not None:
            lines.append(f"  margins: {self.margins}"[:200])
        return "\n".join(lines)

    @property
    def model(self):
        """The sampled-data model as a discrete-time python-control ``StateSpace`` (``dt`` =
        T, named states, inputs and outputs), None for the sweep method."""
        return None if self.sampled is None else self.sampled.to_statespace()

    def __getitem__(self, probe: str) -> np.ndarray:
        """The complex response of one probe, shape (F,)."""
        lower = [p.lower() for p in self.probes]
        if probe.lower() not in lower:
            raise KeyError(f"no probe {probe!r}; probes: {', '.join(self.probes)}")
        return self.H[:, lower.index(probe.lower())]

    def mag_db(self, probe: str) -> np.ndarray:
        """|H| in dB, shape (F,); -inf where the response is exactly zero (a probe the input
        cannot move, such as a node held by a voltage source)."""
        with np.errstate(divide="ignore"):
            return 20.0 * np.log10(np.abs(self[probe]))

    def phase_deg(self, probe: str) -> np.ndarray:
        """Phase in degrees, unwrapped along the frequency axis, shape (F,)."""
        return np.degrees(np.unwrap(np.angle(self[probe])))

    def to_frd(self):
        """The responses as a python-control ``FrequencyResponseData`` (one input, one output
        per probe, frequencies in rad/s)."""
        import control

        resp = self.H.T[:, None, :]  # (outputs, inputs, frequencies)
        return control.FrequencyResponseData(resp, 2 * np.pi * self.freq,
                                             inputs=[self.inject], outputs=list(self.probes))

    def to_dict(self) -> dict:
        """JSON-ready: ``{"freq": [...], "probes": {name: {"mag_db", "phase_deg"}}, ...}``."""
        return {
            "freq": self.freq.tolist(),
            "inject": self.inject,
            "method": self.method,
            "period": self.period,
            "probes": {p: {"mag_db": self.mag_db(p).tolist(),
                           "phase_deg": self.phase_deg(p).tolist(),
                           "re": self[p].real.tolist(), "im": self[p].imag.tolist()}
                       for p in self.probes},
            "orbit": self.orbit,
            **({"loop": self.margins.to_dict()} if self.margins is not None else {}),
            "notes": list(self.notes),
        }


@dataclass(frozen=True)
class LoopMargins:
    """Crossover (Hz) of a loop gain and its phase margin (degrees), and the frequency of a
    -180° phase crossing with the gain margin there (dB); None where the sweep does not reach
    them."""

    crossover: float | None
    phase_margin: float | None
    phase_crossover: float | None
    gain_margin: float | None

    def to_dict(self) -> dict:
        return {"crossover_hz": self.crossover, "phase_margin_deg": self.phase_margin,
                "phase_crossover_hz": self.phase_crossover, "gain_margin_db": self.gain_margin}


def loop_margins(freq: np.ndarray, T: np.ndarray) -> LoopMargins:
    """Crossover and margins of a loop gain ``T(f)`` (log-linear interpolation between the
    sweep's points)."""
    freq = np.asarray(freq, dtype=float)
    with np.errstate(divide="ignore"):  # (a zero loop gain is -inf dB: no crossover there)
        mag = 20.0 * np.log10(np.abs(T))
    ph = np.degrees(np.unwrap(np.angle(T)))
    fc = pm = fp = gm = None
    lf = np.log10(freq)
    for i in range(len(freq) - 1):
        if fc is None and (mag[i] >= 0.0) != (mag[i + 1] >= 0.0):
            a = mag[i] / (mag[i] - mag[i + 1])
            fc = float(10 ** (lf[i] + a * (lf[i + 1] - lf[i])))
            pm = float((360.0 + ph[i] + a * (ph[i + 1] - ph[i])) % 360.0 - 180.0)
        # Phase crossing of -180° (mod 360): the turn count of (phase + 180) changes.
        k0, k1 = np.floor((ph[i] + 180.0) / 360.0), np.floor((ph[i + 1] + 180.0) / 360.0)
        if fp is None and k0 != k1:
            target = -180.0 + 360.0 * max(k0, k1)
            a = (target - ph[i]) / (ph[i + 1] - ph[i])
            fp = float(10 ** (lf[i] + a * (lf[i + 1] - lf[i])))
            gm = float(-(mag[i] + a * (mag[i + 1] - mag[i])))
    return LoopMargins(fc, pm, fp, gm)
