"""Export: named python-control StateSpace, dict/JSON and .npz round trips."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lcs.export import (
    lcs_from_dict,
    lcs_to_dict,
    lcs_to_statespace,
    load_npz,
    switched_from_dict,
    switched_to_dict,
    switched_to_statespaces,
)
from lcs.model import LCS, ModeModel, OutputMap, SwitchControl, SwitchedLCS
from lcs.model import ComplementarityPair as Pair
from pelcs.writers import write_lcs_npz

L, C, R = 100e-6, 470e-6, 10.0


def boost_mode(on: bool) -> LCS:
    if on:  # switch closed: λ = i(D1), w = v(C1)
        return LCS([[0, 0], [0, -1 / (R * C)]], [[0], [1 / C]], [[0, 1]], [[0]],
                   [[1 / L], [0]], [[0]], ("i(L1)", "v(C1)"), (Pair("D1"),), ("Vin",))
    return LCS([[0, -1 / L], [1 / C, -1 / (R * C)]], [[1 / L], [0]], [[1, 0]], [[0]],
               [[1 / L], [0]], [[0]], ("i(L1)", "v(C1)"), (Pair("D1", "voltage"),), ("Vin",))


def boost_output(on: bool, probes) -> OutputMap:
    # v(out) = v(C1); v(sw) = 0 when on, v(C1) - λ when off (λ = reverse voltage); i(L1).
    rows = {
        "v(out)": ([0, 1], [0], [0]),
        "v(sw)": ([0, 0], [0], [0]) if on else ([0, 1], [-1], [0]),
        "i(L1)": ([1, 0], [0], [0]),
    }
    Cy, Dy, Fy = (np.array([rows[p][k] for p in probes], dtype=float).reshape(len(probes), -1)
                  for k in range(3))
    return OutputMap(tuple(probes), Cy, Dy, Fy)


def boost_switched() -> SwitchedLCS:
    def builder(key):
        on = key[0]
        return ModeModel(boost_mode(on), lambda probes: boost_output(on, probes))

    return SwitchedLCS([SwitchControl("S1", "v(gate)", 2.5, 0.1, {"ron": 0.0})],
                       ("i(L1)", "v(C1)"), ("Vin",), ("D1",), builder)


def assert_same_lcs(a: LCS, b: LCS) -> None:
    for k in "ABCDEF":
        np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    assert a.states == b.states and a.pairs == b.pairs and a.inputs == b.inputs


def test_statespace_blocks_and_names():
    lcs = boost_mode(False)
    om = boost_output(False, ["v(out)", "v(sw)"])
    ss = lcs_to_statespace(lcs, om, name="boost off")
    assert ss.name == "boost off"
    assert ss.state_labels == ["i(L1)", "v(C1)"]
    assert ss.input_labels == ["-v(D1)", "Vin"]  # λ = reverse voltage, then the source
    assert ss.output_labels == ["i(D1)", "v(out)", "v(sw)"]
    np.testing.assert_array_equal(ss.A, lcs.A)
    np.testing.assert_array_equal(ss.B, [[1 / L, 1 / L], [0, 0]])
    np.testing.assert_array_equal(ss.C, [[1, 0], [0, 1], [0, 1]])
    np.testing.assert_array_equal(ss.D, [[0, 0], [0, 0], [-1, 0]])


def test_statespace_response_matches_hand_solution():
    # Switch closed, Vin = 1 V step, λ = 0: i(L1)(t) = t / L; check through python-control.
    import control as ct

    ss = lcs_to_statespace(boost_mode(True), boost_output(True, ["i(L1)"]))
    t = np.linspace(0, 1e-4, 11)
    u = np.vstack([np.zeros_like(t), np.ones_like(t)])  # [λ, Vin]
    resp = ct.forced_response(ss, t, u)
    iL = resp.outputs[ss.output_labels.index("i(L1)")]
    np.testing.assert_allclose(iL, t / L, rtol=1e-6, atol=1e-9)


def test_statespace_without_pairs_or_inputs_and_duplicate_names():
    lcs = LCS([[-1.0]], np.zeros((1, 0)), np.zeros((0, 1)), np.zeros((0, 0)), [[1.0]],
              np.zeros((0, 1)), ("v(C1)",), (), ("Vin",))
    om = OutputMap(("v(C1)", "v(C1)"), np.array([[1.0], [2.0]]), np.zeros((2, 0)),
                   np.zeros((2, 1)))
    ss = lcs_to_statespace(lcs, om)
    assert ss.input_labels == ["Vin"]
    assert ss.output_labels == ["v(C1)", "v(C1)#2"]


def test_dict_round_trip_through_json():
    lcs = boost_mode(False)
    d = lcs_to_dict(lcs)
    text = json.dumps(d)
    back = lcs_from_dict(json.loads(text))
    assert_same_lcs(lcs, back)
    assert d["pairs"] == [{"name": "D1", "lam": "voltage"}]
    assert d["format"] == "pelcs.lcs" and d["version"] == 1


def test_dict_rejects_other_formats():
    with pytest.raises(ValueError):
        lcs_from_dict({"format": "something else"})
    d = lcs_to_dict(boost_mode(True))
    d["version"] = 99
    with pytest.raises(ValueError):
        lcs_from_dict(d)


def test_empty_dimensions_round_trip(tmp_path):
    lcs = LCS(np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((2, 0)), np.eye(2), np.zeros((0, 0)),
              np.zeros((2, 0)), (), (Pair("D1"), Pair("D2", "voltage")), ())
    assert_same_lcs(lcs, lcs_from_dict(json.loads(json.dumps(lcs_to_dict(lcs)))))
    write_lcs_npz(tmp_path / "e.npz", lcs)
    assert_same_lcs(lcs, load_npz(tmp_path / "e.npz"))


def test_npz_round_trip_lcs(tmp_path):
    lcs = boost_mode(True)
    path = tmp_path / "mode.npz"
    write_lcs_npz(path, lcs)
    with np.load(path, allow_pickle=False) as data:
        assert {"A", "B", "C", "D", "E", "F", "meta"} <= set(data.files)
    assert_same_lcs(lcs, load_npz(path))


def test_switched_dict_round_trip():
    sw = boost_switched()
    d = switched_to_dict(sw, probes=["v(out)", "v(sw)"])
    back = switched_from_dict(json.loads(json.dumps(d)))
    assert back.switches == sw.switches
    assert back.states == sw.states and back.inputs == sw.inputs and back.diodes == sw.diodes
    for key in sw.all_keys():
        assert_same_lcs(sw.mode(key), back.mode(key))
        a, b = sw.outputs(key, ["v(sw)"]), back.outputs(key, ["v(sw)"])
        assert a.names == b.names
        for k in ("Cy", "Dy", "Fy"):
            np.testing.assert_array_equal(getattr(a, k), getattr(b, k))
    with pytest.raises(KeyError):
        back.outputs((True,), ["i(L1)"])  # not exported


def test_switched_npz_round_trip(tmp_path):
    sw = boost_switched()
    path = tmp_path / "boost.npz"
    write_lcs_npz(path, sw, probes=["v(out)"], modes=[{"S1": True}])
    back = load_npz(path)
    assert isinstance(back, SwitchedLCS)
    assert_same_lcs(sw.mode({"S1": True}), back.mode({"S1": True}))
    with pytest.raises(KeyError):
        back.mode({"S1": False})  # only the on-mode was saved
    np.testing.assert_array_equal(back.outputs((True,), ["v(out)"]).Cy, [[0, 1]])


def test_switched_statespaces_named_by_mode():
    sss = switched_to_statespaces(boost_switched(), probes=["v(out)"])
    assert set(sss) == {(False,), (True,)}
    assert sss[(True,)].name == "mode S1=on"
    assert sss[(False,)].input_labels == ["-v(D1)", "Vin"]
    assert sss[(True,)].input_labels == ["i(D1)", "Vin"]
    assert sss[(True,)].output_labels == ["-v(D1)", "v(out)"]
