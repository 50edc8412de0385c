"""Every code block of the README and of ``docs/`` runs, so that the guide cannot drift.

The blocks are the fenced ```` ```sh ```` and ```` ```python ```` blocks of ``README.md`` and
``docs/*.md``. Python blocks run as scripts; shell blocks hold ``pelcs`` commands (or
``.venv/bin/pelcs``), each run as ``pelcs.cli.main(...)`` and expected to exit with 0. Both
run in a process of their own whose working directory is a temporary folder holding the
checkout's netlist folders (``converters/netlists``, ``tests/netlists``, as links), so the
documented relative paths work and the files the commands write (``out/...``) land in the
temporary folder. The process is forked from the test's, in which pelcs, matplotlib and the
compiled kernels were loaded once (a fresh interpreter spends 2-3 s of every block on those
imports); its stdout and stderr go to a file, its exit status is the block's. A block that
cannot run here (one that installs packages, one that needs a Dask cluster) is marked in the
Markdown by an HTML comment on the line before its fence, ``<!-- not run: REASON -->``;
:data:`NOT_RUN` lists the reasons allowed. ``<!-- slow -->`` marks a block with pytest's
``slow`` marker. Other fences must say ``text`` (output, synopses, formulas), so that no code
block escapes the test by having no language.
"""

from __future__ import annotations

import contextlib
import io
import multiprocessing
import os
import re
import runpy
import shlex
import sys
import warnings
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
    return {"PYTHONPATH": path, "MPLBACKEND": "Agg"}


@pytest.fixture(scope="module")
def warm(tmp_path_factory) -> None:
    """Load in this process what the blocks' forked processes would each import: every
    command's modules, matplotlib and the kernels (by a short run with a plot, its output
    discarded: a failure here is left to the blocks to show)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401

    import pelcs.cli

    pelcs.cli.build_parser([])
    out = tmp_path_factory.mktemp("warm")
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            pelcs.cli.main(["simulate", str(ROOT / "converters/netlists/buck.cir"),
                            "--tstop", "0.2m", "-o", str(out / "w.csv"),
                            "--plot", str(out / "w.png")])
        except Exception:
            pass


def _child(target, cwd: Path, log: Path) -> None:
    """In the forked process: stdout and stderr (the descriptors, for anything the block
    starts too) to ``log``, the working folder and environment of a fresh run, Python's
    default warning filters (not the test's), then the block."""
    fd = os.open(log, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)
    sys.stdout = open(1, "w", encoding="utf-8", errors="backslashreplace", closefd=False)
    sys.stderr = open(2, "w", encoding="utf-8", errors="backslashreplace", closefd=False)
    os.chdir(cwd)
    os.environ.update(_env())
    warnings.resetwarnings()
    for action, category in (("default", DeprecationWarning), ("ignore", DeprecationWarning),
                             ("ignore", PendingDeprecationWarning), ("ignore", ImportWarning),
                             ("ignore", ResourceWarning)):
        warnings.filterwarnings(action, category=category,
                                module="__main__" if action == "default" else "",
                                append=True)
    target()


def _run(target, cwd: Path, what: str) -> None:
    log = cwd.parent / "output.txt"
    proc = multiprocessing.get_context("fork").Process(target=_child,
                                                       args=(target, cwd, log))
    proc.start()
    proc.join(TIMEOUT)
    if proc.exitcode is None:
        proc.kill()
        proc.join()
        pytest.fail(f"{what} did not finish in {TIMEOUT:.0f} s")
    output = log.read_text(encoding="utf-8", errors="replace") if log.exists() else ""
    assert proc.exitcode == 0, f"{what} exited with {proc.exitcode}\noutput:\n{output[-6000:]}"


def _script(path: Path):
    def run() -> None:
        sys.argv = [str(path)]
        sys.path.insert(0, str(path.parent))
        runpy.run_path(str(path), run_name="__main__")
    return run


def _command(args: list[str]):
    def run() -> None:
        import pelcs.cli

        sys.argv = [pelcs.cli.__file__, *args]
        sys.exit(pelcs.cli.main(args))
    return run


def _params():
    for b in RUNNABLE:
        marks = [pytest.mark.slow] if "slow" in b.marks else []
        yield pytest.param(b, id=b.id, marks=marks)


@pytest.mark.parametrize("block", list(_params()))
def test_block_runs(block: Block, workdir: Path, warm, request) -> None:
    if block.lang == "python":
        script = workdir.parent / "block.py"
        script.write_text(block.text, encoding="utf-8")
        _run(_script(script), workdir, f"{block.id} (python)")
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
        _run(_command(args[1:]), workdir, f"{block.id}: {args}")


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
