"""The studies run on a circuit: what takes a ``Circuit`` and its formulation to a result.

``transient.py`` (a run: ``transient_setup``, ``simulate_circuit``; ``timestep.py`` the step
and print grid from ``.tran`` and the sources), ``sweep.py`` (map factories of a netlist for
``lcs.analysis``), ``measure.py`` (measurements over the steady-state window), ``losses.py``
and ``realistic.py`` (conduction losses; runs with piecewise-linear devices),
``param_sweep.py`` (parameter grids, Monte Carlo tolerances), ``ac.py`` (small-signal
response). These modules call the integrators and analyses of ``lcs``; the rest of
``netlist`` (language, circuit, formulation) never imports them.
"""
