"""Limits on what an input may cost: bytes of a netlist file, elements of the expanded
circuit, steps and result memory of a run.

Each limit is checked before the work it bounds (a size estimated, not discovered by running
out of memory) and is named, with its environment variable, in the error: a larger job is a
``PELCS_MAX_...=`` away. Values accept SI suffixes: ``k``, ``M`` (mega), ``G``, ``T``.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass

__all__ = ["Limit", "FILE_BYTES", "ELEMENTS", "DENSE_UNKNOWNS", "STEPS", "MEMORY",
           "available_memory"]

_SI = {"": 1.0, "k": 1e3, "K": 1e3, "M": 1e6, "G": 1e9, "T": 1e12}
_VALUE = re.compile(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([kKMGT]?)[bB]?\s*")


@dataclass(frozen=True)
class Limit:
    """One limit: its environment variable, default and what it bounds.

    Attributes
    ----------
    env : str
        The environment variable that overrides it (``PELCS_MAX_STEPS``).
    default : float
        The value without the variable (for :data:`MEMORY`: 0, meaning the memory available
        now, :func:`available_memory`).
    what : str
        What it counts, for messages (``"time steps"``).
    """

    env: str
    default: float
    what: str

    def value(self) -> float:
        """The limit in force: the environment variable if set and valid, else the default.

        Raises
        ------
        ValueError
            For a variable that is not a positive number (with an SI suffix).
        """
        text = os.environ.get(self.env, "").strip()
        if not text:
            return self.default if self.default > 0 else available_memory()
        m = _VALUE.fullmatch(text)
        if m is None or not float(m.group(1)) > 0:
            raise ValueError(f"{self.env}={text!r} is not a positive number (e.g. 2G, 5e6)")
        return float(m.group(1)) * _SI[m.group(2)]

    def allows(self, amount: float) -> bool:
        """Whether ``amount`` is within the limit: :meth:`value`, except that an amount
        under the floor of :func:`available_memory` needs no look at the memory available
        (a run's check: 40 us for ``/proc/meminfo``).

        Raises
        ------
        ValueError
            As :meth:`value`.
        """
        if (self.default <= 0 and amount <= MIN_AVAILABLE
                and not os.environ.get(self.env, "").strip()):
            return True
        return amount <= self.value()

    def hint(self, example: str) -> str:
        """``raise it with PELCS_MAX_STEPS=2e9 (the limit on time steps)``."""
        return f"to allow more, set the environment variable {self.env} (e.g. {self.env}=" \
               f"{example}; the limit on {self.what})"


#: Bytes of one netlist file (the top one or an include): netlists are text of a few MB at
#: most; more is a wrong file (``.include /dev/zero`` reached 22 GB in 5 s).
FILE_BYTES = Limit("PELCS_MAX_FILE_BYTES", 64e6, "the bytes of a netlist file")
#: Elements of the circuit once its subcircuits are expanded (counted before expanding: a
#: few nested instances can ask for 2^25).
ELEMENTS = Limit("PELCS_MAX_ELEMENTS", 1e5, "the elements of the expanded circuit")
#: Unknowns of a network whose matrix is singular or ill-conditioned, past which its dense
#: rank-revealing decomposition (an SVD, cubic: 1.1 s at 2048 unknowns, 100 s for a mode of
#: 4096 measured while fuzzing) is refused; a regular network of any size takes a sparse LU.
DENSE_UNKNOWNS = Limit("PELCS_MAX_DENSE_UNKNOWNS", 2000,
                       "the unknowns of a singular network's dense decomposition")
#: Time steps of a run.
STEPS = Limit("PELCS_MAX_STEPS", 1e9, "the time steps of a run")
#: Bytes of the results a run stores (default: the memory available when it starts).
MEMORY = Limit("PELCS_MAX_MEMORY", 0.0, "the memory of a run's stored results")


#: The least :func:`available_memory` returns, bytes.
MIN_AVAILABLE = 256e6


def available_memory() -> float:
    """Bytes of memory available now (``MemAvailable`` of ``/proc/meminfo``; elsewhere the
    physical memory), at least :data:`MIN_AVAILABLE`."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return max(float(line.split()[1]) * 1024.0, MIN_AVAILABLE)
    except OSError:
        pass
    try:
        return max(float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")),
                   MIN_AVAILABLE)
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return 8e9
