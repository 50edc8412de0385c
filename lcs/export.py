"""Export of LCS modes: python-control ``StateSpace``, plain dicts (JSON) and ``.npz`` files.

* :func:`lcs_to_statespace` — one mode as a python-control ``StateSpace`` with inputs
  ``[λ, u]`` and outputs ``[w, probes]``, every signal named (states ``i(L1)``, ``v(C1)``;
  λ and w labelled by :class:`lcs.model.ComplementarityPair`, e.g. ``i(D1)`` / ``-v(D1)``;
  sources ``Vin``; probes ``v(out)``). The complementarity ``0 <= w ⊥ λ >= 0`` is not part of
  a ``StateSpace``: it is the linear part to be closed by the caller.
* :func:`lcs_to_dict` / :func:`lcs_from_dict`, :func:`output_map_to_dict` /
  :func:`output_map_from_dict`, :func:`switched_to_dict` / :func:`switched_from_dict` — plain
  dicts of lists, strings, numbers and booleans (``json.dumps`` works on them), with a
  ``"format"`` tag and a ``"version"``.
* :func:`to_arrays` / :func:`load_npz` — matrices as arrays, names and structure as a JSON
  string (loadable with ``allow_pickle=False``); the application writes the ``.npz`` file
  (:func:`pelcs.writers.write_lcs_npz`).

A switched system is exported mode by mode (all ``2**k`` switch configurations unless told
otherwise); the loaded :class:`SwitchedLCS` serves the stored modes and the stored probes.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable, Sequence

import numpy as np

from lcs.model import (
    LCS,
    ComplementarityPair,
    ModeKey,
    ModeModel,
    OutputMap,
    SwitchControl,
    SwitchedLCS,
)

__all__ = [
    "FORMAT_VERSION",
    "lcs_to_statespace",
    "switched_to_statespaces",
    "lcs_to_dict",
    "lcs_from_dict",
    "output_map_to_dict",
    "output_map_from_dict",
    "switched_to_dict",
    "switched_from_dict",
    "to_arrays",
    "load_npz",
]

FORMAT_VERSION = 1
_LCS_TAG = "pelcs.lcs"
_SWITCHED_TAG = "pelcs.switched_lcs"
_MATS = ("A", "B", "C", "D", "E", "F")


# --------------------------------------------------------------------------------------------
# python-control


def _unique(names: Sequence[str]) -> list[str]:
    """Make signal names unique (python-control requires it) by suffixing ``#2``, ``#3``."""
    seen: dict[str, int] = {}
    out = []
    for nm in names:
        if nm in seen:
            seen[nm] += 1
            out.append(f"{nm}#{seen[nm]}")
        else:
            seen[nm] = 1
            out.append(nm)
    return out


def lcs_to_statespace(lcs: LCS, output: OutputMap | None = None, name: str | None = None):
    """One mode as a named python-control ``StateSpace``.

    ``x' = A x + [B E] [λ; u]``, ``[w; y] = [C; Cy] x + [[D, F], [Dy, Fy]] [λ; u]``.

    Parameters
    ----------
    lcs : LCS
        Shapes A (n, n), B (n, m), C (m, n), D (m, m), E (n, p), F (m, p).
    output : OutputMap, optional
        Probes ``y = Cy x + Dy λ + Fy u`` (q outputs) appended after w.
    name : str, optional
        System name.

    Returns
    -------
    control.StateSpace
        n states, m + p inputs, m + q outputs, signals named as described in the module
        docstring (duplicates get a ``#k`` suffix).
    """
    import control as ct

    n, m, p = lcs.n, lcs.m, lcs.p
    Bfull = np.hstack([lcs.B, lcs.E]).reshape(n, m + p)
    Cfull = lcs.C.reshape(m, n)
    Dfull = np.hstack([lcs.D, lcs.F]).reshape(m, m + p)
    out_names = [pr.w_label for pr in lcs.pairs]
    if output is not None:
        q = len(output.names)
        Cy = np.asarray(output.Cy, dtype=float).reshape(q, n)
        Dy = np.asarray(output.Dy, dtype=float).reshape(q, m)
        Fy = np.asarray(output.Fy, dtype=float).reshape(q, p)
        Cfull = np.vstack([Cfull, Cy])
        Dfull = np.vstack([Dfull, np.hstack([Dy, Fy]).reshape(q, m + p)])
        out_names += list(output.names)
    in_names = [pr.lambda_label for pr in lcs.pairs] + list(lcs.inputs)
    kwargs = {}
    if name is not None:
        kwargs["name"] = name
    return ct.ss(
        lcs.A, Bfull, Cfull, Dfull,
        states=_unique(list(lcs.states)), inputs=_unique(in_names),
        outputs=_unique(out_names), **kwargs,
    )


def _mode_name(slcs: SwitchedLCS, key: ModeKey) -> str:
    if not slcs.switches:
        return "mode"
    return "mode " + ",".join(
        f"{s.name}={'on' if on else 'off'}" for s, on in zip(slcs.switches, key, strict=True)
    )


def switched_to_statespaces(
    slcs: SwitchedLCS, probes: Sequence[str] = (), modes: Iterable | None = None
) -> dict[ModeKey, object]:
    """Every (or the given) mode of a switched LCS as a named ``StateSpace``.

    Parameters
    ----------
    slcs : SwitchedLCS
    probes : sequence of str
        Probe names for the extra outputs (e.g. ``"v(out)"``).
    modes : iterable, optional
        Mode keys or configuration dicts; all ``2**k`` when omitted.

    Returns
    -------
    dict
        Mode key -> ``control.StateSpace`` named ``"mode S1=on"`` etc.
    """
    keys = slcs.all_keys() if modes is None else [slcs.key(k) for k in modes]
    out = {}
    for key in keys:
        om = slcs.outputs(key, probes) if probes else None
        out[key] = lcs_to_statespace(slcs.mode(key), om, _mode_name(slcs, key))
    return out


# --------------------------------------------------------------------------------------------
# Plain dicts


def _mat(a: np.ndarray) -> list:
    return np.asarray(a, dtype=float).tolist()


def lcs_to_dict(lcs: LCS) -> dict:
    """A JSON-serialisable dict of one LCS (names, pair types, matrices as nested lists)."""
    d = {
        "format": _LCS_TAG,
        "version": FORMAT_VERSION,
        "states": list(lcs.states),
        "pairs": [{"name": p.name, "lam": p.lam} for p in lcs.pairs],
        "inputs": list(lcs.inputs),
    }
    for key in _MATS:
        d[key] = _mat(getattr(lcs, key))
    return d


def _check_tag(d: dict, tag: str) -> None:
    if d.get("format") != tag:
        raise ValueError(f"not a {tag} dict (format = {d.get('format')!r})")
    if int(d.get("version", -1)) > FORMAT_VERSION:
        raise ValueError(f"{tag} version {d.get('version')} is newer than {FORMAT_VERSION}")


def lcs_from_dict(d: dict) -> LCS:
    """Inverse of :func:`lcs_to_dict`."""
    _check_tag(d, _LCS_TAG)
    states = tuple(d["states"])
    pairs = tuple(ComplementarityPair(p["name"], p.get("lam", "current")) for p in d["pairs"])
    inputs = tuple(d["inputs"])
    n, m, p = len(states), len(pairs), len(inputs)
    shapes = {"A": (n, n), "B": (n, m), "C": (m, n), "D": (m, m), "E": (n, p), "F": (m, p)}
    mats = {k: np.asarray(d[k], dtype=float).reshape(shapes[k]) for k in _MATS}
    return LCS(**mats, states=states, pairs=pairs, inputs=inputs)


def output_map_to_dict(om: OutputMap) -> dict:
    """A JSON-serialisable dict of an :class:`OutputMap`."""
    return {"names": list(om.names), "Cy": _mat(om.Cy), "Dy": _mat(om.Dy), "Fy": _mat(om.Fy)}


def output_map_from_dict(d: dict, n: int, m: int, p: int) -> OutputMap:
    """Inverse of :func:`output_map_to_dict` for n states, m pairs, p inputs."""
    names = tuple(d["names"])
    q = len(names)
    return OutputMap(
        names,
        np.asarray(d["Cy"], dtype=float).reshape(q, n),
        np.asarray(d["Dy"], dtype=float).reshape(q, m),
        np.asarray(d["Fy"], dtype=float).reshape(q, p),
    )


def switched_to_dict(
    slcs: SwitchedLCS, probes: Sequence[str] = (), modes: Iterable | None = None
) -> dict:
    """A JSON-serialisable dict of a switched LCS: switches, names and the listed modes.

    Parameters
    ----------
    slcs : SwitchedLCS
    probes : sequence of str
        Probes whose output maps are stored with every mode.
    modes : iterable, optional
        Mode keys or configuration dicts to store; all ``2**k`` when omitted.

    Returns
    -------
    dict
    """
    keys = slcs.all_keys() if modes is None else [slcs.key(k) for k in modes]
    mode_list = []
    for key in keys:
        entry = {"key": [bool(v) for v in key], "lcs": lcs_to_dict(slcs.mode(key))}
        if probes:
            entry["outputs"] = output_map_to_dict(slcs.outputs(key, probes))
        mode_list.append(entry)
    return {
        "format": _SWITCHED_TAG,
        "version": FORMAT_VERSION,
        "switches": [
            {"name": s.name, "control": s.control, "vt": float(s.vt), "vh": float(s.vh),
             "options": dict(s.options)}
            for s in slcs.switches
        ],
        "states": list(slcs.states),
        "inputs": list(slcs.inputs),
        "diodes": list(slcs.diodes),
        "probes": list(probes),
        "modes": mode_list,
    }


def switched_from_dict(d: dict) -> SwitchedLCS:
    """Inverse of :func:`switched_to_dict`.

    The returned system serves only the stored modes (``KeyError`` for others) and, per mode,
    any subset of the stored probes.
    """
    _check_tag(d, _SWITCHED_TAG)
    switches = [
        SwitchControl(s["name"], s["control"], float(s.get("vt", 0.0)), float(s.get("vh", 0.0)),
                      dict(s.get("options", {})))
        for s in d["switches"]
    ]
    stored: dict[ModeKey, tuple[LCS, OutputMap | None]] = {}
    for entry in d["modes"]:
        lcs = lcs_from_dict(entry["lcs"])
        om = (output_map_from_dict(entry["outputs"], lcs.n, lcs.m, lcs.p)
              if entry.get("outputs") is not None else None)
        stored[tuple(bool(v) for v in entry["key"])] = (lcs, om)

    def builder(key: ModeKey) -> ModeModel:
        if key not in stored:
            raise KeyError(f"mode {key} was not exported")
        lcs, om = stored[key]

        def output(probes: Sequence[str]) -> OutputMap:
            if om is None:
                raise KeyError("no probes were exported")
            idx = []
            for pr in probes:
                if pr not in om.names:
                    raise KeyError(f"probe {pr!r} was not exported; have {', '.join(om.names)}")
                idx.append(om.names.index(pr))
            return OutputMap(tuple(probes), om.Cy[idx], om.Dy[idx], om.Fy[idx])

        return ModeModel(lcs, output)

    return SwitchedLCS(switches, d["states"], d["inputs"], d["diodes"], builder)


# --------------------------------------------------------------------------------------------
# .npz


def _split_arrays(d: dict, prefix: str, arrays: dict) -> dict:
    """Move the matrices of an LCS dict into ``arrays`` (keys prefixed), return the rest."""
    rest = {k: v for k, v in d.items() if k not in _MATS}
    for k in _MATS:
        arrays[f"{prefix}{k}"] = np.asarray(d[k], dtype=float)
    return rest


def to_arrays(obj: LCS | SwitchedLCS, probes: Sequence[str] = (),
              modes: Iterable | None = None) -> dict[str, np.ndarray]:
    """The arrays of an LCS or a switched LCS's ``.npz`` file.

    Matrices are float arrays (``A``, ``B``... or ``mode3/A``...), everything else one JSON
    string under ``meta``; :func:`load_npz` reads the file with ``allow_pickle=False``.

    Parameters
    ----------
    obj : LCS or SwitchedLCS
    probes, modes :
        As in :func:`switched_to_dict` (ignored for a single LCS).
    """
    arrays: dict[str, np.ndarray] = {}
    if isinstance(obj, LCS):
        meta = _split_arrays(lcs_to_dict(obj), "", arrays)
    elif isinstance(obj, SwitchedLCS):
        meta = switched_to_dict(obj, probes, modes)
        for j, entry in enumerate(meta["modes"]):
            entry["lcs"] = _split_arrays(entry["lcs"], f"mode{j}/", arrays)
            if "outputs" in entry:
                for k in ("Cy", "Dy", "Fy"):
                    arrays[f"mode{j}/{k}"] = np.asarray(entry["outputs"].pop(k), dtype=float)
    else:
        raise TypeError(f"cannot save {type(obj).__name__}")
    arrays["meta"] = np.array(json.dumps(meta))
    return arrays


def load_npz(path: str | os.PathLike) -> LCS | SwitchedLCS:
    """Load what :func:`pelcs.writers.write_lcs_npz` wrote (the arrays of :func:`to_arrays`)."""
    with np.load(path, allow_pickle=False) as data:
        meta = json.loads(str(data["meta"]))
        if meta.get("format") == _LCS_TAG:
            for k in _MATS:
                meta[k] = data[k]
            return lcs_from_dict(meta)
        if meta.get("format") == _SWITCHED_TAG:
            for j, entry in enumerate(meta["modes"]):
                for k in _MATS:
                    entry["lcs"][k] = data[f"mode{j}/{k}"]
                if "outputs" in entry:
                    for k in ("Cy", "Dy", "Fy"):
                        entry["outputs"][k] = data[f"mode{j}/{k}"]
            return switched_from_dict(meta)
    raise ValueError(f"{path}: unknown format {meta.get('format')!r}")
