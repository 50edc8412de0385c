"""Close matches for a misspelt name: the "did you mean" of probes and options."""

from __future__ import annotations

import re
from collections.abc import Iterable


def close_matches(word: str, candidates: Iterable[str], n: int = 3) -> list[str]:
    """The candidates closest to ``word`` (difflib's ratio >= 0.6), best first.

    Compared without case and blanks (SPICE names ignore case; ``v( out )`` is ``v(out)``);
    returned as the candidates are spelt.
    """
    import difflib  # (only for a misspelt name: 1 ms of every start otherwise)

    spelt: dict[str, str] = {}
    for c in candidates:
        spelt.setdefault(_key(c), c)
    return [spelt[k] for k in difflib.get_close_matches(_key(word), list(spelt), n=n)]


def did_you_mean(word: str, candidates: Iterable[str]) -> str:
    """``"did you mean v(out)?"``, with the closest candidate; empty when none is close."""
    close = close_matches(word, candidates, n=1)
    return f"did you mean {close[0]}?" if close else ""


def _key(text: str) -> str:
    return re.sub(r"\s+", "", text).lower()


def short_list(names: Iterable[str], limit: int = 30) -> str:
    """``names`` joined by commas, the first ``limit`` of them and how many in all."""
    names = list(names)
    text = ", ".join(names[:limit])
    return text + (f", ... ({len(names)} in all)" if len(names) > limit else "")
