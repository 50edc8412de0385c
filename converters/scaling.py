"""Large converters for scaling studies: netlists whose number of diodes, switches and states
grows with one parameter (``benchmarks/bench_scale.py``).

Every factory returns ngspice-ready netlist text with near-ideal models (``D(IS=1e-12
N=0.05 RS=1m)``, ``SW(RON=1m ROFF=1e9)``), as the bundled converters use, so that the same text
runs in pelcs and ngspice.

* :func:`cockcroft_walton` -- an N-stage half-wave voltage multiplier: 2N capacitors, 2N diodes,
  no switch; output about 2 N Vpk under light load.
* :func:`interleaved_buck` -- P buck phases in parallel on one output capacitor, gates shifted
  by T/P: P switches, P diodes, P + 1 states.
* :func:`rectifier_6pulse`, :func:`rectifier_12pulse` -- three-phase diode bridges (6 and 12
  diodes) on an LC output filter.
* :func:`mmc_arm` -- a modular multilevel converter arm of N half-bridge cells (two switches,
  two antiparallel diodes and a capacitor each) in series with an arm inductor, driven by
  phase-shifted carriers: 2N switches, 2N diodes, N + 1 states.
"""

from __future__ import annotations

_MODELS = """.model DIDEAL D(IS=1e-12 N=0.05 RS=1m)
.model SWIDEAL SW(VT=0.5 VH=0 RON=1m ROFF=1e9)"""


def _check(name: str, value: int, lo: int, hi: int) -> None:
    if not (isinstance(value, int) and lo <= value <= hi):
        raise ValueError(f"{name} must be an integer in [{lo}, {hi}], got {value!r}")


def cockcroft_walton(stages: int = 5, vpk: float = 100.0, f: float = 10e3, c: float = 1e-6,
                     rload: float = 1e6, periods: int = 50, steps_per_period: int = 200) -> str:
    """Half-wave Cockcroft–Walton multiplier of ``stages`` stages.

    Nodes ``a1..aN`` (the pumping column, coupled to the source through ``C1, C3, ...``) and
    ``b1..bN`` (the smoothing column ``C2, C4, ...`` from ground); diodes ``0 -> a1 -> b1 ->
    a2 -> b2 -> ...``; the load ``rload`` on ``bN``.
    """
    _check("stages", stages, 1, 500)
    T = 1.0 / f
    lines = [f"Cockcroft-Walton multiplier, {stages} stages ({2 * stages} diodes)",
             f"Vs s 0 SIN(0 {vpk:g} {f:g})"]
    prev_a, prev_b = "s", "0"
    prev_node = "0"
    for i in range(1, stages + 1):
        a, b = f"a{i}", f"b{i}"
        lines.append(f"C{2 * i - 1} {prev_a} {a} {c:g} IC=0")
        lines.append(f"C{2 * i} {prev_b} {b} {c:g} IC=0")
        lines.append(f"D{2 * i - 1} {prev_node} {a} DIDEAL")
        lines.append(f"D{2 * i} {a} {b} DIDEAL")
        prev_a, prev_b, prev_node = a, b, b
    lines.append(f"R1 b{stages} 0 {rload:g}")
    lines.append(_MODELS)
    h = T / steps_per_period
    lines.append(f".tran {h:g} {periods * T:g} 0 {h:g} UIC")
    lines.append(".end")
    return "\n".join(lines) + "\n"


def interleaved_buck(phases: int = 2, vin: float = 24.0, duty: float = 0.4, fs: float = 50e3,
                     lind: float = 100e-6, cout: float = 100e-6, rload: float = 1.0,
                     periods: int = 100, steps_per_period: int = 100) -> str:
    """``phases`` buck phases (switch, freewheeling diode, inductor) on one output, gates
    shifted by T/phases."""
    _check("phases", phases, 1, 256)
    T = 1.0 / fs
    lines = [f"Interleaved buck, {phases} phases", f"Vin in 0 DC {vin:g}"]
    for k in range(1, phases + 1):
        delay = (k - 1) * T / phases
        lines.append(f"S{k} in sw{k} g{k} 0 SWIDEAL")
        lines.append(f"D{k} 0 sw{k} DIDEAL")
        lines.append(f"L{k} sw{k} out {lind:g}")
        lines.append(f"Vg{k} g{k} 0 PULSE(0 1 {delay:g} 10n 10n {duty * T - 10e-9:g} {T:g})")
    lines.append(f"C1 out 0 {cout:g} IC=0")
    lines.append(f"R1 out 0 {rload:g}")
    lines.append(_MODELS)
    h = T / steps_per_period
    lines.append(f".tran {h:g} {periods * T:g} 0 {h:g} UIC")
    lines.append(".end")
    return "\n".join(lines) + "\n"


def _three_phase(lines: list[str], prefix: str, vpk: float, f: float, shift_deg: float) -> None:
    for k, ph in enumerate(("a", "b", "c")):
        phase = shift_deg - 120.0 * k
        lines.append(f"V{prefix}{ph} {prefix}{ph} {prefix}n SIN(0 {vpk:g} {f:g} 0 0 {phase:g})")


def rectifier_6pulse(vpk: float = 325.0, f: float = 50.0, lout: float = 5e-3,
                     cout: float = 1e-3, rload: float = 20.0, periods: int = 10,
                     steps_per_period: int = 2000) -> str:
    """Three-phase six-pulse diode bridge (6 diodes) on an LC filter and a resistive load."""
    lines = ["Three-phase 6-pulse rectifier"]
    _three_phase(lines, "u", vpk, f, 90.0)
    lines.append("Rn un 0 1e6")
    for k, ph in enumerate(("a", "b", "c")):
        lines.append(f"D{k + 1} u{ph} p DIDEAL")
        lines.append(f"D{k + 4} n u{ph} DIDEAL")
    lines += [f"L1 p q {lout:g}", f"C1 q n {cout:g} IC=0", f"R1 q n {rload:g}", _MODELS]
    T = 1.0 / f
    h = T / steps_per_period
    lines += [f".tran {h:g} {periods * T:g} 0 {h:g} UIC", ".end"]
    return "\n".join(lines) + "\n"


def rectifier_12pulse(vpk: float = 325.0, f: float = 50.0, lout: float = 5e-3,
                      cout: float = 1e-3, rload: float = 20.0, periods: int = 10,
                      steps_per_period: int = 2000) -> str:
    """Two six-pulse bridges in series fed by isolated three-phase sources 30° apart (12
    diodes): bridge u between ``p`` and ``m``, bridge v between ``m`` and ground; each source
    star point tied to its bridge's lower rail by 1 kΩ (a grounding resistor, which fixes
    the winding's common-mode voltage)."""
    lines = ["Three-phase 12-pulse rectifier"]
    _three_phase(lines, "u", vpk, f, 90.0)
    _three_phase(lines, "v", vpk, f, 60.0)
    lines += ["Rnu un m 1e3", "Rnv vn 0 1e3"]
    for k, ph in enumerate(("a", "b", "c")):
        lines.append(f"D{k + 1} u{ph} p DIDEAL")
        lines.append(f"D{k + 4} m u{ph} DIDEAL")
        lines.append(f"D{k + 7} v{ph} m DIDEAL")
        lines.append(f"D{k + 10} 0 v{ph} DIDEAL")
    lines += [f"L1 p q {lout:g}", f"C1 q 0 {cout:g} IC=0", f"R1 q 0 {rload:g}", _MODELS]
    T = 1.0 / f
    h = T / steps_per_period
    lines += [f".tran {h:g} {periods * T:g} 0 {h:g} UIC", ".end"]
    return "\n".join(lines) + "\n"


def mmc_arm(cells: int = 4, vdc: float = 400.0, fs: float = 1e3, f: float = 50.0,
            ccell: float = 2e-3, larm: float = 5e-3, rload: float = 10.0, periods: int = 2,
            steps_per_period: int = 4000) -> str:
    """An MMC arm: ``cells`` half-bridge cells in series with ``larm`` and a load, fed by a DC
    source. Cell k (terminals ``x{k-1}``, ``x{k}``; capacitor from ``c{k}`` to ``x{k}``)
    inserts its capacitor while its upper switch ``Su{k}`` is on and is bypassed by the lower
    switch ``Sl{k}`` otherwise; the antiparallel diodes ``Du{k}`` (terminal to capacitor) and
    ``Dl{k}`` (capacitor minus to terminal) carry the arm current the other way. Gates: 50 %
    duty at ``fs``, cell k shifted by (k-1)/cells of the period (phase-shifted PWM), the lower
    switch complementary."""
    _check("cells", cells, 1, 256)
    T = 1.0 / fs
    vcell = vdc / cells
    lines = [f"MMC arm, {cells} half-bridge cells", f"Vdc top 0 DC {vdc:g}"]
    node = "top"
    for k in range(1, cells + 1):
        out = f"x{k}"
        delay = (k - 1) * T / cells
        # cell: Su from node to cap+, Sl from node to out (bypass); capacitor from cap+ to out;
        # antiparallel diodes across each switch.
        lines.append(f"Su{k} {node} c{k} gu{k} 0 SWIDEAL")
        lines.append(f"Du{k} {node} c{k} DIDEAL")
        lines.append(f"Sl{k} {node} {out} gl{k} 0 SWIDEAL")
        lines.append(f"Dl{k} {out} {node} DIDEAL")
        lines.append(f"C{k} c{k} {out} {ccell:g} IC={vcell:g}")
        lines.append(f"Vgu{k} gu{k} 0 PULSE(0 1 {delay:g} 10n 10n {0.5 * T - 10e-9:g} {T:g})")
        lines.append(f"Vgl{k} gl{k} 0 PULSE(1 0 {delay:g} 10n 10n {0.5 * T - 10e-9:g} {T:g})")
        node = out
    lines += [f"L1 {node} ld {larm:g}", f"R1 ld 0 {rload:g}", _MODELS]
    h = T / steps_per_period * 10
    lines += [f".tran {h:g} {periods / f:g} 0 {h:g} UIC", ".end"]
    return "\n".join(lines) + "\n"
