"""Codes, array layouts and typed containers shared by the Moreau kernel and its driver.

The kernel's data travel in a few named tuples (numba types them field by field, so a
function that takes a ``ModeStack`` reads ``stack.mats.Phi[j, i, k]`` and compiles to plain
array access; a mode is an index ``j`` into the stack):

* :class:`ModeArrays` -- the matrices of one switch mode (2-D), or of every mode stacked along
  a leading mode axis (3-D, in :class:`ModeStack`);
* :class:`SwitchArrays`, :class:`Chunk`, :class:`Schedule`, :class:`Store`, :class:`Limits` --
  the switches, a chunk of the time grid with its inputs, the known switching instants of the
  chunk, the output and event buffers, the integer options;
* :class:`StepWork`, :class:`LocateWork` -- scratch arrays;
* :class:`Ledger`, :class:`Actives`, :class:`Step`, :class:`Inputs`, :class:`Modes`,
  :class:`Ends`, :class:`Crossings`, :class:`Blend` -- the arguments of a step
  (:func:`~.step.mode_step`, :func:`~.sliding.advance`), of the instant search
  (:func:`~.locate.locate`), of the crossing test and of the output row grouped by what they
  hold: counters and options, active sets, the step's interval, its inputs, its modes, the
  states at its ends, the comparators, the mode (or Filippov combination of two) a value is
  taken in.

The kernel's running state (counters, the current switch key, where it stopped) lives in the
``ivars`` (int64) and ``fvars`` (float64) arrays indexed by ``IV_*`` and ``FV_*``, which the
driver reads after each call, and in ``act (2, W)``, the active sets (bitsets of the pairs with
basic λ) of the current mode and of the other mode of a sliding switch, and ``fail (W,)``, the
pairs involved in a failure.
"""

from __future__ import annotations

from collections import namedtuple

from lcs.lcp.compiled import AS_MISSES, AS_NEXT_SLOT, AS_UPDATES
from lcs.simulation.codes import EV_SLIDE_END as EV_SLIDE_END
from lcs.simulation.codes import EV_SLIDE_START as EV_SLIDE_START
from lcs.simulation.codes import EV_SWITCH as EV_SWITCH
from lcs.simulation.codes import OP_REARM as OP_REARM
from lcs.simulation.codes import OP_SET as OP_SET
from lcs.simulation.codes import SW_LOCATED as SW_LOCATED
from lcs.simulation.codes import SW_SAMPLED as SW_SAMPLED
from lcs.simulation.codes import SW_SCHEDULED as SW_SCHEDULED
from lcs.simulation.codes import SWF_LATCH as SWF_LATCH
from lcs.simulation.codes import SWF_RELAY as SWF_RELAY

# Kernel return codes.
STEP_OK = 0
STEP_LCP_FAILED = 1  # Lemke and enumeration found no solution (or the pivot budget ran out)
STEP_NONFINITE = 2
STEP_NONUNIQUE = 3
STEP_NEED_MODE = 4  # build the mode of key state.need, append it, call again
STEP_FULL = 5  # grow the output / event buffers, call again
STEP_CHATTER = 6  # more than max_switchings switchings in one grid step
STEP_SLIDING = 7  # a comparator toggles without progress and may not slide

# Layout of the int64 "ivars" array shared between the driver and the kernel.
IV_NEXT_SLOT = AS_NEXT_SLOT  # next active-set cache slot to (re)use
IV_FALLBACKS = 2  # Lemke calls
IV_PIVOTS = 3  # Lemke pivots in total
IV_GSTEP = 4  # grid steps completed (for ``every``)
IV_OUTPOS = 5  # rows written to the output buffers
IV_ODD = 6  # steps not of the regular length h (shortened, split, sliding-mode partial)
IV_UNIQ = 8  # uniqueness checks done
IV_MISSES = AS_MISSES  # active-set cache misses (factorisations)
IV_UPDATES = AS_UPDATES  # factorisations by rank-one updates
IV_NMODES = 11  # modes in the stacks
IV_EVPOS = 13  # event records written
IV_K = 14  # grid step (index within the chunk) to resume at / where the kernel stopped
IV_SCHED = 15  # next schedule entry of the chunk
IV_INIT = 16  # grid step whose start (schedule, counters) has been processed
IV_NSW = 17  # switchings in the current grid step
IV_LASTSW = 18  # switch flipped last by its comparator (-1: none)
IV_SLIDE = 19  # switch in sliding mode (-1: none)
IV_FAILSW = 20  # switch involved in a chattering / sliding failure
IV_FAILMODE = 21  # mode id of a failing step
IV_STEPS = 22  # steps taken (grid steps and the extra parts of split steps)
IV_LOCATED = 23  # comparator switchings located inside a step
IV_ROOTEVALS = 24  # trial steps of the instant search
IV_SLIDESTEPS = 25  # steps taken in sliding mode
IV_LEMKE = 27  # Lemke status of a failed LCP
IV_WARM = 7  # warm-started principal pivoting solves (cached active set not accepted)
IV_ODDHIT = 28  # shortened steps served by a stored discretisation of their length
IV_ODDMISS = 29  # shortened steps whose length was discretised and stored
IV_LEN = 30

# Layout of the float64 "fvars" array.
FV_RTOL = 0  # fast-path acceptance tolerance (relative)
FV_PIVOT_TOL = 1
FV_LEX_TOL = 2
FV_UNIQ_TOL = 3  # relative state difference that makes two LCP solutions "different"
FV_TCUR = 4  # time of x, s (may lie inside grid step IV_K after a switching)
FV_H = 5  # regular step, s
FV_THETA = 6
FV_FEAS_TOL = 7  # feasibility tolerance of the enumeration fallback (relative)
FV_LASTT = 8  # time of the last comparator switching, s
FV_FAIL_T0 = 9  # failing step: start and end, s
FV_FAIL_T1 = 10
FV_DUTY = 11  # on-fraction of the sliding switch over the last step
FV_ROOT_TOL = 12  # instants are located to this fraction of h
FV_LEN = 13

# Per-mode flags (columns of ``ModeStack.flags``).
MF_FAST = 0  # active-set fast path enabled
MF_UNIQ = 1  # check state uniqueness of Lemke solutions when m <= this (-1: never)
MF_OUTSTATE = 2  # the stored outputs are the states (skip the products)
# every step's next state is unique whatever its λ (lcs.theory.step_uniqueness): no check
MF_IMAGE = 3
MF_LEN = 4

# Shortest run of steps up to the next schedule entry that run_grid gives to its plain loop.
PLAIN_MIN = 16

MODE_FIELDS = ["A", "B", "C", "D", "E", "F", "Phi", "G0", "G1", "K", "M", "Cy", "Dy", "Fy",
               "Cc", "Dc", "Fc", "PhiT", "CT", "KT", "MT"]
ModeArrays = namedtuple("ModeArrays", MODE_FIELDS)
ModeArrays.__doc__ = """The matrices of a switch mode.

The LCS ``A (n, n)``, ``B (n, m)``, ``C (m, n)``, ``D (m, m)``, ``E (n, p)``, ``F (m, p)``; its θ
step of the regular length h, ``Phi (n, n)``, ``G0, G1 (n, p)``, ``K (n, m)``, ``M (m, m)``
(:func:`lcs.integrators.moreau.dense.discretise`); the stored probes ``y = Cy x + Dy λ + Fy u``
with ``Cy (r, n)``, ``Dy (r, m)``, ``Fy (r, p)``; the switch controls ``c = Cc x + Dc λ + Fc u``
with ``Cc (k, n)``, ``Dc (k, m)``, ``Fc (k, p)``; and ``PhiT (n, n)``, ``CT (n, m)``, ``KT (m, n)``,
``MT (m, m)``, the transposes of ``Phi``, ``C``, ``K`` and ``M`` for the regular step's products,
taken a column at a time: each
output entry sums its terms in the same order as a row-by-row product (the same numbers, bit
for bit), and the inner loop runs over contiguous memory, which the compiler vectorises. In a
:class:`ModeStack` every field has a leading mode axis.
"""


def mode_shapes(n: int, m: int, p: int, r: int, k: int) -> ModeArrays:
    """The shape of each field of :class:`ModeArrays` for one mode."""
    return ModeArrays((n, n), (n, m), (m, n), (m, m), (n, p), (m, p), (n, n), (n, p), (n, p),
                      (n, m), (m, m), (r, n), (r, m), (r, p), (k, n), (k, m), (k, p), (n, n),
                      (n, m), (m, n), (m, m))


OddSteps = namedtuple("OddSteps", ["s", "Phi", "G0", "G1", "KT", "M", "next", "sets",
                                   "counters"])
OddSteps.__doc__ = """Discretisations of shortened steps, ``OS`` per mode: the step length
``s (Q, OS)`` in s (-1: an empty slot); the matrices of slot ``o`` of mode ``j`` at index
``jj = j OS + o`` of ``Phi (Q OS, n, n)`` (transposed from
:data:`~lcs.integrators.moreau.dense.discretise.COLUMN_MIN` states on), ``G0, G1 (Q OS, n, p)``,
the transpose of ``K``, ``KT (Q OS, m, n)``, and ``M (Q OS, m, m)``, with an
:class:`~lcs.lcp.compiled.ActiveSets` cache ``sets`` of :data:`ODD_SETS` active sets each (its
own round-robin ``counters``, laid out as the kernel's ``ivars``, whose unused entry 0 counts
evictions); ``next (Q,)`` the slot of each mode to fill next.
Source-driven switchings and PULSE edges fall at the same offsets from the grid every period,
so the same few lengths, and at each the same active sets, recur: the elimination (O(n^3))
and the active set's factorisation are done once."""

#: active-set factorisations kept per stored shortened-step length (a PWM edge's step sees the
#: set before and after it, and block pivoting's intermediate sets: with 2, a 64-phase
#: interleaved buck refactorised 52,000 sets in 200 periods, with 4, 3,000)
ODD_SETS = 4

ModeStack = namedtuple("ModeStack", ["mats", "sets", "key", "flags", "odd", "inp", "span"])
ModeStack.__doc__ = """Every mode built so far, stacked by mode id ``j`` (capacity Q).

``mats``: :class:`ModeArrays` of (Q, ., .) arrays; ``sets``: :class:`ActiveSets` of (Q, S, ...)
arrays; ``key (Q, Wk)``: the switch key of each mode (a bitset, :mod:`lcs.bits`: bit i, switch
i on); ``flags (Q, MF_LEN)``; ``odd``: :class:`OddSteps`; ``inp (Q, p + 1)`` the inputs that
enter mode j's dynamics or LCP (a non-zero column of ``E`` or ``F``): their number
``inp[j, 0]``, then their indices in increasing order. The steps sum the input terms over
those only: gate drives are inputs that only the switches see (an MMC arm of 64 cells has
129 inputs, 1 in its dynamics), and the skipped terms are exact zeros. ``span (Q, 2, n, 2)``:
for each column of ``Phi`` (``span[j, 0]``) and of ``C`` (``span[j, 1]``) the rows from its
first to past its last non-zero entry (0, 0 for a zero column): the regular step's column
products run over those (a multiplier's ``C`` is triangular and its ``Phi`` the identity but
for the part the load couples; an MMC arm's ``C`` has two entries a column).
"""

SwitchArrays = namedtuple("SwitchArrays", ["kind", "flags", "vt", "vh"])
SwitchArrays.__doc__ = """Per switch (k,): ``kind`` (``SW_*``), ``flags`` (``SWF_*``), and the
comparator's threshold ``vt`` and hysteresis half-width ``vh`` (control units)."""

Chunk = namedtuple("Chunk", ["t", "odd", "U0", "U1", "Um", "force_out"])
Chunk.__doc__ = """A chunk of the time grid: boundaries ``t (N + 1,)`` in s (``t[0]`` is the end of
the previous chunk); ``odd (N,)`` steps not of length h; inputs ``U0, U1 (N, p)`` at the start
(right limit) and end (left limit) of each step, linear in between (exact for piecewise-linear
sources, whose breakpoints are grid points); ``Um (N, p)`` at the midpoints when some source is
not piecewise linear (quadratic interpolation, O(h³)), else ``(0, p)``; ``force_out (N,)``
store the end of this step whatever ``every`` says."""

Schedule = namedtuple("Schedule", ["k", "op", "a", "b"])
Schedule.__doc__ = """Known switchings of a chunk: before grid step ``k[i]`` (L,), operation
``op[i]`` (L,) (``OP_*``) with arguments ``a[i]``, ``b[i]`` (L, Wk): the bitsets of
``OP_SET`` (key = (key & ~a) | b), the switch index ``a[i, 0]`` of ``OP_REARM``; sorted by
``k``."""

Store = namedtuple("Store", ["T", "Y", "duty", "ev_t", "ev_key", "ev_info"])
Store.__doc__ = """Output buffers: times ``T (cap,)`` in s and probes ``Y (cap, r)``, written from
row ``ivars[IV_OUTPOS]``; ``duty (r,)`` per probe -1 (``Cy x + Dy λ + Fy u``) or a switch
index (its on-fraction: 0/1, or the equivalent duty while it slides); events: time (s),
switch key after it (cap_e, Wk), ``switch + EV_*`` (-1: schedule), written from
``ivars[IV_EVPOS]``."""

State = namedtuple("State", ["x", "lam", "lama", "key", "act", "fail", "need", "ivars",
                             "fvars"])
State.__doc__ = """The kernel's state between calls: state ``x (n,)``, multipliers ``lam (m,)`` and,
while a switch slides, the other mode's ``lama (m,)``; the switch key ``key (Wk,)``; the active
sets ``act (2, W)`` of the current mode and of the other mode of a sliding switch; ``fail
(W,)`` the pairs of a failed step; ``need (Wk,)`` the key of the mode to build
(``STEP_NEED_MODE``); counters and options ``ivars``, ``fvars``."""

Limits = namedtuple("Limits", ["max_piv", "enum_max_m", "every", "max_sw", "warm_iter"])
Limits.__doc__ = """Lemke's pivot budget; enumeration fallback up to this m (-1: never); store
every ``every``-th grid step; at most ``max_sw`` comparator switchings per grid step; at most
``warm_iter`` iterations of warm-started principal pivoting (0: none, straight to Lemke)."""

StepWork = namedtuple("StepWork", ["xf", "q", "Ko", "Mo", "augn", "lcp"])
StepWork.__doc__ = """Scratch of one θ step: ``x_free (n,)``, ``q (m,)``, the matrices of a step of
another length ``K (n, m)``, ``M (m, m)``, the elimination array ``(n, n + 1 + m)``, and the
LCP solvers' :class:`~lcs.lcp.compiled.LcpWork` (with the cached path's ``λ_a``, ``w`` and its
scale: :func:`lcs.lcp.compiled.solve_cached`)."""

LocateWork = namedtuple("LocateWork", ["ga", "gta", "rate_a", "rate_b", "udot", "xdot", "ut",
                                       "xt", "lamt", "lamat", "xat", "g_hi", "gt_hi", "xs",
                                       "lams", "lamas", "sg", "act", "slots"])
LocateWork.__doc__ = """Scratch of the instant search; on return ``xs, lams, lamas`` hold the
state and multipliers at the located instant."""


Ledger = namedtuple("Ledger", ["ivars", "fvars", "fail", "lim"])
Ledger.__doc__ = """What every step reads its options from and counts into: ``ivars`` (int64,
``IV_*``) and ``fvars`` (float64, ``FV_*``: θ is ``fvars[FV_THETA]``, h ``fvars[FV_H]`` in s) of
:class:`State`; ``fail (W,)`` int64, the pairs of a failed step (a bitset); ``lim``, the
:class:`Limits`. The same arrays for a whole call of the kernel."""

Actives = namedtuple("Actives", ["act", "slots"])
Actives.__doc__ = """The active sets a step starts from, updated to those it ends with:
``act (2, W)`` int64, bitsets of the pairs with basic λ, row 0 for mode ``j``, row 1 for mode
``ja`` (the other mode of a sliding switch); ``slots (2,)`` int64, the cache slots of those
sets in the :class:`ModeStack`'s ``sets`` (-1: not looked up)."""

Step = namedtuple("Step", ["ta", "s", "regular", "commit"])
Step.__doc__ = """One θ step: the interval ``[ta, ta + s]`` (start ``ta`` and length ``s``, in
s); ``regular`` (bool): the length h from a grid point, taken with the stored discretisation
and the grid's inputs ``U0[kk]``, ``U1[kk]`` (else discretised for ``s`` with the inputs
``u0``, ``u1`` of :class:`Inputs`); ``commit`` (bool): a step that is kept, whose pivoting
solution is checked for a unique next state (False for the trial steps of the instant
search)."""

Inputs = namedtuple("Inputs", ["u0", "u1", "U0", "U1", "kk", "tau"])
Inputs.__doc__ = """The inputs of a step inside grid step ``kk`` of a :class:`Chunk`: ``u0 (p,)``
at its start, which lies at the fraction ``tau`` (0 to 1) of the grid step, and ``u1 (p,)`` at
its end; the chunk's ``U0, U1 (N, p)``, of which a regular step reads ``U0[kk]``, ``U1[kk]``
(the same values as ``u0``, ``u1``). Input units. (``U0``, ``U1`` rather than the whole chunk:
its other arrays would be kept live, in registers or on the stack, through the loops that
call a step.)"""

Modes = namedtuple("Modes", ["j", "ja", "sw", "on", "vt"])
Modes.__doc__ = """The modes a step is taken in: ``j``, the current mode (an index into the
:class:`ModeStack`); while switch ``sw`` slides (``sw >= 0``; -1: none), ``ja``, the mode with
``sw`` toggled (-1 when none), ``on`` (bool) whether ``sw`` is on in mode ``j``, and ``vt`` its
comparator threshold (control units; 0 when none)."""

Ends = namedtuple("Ends", ["x", "lam", "xn", "lamn", "xa", "lama", "sg"])
Ends.__doc__ = """The states at the ends of a step: at its start ``x (n,)`` and the
multipliers ``lam (m,)`` of the step before; at its end, in mode ``j``, ``xn (n,)`` (the
Filippov combination of both modes while a switch slides) and ``lamn (m,)``, in the toggled
mode ``ja`` ``xa (n,)`` and ``lama (m,)``; ``sg (3,)``, the relay values ``[σ_j, σ_ja, tol]``
(:func:`~lcs.integrators.moreau.dense.sliding.relay_combine`). States in state units,
multipliers in pair units."""

Blend = namedtuple("Blend", ["j", "ja", "sw", "d"])
Blend.__doc__ = """The mode a value (a control, a probe) is taken in: mode ``j`` (an index into the
:class:`ModeStack`), or while switch ``sw`` slides (``sw >= 0``; -1: none) with ``d != 0``, the
Filippov combination ``(1 - d) v_j + d v_ja`` with its value in mode ``ja``, the mode with
``sw`` toggled; ``d`` is the fraction of the step in mode ``ja`` (0 to 1). Scalars only: built
where it is passed, it costs nothing."""

Crossings = namedtuple("Crossings", ["sws", "key", "c", "cs", "g", "gt"])
Crossings.__doc__ = """The comparators and their last evaluation
(:func:`~lcs.integrators.moreau.dense.comparators.crossing`): ``sws``, the
:class:`SwitchArrays`; ``key (Wk,)`` int64, the switch key (a bitset: bit i, switch i on); per
switch ``(k,)``: the control ``c`` and its round-off scale ``cs`` (control units), the
crossing function ``g`` (positive: crossed; ``-inf``: not a located comparator) and its
round-off tolerance ``gt``."""
