"""B sources written as smooth comparators (sigmoids), read as the ideal comparator they
approximate, and the check after the run that they were one.

Netlists written for ngspice often make a PWM or a control decision with a smooth step, so
that the simulator's Newton iterations see a derivative::

    B1 g 0 V = 5*(1 + tanh(1000*(v(ctl) - v(tri))))/2
    B2 g 0 V = 15*tanh(k*(v(a) - v(b)))
    B3 g 0 V = 5/(1 + exp(-k*(v(a) - v(b))))
    B4 g 0 V = 0.5*5*(1 + atan(v(a,b)/w))

:func:`sigmoid_step` reads such an expression, a sum of constants and constant multiples of
one ``tanh``, ``atan`` or logistic ``1/(c0 + c1 exp(u))`` of an affine form of ``v()`` and
``i()``, as the :class:`SoftStep` (a :class:`~netlist.behavioural_expr.Step`) of its ideal
comparator: ``z > 0 ? hi : lo``, ``hi`` and ``lo`` the sigmoid's two limits and ``z`` its
argument, zero where the sigmoid crosses its mid value (for a logistic ``A/(1 + exp(-u))``,
``z = u/2``: it is ``A(1 + tanh(u/2))/2``). :mod:`netlist.behavioural` then maps it onto the
switches it drives, or makes it a source, as any comparator.

The two differ only while ``z`` is inside the sigmoid's transition band, where the sigmoid is
more than 1 % of its swing from both limits: ``|z| < atanh(0.98)`` (2.30) for ``tanh`` and
the logistic, ``|z| < tan(0.49 pi)`` (31.8) for ``atan``. A steep sigmoid's input crosses
the band in an instant at each switching; a gentle one is an amplifier, whose input a run
may hold inside the band. So the run records ``z`` (:class:`SigmoidBand`, a knee of
:func:`netlist.knee.check_knees` with a share): inside the band for more than
:data:`SIGMOID_SHARE` of the run, the run is refused; otherwise a note says how long it was
inside. A deck written for ngspice has the B line as written (:func:`record`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from .behavioural_expr import Affine, BehaviouralError, Step, Tree, linearise, spice_text
from .circuit import BuiltGroup, Circuit, Element
from .dialect import node_name
from .errors import Diagnostic, Location
from .expressions import CONSTANTS
from .knee import NodeVoltages, voltage_nodes
from .units import format_eng
from .writer import spice_name

__all__ = ["ATAN_BAND", "SIGMOID", "SIGMOID_SHARE", "TANH_BAND", "SigmoidBand", "SoftStep",
           "record", "sigmoid_step", "switch_band"]

#: ``|z| <`` this: ``tanh(z)`` is more than 1 % of its swing (2) from both of its limits
TANH_BAND = math.atanh(0.98)
#: the same for ``atan(z)`` (swing pi): ``|atan z| < 0.49 pi``
ATAN_BAND = math.tan(0.49 * math.pi)
#: the share of a run a sigmoid's input may spend inside its transition band
SIGMOID_SHARE = 0.10
#: :attr:`netlist.circuit.BuiltGroup.construct` of a sigmoid read as a comparator
SIGMOID = "sigmoid comparator"

_BANDS = {"tanh": TANH_BAND, "atan": ATAN_BAND}


@dataclass(frozen=True)
class SoftStep(Step):
    """The ideal comparator of a sigmoid: ``hi`` while ``diff > 0``, else ``lo``, ``diff``
    the sigmoid's argument ``z`` (its transition band is ``|z| < band``); ``shape``
    (``"tanh"``, ``"logistic"``, ``"atan"``) and ``spice``, the expression as ngspice is
    given it (parameters evaluated, nodes and sources of the flattened circuit)."""

    band: float = TANH_BAND
    shape: str = "tanh"
    spice: str = ""


@dataclass(frozen=True)
class _Soft:
    """``mid + half g(z)``: ``g`` is ``tanh`` or ``(2/pi) atan``."""

    mid: float
    half: float
    z: Affine
    shape: str

    def scaled(self, k: float) -> _Soft:
        return _Soft(self.mid * k, self.half * k, self.z, self.shape)


@dataclass(frozen=True)
class _Exp:
    """``c0 + c1 exp(u)``: a logistic once it divides a constant."""

    c0: float
    c1: float
    u: Affine


def _linear(t: Tree, lin: Callable[[Tree], object]) -> Affine | None:
    try:
        out = lin(t)
    except (BehaviouralError, RecursionError):
        return None
    return out if isinstance(out, Affine) else None


def _soft(t: Tree, lin: Callable[[Tree], object]) -> float | _Soft | _Exp | None:
    """A constant, a sigmoid or an exponential of an affine form, or None."""
    form = _linear(t, lin)
    if form is not None:
        return form.const if form.constant else None
    if t.tag == "call" and t.args[0] in ("tanh", "atan", "exp") and len(t.args) == 2:
        u = _linear(t.args[1], lin)
        if u is None or u.constant:
            return None
        if t.args[0] == "exp":
            return _Exp(0.0, 1.0, u)
        return _Soft(0.0, 1.0 if t.args[0] == "tanh" else math.pi / 2, u, t.args[0])
    if t.tag == "neg":
        a = _soft(t.args[0], lin)
        return None if a is None else -a if isinstance(a, float) else _times(a, -1.0)
    if t.tag not in ("+", "-", "*", "/"):
        return None
    a, b = (_soft(x, lin) for x in t.args)
    if a is None or b is None or not (isinstance(a, float) or isinstance(b, float)):
        return None
    if t.tag in ("+", "-"):
        if t.tag == "-":
            b = -b if isinstance(b, float) else _times(b, -1.0)
        c, s = (a, b) if isinstance(a, float) else (b, a)
        if isinstance(s, float):
            return c + s
        return (_Soft(s.mid + c, s.half, s.z, s.shape) if isinstance(s, _Soft)
                else _Exp(s.c0 + c, s.c1, s.u))
    if t.tag == "*":
        c, s = (a, b) if isinstance(a, float) else (b, a)
        return c * s if isinstance(s, float) else _times(s, c)
    if isinstance(b, float):  # a quotient by a constant
        return None if b == 0 else a / b if isinstance(a, float) else _times(a, 1.0 / b)
    if isinstance(b, _Exp) and b.c0 != 0 and b.c1 / b.c0 > 0:
        # K/(c0 + c1 e^u) = (K/c0)/(1 + e^(u + L)), L = ln(c1/c0), and 1/(1 + e^w) is
        # (1 - tanh(w/2))/2
        k = a / (2 * b.c0)
        z = b.u.plus(Affine((), math.log(b.c1 / b.c0))).scaled(0.5)
        return _Soft(k, -k, z, "logistic")
    return None


def _times(s: _Soft | _Exp, k: float) -> _Soft | _Exp:
    return s.scaled(k) if isinstance(s, _Soft) else _Exp(s.c0 * k, s.c1 * k, s.u)


def _spice(t: Tree, env: Mapping[str, float], mapnode: Callable[[str], str],
           source: Callable[[str], str]) -> str:
    """The expression with the parameters' values written in, and the nodes and sources of
    the flattened circuit (the B line ngspice is given)."""

    def leaf(x: Tree) -> str:
        tag, args = x.tag, x.args
        if tag == "num":
            return repr(float(args[0]))
        if tag == "var":
            return repr(float(CONSTANTS[args[0]] if args[0] in CONSTANTS else env[args[0]]))
        if tag == "v":
            return f"v({','.join(mapnode(node_name(n)) for n in args if n is not None)})"
        return f"i({spice_name(source(args[0]))})"

    return spice_text(t, leaf)


def sigmoid_step(tree: Tree, text: str, env: Mapping[str, float],
                 mapnode: Callable[[str], str] = lambda n: n,
                 source: Callable[[str], str] = lambda s: s) -> SoftStep | Affine | None:
    """The ideal comparator of a B expression that is a sigmoid (module docstring), or None.

    Parameters
    ----------
    tree, text : Tree, str
        The parsed expression and its text.
    env : mapping of str to float
        Parameter values (lower-case names).
    mapnode, source : callable
        Node and source names as written -> the flattened circuit's names.

    Returns
    -------
    SoftStep, Affine or None
        The comparator; a constant :class:`Affine` for a sigmoid of zero swing; None for any
        other expression (a sigmoid of something not affine in ``v()``/``i()``, a sum of two
        sigmoids, a sigmoid inside another function...), which the caller refuses as before.
    """
    def lin(t: Tree):
        return linearise(t, text, env, mapnode, source)

    out = _soft(tree, lin)
    if not isinstance(out, _Soft):
        return None
    # (hi the upper limit: the comparator written as 'x > 0 ? hi : lo', x rising with z)
    z = out.z if out.half > 0 else out.z.scaled(-1.0)
    hi, lo = out.mid + abs(out.half), out.mid - abs(out.half)
    if not all(math.isfinite(c) for c in (*(c for _, c in z.terms), z.const, hi, lo)):
        return None
    if hi == lo:
        return Affine((), hi)
    band = _BANDS.get(out.shape, TANH_BAND)
    return SoftStep(z, True, hi, lo, band, out.shape, _spice(tree, env, mapnode, source))


# ------------------------------------------------------------------------------ the check


def _unit(form: Affine) -> str:
    kinds = {q[0] for q, _ in form.terms}
    return "V" if kinds == {"v"} else "A" if kinds == {"i"} else ""


@dataclass
class SigmoidBand:
    """The knee (:func:`netlist.knee.check_knees`) of a sigmoid read as a comparator: its
    argument ``z`` (``diff``: an affine form of the circuit's quantities) must be outside
    ``|z| < band`` for all but :data:`SIGMOID_SHARE` of the run.

    ``input`` is the comparator's input written as the expression reads it (``v(ctl) -
    v(tri)``), ``z / scale``; ``comparator`` the ideal comparator as text; ``text`` the
    expression as written."""

    name: str
    text: str
    diff: Affine
    band: float
    scale: float
    input: str
    comparator: str
    location: Location | None = field(default=None, compare=False, repr=False)
    widened: bool = False  # (to the levels where the switches it drives turn: record)
    share = SIGMOID_SHARE
    # (netlist.knee.knees_for_run: left out of a long run written as it goes, which keeps
    # every step only for its knees, and said so; a shorter run checks it)
    droppable = True
    unchecked = "its input inside the sigmoid's transition band"

    @property
    def _nodes(self) -> tuple[str, ...]:
        return voltage_nodes([q[1] for q, _ in self.diff.terms if q[0] == "v"])

    @property
    def _currents(self) -> tuple[str, ...]:
        return tuple(dict.fromkeys(q[1] for q, _ in self.diff.terms if q[0] == "i"))

    @property
    def probes(self) -> tuple[str, ...]:
        return (*(f"v({n})" for n in self._nodes), *(f"i({s})" for s in self._currents))

    def quantity(self, columns: Sequence[np.ndarray]) -> np.ndarray:
        nv = len(self._nodes)
        volts = NodeVoltages(self._nodes, columns[:nv], columns[0])
        amps = dict(zip(self._currents, columns[nv:], strict=True))
        z = np.full(np.shape(columns[0]), self.diff.const, dtype=float)
        for (kind, ref), c in self.diff.terms:
            z = z + c * (volts(ref) if kind == "v" else amps[ref])
        return z

    def inside(self, z: np.ndarray) -> np.ndarray:
        # (the comparator's side: outside the transition band)
        return np.abs(z) >= self.band

    @property
    def _band(self) -> str:
        unit = _unit(self.diff)
        width = self.band / self.scale
        return f"|{self.input}| < {format_eng(width, unit) if unit else f'{width:.4g}'}"

    @property
    def _where(self) -> str:
        return ("where it is more than 1 % of its swing from both of its values"
                + (", or between its mid value and the level where a switch it drives turns"
                   if self.widened else ""))

    def _x(self, z: float) -> str:
        unit = _unit(self.diff)
        x = z / self.scale
        return format_eng(x, unit) if unit else f"{x:.4g}"

    def outside(self, z: float, t: float, total: float = 0.0) -> Diagnostic:
        return Diagnostic(
            f"{self.name}: the sigmoid '{self.text}', read as the ideal comparator "
            f"{self.comparator}, held its input inside its transition band {self._band} "
            f"({self._where}) for "
            f"{total:.3g} s of the run, more than {SIGMOID_SHARE:.0%} of it, from t = "
            f"{t:.6g} s (its input there: {self._x(z)}, the median): there it is an "
            "amplifier, not a comparator, and the ideal comparator's run is not this circuit",
            self.location,
            "write the comparator ideal (x > 0 ? hi : lo, which pelcs reads exactly), or make "
            "the sigmoid steeper (a larger gain k) if the circuit is meant to switch",
            (self.name,))

    def brief(self, t: float, total: float) -> str:
        return (f"{self.name}: the sigmoid '{self.text}' read as the ideal comparator "
                f"{self.comparator}: its input was inside the sigmoid's transition band "
                f"{self._band} ({self._where}) for "
                f"{total:.3g} s of the run in all, from t = {t:.6g} s (at most "
                f"{SIGMOID_SHARE:.0%} of the run is accepted)")

    def stayed(self, lo: float, hi: float) -> str:
        return (f"{self.name}: the sigmoid '{self.text}' read as the ideal comparator "
                f"{self.comparator}: its input ({self._x(lo)} to {self._x(hi)} over the "
                f"run) never stayed inside the sigmoid's transition band {self._band} from "
                "one step to the next")


def _argument(step: SoftStep, level: float) -> float | None:
    """The argument ``z`` at which the sigmoid's output is ``level``, None if it never is."""
    y = (2 * level - step.hi - step.lo) / (step.hi - step.lo)
    if not -1 < y < 1:
        return None
    return math.tan(y * math.pi / 2) if step.shape == "atan" else math.atanh(y)


def switch_band(step: SoftStep, sign: float, vt: float, vh: float
                ) -> tuple[float, float] | None:
    """Where an S switch whose control is ``sign`` times the sigmoid's output turns, as the
    centre and half-width of a band of ``sign`` times its argument ``z``: on above the
    band, off below (the switch on while ``sign z > 0`` turns there, not at ``z = 0``);
    None where ``VT ± VH`` is not inside the sigmoid's range (or ``VH < 0``)."""
    if vh < 0:
        return None
    ends = [_argument(step, sign * level) for level in (vt + vh, vt - vh)]
    if None in ends:
        return None
    on, off = (sign * z for z in ends)
    return (on + off) / 2, (on - off) / 2


def record(circuit: Circuit, name: str, text: str, step: SoftStep, nodes: tuple[str, str],
           kind_out: str, built: Sequence[Element], switch_lines: Sequence[tuple[str, str]],
           levels: Sequence[float], input_text: Callable[[Affine], str],
           location: Location | None, exact: bool = False) -> None:
    """Record a sigmoid comparator once :func:`netlist.behavioural.resolve_comparators` has
    built it: its knee (:class:`SigmoidBand`, on ``step``'s argument), and the
    :class:`~netlist.circuit.BuiltGroup` that writes its B line (and the lines of the
    switches it drives, ``(name, line)`` as the netlist had them) for ngspice in place of
    ``built``.

    ``levels``: the output levels at which the switches it drives turn (their ``VT ± VH``).
    The ideal comparator turns them where the sigmoid crosses its mid value, the sigmoid
    where it crosses their level: the band checked reaches those levels' arguments too, so
    that the time between the two instants is counted. ``exact``: every switch it drives
    turns where the sigmoid crosses its ``VT ± VH`` (:func:`switch_band`), and the output
    acts through them alone: the run is the sigmoid's, and there is no band to check."""
    z = step.diff
    scale = max((abs(c) for _, c in z.terms), default=1.0)
    x = input_text(z.scaled(1.0 / scale))
    comparator = f"{x} > 0 ? {step.hi:g} : {step.lo:g}"
    turns = [abs(a) for a in map(lambda v: _argument(step, v), levels) if a is not None]
    band = max([step.band, *turns])
    knee = SigmoidBand(name, text.strip(), z, band, scale, x, comparator, location,
                       band > step.band)
    if not exact:
        circuit.knees.append(knee)
    line = f"{spice_name(name, 'B')} {nodes[0]} {nodes[1]} {kind_out}={step.spice}"
    circuit.add_built_group(BuiltGroup(name, SIGMOID, "\n".join(
        [line, *(sl for _, sl in switch_lines)]), replaces=tuple(
        n for n, _ in switch_lines)), built)
    if exact:
        circuit.notes.append(
            f"{name}: the sigmoid '{text.strip()}' ({step.shape}) drives only switches, read "
            f"as turning where it crosses their VT ± VH: at those values of {x}, as ngspice "
            "turns them (ngspice is given the sigmoid)")
        return
    circuit.notes.append(
        f"{name}: the sigmoid '{text.strip()}' ({step.shape}) is read as the ideal comparator "
        f"{comparator}: the two differ only while its input is inside the sigmoid's "
        f"transition band {knee._band} ({knee._where}), which the run checks (at most "
        f"{SIGMOID_SHARE:.0%} of it); ngspice is given the sigmoid")

