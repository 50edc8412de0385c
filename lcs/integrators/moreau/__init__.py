"""The Moreau θ time-stepping integrator.

- :mod:`.integrator`: ``MoreauOptions``, ``MoreauIntegrator``, ``simulate``, ``simulate_lcs``;
- :mod:`.dense`: its compiled kernel on the LCS matrices of each mode;
- :mod:`.sparse`: its compiled kernel on the sparse companion network of each mode (a KKT
  system per step), for large networks whose LCS matrices are dense;
- :mod:`.theta_screen`: where θ < 1 is unreliable.

Nothing is imported here: importing a kernel module imports only what it uses.
"""
