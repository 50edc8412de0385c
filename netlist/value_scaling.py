"""What scales an element's value as written, as ngspice does: its multipliers and its
temperature.

* ``m=`` of R, L, C (``m`` elements in parallel: R/m, L/m, C*m) and ``AREA``, ``m=`` of a
  diode: :func:`multiplier`.
* ngspice runs a circuit at ``.temp T`` (or ``.options temp=T``; 27 °C without either) and
  scales each R, L and C from its nominal temperature ``TNOM`` (its model's ``TNOM``, else
  ``.options tnom=``, else 27 °C) to its own temperature (its ``temp=``, else the circuit's
  plus its ``dtemp=``) by ``1 + TC1 dT + TC2 dT²``, the instance's ``tc1=``/``tc2=`` before
  its resistor model's (``restemp.c``, ``captemp.c``, ``indtemp.c``):
  :func:`temperature_factor`. pelcs's values are those scaled ones, and so are those it
  writes for ngspice.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from .circuit import IgnoredCommand
from .rawdeck import RawElement, RawModel, RawParam, Statement
from .units import parse_number

__all__ = ["NOMINAL", "deck_temperatures", "multiplier", "read_resistor_model",
           "temperature_factor", "value_factor"]

#: ngspice's default circuit and nominal temperature, °C
NOMINAL = 27.0


def _number(text: str) -> float | None:
    text = str(text).strip()
    if len(text) > 2 and text[0] == "{" and text[-1] == "}":
        text = text[1:-1].strip()
    return parse_number(text)


def circuit_temperatures(options: Mapping[str, str], ignored: Iterable[IgnoredCommand]
                         ) -> tuple[float, float, list[tuple[str, IgnoredCommand | None]]]:
    """The circuit's temperature and the default nominal temperature, °C, and the problems
    (a message and the command it is about) of values that are not numbers.

    ``options``: ``.options`` as read (name -> text); ``ignored``: the commands pelcs does not
    act on, among them ``.temp`` (ngspice's last ``.temp`` line sets the temperature, and a
    ``.temp`` line wins over ``.options temp=``)."""
    problems: list[tuple[str, IgnoredCommand | None]] = []
    opts = {str(k).lower(): v for k, v in options.items()}
    temps = {}
    for key in ("temp", "tnom"):
        temps[key] = NOMINAL
        if opts.get(key) not in (None, ""):
            value = _number(opts[key])
            if value is None:
                problems.append((f".options {key}={opts[key]}: not a number", None))
            else:
                temps[key] = value
    for cmd in ignored:
        words = cmd.text.split()
        if words and words[0].lower() == ".temp":
            value = _number(words[1]) if len(words) > 1 else None
            if value is None or len(words) > 2:
                problems.append((f"'{cmd.text}': pelcs reads one temperature, a number", cmd))
            else:
                temps["temp"] = value
    return temps["temp"], temps["tnom"], problems


def deck_temperatures(builder) -> tuple[float, float]:
    """:func:`circuit_temperatures` of ``builder``'s deck (netlist.flatten's), its problems
    reported through it."""
    temp, tnom, problems = circuit_temperatures(builder.deck.options, builder.deck.ignored)
    for message, cmd in problems:
        builder.error(message, cmd.location if cmd is not None else None,
                      "write .temp T (or .options temp=T) with T a number, °C")
    return temp, tnom


def multiplier(builder, el: RawElement, name: str, env: Mapping[str, float],
               failed: set[str]) -> float:
    """The product of an element's multipliers (``m=`` of R, L, C; AREA and ``m=`` of a
    D), 1 without any; an error for one that is not positive (``builder``: netlist.flatten's,
    for its evaluation and errors)."""
    out = 1.0
    for p in el.params:
        if p.name not in ("m", "area"):
            continue
        v = builder.value_or_nan(p.value, env, failed)
        if not v > 0:
            if not math.isnan(v) or p.value.expr is None:
                builder.error(f"{name}: {p.name} must be positive, got {v:g}", p.loc,
                              f"{p.name} multiplies the element: give a positive number",
                              (name,))
            continue
        out *= v
    return out


def value_factor(instance: Mapping[str, float], model: Mapping[str, float], temp: float,
                 tnom: float) -> tuple[float, float, float]:
    """ngspice's factor ``1 + TC1 dT + TC2 dT²`` of an element's value, the element's own
    temperature and its nominal one (°C), ``dT`` their difference.

    Parameters
    ----------
    instance : mapping
        The element's ``tc1``, ``tc2`` (1/°C, 1/°C²), ``temp``, ``dtemp`` (°C) as given, and a
        resistor's ``tce`` (%/°C: the factor is then ``1.01^(TCE dT)``, as ngspice 39's).
    model : mapping
        Its model's ``tc1``, ``tc2``, ``tnom`` as given (empty without a model).
    temp, tnom : float
        The circuit's temperature and the default nominal temperature, °C.
    """
    own = instance["temp"] if "temp" in instance else temp + instance.get("dtemp", 0.0)
    nominal = model.get("tnom", tnom)
    dt = own - nominal
    if "tce" in instance:  # a resistor's exponential coefficient (ngspice 39): %/°C
        return 1.01 ** (instance["tce"] * dt), own, nominal
    tc1 = instance.get("tc1", model.get("tc1", 0.0))
    tc2 = instance.get("tc2", model.get("tc2", 0.0))
    return 1.0 + tc1 * dt + tc2 * dt * dt, own, nominal


def read_resistor_model(reader, st: Statement, name_tok, tree) -> None:
    """``.model NAME R(...)`` into ``reader.deck.models`` (a RawModel of type R): its TC1,
    TC2 and TNOM, the only parameters that change a resistor whose value is given; the others
    (RSH, W, L, ...) noted as not read (``reader``: netlist.reader's, for values and notes)."""
    items = tree.children[3].children if len(tree.children) > 3 else []
    params, others = [], []
    for t in items:
        key = t.children[0]
        if t.data != "flag" and key.lower() in ("tc1", "tc2", "tnom"):
            v = reader.value(t.children[1], st)
            if v is not None:
                params.append(RawParam(key.lower(), v, st, key.start_pos))
        else:
            others.append(str(key))
    if others:
        reader.deck.notes.append(f"line {st.loc(0).line}: resistor model '{name_tok}': "
                                 f"{', '.join(others)} not read (pelcs reads TC1, TC2 and "
                                 "TNOM; its resistors' values are given)")
    scope = reader.sub.key if reader.sub is not None else None
    reader.deck.models.append(RawModel(str(name_tok), "R", params, st, scope))


def temperature_factor(builder, el: RawElement, name: str, env: Mapping[str, float],
                       failed: set[str]) -> float:
    """The factor of an R, L or C value (:func:`value_factor`) from its ``tc1``, ``tc2``,
    ``temp``, ``dtemp`` and its resistor model's (``builder``: netlist.flatten's, for its
    evaluation, temperatures, resistor models, notes and errors); 1 at the nominal
    temperature or without coefficients."""
    given = {p.name: builder.value_or_nan(p.value, env, failed) for p in el.params
             if p.name in ("tc1", "tc2", "temp", "dtemp") or p.name == "tce" and el.kind == "R"}
    found = builder.resistor_models.get(el.ref.lower()) if el.ref else None
    model = found.params if found is not None else {}
    if el.ref and found is None:
        builder.circuit.notes.append(f"{name}: model '{el.ref}' is not a resistor model of "
                                     "the netlist: ignored, the value is used")
    factor, own, nominal = value_factor(given, model, builder.temp, builder.tnom)
    if factor != 1.0:
        builder.circuit.notes.append(f"{name}: value scaled by {factor:.6g} by its TC1, TC2 "
                                     f"from its nominal {nominal:g} °C to its {own:g} °C, as "
                                     "ngspice does")
    if not factor > 0:
        builder.error(f"{name}: its temperature coefficients make its value {factor:g} times "
                      "the nominal one, not positive", el.st.loc(0),
                      "check TC1, TC2 and the temperatures (.temp, temp=, dtemp=)", (name,))
    return factor
