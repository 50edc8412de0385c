"""Run a netlist in ngspice (through PySpice's shared-library interface) and read probes back.

Entry point: :func:`run_ngspice`. It returns an :class:`NgspiceResult` (time, signals by
pelcs probe name, the settings that worked, timings and ngspice's log) or raises an
:class:`NgspiceError` subclass: :class:`NgspiceUnavailable` (PySpice or libngspice missing),
:class:`ProbeError` (a probe names nothing in the circuit), :class:`NgspiceFailed` (every rung
of the ladder failed; ``.attempts`` says why each one did).

One process per simulation
--------------------------
Every simulation runs in a fresh child process (``_worker.py``), measured and decided on
ngspice 39 / PySpice 1.5:

- libngspice keeps state between circuits: after one deck with ``.options cshunt=1e-12``,
  the *unmodified* bridge rectifier that failed before suddenly converges in the same
  process. Ladder rungs would contaminate each other (and the user's later runs);
- a failed run can leave the library in a state only a reload fixes, and a crash (or a
  ``controlled_exit``) of libngspice would take the caller's interpreter with it;
- a child can be killed, so runs get a real ``timeout``;
- whatever PySpice and libngspice print (PySpice warns "Unsupported Ngspice version 39")
  goes into the child's captured output, never to the user's terminal.

The cost is one interpreter start with PySpice imported, about 0.15 s warm; it is hidden by
keeping one spare worker started in advance (started when the previous one is taken), so a
sequence of runs pays it only once.

Probes
------
Probes use pelcs' syntax. ``v(n)`` and ``v(a,b)`` read node vectors (``v(0)`` is 0);
``i(X)`` for V, L, E and H elements reads ngspice's branch current ``x#branch`` (hierarchical
``X1.L1`` becomes ``l.x1.l1#branch``). The current of any other two-terminal element
(R C D S I F G) is measured by a **0 V sense source inserted in series** at its second node,
chosen over ngspice's ``@d1[id]``-style device vectors because it works the same for every
element type, gives exactly pelcs' sign (from the first node through the element to the
second), needs no ``.save`` lines (which would suppress all other vectors) and is read at
the same time points as everything else, and it reports the KCL current, which ngspice's
device vectors do not when ngspice accepts a non-converged point (see the audit below).
Only top-level elements can be sensed (``X1.D1`` works on a flattened ``Circuit``, whose
writer names it ``D.X1.D1``).

The ladder
----------
ngspice's Newton iterations and time-step control were made for smooth devices; near-ideal
diodes and switches give it "timestep too small" on many converters, or worse, a run that
completes with wrong numbers (see *The diode audit* below). :func:`run_ngspice` tries the
rungs of :data:`DEFAULT_LADDER` in order until one succeeds and reports the rung
(``NgspiceResult.rung``, ``.settings_used``, and every failed try in ``.attempts``). Rung 0
is the netlist as written; every later rung keeps everything of the rung before it and adds
the next remedy.

The order comes from ``python -m ngspice_checks.ladder_survey`` (ngspice 39, 6-8 minutes on
2 cores): the 9 bundled netlists plus an LC tank discharging through a diode bridge and a
ramp-comparator buck with a PW=0 sawtooth, each in 5 variants (as written; N=0.001 diodes;
the same with RON=1u/ROFF=1e12 switches; N=0.01 diodes with RON=10m/ROFF=1e6 switches; 1 ps
gate edges) and with/without a probe on i(D1): 110 runs, 60 of them failing as written. Each
remedy was tried *alone* on the failures, then the whole ladder ("art" = the diode audit
failed):

=====================  =====  =====  ======  =====  ===========  ======  ==========  ======
failing family         cases  edges  shunts  Gear   Gear+shunts  models  tolerances  ladder
=====================  =====  =====  ======  =====  ===========  ======  ==========  ======
boost (art)            6      art    yes     art    yes          art     art         3
boost, 1 ps edges      2      art    art     art    art          art     art         3
DCM boost (art)        2      art    art     yes    yes          art     art         2
DCM boost, other D/S   6      art    yes     yes    yes          art     art         2
DCM boost, 1 ps edges  2      art    art     yes    art          art     art         2
buck-boost (art)       4      art    yes     art    yes          yes     art         3
bridge rectifier       10     no     yes     no     yes          no      yes         3
LC tank + bridge       10     no     yes     no     yes          no      yes         3
PRC, steep diodes      6      no     yes     no     yes          yes     no          3
Cuk, 1 ps edges        2      yes    yes     no     yes          no      no          1
PW=0 sawtooth buck     10     yes    no      no     no           no      no          1
=====================  =====  =====  ======  =====  ===========  ======  ==========  ======

All 60 succeed through the ladder: 12 at rung 1, 10 at rung 2, 38 at rung 3; rungs 4 and 5
were never reached. (The sliding-mode boost, which takes 8-10 s on the loaded machine, was
once halted by the watchdog under a 20 s budget; the verdict now has to persist, see below.)

0. ``as-written``: the netlist unchanged (except ``tstop``/``tstep`` overrides and sense
   sources, see *Probes* and *The diode audit*).
(``initial-state``, between rungs 0 and 1, only when the caller gives
   ``initial_voltages``, as ``pelcs check`` does with pelcs' node voltages at t = 0+ after
   its initial jump: ``.ic`` for every node, and for the sense sources' nodes. With UIC,
   ngspice otherwise starts every node without an IC at 0 V; when the diodes must conduct
   at once (the Siconos DiodeBridge: an LC tank charged to 10 V on a bridge and a 1 kOhm
   load) its first step fails on every other rung with "Timestep too small; time = 1e-17".
   The classic rungs after it run without the .ic (kept in them, it made the boost's diode
   audit fail on every rung), and a last rung ``smooth-models+initial-state`` combines
   everything. A capacitor-input bridge switched on while charging is not rescued by it
   (the ideal voltages leave the steep diodes' drops out: "trouble with node n"); the
   shunts are.)
1. ``finite-edges``: every PULSE gets a pulse width and nonzero rise/fall times of at least
   1 ns (TR/TF written as 0 already mean TSTEP in ngspice and are left alone); TR is
   shortened when the pulse would no longer fit in its period. A sawtooth written with
   PW=0 fails at a ramp reset whatever else is done. Changes a waveform by at most 1 ns per
   corner: the least invasive remedy, so first.
2. ``gear``: + ``method=gear`` (BDF2). Changes the numerics only, not the circuit. The
   trapezoidal rule lets the DCM boost's diode conduct in reverse around its turn-off
   (kiloampere spikes during a CCM start-up, about -1 A in steady DCM); Gear removes it
   (alone in 10 of 10 DCM cases), with the trapezoidal rule's steady state (24.947 V vs
   24.950 V; backward Euler, ``maxord=1``, also removes it but is 1.2 % off at TMAX = 0.2
   us: not used). Tried before the shunts because it leaves the circuit alone, and because
   the shunts are slow on the DCM boost (1 pF rings with L1 at 35 MHz while both
   semiconductors are off: 4.5 s instead of 0.3 s, and still an artefact without Gear).
3. ``shunts``: + ``.options cshunt=1e-12 rshunt=1e12``: 1 pF and 1 TOhm from every node to
   ground. Nodes that float while every diode around them is off (a bridge rectifier's
   output between conduction intervals, the LC tank's bridge) make the matrix singular or
   ill-conditioned ("timestep too small ... trouble with node p"); a switch node without
   any capacitance jumps in zero time and gives the boost's reverse-diode artefact. The
   remedy with the widest reach (44 of the 60 alone). cshunt is what matters (rshunt alone
   rescues nothing); rshunt keeps the level of floating nodes defined. 1 pF is negligible
   against the nF-to-mF capacitors of power converters, 1 TOhm against any load.
4. ``relaxed``: + ``reltol=1e-2 abstol=1e-9 vntol=1e-4 chgtol=1e-14 itl4=100
   gmin=1e-10``. Alone it rescues the floating-node families (only as a set: gmin, reltol
   or itl4 alone do not), which rung 3 already does; kept as a fallback, late because it
   costs accuracy (1 % instead of 0.1 % local error).
5. ``smooth-models``: + every D model replaced by ``D(IS=1e-12 N=0.05 RS=1m)``, every SW
   model given ``RON=1m ROFF=1e9`` and a hysteresis of at least ``VH=1m`` (VT kept). The
   textbook remedies for steep diodes (N=0.001: a 26 uV exponential scale) and for switches
   toggling at every Newton iteration when their control sits at VT. In the survey they
   rescued only cases that shunts rescue too; last resort. pelcs treats D and S as ideal
   whatever the models say: only ngspice's approximation of the ideal elements changes
   (the forward drop becomes 36 mV at 1 A).

A rung is abandoned early when ngspice grinds: the worker watches ngspice's progress
reports and halts a run that, for ``min(5 s, timeout/4)`` in a row, looks unable to finish
within ``timeout`` at its recent pace (and within ``timeout/4`` at its average pace):
"stalled" (e.g. the bridge rectifier with a sense source on D1 only advanced 2e-8 s per
second at rungs 0 and 1; it would have ground for hours). A netlist ngspice rejects (syntax,
unknown model) stops the ladder at once: no rung repairs it.

The diode audit
---------------
ngspice 39 *accepts non-converged time points* when a switch closes onto a conducting
near-ideal diode (boost, DCM boost, buck-boost with steep diodes): for a few ns, as long as
the gate voltage ramps, the diode conducts kiloamperes in reverse through the closing
switch and drains the output capacitor (0.7 V of 24 V at the boost's first switching, 1 mC
in the DCM boost's start-up), and the run "succeeds". The device's own ``@d1[id]`` does not
show it (the accepted point violates the diode equation); the branch current of a 0 V
source in series, which obeys KCL, does. So by default (``audit_diodes=True``) every
top-level diode with a static model (no TT, no CJO) gets a sense source, and a rung fails
when a diode conducts in reverse more than ``REVERSE_CHARGE_LIMIT`` (1e-3) of its forward
charge or a reverse peak above its forward peak; a reverse current below
``LEAKAGE_CURRENT`` (1 uA) throughout is leakage (GMIN across the junction of a diode that
never conducts) and passes. Not audited: diodes inside subcircuits
(pass a flattened ``Circuit``), switches (a shoot-through through two switches would go
unnoticed), and artefacts that keep KCL.

Design note
-----------
The deck edits are text edits (:mod:`ngspice_checks.deck`), written when the parser did not
exist. Each rung is data (:class:`NgspiceSettings`) applied by :func:`apply_settings`, so the
same settings can later be applied to a ``Circuit`` before ``netlist.writer.write_circuit``;
:func:`run_ngspice` already accepts a ``Circuit`` (written, flattened, then edited as text).
"""

from __future__ import annotations

import math
import os
import re
import threading
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from netlist.probes import PROBE
from netlist.units import parse_number

from . import deck
from .audit import _audit_diodes, _audited_diodes
from .ladder import DEFAULT_LADDER, NgspiceSettings, SwitchModel, apply_settings, ladder_for
from .workers import _POOL, _WorkerDied

__all__ = [
    "DEFAULT_LADDER",
    "NgspiceAttempt",
    "NgspiceError",
    "NgspiceFailed",
    "NgspiceResult",
    "NgspiceSettings",
    "NgspiceUnavailable",
    "ProbeError",
    "SwitchModel",
    "apply_settings",
    "ngspice_version",
    "run_ngspice",
]




# ------------------------------------------------------------------------------------------
# errors


class NgspiceError(RuntimeError):
    """Base of the runner's errors."""


class NgspiceUnavailable(NgspiceError):
    """PySpice or the ngspice shared library cannot be used here."""


class ProbeError(NgspiceError, ValueError):
    """A probe is malformed or names no node/element of the circuit."""


class NgspiceFailed(NgspiceError):
    """Every rung of the ladder failed; ``attempts`` lists each try and its reason."""

    def __init__(self, message: str, attempts: list[NgspiceAttempt]) -> None:
        super().__init__(message)
        self.attempts = attempts


# ------------------------------------------------------------------------------------------
# settings and the ladder: :mod:`.ladder`


# ------------------------------------------------------------------------------------------
# results


@dataclass
class NgspiceAttempt:
    """One try of one rung.

    Attributes
    ----------
    rung : int
        Position in the ladder that was tried.
    settings : NgspiceSettings
    reason : str or None
        Why it failed; None if it succeeded.
    wall_time : float
        Time spent in ngspice (load + run) in the worker (s); NaN if the worker died.
    log : list of str
        ngspice's output lines (``stdout ...``/``stderr ...``) and captured stray output.
    netlist : str
        The deck that was simulated.
    """

    rung: int
    settings: NgspiceSettings
    reason: str | None
    wall_time: float
    log: list[str]
    netlist: str

    @property
    def ok(self) -> bool:
        return self.reason is None


@dataclass
class NgspiceResult:
    """Outcome of :func:`run_ngspice`.

    Attributes
    ----------
    time : ndarray
        ngspice's time points (s), not equidistant.
    signals : dict
        Probe (as given) -> samples at ``time`` (V or A).
    settings_used : NgspiceSettings
        The rung that succeeded.
    rung : int
        Its position in the ladder (0 = the netlist as written).
    wall_time : float
        ngspice load + run time of the successful rung (s).
    log : list of str
        ngspice's output for the successful rung.
    attempts : list of NgspiceAttempt
        Every rung tried, failures first.
    netlist : str
        The deck ngspice simulated in the successful rung.
    total_time : float
        Wall time of the whole call including failed rungs and process start-up (s).
    """

    time: np.ndarray
    signals: dict[str, np.ndarray]
    settings_used: NgspiceSettings
    rung: int
    wall_time: float
    log: list[str]
    attempts: list[NgspiceAttempt]
    netlist: str
    total_time: float

    def __getitem__(self, probe: str) -> np.ndarray:
        return self.signals[probe]


# ------------------------------------------------------------------------------------------
# probes

_GROUND = {"0", "gnd"}
_BRANCH_KINDS = "vleh"  # elements for which ngspice has a <name>#branch vector
_SENSE_KINDS = "rcdsifg"  # two-terminal currents measured with an inserted 0 V source


@dataclass
class _Probe:
    text: str
    kind: str  # "v" or "i"
    args: tuple[str, ...]  # v: nodes (lower case); i: element name as written


@dataclass
class _ProbePlan:
    probes: list[_Probe]
    sensed: list[str]  # elements that get a sense source
    vectors: list[str] | None  # ngspice vectors to fetch; None = all
    currents: dict[str, str] = field(default_factory=dict)  # i() element (lower) -> vector


def _parse_probe(text: str) -> _Probe:
    m = PROBE.match(text)
    if m is None:
        raise ProbeError(
            f"malformed probe {text!r}: expected v(node), v(node1,node2) or i(element)"
        )
    kind = m.group(1).lower()
    args = tuple(a for a in (m.group(2), m.group(3)) if a is not None)
    if kind == "i":
        if len(args) != 1:
            raise ProbeError(f"malformed probe {text!r}: i() takes one element name")
        return _Probe(text, kind, args)
    return _Probe(text, kind, tuple(a.lower() for a in args))


def _plan_probes(
    text: str, probes: Sequence[str] | None, audited: Sequence[str] = ()
) -> _ProbePlan:
    """Parse the probes, decide which elements need a sense source and which vectors to read.

    ``audited`` elements (the diodes checked for reverse conduction) are sensed as well.
    """
    if probes is None:
        return _ProbePlan([], list(audited), None)
    if isinstance(probes, str):
        probes = [probes]
    elements = {el.name.lower(): el for el in deck.top_level_elements(text)}
    parsed = [_parse_probe(p) for p in probes]
    sensed: list[str] = list(audited)
    currents: dict[str, str] = {}
    vectors: set[str] = {"time"} | {deck.sense_names(d)[0] + "#branch" for d in audited}
    for p in parsed:
        if p.kind == "v":
            vectors.update(n for n in p.args if n not in _GROUND)
            continue
        name = p.args[0]
        parts = name.lower().split(".")
        letter = parts[-1][:1]
        flat = f"{letter}.{name.lower()}"
        if len(parts) > 1 and flat in elements:
            # a flattened deck (netlist.writer) names X1.D1 "D.X1.D1" at top level
            parts = [flat]
        if len(parts) == 1 and parts[0] not in elements:
            known = ", ".join(el.name for el in elements.values())
            raise ProbeError(f"probe {p.text!r}: no element {name!r} in the netlist ({known})")
        if letter in _BRANCH_KINDS:
            # ngspice: top level "l1#branch"; inside instance x1 "l.x1.l1#branch"
            vec = f"{parts[0]}#branch" if len(parts) == 1 else f"{letter}.{'.'.join(parts)}#branch"
        elif letter in _SENSE_KINDS:
            if len(parts) > 1:
                raise ProbeError(
                    f"probe {p.text!r}: currents of {letter.upper()} elements inside "
                    "subcircuits are not supported yet (only V, L, E, H there)"
                )
            element = elements[parts[0]].name
            if element.lower() not in (s.lower() for s in sensed):
                sensed.append(element)
            vec = deck.sense_names(element)[0] + "#branch"
        else:
            raise ProbeError(f"probe {p.text!r}: {name!r} has no single branch current")
        currents[name.lower()] = vec
        vectors.add(vec)
    return _ProbePlan(parsed, sensed, sorted(vectors), currents)


def _evaluate_probes(
    plan: _ProbePlan, vectors: dict[str, np.ndarray], names: list[str], elements: list[str]
) -> dict[str, np.ndarray]:
    """Probe -> samples; with no probes, every node voltage and branch current."""
    time_ = vectors["time"]
    if plan.vectors is None:
        return _all_signals(vectors, elements)

    def vec(name: str, probe: str) -> np.ndarray:
        if name in _GROUND:
            return np.zeros_like(time_)
        if name not in vectors:
            nodes = [n for n in names if "#" not in n and n != "time" and "pelcs_" not in n]
            raise ProbeError(
                f"probe {probe!r}: ngspice has no vector {name!r}; nodes: {', '.join(nodes)}"
            )
        return np.real(vectors[name])

    out = {}
    for p in plan.probes:
        if p.kind == "v":
            v = vec(p.args[0], p.text)
            out[p.text] = v - vec(p.args[1], p.text) if len(p.args) == 2 else v.copy()
        else:
            out[p.text] = vec(plan.currents[p.args[0].lower()], p.text).copy()
    return out


def _all_signals(vectors: dict[str, np.ndarray], elements: list[str]) -> dict[str, np.ndarray]:
    spelled = {e.lower(): e for e in elements}
    out = {}
    for name, values in vectors.items():
        if name == "time" or "pelcs_" in name:
            continue
        if name.endswith("#branch"):
            el = name[: -len("#branch")]
            if re.match(r"^[a-z]\.", el):  # l.x1.l1 -> x1.l1
                el = el[2:]
            out[f"i({spelled.get(el, el)})"] = np.real(values)
        else:
            out[f"v({name})"] = np.real(values)
    return out


# ------------------------------------------------------------------------------------------
# worker processes: :mod:`.workers`

_INSTALL_HINT = (
    "install ngspice's shared library (Debian/Ubuntu: apt install libngspice0-dev; "
    "conda: conda install -c conda-forge ngspice-lib) and PySpice (pip install PySpice), "
    "or point NGSPICE_LIBRARY_PATH at libngspice"
)

_status_lock = threading.Lock()
_status: tuple[bool, str] | None = None  # (available, version or reason)


def _check_available() -> tuple[bool, str]:
    """(True, version) or (False, reason); asked once per process, then cached."""
    global _status
    with _status_lock:
        if _status is not None:
            return _status
        import importlib.util

        if importlib.util.find_spec("PySpice") is None:
            _status = (False, f"PySpice is not installed; {_INSTALL_HINT}")
            return _status
        worker = _POOL.take(prefetch=False)
        try:
            hello = worker.handshake()
        except (TimeoutError, _WorkerDied) as exc:
            worker.kill()
            _status = (False, f"the ngspice worker did not start: {exc}; {_INSTALL_HINT}")
            return _status
        if not hello.get("ok"):
            worker.kill()
            _status = (False, f"cannot load ngspice: {hello.get('error')}; {_INSTALL_HINT}")
            return _status
        _POOL.give_back(worker)
        _status = (True, str(hello.get("version", "?")))
        return _status


def ngspice_version() -> str:
    """The ngspice version PySpice loaded (e.g. ``"39"``); raises NgspiceUnavailable."""
    ok, info = _check_available()
    if not ok:
        raise NgspiceUnavailable(info)
    return info


def _simulate_in_worker(
    netlist: str, vectors: list[str] | None, timeout: float | None, workdir: str | None
) -> dict:
    worker = _POOL.take()
    try:
        hello = worker.handshake()
        if not hello.get("ok"):
            raise NgspiceUnavailable(f"cannot load ngspice: {hello.get('error')}; {_INSTALL_HINT}")
        worker.send(
            {"netlist": netlist, "vectors": vectors, "workdir": workdir, "timeout": timeout}
        )
        # the worker halts a run that cannot finish in time by itself (stall watchdog); the
        # kill here is for a worker that hangs outright
        reply = worker.receive(None if timeout is None else timeout + 30.0)
    except TimeoutError as exc:
        return {"failure": f"timeout: {exc}", "log": []}
    except _WorkerDied as exc:
        return {"failure": f"crash: {exc}", "log": []}
    except KeyboardInterrupt:
        # Ctrl-C (or SIGTERM made one): the run is abandoned, its worker killed rather than
        # waited for (a signal sent to this process alone does not reach it: close() would
        # wait 2 s for it)
        worker.kill()
        raise
    finally:
        worker.close()
    if "error" in reply:
        reply = {"failure": f"worker error: {reply['error']}", "log": reply.get("log", [])}
    # the worker's start-up messages (PySpice's "Unsupported Ngspice version 39" warning,
    # stray output) go to the log too: kept from the user's terminal, not thrown away
    reply["startup_log"] = list(hello.get("log", []))
    return reply


# ------------------------------------------------------------------------------------------
# judging a run

# lines of ngspice output that mean the analysis did not complete
_FATAL = re.compile(
    r"timestep too small|simulation\(s\) aborted|simulation interrupted|"
    r"transient solution failed|no such vector|singular matrix.*aborted|"
    r"there aren't any circuits loaded|fatal",
    re.IGNORECASE,
)


def _tstop_from_listing(listing: list[str]) -> float | None:
    for line in listing:
        body = line.split(":", 1)[-1] if re.match(r"^stdout\s+\d+\s*:", line) else ""
        tokens = deck.split_tokens(body)
        if tokens and tokens[0].lower() == ".tran" and len(tokens) > 2:
            return parse_number(tokens[2])
    return None


def _diagnose(reply: dict) -> str | None:
    """Why the run in ``reply`` failed, or None if it is complete and finite."""
    if "failure" in reply:
        return str(reply["failure"])
    log = reply["log"]
    load_errors = [
        line[len("stderr ") :]
        for line in log[: reply["n_load_lines"]]
        if line.lower().startswith("stderr error")
    ]
    if reply["load_rc"] or load_errors:
        first = load_errors[0] if load_errors else f"ngSpice_Circ returned {reply['load_rc']}"
        return f"netlist rejected by ngspice: {first}"
    # stderr only: the title and the listing, echoed on stdout, may contain any words
    fatal = [line for line in log if line.startswith("stderr") and _FATAL.search(line)]
    if fatal:
        return "ngspice: " + fatal[0].split(" ", 1)[-1].strip()
    if not reply["plot"].startswith("tran"):
        errors = [line for line in log if line.lower().startswith("stderr")]
        detail = errors[0][len("stderr ") :] if errors else "no transient analysis ran"
        return f"no transient result ({detail})"
    if reply["run_rc"]:
        return f"ngspice's run command returned {reply['run_rc']}"
    vectors = reply["vectors"]
    time_ = vectors.get("time")
    if time_ is None or len(time_) < 2:
        return "no time vector in the result"
    tstop = _tstop_from_listing(reply.get("listing", []))
    if tstop is not None and time_[-1] < tstop * (1.0 - 1e-9):
        return f"stopped at t = {time_[-1]:.6g} s before TSTOP = {tstop:.6g} s"
    for name, values in vectors.items():
        if not np.all(np.isfinite(values)):
            return f"vector {name!r} has NaN or inf values"
    return None


# ------------------------------------------------------------------------------------------
# diode audit: :mod:`.audit`


# ------------------------------------------------------------------------------------------
# entry point


def _netlist_text(netlist: Any) -> str:
    if isinstance(netlist, str):
        return netlist
    from netlist.writer import write_circuit  # the Circuit path, once the writer exists

    return write_circuit(netlist)


def run_ngspice(
    netlist_text: str,
    probes: Sequence[str] | None = None,
    *,
    tstop: float | None = None,
    tstep: float | None = None,
    settings: NgspiceSettings | Sequence[NgspiceSettings] | None = None,
    timeout: float | None = 600.0,
    workdir: str | os.PathLike[str] | None = None,
    audit_diodes: bool = True,
    initial_voltages: Mapping[str, float] | None = None,
) -> NgspiceResult:
    """Simulate a netlist's ``.tran`` analysis in ngspice, climbing the ladder on failure.

    Parameters
    ----------
    netlist_text : str or netlist.circuit.Circuit
        ngspice-dialect netlist with a ``.tran`` line (or give ``tstop``). A ``Circuit`` is
        written with ``netlist.writer.write_circuit``.
    probes : sequence of str, optional
        pelcs probes (``v(out)``, ``v(a,b)``, ``i(L1)``, ``i(D1)``). None returns every node
        voltage as ``v(node)`` and every branch current ngspice has as ``i(Name)``.
    tstop, tstep : float, optional
        Override the ``.tran`` stop time and step (s). TSTEP is also ngspice's default for
        PULSE edges written as 0.
    settings : NgspiceSettings or sequence of them, optional
        None tries :data:`DEFAULT_LADDER`; one settings object runs only that (e.g.
        ``previous.settings_used`` to repeat a run); a sequence is a custom ladder.
    timeout : float or None
        Wall-time limit per rung (s); a rung over it is killed and counts as failed.
    workdir : path, optional
        Working directory for ngspice (relative ``.include`` files); default: the current one.
    audit_diodes : bool
        Put a sense source on every top-level diode with a static model and fail a rung in
        which one conducts in reverse (more than ``REVERSE_CHARGE_LIMIT`` of its forward
        charge): ngspice's known shoot-through artefact, see :func:`_audit_diodes`.
    initial_voltages : mapping, optional
        Node name -> voltage (V) of a consistent state at t = 0+ (``pelcs check`` passes
        pelcs' own, after its initial jump). With the default ladder they add the
        ``initial-state`` rung after the netlist as written, kept by every later rung;
        with a custom ladder, rungs with ``initial_voltages=True`` use them.

    Returns
    -------
    NgspiceResult

    Raises
    ------
    NgspiceUnavailable
        PySpice or libngspice cannot be loaded.
    ProbeError
        A probe is malformed or names nothing in the circuit.
    NgspiceFailed
        No rung succeeded; the message summarises each attempt.
    """
    started = time.perf_counter()
    ok, info = _check_available()
    if not ok:
        raise NgspiceUnavailable(info)
    text = deck.set_tran(_netlist_text(netlist_text), tstep, tstop)
    if deck.parse_tran(text) is None:
        raise NgspiceError("the netlist has no usable .tran line; give tstop")
    audited = _audited_diodes(text) if audit_diodes else []
    plan = _plan_probes(text, probes, audited)
    initial = dict(initial_voltages or {})
    for element in plan.sensed:
        if initial:
            # the sense source's new node sits at the element's second node's voltage
            el = next((e for e in deck.top_level_elements(text)
                       if e.name.lower() == element.lower()), None)
            if el is not None and len(el.tokens) > 2:
                n_minus = el.tokens[2].lower()
                v = 0.0 if n_minus in ("0", "gnd") else initial.get(n_minus)
                if v is not None:
                    initial[deck.sense_names(element)[1]] = v
        text = deck.insert_sense_source(text, element)
    elements = [el.name for el in deck.top_level_elements(text)]
    cwd = None if workdir is None else str(Path(workdir).resolve())

    attempts: list[NgspiceAttempt] = []
    for rung, rung_settings in enumerate(ladder_for(settings, bool(initial))):
        candidate = apply_settings(text, rung_settings, initial)
        reply = _simulate_in_worker(candidate, plan.vectors, timeout, cwd)
        reason = _diagnose(reply)
        if reason is None and audited:
            reason = _audit_diodes(reply["vectors"], audited)
        wall = reply.get("load_time", math.nan) + reply.get("run_time", math.nan)
        log = reply.get("startup_log", []) + reply.get("log", [])
        attempt = NgspiceAttempt(rung, rung_settings, reason, wall, log, candidate)
        attempts.append(attempt)
        if reason is not None:
            if reason.startswith("netlist rejected"):
                break  # no rung repairs a syntax error; say so at once
            continue
        signals = _evaluate_probes(plan, reply["vectors"], reply["names"], elements)
        return NgspiceResult(
            time=np.real(reply["vectors"]["time"]).copy(),
            signals=signals,
            settings_used=rung_settings,
            rung=rung,
            wall_time=wall,
            log=attempt.log,
            attempts=attempts,
            netlist=candidate,
            total_time=time.perf_counter() - started,
        )
    summary = "; ".join(f"rung {a.rung} ({a.settings.name}): {a.reason}" for a in attempts)
    raise NgspiceFailed(f"ngspice failed on every rung tried: {summary}", attempts)
