"""A source-driven switch whose control jumps over its threshold at a source breakpoint and
comes back within the same segment, in a circuit whose switch controls depend on the switch
states (the planner's general path, :func:`lcs.simulation.source_switching.source_switch_events`):
refused with a clear error rather than planned wrong (the general path would miss the
switching)."""

from __future__ import annotations

import contextlib
import io

from pelcs.cli import main

# The MOSFET's gate is the sawtooth through S2 (else held at 0 by Rg): its control rows depend
# on S2's state. The sawtooth (TR + TF > PER: cut at each period, ngspice's rule) jumps from
# about 5 V to 0 at every period start, over VTO = 2 V, and rises back through it.
DECK = """a sawtooth gate that jumps over the MOSFET's threshold, through a switch
Vin in 0 DC 12
Vp p 0 PULSE(0 5 0 9.99u 10n 0 10u)
Ven en 0 PULSE(0 1 0 1n 1n 50u 100u)
S2 p gate en 0 SWM
.model SWM SW(VT=0.5 VH=0)
Rg gate 0 1k
M1 sw gate 0 0 NM
.model NM NMOS(VTO=2 KP=20)
L1 in sw 100u
D1 sw out DM
.model DM D
C1 out 0 47u
R1 out 0 20
.tran 0.1u 200u 0 0.1u uic
.end
"""


def test_a_jump_over_the_threshold_on_the_general_path_is_refused(tmp_path):
    path = tmp_path / "jump.cir"
    path.write_text(DECK)
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
        code = main(["simulate", str(path), "--no-progress"])
    out = buf.getvalue()
    assert code == 2, out
    assert ("not supported: switch M1: its control jumps over its threshold at t = 1e-05 s"
            in out)
    assert "Traceback" not in out
