"""Parse time of a generated 20,000-element netlist (goal: under 2 s).

Run by hand::

    .venv/bin/python benchmarks/bench_parse.py [N_ELEMENTS]

The netlist is a ladder of sections, each a series R and L, a shunt C, a diode and, every
tenth section, a PULSE voltage source with a series R; a fifth of the values are parameter
expressions. It prints the size, the best of three parse times (the first parse also builds
the LALR tables, which is shown separately), and the time per element.
"""

from __future__ import annotations

import sys
import time

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1]))

from netlist.expressions import lark_parser  # noqa: E402
from netlist.parser import parse_string  # noqa: E402


def generate(n_elements: int) -> str:
    """A valid netlist with about ``n_elements`` elements (R/L/C/D/V mix, some params)."""
    lines = [f"generated ladder, {n_elements} elements",
             ".param rs=10m lval=1u cval={10*lval/10} vdrive=5 fs=100k",
             ".model DI D(IS=1e-14)",
             "Vin n0 0 DC 12"]
    count = 1
    i = 0
    while count < n_elements:
        a, b, c = f"n{i}", f"m{i}", f"n{i + 1}"
        if i % 5 == 0:
            lines.append(f"R{i} {a} {b} {{rs*2}}")
            lines.append(f"L{i} {b} {c} {{lval}} IC=0")
        else:
            lines.append(f"R{i} {a} {b} 10m")
            lines.append(f"L{i} {b} {c} 1.5uH")
        lines.append(f"C{i} {c} 0 2.2uF")
        lines.append(f"D{i} 0 {c} DI")
        count += 4
        if i % 10 == 9 and count < n_elements:
            lines.append(f"V{i} g{i} 0 PULSE(0 {{vdrive}} 0 10n 10n {{0.5/fs}} {{1/fs}})")
            lines.append(f"RG{i} g{i} {c} 1k")
            count += 2
        i += 1
    lines.append(".tran 10n 1m")
    lines.append(".end")
    return "\n".join(lines) + "\n"


def main() -> None:
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20_000
    text = generate(n)
    t0 = time.perf_counter()
    lark_parser()
    t_tables = time.perf_counter() - t0
    times = []
    for _ in range(3):
        t0 = time.perf_counter()
        circuit = parse_string(text, file="bench.cir")
        times.append(time.perf_counter() - t0)
    best = min(times)
    print(f"{len(circuit.elements)} elements, {len(text.splitlines())} lines, "
          f"{len(text) / 1e6:.2f} MB")
    print(f"grammar tables: {t_tables:.3f} s (once per process)")
    print(f"parse: best {best:.3f} s of {', '.join(f'{t:.3f}' for t in times)} "
          f"({best / len(circuit.elements) * 1e6:.1f} us per element)")


if __name__ == "__main__":
    main()
