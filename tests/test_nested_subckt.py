"""Subcircuit definitions nested in others, local to them as in ngspice: an instance finds
the definition nested in its own body's, then in those around it, then a top-level one
(``Deck.subckt_key``); a ``.model`` likewise. The deck is ngspice's regression test
``tests/regression/lib-processing/scope-3.cir`` run as a transient; its expected voltages
are in that test (11.25 V, 47.67 V, 33 V), and ngspice is run on it as well."""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

from pelcs.api import simulate

SCOPE3 = """scope-3, subckt scopes (ngspice regression test, as a transient)
.param foo = 2k
i1001_t  n1001_t 0  -1mA
x1001_t  n1001_t 0  sub1 foo='foo*3'
i1002_t  n1002_t 0  -1mA
x1002_t  n1002_t 0  sub2 foo='foo*4'
i1003_t  n1003_t 0  -1mA
x1003_t  n1003_t 0  sub foo=3k
.subckt  sub1  n1 n2 foo=5k
.subckt  sub   n1 n2 foo=10k
R1   n1 n2   'foo'
.ends
X1   n1 n2  sub foo='3*foo'
R1   n1 n2  '5*foo'
.ends
.subckt  sub   n1 n2 foo=17k
R1   n1 n2  'foo*11'
.ends
.subckt  sub2  n1 n2 foo=121k
.subckt  sub   n1 n2 foo=117k
R1   n1 n2   'foo'
.ends
X1   n1 n2  sub foo='11*foo'
R1   n1 n2  'foo*13'
.ends
.tran 1u 2u
.end
"""

WANT = [11.25, 47.666666666666666, 33.0]
PROBES = ["v(n1001_t)", "v(n1002_t)", "v(n1003_t)"]

# a model inside a nested definition is seen by that definition's elements only: the outer
# one's switch uses the global sm (RON 1 Ohm: v(b) = 0.5 V), the inner one's its own (RON
# 3 Ohm: v(x1.x2.b) = 0.25 V)
MODELS = """nested model scope
V1 a 0 DC 1
Vc c 0 DC 2
X1 a c outer
.subckt outer in ctl
S1 in b ctl 0 sm
R1 b 0 1
X2 in ctl inner
.subckt inner p q
S2 p b q 0 sm
R2 b 0 1
.model sm SW(VT=1 VH=0 RON=3 ROFF=1G)
.ends inner
.ends outer
.model sm SW(VT=1 VH=0 RON=1 ROFF=1G)
.tran 1u 10u
.end
"""


def test_nested_definitions_are_local():
    res = simulate(SCOPE3, probes=PROBES)
    assert np.allclose(res.y[-1], WANT, rtol=1e-12)


def test_ngspice_agrees(tmp_path, ngspice):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    (tmp_path / "deck.cir").write_text(SCOPE3)
    asks = " ".join(f"{p}[1]" for p in PROBES)
    r = subprocess.run(["ngspice", "-p"], input=f"source deck.cir\nrun\nprint {asks}\nquit\n",
                       cwd=tmp_path, capture_output=True, text=True, timeout=60,
                       env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"})
    got = [float(m.group(1)) for m in re.finditer(r"\]\s*=\s*(\S+)", r.stdout)]
    assert np.allclose(got, WANT, rtol=1e-6), r.stdout[-800:]


def test_a_nested_model_is_local_to_its_definition(tmp_path, ngspice):
    res = simulate(MODELS, probes=["v(x1.b)", "v(x1.x2.b)"], devices="pwl")
    assert np.allclose(res.y[-1], [0.5, 0.25], atol=1e-9)
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    (tmp_path / "deck.cir").write_text(MODELS)
    r = subprocess.run(["ngspice", "-p"], input="source deck.cir\nrun\n"
                       "print v(x1.b)[5] v(x1.x2.b)[5]\nquit\n", cwd=tmp_path,
                       capture_output=True, text=True, timeout=60,
                       env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"})
    got = [float(m.group(1)) for m in re.finditer(r"\]\s*=\s*(\S+)", r.stdout)]
    assert np.allclose(got, [0.5, 0.25], atol=1e-6), r.stdout[-800:]
