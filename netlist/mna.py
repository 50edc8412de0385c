"""The MNA companion network of one switch mode and λ-type assignment
(:mod:`netlist.formulation`): its unknowns, its equations stamped as sparse terms, and the
linear forms of the quantities the formulation reads off its solution."""

from __future__ import annotations

import numpy as np

from .circuit import GROUND, Element

__all__ = ["VOLTAGE_KINDS", "Mna", "Stamps", "coalesce", "dense_form"]

# Branches whose voltage is imposed (a loop of them is degenerate); closed switches too.
VOLTAGE_KINDS = frozenset("VCEH")


class Mna:
    """The MNA companion network of one mode and λ-type assignment.

    Unknowns ``z``: the voltages of the non-ground nodes (V), then the currents (A) of the
    voltage-defined branches (V, C, E, H, closed S, voltage-type D, the inductors pinned at
    zero current: 0 V branches) in netlist order, each
    flowing from n+ through the element to n-. Linear *forms* are vectors over ``(z, ξ)``,
    ``ξ = (x, λ, u)``; a quantity's value is ``form[:nz] @ z + form[nz:] @ ξ``.
    Equations: KCL at every non-ground node (sum of currents leaving = 0), then one branch
    equation per voltage-defined branch; stacked as ``rows @ (z, ξ) = 0`` and split into
    ``M z = K ξ``.
    """

    def __init__(self, f, on: frozenset[str], vdiodes: frozenset[str]):
        # (f: the circuit's netlist.formulation._Formulator, its mode-independent bookkeeping,
        # with its Stamps as f.stamps)
        is_branch = f.stamps.voltage_defined(on, vdiodes)
        self._unknowns(f, on, vdiodes, is_branch)
        r, c, v = f.stamps.terms(is_branch, self.nz)
        nz = self.nz
        inz = c < nz
        # M's entries coalesced (summed in stamping order), row-major as np.nonzero gives
        # them; K = -(the ξ columns) by its entries likewise (the solve's right-hand sides
        # are written from them, and a mode's sparse network keeps them).
        self.entries = coalesce(r[inz], c[inz], v[inz], nz)
        ik = ~inz
        self.K_entries = coalesce(r[ik], c[ik] - nz, -v[ik], f.nxi)

    def _unknowns(self, f, on: frozenset[str], vdiodes: frozenset[str],
                  is_branch: np.ndarray) -> None:
        """Set the mode's unknowns (``branch``, ``nz``, ``width``) from which elements of
        ``f.two_terminal`` are voltage-defined (``is_branch``, bool)."""
        self.f = f
        self.on = on
        self.vdiodes = vdiodes
        nn = len(f.nodes)
        index = np.flatnonzero(is_branch).tolist()
        elements = f.two_terminal
        self.branch: dict[str, int] = dict(zip([elements[e].key for e in index],
                                               range(nn, nn + len(index)), strict=True))
        self.nz = nn + len(index)
        self.width = self.nz + f.nxi

    @classmethod
    def unknowns_only(cls, f, on: frozenset[str], vdiodes: frozenset[str]) -> Mna:
        """An Mna whose unknowns are set and nothing stamped (what :class:`Stamps` reads
        the elements' terms from)."""
        mna = cls.__new__(cls)
        is_branch = np.array([el.kind in VOLTAGE_KINDS or el.key in on or el.key in vdiodes
                              or el.key in f.pinned for el in f.two_terminal], dtype=bool)
        mna._unknowns(f, on, vdiodes, is_branch)
        return mna

    @property
    def M(self) -> np.ndarray:
        """The MNA matrix (nz, nz), dense."""
        I, J, V = self.entries
        M = np.zeros((self.nz, self.nz))
        M[I, J] = V
        return M

    @property
    def K(self) -> np.ndarray:
        """The right-hand side matrix (nz, nξ) of ``M z = K ξ``, dense."""
        I, J, V = self.K_entries
        K = np.zeros((self.nz, self.f.nxi))
        K[I, J] = V
        return K

    def _branch_terms(self, el: Element) -> list[tuple[int, float]]:
        """:meth:`_branch_equation` as (column, coefficient) terms."""
        f, kind, nz = self.f, el.kind, self.nz
        v = self._voltage_terms(*el.nodes[:2])
        if kind == "V":
            return v + [(nz + f.n + f.m + f.input_index[el.key], -1.0)]
        if kind == "C":
            return v + [(nz + f.state_index[el.key], -1.0)]
        if kind in "SL":  # (a closed switch; an inductor pinned at zero current)
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
        if kind in "SL":
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


class Stamps:
    """Every element's MNA terms of a circuit, for any mode: (row, column, value) in element
    order, each row and column named by what it stands for (a node, an element's branch
    current, an entry of ξ) instead of its index, which depends on the mode's unknowns.

    A mode's terms are the rows whose element is (or is not) voltage-defined in it, as the
    terms say, with the names turned into indices: the same terms in the same order as
    stamping element by element (:meth:`Mna._current_terms`, :meth:`Mna._branch_terms`, from
    which they are read), so the same sums, in numpy (an MMC arm of 64 cells: 0.2 ms a mode,
    where stamping took 2 ms).
    """

    # What a term's row or column stands for.
    NODE, BRANCH, XI = 0, 1, 2
    # When an element's term is there: always, when it is voltage-defined, when it is not.
    ALWAYS, IF_BRANCH, IF_NOT = 0, 1, 2

    def __init__(self, f):
        elements = f.two_terminal
        self._index = {el.key: e for e, el in enumerate(elements)}
        self._fixed = np.array([el.kind in VOLTAGE_KINDS or el.key in f.pinned
                                for el in elements], dtype=bool)
        # Switches and diodes are voltage-defined in some modes: their terms are read in
        # both cases (every one voltage-defined, none), the others' once.
        self._nn = len(f.nodes)
        # (the inductors some modes pin at zero current are voltage-defined there, as the
        # closed switches)
        every = Mna.unknowns_only(f, frozenset(el.key for el in elements if el.kind == "S")
                                  | f.pinnable,
                                  frozenset(el.key for el in elements if el.kind == "D"))
        none = Mna.unknowns_only(f, frozenset(), frozenset())
        rows: list[tuple[int, int, int, int, int, int, float]] = []
        for when, mna in ((self.IF_BRANCH, every), (self.IF_NOT, none)):
            owner = {i: self._index[k] for k, i in mna.branch.items()}
            for e, el in enumerate(elements):
                if el.kind not in "SD" and el.key not in f.pinnable:
                    if mna is every:
                        continue  # (read from `none`: the same terms)
                    case = self.ALWAYS
                else:
                    case = when
                for row, col, v in _element_terms(mna, el):
                    rows.append((e, case, *self._name(mna, owner, row),
                                 *self._name(mna, owner, col), v))
        # (in element order; an element's terms in the order read)
        rows.sort(key=lambda t: t[0])
        table = np.array([t[:6] for t in rows], dtype=np.int64).reshape(-1, 6)
        self._element, self._when = table[:, 0], table[:, 1]
        self._row_kind, self._row = table[:, 2], table[:, 3]
        self._col_kind, self._col = table[:, 4], table[:, 5]
        self._value = np.array([t[6] for t in rows], dtype=float)

    def _name(self, mna: Mna, owner: dict[int, int], index: int) -> tuple[int, int]:
        """What row or column ``index`` of ``mna``'s (z, ξ) stands for, (kind, which);
        ``owner``: the element of each branch current's index."""
        if index < self._nn:
            return self.NODE, index
        if index < mna.nz:
            return self.BRANCH, owner[index]
        return self.XI, index - mna.nz

    def voltage_defined(self, on: frozenset[str], vdiodes: frozenset[str]) -> np.ndarray:
        """Which elements are voltage-defined (V C E H, closed S, voltage-type D), bool."""
        out = self._fixed.copy()
        out[[self._index[k] for k in on]] = True
        out[[self._index[k] for k in vdiodes]] = True
        return out

    def terms(self, is_branch: np.ndarray, nz: int) -> tuple[np.ndarray, np.ndarray,
                                                              np.ndarray]:
        """The (row, column, value) terms of the mode where ``is_branch`` elements are
        voltage-defined (``nz`` unknowns), in stamping order; columns ``>= nz`` are ξ's."""
        branch = self._nn + np.cumsum(is_branch) - 1  # (where is_branch)
        voltage = is_branch[self._element]
        keep = ((self._when == self.ALWAYS) | ((self._when == self.IF_BRANCH) & voltage)
                | ((self._when == self.IF_NOT) & ~voltage))
        rk, rv = self._row_kind[keep], self._row[keep]
        ck, cv = self._col_kind[keep], self._col[keep]
        r = np.where(rk == self.NODE, rv, branch[rv])
        c = np.where(ck == self.NODE, cv, np.where(ck == self.BRANCH, branch[cv], nz + cv))
        return r, c, self._value[keep]


def _element_terms(mna: Mna, el: Element) -> list[tuple[int, int, float]]:
    """An element's (row, column, value) MNA terms in ``mna``'s mode, in stamping order:
    its current leaving node a, entering node b, then its branch equation (if
    voltage-defined)."""
    f = mna.f
    terms = mna._current_terms(el)
    a, b = el.nodes[:2]
    out = []
    if a != GROUND:
        out += [(f.node_index[a], c, v) for c, v in terms]
    if b != GROUND:
        out += [(f.node_index[b], c, -v) for c, v in terms]
    if el.key in mna.branch:
        out += [(mna.branch[el.key], c, v) for c, v in mna._branch_terms(el)]
    return out


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


def dense_form(terms: list[tuple[int, float]], width: int) -> np.ndarray:
    """The first ``width`` entries of the form that ``terms`` add up to (in their order)."""
    form = np.zeros(width)
    for c, v in terms:
        if c < width:
            form[c] += v
    return form
