"""ngspice's static (DC) diode characteristic, forward, at the nominal temperature (27 °C):
the current a diode model carries at a junction voltage, and the voltage (series resistance
included) at which it carries a current. :mod:`netlist.pwl` fits its lines to it.

ngspice 39's diode (``dioload.c``, ``diotemp.c``, ``diosetup.c``), forward (``vd > -3 N
Vt``), ``vd`` the junction's voltage (behind ``RS``), ``Vt = k T/q`` at 300.15 K:

- diffusion current ``IS (exp(vd / (N Vt)) - 1)``;
- recombination current, only where the model gives ``ISR``: ``ISR (exp(vd / (NR Vt)) - 1)
  Kgen``, ``Kgen = ((1 - vd/VJ)² + 0.005)^(M/2)`` (the generation factor of the depletion
  region: ``VJ``, ``M`` of the junction capacitance). ``NR`` defaults to 1 in ngspice 39
  (ngspice 40 changed its default to 2; a model that gives ``NR`` is read alike by both);
- high injection, only where the model gives ``IKF`` (and it is not below ngspice's
  ``epsmin``, 1e-28): their sum ``c`` becomes ``c / (1 + sqrt(c / IKF))``;
- the series resistance ``RS``: ``v = vd + RS i``.

The area factor multiplies ``IS``, ``ISR`` and ``IKF`` and divides ``RS``. ngspice holds
``VJ`` to at most ``1/FC`` (``FC``, default 0.5) and ``M`` to at most 0.9. ``gmin`` (1e-12 S
across the junction, a conditioning of ngspice's Newton iteration) is left out: at the
currents a fit covers (nA and up) it is a picoampere. The junction's charge (``CJO``,
``TT``) is no part of the static characteristic, nor the reverse region (the
piecewise-linear diode blocks; breakdown: :mod:`netlist.breakdown`). The temperature
parameters (``EG``, ``XTI``, ``TNOM``, ``TRS1``...) change nothing at the nominal
temperature. A model's sidewall (``JSW``, scaled by the instance's perimeter, default 0)
and tunnelling currents (``JTUN``) are not modelled: :func:`ignored` names them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

__all__ = ["NR_DEFAULT", "VT_THERMAL", "describe", "diode_voltage", "ignored",
           "junction_current", "junction_params", "junction_voltage"]

#: thermal voltage at ngspice's nominal 27 °C (300.15 K), V: its k/q (1.38064852e-23 J/K
#: over 1.6021766208e-19 C) times the temperature
VT_THERMAL = 1.38064852e-23 / 1.6021766208e-19 * 300.15

#: ngspice 39's default recombination emission coefficient (ngspice 40 and later: 2)
NR_DEFAULT = 1.0

#: ngspice's defaults of the parameters the characteristic reads
_DEFAULTS = {"is": 1e-14, "n": 1.0, "rs": 0.0}

#: ngspice's other names of the parameters read here
_ALIASES = {"js": "is", "pb": "vj", "mj": "m", "ik": "ikf"}

#: parameters of the junction's charge (the piecewise-linear diode has none)
_CHARGE = ("cjo", "cj0", "cj", "tt", "fc", "cjp", "cjsw", "php", "mjsw", "fcs")
#: static parameters this characteristic does not model (sidewall, tunnelling, reverse knee)
_STATIC_OTHER = ("jsw", "ns", "jtun", "jtunsw", "ntun", "ikr")


def _param(params: Mapping[str, float], name: str) -> float | None:
    """A model parameter by ngspice's name or one of its aliases (lower case), or None; of
    a model that gives it under both names the one written last, as ngspice reads a model's
    parameters in order (``IS=1e-14 JS=1e-12``: 1e-12)."""
    found = None
    for key, value in params.items():
        k = key.lower()
        if k == name or _ALIASES.get(k) == name:
            found = float(value)
    return found


def junction_params(params: Mapping[str, float], area: float = 1.0) -> dict:
    """The characteristic's parameters from a diode model's (``{name: value}``, any case):
    ``{"is", "n", "rs"}`` with ngspice's defaults, plus ``"isr", "nr", "vj", "m"`` where the
    model gives ``ISR`` and ``"ikf"`` where it gives ``IKF`` (A, Ω, V), the area applied and
    ``VJ``, ``M`` held to ngspice's limits (module docstring)."""
    p = {k: (_param(params, k) if _param(params, k) is not None else v)
         for k, v in _DEFAULTS.items()}
    p["is"] *= area
    p["rs"] /= area
    isr = _param(params, "isr")
    if isr is not None:
        vj = _param(params, "vj")
        vj = 1.0 if vj is None else vj
        fc = _param(params, "fc")
        fc = 0.5 if fc is None else fc
        if fc * vj > 1.0:  # diotemp.c: the junction potential held to 1/FC
            vj = 1.0 / fc
        m = _param(params, "m")
        m = min(0.5 if m is None else m, 0.9)
        nr = _param(params, "nr")
        p.update({"isr": isr * area, "nr": NR_DEFAULT if nr is None else nr, "vj": vj, "m": m})
    ikf = _param(params, "ikf")
    if ikf is not None and ikf >= 1e-28:
        p["ikf"] = ikf * area
    return p


def ignored(params: Mapping[str, float]) -> tuple[list[str], list[str]]:
    """The parameters a model gives that the piecewise-linear diode does not follow, upper
    case: those of its charge (``CJO``, ``TT``...; ``VJ`` and ``M`` among them unless the
    model gives ``ISR``, whose generation factor reads them), and the static currents not
    modelled here (sidewall, tunnelling, reverse knee)."""
    given = {_ALIASES.get(k.lower(), k.lower()) for k in params}
    charge = _CHARGE + (() if "isr" in given else ("vj", "m"))
    return ([k.upper() for k in charge if k in given],
            [k.upper() for k in _STATIC_OTHER if k in given])


def describe(p: Mapping[str, float]) -> str:
    """The parameters of the characteristic, as the fit's report line names them."""
    text = f"IS={p['is']:.3g} N={p['n']:.3g} RS={p['rs']:.3g}"
    if "isr" in p:
        text += (f" ISR={p['isr']:.3g} NR={p['nr']:.3g} (generation factor VJ={p['vj']:.3g} "
                 f"M={p['m']:.3g})")
    if "ikf" in p:
        text += f" IKF={p['ikf']:.3g}"
    return text


def junction_current(vd: np.ndarray | float, p: Mapping[str, float]) -> np.ndarray:
    """The diode's current at the junction voltage ``vd >= 0`` (V, behind ``RS``), A."""
    vd = np.asarray(vd, float)
    vt = VT_THERMAL
    c = p["is"] * np.expm1(np.minimum(vd / (p["n"] * vt), 700.0))
    if "isr" in p:
        gen = ((1.0 - vd / p["vj"]) ** 2 + 0.005) ** (p["m"] / 2.0)
        c = c + p["isr"] * np.expm1(np.minimum(vd / (p["nr"] * vt), 700.0)) * gen
    if "ikf" in p:
        c = np.where(c > 1e-18, c / (1.0 + np.sqrt(np.maximum(c, 0.0) / p["ikf"])), c)
    return c


def _plain(p: Mapping[str, float]) -> bool:
    return "isr" not in p and "ikf" not in p


def junction_voltage(i: np.ndarray | float, p: Mapping[str, float]) -> np.ndarray:
    """The junction voltage (V, without ``RS``) at which the diode carries ``i >= 0`` (A):
    ``N Vt ln(1 + i/IS)`` for a model of ``IS`` and ``N`` alone, else
    :func:`junction_current` inverted by bisection (to 1e-15 V)."""
    i = np.asarray(i, float)
    vt = VT_THERMAL
    if _plain(p):
        return p["n"] * vt * np.log1p(i / p["is"])
    # an upper bound: the diffusion current alone reaching what high injection leaves i
    need = i
    if "ikf" in p:
        s = 0.5 * (i / math.sqrt(p["ikf"]) + np.sqrt(i * i / p["ikf"] + 4.0 * i))
        need = s * s
    lo = np.zeros_like(i)
    hi = p["n"] * vt * np.log1p(need / p["is"]) + 1e-9
    for _ in range(64):  # monotone in vd
        mid = 0.5 * (lo + hi)
        below = junction_current(mid, p) < i
        lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
    return 0.5 * (lo + hi)


def diode_voltage(i: np.ndarray | float, p: Mapping[str, float]) -> np.ndarray:
    """The diode's voltage at the current ``i >= 0`` (A), V: :func:`junction_voltage` plus
    ``RS i``."""
    i = np.asarray(i, float)
    return junction_voltage(i, p) + p["rs"] * i
