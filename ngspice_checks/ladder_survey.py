"""Survey behind the runner's ladder: which single remedy rescues which failing netlist.

Run ``python -m ngspice_checks.ladder_survey [--quick]``. Every bundled converter netlist
(plus two classic trouble makers, defined below) is varied in the ways that make ngspice
fail (steeper diodes, harder switches, ps edges, a sense source in series with D1); each
variant is run as written and, when that fails, once with each remedy of the ladder applied
*alone*, so that the table shows what each remedy is worth by itself, and then through the
whole default ladder (last column: the rung that succeeded). The ladder order in
:mod:`ngspice_checks.runner` follows from it (least invasive first, and cheap-and-effective
before rare-and-expensive). Takes about 10 minutes; not part of the test suite.
"""

from __future__ import annotations

import argparse
import re
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from . import runner

NETLISTS = Path(__file__).resolve().parent.parent / "converters" / "netlists"

#: an LC tank whose energy drains through a diode bridge into an RC load
LC_TANK_BRIDGE = """LC tank discharging through a diode bridge into an RC load
C1 a b 1u IC=10
L1 a b 100u IC=1
D1 a p DI
D2 b p DI
D3 0 a DI
D4 0 b DI
C2 p 0 10u
R1 p 0 100
.model DI D(IS=1e-14 N=0.001)
.tran 0.1u 2m 0 UIC
.end
"""

#: a ramp-comparator buck whose sawtooth has PW=0 and a 1 ps reset
SAWTOOTH_BUCK = """Closed-loop buck, ramp comparator with a PW=0 sawtooth
.param vin=15 tp=400u
Vin in 0 {vin}
S1 in sw ramp con SWI
D1 0 sw DI
L1 sw out 20m
C1 out 0 47u
R1 out 0 22
Vref ref 0 11.3
Econ con 0 out ref 8.4
Vramp ramp 0 PULSE(3.8 8.2 0 {tp-1p} 1p 0 {tp})
.model SWI SW(VT=0 VH=0 RON=1m ROFF=1e9)
.model DI D(IS=1e-14 N=0.001)
.tran 1u 20m 0 UIC
.end
"""

_REMEDIES: dict[str, runner.NgspiceSettings] = {
    "edges": runner.NgspiceSettings("edges", pulse_min_edge=1e-9),
    "shunts": runner.NgspiceSettings("shunts", options={"cshunt": "1e-12", "rshunt": "1e12"}),
    "cshunt": runner.NgspiceSettings("cshunt", options={"cshunt": "1e-12"}),
    "gear": runner.NgspiceSettings("gear", options={"method": "gear"}),
    "gear+shunts": runner.NgspiceSettings(
        "gear+shunts", options={"method": "gear", "cshunt": "1e-12", "rshunt": "1e12"}
    ),
    "models": runner.NgspiceSettings(
        "models",
        diode_model={"is": "1e-12", "n": "0.05", "rs": "1e-3"},
        switch_model=runner.SwitchModel(),
    ),
    "tolerances": runner.NgspiceSettings(
        "tolerances",
        options={
            "reltol": "1e-2",
            "abstol": "1e-9",
            "vntol": "1e-4",
            "chgtol": "1e-14",
            "itl4": "100",
            "gmin": "1e-10",
        },
    ),
}


def _variants(text: str) -> dict[str, str]:
    """The netlist as written and harder variants of it."""

    def diodes(params: str) -> str:
        return re.sub(r"(?im)^(\.model\s+\S+\s+)D\s*\(.*\)\s*$", rf"\1D({params})", text)

    def switches(t: str, ron: str, roff: str) -> str:
        def fix(m: re.Match[str]) -> str:
            body = re.sub(r"(?i)\s*\b(ron|roff)\s*=\s*\S+?(?=[\s)])", "", m.group(2))
            return f"{m.group(1)}SW({body} RON={ron} ROFF={roff})"

        return re.sub(r"(?im)^(\.model\s+\S+\s+)SW\s*\((.*)\)\s*$", fix, t)

    return {
        "as-is": text,
        "steep-D": diodes("IS=1e-14 N=0.001"),
        "steep-D-hard-S": switches(diodes("IS=1e-14 N=0.001"), "1u", "1e12"),
        "mid-D-soft-S": switches(diodes("IS=1e-15 N=0.01"), "10m", "1e6"),
        "ps-edges": re.sub(r"\b10n 10n\b", "1p 1p", text),
    }


@dataclass
class _Row:
    circuit: str
    variant: str
    probes: str
    outcome: dict[str, str]


def _try(text: str, probes: list[str], settings: runner.NgspiceSettings, budget: float) -> str:
    t0 = time.perf_counter()
    try:
        runner.run_ngspice(text, probes, settings=settings, timeout=budget)
    except runner.NgspiceFailed as exc:
        reason = exc.attempts[-1].reason or "?"
        if reason.startswith("stalled"):
            return "stall"
        return "artefact" if reason.startswith("artefact") else "FAIL"
    return f"ok {time.perf_counter() - t0:.1f}s"


def survey(quick: bool = False, budget: float = 20.0, jobs: int = 2) -> list[_Row]:
    """Run the survey; ``quick`` keeps the first two variants only."""
    circuits = {p.stem: p.read_text() for p in sorted(NETLISTS.glob("*.cir"))}
    circuits["lc_tank_bridge"] = LC_TANK_BRIDGE
    circuits["sawtooth_buck"] = SAWTOOTH_BUCK
    cases = []
    for name, text in circuits.items():
        variants = _variants(text)
        for vname in list(variants)[: 2 if quick else None]:
            for probes in ([], ["i(D1)"]):
                cases.append((name, vname, variants[vname], probes))

    def one(case: tuple[str, str, str, list[str]]) -> _Row:
        name, vname, text, probes = case
        outcome = {"as-written": _try(text, probes, runner.DEFAULT_LADDER[0], budget)}
        if not outcome["as-written"].startswith("ok"):
            for rname, settings in _REMEDIES.items():
                outcome[rname] = _try(text, probes, settings, budget)
            try:
                res = runner.run_ngspice(text, probes, timeout=budget)
                outcome["ladder"] = f"rung {res.rung}"
            except runner.NgspiceFailed:
                outcome["ladder"] = "FAIL"
        return _Row(name, vname, ",".join(probes) or "-", outcome)

    with ThreadPoolExecutor(max_workers=jobs) as pool:
        rows = list(pool.map(one, cases))
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="first two variants only")
    ap.add_argument("--jobs", type=int, default=2, help="simulations in parallel")
    ap.add_argument("--budget", type=float, default=20.0, help="timeout per run (s)")
    args = ap.parse_args()
    rows = survey(args.quick, args.budget, args.jobs)
    cols = ["as-written", *_REMEDIES, "ladder"]
    print(f"{'circuit':18} {'variant':15} {'probe':6} " + " ".join(f"{c:>11}" for c in cols))
    for r in rows:
        cells = " ".join(f"{r.outcome.get(c, ''):>11}" for c in cols)
        print(f"{r.circuit:18} {r.variant:15} {r.probes:6} {cells}")


if __name__ == "__main__":
    main()
