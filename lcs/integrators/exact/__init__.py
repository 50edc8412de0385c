"""Exact event-driven integration of a switched LCS.

- :mod:`.flow`: the affine dynamics of one mode (switch configuration, held diodes) and its
  exact flow over an interval of linear inputs (one matrix exponential);
- :mod:`.events`: following a span mode by mode, events located on the exact flow;
- :mod:`.saltation`: transition matrices composed with the saltation matrices (monodromy,
  harmonic response);
- :mod:`.orbit`: the periodic orbit by Newton's method with the exact monodromy;
- :mod:`.simulate`: a transient run with dense output and the list of events.
"""
