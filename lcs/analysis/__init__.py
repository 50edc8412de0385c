"""Nonsmooth bifurcation analysis of switched LCS.

* :mod:`.maps` -- stroboscopic and event maps built on
:func:`lcs.integrators.moreau.integrator.simulate`, and
  :class:`~.maps.FunctionMap` for any Python function (the names of :mod:`.base`,
  :mod:`.jacobians`, :mod:`.patterns`, :mod:`.lcs_map`, :mod:`.stroboscopic` and
  :mod:`.event_map`, gathered);
* :mod:`.orbits` -- periodic orbits by Newton shooting, Floquet multipliers, classification,
  switching patterns;
* :mod:`.continuation` -- natural continuation of an orbit in a parameter, detection and
  bisection of flip, fold, Neimark-Sacker and border-collision points, from many starting
  states in parallel;
* :mod:`.bifurcation` -- bifurcation diagrams (fixed initial condition or following the
  attractor, up and down), in parallel;
* :mod:`.basins` -- basins of attraction by simple cell mapping (Hsu);
* :mod:`.tables` -- tables of parameter sweeps and Monte Carlo runs;
* :mod:`.parallel` -- the task engine and progress bar the sweeps share: a local process
  pool, or Dask distributed (a local cluster or a scheduler's workers).

Nothing here knows about netlists: a parameter enters through a *map factory*, a picklable
callable ``factory(value) -> Map`` (:class:`netlist.studies.sweep.CircuitMapFactory` for circuits).
"""
