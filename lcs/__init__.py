"""The mathematics of pelcs: LCS models, LCP solvers, passivity, well-posedness, GDCM,
integrators, controllers and analysis (``docs/architecture.md``). Knows nothing of netlists."""
