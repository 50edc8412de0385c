"""Every code block of the README and of ``docs/`` runs, so that the guide cannot drift.

The blocks are the fenced ```` ```sh ```` and ```` ```python ```` blocks of ``README.md`` and
``docs/*.md``. Python blocks run as scripts; shell blocks hold ``pelcs`` commands (or
``.venv/bin/pelcs``), each run as ``python -m pelcs.cli ...`` and expected to exit with 0. Both
run in a fresh process whose working directory is a temporary folder holding the checkout's
netlist folders (``converters/netlists``, ``tests/netlists``, as links), so the documented
relative paths work and the files the commands write (``out/...``) land in the temporary
folder. A block that cannot run here (one that installs packages, one that needs a Dask
cluster) is marked in the Markdown by an HTML comment on the line before its fence,
``<!-- not run: REASON -->``; :data:`NOT_RUN` lists the reasons allowed. ``<!-- slow -->``
marks a block with pytest's ``slow`` marker. Other fences must say ``text`` (output,
synopses, formulas), so that no code block escapes the test by having no language.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

# (the slow part of the suite: outside the fast subset that `-m 'not slow'` selects)
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
RUN = ("sh", "python")
OTHER = ("text",)
# The reasons a block may be left out, and at most how many blocks each: a short list, so
# that leaving a block out stays the exception.
NOT_RUN = {"installs packages": 2, "needs a Dask cluster": 2, "regenerates the gallery": 1,
           "runs for minutes": 2}
# Folders of the checkout the documented commands read, linked into the working folder.
DATA = ("converters/netlists", "tests/netlists")
TIMEOUT = 600.0


@dataclass(frozen=True)
class Block:
    page: Path
    line: int           # of the opening fence, 1-based
    lang: str
    text: str
    marks: tuple[str, ...]   # the HTML comments on the line before the fence

    @property
    def id(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"

    def not_run(self) -> str | None:
        for m in self.marks:
            if m.startswith("not run:"):
                return m.removeprefix("not run:").strip()
        return None


FENCE = re.compile(r"^(\s*)```(\S*)\s*$")
COMMENT = re.compile(r"^\s*<!--\s*(.*?)\s*-->\s*$")


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of a Markdown page, with the HTML comments just before each."""
    lines = page.read_text(encoding="utf-8").splitlines()
    out, i = [], 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if not m:
            i += 1
            continue
        indent, lang, start = m.group(1), m.group(2), i
        j = i + 1
        while j < len(lines) and not FENCE.match(lines[j]):
            j += 1
        body = [ln[len(indent):] if ln.startswith(indent) else ln for ln in lines[i + 1:j]]
        marks, k = [], start - 1
        while k >= 0 and COMMENT.match(lines[k]):
            marks.append(COMMENT.match(lines[k]).group(1))
            k -= 1
        out.append(Block(page, start + 1, lang, "\n".join(body) + "\n", tuple(marks)))
        i = j + 1
    return out


ALL = [b for p in PAGES for b in blocks(p)]
RUNNABLE = [b for b in ALL if b.lang in RUN and b.not_run() is None]


def commands(text: str) -> list[list[str]]:
    """The commands of a shell block: continuation lines joined, comments dropped."""
    joined = re.sub(r"\\\n", " ", text)
    return [args for line in joined.splitlines() if (args := shlex.split(line, comments=True))]


@pytest.fixture
def workdir(tmp_path: Path) -> Path:
    work = tmp_path / "work"
    for rel in DATA:
        (work / rel).parent.mkdir(parents=True, exist_ok=True)
        (work / rel).symlink_to(ROOT / rel, target_is_directory=True)
    return work


def _env() -> dict[str, str]:
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    return {**os.environ, "PYTHONPATH": path, "MPLBACKEND": "Agg"}


def _run(argv: list[str], cwd: Path, what: str) -> None:
    proc = subprocess.run(argv, cwd=cwd, env=_env(), capture_output=True, text=True,
                          timeout=TIMEOUT)
    assert proc.returncode == 0, (f"{what} exited with {proc.returncode}\n"
                                  f"stdout:\n{proc.stdout[-3000:]}\nstderr:\n{proc.stderr[-3000:]}")


def _params():
    for b in RUNNABLE:
        marks = [pytest.mark.slow] if "slow" in b.marks else []
        yield pytest.param(b, id=b.id, marks=marks)


@pytest.mark.parametrize("block", list(_params()))
def test_block_runs(block: Block, workdir: Path, request) -> None:
    if block.lang == "python":
        script = workdir.parent / "block.py"
        script.write_text(block.text, encoding="utf-8")
        _run([sys.executable, str(script)], workdir, f"{block.id} (python)")
        return
    cmds = commands(block.text)
    assert cmds, f"{block.id}: an empty shell block"
    for args in cmds:
        assert Path(args[0]).name == "pelcs", (
            f"{block.id}: a shell block runs pelcs commands only ({args[0]!r}); mark a block "
            "that cannot run here with <!-- not run: REASON --> (reasons: "
            f"{', '.join(NOT_RUN)})")
        if args[1:2] == ["check"]:
            request.getfixturevalue("ngspice")
        _run([sys.executable, "-m", "pelcs.cli", *args[1:]], workdir, f"{block.id}: {args}")


def test_fences_have_a_known_language() -> None:
    odd = [f"{b.id}: ```{b.lang}" for b in ALL if b.lang not in RUN + OTHER]
    assert not odd, "fences must say sh, python or text:\n" + "\n".join(odd)


def test_blocks_left_out_are_few_and_say_why() -> None:
    counts: dict[str, int] = {}
    for b in ALL:
        reason = b.not_run()
        if reason is None:
            continue
        assert reason in NOT_RUN, f"{b.id}: not run for an unlisted reason {reason!r}"
        counts[reason] = counts.get(reason, 0) + 1
    over = {r: n for r, n in counts.items() if n > NOT_RUN[r]}
    assert not over, f"more blocks left out than allowed: {over}"
    assert len(RUNNABLE) >= 15


def test_images_and_links_exist() -> None:
    """Every figure and every relative link of the README and the pages points at a file."""
    missing = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", text):
            if "://" in target or target.startswith("mailto:"):
                continue
            if not (page.parent / target).exists():
                missing.append(f"{page.relative_to(ROOT)}: {target}")
    assert not missing, "\n".join(missing)
