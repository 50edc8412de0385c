"""Sparse KKT stepping of switched LCS that come from circuits: Moreau's θ scheme solved in
the circuit's own network unknowns, so that a step costs a time proportional to the size of
the circuit rather than to its square.

The dense kernel (:mod:`lcs.integrators.moreau.dense`) stores per mode the θ-discretised matrices of
the LCS (``Phi``, ``K``, ``M``) and per active set the inverse of ``M_aa``. On a voltage multiplier
these are dense (every capacitor voltage enters the diodes' ``w`` further up the ladder), so a
step of a 100-stage multiplier reads about 0.7 MB of matrices, and its cost grows as the
square of the size. Here a step solves the companion network of the mode with the active
diodes as shorts (:mod:`.step`: the KKT system of the step in the unknowns ``z`` of
:class:`~lcs.network.NetworkRealisation` and the active pairs' λ), by a sparse LU of that
system (:mod:`.lu`, columns in a minimum-degree order of :mod:`.ordering`) cached per mode,
step length and active set (:class:`~.layout.KKTCache`).

========================  ==================================================================
:mod:`.lu`                Gilbert–Peierls sparse LU with partial pivoting, its solve
:mod:`.ordering`          minimum-degree column order on ``A + Aᵀ``
:mod:`.layout`            the mode store, the factorisation cache, codes
:mod:`.stack`             building them from the modes' networks (Python)
:mod:`.step`              one θ step: KKT assembly, factorisation, solve, checks, pivoting
:mod:`.grid`              :func:`~.grid.run_kkt`, the loop over a chunk of the time grid
:mod:`.integrate`         which runs it takes, and its calls from the Moreau integrator
========================  ==================================================================

The results are those of the dense kernel up to round-off (``tests/test_kkt.py``: within
1e-9 of the largest value on every family of ``converters/scaling.py``).
"""
