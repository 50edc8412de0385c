"""pelcs: power-electronics netlists with ideal diodes and switches as linear complementarity
systems.

The Python API (see :mod:`pelcs.api`)::

    import pelcs
    circuit = pelcs.load("converters/netlists/boost.cir", params={"duty": 0.4})
    system = pelcs.formulate(circuit)
    res = pelcs.simulate(circuit, tstop="2m", probes=["v(out)", "i(L1)"])
    res.t, res["v(out)"]
    orb = pelcs.orbit("converters/netlists/boost.cir")   # also check, continuation,
    orb.multipliers, orb.to_pandas(), orb.plot()         # bifurcation, basins, sweep

The import packages are ``netlist`` (grammar, parser, circuit model, formulation), ``lcs`` (the
mathematics), ``converters``, ``ngspice_checks``; this package holds the version, the API, the
plotting helpers and the CLI.
"""

from typing import TYPE_CHECKING

__version__ = "0.1.0"

if TYPE_CHECKING:  # for type checkers and IDEs; at run time the names load lazily
    from lcs.notices import NonPassiveWarning

    from .api import (
        SimulationError,
        SimulationResult,
        ac,
        basins,
        bifurcation,
        check,
        continuation,
        formulate,
        load,
        orbit,
        simulate,
        sweep,
    )

__all__ = ["NonPassiveWarning", "SimulationError", "SimulationResult", "__version__", "ac",
           "basins", "bifurcation", "check", "continuation", "formulate", "load", "orbit",
           "simulate", "sweep"]

_API = {"load", "formulate", "simulate", "ac", "check", "orbit", "continuation",
        "bifurcation", "basins", "sweep", "SimulationError", "SimulationResult"}


def __getattr__(name: str):
    # Lazy: ``import pelcs`` (done by the CLI for the version) stays cheap; numpy, scipy and
    # numba load on first use of the API.
    if name in _API:
        from . import api

        return getattr(api, name)
    if name == "NonPassiveWarning":
        from lcs.notices import NonPassiveWarning

        return NonPassiveWarning
    raise AttributeError(f"module 'pelcs' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | _API)
