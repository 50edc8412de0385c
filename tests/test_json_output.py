"""Every ``--json`` of the CLI is strict JSON (:mod:`pelcs.jsonout`): NaN and infinities are
written as null, never as the ``NaN`` / ``Infinity`` that ``json.dumps`` writes by default and
strict parsers (jq, JavaScript) reject.

Inputs that really produce a non-finite value: ``ac`` (a probe that does not respond to the
injected source: |H| = 0, -inf dB), ``orbit`` (a strongly unstable circuit whose scaled Newton
residual overflows) and ``lcs`` (a switch model with a threshold beyond the largest float).
For ``continue`` none was found (its orbits and multipliers come from maps that refuse
non-finite states); the shared function is tested on its own.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from pelcs.cli import main
from pelcs.jsonout import dumps, json_ready

NETLISTS = Path(__file__).parent / "netlists"


def _refuse(name: str):
    raise AssertionError(f"not strict JSON: {name}")


def strict(text: str):
    """``text`` parsed as strict JSON (NaN, Infinity, -Infinity are refused)."""
    return json.loads(text, parse_constant=_refuse)


def compare(got, ref, path: str = "") -> int:
    """Assert that ``got`` (parsed strict JSON) is ``ref`` (the Python data) with every
    non-finite number replaced by None and every finite one unchanged; return how many
    non-finite numbers ``ref`` held."""
    if isinstance(ref, np.ndarray):
        ref = ref.tolist()
    if isinstance(ref, dict):
        assert isinstance(got, dict) and list(got) == list(ref), path
        return sum(compare(got[k], v, f"{path}.{k}") for k, v in ref.items())
    if isinstance(ref, (list, tuple)):
        assert isinstance(got, list) and len(got) == len(ref), path
        return sum(compare(g, r, f"{path}[{i}]") for i, (g, r) in
                   enumerate(zip(got, ref, strict=True)))
    if isinstance(ref, (float, np.floating)) and not math.isfinite(ref):
        assert got is None, f"{path}: {got!r} for {ref!r}"
        return 1
    assert got == ref and type(got) is type(json_ready(ref)), f"{path}: {got!r} != {ref!r}"
    return 0


# -- the shared function -------------------------------------------------------------------


def test_json_ready_nested_numpy_and_non_finite():
    data = {
        "a": [1.5, math.nan, (math.inf, -math.inf)],
        "b": {"c": np.float64(2.5), "d": np.float32(np.nan), "e": np.int64(7),
              "f": np.bool_(True), "g": np.float64(-np.inf)},
        "h": np.array([[1.0, np.nan], [np.inf, -2.0]]),
        "i": np.array([1, 2], dtype=np.int32),
        "j": np.array([True, False]),
        "k": (np.int8(-3), np.uint16(4)),
        "s": "NaN", "n": None, "t": True, "z": 0, "neg0": -0.0,
    }
    out = json_ready(data)
    assert out == {
        "a": [1.5, None, [None, None]],
        "b": {"c": 2.5, "d": None, "e": 7, "f": True, "g": None},
        "h": [[1.0, None], [None, -2.0]],
        "i": [1, 2],
        "j": [True, False],
        "k": [-3, 4],
        "s": "NaN", "n": None, "t": True, "z": 0, "neg0": -0.0,
    }
    # Python types only (json.dumps knows them), bools stay bools, counts stay ints.
    assert type(out["b"]["c"]) is float and type(out["b"]["e"]) is int
    assert type(out["b"]["f"]) is bool and type(out["t"]) is bool
    assert type(out["i"][0]) is int and type(out["j"][0]) is bool
    assert type(out["k"][0]) is int
    text = dumps(data)
    assert "NaN" not in text.replace('"NaN"', "") and "Infinity" not in text
    assert strict(text) == out
    assert compare(strict(text), data) == 7


def test_dumps_is_strict_and_passes_keywords():
    assert dumps({"x": [math.nan, 1.0]}, indent=1) == '{\n "x": [\n  null,\n  1.0\n ]\n}'
    assert dumps([math.inf, -math.inf]) == "[null, null]"
    assert dumps({"b": 1, "a": 2}, sort_keys=True) == '{"a": 2, "b": 1}'
    # Objects json cannot write are still an error, not silently dropped.
    with pytest.raises(TypeError):
        dumps({"x": object()})


def test_every_json_command_uses_the_shared_writer():
    from pelcs.commands import ac, continuation, lcs, orbit, sweep

    for module in (ac, continuation, lcs, orbit, sweep):
        assert module.dumps is dumps, module.__name__
        assert "json" not in vars(module), f"{module.__name__} imports json itself"


# -- commands on inputs that produce non-finite numbers ------------------------------------


@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_ac_json_zero_response_is_null(capsys):
    # v(in) is held by the DC source Vin: its response to Vc is exactly 0, -inf dB.
    from netlist.parser import parse_file
    from netlist.studies.ac import ac_analysis

    path = str(NETLISTS / "ac" / "buck_vc.cir")
    argv = ["ac", path, "--period", "ts", "--inject", "Vc", "--probe", "v(in),v(out)",
            "--freq", "100:10k:3", "--json"]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "warning" not in captured.err  # (-inf dB is the answer, not a numpy warning)
    got = strict(captured.out)
    ref = ac_analysis(parse_file(path), period="ts", inject="Vc", probes=["v(in)", "v(out)"],
                      freqs=np.logspace(2, 4, 3)).to_dict()
    assert compare(got, ref) == 3
    assert got["probes"]["v(in)"]["mag_db"] == [None, None, None]
    assert got["probes"]["v(in)"]["re"] == [0.0, 0.0, 0.0]
    assert all(isinstance(v, float) for v in got["probes"]["v(out)"]["mag_db"])


@pytest.mark.slow  # (over 0.4 s: outside the fast subset)
@pytest.mark.filterwarnings("error::RuntimeWarning")
def test_orbit_json_overflowed_residual_is_null(capsys):
    # Rn = -50 Ohm grows like exp(2.5e4 t): over T = 16.2 ms the state stays finite (the
    # simulation fails from about 16.5 ms) but P(x) - x divided by the state scale exceeds
    # the largest float at the start (the residual's norm is infinite there, and no numpy
    # warning is raised). Newton gives up (exit 3) and the report still prints, strict JSON
    # with the last iterate's residual (null if it is infinite).
    from lcs.analysis.orbits import find_orbit
    from netlist.studies.sweep import CircuitMapFactory

    path = str(NETLISTS / "sim" / "tunnel_nonpassive.cir")
    code = main(["orbit", path, "--period", "16.2m", "--transient", "0", "--json"])
    captured = capsys.readouterr()
    out = captured.out
    assert "overflow" not in captured.err
    assert code == 3
    got = strict(out)
    assert got["converged"] is False
    m = CircuitMapFactory(path=path, period=16.2e-3)()
    orbit = find_orbit(m, np.asarray(m.x0, dtype=float), 1, max_iter=0, restarts=())
    assert math.isinf(orbit.residual)  # at the start
    assert strict(dumps(orbit.to_dict()))["residual"] is None
    orbit = find_orbit(m, np.asarray(m.x0, dtype=float), 1)
    ref = {**orbit.to_dict(), "notes": list(m.notes) + list(orbit.notes)}  # as the CLI
    assert compare({k: got[k] for k in ref}, ref) == int(math.isinf(ref["residual"]))
    assert got["multipliers"] is None  # no orbit: no multipliers of its own


def test_overflowing_number_in_a_netlist_is_an_input_error(tmp_path, capsys):
    # A literal 1e999 used to read as inf (expressions and --param refused it) and reached
    # `pelcs lcs --json` as an infinite switch threshold: it is now the netlist's error, with
    # its place, like any invalid number.
    path = tmp_path / "never_on.cir"
    path.write_text("""Switch that never turns on
Vin in 0 DC 12
Vc con 0 DC 1
S1 in sw con 0 SWX
L1 sw out 10u
D1 0 sw DIDEAL
R1 out 0 10
.model SWX SW(VT=1e999 VH=0 RON=1m ROFF=1e9)
.model DIDEAL D
.end
""")
    assert main(["lcs", str(path), "--json"]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert f"{path}:8:18" in captured.err and "'1e999' is too large" in captured.err
    assert "Traceback" not in captured.err
