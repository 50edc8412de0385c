"""The build machinery of the compiled kernels: the export table and the cache stamp of the
kernel sources with the loading of the ahead-of-time module (:mod:`.kernels`), its build
(:mod:`.aot`), the kernels' first use after an installation (:mod:`.kernel_setup`), and a run
of every kernel specialisation (:mod:`.warmup`). It imports the kernels; no kernel imports it
(``lcs.jit`` reads the stamp and the ahead-of-time functions from :mod:`.kernels`, which
imports nothing of pelcs at import time). Nothing is imported here: ``lcs.jit`` imports
:mod:`.kernels` on every run."""
