"""The temperature coefficients of resistors, capacitors and inductors, as ngspice applies
them (``restemp.c``, ``captemp.c``, ``indtemp.c``).

An R, C or L line's ``TC1=``/``TC2=`` scale its value at the instance's temperature ``T``::

    value(T) = value (1 + TC1 (T - TNOM) + TC2 (T - TNOM)^2)

(a resistor's ``TCE=`` instead: ``value 1.01^(TCE (T - TNOM))``). ``T`` is the instance's
``TEMP=``, else the circuit's temperature (``.temp``, else ``.options temp=``, else 27 °C)
plus its ``DTEMP=``; ``TNOM`` is ``.options tnom=``, else 27 °C. At ``T = TNOM`` the value is
the one written.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from .units import parse_number

__all__ = ["NOMINAL", "TEMPERATURE_PARAMS", "circuit_temperatures", "scale",
           "temperature_factor"]

#: ngspice's default circuit and nominal temperature, °C
NOMINAL = 27.0

#: instance parameters about temperature that an R, C or L line may carry
TEMPERATURE_PARAMS = ("tc1", "tc2", "tce", "temp", "dtemp")


def circuit_temperatures(options: Mapping[str, object], ignored: Sequence) -> tuple[float, float]:
    """(the circuit's temperature, TNOM), °C, from ``.options`` and the ``.temp`` commands
    (``ignored``: the deck's commands pelcs does not act on, each with its ``text``); a
    value that is not a number counts as absent."""
    opts = {str(k).lower(): v for k, v in options.items()}

    def number(value) -> float | None:
        v = parse_number(str(value)) if value is not None else None
        return float(v) if v is not None else None

    temp = number(opts.get("temp"))
    for cmd in ignored:
        words = str(getattr(cmd, "text", "")).split()
        if len(words) > 1 and words[0].lower() == ".temp":
            temp = number(words[1]) if number(words[1]) is not None else temp
    tnom = number(opts.get("tnom"))
    return (NOMINAL if temp is None else temp), (NOMINAL if tnom is None else tnom)


def temperature_factor(kind: str, given: Mapping[str, float], temp: float,
                       tnom: float) -> float:
    """The factor on an R, C or L value (``kind``) of its line's temperature parameters
    ``given`` (lower-case names of :data:`TEMPERATURE_PARAMS`, evaluated) at the circuit's
    ``temp`` and nominal ``tnom`` (°C); 1 where it has no coefficient."""
    t = given.get("temp")
    diff = (t if t is not None else temp + given.get("dtemp", 0.0)) - tnom
    if kind == "R" and "tce" in given:
        return 1.01 ** (given["tce"] * diff)
    return 1.0 + given.get("tc1", 0.0) * diff + given.get("tc2", 0.0) * diff * diff


def scale(builder, el, name: str, env: Mapping[str, float], failed: set[str]) -> float:
    """The factor on the value of ``el``, an R, L or C line (``netlist.rawdeck.RawElement``)
    named ``name``, of its temperature parameters, evaluated by ``builder``
    (``netlist.flatten._Builder``) in ``env``; a note in its circuit where it is not 1."""
    if not el.temperature:
        return 1.0
    given = {p.name: builder.value_or_nan(p.value, env, failed) for p in el.temperature}
    if any(math.isnan(v) for v in given.values()):
        return 1.0  # (reported where it was evaluated)
    temp, tnom = circuit_temperatures(builder.deck.options, builder.deck.ignored)
    factor = temperature_factor(el.kind, given, temp, tnom)
    if factor != 1.0:
        at = given.get("temp", temp + given.get("dtemp", 0.0))
        said = ", ".join(f"{k.upper()} = {v:g}" for k, v in given.items())
        builder.circuit.notes.append(
            f"{name}: {said}: its value times {factor:.6g} at {at:g} °C (TNOM {tnom:g} °C), "
            "as ngspice scales it (1 + TC1 dT + TC2 dT^2; TCE: 1.01^(TCE dT))")
    return factor
