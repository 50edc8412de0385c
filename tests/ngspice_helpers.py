"""ngspice run side by side with pelcs in the tests, in its pipe mode (``ngspice -p``): the
values of expressions (``print``) and the waveforms of probes (``wrdata``).

Each run gets ``HOME`` set to the test's temporary folder, so that no ``~/.spiceinit`` of the
machine changes what ngspice does.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import pytest

from ngspice_checks.availability import REQUIRE_ENV

__all__ = ["ngspice_executable", "ngspice_print", "ngspice_run", "ngspice_wrdata"]


def ngspice_executable() -> str:
    """The path of the ngspice program; skips the test when there is none, or fails it under
    ``PELCS_REQUIRE_NGSPICE=1`` (as the ``ngspice`` fixture does for the shared library)."""
    exe = shutil.which("ngspice")
    if exe is None:
        message = "NGSPICE MISSING - no ngspice program on PATH: its cross-checks not run"
        if os.environ.get(REQUIRE_ENV) == "1":
            pytest.fail(f"{message} ({REQUIRE_ENV}=1 requires ngspice)", pytrace=False)
        pytest.skip(message)
    return exe


def _pipe(commands: str, cwd: Path, home: Path, timeout: float) -> subprocess.CompletedProcess:
    return subprocess.run([ngspice_executable(), "-p"], input=commands, cwd=cwd,
                          capture_output=True, text=True, timeout=timeout,
                          env={"HOME": str(home), "PATH": os.environ.get("PATH", "/usr/bin")})


def ngspice_print(deck: str, expressions: list[str], tmp: Path, files: dict | None = None
                  ) -> dict[str, float]:
    """Run ``deck`` in ngspice (``run``), print each expression; their values (``files``:
    ``{name: text}`` written beside the deck, for its includes)."""
    for name, text in (files or {}).items():
        (tmp / name).write_text(text)
    (tmp / "deck.cir").write_text(deck)
    commands = "source deck.cir\nrun\n" + "".join(f"print {e}\n" for e in expressions) + "quit\n"
    r = _pipe(commands, tmp, tmp, 60)
    out = {}
    for line in r.stdout.splitlines():
        if " = " in line:
            key, _, value = line.partition(" = ")
            try:
                out[key.strip().lower()] = float(value.split()[0])
            except ValueError:
                pass
    missing = [e for e in expressions if e.lower() not in out]
    assert not missing, r.stdout[-2000:] + r.stderr[-2000:]
    return {e: out[e.lower()] for e in expressions}


def ngspice_dc_voltages(devices: str, currents: Sequence[float], tmp: Path) -> np.ndarray:
    """ngspice's operating point ``v(a)`` (V) with each of ``currents`` (A) driven into node
    ``a`` by a current source from ground; ``devices``: the deck's other lines (the devices
    from ``a`` to ground and their models), one deck per current in a folder of ``tmp``."""
    out = []
    for k, current in enumerate(currents):
        sub = tmp / f"dc{k}"
        sub.mkdir()
        deck = f"* at {current} A\nI1 0 a DC {current}\n{devices}.op\n.end\n"
        out.append(ngspice_print(deck, ["v(a)"], sub)["v(a)"])
    return np.array(out)


def ngspice_run(deck: str | Path, probes: Sequence[str], tmp: Path, timeout: float = 120, *,
                before: Sequence[str] = ()) -> tuple[np.ndarray | None, str]:
    """Run a deck in ngspice (``run``, the commands ``before``, then ``wrdata`` of the
    ``probes``): the rows written, shape (N, 2 len(probes)) (time and value per probe), or
    None when ngspice wrote none; and what ngspice printed.

    ``deck``: the netlist's text (written to ``tmp/deck.cir``) or a netlist file (sourced
    from its own folder, where its includes are).
    """
    if isinstance(deck, Path):
        path = deck
    else:
        path = tmp / "deck.cir"
        path.write_text(deck)
    out = tmp / "out.txt"
    out.unlink(missing_ok=True)  # (a file of an earlier run is not this run's)
    commands = "".join(f"{c}\n" for c in (f"source {path.name}", "run", *before,
                                         f"wrdata {out} {' '.join(probes)}", "quit"))
    r = _pipe(commands, path.parent, tmp, timeout)
    data = np.loadtxt(out, ndmin=2) if out.exists() else None
    return data, r.stdout + r.stderr


def ngspice_wrdata(deck: str | Path, probes: Sequence[str], tmp: Path, timeout: float = 120,
                   *, before: Sequence[str] = ()) -> np.ndarray:
    """:func:`ngspice_run`'s rows, which ngspice must have written."""
    data, log = ngspice_run(deck, probes, tmp, timeout, before=before)
    assert data is not None, log
    return data
