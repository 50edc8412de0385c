"""Strict JSON for the commands' ``--json`` output.

``json.dumps`` writes NaN, infinities as ``NaN``, ``Infinity`` and ``-Infinity``, which are
not JSON: jq, JavaScript's ``JSON.parse`` and other strict parsers reject the whole document.
Every ``--json`` of the CLI goes through :func:`dumps`, which writes them as ``null``.
"""

from __future__ import annotations

import json

import numpy as np

__all__ = ["dumps", "json_ready"]


def json_ready(value):
    """``value`` with NaN and infinities as None, numpy scalars and arrays as Python numbers
    and lists, tuples as lists; dicts and lists are walked recursively, anything else (str,
    None, ...) is returned as it is."""
    if isinstance(value, dict):
        return {k: json_ready(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_ready(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_ready(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    return value


def dumps(obj, **kw) -> str:
    """``json.dumps`` of :func:`json_ready` ``(obj)``, strict (``allow_nan=False``); keywords
    (``indent``, ...) go to ``json.dumps``."""
    return json.dumps(json_ready(obj), allow_nan=False, **kw)
