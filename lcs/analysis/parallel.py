"""The task engine of the sweeps: a local process pool, or Dask distributed, with progress.

:func:`run_tasks` calls ``fn(task, report)`` for every task and returns the results in task
order; ``report(n)`` advances the progress bar by n units from inside a task, so that a long
task (a follow-mode sweep of many parameter values) still moves the bar. Where the tasks run
is the ``scheduler``:

``None`` (default) -- locally, with the engine measured to be the faster one on this kind of
    machine (:data:`LOCAL_DEFAULT`): the process pool of this module. A Dask local cluster
    does the same work with the same numbers but costs 2-3 s more to start its worker
    processes (``benchmarks/bench_analysis.py --engines``; numbers in ``docs/performance.md``).
``"processes"`` -- the process pool: ``fork`` where available (workers inherit the imported
    modules and numba's compiled kernels, so they start in milliseconds), else ``spawn``;
    one process per core; a queue carries the progress counts to the parent. One worker (or
    one task) runs in this process.
``"local"`` -- a Dask ``LocalCluster`` of ``workers`` processes (one thread each), started for
    the call and closed after it.
an address (``"tcp://10.0.0.5:8786"``, ``"10.0.0.5:8786"``) or a ``distributed.Client`` -- the
    workers of that Dask scheduler. They need pelcs installed (same version); a task's
    ``report`` goes to the scheduler as a worker event (``Worker.log_event``) and the client
    subscribes to it, so the bar follows the whole cluster. An address is TCP only (TLS,
    WebSocket, UCX need settings: pass a ``distributed.Client`` connected with them), and
    is checked before a Client is made: a closed port fails at once, and an open port must
    answer Dask's handshake as a scheduler within :data:`HANDSHAKE_TIMEOUT` (a dashboard or
    web server never would). Ctrl-C cancels the tasks on the cluster.

The results do not depend on the engine: a task is a pure function of its arguments (the
analysis cores never let the split of the work into tasks change a number), so the pool, a
local cluster and a remote cluster give identical arrays on identical hardware and software.
(Numba compiles for the CPU it runs on: machines of different CPU families may differ in the
last bits.)

Task functions, tasks and the map factories in them must be picklable: module-level
functions and dataclasses. Dask is imported only when a Dask engine is asked for.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import multiprocessing as mp
import os
import queue as queue_mod
import signal
import socket
import sys
import threading
import time
import uuid
from collections.abc import Callable, Sequence
from typing import Any

from .. import interrupt

__all__ = ["LOCAL_DEFAULT", "NOT_RUN", "SchedulerError", "TaskEngine", "default_workers",
           "portable", "progress_bar", "run_tasks", "task_engine"]

# The local engine used when no scheduler is given: "processes" or "local" (see the module
# docstring and docs/performance.md for the measurement behind the choice).
LOCAL_DEFAULT = "processes"

# Seconds to wait for a Dask scheduler's TCP port to accept, and for its first worker.
CONNECT_TIMEOUT = 10.0

# Seconds for whatever listens at a scheduler address to answer Dask's handshake. A scheduler
# answers in milliseconds; anything else there (its dashboard, a web server) never does, and
# Dask's own connect waits for that answer without a time limit.
HANDSHAKE_TIMEOUT = 5.0

# Address schemes Dask knows but a scheduler address string cannot use here: they need
# settings (TLS certificates, UCX) that only a distributed.Client made by the caller carries.
_OTHER_SCHEMES = {"tls": "TLS", "ws": "WebSocket", "wss": "WebSocket", "ucx": "UCX",
                  "inproc": "in-process"}

_QUEUE = None  # set in each pool worker by _init


class SchedulerError(RuntimeError):
    """A Dask scheduler cannot be reached, has no workers, or Dask is not installed.

    Parameters
    ----------
    message : str
        What is wrong (one line).
    hint : str
        What to do, where it is not the usual (start a scheduler and workers); empty for
        the usual.
    """

    def __init__(self, message: str, hint: str = ""):
        super().__init__(message)
        self.hint = hint


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


class _Progress:
    """A bar fed whole units: reports (fractions of a step, Dask events) add up here, and
    the bar moves by the whole units reached (tqdm shows a float count as ``12.0/60``).
    ``bar`` None: nothing is shown, the reports are only counted."""

    def __init__(self, bar, total: int):
        self.bar = bar
        self.total = int(total)
        self.done = 0.0
        self.shown = 0

    def add(self, n: float = 1) -> None:
        self.done += float(n)
        # The allowance keeps a sum of fractions such as ten reports of 0.1 one whole unit.
        self._show(min(int(self.done + 1e-9), self.total))

    def finish(self) -> None:
        """All tasks finished: the bar shows the total (the reports may fall short of it: a
        continuation that stopped early, Dask events still on their way)."""
        self._show(self.total)
        refresh = getattr(self.bar, "refresh", None)
        if callable(refresh):
            refresh()  # drawn now: tqdm skips the draw of an update soon after the last one

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()

    def _show(self, whole: int) -> None:
        if whole > self.shown and self.bar is not None:
            self.bar.update(whole - self.shown)
        self.shown = max(self.shown, whole)


def portable(obj: Any) -> Any:
    """``obj.portable()`` if it has one (with its netlist path made absolute), else ``obj``.

    A map factory that reads files (a netlist path) provides ``portable()``: a copy that
    carries the file's text, so that workers on other machines do not need the file, and
    that long-lived workers do not reuse maps cached for an older version of the file.
    The workers still read the netlist's ``.include``/``.lib`` files, relative to the
    netlist's directory: a relative ``path`` field of such a factory (a dataclass) is made
    absolute here, against this process's working directory, because a Dask worker has a
    working directory of its own. (The included files must then be at that absolute path
    on the workers' machines: a shared or an identical file system.)
    """
    fn = getattr(obj, "portable", None)
    if not callable(fn):
        return obj
    out = fn()
    path = getattr(out, "path", None)
    if (dataclasses.is_dataclass(out) and isinstance(path, str) and path
            and not path.startswith("<") and not os.path.isabs(path)):
        out = dataclasses.replace(out, path=os.path.abspath(path))
    return out


# -- process pool ---------------------------------------------------------------------------


def _init(q) -> None:
    global _QUEUE
    _QUEUE = q
    # Ctrl-C reaches every process of the terminal's group: the parent alone answers it (it
    # stops the pool and keeps the finished tasks), a worker keeps computing until then.
    # SIGTERM is the pool's own way to stop its workers: its default action (a forked worker
    # would otherwise inherit the parent's handler, lcs.interrupt).
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
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


# The result of a task an interrupt left unfinished (``TaskEngine.run(partial=True)``).
NOT_RUN = None


def _run_here(fn, tasks, progress: _Progress, partial: bool = False) -> list:
    if not partial:
        results = [fn(t, progress.add) for t in tasks]
        progress.finish()
        return results
    results = [NOT_RUN] * len(tasks)
    for i, t in enumerate(tasks):
        if interrupt.requested() is not None:
            return results
        value = fn(t, progress.add)
        if interrupt.requested() is not None:
            # (a task of this process may have been cut short by the same request: a
            # simulation stops between kernel calls; it is not counted as finished)
            return results
        results[i] = value
    progress.finish()
    return results


def _run_pool(fn, tasks, n: int, start_method: str | None, progress: bool, total: int,
              desc: str, unit: str, partial: bool = False) -> list:
    if start_method is None:
        start_method = "fork" if "fork" in mp.get_all_start_methods() else "spawn"
    ctx = mp.get_context(start_method)
    q = ctx.Queue()
    # (leaving the block terminates the workers: an interrupt drops the unfinished tasks)
    with ctx.Pool(n, initializer=_init, initargs=(q,)) as pool:
        # The bar is created after the workers exist: its monitor thread must not be forked.
        bar = _Progress(progress_bar(progress, total, desc, unit), total)
        try:
            # One async result per task, in task order (the queue of the pool is FIFO, as
            # map's with chunksize 1): the finished ones are known when an interrupt comes.
            pending = [pool.apply_async(_call, ((fn, t),)) for t in tasks]
            while not all(r.ready() for r in pending):
                if partial and interrupt.requested() is not None:
                    return [r.get() if r.ready() else NOT_RUN for r in pending]
                try:
                    bar.add(q.get(timeout=0.1))
                except queue_mod.Empty:
                    continue
            results = [r.get() for r in pending]
            bar.finish()
        finally:
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
            worker.log_event(topic, float(n))  # the client adds up whole units (_Progress)

    return fn(task, report)


def _drain(events: queue_mod.SimpleQueue, bar: _Progress) -> None:
    while True:
        try:
            bar.add(events.get_nowait())
        except queue_mod.Empty:
            return


def _wait_futures(futures: list, tick: Callable[[], None], interval: float = 0.02,
                  stop: Callable[[], bool] | None = None) -> None:
    """Return when every future is finished, or one is not (an error, a cancel), or
    ``stop()`` is true.

    Polled from this thread instead of blocking in ``client.gather``: a Ctrl-C in the
    middle of a gather leaves its coroutine on the client's event loop, and closing the
    client then logs one "Task exception was never retrieved ... AllExit" traceback per
    task. ``tick()`` runs between polls (it moves the progress bar).
    """
    pending = list(futures)
    while pending:
        still = []
        for f in pending:
            status = f.status
            if status == "pending":
                still.append(f)
            elif status != "finished":
                return  # an error or a cancel: gather raises it at once
        pending = still
        tick()
        if stop is not None and stop():
            return
        if pending:
            time.sleep(interval)


def _quiet_shutdown(record: logging.LogRecord) -> bool:
    """A filter of asyncio's log: False for its report of a future that ended in a timeout
    nobody waited for. Dask's client leaves one when it closes its connection after an
    interrupted run on a loaded machine (its wait for the send loop to stop times out after
    that loop was dropped); the run's own outcome is what pelcs reports. Only tornado's
    timeout ("Timeout"; asyncio's TimeoutError, a class of its own before Python 3.11) is
    dropped."""
    exc = record.exc_info[1] if record.exc_info else None
    return not (isinstance(exc, (TimeoutError, asyncio.TimeoutError)) and str(exc) == "Timeout"
                and record.getMessage().startswith("Future exception was never retrieved"))


def _import_distributed():
    try:
        import distributed
    except ImportError as exc:  # pragma: no cover - a dependency
        raise SchedulerError("Dask distributed is not installed: pip install "
                             "'dask[distributed]'") from exc
    asyncio_log = logging.getLogger("asyncio")
    if _quiet_shutdown not in asyncio_log.filters:
        asyncio_log.addFilter(_quiet_shutdown)
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
            unit: str = "it", partial: bool = False) -> list:
        """``[fn(task, report) for task in tasks]`` on this engine (see :func:`run_tasks`).

        With ``partial`` and inside :func:`lcs.interrupt.deferred_interrupts`, the first
        SIGINT or SIGTERM stops the run: the tasks under way are dropped (the pool's workers
        are terminated, a Dask cluster's tasks cancelled), and the result holds
        :data:`NOT_RUN` (None) for every task that had not finished;
        :func:`lcs.interrupt.requested` then tells the caller the run was interrupted.
        """
        tasks = list(tasks)
        total = len(tasks) if total is None else int(total)
        if partial:
            interrupt.keeping()  # (the finished tasks are worth keeping from now on)
        if self.kind == "dask":
            return self._run_dask(fn, tasks, progress, total, desc, unit, partial)
        n = min(self.workers, len(tasks)) if tasks else 1
        if self.kind == "serial" or n <= 1:
            bar = _Progress(progress_bar(progress, total, desc, unit), total)
            try:
                return _run_here(fn, tasks, bar, partial)
            finally:
                bar.close()
        return _run_pool(fn, tasks, n, self._start_method, progress, total, desc, unit,
                         partial)

    def _run_dask(self, fn, tasks, progress, total, desc, unit, partial=False) -> list:
        if not tasks:
            return []
        client = self._client
        shown = progress_bar(progress, total, desc, unit)
        bar = _Progress(shown, total)
        topic = f"pelcs-progress-{uuid.uuid4().hex}" if shown is not None else None
        # Worker events arrive on the client's event-loop thread: queued there, and the bar
        # moved only by this thread.
        events: queue_mod.SimpleQueue = queue_mod.SimpleQueue()
        if topic is not None:
            client.subscribe_topic(topic, lambda event: events.put(event[1]))
        futures: list = []
        try:
            # Keys named after the sweep: the dashboard's progress bars group them so.
            token = uuid.uuid4().hex
            name = "".join(c if c.isalnum() else "_" for c in (desc or "tasks"))
            futures = [client.submit(_dask_call, fn, t, topic, key=f"pelcs_{name}-{token}-{i}")
                       for i, t in enumerate(tasks)]
            stop = (lambda: interrupt.requested() is not None) if partial else None
            _wait_futures(futures, lambda: _drain(events, bar), stop=stop)
            if stop is not None and stop():
                done = [f.status == "finished" for f in futures]
                got = iter(client.gather([f for f, d in zip(futures, done, strict=True) if d]))
                client.cancel([f for f, d in zip(futures, done, strict=True) if not d])
                return [next(got) if d else NOT_RUN for d in done]
            results = client.gather(futures)
            _drain(events, bar)
            bar.finish()
        except BaseException:
            # Ctrl-C, or an error in a task: the cluster drops the other tasks. Nothing of
            # this run waits on the client's event loop (_wait_futures), so closing the
            # client afterwards is quiet.
            if futures:
                with contextlib.suppress(Exception):
                    client.cancel(futures)
            raise
        finally:
            if topic is not None:
                with contextlib.suppress(Exception):
                    client.unsubscribe_topic(topic)
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
    address, host, port = _check_address(str(scheduler))
    _probe(address, host, port)
    # Made only now that a scheduler answered, and closed at once if it fails: a Client
    # left half-made is closed by its __del__, which waits 20 s on a loop that is gone and
    # then prints a traceback ("Exception ignored in Client.__del__").
    client = distributed.Client.__new__(distributed.Client)
    try:
        client.__init__(address, timeout=CONNECT_TIMEOUT, set_as_default=False)
    except (OSError, TimeoutError, ValueError) as exc:
        _close_quietly(client)
        raise SchedulerError(f"cannot connect to the Dask scheduler at {address}: {exc}"
                             ) from None
    except BaseException:
        _close_quietly(client)
        raise
    try:
        client.wait_for_workers(1, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as exc:
        _close_quietly(client)
        raise SchedulerError(f"the Dask scheduler at {address} has no workers (waited "
                             f"{CONNECT_TIMEOUT:g} s): start some with 'dask worker "
                             f"{address}'") from exc
    except BaseException:
        _close_quietly(client)
        raise
    nthreads = client.nthreads()
    slots = sum(nthreads.values())
    return TaskEngine("dask", max(1, slots), f"Dask scheduler {client.scheduler.address} "
                      f"({len(nthreads)} workers, {slots} threads)", client=client)


def _close_quietly(client) -> None:
    with contextlib.suppress(Exception):
        client.close(timeout=CONNECT_TIMEOUT)


def _check_address(address: str) -> tuple[str, str, int]:
    """``tcp://HOST:PORT``, the host and the port of a scheduler address given as that or
    as ``HOST:PORT`` (Dask's default scheme is TCP); any other scheme, or no port, is a
    :class:`SchedulerError`."""
    address = address.strip()
    example = "expected tcp://HOST:PORT, e.g. tcp://10.0.0.5:8786"
    hint = "give the address that 'dask scheduler' prints as 'Scheduler at: tcp://HOST:PORT'"
    if not address:
        raise SchedulerError(f"empty scheduler address ({example})", hint)
    scheme, sep, location = address.partition("://")
    if not sep:
        scheme, location = "tcp", address
    scheme = scheme.lower()
    if scheme in ("http", "https"):
        raise SchedulerError(
            f"{address} is a web address (a dashboard?), not a Dask scheduler's address",
            "give the scheduler's tcp:// address: 'dask scheduler' prints it as 'Scheduler "
            "at: tcp://HOST:8786' (the dashboard is the web page on port 8787)")
    if scheme in _OTHER_SCHEMES:
        raise SchedulerError(
            f"{address}: {_OTHER_SCHEMES[scheme]} ({scheme}://) scheduler addresses are not "
            "supported here, only tcp://HOST:PORT",
            "in Python, connect a distributed.Client yourself (with the settings the "
            "scheduler needs, e.g. security=) and pass the Client as scheduler= "
            "(e.g. bifurcation_diagram(..., scheduler=client)); or give the scheduler a "
            "tcp:// address")
    if scheme != "tcp":
        raise SchedulerError(f"bad scheduler address {address!r}: unknown scheme "
                             f"{scheme}:// ({example})", hint)
    from distributed.comm.addressing import parse_host_port

    try:
        host, port = parse_host_port(location)
    except ValueError as exc:
        raise SchedulerError(f"bad scheduler address {address!r}: {exc} ({example})",
                             hint) from None
    if not host or not 0 < port < 65536:
        raise SchedulerError(f"bad scheduler address {address!r}: "
                             f"{'no host' if not host else f'port {port}'} ({example})", hint)
    return f"tcp://{location}", host, port


def _probe(address: str, host: str, port: int) -> None:
    """Fail fast, with a :class:`SchedulerError`, unless a Dask scheduler answers at
    ``address`` (``tcp://HOST:PORT``, checked by :func:`_check_address`).

    A closed port is found in milliseconds (the Dask client would retry until its
    timeout); an open one must answer Dask's handshake and say it is a scheduler within
    :data:`HANDSHAKE_TIMEOUT` (Dask's connect would wait for a dashboard's or a web
    server's answer forever).
    """
    try:
        socket.create_connection((host, port), timeout=CONNECT_TIMEOUT).close()
    except OSError as exc:
        raise SchedulerError(f"cannot connect to the Dask scheduler at {address}: "
                             f"{exc.strerror or exc}") from None
    not_dask = (f"{address} is not a Dask scheduler", "is it a dashboard or another "
                "service? Give the scheduler's address: 'dask scheduler' prints it as "
                "'Scheduler at: tcp://HOST:PORT' (port 8786 by default)")
    try:
        identity = _ask_identity(address, HANDSHAKE_TIMEOUT)
    except TimeoutError:
        raise SchedulerError(f"{not_dask[0]} (no answer to Dask's handshake within "
                             f"{HANDSHAKE_TIMEOUT:g} s)",
                             f"{not_dask[1]}; a scheduler too busy to answer in that time "
                             "(a large graph, an overloaded head node): try again") from None
    except OSError:  # Dask's CommClosedError among others
        raise SchedulerError(f"{not_dask[0]} (it closed the connection at Dask's "
                             "handshake)", not_dask[1]) from None
    except Exception as exc:
        raise SchedulerError(f"{not_dask[0]} (its answer to Dask's handshake is not Dask's:"
                             f" {type(exc).__name__})", not_dask[1]) from None
    kind = identity.get("type") if isinstance(identity, dict) else None
    if not isinstance(kind, str):
        raise SchedulerError(f"{not_dask[0]} (no identity after Dask's handshake)",
                             not_dask[1])
    if "scheduler" not in kind.lower():
        raise SchedulerError(f"{address} is a Dask {kind}, not a scheduler",
                             "give the scheduler's address: a worker logs it as "
                             "'Registered to: tcp://HOST:PORT'")


def _ask_identity(address: str, timeout: float) -> dict:
    """The ``identity`` of the Dask server at ``address``, within ``timeout`` seconds.

    Raises TimeoutError without an answer in time, else whatever the connection raised.
    Runs its own event loop in a thread of its own: the caller's thread may have a loop
    running already (a notebook).
    """
    from distributed.comm.addressing import parse_address
    from distributed.comm.registry import get_backend

    scheme, location = parse_address(address)

    async def ask() -> dict:
        comm = await get_backend(scheme).get_connector().connect(location, deserialize=True)
        try:
            # Dask's handshake, then one request, as distributed.comm.connect and rpc do
            # (connect itself would wait for the handshake's answer without a limit).
            await comm.write(comm.handshake_info())
            await comm.read()
            await comm.write({"op": "identity", "reply": True})
            return await comm.read()
        finally:
            comm.abort()

    outcome: dict[str, Any] = {}

    def run() -> None:
        try:
            outcome["identity"] = asyncio.run(asyncio.wait_for(ask(), timeout))
        except BaseException as exc:  # handed to the caller's thread
            outcome["error"] = exc

    thread = threading.Thread(target=run, name="pelcs-dask-probe", daemon=True)
    thread.start()
    thread.join(timeout + 1.0)  # the loop's own wait_for ends it before this
    if thread.is_alive():  # pragma: no cover - a connect stuck below asyncio
        raise TimeoutError
    if "error" in outcome:
        exc = outcome["error"]
        if isinstance(exc, asyncio.TimeoutError):
            raise TimeoutError from None
        raise exc
    return outcome["identity"]


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
        The address is not ``tcp://HOST:PORT`` (or ``HOST:PORT``), nothing listens there,
        what listens is not a Dask scheduler, or the scheduler has no workers.
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
