"""A non-passive circuit is simulated as its ideal model says, with a warning before the run,
a note on the growth after it, and ``--strict`` / ``strict=True`` to refuse it.

The circuit (tests/netlists/sim/tunnel_nonpassive.cir): a 1 A source into Rn = -50 Ω in
parallel with L1 = 1 mH in series with C1 = 1 µF, a diode to a 10 Ω load. With the diode
off, by hand: i' = (Rn (I - i) - v)/L, v' = i/C, so A = [[-Rn/L, -1/L], [1/C, 0]] =
[[5e4, -1e3], [1e6, 0]], with eigenvalues 2.5e4 ± 1.936e4j 1/s: unstable.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest

import pelcs
from lcs.notices import NonPassiveWarning
from lcs.results import SimulationResult
from lcs.theory import screening
from netlist.errors import NetlistError
from netlist.studies.growth import state_growth
from pelcs.cli import main

ROOT = Path(__file__).resolve().parents[1]
TUNNEL = str(ROOT / "tests" / "netlists" / "sim" / "tunnel_nonpassive.cir")
BOOST = str(ROOT / "converters" / "netlists" / "boost.cir")


def test_cli_warns_before_the_run_and_notes_the_growth(capsys):
    code = main(["simulate", TUNNEL])
    out, err = capsys.readouterr()
    assert code == 0  # the ideal model's growth is its true solution: the run goes on
    warning = [line for line in err.splitlines() if line.startswith("warning:")]
    assert len(warning) == 1, err
    assert "not passive" in warning[0] and "tunnel_nonpassive.cir" in warning[0]
    # the reason is `pelcs lcs`'s: the unstable eigenvalue, 2.5e4 1/s by hand
    m = re.search(r"unstable eigenvalue (\S+)j 1/s", warning[0])
    lam = complex(m.group(1) + "j")
    assert abs(lam.real - 2.5e4) < 1.0 and abs(abs(lam.imag) - np.sqrt(1e9 - 6.25e8)) < 10
    assert "the state grew by a factor of" in out
    # e^(2.5e4 * 4.5 ms) over the last nine tenths: ~1e48 at least
    factor = float(re.search(r"grew by a factor of ([0-9.e+]+)", out).group(1))
    assert factor > 1e40


def test_cli_strict_refuses(capsys):
    code = main(["simulate", TUNNEL, "--strict"])
    out, err = capsys.readouterr()
    assert code == 2
    assert "error:" in err and "not passive" in err and "--strict" in err
    assert "final values" not in out  # nothing was run


def test_api_warns_and_strict_raises():
    with pytest.warns(NonPassiveWarning, match="not passive"):
        res = pelcs.simulate(TUNNEL, tstop="1m")
    assert any("not passive" in n for n in res.notes)
    with pytest.raises(NetlistError, match="not passive"):
        pelcs.simulate(TUNNEL, tstop="1m", strict=True)
    assert pelcs.NonPassiveWarning is NonPassiveWarning


def test_passive_converter_runs_without_warning():
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonPassiveWarning)
        res = pelcs.simulate(BOOST, tstop="50u")
    assert not any("not passive" in n for n in res.notes)
    assert not any("grew by" in n for n in res.notes)


def test_analysis_commands_warn_too(capsys):
    # the stroboscopic map of every analysis command is set up the same way
    from netlist.studies.sweep import circuit_map

    circuit = pelcs.load(TUNNEL)
    with pytest.warns(NonPassiveWarning):
        circuit_map(circuit, 1e-4)


def test_screen_is_cached_with_the_formulation(monkeypatch):
    system = pelcs.formulate(TUNNEL)
    from netlist.formulation import storage_matrix

    energy = storage_matrix(pelcs.load(TUNNEL))
    first = screening.screen_modes(system, energy)
    assert len(first) == 1 and "unstable eigenvalue" in first[0].reason

    def fail(*args, **kwargs):
        raise AssertionError("check_passivity called again")

    monkeypatch.setattr(screening.passivity, "check_passivity", fail)
    assert screening.screen_modes(system, energy) == first


def test_growth_note_threshold():
    t = np.linspace(0.0, 1.0, 101)
    grows = SimulationResult(t=t, names=("x",), y=np.exp(20.0 * t)[:, None],
                             x_final=np.zeros(1), lambda_final=np.zeros(0))
    note = state_growth(grows)
    # first tenth peaks at e^2, the end is e^20: a factor e^18 = 6.6e7 > 1e6
    assert note and f"{np.exp(18.0):.3g}" in note
    mild = SimulationResult(t=t, names=("x",), y=np.exp(10.0 * t)[:, None],
                            x_final=np.zeros(1), lambda_final=np.zeros(0))
    assert state_growth(mild) is None  # e^9 = 8.1e3 < 1e6


def test_structurally_passive_circuits_skip_the_screen(monkeypatch):
    """Positive R, L, C (and K with a positive definite inductance matrix), ideal diodes and
    switches, independent sources: passive in every mode by construction, so the numerical
    screen is not run for them; it still runs for a negative resistance, a controlled source
    or an indefinite coupling. The claim is checked on the circuits themselves: the numerical
    screen finds no non-passive mode in any of them."""
    from converters import scaling
    from netlist.formulation import formulate, storage_matrix
    from netlist.parser import parse_string
    from netlist.passive import structurally_passive

    passive = [scaling.cockcroft_walton(5), scaling.interleaved_buck(3), scaling.mmc_arm(2),
               scaling.rectifier_6pulse(), Path(BOOST).read_text()]
    coupled = """* coupled inductors, k < 1
V1 in 0 PULSE(0 10 0 1n 1n 5u 10u)
L1 in a 1m
L2 b 0 2m
K1 L1 L2 0.9
D1 b out DI
C1 out 0 1u
R1 out 0 10
Ra a 0 1
.model DI D
.tran 1u 100u
.end
"""
    for text in [*passive, coupled]:
        circuit = parse_string(text)
        energy = storage_matrix(circuit)
        assert structurally_passive(circuit, energy)
        assert screening.screen_modes(formulate(circuit), energy) == []
    controlled = coupled.replace("Ra a 0 1", "Ra a 0 1\nE1 c 0 a 0 2\nRc c 0 5")
    negative = coupled.replace("Ra a 0 1", "Ra a 0 -1")
    for text in (controlled, negative, Path(TUNNEL).read_text()):
        circuit = parse_string(text)
        assert not structurally_passive(circuit, storage_matrix(circuit))

    calls = []
    real = screening.screen_modes
    monkeypatch.setattr(screening, "screen_modes",
                        lambda *a, **k: calls.append(1) or real(*a, **k))
    with warnings.catch_warnings():
        warnings.simplefilter("error", NonPassiveWarning)
        pelcs.simulate(BOOST, tstop="50u")
    assert calls == []
    with pytest.warns(NonPassiveWarning):
        pelcs.simulate(TUNNEL, tstop="1m")
    assert calls == [1]
