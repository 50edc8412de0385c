"""Spellings ngspice reads and pelcs now reads alike, each checked against ngspice's
element values on the same deck (``print @R1[resistance]``):

- comparisons, ``&&``, ``||`` and ``c ? a : b`` in parameter expressions (ngspice's numparam:
  a comparison is 1 or 0, ``c`` is true when not 0);
- a value named by its keyword: ``R1 a b r=1k``, ``C1 a b c=1u``, ``L1 a b l=1m``;
- the micro sign ``µ`` (LTspice's ``1000µF``), read as ``u``.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from netlist.parser import parse_string

DECK = """parameter logic and keyword values
.param a=2 b=3
.param d={a>b ? 1u : 2u}
.param e={a<b ? 1k : 2k}
.param f={(a<b) && (b<2) || a==2}
.param g={a>=2 || b<0}
.param h={a!=2}
.param k={max(a>b, 0.5) * (a <= b ? 4 : 8)}
V1 in 0 1
R1 in 0 {e*f}
C1 in 0 {d}
R2 in 0 {1k+g}
R3 in 0 {1k+h}
R4 in 0 {1k*k}
R5 in 0 r=2.2k
C2 in 0 c = 3u
L2 in x l={e*1u}
R6 x 0 1
.tran 1u 2u
.end
"""

# element -> (ngspice's property, the value numparam's rules give)
WANT = {"R1": ("resistance", 1e3), "C1": ("capacitance", 2e-6), "R2": ("resistance", 1001.0),
        "R3": ("resistance", 1e3), "R4": ("resistance", 2e3), "R5": ("resistance", 2.2e3),
        "C2": ("capacitance", 3e-6), "L2": ("inductance", 1e-3)}


def test_pelcs_values():
    c = parse_string(DECK)
    for name, (_, want) in WANT.items():
        assert c.element(name).value == pytest.approx(want, rel=1e-12), name


def test_ngspice_values(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    (tmp_path / "deck.cir").write_text(DECK)
    asks = " ".join(f"@{n.lower()}[{prop}]" for n, (prop, _) in WANT.items())
    r = subprocess.run(["ngspice", "-p"], input=f"source deck.cir\nrun\nprint {asks}\nquit\n",
                       cwd=tmp_path, capture_output=True, text=True, timeout=60,
                       env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"})
    got = {m.group(1).upper(): float(m.group(2)) for m in
           re.finditer(r"@(\w+)\[\w+\] = (\S+)", r.stdout)}
    for name, (_, want) in WANT.items():
        assert got.get(name) == pytest.approx(want, rel=1e-6), (name, r.stdout[-800:])


def test_the_micro_sign_is_u(tmp_path, ngspice):
    # LTspice writes µ (U+00B5) for micro; ngspice reads every one as 'u' (inpcom.c)
    deck = ("micro sign\nV1 a 0 1\nC1 a 0 1000\u00b5F\nC2 a 0 2\u00b5\nR1 a 0 1k\n"
            ".tran 1u 2u\n.end\n")
    c = parse_string(deck)
    assert (c.element("C1").value, c.element("C2").value) == (1e-3, 2e-6)
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    (tmp_path / "deck.cir").write_text(deck, encoding="utf-8")
    r = subprocess.run(["ngspice", "-p"], input="source deck.cir\nrun\n"
                       "print @c1[capacitance] @c2[capacitance]\nquit\n", cwd=tmp_path,
                       capture_output=True, text=True, timeout=60,
                       env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"})
    got = [float(m.group(1)) for m in re.finditer(r"\] = (\S+)", r.stdout)]
    assert got == pytest.approx([1e-3, 2e-6]), r.stdout[-500:]
