"""Lines ngspice 39 refuses, refused by pelcs at their place with what to write instead, and
their neighbours ngspice reads, read alike (each checked against ngspice on the same deck).

- ``pi`` in a ``.param`` or ``{...}`` expression, or as a bare value, with no ``.param pi``:
  numparam has no such constant ("Undefined parameter [pi]"); a B source knows pi.
- ``.tran tstep tstop`` with parameter names: ngspice substitutes nothing there ("TSTEP is
  invalid, must be greater than zero"; "unknown parameter on .tran" for TSTART, TMAX); in
  braces they are read.
"""

from __future__ import annotations

import math
import re
import shutil
import subprocess

import pytest

from netlist.parser import parse_string
from tests.netlist_asserts import refused_at


def _ngspice(tmp_path, deck: str, commands: str) -> str:
    (tmp_path / "deck.cir").write_text(deck.replace(".end\n", f".control\n{commands}\n.endc\n"
                                                    ".end\n"))
    r = subprocess.run(["ngspice", "-b", "deck.cir"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=60, env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"})
    return r.stdout + r.stderr


PI_DECKS = {
    "param": ("t\n.param a={2*pi}\nV1 n1 0 {a}\nR1 n1 0 1\n.tran 1u 2u\n.end\n", (2, 13)),
    "braces": ("t\nV1 n1 0 {pi/2}\nR1 n1 0 1\n.tran 1u 2u\n.end\n", (2, 10)),
    "bare": ("t\nV1 n1 0 pi\nR1 n1 0 1\n.tran 1u 2u\n.end\n", (2, 9)),
}


@pytest.mark.parametrize("kind", list(PI_DECKS))
def test_pi_without_a_param_is_refused(kind):
    deck, where = PI_DECKS[kind]
    refused_at(deck, where, ["unknown parameter 'pi'", "Undefined parameter [pi]",
                             ".param pi=3.14159"])


@pytest.mark.parametrize("kind", list(PI_DECKS))
def test_ngspice_refuses_pi_without_a_param(tmp_path, ngspice, kind):
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    out = _ngspice(tmp_path, PI_DECKS[kind][0], "op\nprint v(n1)")
    assert re.search(r"Undefined parameter \[pi\]|unknown parameter \(pi\)", out), out
    assert "v(n1) =" not in out


def test_pi_defined_by_a_param_and_in_a_b_source(tmp_path, ngspice):
    deck = ("t\n.param pi=3\nV1 n1 0 {2*pi}\nR1 n1 0 1\nB2 n2 0 V=2*pi\nR2 n2 0 1\n"
            ".tran 1u 2u\n.end\n")
    c = parse_string(deck)
    # numparam's pi is the .param; a B source's pi is the constant (ngspice: 6 and 6.283185)
    assert c.element("V1").dc == 6.0
    assert c.element("B2").dc == pytest.approx(2 * math.pi, rel=1e-15)
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    out = _ngspice(tmp_path, deck, "set numdgt=12\nop\nprint v(n1) v(n2)")
    got = dict(re.findall(r"(v\(n\d\)) = (\S+)", out))
    assert float(got["v(n1)"]) == pytest.approx(6.0, rel=1e-9), out
    assert float(got["v(n2)"]) == pytest.approx(2 * math.pi, rel=1e-9), out


TRAN = ("t\n.param tstep=1u tstop=10u\nV1 n1 0 PULSE(0 1 0 1n 1n 5u 10u)\nR1 n1 0 1\n"
        "{tran}\n.end\n")


@pytest.mark.parametrize(("tran", "col", "said"), [
    (".tran tstep tstop", 7, "TSTEP is invalid"), (".tran 1u tstop", 10, "TSTOP is invalid"),
    (".tran 1u 10u 0 tstep", 16, "unknown parameter on .tran")])
def test_tran_fields_named_bare_are_refused(tmp_path, ngspice, tran, col, said):
    deck = TRAN.format(tran=tran)
    refused_at(deck, (5, col), ["bare name", said, "write it in braces"])
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    out = _ngspice(tmp_path, deck, "run\nprint length(time)")
    assert said in out and "length(time) =" not in out, out


def test_tran_fields_in_braces_are_read(tmp_path, ngspice):
    deck = TRAN.format(tran=".tran {tstep} {tstop}")
    tran = parse_string(deck).tran
    assert (tran.tstep, tran.tstop) == (1e-6, 1e-5)
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    out = _ngspice(tmp_path, deck, "run\nprint time[length(time)-1]")
    assert float(re.search(r"time\[length\(time\)-1\] = (\S+)", out).group(1)) == 1e-5, out


ENDS = {
    # .ends naming the other subcircuit: ngspice 39 ignores the name (v(n2) = 0.5)
    "other": ("t\n.subckt aa in out\nR1 in out 1k\n.ends bb\n.subckt bb in out\nR1 in out 2k\n"
              ".ends bb\nV1 n1 0 1\nX1 n1 n2 aa\nR2 n2 0 1k\n.tran 1u 2u\n.end\n", 0.5),
    # nested, the names swapped: .ends closes the innermost open one (v(n2) = 0.25)
    "nested": ("t\n.subckt outer in out\n.subckt inner a b\nR1 a b 3k\n.ends outer\n"
               "Xi in out inner\n.ends inner\nV1 n1 0 1\nX1 n1 n2 outer\nR2 n2 0 1k\n"
               ".tran 1u 2u\n.end\n", 0.25),
}


@pytest.mark.parametrize("kind", list(ENDS))
def test_the_name_after_ends_is_ignored_with_a_note(tmp_path, ngspice, kind):
    from pelcs.api import simulate

    deck, want = ENDS[kind]
    res = simulate(deck, probes=["v(n2)"])
    assert res.y[-1, 0] == pytest.approx(want, rel=1e-9)
    assert any("ngspice ignores the name after .ends" in n for n in res.notes), res.notes
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    out = _ngspice(tmp_path, deck, "op\nprint v(n2)")
    assert float(re.search(r"v\(n2\) = (\S+)", out).group(1)) == pytest.approx(want), out
