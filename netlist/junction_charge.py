"""A diode's depletion charge (``CJO``, ``VJ``, ``M``, ``FC``) as a linear capacitance with
``--devices pwl``.

ngspice's depletion charge (``dioload.c``), ``vd`` the junction voltage: below ``FC VJ``,
``Q = VJ CJO (1 - (1 - vd/VJ)^(1-M)) / (1 - M)``; above, the capacitance continues linearly
in ``vd`` (``CJO/F2 (F3 + M vd/VJ)``, ``F2 = (1 - FC)^(1+M)``, ``F3 = 1 - FC (1 + M)``).
The piecewise-linear circuit is linear between events, so a diode's charge becomes one
capacitor across it, of the charge the model moves over the voltage swing the diode sees,
``(Q(v_hi) - Q(v_lo)) / (v_hi - v_lo)``: a capacitor of that value moves the same charge
between the swing's ends.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

__all__ = ["charge_params", "depletion_charge", "swing_capacitance"]


def charge_params(params: Mapping[str, float], area: float = 1.0) -> dict | None:
    """``{"cjo", "vj", "m", "fc"}`` (F, V) of a diode model's depletion charge, ngspice's
    defaults filled in (VJ 1 V, M 0.5, FC 0.5; ``VJ`` held to ``1/FC``, ``M`` to 0.9, as
    ngspice does) and ``CJO`` times the area; None without a ``CJO`` above 0."""
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


def _check() -> None:  # pragma: no cover - a sanity check by hand
    p = {"cjo": 1e-12, "vj": 1.0, "m": 0.5, "fc": 0.5}
    assert math.isclose(swing_capacitance(p, 0.0, 0.0), 1e-12, rel_tol=1e-6)
