"""The same name means the same thing everywhere: ``freq`` in the API and ``--freq`` on the
command line (``freqs=`` still taken), ``--tol`` the Newton tolerance on the scaled residual
in both ``orbit`` and ``continue`` (the bisection tolerance of continue is ``--locate-tol``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import pelcs
from netlist.errors import NetlistError
from pelcs.cli import build_parser, main

AC = Path(__file__).resolve().parents[1] / "converters" / "netlists" / "ac"
VM_BUCK = str(Path(__file__).resolve().parents[1] / "converters" / "netlists" / "vm_buck.cir")
BUCK_VC = str(AC / "buck_vc.cir")


def test_api_freq_and_cli_freq_agree(capsys):
    kw = dict(period="ts", inject="Vc", probes=["v(out)"])
    by_text = pelcs.ac(BUCK_VC, freq="100:10k:3", **kw)
    by_values = pelcs.ac(BUCK_VC, freq=np.logspace(2, 4, 3), **kw)
    by_old_name = pelcs.ac(BUCK_VC, freqs=np.logspace(2, 4, 3), **kw)
    assert main(["ac", BUCK_VC, "--period", "ts", "--inject", "Vc", "--probe", "v(out)",
                 "--freq", "100:10k:3", "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    np.testing.assert_allclose(by_text.freq, [100.0, 1e3, 1e4])
    for fr in (by_values, by_old_name):
        np.testing.assert_array_equal(fr.freq, by_text.freq)
        np.testing.assert_array_equal(fr["v(out)"], by_text["v(out)"])
    np.testing.assert_allclose(cli["freq"], by_text.freq)
    np.testing.assert_allclose(cli["probes"]["v(out)"]["mag_db"], by_text.mag_db("v(out)"))


def test_freq_without_count_and_errors():
    from netlist.studies.ac import parse_frequencies

    assert parse_frequencies("100:10k").size == 30
    assert parse_frequencies("1k").tolist() == [1000.0]
    for bad in ("10k:100", "100:1k:1", "100:1k:2.5", "a:b", "1:2:3:4"):
        with pytest.raises(NetlistError, match="FMIN"):
            parse_frequencies(bad)
    with pytest.raises(TypeError, match="not both"):
        pelcs.ac(BUCK_VC, period="ts", inject="Vc", probes=["v(out)"], freq=[1e3],
                 freqs=[1e3])


def _tol_action(command: str):
    parser = build_parser(commands=[command])
    sub = next(a for a in parser._actions if hasattr(a, "choices") and a.choices)
    return next(a for a in sub.choices[command]._actions if "--tol" in a.option_strings)


def test_tol_is_declared_the_same_in_orbit_and_continue():
    a, b = _tol_action("orbit"), _tol_action("continue")
    assert (a.help, a.default, a.metavar) == (b.help, b.default, b.metavar)
    assert "Newton tolerance on the scaled residual" in a.help


class _Stop(Exception):
    pass


def test_tol_reaches_newton_in_both(monkeypatch, capsys):
    import lcs.analysis.continuation as continuation
    import lcs.analysis.orbits as orbits

    seen = {}

    def fake_find_orbit(*args, **kwargs):
        seen["orbit"] = kwargs["tol"]
        raise _Stop

    def fake_continue_orbit(*args, **kwargs):
        seen["continue"] = (kwargs["newton_tol"], kwargs["tol"])
        raise _Stop

    monkeypatch.setattr(orbits, "find_orbit", fake_find_orbit)
    monkeypatch.setattr(continuation, "continue_orbit", fake_continue_orbit)
    with pytest.raises(_Stop):
        main(["orbit", VM_BUCK, "--tol", "1e-7"])
    with pytest.raises(_Stop):
        main(["continue", VM_BUCK, "--param", "vin=20:21:3", "--tol", "1e-7", "--no-progress"])
    assert seen["orbit"] == seen["continue"][0] == 1e-7
    assert seen["continue"][1] is None  # bisection: its default |STOP-START|*1e-4
    assert "--tol is the Newton tolerance" in capsys.readouterr().err
    with pytest.raises(_Stop):
        main(["continue", VM_BUCK, "--param", "vin=20:21:3", "--locate-tol", "1e-3",
              "--no-progress"])
    assert seen["continue"] == (1e-10, 1e-3)
    assert "--tol is the Newton tolerance" not in capsys.readouterr().err
