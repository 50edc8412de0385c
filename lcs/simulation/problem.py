"""A switched LCS as every integrator sees it: per mode, the LCS, the stored probes and the
switch controls, as contiguous arrays built on first use.

Modes are keyed by int bitmasks (bit i: switch i on) inside the integrators and by tuples of
booleans (:data:`lcs.model.ModeKey`) outside; :func:`mode_tuple` and :func:`key_of` convert.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..model import LCS, ModeKey, OutputMap, SwitchedLCS
from ..network import NetworkRealisation
from .switches import SW_SCHEDULED, reads_state, same_input_rows


def contiguous(a, shape=None) -> np.ndarray:
    """``a`` as a C-contiguous float64 array (of ``shape`` when given)."""
    arr = np.ascontiguousarray(a, dtype=float)
    return arr.reshape(shape) if shape is not None else arr


def mode_tuple(key: int, k: int) -> ModeKey:
    """The mode tuple of switch key ``key`` (k switches)."""
    return tuple(bool((key >> i) & 1) for i in range(k))


def key_of(mode: ModeKey) -> int:
    """The switch key (bitmask) of a mode tuple."""
    return sum(1 << i for i, on in enumerate(mode) if on)


def pair_names(lcs: LCS, mask: int) -> tuple[str, ...]:
    """Names of the complementarity pairs (diodes) of bitmask ``mask``."""
    return tuple(pr.name for i, pr in enumerate(lcs.pairs) if (mask >> i) & 1)


def fmt_mode(desc: dict[str, str]) -> str:
    """``"S1 on, S2 off"`` (or ``"single LCS"``)."""
    return ", ".join(f"{k} {v}" for k, v in desc.items()) if desc else "single LCS"


def duty_switch(name: str, switches: Sequence[str]) -> int:
    """Index of the switch ``S`` of a probe ``d(S)`` (its on-fraction), or -1."""
    nm = name.strip().lower()
    if nm.startswith("d(") and nm.endswith(")"):
        inner = nm[2:-1].strip()
        for i, s in enumerate(switches):
            if s.lower() == inner:
                return i
    return -1


def state_outputs(lcs: LCS, names: Sequence[str]) -> OutputMap:
    """The output builder of a bare LCS: only its states are known probes."""
    unknown = [nm for nm in names if nm.lower() not in [s.lower() for s in lcs.states]]
    raise KeyError(
        f"unknown probe(s) {', '.join(unknown)}: a bare LCS knows only its states "
        f"({', '.join(lcs.states)}); pass an OutputMap for other outputs"
    )


@dataclass
class OutputRows:
    """Stored probes of one mode: ``y = Cy x + Dy λ + Fy u``, shapes (r, n), (r, m), (r, p);
    ``duty (r,)`` int64 is the switch of a ``d(S)`` probe (-1 for the others)."""

    names: tuple[str, ...]
    Cy: np.ndarray
    Dy: np.ndarray
    Fy: np.ndarray
    duty: np.ndarray

    def row(self, key: int, slide: int, duty_value: float, x, lam, u) -> np.ndarray:
        """The probes at one instant (switch key ``key``; ``duty_value`` for the switch
        ``slide`` while it slides)."""
        y = self.Cy @ x + self.Dy @ lam + self.Fy @ u
        rows = self.__dict__.get("_duty_rows")
        if rows is None:  # (the d(S) probes, listed once: numpy scalars are slow to iterate)
            rows = self.__dict__["_duty_rows"] = [
                (r, int(i)) for r, i in enumerate(self.duty.tolist()) if i >= 0]
        for r, i in rows:
            y[r] = duty_value if i == slide else float((key >> i) & 1)
        return y


class Problem:
    """A switched LCS with the probes to store.

    Parameters
    ----------
    system : SwitchedLCS
    probes : sequence of str, OutputMap or None
        Names of the stored outputs (states, anything the system's output maps know, ``d(S)``
        for a switch's state or duty), an explicit output map, or None for every state.
    """

    def __init__(self, system: SwitchedLCS, probes: Sequence[str] | OutputMap | None):
        self.system = system
        self.probes = probes
        self._outputs: dict[ModeKey, OutputRows] = {}
        self._arrays: dict[ModeKey, tuple] = {}
        self._controls: dict[tuple, tuple] = {}
        self.switch_names = [s.name for s in system.switches]

    @property
    def k(self) -> int:
        return len(self.switch_names)

    def lcs(self, mode: ModeKey) -> LCS:
        return self.system.mode(mode)

    def network(self, mode: ModeKey) -> NetworkRealisation | None:
        """The sparse network of a mode's LCS (:mod:`lcs.network`), or None."""
        return self.system.network(mode)

    def describe(self, mode: ModeKey) -> dict[str, str]:
        return self.system.describe_mode(mode) if self.system.switches else {}

    def mode_arrays(self, mode: ModeKey) -> tuple[np.ndarray, ...]:
        """``(A, B, C, D, E, F)`` of a mode as contiguous arrays (checked to keep the numbers
        of states, pairs and inputs of the system)."""
        if mode not in self._arrays:
            lcs = self.lcs(mode)
            n, m, p = len(self.system.states), len(self.system.diodes), len(self.system.inputs)
            if lcs.n != n or lcs.m != m or lcs.p != p:
                raise ValueError("all modes must have the same numbers of states, pairs and "
                                 "inputs")
            self._arrays[mode] = (contiguous(lcs.A, (n, n)), contiguous(lcs.B, (n, m)),
                                  contiguous(lcs.C, (m, n)), contiguous(lcs.D, (m, m)),
                                  contiguous(lcs.E, (n, p)), contiguous(lcs.F, (m, p)))
        return self._arrays[mode]

    def output(self, mode: ModeKey) -> OutputRows:
        """The stored probes of a mode."""
        if mode in self._outputs:
            return self._outputs[mode]
        lcs = self.lcs(mode)
        n, m, p = lcs.n, lcs.m, lcs.p
        if isinstance(self.probes, OutputMap):
            om = self.probes
            q = len(om.names)
            Cy, Dy, Fy = contiguous(om.Cy, (q, n)), contiguous(om.Dy, (q, m)), \
                contiguous(om.Fy, (q, p))
            out = OutputRows(tuple(om.names), Cy, Dy, Fy, np.full(Cy.shape[0], -1, np.int64))
        else:
            names = tuple(self.probes) if self.probes is not None else tuple(lcs.states)
            k = len(names)
            Cy, Dy, Fy = np.zeros((k, n)), np.zeros((k, m)), np.zeros((k, p))
            duty = np.array([duty_switch(nm, self.switch_names) for nm in names], np.int64)
            lower_states = [s.lower() for s in lcs.states]
            shadowed = getattr(self.system, "shadowed", frozenset())

            def state(nm: str) -> int:
                # (a state by its name in any case, but for a spelling other than the state's
                # own that the output maps read otherwise: v(c1) of a node c1 beside C1)
                if nm in lcs.states:
                    return lcs.states.index(nm)
                low = nm.lower()
                return lower_states.index(low) if (low in lower_states
                                                   and low not in shadowed) else -1

            index = [state(nm) for nm in names]
            others = [(i, nm) for i, nm in enumerate(names) if index[i] < 0 and duty[i] < 0]
            for i, j in enumerate(index):
                if j >= 0:
                    Cy[i, j] = 1.0
            if others:
                om = self.system.outputs(mode, [nm for _, nm in others])
                q = len(others)
                oCy, oDy, oFy = contiguous(om.Cy, (q, n)), contiguous(om.Dy, (q, m)), \
                    contiguous(om.Fy, (q, p))
                for r, (i, _) in enumerate(others):
                    Cy[i], Dy[i], Fy[i] = oCy[r], oDy[r], oFy[r]
            out = OutputRows(names, Cy, Dy, Fy, duty)
        self._outputs[mode] = out
        return out

    def control_rows(self, mode: ModeKey, plan, src_maps: dict, base: ModeKey):
        """Switch controls ``c = Cc x + Dc λ + Fc u`` of a mode, shapes (k, n), (k, m), (k, p):
        a surface controller's combination of probes, a comparator's control probe, zero for
        switches driven by sources or controllers (whose control is checked to stay
        independent of the state in this mode).

        ``plan`` is the run's :class:`~lcs.simulation.switches.SwitchPlan`; ``src_maps`` the
        source-driven switches' control rows per mode and ``base`` the initial mode, as
        :func:`lcs.simulation.source_switching.source_switch_events` computed them.
        """
        # (kept for repeated runs: the rows and the checks are the system's for one plan of
        # its switches; a surface controller's rows are not kept)
        memo_key = None if plan.surface else (mode, tuple(plan.kind.tolist()),
                                              tuple(plan.source), tuple(base))
        if memo_key is not None and memo_key in self._controls:
            return self._controls[memo_key]
        rows = self._control_rows(mode, plan, src_maps, base)
        if memo_key is not None:
            self._controls[memo_key] = rows
        return rows

    def _control_rows(self, mode: ModeKey, plan, src_maps: dict, base: ModeKey):
        system = self.system
        n, m, p = len(system.states), len(system.diodes), len(system.inputs)
        k = len(system.switches)
        Cc, Dc, Fc = np.zeros((k, n)), np.zeros((k, m)), np.zeros((k, p))
        sources = []
        for i, s in enumerate(system.switches):
            if i in plan.surface:
                ctrl = plan.surface[i]
                terms = dict(ctrl.terms)
                om = system.outputs(mode, list(terms))
                coef = np.array([terms[nm] for nm in terms], dtype=float)
                q = len(coef)
                Cc[i] = coef @ contiguous(om.Cy, (q, n))
                Dc[i] = coef @ contiguous(om.Dy, (q, m))
                Fc[i] = coef @ contiguous(om.Fy, (q, p))
                continue
            if plan.kind[i] == SW_SCHEDULED:
                if i in plan.source:
                    sources.append(i)
                continue
            om = system.outputs(mode, [s.control])
            Cc[i] = contiguous(om.Cy, (1, n))[0]
            Dc[i] = contiguous(om.Dy, (1, m))[0]
            Fc[i] = contiguous(om.Fy, (1, p))[0]
        if sources:
            self._check_source_controls(sources, mode, plan, src_maps, base)
        return Cc, Dc, Fc

    def _check_source_controls(self, idx: list[int], mode: ModeKey, plan, src_maps,
                               base) -> None:
        """The controls of the source-driven switches ``idx`` must not depend on the state in
        ``mode``, nor differ from the rows their instants were computed with."""
        switches = self.system.switches
        om = self.system.outputs(mode, [switches[i].control for i in idx])
        state_dep = reads_state(om)
        if state_dep.any():
            s = switches[idx[int(np.flatnonzero(state_dep)[0])]]
            raise NotImplementedError(
                f"switch {s.name}: its control {s.control!r} is driven by sources alone in the "
                f"initial mode but depends on the circuit state in mode "
                f"{fmt_mode(self.describe(mode))}; switches whose kind (source-driven or "
                "comparator) changes with the mode are not supported"
            )
        src = set(plan.source)
        ref_mode = tuple(on if j in src else base[j] for j, on in enumerate(mode))
        rows = src_maps.get(ref_mode)
        if rows is None:
            return
        Fy = np.asarray(om.Fy, dtype=float).reshape(len(idx), -1)
        ok = same_input_rows(rows[idx], Fy)
        if not ok.all():
            s = switches[idx[int(np.flatnonzero(~ok)[0])]]
            raise NotImplementedError(
                f"switch {s.name}: its gate {s.control!r} depends on the state of a "
                "comparator-driven switch; source-driven instants are computed with the "
                "comparators in their initial states, so this is not supported"
            )
