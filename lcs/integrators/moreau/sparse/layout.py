"""Typed containers and codes of the sparse KKT stepping (see :mod:`lcs.integrators.moreau.sparse`).

Every mode's sparse matrices live in one ragged store (:class:`NetStack`): flat ``ptr``,
``idx``, ``val`` arrays, and per mode a row of ``tab`` giving where each of its structures
(:data:`ST_TEMPLATE` ... :data:`ST_YU`) starts in ``ptr``. A structure is compressed by
columns (CSC) or by rows (CSR) as its use needs; its pointers are absolute positions in
``idx`` and ``val``. Vectors of a mode (orders, pivots, scalings) are in ``ivec``/``fvec``
from ``vtab``'s offsets.
"""

from __future__ import annotations

from collections import namedtuple

# Kernel return codes beyond lcs.integrators.moreau.dense.layout's STEP_* (0 ... 7).
STEP_FALLBACK = 8  # this grid step needs the dense kernel (pivoting failed, no network)
STEP_GROW = 9  # a factorisation needs more room than the cache's slots have

# Structures of a mode in NetStack.tab.
ST_TEMPLATE = 0  # the KKT matrix with every pair active, CSC over N = nz + m columns
ST_SX = 1  # S's state columns, CSC over n columns (rows: network equations)
ST_SU = 2  # S's input columns, CSC over p columns
ST_RX = 3  # Rx, CSR over n rows (columns: network unknowns)
ST_RW = 4  # Rw, CSR over m rows
ST_D = 5  # the LCS's D, CSR over m rows (columns: pairs)
ST_F = 6  # the LCS's F, CSR over m rows (columns: inputs)
ST_YL = 7  # factors of Y (for A x when θ < 1): L, CSC over nz columns
ST_YU = 8  # and U
ST_LEN = 9

# Vectors of a mode: their offsets in NetStack.vtab's columns, integer ones into ivec, float
# ones into fvec.
VI_ORDER = 0  # the KKT column order (N)
VI_YORDER = 1  # Y's column order (nz)
VI_YPINV = 2  # Y's row pivots (nz)
VF_YROW = 3  # Y's row scaling (nz)
VF_YCOL = 4  # Y's column scaling (nz)
V_LEN = 5

# Kinds of the template's entries: when the entry is part of an active set's KKT matrix.
K_ALWAYS = 0  # the companion network Y - s θ S_x Rx (value val + s val2)
K_ROW_ACTIVE = 1  # Rw: in the row of pair i, present when i is active
K_COL_ACTIVE = 2  # -S_λ: in the column of pair i, present when i is active
K_BOTH_ACTIVE = 3  # (θ - 1) D: row pair and column pair both active
K_COL_INACTIVE = 4  # 1 on the diagonal of an inactive pair (its μ = 0)

# Per-mode flags (NetStack.flags columns).
NF_OUTSTATE = 0  # the stored probes are the states
NF_LEN = 1

NetStack = namedtuple("NetStack", ["dims", "tab", "ptr", "idx", "val", "val2", "kind",
                                   "vtab", "ivec", "fvec", "zw", "key", "inp", "flags", "Cy",
                                   "Dy", "Fy"])
NetStack.__doc__ = """Every mode's network, stacked (capacity Q).

``dims (Q, 2)``: ``nz`` and the KKT size ``N = nz + m``; ``tab (Q, ST_LEN)``, ``ptr``,
``idx``, ``val``, ``val2``, ``kind``: the ragged sparse structures (module docstring; ``val2``
and ``kind`` only matter for the template: an entry's value is ``val + s val2`` for a step of
length ``s``, its ``kind`` one of ``K_*``); ``vtab (Q, V_LEN)``, ``ivec``, ``fvec``: the
vectors; ``zw (Q, m)``: 1 for a pair whose ``w`` vanishes identically (kept inactive);
``key (Q, Wk)``: the switch key; ``inp (Q, p + 1)``: the inputs in the mode's dynamics or
pairs (their count, then their indices); ``flags (Q, NF_LEN)``; ``Cy (Q, r, n)``, ``Dy (Q, r,
m)``, ``Fy (Q, r, p)``: the stored probes.
"""

KKTCache = namedtuple("KKTCache", ["mode", "s", "sets", "state", "Lp", "Li", "Lx", "Up",
                                   "Ui", "Ux", "pinv", "rs", "cs", "counters", "hkey", "table",
                                   "thash", "succ", "succ_key"])
KKTCache.__doc__ = """Factorisations of KKT matrices, T slots shared by every mode.

Slot t holds the matrix of mode ``mode[t]``, step length ``s[t]`` (s) and active set
``sets[t] (Wm,)``; ``state[t]``: 0 factorised, -1 singular, -2 empty. Its factors
(:func:`lcs.integrators.moreau.sparse.lu.factor`: ``Lp, Up (T, Nmax + 1)``,
``Li, Lx, Ui, Ux (T, cap)``, ``pinv (T, Nmax)``) are those of the matrix scaled by rows ``rs``
and columns ``cs`` (T, Nmax), powers of two. ``counters (C_LEN,)``: the next slot to reuse,
factorisations, singular sets, KKT solves, refinements (the last three diagnostics, read from
:func:`lcs.integrators.moreau.sparse.integrate.kept`).
``hkey (T,)``: each slot's key hash; ``table, thash (H,)``: the slots by hash (open
addressing, H a power of two >= 4 T; -1 empty) and the hash each entry was stored under.
``succ, succ_key (T,)``: the slot of the set a step last ended in after pivoting away from
slot t's set, and that slot's key hash when it was recorded (-1: none): the set tried next
when t's fails again (:func:`lcs.integrators.moreau.sparse.step.kkt_step`)."""

C_NEXT = 0
C_FACTOR = 1
C_SINGULAR = 2
C_TRIALS = 3  # KKT solves (one per step, more while pivoting)
C_REFINE = 4  # solutions refined before their set was judged
C_LEN = 5
