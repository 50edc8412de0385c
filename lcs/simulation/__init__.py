"""The simulation driver, common to every integrator (``docs/architecture.md``).

:mod:`.problem` (modes, probes, controls), :mod:`.switches` (how each switch is driven),
:mod:`.inputs` (sources), :mod:`.source_switching` (instants of source-driven switches),
:mod:`.schedule` (breakpoints, known switchings, Python controllers), :mod:`.initial`
(initial mode and state), :mod:`.recorder` (saved probes and events), :mod:`.failures`
(errors), :mod:`.integrator` (the interface an integrator implements) and :mod:`.driver`
(the run).
"""
