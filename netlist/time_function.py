"""A piecewise-constant function of time (:class:`TimeValue`): the value of a resistor stepped
in time (:mod:`netlist.time_value`), kept on the element that stands for it
(:attr:`netlist.circuit.Resistor.time_value`) for the writer and the notes; the PWL waveform
of a B source whose expression is such a function (:mod:`netlist.behavioural`)."""

from __future__ import annotations

from dataclasses import dataclass

from lcs.signals import Pwl

from .units import format_eng, format_number

__all__ = ["TimeValue"]


@dataclass(frozen=True)
class TimeValue:
    """A piecewise-constant function of time: ``values[0]`` until ``times[0]``, ``values[k]``
    from ``times[k-1]`` to ``times[k]``, ``values[-1]`` after ``times[-1]``.

    Attributes
    ----------
    times : tuple of float
        The instants where the value changes (s), increasing, all positive.
    values : tuple of float
        ``len(times) + 1`` values, each different from the next (Ω for a resistor).
    """

    times: tuple[float, ...]
    values: tuple[float, ...]

    def at(self, t: float) -> float:
        """The value at ``t`` (s); the new value from an instant on."""
        k = sum(1 for x in self.times if t >= x)
        return self.values[k]

    def pwl(self) -> Pwl:
        """The function as a PWL waveform that jumps at the instants (two points at each),
        the new value from the instant on."""
        times, values = [0.0], [self.values[0]]
        for t, before, after in zip(self.times, self.values, self.values[1:], strict=False):
            times += [t, t]
            values += [before, after]
        return Pwl(tuple(times), tuple(values))

    def expression(self) -> str:
        """The value as an ngspice expression of ``time`` that pelcs reads back to this
        function (numbers written bit for bit)."""
        out = format_number(self.values[-1])
        for t, v in zip(reversed(self.times), reversed(self.values[:-1]), strict=True):
            out = f"time < {format_number(t)} ? {format_number(v)} : {out}"
        return out

    def describe(self, unit: str) -> str:
        """``100 Ω until 12 ms, 50 Ω until 20 ms, 200 Ω after`` (values and instants in
        engineering notation)."""
        parts = [f"{format_eng(v, unit)} until {format_eng(t, 's')}"
                 for v, t in zip(self.values, self.times, strict=False)]
        return ", ".join(parts + [f"{format_eng(self.values[-1], unit)} after"])
