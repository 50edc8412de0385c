"""The integrators of a switched LCS, each run by the driver common to them
(:mod:`lcs.simulation`): the Moreau θ time-stepping (:mod:`.moreau`) and the exact event-driven
integration (:mod:`.exact`)."""
