"""Worker pool with a progress bar for the parameter and cell sweeps.

:func:`run_tasks` calls ``fn(task, report)`` for every task, in worker processes when more
than one worker is asked for, and returns the results in task order. ``report(n)`` advances
the progress bar by n units from inside a task (a queue carries the counts from the workers to
the parent), so that a long task (a follow-mode sweep of many parameter values) still moves
the bar.

Start method: ``fork`` where available (workers inherit the imported modules and numba's
compiled kernels, so they start in milliseconds), else ``spawn`` (each worker imports pelcs
and loads the kernels from numba's cache, about a second). Task functions, tasks and the map
factories in them must be picklable: module-level functions and dataclasses.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import queue as queue_mod
import sys
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["default_workers", "progress_bar", "run_tasks"]

_QUEUE = None  # set in each worker by _init


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


def _init(q) -> None:
    global _QUEUE
    _QUEUE = q


def _report_to_queue(n: int = 1) -> None:
    if _QUEUE is not None:
        _QUEUE.put(int(n))


def _call(item):
    fn, task = item
    return fn(task, _report_to_queue)


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
) -> list:
    """Run ``fn(task, report)`` for every task; results in task order.

    Parameters
    ----------
    fn : callable
        Module-level function (picklable).
    tasks : sequence
    workers : int, optional
        Processes; default all cores, at most one per task. 1 runs in this process.
    progress : bool
        Show a tqdm bar (terminal only) of ``total`` units advanced by ``report``.
    total : int, optional
        Progress units; default one per task.
    desc, unit : str
        Bar labels.
    start_method : str, optional
        ``"fork"``, ``"spawn"`` or ``"forkserver"``; default fork where available.

    Returns
    -------
    list
        ``fn``'s results, in the order of ``tasks``. An exception in a task is re-raised here.
    """
    tasks = list(tasks)
    total = len(tasks) if total is None else int(total)
    n = default_workers() if workers is None else max(1, int(workers))
    n = min(n, len(tasks)) if tasks else 1
    if n <= 1:
        bar = progress_bar(progress, total, desc, unit)

        def report(k: int = 1) -> None:
            if bar is not None:
                bar.update(k)

        try:
            return [fn(t, report) for t in tasks]
        finally:
            if bar is not None:
                bar.close()
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
