"""The degenerate topologies of a switch mode, which leave no explicit state-space form: a
loop of voltage-defined branches (capacitors, voltage sources, closed switches, E/H sources)
or a cutset of current-defined ones (inductors, current sources, F/G sources), found on the
mode's branch graph (:mod:`netlist.topology`) and reported with the elements named.

The inductors a mode pins at zero current (:mod:`netlist.formulation`: in series with an open
switch, or with one end unconnected) are 0 V branches there, neither current-defined nor able
to close a loop (each is a bridge).
"""

from __future__ import annotations

from collections.abc import Sequence

from .circuit import GROUND, Element
from .errors import Diagnostic, NetlistError
from .mna import VOLTAGE_KINDS
from .perfect_coupling import transformer_sources
from .topology import find_cutset, find_loop

__all__ = ["CURRENT_KINDS", "check_topology", "pinnable_inductors", "pinned_in"]

# Branches whose current is imposed (a cutset of them is degenerate).
CURRENT_KINDS = frozenset("LIFG")


def _error(message: str, hint: str, elements: Sequence[str], el: Element,
           file: str | None) -> NetlistError:
    return NetlistError(Diagnostic(message=message, location=el.location, hint=hint,
                                   elements=tuple(elements)), file=file)


def check_topology(f, on: frozenset[str], desc: str) -> None:
    """Raise the :class:`NetlistError` of a mode's loop of voltage-defined or cutset of
    current-defined branches, if it has one.

    Parameters
    ----------
    f : netlist.formulation._Formulator
        The circuit's bookkeeping (``two_terminal``, ``by_key``, ``switches``, ``file``).
    on : frozenset of str
        Keys of the closed switches and of the inductors the mode pins.
    desc : str
        The mode in words (``"S1=off"``), for the message.
    """
    where = f" with {desc}" if desc else ""
    ideal = transformer_sources(f.circuit)  # (their E, F sources impose nothing)
    voltage_branches = [
        (el.name, *el.nodes) for el in f.two_terminal
        if (el.kind in VOLTAGE_KINDS and el.key not in ideal) or (el.kind in "SL" and el.key in on)
    ]
    loop = find_loop(voltage_branches)
    if loop is not None:
        closing = [name for name in loop if f.by_key[name.lower()].kind == "S"]
        hint = ("their voltages are tied by Kirchhoff's voltage law, so they cannot all be "
                "states or sources; add a small series resistance in the loop (e.g. the "
                "capacitor's ESR or a source resistance)")
        if closing and any(f.by_key[name.lower()].kind == "C" for name in loop):
            # (a capacitor straight across voltage sources is read: no state; one that an
            # ideal switch puts there jumps to their voltage, an impulse of current)
            hint = (f"closing {', '.join(closing)} ties the voltages at once: a capacitor "
                    "voltage would jump, an impulse of current that ideal switches cannot "
                    "carry; run with --devices pwl (each switch at its on resistance, RON of "
                    "its model) or add a small series resistance in the loop (e.g. the "
                    "capacitor's ESR)")
        raise _error(
            f"loop of capacitors/voltage sources{where}: {' - '.join(loop)} (capacitors, "
            "voltage sources, closed switches and E/H sources with no impedance between "
            "them)",
            hint, loop, el=f.by_key[loop[-1].lower()], file=f.file)
    contracted = [
        el.nodes for el in f.two_terminal
        if (el.kind not in CURRENT_KINDS or el.key in on or el.key in ideal)
        and (el.kind != "S" or el.key in on)
    ]
    current_branches = [(el.name, *el.nodes) for el in f.two_terminal
                        if el.kind in CURRENT_KINDS and el.key not in on | ideal]
    cut = find_cutset(contracted, current_branches, GROUND)
    if cut is not None and all(f.by_key[c.lower()].kind == "L" for c in cut) \
            and any(sw.key not in on for sw in f.switches):
        # (inductors that only the open switches connect: what an ideal switch does to
        # their current is a jump to zero, which the run does not model)
        raise _error(
            f"cutset of inductors{where}: {', '.join(cut)} (with these switches open, "
            "no other branch carries the current of the inductors)",
            "an ideal switch opening there would cut the inductor current to zero at "
            "once (its flux lost, and ½ L i² with it), a jump that pelcs applies only to "
            "an uncoupled inductor with nothing else in series (not to coupled or "
            "series-tied inductors); give the current a path that stays: a freewheeling "
            "diode, an RC snubber or a large resistance across the switch or the inductor",
            cut, el=f.by_key[cut[0].lower()], file=f.file)
    if cut is not None:
        raise _error(
            f"cutset of inductors/current sources{where}: {', '.join(cut)} (inductors, "
            "current sources and F/G sources are the only branches joining one part of the "
            "circuit to the rest)",
            "their currents are tied by Kirchhoff's current law, so they cannot all be "
            "states or sources; give the current another path, e.g. a large resistance or "
            "a freewheeling diode across the inductor",
            cut, el=f.by_key[cut[0].lower()], file=f.file)


def _fixed_current_index(f) -> dict[str, int]:
    """Index of each non-switch, non-diode branch (by key) among the fixed edges of
    ``f._current_bridges`` (the branches carrying current)."""
    fixed = [el for el in f.two_terminal if el.kind != "S" and el.kind != "D"]
    return {el.key: i for i, el in enumerate(fixed)}


def pinnable_inductors(f) -> frozenset[str]:
    """Uncoupled inductors, other than ``f.pinned`` (pinned in every mode), that are bridges
    of the branches carrying current once every switch is open: the modes whose open
    switches leave nothing else in series with them pin them at zero current."""
    coupled = {str(name).lower() for el in f.elements if el.kind == "K"
               for name in el.inductors}
    cut = f._current_bridges.bridges(())
    return frozenset(key for key, i in _fixed_current_index(f).items()
                     if f.by_key[key].kind == "L" and i in cut and key not in coupled
                     and key not in f.pinned)


def pinned_in(f, on: frozenset[str]) -> frozenset[str]:
    """Keys of the inductors pinned at zero current with the switches ``on`` closed."""
    if not f.pinnable:
        return f.pinned
    cut = f._current_bridges.bridges(f._closed(on))
    index = _fixed_current_index(f)
    return f.pinned | {key for key in f.pinnable if index[key] in cut}
