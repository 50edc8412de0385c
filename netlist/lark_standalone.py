"""lark's stand-alone LALR parser of ``grammar.lark``: the netlist parser without importing lark.

Importing lark and loading its cached tables takes about 26 ms of CPU (lark's package imports
its grammar compiler, its Earley and CYK parsers, tempfile and hashlib); lark's stand-alone
parser (``lark.tools.standalone``: lark's runtime and the grammar's tables in one module)
takes about 15 ms, so a 100-step command starts 10 % sooner. The stand-alone code is
generated on this machine from the installed lark the first time it is needed (about 0.3 s,
once), compiled and kept in the cache directory (``$PELCS_CACHE_DIR``, else
``netlist/__pycache__``), keyed on the grammar's text, the start rules, lark's version and
Python's; it is not part of pelcs' sources (lark issues it under the Mozilla Public License).

Importing this module executes that code in this module's namespace, so the parser's classes
(``Lark_StandAlone``, ``Token``, ``Tree``, ``UnexpectedInput``...) are attributes of
``netlist.lark_standalone`` and pickle by that name. :data:`AVAILABLE` is False, and nothing
else is defined, where the code cannot be generated (a lark without the stand-alone tool) or
``PELCS_LARK_STANDALONE=0``; :mod:`netlist.expressions` then uses lark itself, as the same
grammar and start rules give the same trees and errors.
"""

from __future__ import annotations
import __future__

import marshal
import os
import sys
from pathlib import Path
from types import CodeType

GRAMMAR_FILE = Path(__file__).with_name("grammar.lark")

# Start rules of grammar.lark: one per statement shape, and the expression rule.
START_RULES = [
    "passive", "source", "diode", "switch", "device", "vcontrolled", "ccontrolled", "coupling",
    "instance", "param_cmd", "subckt_cmd", "ends_cmd", "model_cmd", "ic_cmd", "tran_cmd",
    "step_cmd", "options_cmd", "include_cmd", "lib_cmd", "global_cmd", "expression",
]

#: Bumped when what is cached changes.
_FORMAT = 2
_CACHE_NAME = "grammar.lark-standalone"


def cache_dir() -> Path | None:
    """The directory of the grammar's caches: the first of :func:`lcs.build.kernels.cache_roots`
    for ``netlist/__pycache__`` that can be written (created if missing); None when none can.
    """
    from lcs.build.kernels import cache_roots

    for root in cache_roots(GRAMMAR_FILE.with_name("__pycache__")):
        try:
            root.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(root, os.W_OK):
            return root
    return None


def _lark_version() -> str:
    """The installed lark's version, read from its ``__init__.py`` without importing it."""
    from importlib.machinery import PathFinder

    spec = PathFinder.find_spec("lark")
    if spec is None or spec.origin is None:
        return ""
    for line in Path(spec.origin).read_text(encoding="utf-8").splitlines():
        if line.startswith("__version__"):
            return line.partition("=")[2].strip().strip("'\"")
    return ""


def _generate(grammar: str) -> CodeType:
    """Compile lark's stand-alone parser of ``grammar`` (imports lark; about 0.3 s)."""
    import io

    from lark import Lark
    from lark.tools.standalone import gen_standalone

    parser = Lark(grammar, parser="lalr", lexer="contextual", start=START_RULES,
                  maybe_placeholders=False)
    out = io.StringIO()
    gen_standalone(parser, out=out)
    # With postponed annotations (PEP 563): lark's type annotations (typing's generics, some
    # 300 of them) stay strings instead of being built at every start; nothing in lark reads
    # them at run time.
    return compile(out.getvalue(), "<lark stand-alone parser of netlist/grammar.lark>", "exec",
                   flags=__future__.annotations.compiler_flag, dont_inherit=True)


def _code() -> CodeType:
    """The stand-alone parser's code: from the cache when it was made for this grammar, lark
    and Python, else generated (and cached where the directory is writable)."""
    grammar = GRAMMAR_FILE.read_text(encoding="utf-8")
    key = (_FORMAT, grammar, tuple(START_RULES), _lark_version(), sys.version)
    root = cache_dir()
    path = root / _CACHE_NAME if root is not None else None
    if path is not None:
        try:
            cached_key, code = marshal.loads(path.read_bytes())
            if cached_key == key and isinstance(code, CodeType):
                return code
        except (OSError, ValueError, EOFError, TypeError):
            pass  # missing or unreadable (another Python, a torn write): made again
    code = _generate(grammar)
    if path is not None:
        from lcs.atomic import atomic_path

        try:
            with atomic_path(path) as tmp:  # (whole or not at all, also for a concurrent reader)
                tmp.write_bytes(marshal.dumps((key, code)))
        except OSError:
            pass  # not cached: generated again at the next start
    return code


AVAILABLE = False
if os.environ.get("PELCS_LARK_STANDALONE", "1") != "0":
    try:
        _stand_alone = _code()
    except Exception:  # noqa: BLE001 - any failure of the generator: lark itself parses
        _stand_alone = None
    if _stand_alone is not None:
        exec(_stand_alone, globals())  # the parser's definitions, as a module of their own
        AVAILABLE = True
