"""The diode audit: ngspice runs that "succeed" with a near-ideal diode conducting in reverse
(non-converged time points accepted when a switch closes onto it) are found by the branch
current of a 0 V sense source in series with each static diode (see *The diode audit* in
:mod:`ngspice_checks.runner`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from netlist.units import parse_number

from . import deck

#: a diode whose reverse charge exceeds this fraction of its forward charge is an artefact
REVERSE_CHARGE_LIMIT = 1e-3

#: a reverse current that never exceeds this (A) is leakage, not an artefact: ngspice puts
#: GMIN (1e-12 S, 1e-10 S at the relaxed rung) across every junction, so a diode that never
#: conducts carries GMIN times its reverse voltage (25 pA at 24 V), which the charge ratio
#: alone would flag
LEAKAGE_CURRENT = 1e-6

_DYNAMIC_DIODE_PARAMS = ("tt", "cjo", "cj0", "cj")


def _audited_diodes(text: str) -> list[str]:
    """Top-level diodes whose model is static (no TT, no junction capacitance).

    Those cannot carry reverse current beyond their leakage, so a reverse current is a
    numerical artefact; diodes with a transit time or CJO may legitimately recover.
    """
    models = {m.name.lower(): m for m in deck.models(text)}
    out = []
    for el in deck.top_level_elements(text):
        if not el.name.lower().startswith("d") or len(el.tokens) < 4:
            continue
        model = models.get(el.tokens[3].lower())
        dynamic = model is not None and any(
            parse_number(model.params.get(k, "0")) not in (0.0,)
            for k in _DYNAMIC_DIODE_PARAMS
            if k in model.params
        )
        if not dynamic:
            out.append(el.name)
    return out


def _audit_diodes(vectors: dict[str, np.ndarray], diodes: Sequence[str]) -> str | None:
    """Reason if a static diode conducted a non-negligible charge in reverse, else None.

    ngspice 39 accepts non-converged time points when a switch closes onto a conducting
    near-ideal diode (boost converters: the switch node is pulled to ground while D1 still
    carries the inductor current). For a few ns the diode then conducts kiloamperes in
    reverse and drains the output capacitor, and the run still "succeeds". The device's own
    ``@d1[id]`` does not show it (the accepted point violates the diode equation); the
    branch current of the series sense source, which obeys KCL, does.
    """
    t = np.real(vectors["time"])
    for name in diodes:
        i = np.real(vectors.get(deck.sense_names(name)[0] + "#branch", np.zeros(0)))
        if len(i) != len(t) or len(t) < 2:
            continue
        if -i.min() <= LEAKAGE_CURRENT:
            continue
        reverse = float(np.trapezoid(np.maximum(-i, 0.0), t))
        forward = float(np.trapezoid(np.maximum(i, 0.0), t))
        if reverse > REVERSE_CHARGE_LIMIT * max(forward, 1e-12) or -i.min() > max(i.max(), 1e-3):
            k = int(np.argmin(i))
            return (
                f"artefact: diode {name} conducted {reverse:.3g} C in reverse (vs {forward:.3g} C"
                f" forward; peak {i[k]:.3g} A at t = {t[k]:.4g} s): ngspice accepted "
                "non-converged time points"
            )
    return None


