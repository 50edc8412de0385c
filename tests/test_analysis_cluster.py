"""The sweeps on a real Dask cluster: a ``dask scheduler`` and two ``dask worker`` processes on
127.0.0.1, started and stopped here. Every result must equal the local run's, number for
number; progress reports must reach the client from the workers; a wrong address must be an
input error. Also: ``pelcs simulate`` does not import Dask.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
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
from netlist.param_sweep import run_sweep
from netlist.sweep import CircuitMapFactory
from pelcs.cli import main

ROOT = Path(__file__).resolve().parents[1]
VM_BUCK = str(ROOT / "converters" / "netlists" / "vm_buck.cir")


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
                p.wait(timeout=20)
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


def test_progress_reaches_the_client_from_the_workers(netlists, cluster, monkeypatch):  # noqa: F811
    class Counter:
        n = 0.0
        closed = False

        def update(self, k):
            self.n += k

        def close(self):
            self.closed = True

    bar = Counter()
    monkeypatch.setattr(parallel, "progress_bar", lambda *a, **k: bar)
    f = CircuitMapFactory(netlists["buck"], period="ts")
    grid = [("v(C1)", 0, 24, 10), ("i(L1)", 0, 24, 10)]
    cell_basins(f, grid, scheduler=cluster, progress=True)
    # Every cell was reported by a worker (in blocks of up to 64) before the results came.
    assert bar.n == 100 and bar.closed


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
    code = main(["continue", VM_BUCK, "--period", "tp", "--param", "vin=20:22", "--steps",
                 "2", "--start", "v(C1)=11:13:2", "--scheduler", cluster, "--json",
                 "--no-progress"])
    r = json.loads(capsys.readouterr().out)
    assert code == 0 and [c["same_as"] for c in r["continuations"]] == [None, 0]


def test_unreachable_scheduler_is_an_input_error(netlists, capsys, monkeypatch):  # noqa: F811
    monkeypatch.setattr(parallel, "CONNECT_TIMEOUT", 2.0)
    for address, words in (("tcp://127.0.0.1:1", "cannot connect to the Dask scheduler"),
                           ("no-port-here", "bad scheduler address")):
        code = main(["basins", netlists["buck"], "--period", "ts", "--grid",
                     "v(C1)=0:24:4,i(L1)=0:24:4", "--scheduler", address])
        err = capsys.readouterr().err
        assert code == 2 and words in err and "dask worker" in err, err
        assert "Traceback" not in err


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
