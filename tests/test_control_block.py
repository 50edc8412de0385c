"""A ``.control`` block's ``alter``, ``stop`` and ``resume`` commands (netlist.control_block):
an ``alter`` before the run applied as ngspice 39 applies it (compared with ngspice's run of the
same deck), the others noted or refused at their place."""

from __future__ import annotations

import re
import shutil
import subprocess

import pytest

from netlist.parser import parse_string
from tests.netlist_asserts import refused_at

RC = "t\nV1 n1 0 1\nR1 n1 n2 1k\nR2 n2 0 1k\nC1 n2 0 1n\n{tran}.control\n{commands}\n.endc\n.end\n"


def _deck(commands: str, tran: str = "") -> str:
    return RC.format(tran=tran, commands=commands.replace("|", "\n"))


def _ngspice_last(tmp_path, deck: str) -> float:
    deck = deck.replace(".endc", "print v(n2)[length(v(n2))-1]\n.endc")
    (tmp_path / "deck.cir").write_text(deck)
    r = subprocess.run(["ngspice", "-b", "deck.cir"], cwd=tmp_path, capture_output=True,
                       text=True, timeout=60, env={"HOME": str(tmp_path), "PATH": "/usr/bin:/bin"})
    return float(re.search(r"v\(n2\)\[length\(v\(n2\)\)-1\] = (\S+)", r.stdout).group(1))


@pytest.mark.parametrize(("commands", "tran", "want"), [
    ("alter R1 2k|tran 0.1u 5u", "", 1 / 3),
    ("alter @R1[resistance]=2k|alter V1 dc=3|run", ".tran 0.1u 5u\n", 1.0),
    ("alter R2 = 3k|tran 0.1u 5u", "", 0.75),
])
def test_an_alter_before_the_run_is_applied(tmp_path, ngspice, commands, tran, want):
    from pelcs.api import simulate

    deck = _deck(commands, tran)
    res = simulate(deck, probes=["v(n2)"])
    assert res.y[-1, 0] == pytest.approx(want, rel=1e-9)
    assert sum("applied:" in n for n in res.notes) == commands.count("alter"), res.notes
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    assert _ngspice_last(tmp_path, deck) == pytest.approx(want, rel=1e-5)


def test_an_alter_after_the_run_changes_only_later_runs(tmp_path, ngspice):
    deck = _deck("tran 0.1u 5u|alter R1 3k|run")
    c = parse_string(deck)
    assert c.element("R1").value == 1e3
    assert any("after the run pelcs simulates" in n for n in c.notes), c.notes
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    # the first run is at R1 = 1k: its last v(n2) 0.5; ngspice's last run (0.25) comes after
    d = deck.replace("alter R1 3k\nrun", "print v(n2)[length(v(n2))-1]")
    assert _ngspice_last(tmp_path, d) == pytest.approx(0.5, rel=1e-5)


def test_a_block_without_a_run_alters_nothing():
    c = parse_string(_deck("alter R1 2k", ".tran 0.1u 5u\n"))
    assert c.element("R1").value == 1e3
    assert any("starts no run" in n for n in c.notes), c.notes


def test_stop_and_resume_are_noted():
    c = parse_string(_deck("resume|stop when time=2u|tran 0.1u 5u|resume"))
    notes = " ".join(c.notes)
    assert "continues nothing" in notes and "'stop' not applied" in notes
    assert "continues ngspice's run" in notes


@pytest.mark.parametrize(("commands", "line", "words"), [
    ("alter R1 {2k}|tran 0.1u 5u", 7, ["pelcs cannot apply it", "'{2k}' is not a number"]),
    ("alter X1 2k|tran 0.1u 5u", 7, ["pelcs cannot apply it", "'X1' is no top-level"]),
    ("alter R1 tc1 1m|tran 0.1u 5u", 7, ["pelcs cannot apply it", "'tc1' is not the value"]),
    ("altermod|alter R1|tran 0.1u 5u", 8, ["cannot read 'alter R1'"]),
])
def test_an_alter_pelcs_cannot_apply_is_refused(commands, line, words):
    refused_at(_deck(commands), (line, 1), words)


def test_an_alter_of_a_pulse_source_is_refused():
    deck = _deck("alter V1 3|tran 0.1u 5u").replace("V1 n1 0 1",
                                                    "V1 n1 0 PULSE(0 1 0 1n 1n 1u 2u)")
    refused_at(deck, (7, 1), ["V1 has a PULSE waveform"])


def test_an_alter_during_a_stopped_run_is_refused(tmp_path, ngspice):
    deck = _deck("stop when time=2u|tran 0.1u 5u|alter R1 3k|resume")
    refused_at(deck, (9, 1), ["between a 'stop' and 'resume'"])
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    # ngspice changes R1 at 2 us: its run ends near 0.25 V, a run at 1k ends at 0.5 V
    assert _ngspice_last(tmp_path, deck) == pytest.approx(0.2546, abs=1e-3)


@pytest.mark.parametrize(("commands", "want"), [
    # the loop's last value sets R1 for the tran after it (ngspice: 0.25 V)
    ("foreach v 1k 2k 3k|alter R1 $v|op|end|tran 0.1u 5u", 0.25),
    # the run inside the loop: its first run is at the first value (ngspice: tran1 at 1/3 V)
    ("foreach v 2k 3k|alter R1 = $v|tran 0.1u 5u|end", 1 / 3),
    ("set rv = 3k|alter R1 $rv|tran 0.1u 5u", 0.25),
])
def test_an_alter_of_a_control_variable(tmp_path, ngspice, commands, want):
    from pelcs.api import simulate

    deck = _deck(commands)
    res = simulate(deck, probes=["v(n2)"])
    assert res.y[-1, 0] == pytest.approx(want, rel=1e-9)
    assert any("applied:" in n and "$" in n for n in res.notes), res.notes
    if shutil.which("ngspice") is None:
        pytest.skip("no ngspice executable")
    d = deck.replace(".endc", "setplot tran1\n.endc")
    assert _ngspice_last(tmp_path, d) == pytest.approx(want, rel=1e-5)


def test_an_alter_inside_other_control_flow_is_refused():
    refused_at(_deck("if 1|alter R1 2k|end|tran 0.1u 5u"), (8, 1),
               ["inside if", "does not run ngspice's control flow"])
    refused_at(_deck("alter R1 $nope|tran 0.1u 5u"), (7, 1), ["a variable pelcs does not know"])
