"""A diode's depletion charge (``CJO``, ``VJ``, ``M``, ``FC``) in the piecewise-linear diode
(``--devices pwl``): a linear capacitor across the junction, behind ``RS``.

ngspice's diode (``dioload.c``) is a series resistance ``RS`` from the anode to an internal
node, then the junction: its static current and its charge both between that node and the
cathode. The depletion charge, ``vd`` the junction voltage: below ``FC VJ``,
``Q = VJ CJO (1 - (1 - vd/VJ)^(1-M)) / (1 - M)``; above, the capacitance continues linearly
in ``vd`` (``CJO/F2 (F3 + M vd/VJ)``, ``F2 = (1 - FC)^(1+M)``, ``F3 = 1 - FC (1 + M)``).
The piecewise-linear circuit is linear between events, so the charge becomes one linear
capacitor, of the charge the model moves over the junction voltage swing the diode sees,
``(Q(v_hi) - Q(v_lo)) / (v_hi - v_lo)`` (a capacitor of that value moves the same charge
between the swing's ends), placed where ngspice places the charge: ``RS`` outside, the
fit's characteristic less ``RS i`` inside (each segment's line, the fit bounding every slope
to ``RS`` or more), and the capacitor across the inside part. ``RS`` times the capacitance is
picoseconds, a mode few steps resolve: :func:`fastest_junction_mode` finds it, and
``netlist.studies.realistic`` runs with θ = 1 where the step does not resolve it. The
diffusion charge (``TT``) is not modelled: the pwl diode's current is not a state.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from .circuit import Capacitor, Circuit, Diode, Resistor, VoltageSource
from .topology import UnionFind

__all__ = ["charge_params", "depletion_charge", "fastest_junction_mode", "junction_charges",
           "swing_capacitance", "with_junction_charge"]


def charge_params(params: Mapping[str, float], area: float = 1.0) -> dict | None:
    """``{"cjo", "vj", "m", "fc"}`` (F, V) of a diode model's depletion charge, ngspice's
    defaults filled in (VJ 1 V, M 0.5, FC 0.5; ``VJ`` held to ``1/FC`` and ``M`` to 0.9, as
    ngspice's ``diotemp.c`` does) and ``CJO`` times the area; None without a ``CJO`` above 0.
    """
    p = {k.lower(): float(v) for k, v in params.items()
         if k.lower() in ("cjo", "cj0", "cj", "vj", "pb", "m", "mj", "fc")}
    cjo = p.get("cjo", p.get("cj0", p.get("cj", 0.0)))
    if not cjo > 0:
        return None
    vj = p.get("vj", p.get("pb", 1.0))
    fc = p.get("fc", 0.5)
    if fc * vj > 1.0:
        vj = 1.0 / fc
    m = min(p.get("m", p.get("mj", 0.5)), 0.9)
    return {"cjo": cjo * area, "vj": vj, "m": m, "fc": fc}


def depletion_charge(v: float, p: Mapping[str, float]) -> float:
    """ngspice's depletion charge at the junction voltage ``v`` (V), C (module docstring)."""
    cjo, vj, m, fc = p["cjo"], p["vj"], p["m"], p["fc"]
    vd_fc = fc * vj
    if v < vd_fc:
        return vj * cjo * (1.0 - (1.0 - v / vj) ** (1.0 - m)) / (1.0 - m)
    f1 = vj * (1.0 - (1.0 - fc) ** (1.0 - m)) / (1.0 - m)
    f2 = (1.0 - fc) ** (1.0 + m)
    f3 = 1.0 - fc * (1.0 + m)
    return cjo * f1 + cjo / f2 * (f3 * (v - vd_fc) + m / (2.0 * vj) * (v * v - vd_fc * vd_fc))


def swing_capacitance(p: Mapping[str, float], v_lo: float, v_hi: float) -> float:
    """The capacitance (F) that moves the model's charge over ``[v_lo, v_hi]`` (V): its
    chord; the model's capacitance at ``v_lo`` where the swing is nil."""
    if not v_hi - v_lo > 1e-9:
        h = 1e-6
        return (depletion_charge(v_lo + h, p) - depletion_charge(v_lo - h, p)) / (2 * h)
    return (depletion_charge(v_hi, p) - depletion_charge(v_lo, p)) / (v_hi - v_lo)


def junction_charges(circuit: Circuit, swings: Mapping[str, tuple[float, float]],
                     merged: Mapping[str, str]
                     ) -> tuple[dict[str, tuple[float, float]], list[str]]:
    """``{diode name: (RS in Ω, C in F)}`` for each fitted diode whose one junction has a
    depletion charge (``CJO > 0``), ``C`` its :func:`swing_capacitance` over ``swings[name]``
    (V, the anode-cathode voltages the ideal run puts across it, 0 V included), ``RS`` its
    model's (area applied) plus a macro-model's series resistance; and a note per diode.
    Diodes of several junctions (a macro-model's, or merged in parallel) keep no charge, nor
    a diode without ``RS`` whose terminals capacitors and voltage sources already join (its
    capacitor would sit across them and close a loop), each with a note."""
    from .pwl import diode_params, junction_models

    joined = UnionFind()  # (the nodes capacitors and voltage sources join)
    for e in circuit.elements:
        if isinstance(e, (Capacitor, VoltageSource)):
            joined.union(e.nodes[0], e.nodes[1])
    out: dict[str, tuple[float, float]] = {}
    lines: list[str] = []
    for el in circuit.elements:
        if not isinstance(el, Diode) or el.ideal or el.key in merged or el.name not in swings:
            continue
        models, _ = junction_models(circuit, el, merged)
        charged = [q for q in (charge_params(*m) for m in models) if q is not None]
        if not charged:
            continue
        if len(models) != 1:
            lines.append(f"{el.name}: the depletion charge (CJO) of its several junctions not "
                         "modelled")
            continue
        params, series = diode_params(circuit, el, merged)
        lo, hi = swings[el.name]
        c = swing_capacitance(charged[0], lo, hi)
        rs = float(params[0]["rs"]) + float(series)
        if not rs > 0:
            if not joined.union(el.nodes[0], el.nodes[1]):
                lines.append(f"{el.name}: its depletion charge (CJO) not modelled: without RS "
                             "its capacitor would close a loop of capacitors and voltage "
                             "sources")
                continue
        out[el.name] = (rs, c)
        tt = any(k.lower() == "tt" and float(v) > 0 for k, v in models[0][0].items())
        lines.append(f"{el.name}: depletion charge (CJO, VJ, M, FC) as {c:.4g} F behind RS = "
                     f"{rs:.3g} Ω, the charge the model moves over {lo:.3g}..{hi:.3g} V"
                     + ("; its diffusion charge (TT) not modelled" if tt else ""))
    return out, lines


def with_junction_charge(circuit: Circuit, run_circuit: Circuit, fits: Sequence,
                         charges: Mapping[str, tuple[float, float]],
                         notes: list[str] | None = None) -> Circuit:
    """The piecewise-linear circuit ``run_circuit`` (:func:`netlist.pwl.pwl_circuit` of
    ``circuit``, with its ``fits``) with each diode of ``charges`` (``{name: (RS in Ω, C in
    F)}``) rebuilt as ``RS`` from its anode to ``<element>#j``, the junction's own
    characteristic from there to its cathode (every segment's line ``v = a + b i`` less
    ``RS i``: the fit's characteristic less the drop on ``RS``, convex as the fit is) and the
    capacitor ``<element>#cj`` across the junction (across the diode where ``RS`` is 0).
    Where the fit's least slope is under twice ``RS`` (a diode fitted at its bound ``Ron =
    RS``), ``RS`` outside is half that slope, and a line appended to ``notes`` says so."""
    from .pwl import diode_chain, lines_fit, segment_lines

    fit_of = {f.element: f for f in fits}
    rebuilt: dict[str, list] = {}
    for name, (rs, c) in charges.items():
        f = fit_of.get(name)
        if f is None or not c > 0:
            continue
        el = circuit.element(name)
        key = name.lower()
        anode, cathode = el.nodes[0], el.nodes[1]
        lines = segment_lines(f.vf, f.ron, tuple(f.branches))
        # (the fit bounds every slope to RS or more; at or near the bound half the least
        # slope stays inside: a sliver there would put the capacitor behind a vanishing
        # resistance, a mode of RS C times that sliver's fraction, which round-off turns
        # unstable: a rectifier's 8 pF behind 1e-11 Ohm, no step solution)
        least = min(b for _, b in lines)
        if rs > 0.5 * least and notes is not None:
            notes.append(f"{name}: its junction capacitor behind {0.5 * least:.3g} Ω of its "
                         f"RS = {rs:.3g} Ω (its fit's least slope, {least:.3g} Ω, leaves no "
                         "more inside)")
        rs = min(rs, 0.5 * least)
        inner = lines_fit([(a, b - rs) for a, b in lines]) if rs > 0 else None
        if inner is None:  # no RS: the capacitor across the diode
            rebuilt[name] = [*(e for e in run_circuit.elements if _of(e, name)),
                             Capacitor(f"{name}#cj", (anode, cathode), el.location, c)]
            continue
        j = f"{key}#j"
        rebuilt[name] = [Resistor(f"{name}#rs", (anode, j), el.location, rs),
                         *diode_chain(replace(el, nodes=(j, cathode)), *inner),
                         Capacitor(f"{name}#cj", (j, cathode), el.location, c)]
    out, done = [], set()
    for e in run_circuit.elements:
        name = next((n for n in rebuilt if _of(e, n)), None)
        if name is None:
            out.append(e)
        elif name not in done:
            done.add(name)
            out.extend(rebuilt[name])
    return replace(run_circuit, elements=out)


def _of(e, name: str) -> bool:
    """Whether ``e`` is part of the fitted diode ``name``'s chain (``netlist.pwl``)."""
    return e.name == name or e.name.startswith(f"{name}#")


def fastest_junction_mode(system, energy: np.ndarray, names: Sequence[str],
                          states: Sequence[str] = ()) -> complex | None:
    """The eigenvalue (1/s) of largest modulus, over the switch modes' state matrices (every
    diode at λ = 0, blocking: where the junction capacitors act), among the modes whose
    energy (``½ x' E x``, ``energy`` = E) lies half or more in the junction capacitors
    ``<name>#cj`` of ``names`` and the ``states`` named (``v(C1)``); None if none.
    ``system``: a ``lcs.model.SwitchedLCS``."""
    want = {f"v({n.lower()}#cj)" for n in names} | {s.lower() for s in states}
    idx = [i for i, s in enumerate(system.states) if s.lower() in want]
    if not idx:
        return None
    L = np.linalg.cholesky(np.asarray(energy, float))
    k = len(system.switches)
    keys = system.all_keys() if k <= 4 else [tuple(False for _ in range(k)),
                                                tuple(True for _ in range(k))]
    best = None
    for key in keys:
        try:
            A = np.asarray(system.mode(tuple(bool(v) for v in key)).A, float)
        except Exception:  # noqa: BLE001  (a degenerate mode is the run's to report)
            continue
        mu, V = np.linalg.eig(A)
        W = np.abs(L.T @ V) ** 2  # each eigenvector's energy, by state
        W /= np.maximum(W.sum(axis=0, keepdims=True), 1e-300)
        for j in np.flatnonzero(W[idx].sum(axis=0) >= 0.5):
            if best is None or abs(mu[j]) > abs(best):
                best = complex(mu[j])
    return best
