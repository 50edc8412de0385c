"""Small-signal analysis of switching converters around their periodic steady state.

The exact periodic orbit and its saltation-corrected Jacobians come from
:mod:`lcs.integrators.exact`.

- :mod:`.ltp`: its linearisation with saltations: sampled-data model, harmonic response;
- :mod:`.sweep`: the brute-force time-domain sinusoidal sweep;
- :mod:`.response`: the frequency response, margins, python-control export.
"""

from .response import FrequencyResponse, LoopMargins, loop_margins

__all__ = ["FrequencyResponse", "LoopMargins", "loop_margins"]
