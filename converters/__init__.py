"""Converters: bundled netlists (``netlists/*.cir``), netlist factories
(:mod:`converters.factories`), design helpers (:mod:`converters.design`) and CCM averaged
models with ripple formulas (:mod:`converters.averaged`)."""
