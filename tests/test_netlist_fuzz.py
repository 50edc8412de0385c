"""Fuzzing: mutated netlists and random bytes either parse or raise NetlistError, nothing else.

A NetlistError must also be well-formed: at least one diagnostic, each with a message, and a
location (when there is one) whose line exists in the input.
"""

from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.writer import write_circuit

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
