"""The MNA companion network of one switch mode and λ-type assignment
(:mod:`netlist.formulation`): its unknowns, its equations stamped as sparse terms, and the
linear forms of the quantities the formulation reads off its solution."""

from __future__ import annotations

import numpy as np

from .circuit import GROUND, Element

__all__ = ["VOLTAGE_KINDS", "Mna", "coalesce"]

# Branches whose voltage is imposed (a loop of them is degenerate); closed switches too.
VOLTAGE_KINDS = frozenset("VCEH")


class Mna:
    """The MNA companion network of one mode and λ-type assignment.

    Unknowns ``z``: the voltages of the non-ground nodes (V), then the currents (A) of the
    voltage-defined branches (V, C, E, H, closed S, voltage-type D) in netlist order, each
    flowing from n+ through the element to n-. Linear *forms* are vectors over ``(z, ξ)``,
    ``ξ = (x, λ, u)``; a quantity's value is ``form[:nz] @ z + form[nz:] @ ξ``.
    Equations: KCL at every non-ground node (sum of currents leaving = 0), then one branch
    equation per voltage-defined branch; stacked as ``rows @ (z, ξ) = 0`` and split into
    ``M z = K ξ``.
    """

    def __init__(self, f, on: frozenset[str], vdiodes: frozenset[str]):
        # (f: the circuit's netlist.formulation._Formulator, its mode-independent bookkeeping)
        self.f = f
        self.on = on
        self.vdiodes = vdiodes
        nn = len(f.nodes)
        self.branch: dict[str, int] = {}
        for el in f.two_terminal:
            if self._voltage_defined(el):
                self.branch[el.key] = nn + len(self.branch)
        self.nz = nn + len(self.branch)
        self.width = self.nz + f.nxi
        # Stamped as (row, column, value) terms in element order and summed in that order:
        # the sums of adding each element's dense form row by row, without a dense vector per
        # element, nor a dense matrix (an MMC arm of 64 cells: 515 unknowns, 771 non-zeros).
        ri: list[int] = []
        ci: list[int] = []
        vals: list[float] = []
        for el in f.two_terminal:
            terms = self._current_terms(el)
            a, b = el.nodes[:2]
            if a != GROUND:
                ra = f.node_index[a]
                for c, v in terms:
                    ri.append(ra)
                    ci.append(c)
                    vals.append(v)
            if b != GROUND:
                rb = f.node_index[b]
                for c, v in terms:
                    ri.append(rb)
                    ci.append(c)
                    vals.append(-v)
            if el.key in self.branch:
                rb = self.branch[el.key]
                for c, v in self._branch_terms(el):
                    ri.append(rb)
                    ci.append(c)
                    vals.append(v)
        r = np.array(ri, dtype=np.int64)
        c = np.array(ci, dtype=np.int64)
        v = np.array(vals, dtype=float)
        nz = self.nz
        inz = c < nz
        # M's entries coalesced (summed in stamping order), row-major as np.nonzero gives
        # them; K = -(the ξ columns) as a dense array (the solve's right-hand sides), and
        # K's entries (what a mode's sparse network keeps once the dense K is dropped).
        self.entries = coalesce(r[inz], c[inz], v[inz], nz)
        self.K = np.zeros((nz, f.nxi))
        ik = ~inz
        np.add.at(self.K, (r[ik], c[ik] - nz), -v[ik])
        self.K_entries = coalesce(r[ik], c[ik] - nz, -v[ik], f.nxi)

    @property
    def M(self) -> np.ndarray:
        """The MNA matrix (nz, nz), dense."""
        I, J, V = self.entries
        M = np.zeros((self.nz, self.nz))
        M[I, J] = V
        return M

    def _branch_terms(self, el: Element) -> list[tuple[int, float]]:
        """:meth:`_branch_equation` as (column, coefficient) terms."""
        f, kind, nz = self.f, el.kind, self.nz
        v = self._voltage_terms(*el.nodes[:2])
        if kind == "V":
            return v + [(nz + f.n + f.m + f.input_index[el.key], -1.0)]
        if kind == "C":
            return v + [(nz + f.state_index[el.key], -1.0)]
        if kind == "S":
            return v
        if kind == "D":
            return v + [(nz + f.n + f.diode_index[el.key], 1.0)]
        # (E, H: rare; their dense forms)
        return _terms(self._branch_equation(el))

    def w_terms(self, diode: Element) -> list[tuple[int, float]]:
        """:meth:`w_form` as (column, coefficient) terms."""
        if diode.key in self.vdiodes:
            return self._current_terms(diode)
        anode, cathode = diode.nodes
        return self._voltage_terms(cathode, anode)

    def _current_terms(self, el: Element) -> list[tuple[int, float]]:
        """:meth:`current` as (column, coefficient) terms, in the order of its dense form's
        additions."""
        f, kind = self.f, el.kind
        if el.key in self.branch:
            return [(self.branch[el.key], 1.0)]
        if kind == "R":
            if el.nodes[0] == el.nodes[1]:  # (shorted on itself: no current, no terms)
                return []
            return [(c, v / float(el.value)) for c, v in self._voltage_terms(*el.nodes)]
        if kind == "L":
            return [(self.nz + f.state_index[el.key], 1.0)]
        if kind == "D":
            return [(self.nz + f.n + f.diode_index[el.key], 1.0)]
        if kind == "I":
            return [(self.nz + f.n + f.m + f.input_index[el.key], 1.0)]
        if kind == "S":  # open
            return []
        # (G, F: rare; their dense forms)
        return _terms(self.current(el))

    def _voltage_terms(self, a: str, b: str = GROUND) -> list[tuple[int, float]]:
        terms = []
        if a != GROUND:
            terms.append((self.f.node_index[a], 1.0))
        if b != GROUND:
            terms.append((self.f.node_index[b], -1.0))
        return terms

    def _voltage_defined(self, el: Element) -> bool:
        return (el.kind in VOLTAGE_KINDS or (el.kind == "S" and el.key in self.on)
                or (el.kind == "D" and el.key in self.vdiodes))

    def _unit(self, index: int) -> np.ndarray:
        form = np.zeros(self.width)
        form[index] = 1.0
        return form

    def _xi(self, index: int) -> np.ndarray:
        return self._unit(self.nz + index)

    def voltage(self, a: str, b: str = GROUND) -> np.ndarray:
        """Form of v(a) - v(b), V."""
        form = np.zeros(self.width)
        if a != GROUND:
            form[self.f.node_index[a]] += 1.0
        if b != GROUND:
            form[self.f.node_index[b]] -= 1.0
        return form

    def current(self, el: Element) -> np.ndarray:
        """Form of the current from n+ through ``el`` to n- (anode -> cathode for a diode), A."""
        f, kind = self.f, el.kind
        if el.key in self.branch:
            return self._unit(self.branch[el.key])
        if kind == "R":
            return self.voltage(*el.nodes) / float(el.value)
        if kind == "L":
            return self._xi(f.state_index[el.key])
        if kind == "D":
            return self._xi(f.n + f.diode_index[el.key])
        if kind == "I":
            return self._xi(f.n + f.m + f.input_index[el.key])
        if kind == "S":  # open
            return np.zeros(self.width)
        if kind == "G":
            return float(el.gain) * self.voltage(*el.control)
        if kind == "F":
            return float(el.gain) * self._unit(self.branch[el.source.lower()])
        raise AssertionError(f"no current form for {el.kind}")  # pragma: no cover

    def _branch_equation(self, el: Element) -> np.ndarray:
        """Form that vanishes on a voltage-defined branch's constitutive law."""
        f, kind = self.f, el.kind
        v = self.voltage(*el.nodes)
        if kind == "V":
            return v - self._xi(f.n + f.m + f.input_index[el.key])
        if kind == "C":
            return v - self._xi(f.state_index[el.key])
        if kind == "S":
            return v
        if kind == "D":  # v(a) - v(k) = -λ
            return v + self._xi(f.n + f.diode_index[el.key])
        if kind == "E":
            return v - float(el.gain) * self.voltage(*el.control)
        if kind == "H":
            return v - float(el.gain) * self._unit(self.branch[el.source.lower()])
        raise AssertionError(f"no branch equation for {el.kind}")  # pragma: no cover

    def w_form(self, diode: Element) -> np.ndarray:
        """Form of the diode's w: reverse voltage (current-type λ) or current (voltage-type)."""
        if diode.key in self.vdiodes:
            return self.current(diode)
        anode, cathode = diode.nodes
        return self.voltage(cathode, anode)


def coalesce(rows, cols, vals, width: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The (row, column, value) entries of a matrix of ``width`` columns with repeated
    positions summed (in the order given) and zeros dropped, row-major."""
    r = np.asarray(rows, dtype=np.int64)
    c = np.asarray(cols, dtype=np.int64)
    v = np.asarray(vals, dtype=float)
    uniq, inv = np.unique(r * width + c, return_inverse=True)
    total = np.bincount(inv, weights=v, minlength=uniq.size)
    keep = total != 0
    return uniq[keep] // width, uniq[keep] % width, total[keep]


def _terms(form: np.ndarray) -> list[tuple[int, float]]:
    """A dense form as (column, coefficient) terms."""
    return [(int(c), float(form[c])) for c in np.flatnonzero(form)]
