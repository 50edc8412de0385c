"""Capacitors whose value is constant below a knee of their own voltage.

A magnetic core modelled by its magnetising capacitor (the pess transformers' gyrator-capacitor
model) saturates past a knee::

    Cper n1 n2 c = 'v(n1,n2) < 5 ? {C} : {0.99*C*exp(-10*v(n1,n2)) + 0.01*C}'

Below the knee the capacitor is the constant ``C``: exactly linear. pelcs reads such a value
(``cond ? C0 : anything``, ``cond`` a comparison of an affine form of the capacitor's own
voltage with a constant, ``C0`` constant) as the capacitor ``C0`` and checks, after the run,
that the voltage stayed on the constant side of the knee at every stored point; the run is a
:class:`~netlist.errors.NetlistError` naming the instant otherwise (pelcs does not simulate the
nonlinear side). A run that stays says so in a note.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .behavioural_expr import Affine, BehaviouralError, Step, linearise
from .checks import value_problem
from .circuit import GROUND, Capacitor, Element
from .errors import Diagnostic, NetlistError
from .rawdeck import RawElement

__all__ = ["KNEE_STEPS", "KneeCapacitor", "NodeVoltages", "check_knees", "elaborate_knee",
           "knee_probes", "knees_for_run", "voltage_nodes"]

_FORM = ("pelcs reads a capacitor value 'v(n+,n-) < K ? C0 : ...' (any comparison of an affine "
         "form of the capacitor's own voltage with constants, C0 constant) as the capacitor C0, "
         "and checks the run stays on C0's side of the knee")


@dataclass
class KneeCapacitor(Capacitor):
    """A capacitor of value ``value`` while ``gain*v + offset > 0`` (``>= 0`` if not
    ``strict``), ``v`` its voltage (V); ``text`` the value expression as written."""

    gain: float = 1.0
    offset: float = 0.0
    strict: bool = True
    text: str = ""

    @property
    def probes(self) -> tuple[str, ...]:
        return (f"v({self.name})",)

    def quantity(self, columns: Sequence[np.ndarray]) -> np.ndarray:
        return columns[0]

    def inside(self, v: np.ndarray) -> np.ndarray:
        g = self.gain * v + self.offset
        return g > 0 if self.strict else g >= 0

    def outside(self, v: float, t: float) -> Diagnostic:
        return Diagnostic(
            f"capacitor '{self.name}' ({self.text}) is {self.value:g} F only while "
            f"{self.region}; the run took it to {v:.4g} V at t = {t:.6g} s, past the knee, "
            "where its value depends on its voltage (nonlinear)", self.location,
            "pelcs simulates such a capacitor below its knee only; shorten the run or "
            "change the circuit so that it stays below", (self.name,))

    def stayed(self, lo: float, hi: float) -> str:
        return (f"{self.name}: capacitor value '{self.text}' read as {self.value:g} F, its "
                f"value while {self.region}: the run stayed there ({lo:.4g} V to {hi:.4g} V)")

    @property
    def region(self) -> str:
        """The constant side, as ``v < 5 V``."""
        knee = -self.offset / self.gain
        op = (">" if self.strict else ">=") if self.gain > 0 else ("<" if self.strict else "<=")
        return f"v({self.name}) {op} {knee:g} V"


def elaborate_knee(el: RawElement, prefix: str, mapnode: Callable[[str], str],
                   env: Mapping[str, float], source: Callable[[str], str],
                   error: Callable[..., None]) -> list[Element]:
    """The :class:`KneeCapacitor` of a C line whose value is ``cond ? C0 : ...``; nothing
    after reporting a form pelcs does not read with ``error(message, location, hint,
    elements)``."""
    name = prefix + el.name if prefix else el.name
    _, tree, text, offset = el.behaviour
    nodes = tuple(map(mapnode, el.nodes))
    cond, yes, _no = tree.args

    def fail(message: str, at: int) -> list[Element]:
        error(f"capacitor '{name}': {message}", el.st.loc(offset + at), _FORM, (name,))
        return []

    try:
        c0 = linearise(yes, text, env, mapnode, source)
        step = linearise(cond, text, env, mapnode, source)
    except BehaviouralError as exc:
        return fail(exc.message, exc.offset)
    if not isinstance(c0, Affine) or not c0.constant:
        return fail("the value below the knee is not a constant", yes.start)
    if not isinstance(step, Step) or (step.hi == 0) == (step.lo == 0):
        return fail("the condition is not one comparison", cond.start)
    diff, strict = step.diff, step.strict
    if step.hi == 0:  # C0 while the comparison is false: not (d > 0) is -d >= 0
        diff, strict = diff.scaled(-1.0), not strict
    coef = dict(diff.terms)
    p, n = nodes
    a = coef.get(("v", p), 0.0) if p != GROUND else -coef.get(("v", n), 0.0)
    want = {q: c for q, c in (((("v", p), a), (("v", n), -a))) if q[1] != GROUND}
    if a == 0 or coef != want:
        return fail("the condition reads something other than the capacitor's own voltage "
                    f"v({el.nodes[0]},{el.nodes[1]})", cond.start)
    problem = value_problem("C", c0.const)
    if problem:
        return fail(problem[0], yes.start)
    return [KneeCapacitor(name, nodes, el.st.loc(0), c0.const, None, a, diff.const, strict,
                          text)]


def voltage_nodes(*groups: Sequence[str]) -> tuple[str, ...]:
    """The nodes other than ground among ``groups``, once each, in order: those a knee
    reads through ``v(node)`` probes."""
    return tuple(n for n in dict.fromkeys(n for g in groups for n in g) if n != GROUND)


class NodeVoltages:
    """The voltages, V, of a run at the ``nodes`` a knee reads (:func:`voltage_nodes`, its
    ``columns`` in that order): ``v(node)``, ``v.across((a, b))``; ground 0."""

    def __init__(self, nodes: Sequence[str], columns: Sequence[np.ndarray],
                 like: np.ndarray) -> None:
        self._v = dict(zip(nodes, columns, strict=True))
        self.zero = np.zeros_like(like)

    def __call__(self, node: str) -> np.ndarray:
        return self._v.get(node, self.zero)

    def across(self, pair: Sequence[str]) -> np.ndarray:
        return self(pair[0]) - self(pair[1])


#: a run written as it goes (to a file, or onto an output grid) that would keep more steps
#: than this for a check it may leave out (:attr:`droppable`, with what it leaves
#: :attr:`unchecked`: a MOSFET's reverse channel and its channel's current bound, present in
#: every circuit of MOSFET switches) leaves it out and says so: keeping every step of a long
#: run is what writing as it goes avoids (a 2 s boost: 866 MB, not 57 MB)
KNEE_STEPS = 1_000_000


def knees_for_run(knees: Sequence, steps: float, streaming: bool) -> tuple[tuple, str | None]:
    """The knees a run of ``steps`` steps checks, and a note on those it leaves out."""
    if not streaming or steps <= KNEE_STEPS:
        return tuple(knees), None
    dropped = [k for k in knees if getattr(k, "droppable", False)]
    if not dropped:
        return tuple(knees), None
    per: dict[str, list[str]] = {}  # element -> what goes unchecked
    for k in dropped:
        per.setdefault(k.name, []).append(k.unchecked)
    groups: dict[tuple[str, ...], list[str]] = {}  # the same checks left out -> elements
    for name, what in per.items():
        groups.setdefault(tuple(what), []).append(name)
    return tuple(k for k in knees if k not in dropped), (
        "; ".join(f"{', '.join(names)}: not checked for {', or for '.join(what)}"
                  for what, names in groups.items())
        + f" in this run of {steps:.3g} steps written as it goes (the checks keep every "
        f"step, past {KNEE_STEPS:,}): a shorter run, or one that keeps its steps, checks it")


def knee_probes(knees: Sequence, probes: Sequence[str] | None,
                states: Sequence[str] = ()) -> list[str]:
    """The probes a run must store besides ``probes`` (``None``: the ``states``) to check
    its knees."""
    # (as spelled: a knee's v(c1), node c1's voltage, is not the state v(C1) of a capacitor
    # C1, nor a probe written V(C1); a knee's own column costs at most a duplicate)
    have = set(states if probes is None else probes)
    out = []
    for k in knees:
        for p in k.probes:
            if p not in have:
                have.add(p)
                out.append(p)
    return out


def check_knees(knees: Sequence, result, extra: int) -> None:
    """Check that every knee's quantity stayed on its linear side over ``result``; drop the
    ``extra`` last columns (:func:`knee_probes`); a note per knee.

    A knee is a :class:`KneeCapacitor` or another object with its ``probes`` (state names
    it reads), ``quantity(columns)``, ``inside(values)`` (a boolean array), ``outside(value,
    t)`` (the :class:`~netlist.errors.Diagnostic` of a run that left) and ``stayed(lo, hi)``
    (the note of one that did not, or None): a magnetic core (:mod:`netlist.magnetic_core`),
    a MOSFET whose channel would conduct backwards (:class:`netlist.devices.ReverseChannel`).
    One with a ``share`` (a fraction) may leave for up to that share of the run's time
    (counted between consecutive steps both outside; a lone step is an instant): its
    ``outside(value, t, total)`` is the error past it (``total`` s outside in all), its
    ``brief(t, total)`` the note below it (:class:`netlist.devices.ChannelLimit`); the
    error's value is the median over the points counted, its time the first.

    Raises
    ------
    NetlistError
        A quantity that crossed its knee: when, and where it got to.
    """
    names = list(result.names)
    for k in knees:
        columns = [np.asarray(result.y[:, names.index(p)], dtype=float)
                   for p in k.probes]
        if not columns[0].size:
            continue
        q = k.quantity(columns)
        out = ~k.inside(q)
        bad = np.flatnonzero(out)
        share = getattr(k, "share", None)
        if bad.size and share is not None:
            # (the time between two steps both outside, up to a share of the run: a lone
            # step outside is an instant, as where a switch turns at its threshold)
            t = np.asarray(result.t, dtype=float)
            both = np.flatnonzero(out[1:] & out[:-1])
            if both.size:
                total, i = float(np.diff(t)[both].sum()), int(both[0])
                if total > share * (t[-1] - t[0]):
                    # (the median over the points counted: the first may stand just past
                    # the knee, and the largest where the gate has just turned the switch)
                    counted = q[np.union1d(both, both + 1)]
                    raise NetlistError(k.outside(float(np.median(counted)), float(t[i]),
                                                 total))
                result.notes.append(k.brief(float(t[i]), total))
                continue
            bad = bad[:0]  # (lone steps outside only: instants, the note of a run that stayed)
        if bad.size:
            i = int(bad[0])
            raise NetlistError(k.outside(float(q[i]), float(result.t[i])))
        note = k.stayed(float(q.min()), float(q.max()))
        if note:
            result.notes.append(note)
    if extra:
        result.names = tuple(result.names[:-extra])
        result.y = result.y[:, :-extra]
