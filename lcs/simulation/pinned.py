"""States that a switch mode holds at zero, and their jump to zero when the mode is entered.

An inductor that the open switches leave with no path for its current (in series with an
ideal switch that opens) has its current pinned at zero in those modes
(:attr:`lcs.model.ModeModel.pinned`): the LCS gives it no dynamics and takes it into nothing.
An ideal switch cuts the current at once: entering such a mode with a current, the state
jumps to zero and the energy ``½ L i²`` it stored is lost (a real switch turns it into a
voltage spike across itself, or an arc; ngspice's SW, open, spends it in its ``ROFF`` within
``L / ROFF``, through a spike of ``i ROFF``). This is the inductor's counterpart of a
capacitor whose charge jumps when a diode closes it onto another voltage, except that no
multiplier of the step can carry it (the constraint ``i = 0`` is two-sided), so the run
applies it between two of its windows.

The run therefore cuts its windows at every known switching instant (source-driven switches,
Python controllers' commands) when the system has such states, and sets them to zero where
the mode about to start pins them. A comparator-driven switching inside a window cannot be
handled so: a run that enters a pinning mode there gets a
:class:`~lcs.results.SimulationError` (``kind = "pinned_jump"``) saying so, and its result
ends there.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..model import TERMINALS_OPTION, ModeKey, SwitchedLCS
from ..results import SimulationError
from .codes import OP_SET
from .problem import fmt_mode
from .schedule import KnownSwitchings

__all__ = ["PinnedJumps"]


def key_after(key: int, known: KnownSwitchings, t: float, tol: float) -> int:
    """The switch key once the ``OP_SET`` entries of ``known`` at ``t`` (to ``tol``) apply."""
    from ..bits import from_words

    for tk, op, a, b in zip(known.t, known.op, known.a, known.b, strict=True):
        if abs(tk - t) <= tol and op == OP_SET:
            key = (key & ~from_words(a)) | from_words(b)
    return key


def _self_controlled(sw) -> bool:
    """Whether a switch's control is the voltage across its own terminals (either way): the
    one a cut's voltage surely reaches (the others' controls may not see it, and the run has
    no voltage for the cut to tell)."""
    opts = sw.options if isinstance(sw.options, dict) else {}
    pair = str(opts.get(TERMINALS_OPTION, ""))
    if not pair.startswith("v(") or not str(sw.control).startswith("v("):
        return False

    def nodes(v: str) -> list:
        return v[2:-1].lower().split(",")

    # (a terminal inside the switch's own model, as its RON's node with --devices pwl,
    # stands for the outer one behind it)
    inner = f"{sw.name.lower()}#"
    ctl, ends = nodes(sw.control), nodes(pair)
    rest = [n for n in ends if n not in ctl]
    return len(ctl) == 2 and len(rest) <= 1 and all(n.startswith(inner) for n in rest) and (
        len(set(ends) & set(ctl)) == 2 - len(rest))


@dataclass
class PinnedJumps:
    """The jumps to zero of the pinned states over one run, and their notes.

    Attributes
    ----------
    system : SwitchedLCS
    k : int
        Number of switches.
    jumps : dict
        Per state index: ``[count, first time (s), first value, energy lost in all (J)]``.
    instants : list of float
        The instants where the run checked (window starts), s.
    """

    system: SwitchedLCS
    k: int
    #: The switches their comparators drive from the state (their indices)
    comparators: tuple = ()
    jumps: dict = field(default_factory=dict)
    instants: list = field(default_factory=list)

    def apply(self, mode: ModeKey, x: np.ndarray, t: float) -> bool:
        """Set to zero, in place, the states of ``x`` that ``mode`` pins; whether any was
        nonzero."""
        self.instants.append(t)
        pinned = self.system.pinned(mode)
        jumped = False
        for i, coef in pinned.items():
            if x[i] != 0.0:
                rec = self.jumps.setdefault(i, [0, t, float(x[i]), 0.0])
                rec[0] += 1
                rec[3] += 0.5 * coef * float(x[i]) ** 2
                x[i] = 0.0
                jumped = True
        return jumped

    def carried(self, mode: ModeKey, x: np.ndarray, t: float) -> SimulationError | None:
        """The error of a cut, at a known instant ``t`` where ``mode`` starts from the state
        ``x``, of a nonzero current that a switch off in ``mode``, controlled by its own
        terminals, would give a path to by turning on, or None.

        The cut comes first at the instant, and the comparator would see only what follows
        it; a real switch's current drives the voltage across the open switches up at once,
        and a comparator that watches it (a switch controlled by its own terminals, as a
        diode) turns on and carries the current: the run's cut would be no solution.
        """
        pinned = self.system.pinned(mode)
        cut = [i for i in pinned if x[i] != 0.0]
        if not cut:
            return None
        for j in self.comparators:
            if mode[j] or not _self_controlled(self.system.switches[j]):
                continue
            other = tuple(True if i == j else on for i, on in enumerate(mode))
            try:
                freed = [i for i in cut if i not in self.system.pinned(other)]
            except Exception:  # (a mode the circuit cannot take: no way out there)
                continue
            if not freed:
                continue
            name = self.system.switches[j].name
            names = ", ".join(self.system.states[i] for i in freed)
            return self._error(t, mode, (
                   f"the open switches cut {names} here, where switch {name}, off, would give "
                   "it a path by turning on: its "
                   "comparator would see the voltage the current drives across it (a switch "
                   "controlled by its own terminals, as a diode, is the usual case), which an "
                   "ideal switch's cut does not let it; the results stop there. Give the "
                   "current a path that stays (a diode in place of the switch)"))
        return None

    def _error(self, t: float, mode: ModeKey, why: str) -> SimulationError:
        """The ``pinned_jump`` error at ``t`` (s) in ``mode``, ``why`` after the place."""
        desc = {s.name: ("on" if on else "off")
                for s, on in zip(self.system.switches, mode, strict=True)}
        return SimulationError(f"t = {t:.9g} s, mode: {fmt_mode(desc)}: {why}",
                               kind="pinned_jump", time=t, t_prev=t, mode=desc)

    def notes(self) -> list[str]:
        """One note per state that jumped."""
        # (plain numbers: the layers above write values for people, this one only says them)
        out = []
        for i, (count, t0, x0, energy) in sorted(self.jumps.items()):
            name = self.system.states[i]
            unit = "A" if name.lower().startswith("i(") else ""
            times = "once" if count == 1 else f"{count} times"
            out.append(
                f"{name}: the open switches leave it no path, so the ideal switches cut it to "
                f"0 {times} (first at t = {t0:.4g} s, from {x0:.4g} {unit}".rstrip()
                + f"): its flux is lost, {energy:.4g} J "
                "(½ L i²) in all; a real switch spends it in a voltage spike across itself "
                "(ngspice's SW in its ROFF)")
        return out

    def unhandled(self, mode0: ModeKey, events, tol: float,
                  sliding=()) -> SimulationError | None:
        """The error of a run (from ``mode0``, through the mode changes ``events``) that
        entered a pinning mode between the instants it checked (a comparator's switching),
        or that slid (``sliding``: ``[(switch name, t_start, t_end or None)]``) between two
        modes that do not pin the same states, or None."""
        first = self._sliding_across_a_cut(mode0, events, tol, sliding)
        checked = np.array(sorted(self.instants))
        prev = self.system.pinned(mode0)
        for t, mode in events:
            if first is not None and t > first.time:
                return first
            pinned = self.system.pinned(mode)
            new = [i for i in pinned if i not in prev]
            prev = pinned
            if not new:
                continue
            j = np.searchsorted(checked, t - tol)
            if j < len(checked) and abs(checked[j] - t) <= tol:
                continue
            names = ", ".join(self.system.states[i] for i in new)
            return self._error(t, mode, (
                   f"a comparator's switching leaves {names} no path: an ideal switch cuts it "
                   "to 0 there (its flux lost), a "
                   "jump that pelcs applies only at known switching instants (switches "
                   "driven by sources or Python controllers), so the results stop there. "
                   "Give the current a path that stays (a freewheeling diode, an RC "
                   "snubber), or drive the switch from a source"))
        return first

    def _sliding_across_a_cut(self, mode0: ModeKey, events, tol: float,
                              sliding) -> SimulationError | None:
        """The error of the first sliding interval whose two modes do not pin the same
        states, or None.

        A switch slides (Filippov) where its control, the instant it turns, wants it back:
        the run then blends its two modes. Where one of them leaves an inductor no path, its
        current is cut at once on entering it, and a blend that averages a current with its
        cut is no solution of the circuit. It is what a switch controlled by its own terminal
        voltage meets (``S2 0 sw sw 0``, on while v(sw) > 0, as a buck's freewheeling path):
        off, it cuts the inductor's current, after which its control is positive and it turns
        on, carrying the current the other way; blended, it would hold v(sw) at its threshold
        as an ideal diode would (a buck's output at V·D where ngspice gives nearly 0 V).
        """
        times = [t for t, _ in events]
        modes = [tuple(md) for _, md in events]
        index = {s.name: i for i, s in enumerate(self.system.switches)}
        for name, t0, _t1 in sorted(sliding, key=lambda r: r[1]):
            sw = index[name]
            j = int(np.searchsorted(times, t0 + tol, side="right")) - 1
            mode = modes[j] if j >= 0 else tuple(mode0)
            other = tuple(not on if i == sw else on for i, on in enumerate(mode))
            a, b = self.system.pinned(mode), self.system.pinned(other)
            if set(a) == set(b):
                continue
            cut = [i for i in (*a, *b) if (i in a) != (i in b)]
            names = ", ".join(dict.fromkeys(self.system.states[i] for i in cut))
            return self._error(t0, mode, (
                   f"switch {name} would slide on its threshold (its control wants it back the "
                   "instant it turns) between a mode "
                   f"where {names} has a path and one where the open switches leave it none: "
                   "an ideal switch cuts that current at once, and a sliding blend of the two "
                   "modes is no solution of the circuit (a switch controlled by its own "
                   "terminals, as a diode, is the usual cause), so the results stop there. "
                   "Give the current a path that stays (for a freewheeling path, a diode in "
                   "place of the switch)"))
        return None

