"""The integer codes the compiled kernels share with the Python side of a run.

numba freezes module constants into the code it compiles, so these live in a file of their own
that is part of the kernels' cache stamp (:data:`lcs.build.kernels.KERNEL_SOURCES`): changing one
recompiles every kernel, where a change elsewhere in the simulation package does not.
"""

# Event records (lcs.simulation.recorder): the switch index plus one of these.
EV_SWITCH = 0
EV_SLIDE_START = 1 << 20
EV_SLIDE_END = 2 << 20

# Operations of known switchings (lcs.simulation.schedule), applied at their instant.
OP_SET = 0  # key = (key & ~a) | b   (source- or controller-driven switches)
OP_REARM = 1  # latched switch a: on iff its control >= vt - vh

# How each switch is driven (lcs.simulation.switches).
SW_SCHEDULED = 0  # sources or a Python controller: instants known in advance
SW_LOCATED = 1  # comparator: crossings located inside the step
SW_SAMPLED = 2  # comparator sampled at the end of each step (explicit method)
SWF_LATCH = 1  # an off switch turns on only at the re-arm instants (clock period starts)
SWF_RELAY = 2  # may enter a Filippov sliding mode
