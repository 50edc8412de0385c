"""Small-signal analysis of switching converters around their periodic steady state.

- :mod:`.modeflow`: the affine dynamics of one mode (switch configuration, held diodes);
- :mod:`.pwl_orbit`: the exact periodic orbit (event instants to round-off);
- :mod:`.ltp`: its linearisation with saltations: sampled-data model, harmonic response;
- :mod:`.sweep`: the brute-force time-domain sinusoidal sweep;
- :mod:`.response`: the frequency response, margins, python-control export.
"""

from .response import FrequencyResponse, LoopMargins, loop_margins

__all__ = ["FrequencyResponse", "LoopMargins", "loop_margins"]
