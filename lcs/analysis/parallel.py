"""The task engine of the sweeps: a local process pool, or Dask distributed, with progress.

:func:`run_tasks` calls ``fn(task, report)`` for every task and returns the results in task
order; ``report(n)`` advances the progress bar by n units from inside a task, so that a long
task (a follow-mode sweep of many parameter values) still moves the bar. Where the tasks run
is the ``scheduler``:

``None`` (default) -- locally, with the engine measured to be the faster one on this kind of
    machine (:data:`LOCAL_DEFAULT`): the process pool of this module. A Dask local cluster
    does the same work with the same numbers but costs 2-3 s more to start its worker
    processes (``benchmarks/bench_analysis.py --engines``; numbers in the README).
``"processes"`` -- the process pool: ``fork`` where available (workers inherit the imported
    modules and numba's compiled kernels, so they start in milliseconds), else ``spawn``;
    one process per core; a queue carries the progress counts to the parent. One worker (or
    one task) runs in this process.
``"local"`` -- a Dask ``LocalCluster`` of ``workers`` processes (one thread each), started for
    the call and closed after it.
an address (``"tcp://10.0.0.5:8786"``, ``"10.0.0.5:8786"``) or a ``distributed.Client`` -- the
    workers of that Dask scheduler. They need pelcs installed (same version); a task's
    ``report`` goes to the scheduler as a worker event (``Worker.log_event``) and the client
    subscribes to it, so the bar follows the whole cluster.

The results do not depend on the engine: a task is a pure function of its arguments (the
analysis cores never let the split of the work into tasks change a number), so the pool, a
local cluster and a remote cluster give identical arrays on identical hardware and software.
(Numba compiles for the CPU it runs on: machines of different CPU families may differ in the
last bits.)

Task functions, tasks and the map factories in them must be picklable: module-level
functions and dataclasses. Dask is imported only when a Dask engine is asked for.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import os
import queue as queue_mod
import socket
import sys
import threading
import uuid
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["LOCAL_DEFAULT", "SchedulerError", "TaskEngine", "default_workers", "portable",
           "progress_bar", "run_tasks", "task_engine"]

# The local engine used when no scheduler is given: "processes" or "local" (see the module
# docstring and the README for the measurement behind the choice).
LOCAL_DEFAULT = "processes"

# Seconds to wait for a Dask scheduler to answer, and for its first worker.
CONNECT_TIMEOUT = 10.0

_QUEUE = None  # set in each pool worker by _init


class SchedulerError(RuntimeError):
    """A Dask scheduler cannot be reached, has no workers, or Dask is not installed."""


def default_workers() -> int:
    """The number of usable cores."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def progress_bar(show: bool, total: int, desc: str, unit: str):
    """A tqdm bar on stderr when ``show`` and stderr is a terminal, else None."""
    if not show or not sys.stderr.isatty():
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None
    return tqdm(total=total, desc=desc, unit=unit, leave=False, dynamic_ncols=True)


def portable(obj: Any) -> Any:
    """``obj.portable()`` if it has one, else ``obj``.

    A map factory that reads files (a netlist path) provides ``portable()``: a copy that
    carries the file's text, so that workers on other machines do not need the file, and
    that long-lived workers do not reuse maps cached for an older version of the file.
    """
    fn = getattr(obj, "portable", None)
    return fn() if callable(fn) else obj


# -- process pool ---------------------------------------------------------------------------


def _init(q) -> None:
    global _QUEUE
    _QUEUE = q
    # One BLAS thread per worker: the pool already uses every core, and OpenBLAS's own
    # threads, inherited through fork, spin against each other on the small matrices of the
    # exact method (a 7-value bifurcation diagram took 240 s instead of 3 s on 2 cores).
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - a dependency; only a broken install lacks it
        return
    threadpool_limits(1)


def _report_to_queue(n: float = 1) -> None:
    if _QUEUE is not None:
        _QUEUE.put(n)


def _call(item):
    fn, task = item
    return fn(task, _report_to_queue)


def _run_here(fn, tasks, bar) -> list:
    def report(k: float = 1) -> None:
        if bar is not None:
            bar.update(k)

    return [fn(t, report) for t in tasks]


def _run_pool(fn, tasks, n: int, start_method: str | None, progress: bool, total: int,
              desc: str, unit: str) -> list:
    if start_method is None:
        start_method = "fork" if "fork" in mp.get_all_start_methods() else "spawn"
    ctx = mp.get_context(start_method)
    q = ctx.Queue()
    with ctx.Pool(n, initializer=_init, initargs=(q,)) as pool:
        # The bar is created after the workers exist: its monitor thread must not be forked.
        bar = progress_bar(progress, total, desc, unit)
        try:
            async_result = pool.map_async(_call, [(fn, t) for t in tasks], chunksize=1)
            while not async_result.ready():
                try:
                    k = q.get(timeout=0.1)
                except queue_mod.Empty:
                    continue
                if bar is not None:
                    bar.update(k)
            results = async_result.get()
            while bar is not None:
                try:
                    bar.update(q.get_nowait())
                except queue_mod.Empty:
                    break
        finally:
            if bar is not None:
                bar.close()
    return results


# -- Dask -----------------------------------------------------------------------------------


def _dask_call(fn, task, topic: str | None):
    """Run one task on a Dask worker; ``report`` becomes a worker event on ``topic`` (none
    without a progress bar)."""
    from distributed import get_worker

    worker = None
    if topic is not None:
        try:
            worker = get_worker()
        except ValueError:  # pragma: no cover - run outside a worker
            worker = None

    def report(n: float = 1) -> None:
        if worker is not None and n:
            worker.log_event(topic, float(n))

    return fn(task, report)


def _import_distributed():
    try:
        import distributed
    except ImportError as exc:  # pragma: no cover - a dependency
        raise SchedulerError("Dask distributed is not installed: pip install "
                             "'dask[distributed]'") from exc
    return distributed


class TaskEngine:
    """Where tasks run: this process, the process pool, or a Dask cluster.

    Use :func:`task_engine` to make one (a context manager); ``workers`` is the number of
    tasks that run at once, for the callers' split of the work into tasks.

    Attributes
    ----------
    kind : str
        ``"serial"``, ``"processes"`` or ``"dask"``.
    workers : int
        Parallel slots (processes, or Dask worker threads).
    description : str
        For summaries, e.g. ``"Dask scheduler tcp://127.0.0.1:8786 (2 workers, 2 threads)"``.
    """

    def __init__(self, kind: str, workers: int, description: str, *, client=None,
                 cluster=None, own_client: bool = True, start_method: str | None = None):
        self.kind = kind
        self.workers = int(workers)
        self.description = description
        self._client = client
        self._cluster = cluster
        self._own_client = own_client
        self._start_method = start_method

    @property
    def distributed(self) -> bool:
        """True for a Dask engine (tasks leave this machine's process tree, or may)."""
        return self.kind == "dask"

    def run(self, fn: Callable[[Any, Callable[[int], None]], Any], tasks: Sequence[Any], *,
            progress: bool = False, total: int | None = None, desc: str = "",
            unit: str = "it") -> list:
        """``[fn(task, report) for task in tasks]`` on this engine (see :func:`run_tasks`)."""
        tasks = list(tasks)
        total = len(tasks) if total is None else int(total)
        if self.kind == "dask":
            return self._run_dask(fn, tasks, progress, total, desc, unit)
        n = min(self.workers, len(tasks)) if tasks else 1
        if self.kind == "serial" or n <= 1:
            bar = progress_bar(progress, total, desc, unit)
            try:
                return _run_here(fn, tasks, bar)
            finally:
                if bar is not None:
                    bar.close()
        return _run_pool(fn, tasks, n, self._start_method, progress, total, desc, unit)

    def _run_dask(self, fn, tasks, progress, total, desc, unit) -> list:
        if not tasks:
            return []
        client = self._client
        topic = f"pelcs-progress-{uuid.uuid4().hex}"
        bar = progress_bar(progress, total, desc, unit)
        lock = threading.Lock()
        open_ = [bar is not None]

        def on_event(event) -> None:
            _, n = event
            with lock:
                if open_[0]:
                    bar.update(n)

        if bar is not None:
            client.subscribe_topic(topic, on_event)
        try:
            # Keys named after the sweep: the dashboard's progress bars group them so.
            token = uuid.uuid4().hex
            name = "".join(c if c.isalnum() else "_" for c in (desc or "tasks"))
            futures = [client.submit(_dask_call, fn, t, topic if bar is not None else None,
                                     key=f"pelcs_{name}-{token}-{i}")
                       for i, t in enumerate(tasks)]
            results = client.gather(futures)
        finally:
            if bar is not None:
                client.unsubscribe_topic(topic)
                with lock:
                    open_[0] = False
                    bar.close()
        return list(results)

    def close(self) -> None:
        """Disconnect from the scheduler (a local cluster is shut down; a remote one is not)."""
        if self._client is not None and self._own_client:
            self._client.close()
        self._client = None
        if self._cluster is not None:
            self._cluster.close()
            self._cluster = None

    def __enter__(self) -> TaskEngine:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _dask_engine(scheduler, workers: int | None) -> TaskEngine:
    distributed = _import_distributed()
    if isinstance(scheduler, distributed.Client):
        client = scheduler
        slots = sum(client.nthreads().values())
        return TaskEngine("dask", max(1, slots), f"Dask client of {client.scheduler.address} "
                          f"({len(client.nthreads())} workers, {slots} threads)",
                          client=client, own_client=False)
    if scheduler == "local":
        n = default_workers() if workers is None else max(1, int(workers))
        cluster = distributed.LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                           dashboard_address=":0",
                                           silence_logs=logging.ERROR)
        client = distributed.Client(cluster, set_as_default=False)
        return TaskEngine("dask", n, f"Dask local cluster ({n} worker processes)",
                          client=client, cluster=cluster)
    address = str(scheduler).strip()
    if not address:
        raise SchedulerError("empty scheduler address")
    _probe(address)
    try:
        client = distributed.Client(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        raise SchedulerError(f"cannot connect to the Dask scheduler at {address}: {exc}"
                             ) from None
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as exc:
        client.close()
        raise SchedulerError(f"the Dask scheduler at {address} has no workers (waited "
                             f"{CONNECT_TIMEOUT:g} s): start some with 'dask worker "
                             f"{address}'") from exc
    nthreads = client.nthreads()
    slots = sum(nthreads.values())
    return TaskEngine("dask", max(1, slots), f"Dask scheduler {client.scheduler.address} "
                      f"({len(nthreads)} workers, {slots} threads)", client=client)


def _probe(address: str) -> None:
    """Fail fast on a malformed address or a closed TCP port (the Dask client would retry
    until its timeout, and leave a half-made client behind)."""
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        protocol, location = parse_address(address)
        if protocol not in ("tcp", "tls"):
            return
        host, port = parse_host_port(location)
    except ValueError as exc:
        raise SchedulerError(f"bad scheduler address {address!r}: {exc} (expected "
                             "tcp://HOST:PORT, e.g. tcp://10.0.0.5:8786)") from None
    try:
        socket.create_connection((host, int(port)), timeout=CONNECT_TIMEOUT).close()
    except OSError as exc:
        raise SchedulerError(f"cannot connect to the Dask scheduler at {address}: "
                             f"{exc.strerror or exc}") from None


def task_engine(scheduler=None, workers: int | None = None, *,
                start_method: str | None = None) -> TaskEngine:
    """The engine for ``scheduler`` (see the module docstring); close it after use.

    Parameters
    ----------
    scheduler : None, str or distributed.Client
        None (the local default, :data:`LOCAL_DEFAULT`), ``"processes"``, ``"local"``, a
        Dask scheduler address, or a connected ``distributed.Client`` (left open).
    workers : int, optional
        Local engines: processes (default all cores; 1 runs in this process). Ignored for a
        remote scheduler (its workers' threads are the slots).
    start_method : str, optional
        Process pool start method (``"fork"``, ``"spawn"``, ``"forkserver"``).

    Raises
    ------
    SchedulerError
        The scheduler cannot be reached or has no workers.
    """
    if scheduler is None:
        scheduler = LOCAL_DEFAULT
    if isinstance(scheduler, str) and scheduler.strip().lower() in ("processes", "local"):
        scheduler = scheduler.strip().lower()
    if scheduler == "processes":
        n = default_workers() if workers is None else max(1, int(workers))
        kind = "serial" if n <= 1 else "processes"
        desc = "this process" if n <= 1 else f"{n} local processes"
        return TaskEngine(kind, n, desc, start_method=start_method)
    return _dask_engine(scheduler, workers)


def run_tasks(
    fn: Callable[[Any, Callable[[int], None]], Any],
    tasks: Sequence[Any],
    *,
    workers: int | None = None,
    progress: bool = False,
    total: int | None = None,
    desc: str = "",
    unit: str = "it",
    start_method: str | None = None,
    scheduler=None,
) -> list:
    """Run ``fn(task, report)`` for every task; results in task order.

    Parameters
    ----------
    fn : callable
        Module-level function (picklable).
    tasks : sequence
    workers : int, optional
        Local processes; default all cores, at most one per task. 1 runs in this process.
    progress : bool
        Show a tqdm bar (terminal only) of ``total`` units advanced by ``report``.
    total : int, optional
        Progress units; default one per task.
    desc, unit : str
        Bar labels.
    start_method : str, optional
        ``"fork"``, ``"spawn"`` or ``"forkserver"``; default fork where available.
    scheduler : None, str or distributed.Client
        Where to run (:func:`task_engine`); default locally.

    Returns
    -------
    list
        ``fn``'s results, in the order of ``tasks``. An exception in a task is re-raised here.
    """
    with task_engine(scheduler, workers, start_method=start_method) as eng:
        return eng.run(fn, tasks, progress=progress, total=total, desc=desc, unit=unit)
