"""A level 1, 2 or 3 MOSFET model's threshold where it gives NSUB but no VTO: ngspice
computes VTO from the substrate doping (``mos1temp.c``, ``mos2temp.c``, ``mos3temp.c``),
where its default VTO = 0 holds only without NSUB."""

from __future__ import annotations

import math
from collections.abc import Mapping

__all__ = ["nsub_vto"]


def nsub_vto(mtype: str, params: Mapping[str, object]) -> float | None:
    """The VTO, V (negative for a usual PMOS), that ngspice 39 gives a level 1, 2 or 3 model
    without one from its NSUB (cm^-3): flat band from the gate's work function (TPG, default
    1: opposite to the substrate) and NSS, plus ``GAMMA sqrt(PHI) + PHI``, at 27 °C
    (``mos1temp.c``; levels 2 and 3 take TOX = 100 nm where not given, level 1 none and then
    no NSUB); None where that does not apply (no NSUB, a value not a number)."""
    p = {k.lower(): v for k, v in params.items()}

    def num(key: str, default: float | None) -> float | None:
        v = p.get(key, default)
        return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else None

    level, nsub = num("level", 1.0), num("nsub", 0.0)
    tox = num("tox", 1e-7 if level in (2.0, 3.0) else 0.0)
    nss, tpg = num("nss", 0.0), num("tpg", 1.0)
    if level not in (1.0, 2.0, 3.0) or None in (nsub, tox, nss, tpg) \
            or not (nsub * 1e6 > 1.45e16 and tox > 0):
        return None
    sign = -1.0 if mtype == "PMOS" else 1.0
    q, vt = 1.6021766208e-19, 1.3806226e-23 / 1.6021918e-19 * 300.15
    eg = 1.16 - 7.02e-4 * 300.15**2 / (300.15 + 1108)
    cox = 3.9 * 8.854214871e-12 / tox
    phi = num("phi", max(0.1, 2 * vt * math.log(nsub * 1e6 / 1.45e16)))
    gamma = num("gamma", math.sqrt(2 * 11.70 * 8.854214871e-12 * q * nsub * 1e6) / cox)
    if phi is None or gamma is None or phi <= 0:
        return None
    wkfng = 3.25 + 0.5 * eg - sign * tpg * 0.5 * eg if tpg != 0 else 3.2
    vfb = wkfng - (3.25 + 0.5 * eg + sign * 0.5 * phi) - nss * 1e4 * q / cox
    return vfb + sign * (gamma * math.sqrt(phi) + phi)
