"""Scaling study: pelcs against ngspice on converters with many diodes and
switches, whole commands side by side.

Families (``converters/scaling.py``, near-ideal models in the text both programs read):
Cockcroft-Walton multipliers of N stages (2N diodes), interleaved bucks of P phases (P switches,
P diodes), three-phase 6- and 12-pulse rectifiers, MMC arms of N half-bridge cells (2N switches,
2N diodes).

For each netlist:

* ``pelcs``: the whole command ``pelcs simulate FILE -o OUT.npz`` in a fresh process (start-up,
  parsing, formulation, simulation, writing), and, in process, the time per step and the solver
  counters, of a first run (modes formulated as they are reached) and of a second one (modes
  built: the stepping alone), and the formulation's cost per mode (their difference); the
  kernel "auto" chose, and the stepping with each kernel forced (``dense``: stored
  θ-discretised matrices; ``sparse``: the circuit's factorised network,
  ``lcs.integrators.moreau.sparse``);
* ``ngspice``: ``ngspice -b -r OUT.raw FILE`` in a fresh process, the netlist as written; when
  that fails ("timestep too small": ngspice's Newton iterations do not converge on the
  near-ideal models at this size), the same with softened models (diodes ``N=1 RS=10m``,
  switches ``RON=10m``), reported as such: pelcs simulates the ideal elements either way.

Run: ``.venv/bin/python benchmarks/bench_scale.py [--quick] [--family NAME]... [--timeout S]
[--repeat N] [--plot OUT.png]`` (``--repeat``: best of N whole commands, both programs);
prints a table and writes ``benchmarks/results/bench_scale.json`` and the Markdown tables of
``docs/performance.md``, ``benchmarks/results/bench_scale.md`` (``--replot --plot OUT.png``
draws the JSON file again, ``--tables`` writes the Markdown from it again). Each row also
records the machine's state before its case (:func:`host_state`): this shared machine's
speed varies within the hour.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(HERE))
# One BLAS thread in this process, as the command sets for itself (pelcs/cli.py), so that
# the in-process figures are measured as the command runs.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from converters import scaling  # noqa: E402

# Run lengths of a design study (a few hundred switching periods), long enough that start-up
# does not decide the comparison.
FAMILIES = {
    "cockcroft_walton": (lambda n: scaling.cockcroft_walton(n, periods=200),
                         (5, 10, 20, 50, 100, 200)),
    "interleaved_buck": (lambda p: scaling.interleaved_buck(p, periods=200),
                         (2, 4, 8, 16, 32, 64)),
    "rectifier_6pulse": (lambda _: scaling.rectifier_6pulse(periods=20), (1,)),
    "rectifier_12pulse": (lambda _: scaling.rectifier_12pulse(periods=20), (1,)),
    "mmc_arm": (lambda c: scaling.mmc_arm(c, periods=4), (4, 8, 16, 32, 64)),
}
QUICK = {"cockcroft_walton": (5, 20), "interleaved_buck": (2, 8), "rectifier_6pulse": (1,),
         "rectifier_12pulse": (1,), "mmc_arm": (4, 8)}


def _pelcs_inprocess(text: str, tmp: Path) -> dict:
    """The command's phases timed in this process (kernels loaded): parsing, set-up, the run
    (modes formulated as they are reached, then stepping), the output (resampled onto the
    TSTEP grid and written as NPZ, as ``pelcs simulate -o out.npz``), and the stepping
    alone in a second run."""
    from lcs.results import resample
    from netlist.parser import parse_file
    from netlist.studies.transient import run_setup, transient_setup
    from pelcs.writers import write_npz

    path = tmp / "inprocess.cir"
    path.write_text(text)
    t0 = time.perf_counter()
    circuit = parse_file(path)
    t1 = time.perf_counter()
    setup = transient_setup(circuit)
    t2 = time.perf_counter()
    res = run_setup(setup, progress=False)
    t3 = time.perf_counter()
    tstep = circuit.tran.tstep if circuit.tran is not None else 0.0
    out = resample(res, tstep) if tstep >= setup.h * (1 - 1e-9) else res
    write_npz(out, tmp / "inprocess.npz")
    t4 = time.perf_counter()
    dt = t3 - t2
    phases = dict(parse_s=t1 - t0, setup_s=t2 - t1, run_s=dt, output_s=t4 - t3)
    st = res.stats
    # Again, with the modes formulated and discretised and the caches filled: the stepping
    # alone (what a sweep or a longer run pays per step).
    t0 = time.perf_counter()
    run_setup(setup, progress=False)
    dt2 = time.perf_counter() - t0
    return dict(**phases, stepping_s=dt2,n=len(setup.system.states), m=len(setup.system.diodes),
                k=len(setup.system.switches), steps=st.steps,
                us_per_step=1e6 * dt / max(st.steps, 1),
                us_per_step_stepping=1e6 * dt2 / max(st.steps, 1),
                ms_per_mode=1e3 * max(dt - dt2, 0.0) / max(st.modes_built, 1),
                lemke=st.fallbacks,
                warm=st.warm_solves, factorisations=st.factorisations,
                updates=st.factor_updates, modes=st.modes_built, kernel=st.kernel,
                error=res.error.kind if res.error else None, **_kernels(setup))


def _kernels(setup) -> dict:
    """The stepping (second run, µs per step) with each kernel forced: the dense one's stored
    θ-discretised matrices and the sparse one's factorised network
    (lcs.integrators.moreau.sparse)."""
    from lcs.integrators.moreau.integrator import MoreauOptions
    from netlist.studies.transient import run_setup

    out = {}
    for kernel in ("dense", "sparse"):
        opts = MoreauOptions(kernel=kernel)
        run_setup(setup, options=opts)
        t0 = time.perf_counter()
        res = run_setup(setup, options=opts)
        dt = time.perf_counter() - t0
        out[f"us_{kernel}"] = 1e6 * dt / max(res.stats.steps, 1)
        if kernel == "sparse":
            out["sparse_dense_steps"] = res.stats.dense_steps
    return out


# The processes run as on a user's machine: without this workplace's PYTHONDONTWRITEBYTECODE
# (see bench_command.py).
_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
REPEAT = 1


def _whole(cmd: list[str], timeout: float) -> tuple[float | None, str]:
    """Best wall time of :data:`REPEAT` runs of ``cmd`` (None and the reason on a failure)."""
    best = None
    for _ in range(REPEAT):
        t0 = time.perf_counter()
        try:
            r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=_ENV)
        except subprocess.TimeoutExpired:
            return None, f"timeout {timeout:g} s"
        dt = time.perf_counter() - t0
        out = r.stdout + r.stderr
        if r.returncode != 0 or "Timestep too small" in out or "aborted" in out.lower():
            return None, (out.strip().splitlines()[-1][:120] if out.strip()
                          else f"exit {r.returncode}")
        best = dt if best is None else min(best, dt)
    return best, ""


def host_state() -> dict:
    """How fast this (shared) machine is right now: the best of 5 of a fixed pure-Python loop
    (``cpu_ms``: the interpreter's speed, what start-up and parsing pay) and of filling 64 MB
    of fresh memory (``fresh_mb_ms``: the kernel's page zeroing, what the first touch of a
    run's stores and factors pays). A row's ratios can then be read against the machine's
    state when it ran: on this 2-core virtual machine both vary by 30 % and more within an
    hour, and they slow pelcs more than ngspice."""
    import numpy as np

    def best(fn) -> float:
        out = []
        for _ in range(5):
            t0 = time.perf_counter()
            fn()
            out.append(time.perf_counter() - t0)
        return 1e3 * min(out)

    def loop():
        acc = 0
        for i in range(200_000):
            acc += i * i
        return acc

    return dict(cpu_ms=best(loop), fresh_mb_ms=best(lambda: np.ones(8 << 20)))


def run_case(family: str, size: int, timeout: float) -> dict:
    text = FAMILIES[family][0](size)
    row = dict(family=family, size=size, host=host_state())
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"{family}_{size}.cir"
        path.write_text(text)
        pelcs = str(HERE / ".venv" / "bin" / "pelcs")
        row["pelcs_s"], row["pelcs_note"] = _whole(
            [pelcs, "simulate", str(path), "-o", str(Path(tmp) / "out.npz")], timeout)
        row.update(_pelcs_inprocess(text, Path(tmp)))
        if row.get("pelcs_s"):
            # What the command spends besides its phases: the interpreter, the imports, the
            # argument parsing and the kernels' loading.
            row["startup_s"] = max(0.0, row["pelcs_s"] - sum(
                row[k] for k in ("parse_s", "setup_s", "run_s", "output_s")))
        raw = str(Path(tmp) / "out.raw")
        row["ngspice_s"], note = _whole(["ngspice", "-b", "-r", raw, str(path)], timeout)
        row["ngspice_models"] = "near-ideal"
        if row["ngspice_s"] is None:
            soft = path.with_name("soft.cir")
            soft.write_text(text.replace("D(IS=1e-12 N=0.05 RS=1m)", "D(IS=1e-12 N=1 RS=10m)")
                            .replace("RON=1m", "RON=10m"))
            row["ngspice_s"], note2 = _whole(["ngspice", "-b", "-r", raw, str(soft)], timeout)
            row["ngspice_models"] = "softened"
            if row["ngspice_s"] is None:
                row["ngspice_models"] = None
                row["ngspice_note"] = f"near-ideal: {note}; softened: {note2}"
    if row.get("pelcs_s") and row.get("ngspice_s"):
        row["ratio"] = row["ngspice_s"] / row["pelcs_s"]
    return row


LABELS = {"cockcroft_walton": "Cockcroft-Walton", "interleaved_buck": "interleaved buck",
          "mmc_arm": "MMC arm"}


def plot(rows: list[dict], path: Path) -> Path:
    """Two panels from a run's rows: time per step against the circuit's size (states +
    pairs) with each kernel, with a line of slope 1 and one of slope 2 for reference;
    whole-command speed-up over ngspice against the size."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(10, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(1, 2)
    sizes = []
    for family, label in LABELS.items():
        rs = sorted((r for r in rows if r["family"] == family and r.get("steps")),
                    key=lambda r: r["n"] + r["m"])
        if not rs:
            continue
        x = [r["n"] + r["m"] for r in rs]
        sizes += x
        if all("us_dense" in r for r in rs):
            line, = ax1.loglog(x, [r["us_sparse"] for r in rs], "o-",
                               label=f"{label}: sparse kernel")
            ax1.loglog(x, [r["us_dense"] for r in rs], "s--", color=line.get_color(),
                       mfc="none", label=f"{label}: dense kernel")
        else:  # (results of the benchmark before the sparse kernel)
            ax1.loglog(x, [r["us_per_step_stepping"] for r in rs], "s--", mfc="none",
                       label=f"{label}: stepping (modes built)")
        ok = [(xi, r["ratio"]) for xi, r in zip(x, rs, strict=True) if r.get("ratio")]
        if ok:
            ax2.semilogx(*zip(*ok, strict=True), "o-", label=label)
    if sizes:
        lo, hi = min(sizes), max(sizes)
        for slope, style in ((1, ":"), (2, "--")):
            ax1.loglog([lo, hi], [0.3 * (v / lo) ** slope for v in (lo, hi)], "k" + style,
                       lw=0.8, label=f"∝ size^{slope}")
    ax1.set_xlabel("states + complementarity pairs")
    ax1.set_ylabel("time per step [µs]")
    ax1.set_title("pelcs: time per step (modes built) against circuit size", fontsize=10)
    ax1.grid(True, which="both", color="0.9")
    ax1.legend(fontsize=6.5)
    ax2.axhline(1.0, color="0.4", lw=0.8, label="as fast as ngspice")
    ax2.axhline(5.0, color="0.4", lw=0.8, ls="--", label="5x")
    ax2.set_xlabel("states + complementarity pairs")
    ax2.set_ylabel("ngspice time / pelcs time (whole command) [-]")
    ax2.set_title("whole command: speed-up over ngspice -b", fontsize=10)
    ax2.grid(True, which="both", color="0.9")
    ax2.legend(fontsize=8)
    fig.savefig(path, dpi=110)
    return path


NAMES = {"cockcroft_walton": ("Cockcroft–Walton", "stages"),
         "interleaved_buck": ("interleaved buck", "phases"), "mmc_arm": ("MMC arm", "cells")}


def _case(row: dict) -> str:
    """A row's case as the tables name it: "Cockcroft–Walton, 50 stages", "6-pulse
    rectifier"."""
    if row["family"] in NAMES:
        name, unit = NAMES[row["family"]]
        return f"{name}, {row['size']} {unit}"
    if row["family"].startswith("rectifier_"):
        return row["family"].split("_")[1].replace("pulse", "-pulse rectifier")
    return f"{row['family']} {row['size']}"


def tables(rows: list[dict]) -> str:
    """The two Markdown tables of ``docs/performance.md`` from a run's rows: per case the time
    per step with each kernel (the one "auto" picks in bold) and both whole commands; then
    where the pelcs command's time goes."""
    def us(v: float | None, bold: bool) -> str:
        if v is None:
            return "—"
        text = f"{v:.2f}" if v < 1 else f"{v:.0f}" if v >= 100 else f"{v:.1f}"
        return f"**{text}**" if bold else text

    lines = ["| case | states / pairs / switches | dense µs/step | sparse µs/step | "
             "pelcs command | ngspice command | ratio |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        ng = r.get("ngspice_s")
        ngs = (f"{ng:.2f} s" + (" (softened models)" if r.get("ngspice_models") == "softened"
                                else "")) if ng else "fails (aborted)"
        ratio = f"{r['ratio']:.1f}x" if r.get("ratio") else "—"
        pelcs_s = f"{r['pelcs_s']:.2f} s" if r.get("pelcs_s") else "fails"
        lines.append(f"| {_case(r)} | {r['n']} / {r['m']} / {r['k']} | "
                     f"{us(r.get('us_dense'), r.get('kernel') == 'dense')} | "
                     f"{us(r.get('us_sparse'), r.get('kernel') == 'sparse')} | {pelcs_s} | "
                     f"{ngs} | {ratio} |")
    lines += ["", "| case | start-up | parsing | modes (count) | stepping | output (NPZ) | "
              "command |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        if r.get("startup_s") is None:
            continue
        lines.append(f"| {_case(r)} | {r['startup_s']:.2f} s | {r['parse_s']:.3f} s | "
                     f"{max(0.0, r['run_s'] - r['stepping_s']):.2f} s ({r['modes']}) | "
                     f"{r['stepping_s']:.2f} s | {r['output_s']:.2f} s | {r['pelcs_s']:.2f} s |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="two sizes per family")
    ap.add_argument("--family", action="append", choices=sorted(FAMILIES))
    ap.add_argument("--timeout", type=float, default=600.0)
    ap.add_argument("--repeat", type=int, default=1,
                    help="best of N runs of each whole command (pelcs and ngspice)")
    ap.add_argument("--plot", metavar="OUT.png",
                    help="draw the results (of this run, or with --replot of the last one)")
    ap.add_argument("--replot", action="store_true",
                    help="only draw benchmarks/results/bench_scale.json (with --plot)")
    ap.add_argument("--tables", action="store_true",
                    help="only write benchmarks/results/bench_scale.md from the JSON file")
    args = ap.parse_args(argv)
    results = HERE / "benchmarks" / "results"
    if args.tables:
        rows = json.loads((results / "bench_scale.json").read_text())
        (results / "bench_scale.md").write_text(tables(rows))
        print(results / "bench_scale.md")
        return 0
    if args.replot:
        if not args.plot:
            ap.error("--replot needs --plot OUT.png")
        rows = json.loads((HERE / "benchmarks" / "results" / "bench_scale.json").read_text())
        print(plot(rows, Path(args.plot)))
        return 0
    global REPEAT
    REPEAT = max(1, args.repeat)
    from lcs.build.warmup import warm_up

    warm_up()
    rows = []
    print(f"{'case':24s} {'n':>4s} {'m':>4s} {'k':>4s} {'steps':>7s} {'us/step':>8s} "
          f"{'stepping':>8s} {'dense':>7s} {'sparse':>7s} {'kernel':>6s} {'ms/mode':>7s} "
          f"{'lemke':>5s} {'warm':>5s} {'modes':>5s} {'pelcs s':>8s} {'ngspice s':>10s} "
          f"{'models':>10s} {'ratio':>6s}")
    for family in args.family or sorted(FAMILIES):
        sizes = QUICK[family] if args.quick else FAMILIES[family][1]
        for size in sizes:
            row = run_case(family, size, args.timeout)
            rows.append(row)
            ng = row.get("ngspice_s")
            print(f"{family + ' ' + str(size):24s} {row['n']:4d} {row['m']:4d} {row['k']:4d} "
                  f"{row['steps']:7d} {row['us_per_step']:8.2f} "
                  f"{row['us_per_step_stepping']:8.2f} {row['us_dense']:7.2f} "
                  f"{row['us_sparse']:7.2f} {row['kernel']:>6s} {row['ms_per_mode']:7.2f} "
                  f"{row['lemke']:5d} "
                  f"{row['warm']:5d} {row['modes']:5d} "
                  f"{row['pelcs_s'] if row['pelcs_s'] else float('nan'):8.2f} "
                  f"{ng if ng else float('nan'):10.2f} {str(row.get('ngspice_models')):>10s} "
                  f"{row.get('ratio', float('nan')):6.1f}"
                  + (f"  pelcs: {row['error']}" if row.get("error") else "")
                  + (f"  ngspice: {row['ngspice_note']}" if row.get("ngspice_note") else ""),
                  flush=True)
    print("\nwhere the pelcs command's time goes (s; modes: the first run less the second, "
          "stepping: the second run)")
    print(f"{'case':24s} {'start-up':>8s} {'parse':>7s} {'set-up':>7s} {'modes':>7s} "
          f"{'stepping':>8s} {'output':>7s} {'command':>8s}")
    for row in rows:
        if row.get("startup_s") is None:
            continue
        print(f"{row['family'] + ' ' + str(row['size']):24s} {row['startup_s']:8.3f} "
              f"{row['parse_s']:7.3f} {row['setup_s']:7.3f} "
              f"{max(0.0, row['run_s'] - row['stepping_s']):7.3f} {row['stepping_s']:8.3f} "
              f"{row['output_s']:7.3f} {row['pelcs_s']:8.3f}")
    cpu = [row["host"]["cpu_ms"] for row in rows]
    mem = [row["host"]["fresh_mb_ms"] for row in rows]
    if rows:
        print(f"\nhost state over the run (best of 5 before each case): a pure-Python loop "
              f"{min(cpu):.1f}-{max(cpu):.1f} ms, 64 MB of fresh memory "
              f"{min(mem):.1f}-{max(mem):.1f} ms")
    out = HERE / "benchmarks" / "results"
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench_scale.json").write_text(json.dumps(rows, indent=1))
    (out / "bench_scale.md").write_text(tables(rows))
    if args.plot:
        print(plot(rows, Path(args.plot)))
    return 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    sys.exit(main())
