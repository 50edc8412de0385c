"""Fuzzing: mutated netlists and random bytes either parse or raise NetlistError, nothing else.

A NetlistError must also be well-formed: at least one diagnostic, each with a message, and a
location (when there is one) whose line exists in the input.
"""

from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.writer import write_circuit

# (the slow part of the suite: outside the fast subset that `-m 'not slow'` selects)
pytestmark = pytest.mark.slow

SEEDS = [
    (Path(__file__).parent / "netlists" / "cuk_coupled.cir").read_text(),
    """mutation seed: everything in one file
.param vin=12 fs={1/ts} ts=20u duty=0.4
.subckt cell d s g params: r=1m
S1 d s g 0 SWM ON
D1 s d DM
Rs d s {r*1k}
.ends cell
Vin in 0 DC {vin} AC 1
L1 in sw 100u IC=0.1
X1 sw 0 gate cell params: r=2m
D2 sw out DM
C1 out 0 100u IC=0
R1 out 0 {vin**2/10}
K1 L1 L2 0.5
L2 aux 0 10u
Raux aux 0 1
E1 e 0 out 0 0.1
Re e 0 1k
G1 0 g out 0 1m
Rg g 0 1k
Vs out m 0
Rm m 0 1Meg
F1 0 f Vs 2
Rf f 0 1
H1 h 0 Vs 3
Rh h 0 1
I1 0 out SIN(0 1m 1k)
Vg gate 0 PULSE(0 1 0 10n 10n {duty*ts} {ts})
+ ; continued
Vp p 0 PWL(0 0 1u 1) $ comment
Rp p 0 1
Ve x 0 EXP(0 1 1u 1u 2u 1u)
Rx x 0 1
.model SWM SW(VT=0.5 VH=0.1)
.model DM D(IS=1n)
.ic v(out)=1 v(in)=12
.tran 0.1u 1m 0 0.1u UIC
.options reltol=1e-4
.print tran v(out)
.control
run
.endc
.end
""",
]

_TOKEN_CHARS = st.sampled_from(list("(){}=,'\"+-*/^.;$ \t\nabcxyz019kmuMEG") + ["\x00", "\xb5"])


def _check(text: str) -> None:
    try:
        circuit = parse_string(text, file="fuzz.cir")
    except NetlistError as exc:
        assert exc.diagnostics
        n_lines = len(text.split("\n"))
        for d in exc.diagnostics:
            assert d.message and "\n" not in d.message
            if d.location is not None and d.location.file == "fuzz.cir":
                assert 1 <= d.location.line <= n_lines
                assert d.location.column >= 1
        assert exc.format()
    else:
        # whatever parses must also write back and parse again to the same circuit
        again = parse_string(write_circuit(circuit), file="fuzz.cir")
        assert again == circuit


@st.composite
def mutated(draw):
    text = draw(st.sampled_from(SEEDS))
    lines = text.split("\n")
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["del_line", "dup_line", "swap_lines", "del_token",
                                   "dup_token", "swap_tokens", "insert_char", "replace_char"]))
        i = draw(st.integers(0, len(lines) - 1))
        j = draw(st.integers(0, len(lines) - 1))
        if op == "del_line" and len(lines) > 1:
            del lines[i]
        elif op == "dup_line":
            lines.insert(j, lines[i])
        elif op == "swap_lines":
            lines[i], lines[j] = lines[j], lines[i]
        else:
            toks = lines[i].split(" ")
            k = draw(st.integers(0, len(toks) - 1))
            m = draw(st.integers(0, len(toks) - 1))
            if op == "del_token":
                del toks[k]
            elif op == "dup_token":
                toks.insert(m, toks[k])
            elif op == "swap_tokens":
                toks[k], toks[m] = toks[m], toks[k]
            else:
                line = " ".join(toks)
                pos = draw(st.integers(0, len(line)))
                ch = draw(_TOKEN_CHARS)
                if op == "insert_char":
                    line = line[:pos] + ch + line[pos:]
                else:
                    line = line[:pos] + ch + line[pos + 1:]
                toks = [line]
            lines[i] = " ".join(toks)
    return "\n".join(lines)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_netlists_raise_only_netlist_error(text):
    _check(text)


@settings(max_examples=100, deadline=None)
@given(st.text(alphabet=_TOKEN_CHARS, max_size=200))
def test_random_text_raises_only_netlist_error(text):
    _check("title\n" + text)


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=300))
def test_random_bytes_raise_only_netlist_error(tmp_path_factory, data):
    p = tmp_path_factory.mktemp("fuzz") / "random.cir"
    p.write_bytes(data)
    try:
        parse_file(p)
    except NetlistError as exc:
        assert exc.diagnostics and exc.format()


def test_seeds_are_valid_netlists():
    # mutations must start from netlists that parse, so that the round trip above is exercised
    assert [len(parse_string(s).elements) for s in SEEDS] == [14, 27]


# -- the commands on mutated netlists ---------------------------------------------------------
#
# A seeded mutator over the bundled and test netlists (numbers, lines, nodes, unicode and
# bytes, includes, subcircuits); ``info``, ``lcs`` and ``simulate`` run in process on each
# mutant and must exit 0, 2 or 3 with no exception escaping, within a bounded time. The fixed
# sample below runs in CI; a long run: PELCS_FUZZ_CASES=5000 (and PELCS_FUZZ_SEED=N for other
# mutants) pytest tests/test_netlist_fuzz.py -k commands.

import os  # noqa: E402
import random  # noqa: E402
import re  # noqa: E402
import signal  # noqa: E402
import time  # noqa: E402

_ROOT = Path(__file__).resolve().parents[1]
_CORPUS = sorted([*(_ROOT / "converters" / "netlists").glob("*.cir"),
                  *(_ROOT / "tests" / "netlists").rglob("*.cir")])
_CASES = int(os.environ.get("PELCS_FUZZ_CASES", "60"))
_SEED = int(os.environ.get("PELCS_FUZZ_SEED", "0"))
# Seconds a command may take on a mutant (runs are also bounded by PELCS_MAX_STEPS below).
_BUDGET = float(os.environ.get("PELCS_FUZZ_BUDGET", "20"))

_NUMBER = re.compile(r"(?<![A-Za-z_])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?[a-zA-Z]*")
_ODD_NUMBERS = ["0", "-1", "1e308", "1e-308", "nan", "inf", "-0", "1e30", "1e-30", "1meg",
                "1e", ".", "99999999999999999999", "1e-15", "1T", "1f", "{1/0}", "{-1}"]
_ODD_TEXT = ["µ", "\u202e", "\ufeff", "\x00", "é", "😀", "\t", "\r", "+", "*", "$", ";", "(",
             ")", "{", "}", "=", ",", "'", '"']
_ODD_BYTES = [b"\xff", b"\xc3", b"\x80\x80", b"\xed\xa0\x80"]


def _includes(tmp: Path) -> list[str]:
    return [".include /dev/zero", f".include {tmp}", f".include {tmp / 'missing.inc'}",
            f".include {tmp / 'self.cir'}", f".include {_CORPUS[0]}", ".lib /dev/null x",
            f".include {tmp / 'big.inc'}"]


def _blow_up(levels: int) -> list[str]:
    lines = [".subckt fz0 a b", "R1 a b 1", ".ends"]
    for i in range(1, levels + 1):
        lines += [f".subckt fz{i} a b", f"X1 a m fz{i - 1}", f"X2 m b fz{i - 1}", ".ends"]
    return [*lines, f"Xfz in 0 fz{levels}"]


def _mutate(text: str, rng: random.Random, tmp: Path) -> bytes:
    """One mutant of a netlist: 1 to 4 random edits; bytes, since some edits are not text."""
    lines = text.split("\n")
    nodes = sorted({tok for line in lines[1:] if line[:1].isalpha()
                    for tok in line.split()[1:3]}) or ["0"]
    raw: list[bytes] = []
    for _ in range(rng.randint(1, 4)):
        i = rng.randrange(len(lines))
        op = rng.choice(["number", "number", "del_line", "dup_line", "swap_lines", "node",
                         "char", "bytes", "include", "subckt", "recursive", "repeat"])
        if op == "number":
            found = list(_NUMBER.finditer(lines[i]))
            if found:
                m = rng.choice(found)
                lines[i] = lines[i][:m.start()] + rng.choice(_ODD_NUMBERS) + lines[i][m.end():]
        elif op == "del_line" and len(lines) > 1:
            del lines[i]
        elif op == "dup_line":
            lines.insert(rng.randrange(len(lines)), lines[i])
        elif op == "swap_lines":
            j = rng.randrange(len(lines))
            lines[i], lines[j] = lines[j], lines[i]
        elif op == "node":
            toks = lines[i].split(" ")
            if len(toks) > 2:
                toks[rng.randint(1, 2)] = rng.choice([*nodes, "0", "gnd", "new_node", "ü"])
                lines[i] = " ".join(toks)
        elif op == "char":
            pos = rng.randint(0, len(lines[i]))
            lines[i] = lines[i][:pos] + rng.choice(_ODD_TEXT) + lines[i][pos:]
        elif op == "bytes":
            raw.append(rng.choice(_ODD_BYTES))
        elif op == "include":
            lines.insert(rng.randint(1, len(lines)), rng.choice(_includes(tmp)))
        elif op == "subckt":
            lines[1:1] = _blow_up(rng.choice([3, 12, 25]))
        elif op == "recursive":
            lines[1:1] = [".subckt rec a b", "X1 a b rec", ".ends", "Xr in 0 rec"]
        else:  # a line repeated many times
            lines[i + 1:i + 1] = [lines[i]] * rng.choice([10, 1000])
    data = "\n".join(lines).encode("utf-8", errors="surrogatepass")
    for chunk in raw:
        pos = rng.randint(0, len(data))
        data = data[:pos] + chunk + data[pos:]
    return data


class _Overtime(BaseException):
    """A command ran past its budget (BaseException: no ``except Exception`` hides it)."""


def _alarm(signum, frame):
    raise _Overtime


def _command(argv: list[str]) -> tuple[int, float]:
    """Exit status and wall time of ``pelcs ARGV`` in process, within the budget."""
    from pelcs.cli import main

    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, _BUDGET)
    t0 = time.perf_counter()
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse: bad options
        code = exc.code if isinstance(exc.code, int) else 2
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)
    return code, time.perf_counter() - t0


def _mutants():
    rng = random.Random(_SEED)
    for k in range(_CASES):
        seed = rng.choice(_CORPUS)
        yield pytest.param(seed, rng.getrandbits(32), id=f"{k}-{seed.stem}")


@pytest.mark.parametrize("seed_file, case", list(_mutants()))
def test_commands_on_mutated_netlists(tmp_path, monkeypatch, capsys, seed_file, case):
    monkeypatch.setenv("PELCS_MAX_STEPS", "2e5")  # every run a fraction of a second
    monkeypatch.chdir(tmp_path)
    (tmp_path / "big.inc").write_bytes(b"* " + b"x" * 1000 + b"\n")
    monkeypatch.setenv("PELCS_MAX_FILE_BYTES", "100k")
    data = _mutate(seed_file.read_text(encoding="utf-8"), random.Random(case), tmp_path)
    path = tmp_path / "self.cir"
    path.write_bytes(data)
    for argv in (["info", str(path)], ["lcs", str(path)],
                 ["simulate", str(path), "--no-progress", "-o", str(tmp_path / "out.npz")]):
        try:
            code, wall = _command(argv)
        except _Overtime:
            pytest.fail(f"pelcs {argv[0]} ran more than {_BUDGET} s on mutant {case} of "
                        f"{seed_file.name}:\n{data.decode('utf-8', 'replace')[:3000]}")
        except Exception as exc:  # noqa: BLE001 - the point of the test
            pytest.fail(f"pelcs {argv[0]}: {type(exc).__name__}: {exc} on mutant {case} of "
                        f"{seed_file.name}:\n{data.decode('utf-8', 'replace')[:3000]}")
        err = capsys.readouterr().err
        assert code in (0, 2, 3), (argv[0], code, err)
        assert "Traceback" not in err


def test_extreme_value_found_by_fuzzing(tmp_path, capsys, monkeypatch):
    # L = 1e-308 gives matrix entries of 1e308: lcs died in an SVD (LinAlgError), simulate
    # in the discretisation (ValueError); now 'passivity unknown' and an input error
    monkeypatch.chdir(tmp_path)
    text = (_ROOT / "tests" / "netlists" / "ac" / "buck_dcm.cir").read_text()
    path = tmp_path / "extreme.cir"
    path.write_text(text.replace("L1 sw out 10u", "L1 sw out 1e-308"))
    assert _command(["lcs", str(path)])[0] == 0
    assert "passivity unknown: the check failed numerically" in capsys.readouterr().out
    assert _command(["simulate", str(path), "--no-progress"])[0] == 2
    assert "cannot simulate: I - h θ A is singular" in capsys.readouterr().err


_B_CHARS = st.sampled_from(list("(){}=,'+-*/^<>!?:&|. abvi019kmtu") + ["v(a)", "i(Va)", "v(a,0)",
                                                                        "time", "u(", "max("])


@settings(max_examples=200, deadline=None)
@given(st.lists(_B_CHARS, max_size=40).map("".join))
def test_random_b_expressions_raise_only_netlist_error(expr):
    # (no round trip: pelcs writes a B source as the elements it became)
    text = f"b fuzz\nVa a 0 1\nRa a 0 1\nB1 g 0 V = {expr}\nVin in 0 1\nS1 in o g 0 m\n" \
           "Ro o 0 1\n.model m SW()\n.end\n"
    try:
        parse_string(text, file="fuzz.cir")
    except NetlistError as exc:
        assert exc.diagnostics and exc.format()
        for d in exc.diagnostics:
            assert d.message and "\n" not in d.message
