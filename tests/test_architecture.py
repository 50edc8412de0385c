"""The layering of docs/architecture.md, checked on the source: no import cycles between
modules, ``lcs`` imports nothing of ``netlist``/``pelcs``/``ngspice_checks``, ``netlist``
nothing of ``pelcs``/``ngspice_checks``, the core of ``netlist`` (language, circuit,
formulation) nothing of its studies ``netlist.studies``, ``ngspice_checks`` nothing of
``pelcs``, nothing imports the CLI but ``python -m pelcs`` (only the Python API's analyses
use its commands' parsers and computing functions), ``lcs`` draws nothing (no matplotlib,
no figure helpers), ``lcs`` and ``netlist`` write no file (results are written by
``pelcs.writers``), no kernel module imports the build tools ``lcs.build``, and no code module
is over 800 lines; no function is over the complexity cap, and no compiled function takes
more than 13 arguments (the kernels' arguments travel in named tuples).

Imports are read statically (every ``import`` statement, also those inside functions: a lazy
import is still a dependency).
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

# (the project's rules stay in the fast subset; one xdist group, so that the modules are
# parsed once, by one worker)
pytestmark = pytest.mark.xdist_group("architecture")

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("lcs", "netlist", "pelcs", "ngspice_checks", "converters")
MAX_LINES = 800


@functools.cache
def _modules() -> dict[str, Path]:
    out = {}
    for pkg in PACKAGES:
        for path in (ROOT / pkg).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            out[name] = path
    return out


def _imports(name: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """Modules of ours that ``name`` imports (submodule granularity)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    is_pkg = path.name == "__init__.py"
    base = name.split(".") if is_pkg else name.split(".")[:-1]
    found: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                stem = base[: len(base) - node.level + 1]
                mod = ".".join(stem + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            targets = [f"{mod}.{a.name}" for a in node.names] + [mod]
        else:
            continue
        for t in targets:
            while t and t not in modules:
                t = t.rpartition(".")[0]
            if t and t != name:
                found.add(t)
    return found


@functools.cache
def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(name, path, modules) for name, path in modules.items()}


def _is_package_init(name: str, target: str) -> bool:
    # "from . import x" inside a package, or a package's __init__ re-exporting its own
    # modules, is how packages are built, not a dependency cycle between concepts.
    return target == name.rpartition(".")[0] or name == target.rpartition(".")[0]


def test_no_import_cycles():
    graph = {k: {t for t in v if not _is_package_init(k, t)} for k, v in _graph().items()}
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            strong(v)
    assert not cycles, f"import cycles: {cycles}"


#: The modules of the Python API that run the commands' analyses with the commands' own
#: option parsers and computing functions (one copy of each, for both front ends).
API_ANALYSES = ("pelcs.api_analyses", "pelcs.api_options", "pelcs.api_results")

FORBIDDEN = {
    "lcs": ("netlist", "pelcs", "ngspice_checks", "converters"),
    "netlist": ("pelcs", "ngspice_checks"),
    "ngspice_checks": ("pelcs",),
}


def test_layers():
    bad = []
    for name, targets in _graph().items():
        top = name.split(".")[0]
        for t in targets:
            if t.split(".")[0] in FORBIDDEN.get(top, ()):
                bad.append(f"{name} -> {t}")
            if t == "pelcs.cli" and name not in ("pelcs.cli", "pelcs.__main__"):
                bad.append(f"{name} -> {t} (nothing imports the CLI)")
            if t.startswith("pelcs.commands") and not name.startswith(
                    ("pelcs.cli", "pelcs.commands", *API_ANALYSES)):
                bad.append(f"{name} -> {t} (only the CLI and the Python API's analyses "
                           "use the commands)")
    assert not bad, "layering violations:\n" + "\n".join(sorted(bad))


#: Libraries that draw: the mathematics (``lcs``) imports none of them, and holds no module of
#: figure helpers (axis labels, units written for people); figures are the application's
#: (``pelcs``), the numbers with units ``netlist.units``'.
DRAWING = ("matplotlib",)
PRESENTATION_IN_LCS = ("lcs.axes", "lcs.units_format")


def drawing_imports(source: str) -> list[str]:
    """The modules of :data:`DRAWING` that ``source`` imports (lazy imports included)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            found.append(node.module or "")
    return sorted(m for m in found if m.split(".")[0] in DRAWING)


def test_the_mathematics_draws_nothing():
    bad = sorted(f"{name} -> {m}" for name, path in _modules().items() if _in(name, "lcs")
                 for m in drawing_imports(path.read_text(encoding="utf-8")))
    assert not bad, ("lcs imports a drawing library (figures belong to pelcs):\n"
                     + "\n".join(bad))
    left = [m for m in PRESENTATION_IN_LCS if m in _modules()]
    assert not left, f"presentation modules in lcs: {left} (pelcs.figures, netlist.units)"


def test_drawing_imports_finds_an_import():
    # The rule must be able to fail: a lazy import inside a function counts, and so does a
    # plain one; another library, a relative import or a name that only starts alike do not.
    code = ("import numpy as np\n"
            "import matplotlib.pyplot as plt\n"
            "from . import matplotlib_like\n"
            "import matplotlibish\n"
            "def f():\n"
            "    from matplotlib.figure import Figure\n")
    assert drawing_imports(code) == ["matplotlib.figure", "matplotlib.pyplot"]


#: What writes a file: modules imported for writing, and functions and methods that write.
#: Result files are the application's (``pelcs.writers.write_table``); the mathematics and the
#: language give plain data (``columns()``, ``arrays()``) and write none.
WRITING_MODULES = ("csv", "zipfile")
WRITING_CALLS = ("savez", "savez_compressed", "savetxt", "save", "tofile", "to_csv",
                 "to_parquet", "to_npz", "write_text", "write_bytes", "write_table",
                 "write_arrays", "atomic_path")
#: The files ``lcs`` and ``netlist`` may write, none of them a result: ``atomic_path`` itself
#: (below ``ngspice_checks`` and the parser cache, which may not import ``pelcs``), the build
#: tools' compiler logs and compiled module, the stand-alone parser's cache.
WRITES_ALLOWED = ("lcs.atomic", "lcs.build", "netlist.lark_standalone")
_WRITE_FLAGS = ("O_WRONLY", "O_RDWR", "O_CREAT", "O_APPEND", "O_TRUNC")


def file_writes(source: str) -> list[str]:
    """What in ``source`` writes a file (see :data:`WRITING_MODULES`, :data:`WRITING_CALLS`;
    ``open`` or ``os.open`` with a mode or flags that write)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            found += [f"import {a.name}" for a in node.names
                      if a.name.split(".")[0] in WRITING_MODULES]
        elif isinstance(node, ast.ImportFrom) and not node.level:
            if (node.module or "").split(".")[0] in WRITING_MODULES:
                found.append(f"from {node.module} import")
        elif isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
            if name in WRITING_CALLS:
                found.append(f"{name}()")
            elif name == "open":
                mode = node.args[1] if len(node.args) > 1 else next(
                    (k.value for k in node.keywords if k.arg in ("mode", "flags")), None)
                if mode is None:
                    continue
                text = ast.unparse(mode)
                # (a mode string that writes, flags that write, a mode not spelled out)
                if (any(c in mode.value for c in "wax+") if isinstance(mode, ast.Constant)
                        else "O_" not in text or any(f in text for f in _WRITE_FLAGS)):
                    found.append(f"open(..., {text})")
    return found


def test_the_mathematics_and_the_language_write_no_file():
    bad = sorted(f"{name}: {w}" for name, path in _modules().items()
                 if (_in(name, "lcs") or _in(name, "netlist"))
                 and not any(_in(name, a) for a in WRITES_ALLOWED)
                 for w in file_writes(path.read_text(encoding="utf-8")))
    assert not bad, ("lcs or netlist writes a file (results are written by pelcs.writers; "
                     "give the data as columns() or arrays()):\n" + "\n".join(bad))


def test_file_writes_finds_a_write():
    # The rule must be able to fail: every way of writing is reported, lazy ones too; reading
    # a file, numpy's load, a name that only starts alike are not.
    code = ("import csv\n"
            "import numpy as np\n"
            "from zipfile import ZipFile\n"
            "import csvkit_like\n"
            "def f(path, x):\n"
            "    np.savez_compressed(path, x=x)\n"
            "    open(path, 'w').write('x')\n"
            "    open(path, mode='ab')\n"
            "    open(path).read(); open(path, 'rb'); np.load(path)\n"
            "    path.write_text('x'); path.read_text()\n"
            "    with atomic_path(path) as tmp: pass\n"
            "    os.open(path, os.O_RDONLY | getattr(os, 'O_BINARY', 0))\n"
            "    os.open(path, os.O_WRONLY | os.O_CREAT)\n")
    assert sorted(file_writes(code)) == sorted([
        "import csv", "from zipfile import", "savez_compressed()", "open(..., 'w')",
        "open(..., 'ab')", "write_text()", "atomic_path()",
        "open(..., os.O_WRONLY | os.O_CREAT)"])


#: The sub-package of ``netlist`` that runs integrators and analyses on a circuit; the rest of
#: ``netlist`` is what those studies start from and never imports them.
STUDIES = "netlist.studies"


def _in(name: str, package: str) -> bool:
    return name == package or name.startswith(package + ".")


def core_imports_studies(graph: dict[str, set[str]]) -> list[str]:
    """Imports of ``netlist.studies`` by a module of ``netlist`` outside it."""
    return sorted(f"{name} -> {t}" for name, targets in graph.items()
                  if _in(name, "netlist") and not _in(name, STUDIES)
                  for t in targets if _in(t, STUDIES))


def test_netlist_core_never_imports_its_studies():
    bad = core_imports_studies(_graph())
    assert not bad, ("the core of netlist imports its studies (netlist.studies runs on the "
                     "core, not the reverse):\n" + "\n".join(bad))


def test_core_imports_studies_finds_an_edge():
    # The rule above must be able to fail: a core module importing a study, directly or
    # through the sub-package, is reported; a study importing the core or another study is not.
    graph = {
        "netlist.formulation": {"netlist.circuit"},
        "netlist.parser": {"netlist.studies.transient"},
        "netlist": {"netlist.studies"},
        "netlist.studies.sweep": {"netlist.parser", "netlist.studies.transient"},
        "netlist.studiesque": {"netlist.circuit"},
    }
    assert core_imports_studies(graph) == [
        "netlist -> netlist.studies", "netlist.parser -> netlist.studies.transient"]
    assert STUDIES in _modules()


#: The build machinery of the kernels (export table and stamp, the ahead-of-time module, the
#: first use after an installation, the warm-up): it imports the kernels, no kernel imports it.
BUILD = "lcs.build"
#: The packages of the integrators, their kernels and the driver common to them.
KERNEL_PACKAGES = ("lcs.integrators", "lcs.lcp", "lcs.simulation")


def kernels_importing_build(graph: dict[str, set[str]]) -> list[str]:
    """Imports of ``lcs.build`` by a module of an integrator, the LCP solvers or the driver."""
    return sorted(f"{name} -> {t}" for name, targets in graph.items()
                  if any(_in(name, pkg) for pkg in KERNEL_PACKAGES)
                  for t in targets if _in(t, BUILD))


def test_no_kernel_imports_the_build_tools():
    bad = kernels_importing_build(_graph())
    assert not bad, ("a kernel module imports the build tools (lcs.build imports the kernels, "
                     "not the reverse):\n" + "\n".join(bad))
    assert BUILD in _modules()


def test_kernels_importing_build_finds_an_edge():
    # The rule must be able to fail: a kernel module importing a build tool is reported (also
    # a lazy import, read like any other); the build tools importing the kernels are not.
    graph = {
        "lcs.simulation.driver": {"lcs.build.kernels"},
        "lcs.lcp.compiled": {"lcs.jit"},
        "lcs.build.warmup": {"lcs.integrators.moreau.dense.grid", "lcs.lcp.compiled"},
        "lcs.buildings": {"lcs.build"},
    }
    assert kernels_importing_build(graph) == ["lcs.simulation.driver -> lcs.build.kernels"]


def test_module_sizes():
    big = {str(p.relative_to(ROOT)): n for p in _modules().values()
           if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES}
    assert not big, f"modules over {MAX_LINES} lines: {big}"


#: Cyclomatic complexity (McCabe) a function may have, and the compiled kernels allowed more:
#: their loops are inlined into one function on purpose (a call per step would cost more
#: than the step; docs/performance.md).
MAX_COMPLEXITY = 40
COMPLEX_KERNELS = frozenset({"lcs.integrators.moreau.dense.grid.run_grid"})

def _statements(stmts) -> int:
    """McCabe's decision points of a block of statements, as ruff's C901 and PyCQA's mccabe
    count them: each if/elif, loop (and its else), except handler, try's else and match case;
    a nested function counts one and its body (a class its body); expressions count
    nothing."""
    n = 0
    for st in stmts:
        if isinstance(st, ast.If):
            n += 1 + _statements(st.body)
            orelse = st.orelse
            # (an elif is an If alone in the else block)
            while len(orelse) == 1 and isinstance(orelse[0], ast.If):
                n += 1 + _statements(orelse[0].body)
                orelse = orelse[0].orelse
            n += _statements(orelse)
        elif isinstance(st, ast.For | ast.AsyncFor | ast.While):
            n += 1 + _statements(st.body) + _statements(st.orelse)
        elif isinstance(st, ast.With | ast.AsyncWith):
            n += _statements(st.body)
        elif isinstance(st, ast.Match):
            n += sum(1 + _statements(case.body) for case in st.cases)
        elif isinstance(st, ast.Try):
            n += (_statements(st.body) + (1 if st.orelse else 0) + _statements(st.orelse)
                  + _statements(st.finalbody)
                  + sum(1 + _statements(h.body) for h in st.handlers))
        elif isinstance(st, ast.FunctionDef | ast.AsyncFunctionDef):
            n += 1 + _statements(st.body)
        elif isinstance(st, ast.ClassDef):
            n += _statements(st.body)
    return n


def complexity(func: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Cyclomatic complexity of ``func``: 1 + its decision points (:func:`_statements`)."""
    return 1 + _statements(func.body)


def _functions(name: str, path: Path):
    """``(qualified name, function node)`` of every function of a module."""
    out = []

    def walk(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                out.append((f"{prefix}.{child.name}", child))
                walk(child, f"{prefix}.{child.name}")
            elif isinstance(child, ast.ClassDef):
                walk(child, f"{prefix}.{child.name}")

    walk(ast.parse(path.read_text(encoding="utf-8")), name)
    return out


def test_complexity_cap():
    seen, over = set(), {}
    for name, path in _modules().items():
        for qual, func in _functions(name, path):
            seen.add(qual)
            if (c := complexity(func)) > MAX_COMPLEXITY and qual not in COMPLEX_KERNELS:
                over[qual] = c
    assert not over, f"functions over complexity {MAX_COMPLEXITY}: {over} (split them)"
    assert COMPLEX_KERNELS <= seen  # (the allowed kernels still exist under these names)


def test_complexity_counts_decisions():
    code = ("def f(x, ys):\n"
            "    if x and ys or not x:\n"
            "        return [y for y in ys if y]\n"
            "    elif x is None:\n"
            "        pass\n"
            "    for y in ys:\n"
            "        while y:\n"
            "            y -= 1\n"
            "    try:\n"
            "        pass\n"
            "    except ValueError:\n"
            "        pass\n"
            "    def g():\n"
            "        if x:\n"
            "            pass\n"
            "    return 1 if x else 2\n")
    (f,) = ast.parse(code).body
    # 1 + if + elif + for + while + except + the nested function and its if (expressions:
    # nothing)
    assert complexity(f) == 1 + 1 + 1 + 1 + 1 + 1 + 2


#: Arguments a compiled function (``@kernel``, ``@inline``, ``@jitted``) may take: the rest
#: travel in named tuples (lcs.integrators.moreau.dense.layout and the tuples of the modules
#: that define the functions).
MAX_KERNEL_ARGS = 13


def _compiled(func: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    """Whether ``func`` is decorated as a compiled function of :mod:`lcs.jit`."""
    for dec in func.decorator_list:
        target = dec.func if isinstance(dec, ast.Call) else dec
        if isinstance(target, ast.Name) and target.id in ("kernel", "inline", "jitted"):
            return True
    return False


def test_kernel_argument_cap():
    wide = {}
    for name, path in _modules().items():
        if not name.startswith("lcs."):
            continue
        for qual, func in _functions(name, path):
            n = len(func.args.args)
            if _compiled(func) and n > MAX_KERNEL_ARGS:
                wide[qual] = n
    assert not wide, (f"compiled functions over {MAX_KERNEL_ARGS} arguments: {wide} (group the "
                      "arguments that travel together in named tuples, as "
                      "lcs.integrators.moreau.dense.layout does)")
