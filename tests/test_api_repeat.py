"""Repeated simulations through the Python API: the netlist is read once
(:mod:`netlist.deck_cache`), the system formulated once per set of values
(:mod:`netlist.system_cache`), and every run still gives, bit for bit, what a fresh parse and
simulation of the same values gives; an edited file (or include) is read again."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import pelcs
from lcs.signals import Pulse
from netlist import deck_cache, system_cache
from netlist.errors import NetlistError
from netlist.parser import parse_file, parse_string
from netlist.studies.transient import simulate_circuit

BUCK = Path(__file__).resolve().parents[1] / "converters" / "netlists" / "buck.cir"
TSTOP = 5 / 50e3  # five switching periods of the buck
PROBES = ["v(out)", "i(L1)"]

# The buck with its load and inductance as parameters too.
BUCK_PARAMS = """buck with parameters
.param vin=24 duty=0.5 fs=50k rload=5 lval=200u
.param ts={1/fs}
Vin in 0 DC {vin}
S1 in sw gate 0 SWIDEAL
D1 0 sw DIDEAL
L1 sw out {lval}
C1 out 0 100u IC=0
R1 out 0 {rload}
Vg gate 0 PULSE(0 1 0 10n 10n {duty*ts-10n} {ts})
.model SWIDEAL SW(VT=0.5 VH=0 RON=1m ROFF=1e9)
.model DIDEAL D(IS=1e-12 N=0.05 RS=1m)
.tran 0.2u 5m 0 0.2u UIC
.end
"""


def _same(a, b) -> bool:
    """Bit for bit: times, probes, events, notes, θ (the API's own note on the device
    models an ideal run leaves out, which netlist.studies.left_out writes, set aside)."""
    notes = [n for n in a.notes if not n.startswith("ideal devices:")]
    return (a.t.tobytes() == b.t.tobytes() and a.y.tobytes() == b.y.tobytes()
            and a.names == b.names and a.events == b.events and notes == b.notes
            and a.theta == b.theta)


def _fresh_file(path, params):
    return simulate_circuit(parse_file(path, params), tstop=TSTOP, probes=PROBES)


def test_repeated_duty_runs_equal_fresh_runs_bit_for_bit():
    # Back and forth: a value met before must not inherit anything from the runs between
    # (the stored shortened steps of other duties differ from its own at round-off).
    for duty in (0.5, 0.3, 0.5, 0.62, 0.3):
        res = pelcs.simulate(BUCK, tstop=TSTOP, probes=PROBES, params={"duty": duty})
        assert _same(res, _fresh_file(BUCK, {"duty": duty})), duty


def test_repeated_load_and_inductance_runs_equal_fresh_runs():
    # R and L change the system: each set of values gets its own, kept for its next run.
    sets = [{"rload": 5}, {"rload": 2.5, "lval": "150u"}, {"rload": 5},
            {"duty": 0.4, "lval": "150u", "rload": 2.5}]
    for params in sets:
        res = pelcs.simulate(BUCK_PARAMS, tstop=TSTOP, probes=PROBES, params=params)
        ref = simulate_circuit(parse_string(BUCK_PARAMS, params={
            k: (float(v) if not isinstance(v, str) else 150e-6) for k, v in params.items()}),
            tstop=TSTOP, probes=PROBES)
        assert _same(res, ref), params


def test_a_repeated_value_set_reuses_the_deck_and_the_system():
    a = pelcs.load(BUCK_PARAMS, params={"duty": 0.3})
    b = pelcs.load(BUCK_PARAMS, params={"duty": 0.6})
    c = pelcs.load(BUCK_PARAMS, params={"rload": 3})
    assert system_cache.formulation_key(a) == system_cache.formulation_key(b)  # inputs only
    assert system_cache.formulation_key(a) != system_cache.formulation_key(c)
    assert system_cache.reused_system(a) is system_cache.reused_system(b)
    assert system_cache.reused_system(c) is not system_cache.reused_system(a)
    # One deck for every value set of the same text.
    d1 = deck_cache.cached_deck(BUCK_PARAMS, "<string>", None, None)
    d2 = deck_cache.cached_deck(BUCK_PARAMS, "<string>", None, {"duty": 0.1})
    assert d1 is d2


def test_a_changed_circuit_object_gets_its_own_system():
    c = pelcs.load(BUCK_PARAMS)
    first = system_cache.reused_system(c)
    c.element("R1").value = 2.0  # the caller edits the circuit it holds
    second = system_cache.reused_system(c)
    assert second is not first
    # The first system was formulated from a copy: it still has R1 = 5 ohm.
    again = system_cache.reused_system(pelcs.load(BUCK_PARAMS))
    assert again is first
    on = {"S1": True}
    a_on = first.mode(on).A
    assert not np.array_equal(a_on, second.mode(on).A)


def test_an_edited_file_is_read_again(tmp_path):
    net = tmp_path / "buck.cir"
    net.write_text(BUCK.read_text())
    before = pelcs.simulate(net, tstop=TSTOP, probes=PROBES)
    stat = net.stat()
    # Same size, same modification time: only the bytes tell.
    net.write_text(BUCK.read_text().replace("R1 out 0 5", "R1 out 0 4"))
    os.utime(net, ns=(stat.st_atime_ns, stat.st_mtime_ns))
    assert net.stat().st_size == stat.st_size and net.stat().st_mtime_ns == stat.st_mtime_ns
    after = pelcs.simulate(net, tstop=TSTOP, probes=PROBES)
    assert _same(after, _fresh_file(net, {}))
    assert not np.array_equal(before.y, after.y)


def test_an_edited_include_is_read_again(tmp_path):
    inc = tmp_path / "load.inc"
    inc.write_text("R1 out 0 5\n")
    top = tmp_path / "top.cir"
    top.write_text(BUCK.read_text().replace("R1 out 0 5", ".include load.inc"))
    first = pelcs.load(top)
    assert first.element("R1").value == 5.0
    inc.write_text("R1 out 0 7\n")
    assert pelcs.load(top).element("R1").value == 7.0
    inc.unlink()  # gone: the error, not the kept deck
    with pytest.raises(NetlistError, match="file not found"):
        pelcs.load(top)


def test_a_netlist_with_errors_is_not_kept_and_errors_stay_the_same(tmp_path):
    bad = BUCK_PARAMS.replace("R1 out 0 {rload}", "R1 out 0 {rlaod}")
    for _ in range(2):
        with pytest.raises(NetlistError) as fresh:
            parse_string(bad)
        with pytest.raises(NetlistError) as kept:
            pelcs.load(bad)
        assert str(kept.value) == str(fresh.value)
    with pytest.raises(NetlistError, match="duty"):
        pelcs.load(BUCK_PARAMS, params={"dutty": 0.3})  # an unknown override, every time
    with pytest.raises(NetlistError, match="duty"):
        pelcs.load(BUCK_PARAMS, params={"dutty": 0.3})


def test_pulse_at_one_instant_is_the_array_evaluation_bit_for_bit():
    rng = np.random.default_rng(1)
    pulses = [Pulse(0, 1, 0, 1e-8, 1e-8, 0.4 * 2e-5 - 1e-8, 2e-5),
              Pulse(2.5, -1, 3e-6, 1e-6, 2e-6, 5e-6, 1e-5, 3.5),     # NP, inverted
              Pulse(0, 5, 0, 1e-3, 1e-3, 0, 1.5e-3),                  # PW = 0, cut
              Pulse(1, 2, 1e-4, 1e-4, 1e-3, 1e-3, 2.1e-3),            # cut period
              Pulse(0, 1, 0, 1e-6, 1e-6, -1e-7, 1e-5),                # negative PW
              Pulse(0, 1, 1e-6, 1e-6, 1e-6, 0, 0)]                    # one pulse
    for p in pulses:
        per = max(p.per, 1e-6)
        corners = (p.td + np.arange(12)[:, None] * per
                   + np.array([0, p.tr, p.tr + p.pw, p.tr + p.pw + p.tf, p.per])).ravel()
        t = np.concatenate([rng.uniform(-1e-5, 30 * per, 400), corners,
                            np.nextafter(corners, np.inf), np.nextafter(corners, -np.inf)])
        for side in (-1, 0, 1):
            whole = p(t, side)
            one = np.array([p(np.array([x]), side)[0] for x in t])
            assert whole.view(np.int64).tolist() == one.view(np.int64).tolist(), (p, side)
    assert p(np.array(0.5e-6)).shape == ()


def test_pulse_evaluated_again_at_some_of_the_same_instants_gives_the_same_bits():
    # The last evaluation's instants serve the next call's (a run's segment starts, ends,
    # input table): overlaps, supersets, shuffled, many new instants, the other side.
    p = Pulse(0, 1, 0, 1e-8, 1e-8, 0.4 * 2e-5 - 1e-8, 2e-5)
    grid = np.sort(np.concatenate([np.linspace(0, 4e-4, 81), 2e-5 * np.arange(20) + 1e-8]))
    rng = np.random.default_rng(2)
    calls = [(grid[:-1], 1), (grid[1:], -1), (grid[1:], 1), (grid, 0), (grid[::-1], 0),
             (np.concatenate([grid[:30], rng.uniform(0, 4e-4, 50)]), 0),
             (rng.permutation(grid), 0)]
    # (a pulse whose breakpoints were asked for evaluates the run's ends with its first
    # instants)
    q = Pulse(*[getattr(p, f) for f in ("v1", "v2", "td", "tr", "tf", "pw", "per")])
    q.breakpoints(0.0, 4e-4)
    for t, side in calls:
        fresh = Pulse(*[getattr(p, f) for f in ("v1", "v2", "td", "tr", "tf", "pw", "per")])
        want = fresh._values(t, side)
        for pulse in (p, q):
            got = pulse(t, side)
            assert got.view(np.int64).tolist() == want.view(np.int64).tolist(), side


def test_kept_shortened_steps_change_a_run_only_at_round_off():
    # Why the API starts every run without the stored shortened steps: with them (the
    # default for repeated runs of one system, e.g. shooting) a duty's run after another
    # duty's differs from its fresh run, at round-off.
    from lcs.integrators.moreau.integrator import MoreauOptions

    c3, c5 = parse_file(BUCK, {"duty": 0.3}), parse_file(BUCK, {"duty": 0.5})
    system = system_cache.formulate(c5)
    simulate_circuit(c5, tstop=TSTOP, probes=PROBES, system=system)
    kept = simulate_circuit(c3, tstop=TSTOP, probes=PROBES, system=system)
    cleared = simulate_circuit(c3, tstop=TSTOP, probes=PROBES, system=system,
                               options=MoreauOptions(keep_odd_steps=False))
    fresh = _fresh_file(BUCK, {"duty": 0.3})
    assert _same(cleared, fresh)
    assert not _same(kept, fresh)  # (without the option the API's runs would not be exact)
    assert np.allclose(kept.y, fresh.y, rtol=0, atol=1e-9)


def test_the_caches_are_bounded(monkeypatch):
    monkeypatch.setattr(system_cache, "MAX_SYSTEMS", 2)
    systems = [system_cache.reused_system(pelcs.load(BUCK_PARAMS, params={"rload": r}))
               for r in (1.0, 2.0, 3.0)]
    assert system_cache.reused_system(pelcs.load(BUCK_PARAMS, params={"rload": 3.0})) \
        is systems[2]
    assert system_cache.reused_system(pelcs.load(BUCK_PARAMS, params={"rload": 1.0})) \
        is not systems[0]  # dropped, formulated again
    # A large circuit's systems are kept by twos at most (its elements count).
    monkeypatch.setattr(system_cache, "MAX_SYSTEMS", 16)
    monkeypatch.setattr(system_cache, "MAX_ELEMENTS", 20)  # the buck has 8 elements
    first = system_cache.reused_system(pelcs.load(BUCK_PARAMS, params={"rload": 4.0}))
    for r in (5.0, 6.0):
        system_cache.reused_system(pelcs.load(BUCK_PARAMS, params={"rload": r}))
    assert system_cache.reused_system(pelcs.load(BUCK_PARAMS, params={"rload": 4.0})) \
        is not first
    monkeypatch.setattr(deck_cache, "MAX_CHARS", len(BUCK_PARAMS) + 10)
    deck = deck_cache.cached_deck(BUCK_PARAMS, "<string>", None, None)
    deck_cache.cached_deck(BUCK_PARAMS + "* other\n", "<string>", None, None)
    assert deck_cache.cached_deck(BUCK_PARAMS, "<string>", None, None) is not deck


def test_the_formulation_key_tells_signed_zeros_apart():
    a, b = pelcs.load(BUCK_PARAMS), pelcs.load(BUCK_PARAMS)
    a.element("C1").ic, b.element("C1").ic = 0.0, -0.0
    assert system_cache.formulation_key(a) != system_cache.formulation_key(b)
    b.element("C1").ic = 0.0
    assert system_cache.formulation_key(a) == system_cache.formulation_key(b)


def test_threads_get_their_own_systems_and_fresh_results():
    from concurrent.futures import ThreadPoolExecutor

    duties = [0.3, 0.45, 0.6, 0.35, 0.5, 0.65]

    def run(duty):
        return pelcs.simulate(BUCK, tstop=TSTOP, probes=PROBES, params={"duty": duty})

    with ThreadPoolExecutor(3) as pool:
        results = list(pool.map(run, duties))
    for duty, res in zip(duties, results, strict=True):
        assert _same(res, _fresh_file(BUCK, {"duty": duty})), duty
    c = pelcs.load(BUCK)
    with ThreadPoolExecutor(1) as pool:
        other = pool.submit(system_cache.reused_system, c).result()
    assert other is not system_cache.reused_system(c)


def _state(make):
    """Every field of a circuit, locations and model parameters included (or its error)."""
    import dataclasses

    try:
        c = make()
    except NetlistError as exc:
        return str(exc)
    out = []
    for f in dataclasses.fields(c):
        v = getattr(c, f.name)
        if f.name == "elements":
            v = [(type(e).__name__, e.key, [(g.name, repr(getattr(e, g.name)))
                                           for g in dataclasses.fields(e)]) for e in v]
        elif f.name == "models":
            v = {k: (m.name, m.type, sorted(m.params.items()), m.location) for k, m in v.items()}
        out.append((f.name, repr(v)))
    return out


def test_rebound_circuits_equal_full_evaluations():
    # Re-binding evaluates again only the elements a changed parameter reaches; what it
    # gives must be the flattener's circuit field for field, errors included.
    rng = np.random.default_rng(3)
    sets = [{}, {"duty": 0.3}, {"rload": 2.0}, {"duty": 0.3, "rload": 2.0}, {"lval": 1e-4},
            {"vin": 12}, {"fs": 100e3}, {"duty": 0.0}, {"rload": -1.0}, {"dutty": 0.2},
            {"duty": float("nan")}]
    sets += [{"duty": float(rng.uniform(0.1, 0.9)), "rload": float(rng.uniform(1, 10))}
             for _ in range(10)]
    # Parameters in a model, the .tran, an .ic: those changes take the full evaluation.
    fixed = BUCK_PARAMS.replace("VT=0.5", "VT={vt}").replace(".tran 0.2u 5m",
                                                             ".tran 0.2u {tst}")
    fixed = fixed.replace(".param ts={1/fs}",
                          ".param ts={1/fs} vt=0.5 tst=5m vic=1\n.ic v(out)={vic}")
    for text in (BUCK_PARAMS, fixed):
        for params in sets + [{"vt": 0.4}, {"tst": 1e-3}, {"vic": 2.0, "duty": 0.4}]:
            if text is BUCK_PARAMS and set(params) & {"vt", "tst", "vic"}:
                continue
            kept = _state(lambda t=text, p=params: parse_string(t, params=p, reuse=True))
            assert kept == _state(lambda t=text, p=params: parse_string(t, params=p)), params
    # The circuit handed out is the caller's: editing it changes no later one.
    first = pelcs.load(BUCK_PARAMS, params={"duty": 0.31})
    first.element("R1").value = 99.0
    first.element("Vg").waveform = None
    assert pelcs.load(BUCK_PARAMS, params={"duty": 0.32}).element("R1").value == 5.0
    assert pelcs.load(BUCK_PARAMS, params={"duty": 0.31}).element("Vg").waveform is not None
    text = BUCK_PARAMS + "* a deck of its own: this load is its first evaluation\n"
    base = pelcs.load(text, params={"duty": 0.2})
    base.element("R1").value = 77.0
    assert pelcs.load(text, params={"duty": 0.25}).element("R1").value == 5.0


def test_rebound_parameters_in_any_order_equal_full_evaluations():
    # The global parameters are evaluated in an order found once per deck (each after those
    # it uses); a cycle, a duplicate or a failing expression goes through the flattener.
    chained = BUCK_PARAMS.replace(".param ts={1/fs}",
                                  ".param ton={duty*ts} ts={1/fs} r2={rload*2}")
    chained = chained.replace("R1 out 0 {rload}", "R1 out 0 {r2/2}")
    cycle = BUCK_PARAMS.replace(".param ts={1/fs}", ".param ts={1/fs} a={b+1} b={a}")
    twice = BUCK_PARAMS.replace(".param ts={1/fs}", ".param ts={1/fs} rload=6")
    inverse = BUCK_PARAMS.replace("R1 out 0 {rload}", "R1 out 0 {1/rload}")
    for text, sets in [(chained, [{"duty": 0.3}, {"rload": 2.0}, {"fs": 1e5, "duty": 0.6}]),
                       (cycle, [{"duty": 0.3}, {"a": 1.0}, {"b": 2.0, "duty": 0.4}]),
                       (twice, [{"duty": 0.3}, {"rload": 2.0}]),
                       (inverse, [{"rload": 2.0}, {"rload": 0.0}, {"rload": 4.0}])]:
        for params in sets:
            kept = _state(lambda t=text, p=params: parse_string(t, params=p, reuse=True))
            assert kept == _state(lambda t=text, p=params: parse_string(t, params=p)), params


# An ideal diode forward biased by its capacitor's IC: an inconsistent initial state (the
# state jumps at t = 0, with a note); the comparator's VH is ignored with
# switching='implicit' (a note of the switch plan).
JUMP = """capacitor charged across a diode
.param duty=0.5
Vg g 0 PULSE(0 1 0 10n 10n {duty*10u} 10u)
R3 g a 1k
C1 a 0 1u IC=1
D1 a 0 DI
S1 a b a 0 SWH
R1 b 0 10
.model SWH SW(VT=0.5 VH=0.1)
.model DI D
.tran 0.1u 50u UIC
.end
"""


def test_kept_plans_and_initial_states_leave_every_run_its_notes():
    # The switch plan and a consistent initial state are kept for the next runs; a run still
    # gets the notes a fresh run gets (the plan's), and an inconsistent initial state is
    # met, handled and noted again in every run.
    for duty in (0.5, 0.3, 0.5):
        for switching in ("implicit", None):
            res = pelcs.simulate(JUMP, params={"duty": duty}, switching=switching)
            ref = simulate_circuit(parse_string(JUMP, params={"duty": duty}),
                                   switching=switching)
            assert _same(res, ref), (duty, switching)
            assert any("ignores its hysteresis" in n for n in res.notes) == \
                (switching == "implicit")
            assert any("jump" in n for n in res.notes), res.notes
    res = pelcs.simulate(BUCK, tstop=TSTOP, probes=PROBES, params={"duty": 0.4})
    res.x_final[:] = 7.0  # (a result's arrays are its own: the next run starts as before)
    assert _same(pelcs.simulate(BUCK, tstop=TSTOP, probes=PROBES, params={"duty": 0.4}),
                 _fresh_file(BUCK, {"duty": 0.4}))


TEMPERATURE_PARAMS = """resistors scaled by their temperature coefficients, a parameter changed
.param rl=1k
V1 in 0 10
R1 in a {rl} MDR
R2 a 0 1k tc1=1m
C1 a 0 1u dtemp=10 tc1=5m
.model MDR R(TC1=0.01 TNOM=30)
.temp 77
.tran 1u 10u
.end
"""


def test_a_repeated_value_set_keeps_the_temperature_scaling():
    # the kept evaluation re-binds R1 alone: it keeps its model's scaling, R2 its own
    for rl in (1e3, 2e3, 1e3):
        again = pelcs.load(TEMPERATURE_PARAMS, params={"rl": rl})
        fresh = parse_string(TEMPERATURE_PARAMS, params={"rl": rl})
        for name in ("R1", "R2", "C1"):
            assert again.element(name).value == fresh.element(name).value, (rl, name)
        assert fresh.element("R1").value == pytest.approx(rl * 1.47)
        assert fresh.element("R2").value == pytest.approx(1e3 * 1.05)
