"""The time step and the print grid of a run, from the netlist's ``.tran`` and its sources.

``.tran TSTEP TSTOP [TSTART [TMAX]]``: TSTEP is ngspice's print interval, not its step.
ngspice bounds its own steps by TMAX, or without TMAX by ``min(TSTEP, (TSTOP - TSTART) / 50)``
(ngspice 39, ``traninit.c``), lands on the sources' breakpoints and shortens them further where
its error estimate says so. pelcs takes a fixed step: that bound, no longer than what resolves
the smooth sources (:func:`tran_step`); it writes the TSTEP grid unless that grid is too coarse
to show the sources (:func:`print_step`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from lcs.signals import Exp, Pulse, Signal, Sin

from ..circuit import Tran

__all__ = ["default_step", "print_step", "smooth_step", "source_periods", "tran_step"]

# Default step without .tran: this many steps per shortest source period, and at least this
# many steps per run (a switching converter needs ~100 steps per period for 0.1 % accuracy
# of the averages with θ = 1/2; see tests/test_simulate_reference.py).
STEPS_PER_PERIOD = 100
MIN_STEPS_PER_RUN = 5000
# ngspice's step bound without TMAX: (TSTOP - TSTART) / this (ngspice 39, traninit.c)
NGSPICE_STEPS_PER_RUN = 50
# Steps per written EXP time constant that resolve the exponential.
STEPS_PER_TAU = 20
# A print interval longer than this fraction of a source period does not show the source.
SHOWN_PER_PERIOD = 10


def default_step(waves: Sequence[Signal], tstop: float) -> float:
    """Step for a run without ``.tran`` step: 1/100 of the shortest source period.

    Parameters
    ----------
    waves : sequence of Signal
        The source waveforms as parsed (unresolved: only explicit periods count).
    tstop : float
        Stop time, s.

    Returns
    -------
    float
        ``min(tstop / 5000, period / 100)`` over the PULSE periods and SIN periods given, s.
    """
    h = tstop / MIN_STEPS_PER_RUN
    for w in waves:
        if isinstance(w, Pulse) and w.per:
            h = min(h, w.per / STEPS_PER_PERIOD)
        elif isinstance(w, Sin) and w.freq:
            h = min(h, 1.0 / (w.freq * STEPS_PER_PERIOD))
        elif (top := _top_frequency(w, tstop)) is not None:
            h = min(h, 1.0 / (top * STEPS_PER_PERIOD))
    return h


def _top_frequency(w: Signal, tstop: float | None = None) -> float | None:
    """The highest frequency of a modulated source (SFFM, AM) written in the netlist, Hz; of
    a B source of time over ``[0, tstop]`` where given (the slope of a sine's argument that
    is not affine: ``sin(2*pi*100k*(time - floor(time/T)*T))``, a chirp)."""
    f = getattr(w, "top_frequency", None)
    top = f() if f is not None else None
    run = getattr(w, "run_frequency", None)
    if run is not None and tstop is not None and tstop > 0:
        top = max(top or 0.0, run(0.0, tstop))
    return top if top else None


def smooth_step(waves: Sequence[Signal], names: Sequence[str] | None = None,
                tstop: float | None = None) -> tuple[float, str]:
    """The longest step that resolves the smooth sources, s (inf when there is none), and
    what sets it.

    A PULSE or PWL source needs no bound: its corners are step boundaries and it is linear in
    between. A SIN needs :data:`STEPS_PER_PERIOD` steps a period (θ = 1/2 then follows it to
    0.03 % in phase), an EXP :data:`STEPS_PER_TAU` steps a time constant; only values written
    in the netlist count (those ngspice fills from ``.tran`` follow the step anyway).
    """
    h, what = math.inf, ""
    for j, w in enumerate(waves):
        name = f" {names[j]}" if names is not None else ""
        if isinstance(w, Sin) and w.freq:
            if 1.0 / (w.freq * STEPS_PER_PERIOD) < h:
                h = 1.0 / (w.freq * STEPS_PER_PERIOD)
                what = f"1/{STEPS_PER_PERIOD} of the period of the SIN source{name}"
        elif (top := _top_frequency(w, tstop)) is not None:
            if 1.0 / (top * STEPS_PER_PERIOD) < h:
                h = 1.0 / (top * STEPS_PER_PERIOD)
                what = (f"1/{STEPS_PER_PERIOD} of the shortest period of the "
                        f"{getattr(w, 'keyword', type(w).__name__.upper())} source{name}")
        elif isinstance(w, Exp):
            for tau in (w.tau1, w.tau2):
                if tau and tau / STEPS_PER_TAU < h:
                    h = tau / STEPS_PER_TAU
                    what = f"1/{STEPS_PER_TAU} of a time constant of the EXP source{name}"
    return h, what


def source_periods(waves: Sequence[Signal]) -> list[float]:
    """The periods written in the netlist (PULSE PER, SIN 1/FREQ), s."""
    out = []
    for w in waves:
        if isinstance(w, Pulse) and w.per:
            out.append(float(w.per))
        elif isinstance(w, Sin) and w.freq:
            out.append(1.0 / w.freq)
    return out


def tran_step(tran: Tran, waves: Sequence[Signal], tstop: float,
              names: Sequence[str] | None = None) -> tuple[float, str | None]:
    """The step of a run from a ``.tran`` line, s, and a note when it is not TSTEP.

    ``.tran TSTEP`` is ngspice's print interval, not its step: ngspice takes its own steps,
    at most TMAX, or without TMAX at most ``min(TSTEP, (TSTOP - TSTART) / 50)`` (ngspice 39,
    ``traninit.c``), lands on the sources' breakpoints and shortens them further where its
    error estimate says so. pelcs takes a fixed step: that bound, and no longer than what
    resolves the smooth sources (:func:`smooth_step`). A TSTEP that is already finer is kept.

    Parameters
    ----------
    tran : Tran
    waves : sequence of Signal
        The sources as parsed.
    tstop : float
        Stop time of the run, s.
    names : sequence of str, optional
        The sources' names, for the note.
    """
    span = tstop - tran.tstart if 0 <= tran.tstart < tstop else tstop
    if tran.no_tstep and not tran.tmax:
        # LTspice's .tran 0 TSTOP: no print interval, no bound of ngspice's: the step of a
        # run without .tran, 1/100 of the shortest source period (its tstep, TSTOP/1000, is
        # only the print interval: a 100 kHz buck run for 10 ms would get one step a period)
        h = default_step(waves, span)
        # (and no longer than what resolves the smooth sources: an EXP's time constant)
        smooth, what = smooth_step(waves, names, tstop)
        if smooth < h:
            return smooth, f"step h = {_eng_s(smooth)}: {what} (LTspice's .tran 0 TSTOP)"
        return h, (f"step h = {_eng_s(h)}: LTspice's .tran 0 TSTOP gives no step; 1/"
                   f"{STEPS_PER_PERIOD} of the shortest source period, {MIN_STEPS_PER_RUN} "
                   "steps a run at least")
    if tran.tmax:
        h = float(tran.tmax)
    else:
        h = min(float(tran.tstep), span / NGSPICE_STEPS_PER_RUN)

    def bound() -> str:  # (only for a note: a design loop asks for the step every run)
        if tran.tmax:
            return f".tran TMAX = {_eng_s(tran.tmax)}"
        return (f"ngspice's bound min(TSTEP, (TSTOP - TSTART)/{NGSPICE_STEPS_PER_RUN}) = "
                f"{_eng_s(h)}")

    smooth, what = smooth_step(waves, names, tstop)
    if smooth < h:
        return smooth, (f"step h = {_eng_s(smooth)}: {what} (shorter than {bound()}; .tran "
                        f"TSTEP = {_eng_s(tran.tstep)} is ngspice's print interval, not its "
                        "step)")
    if not tran.tmax and h < tran.tstep:
        return h, (f"step h = {_eng_s(h)}: {bound()} (.tran TSTEP = {_eng_s(tran.tstep)} is "
                   "ngspice's print interval, not its step)")
    return h, None


def _eng_s(x: float) -> str:
    from ..units import format_eng

    return format_eng(x, "s")


def print_step(tran: Tran | None, waves: Sequence[Signal], h: float
               ) -> tuple[float | None, str | None]:
    """The spacing of the points written by default (s), and a note when it is not TSTEP.

    As ngspice prints at its ``.tran TSTEP`` interval, pelcs writes that grid, unless it is
    finer than the step ``h`` (then every step: interpolating below the step adds points and
    no information) or too coarse to show the sources: more than 1/:data:`SHOWN_PER_PERIOD`
    of the shortest source period (a 50 Hz sine printed every 10 ms is printed at its zero
    crossings), in which case every step is written and the note says so. None: every step.
    """
    if tran is None or not tran.tstep > 0 or tran.tstep < h * (1 - 1e-9):
        return None, None
    periods = source_periods(waves)
    if periods and tran.tstep > min(periods) / SHOWN_PER_PERIOD:
        return None, (f".tran TSTEP = {_eng_s(tran.tstep)} is too coarse to show a source of "
                      f"period {_eng_s(min(periods))}: every step ({_eng_s(h)}) is written "
                      "instead")
    return float(tran.tstep), None
