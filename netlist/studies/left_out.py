"""What an ideal run of a netlist leaves out of its diodes' and switches' models."""

from __future__ import annotations

from ..circuit import Circuit, Diode, Switch
from ..diode_dc import diode_voltage, junction_params

__all__ = ["DIODE_DROP", "SWITCH_RON", "models_left_out"]

#: a diode model that drops at least this at 1 mA (V), and a switch model of at least this
#: RON (Ω), is a real device's: the ideal run's answer may differ by its drops (a model that
#: drops less, such as the bundled converters' near-ideal ones, goes unmentioned)
DIODE_DROP = 0.1
SWITCH_RON = 0.01


def models_left_out(circuit: Circuit, most: int = 4) -> str | None:
    """The note of an ideal run of a netlist whose diodes and switches have models: what of
    them the run leaves out, and how to have it (a rectifier's 1N4007 drops 0.7 V of 10 V:
    the ideal run's mean output is 10 % above ngspice's). None where there is nothing.

    Diodes and switches pelcs built (limiters, comparators' switches, transistors' body
    diodes), idealised transistors and diode macro-models (noted on their own), and models
    under :data:`DIODE_DROP` and :data:`SWITCH_RON`, are not listed.
    """
    parts = []
    for el in circuit.elements:
        if el.built_for:
            continue
        model = circuit.models.get(getattr(el, "model", "").lower())
        if model is None or getattr(el, "device", None) is not None:
            continue
        if isinstance(el, Diode) and not el.ideal and not el.body_of:
            vf = float(diode_voltage(1e-3, junction_params(model.params, el.area)))
            if vf >= DIODE_DROP:
                # (a model inside a subcircuit is named <subckt>:<model>)
                parts.append(f"{el.name}'s forward voltage ({el.model.split(':')[-1]}: "
                             f"{vf:.2g} V at 1 mA)")
        elif isinstance(el, Switch):
            ron = float(model.params.get("ron", 1.0))  # (ngspice's SW default: 1 Ω)
            if ron >= SWITCH_RON:
                parts.append(f"{el.name}'s on-resistance ({ron:g} Ω)")
    if not parts:
        return None
    more = f" and {len(parts) - most} more" if len(parts) > most else ""
    return (f"ideal devices: {', '.join(parts[:most])}{more} left out of the run; "
            "--devices pwl fits the diodes and switches to their models")
