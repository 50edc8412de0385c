"""The sweeps on a real Dask cluster: a ``dask scheduler`` and two ``dask worker`` processes on
127.0.0.1, started and stopped here (the workers in a directory of their own, not the tests').
Every result must equal the local run's, number for number; progress reports must reach the
client from the workers, in whole units, up to the total; a wrong address must be an input
error within seconds, without tracebacks, also later at exit; Ctrl-C must be quiet; a netlist
given by a relative path with relative includes must run on those workers. Also: ``pelcs
simulate`` does not import Dask.
"""

from __future__ import annotations

import http.server
import json
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest
from test_analysis_maps import netlists  # noqa: F401 - fixture
from test_sweep import BUCK, RC_TEXT

import lcs.analysis.parallel as parallel
from lcs.analysis.basins import cell_basins
from lcs.analysis.bifurcation import bifurcation_diagram
from lcs.analysis.continuation import continue_orbits, same_orbit
from netlist.studies.param_sweep import run_sweep
from netlist.studies.sweep import CircuitMapFactory
from pelcs.cli import main

# (the slow part of the suite: outside the fast subset that `-m 'not slow'` selects; one
# xdist group, so that one worker starts the module's cluster, not both)
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("cluster")]

ROOT = Path(__file__).resolve().parents[1]
VM_BUCK = str(ROOT / "converters" / "netlists" / "vm_buck.cir")
# A netlist with a relative .include and a relative .lib (and the files they name).
BUCK_SYNC = ROOT / "tests" / "netlists" / "buck_sync.cir"
BUCK_SYNC_FILES = ("buck_sync.cir", "models.inc", "lib/cells.lib")


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """Address of a scheduler with two single-threaded workers (separate processes)."""
    pytest.importorskip("distributed")
    d = tmp_path_factory.mktemp("dask")
    sched_file = d / "scheduler.json"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    procs = []
    log = open(d / "cluster.log", "w")  # noqa: SIM115 - closed in the teardown
    try:
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", "0",
             "--no-dashboard", "--scheduler-file", str(sched_file)],
            stdout=log, stderr=subprocess.STDOUT, cwd=d, env=env))
        deadline = time.monotonic() + 60
        while not sched_file.exists():
            assert time.monotonic() < deadline, "the scheduler did not start"
            assert procs[0].poll() is None, "the scheduler exited"
            time.sleep(0.05)
        time.sleep(0.1)  # the file is written in one go, but give it a moment
        address = json.loads(sched_file.read_text())["address"]
        for _ in range(2):
            procs.append(subprocess.Popen(
                [sys.executable, "-m", "dask", "worker", address, "--nthreads", "1",
                 "--no-nanny", "--no-dashboard", "--host", "127.0.0.1",
                 "--local-directory", str(d)],
                stdout=log, stderr=subprocess.STDOUT, cwd=d, env=env))
        from distributed import Client

        with Client(address, set_as_default=False, timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        yield address
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                # (a worker asked to stop may wait out its own 20 s shutdown timeout on a
                # loaded machine; nothing of it is tested here)
                p.wait(timeout=3)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        log.close()


def test_bifurcation_diagram_cluster_equals_local(netlists, cluster):  # noqa: F811
    f = CircuitMapFactory(netlists["buck"], period="ts", param="duty")
    kw = dict(x0=f(0.3).x0, transient=20, record=3, probes=["v(out)", "i(L1)"])
    duty = np.linspace(0.3, 0.6, 6)
    local = bifurcation_diagram(f, duty, workers=2, **kw)
    remote = bifurcation_diagram(f, duty, scheduler=cluster, **kw)
    assert "Dask scheduler" in remote.engine and "2 workers" in remote.engine
    assert local.engine == "2 local processes"
    np.testing.assert_array_equal(local.branches[0].samples, remote.branches[0].samples)
    np.testing.assert_array_equal(local.branches[0].x_final, remote.branches[0].x_final)
    follow = dict(kw, follow=True, directions=("up", "down"))
    a = bifurcation_diagram(f, duty, workers=1, **follow)
    b = bifurcation_diagram(f, duty, scheduler=cluster, **follow)
    for ba, bb in zip(a.branches, b.branches, strict=True):
        np.testing.assert_array_equal(ba.samples, bb.samples)


def test_basins_cluster_equals_local(netlists, cluster):  # noqa: F811
    f = CircuitMapFactory(netlists["buck"], period="ts")
    grid = [("v(C1)", 0, 24, 8), ("i(L1)", 0, 24, 6)]
    local = cell_basins(f, grid, workers=2)
    remote = cell_basins(f, grid, scheduler=cluster)
    for name in ("image", "group", "steps", "failed"):
        np.testing.assert_array_equal(getattr(local, name), getattr(remote, name), name)
    assert len(remote.attractors) == 1


def test_continuation_from_many_starts_cluster_equals_local(cluster):
    f = CircuitMapFactory(VM_BUCK, period="tp", param="vin")
    x0 = f(20.0).x0
    starts = [x0 + [0.0, dv] for dv in (-2.0, 0.0, 2.0)]
    kw = dict(steps=3, tol=1e-2, transient=50, param_name="vin")
    local = continue_orbits(f, 20.0, 26.0, starts, workers=2, **kw)
    remote = continue_orbits(f, 20.0, 26.0, starts, scheduler=cluster, **kw)
    for a, b in zip(local, remote, strict=True):
        assert [o.param for o in a.orbits] == [o.param for o in b.orbits]
        for oa, ob in zip(a.orbits, b.orbits, strict=True):
            np.testing.assert_array_equal(oa.points, ob.points)
            np.testing.assert_array_equal(oa.multipliers, ob.multipliers)
        assert [x.param for x in a.bifurcations] == [x.param for x in b.bifurcations]
    # The period-1 orbit is unique here: every start finds it, and it flips near 24.52 V.
    assert all(same_orbit(local[0].orbits[0], r.orbits[0]) for r in local[1:])
    assert [b.type for b in local[0].bifurcations] == ["flip"]
    assert local[0].bifurcations[0].param == pytest.approx(24.52, abs=0.02)


def test_sweep_and_monte_carlo_cluster_equal_local(cluster, tmp_path):
    rc = tmp_path / "rc.cir"
    rc.write_text(RC_TEXT)
    kw = dict(tolerances=["R*=5%", "C1=10%"], runs=10, seed=9)
    local = run_sweep(rc, ["mean(v(out))", "ripple(v(out))"], workers=2, **kw)
    remote = run_sweep(rc, ["mean(v(out))", "ripple(v(out))"], scheduler=cluster, **kw)
    np.testing.assert_array_equal(local.input_values, remote.input_values)
    np.testing.assert_array_equal(local.values, remote.values)
    np.testing.assert_array_equal(local.nominal, remote.nominal)
    a = run_sweep(BUCK, ["mean(v(out))"], params={"duty": [0.3, 0.5, 0.7]}, workers=1)
    b = run_sweep(BUCK, ["mean(v(out))"], params={"duty": [0.3, 0.5, 0.7]}, scheduler=cluster)
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_allclose(b["mean(v(out))"], 24 * b["duty"], atol=1e-4)


class _Bar:
    """Stands in for the tqdm bar: records every update."""

    def __init__(self):
        self.updates: list = []
        self.closed = False

    @property
    def n(self):
        return sum(self.updates)

    def update(self, k):
        self.updates.append(k)

    def refresh(self):
        pass

    def close(self):
        self.closed = True


def test_progress_reaches_the_client_from_the_workers(netlists, cluster, monkeypatch):  # noqa: F811
    bars: list[_Bar] = []
    monkeypatch.setattr(parallel, "progress_bar", lambda *a, **k: bars.append(_Bar()) or bars[-1])
    f = CircuitMapFactory(netlists["buck"], period="ts")
    grid = [("v(C1)", 0, 24, 10), ("i(L1)", 0, 24, 10)]
    cell_basins(f, grid, scheduler=cluster, progress=True)
    # 16 blocks, each reported by its worker as an event: the bar moved more than once
    # before the end (the end only tops it up to the total), by whole cells.
    (bar,) = bars
    assert bar.n == 100 and bar.closed and len(bar.updates) > 1
    assert all(type(k) is int for k in bar.updates), bar.updates
    # A continuation reports fractions of a step: the bar still counts whole steps, and
    # shows the total at the end (10 here) even where a run ends early.
    f = CircuitMapFactory(VM_BUCK, period="tp", param="vin")
    continue_orbits(f, 20.0, 22.0, [f(20.0).x0, f(20.0).x0 + [0.0, 1.0]], steps=5,
                    transient=50, scheduler=cluster, progress=True)
    bar = bars[-1]
    assert bar.n == 10 and bar.closed and all(type(k) is int for k in bar.updates), bar.updates


def test_progress_counts_whole_units():
    bar = _Bar()
    progress = parallel._Progress(bar, 6)
    for _ in range(10):
        progress.add(0.3)  # 3.0 in all, not exactly in floating point
    assert bar.updates == [1, 1, 1]
    progress.add(1.5)
    assert bar.n == 4 and all(type(k) is int for k in bar.updates)
    progress.finish()
    assert bar.n == 6
    progress.add(5)  # never past the total
    assert bar.n == 6
    quiet = parallel._Progress(None, 3)  # no bar: counted only
    quiet.add(2)
    quiet.finish()
    assert quiet.shown == 3


def test_cli_scheduler_option(netlists, cluster, capsys, tmp_path):  # noqa: F811
    csv_local, csv_remote = tmp_path / "a.csv", tmp_path / "b.csv"
    argv = ["bifurcation", netlists["buck"], "--period", "ts", "--param", "duty=0.3:0.6:3",
            "--transient", "10", "--record", "2", "--no-progress"]
    assert main(argv + ["-o", str(csv_local), "--workers", "2"]) == 0
    assert main(argv + ["-o", str(csv_remote), "--scheduler", cluster]) == 0
    out = capsys.readouterr().out
    assert f"on Dask scheduler {cluster} (2 workers, 2 threads)" in out
    assert csv_local.read_text() == csv_remote.read_text()
    code = main(["sweep", str(BUCK), "--param", "duty=0.4", "--measure", "mean(v(out))",
                 "--scheduler", cluster, "--json"])
    r = json.loads(capsys.readouterr().out)
    assert code == 0 and r["rows"][0]["mean(v(out))"] == pytest.approx(9.6, abs=1e-4)
    code = main(["continue", VM_BUCK, "--period", "tp", "--param", "vin=20:22:3",
                 "--start", "v(C1)=11:13:2", "--scheduler", cluster, "--json",
                 "--no-progress"])
    r = json.loads(capsys.readouterr().out)
    assert code == 0 and [c["same_as"] for c in r["continuations"]] == [None, 0]


def test_unreachable_scheduler_is_an_input_error(netlists, capsys, monkeypatch):  # noqa: F811
    monkeypatch.setattr(parallel, "CONNECT_TIMEOUT", 2.0)
    for address, words in (("tcp://127.0.0.1:1", ["cannot connect to the Dask scheduler",
                                                  "dask worker"]),
                           ("no-port-here", ["bad scheduler address", "missing port",
                                             "Scheduler at: tcp://"]),
                           ("127.0.0.1:99999", ["bad scheduler address", "port 99999"])):
        code = main(["basins", netlists["buck"], "--period", "ts", "--grid",
                     "v(C1)=0:24:4,i(L1)=0:24:4", "--scheduler", address])
        err = capsys.readouterr().err
        assert code == 2 and all(w in err for w in words), err
        assert "Traceback" not in err


class _QuietHTTPHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@pytest.fixture(scope="module")
def http_port():
    """Port of a web server (something open on TCP that is not a Dask scheduler)."""
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), _QuietHTTPHandler)
    server.daemon_threads = True
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield server.server_address[1]
    server.shutdown()
    server.server_close()


# Runs main() for each address of argv[1] (JSON) in one process, each call's stderr kept
# apart: what the process prints outside them (at exit, from a Client left half-made) is
# the test's too.
_ADDRESSES_SCRIPT = """
import contextlib, io, json, sys, time
import lcs.analysis.parallel as parallel
parallel.HANDSHAKE_TIMEOUT = 1.0
from pelcs.cli import main
out = []
for address in json.loads(sys.argv[1]):
    err = io.StringIO()
    t = time.monotonic()
    with contextlib.redirect_stderr(err):
        code = main(["basins", sys.argv[2], "--period", "tp", "--grid",
                     "v(C1)=0:24:4,i(L1)=0:24:4", "--no-progress", "--scheduler", address])
    out.append((address, code, time.monotonic() - t, err.getvalue()))
print(json.dumps(out))
"""


def test_wrong_addresses_fail_fast_and_quietly(cluster, http_port):
    from distributed import Client

    with Client(cluster, set_as_default=False, timeout=30) as client:
        worker = sorted(client.scheduler_info()["workers"])[0]
    web = f"127.0.0.1:{http_port}"
    expected = {
        # Open ports that are not a Dask scheduler: Dask's handshake alone waited forever.
        f"tcp://{web}": [f"tcp://{web} is not a Dask scheduler (no answer to Dask's "
                         "handshake within 1 s)", "Scheduler at: tcp://"],
        web: [f"tcp://{web} is not a Dask scheduler"],
        worker: [f"{worker} is a Dask Worker, not a scheduler", "Registered to"],
        # Schemes refused before any connection (http:// printed a Client.__del__
        # traceback 20 s after its error; tls:// was a TypeError traceback).
        f"http://{web}": ["is a web address", "Scheduler at: tcp://"],
        "foo://x": ["bad scheduler address 'foo://x': unknown scheme foo://"],
        "inproc://x": ["in-process (inproc://) scheduler addresses are not supported",
                       "distributed.Client", "scheduler="],
        f"tls://{web}": ["TLS (tls://) scheduler addresses are not supported",
                         "distributed.Client", "scheduler="],
    }
    t = time.monotonic()
    r = subprocess.run([sys.executable, "-c", _ADDRESSES_SCRIPT, json.dumps(list(expected)),
                        VM_BUCK], capture_output=True, text=True, timeout=120)
    elapsed = time.monotonic() - t
    assert r.returncode == 0 and r.stderr == "", r.stderr  # nothing later, at exit either
    for address, code, seconds, err in json.loads(r.stdout):
        assert code == 2, (address, err)
        assert all(w in err for w in expected[address]), (address, err)
        assert "Traceback" not in err and "Exception ignored" not in err, (address, err)
        lines = err.strip().splitlines()
        assert len(lines) == 2 and lines[1].startswith("  hint: "), err  # error, hint
        # (a 1 s handshake timeout here; the limits leave room for a loaded machine and stay
        # far below the 30 s that Dask's default connect timeout would hang)
        limit = 10.0 if "Dask scheduler (" in err else 5.0
        assert seconds < limit, (address, seconds)
    assert elapsed < 30


def test_not_a_scheduler_with_the_default_timeouts(http_port):
    """The command line as the user runs it: an exit within 10 s, the wait named."""
    address = f"tcp://127.0.0.1:{http_port}"
    t = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "pelcs.cli", "bifurcation", VM_BUCK,
                        "--period", "tp", "--param", "vin=20:30:3", "--transient", "1",
                        "--record", "1", "--scheduler", address],
                       capture_output=True, text=True, timeout=60)
    elapsed = time.monotonic() - t
    assert r.returncode == 2, r.stderr
    assert (f"--scheduler: {address} is not a Dask scheduler (no answer to Dask's handshake "
            f"within {parallel.HANDSHAKE_TIMEOUT:g} s)") in r.stderr
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr
    # (the 5 s handshake and a command's start-up; room for a loaded machine, and still far
    # from the 30 s that Dask's default connect timeout would hang)
    assert elapsed < 20, elapsed


# Ctrl-C in the middle of a run on the cluster: SIGINT's handler installed explicitly, as a
# shell would leave it, also where the tests run as a background job (SIGINT ignored).
_INTERRUPTED_SCRIPT = """
import signal, sys
signal.signal(signal.SIGINT, signal.default_int_handler)
from pelcs.cli import main
sys.exit(main(sys.argv[1:]))
"""

_LONG_RUNS = {  # a few seconds on the two workers, in tasks of well under a second
    "basins": (["basins", VM_BUCK, "--period", "tp", "--grid", "v(C1)=0:24:60,i(L1)=0:24:60",
                "--no-progress"], "pelcs_cells-"),
    "sweep": (["sweep", VM_BUCK, "--param", "vin=20:35:50", "--measure", "mean(v(C1))",
               "--tstop", "200m"], "pelcs_sweep-"),
}


def test_a_timeout_nobody_awaited_in_the_clients_shutdown_is_not_reported(caplog):
    # What a loaded machine printed after an interrupted sweep on a cluster: asyncio's report
    # of a future of Dask's client that timed out while it closed. Real futures, collected as
    # asyncio collects them; another exception is still reported.
    import asyncio
    import gc
    import logging

    parallel._import_distributed()
    loop = asyncio.new_event_loop()
    try:
        with caplog.at_level(logging.ERROR, logger="asyncio"):
            for exc in (asyncio.TimeoutError("Timeout"), TimeoutError("Timeout"),
                        TimeoutError("a user's own timeout"), ValueError("a real failure")):
                future = loop.create_future()
                future.set_exception(exc)
                del future
                gc.collect()
    finally:
        loop.close()
    reported = [r for r in caplog.records if r.name == "asyncio"]
    assert all("never retrieved" in r.getMessage() for r in reported)
    assert [str(r.exc_info[1]) for r in reported] == ["a user's own timeout", "a real failure"]


@pytest.mark.parametrize("command", sorted(_LONG_RUNS))
def test_interrupt_on_a_cluster_is_quiet(cluster, command):
    from distributed import Client

    argv, key_prefix = _LONG_RUNS[command]
    with Client(cluster, set_as_default=False, timeout=30) as client:

        def running() -> bool:
            return any(str(k).startswith(key_prefix)
                       for keys in client.processing().values() for k in keys)

        p = subprocess.Popen([sys.executable, "-c", _INTERRUPTED_SCRIPT, *argv, "--scheduler",
                              cluster], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True)
        try:
            deadline = time.monotonic() + 60
            while not running():
                assert p.poll() is None, p.communicate()
                assert time.monotonic() < deadline, "the run did not start"
                time.sleep(0.02)
            time.sleep(0.3)
            p.send_signal(signal.SIGINT)
            t = time.monotonic()
            _, err = p.communicate(timeout=30)
            elapsed = time.monotonic() - t
        finally:
            if p.poll() is None:
                p.kill()
                p.communicate()
        # The run's tasks left the cluster (the running ones finish on their workers).
        deadline = time.monotonic() + 20
        while running() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not running()
    # Was: one "Task exception was never retrieved ... AllExit" traceback per task. The
    # finished tasks are kept (tests/test_interrupt_analyses.py): the note says how many.
    assert p.returncode == 130, err
    assert "Traceback" not in err and "exception" not in err.lower(), err
    assert "interrupted (SIGINT) after " in err, err
    assert elapsed < 10, elapsed  # (room for a loaded machine)


def _copy_buck_sync(to: Path) -> None:
    for name in BUCK_SYNC_FILES:
        (to / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(BUCK_SYNC.parent / name, to / name)


def test_relative_netlist_with_relative_includes_on_workers_elsewhere(cluster, tmp_path,
                                                                     monkeypatch, capsys):
    from distributed import Client

    _copy_buck_sync(tmp_path / "sub")
    monkeypatch.chdir(tmp_path)
    with Client(cluster, set_as_default=False, timeout=30) as client:
        cwds = set(client.run(os.getcwd).values())
    assert os.getcwd() not in cwds and len(cwds) == 1  # the workers run elsewhere
    rel = os.path.join("sub", "buck_sync.cir")
    f = CircuitMapFactory(rel, period="ts", param="vin")
    kw = dict(x0=f(24.0).x0, transient=5, record=2, probes=["v(out)"])
    vin = np.array([20.0, 24.0, 28.0])
    local = bifurcation_diagram(f, vin, workers=1, **kw)
    remote = bifurcation_diagram(f, vin, scheduler=cluster, **kw)
    assert remote.branches[0].ok.all()
    np.testing.assert_array_equal(local.branches[0].samples, remote.branches[0].samples)
    capsys.readouterr()
    common = ["--period", "ts", "--scheduler", cluster, "--no-progress"]
    for argv in (["bifurcation", rel, "--param", "vin=20:28:3", "--transient", "5",
                  "--record", "2", "--probe", "v(out)"],
                 ["basins", rel, "--grid", "v(Cout)=0:10:3,i(L1)=0:5:3"],
                 ["continue", rel, "--param", "vin=20:22:3"]):
        code = main(argv + common)
        out, err = capsys.readouterr()
        assert code == 0 and "not found" not in out + err, (argv[0], out, err)
        if argv[0] == "bifurcation":  # the summary still names the netlist as given
            assert out.startswith(f"{rel}: Synchronous buck"), out


def test_sweep_relative_includes_on_workers_elsewhere(cluster, tmp_path, monkeypatch):
    _copy_buck_sync(tmp_path / "sub")
    monkeypatch.chdir(tmp_path)
    table = run_sweep(os.path.join("sub", "buck_sync.cir"), ["mean(v(out))"],
                      params={"vin": [20.0, 24.0]}, scheduler=cluster)
    assert table.ok.all(), table.messages


def test_portable_makes_a_relative_netlist_path_absolute(tmp_path, monkeypatch):
    _copy_buck_sync(tmp_path)
    monkeypatch.chdir(tmp_path)
    p = parallel.portable(CircuitMapFactory("buck_sync.cir", period="ts"))
    assert p.path == os.path.join(os.getcwd(), "buck_sync.cir")
    assert p.text == (tmp_path / "buck_sync.cir").read_text()
    assert parallel.portable(p) == p  # already absolute
    monkeypatch.chdir(ROOT)  # elsewhere, as a worker: the includes are still found
    assert p.circuit().title.startswith("Synchronous buck")
    other = object()
    assert parallel.portable(other) is other


def test_local_dask_cluster_equals_process_pool(netlists):  # noqa: F811
    pytest.importorskip("distributed")
    f = CircuitMapFactory(netlists["buck"], period="ts")
    grid = [("v(C1)", 0, 24, 6), ("i(L1)", 0, 24, 4)]
    pool = cell_basins(f, grid, workers=2)
    dask_local = cell_basins(f, grid, workers=2, scheduler="local")
    assert dask_local.engine == "Dask local cluster (2 worker processes)"
    np.testing.assert_array_equal(pool.image, dask_local.image)


def test_simulate_does_not_import_dask():
    code = ("import sys\nfrom pelcs.cli import main\n"
            f"main(['simulate', {str(BUCK)!r}, '--probe', 'v(out)', '--tstop', '0.1m'])\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] in "
            "('dask', 'distributed', 'pandas')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip().splitlines()[-1] == "[]"


def test_portable_factory_carries_the_netlist(netlists, tmp_path):  # noqa: F811
    path = tmp_path / "buck.cir"
    path.write_text(Path(netlists["buck"]).read_text())
    f = CircuitMapFactory(str(path), period="ts", param="duty")
    p = f.portable()
    assert p.text == path.read_text() and p.portable() is p and f.text is None
    x_ref = f(0.4).power(f(0.4).x0, 3)
    path.unlink()  # workers elsewhere have no copy of the file
    np.testing.assert_array_equal(p(0.4).power(p(0.4).x0, 3), x_ref)
    # An edited netlist is another factory: a long-lived worker cannot reuse a stale map.
    edited = CircuitMapFactory(str(path), period="ts", param="duty",
                               text=p.text + "* edited\n")
    assert edited != p and hash(edited) != hash(p)
