"""Bit-for-bit fingerprints of every simulation result the test suite makes (a pytest plugin).

A refactoring of the simulation core must leave every number unchanged. Run the suite once
before and once after the change with this plugin, then compare the two files::

    PELCS_FINGERPRINT=/tmp/before.json .venv/bin/python -m pytest -q -p benchmarks.fingerprint
    PELCS_FINGERPRINT=/tmp/after.json  .venv/bin/python -m pytest -q -p benchmarks.fingerprint
    .venv/bin/python -m benchmarks.fingerprint /tmp/before.json /tmp/after.json

Every :class:`lcs.results.SimulationResult` built in the test process is hashed when it is
created (times, probes, final state and multipliers, events, counters), keyed by the test
and the order of creation within it. ``-0.0`` and ``0.0`` hash alike (a sum that adds a zero
term in another order may flip the sign of a zero, which is not a difference). Results made in
worker processes (parallel bifurcation diagrams) or subprocesses are not seen.
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
from collections import defaultdict

import numpy as np

_RECORDS: dict[str, list[str]] = defaultdict(list)
_CURRENT = ["(collection)"]


def _digest(res) -> str:
    h = hashlib.sha256()
    for arr in (res.t, res.y, res.x_final, res.lambda_final):
        a = np.ascontiguousarray(np.asarray(arr, dtype=float)) + 0.0
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    h.update(repr([(float(t), tuple(m)) for t, m in res.events]).encode())
    h.update(repr(res.sliding).encode())
    st = res.stats
    h.update(repr((st.steps, st.odd_steps, st.fallbacks, st.located,
                   st.sliding_steps)).encode())
    h.update(repr(res.error.kind if res.error is not None else None).encode())
    return h.hexdigest()[:16]


def pytest_configure(config):  # noqa: D103
    path = os.environ.get("PELCS_FINGERPRINT")
    if not path:
        return
    from lcs.results import SimulationResult

    original = SimulationResult.__init__

    def init(self, *args, **kwargs):
        original(self, *args, **kwargs)
        _RECORDS[_CURRENT[0]].append(_digest(self))

    SimulationResult.__init__ = init


def pytest_runtest_setup(item):  # noqa: D103
    _CURRENT[0] = item.nodeid


def pytest_unconfigure(config):  # noqa: D103
    path = os.environ.get("PELCS_FINGERPRINT")
    if path:
        with open(path, "w") as fh:
            json.dump(_RECORDS, fh, indent=0, sort_keys=True)


def compare(before: str, after: str) -> int:
    """Print the tests whose results differ; return the number of differences."""
    with open(before) as fh:
        a = json.load(fh)
    with open(after) as fh:
        b = json.load(fh)
    diff = 0
    for test in sorted(set(a) | set(b)):
        if a.get(test) != b.get(test):
            diff += 1
            print(f"DIFFERS {test}: {len(a.get(test, []))} vs {len(b.get(test, []))} results")
    total = sum(len(v) for v in a.values())
    print(f"{total} results in {len(a)} tests before, {sum(len(v) for v in b.values())} after; "
          f"{diff} tests differ")
    return diff


if __name__ == "__main__":
    sys.exit(1 if compare(sys.argv[1], sys.argv[2]) else 0)
