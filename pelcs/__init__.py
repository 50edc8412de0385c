"""pelcs: power-electronics netlists with ideal diodes and switches as linear complementarity
systems.

The import packages are ``netlist`` (grammar, parser, circuit model, formulation), ``lcs`` (the
mathematics), ``converters``, ``ngspice_checks``; this package holds the version and the CLI.
"""

__version__ = "0.1.0"
