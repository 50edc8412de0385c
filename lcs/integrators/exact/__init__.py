"""Exact event-driven integration of a switched LCS.

- :mod:`.flow`: the affine dynamics of one mode (switch configuration, held diodes) and its
  exact flow over an interval of linear inputs (one matrix exponential);
- :mod:`.events`: following a span mode by mode, events located on the exact flow;
- :mod:`.integrator` and :mod:`.simulate`: a transient run with dense output and the list of
  events, in the simulation driver;
- :mod:`.sliding`: Filippov sliding on a comparator surface.

What is computed on the exact flows is in :mod:`lcs.analysis`: :mod:`lcs.analysis.saltation`
(transition matrices composed with the saltation matrices: monodromy, harmonic response),
:mod:`lcs.analysis.exact_orbit` (the periodic orbit by Newton's method with the exact
monodromy), :mod:`lcs.analysis.exact_map` (the exact stroboscopic map and its Jacobians).
"""
