"""The ngspice worker processes: one child per run, each running ``_worker.py`` (libngspice
through PySpice), with a pool that starts the next one while the current one runs (see the
*Design* notes of :mod:`ngspice_checks.runner`: a process per run keeps ngspice's global
state and its output out of the caller)."""

from __future__ import annotations

import atexit
import os
import queue
import subprocess
import sys
import tempfile
import threading
from pathlib import Path
from typing import Any

from . import _worker

_WORKER_SCRIPT = Path(__file__).with_name("_worker.py")

#: seconds allowed for a worker to start (cold start compiles PySpice's .pyc: ~20 s seen)
STARTUP_TIMEOUT = 120.0


class _WorkerDied(Exception):
    pass


class _Worker:
    """One child process running ``_worker.py``; a thread reads its replies into a queue."""

    def __init__(self) -> None:
        self._stderr = tempfile.TemporaryFile()
        # Hermetic: libngspice reads a ``.spiceinit`` from the working directory and from
        # $HOME when it starts, and such a file may hold ``shell`` commands. A downloaded
        # project's folder must not run anything: the child starts in an empty private
        # folder that is also its HOME (the request's folder, for .include, is entered after
        # ngspice has started).
        self._home = tempfile.TemporaryDirectory(prefix="pelcs-ngspice-")
        env = dict(os.environ)
        env.setdefault("PYTHONUNBUFFERED", "1")
        env["HOME"] = self._home.name
        env.pop("SPICE_USERINIT_DIR", None)
        self.proc = subprocess.Popen(
            [sys.executable, str(_WORKER_SCRIPT)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=self._stderr,
            env=env,
            cwd=self._home.name,
        )
        self._replies: queue.Queue[Any] = queue.Queue()
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()
        self.hello: dict | None = None

    def _read(self) -> None:
        assert self.proc.stdout is not None
        while True:
            try:
                msg = _worker._recv(self.proc.stdout)
            except Exception:  # a torn message means the child died mid-write
                msg = None
            self._replies.put(msg)
            if msg is None:
                return

    def receive(self, timeout: float | None) -> dict:
        try:
            msg = self._replies.get(timeout=timeout)
        except queue.Empty:
            self.kill()
            raise TimeoutError(f"no answer from the ngspice worker within {timeout} s") from None
        if msg is None:
            rc = self.proc.wait()
            raise _WorkerDied(f"the ngspice worker died (exit code {rc}){self._stderr_tail()}")
        return msg

    def _stderr_tail(self) -> str:
        try:
            self._stderr.seek(0)
            text = self._stderr.read().decode("utf-8", "replace").strip()
        except (OSError, ValueError):
            return ""
        return ":\n" + text[-2000:] if text else ""

    def handshake(self) -> dict:
        if self.hello is None:
            self.hello = self.receive(STARTUP_TIMEOUT)
        return self.hello

    def send(self, obj: Any) -> None:
        assert self.proc.stdin is not None
        try:
            _worker._send(self.proc.stdin, obj)
        except (BrokenPipeError, OSError) as exc:
            raise _WorkerDied(f"the ngspice worker is gone: {exc}{self._stderr_tail()}") from exc

    def alive(self) -> bool:
        return self.proc.poll() is None

    def kill(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait()
        self._close_pipes()

    def close(self) -> None:
        """Let an idle worker exit (EOF on its stdin), killing it if it lingers."""
        try:
            if self.proc.stdin is not None:
                self.proc.stdin.close()
            self.proc.wait(timeout=2.0)
        except (OSError, subprocess.TimeoutExpired):
            self.kill()
        self._close_pipes()

    def _close_pipes(self) -> None:
        for stream in (self.proc.stdin, self.proc.stdout, self._stderr):
            try:
                if stream is not None:
                    stream.close()
            except OSError:
                pass
        self._home.cleanup()


class _Pool:
    """At most one idle, pre-started worker; each simulation takes one and starts the next.

    Set ``PELCS_NGSPICE_PREFETCH=0`` to start workers only on demand.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._spare: _Worker | None = None

    def take(self, prefetch: bool = True) -> _Worker:
        with self._lock:
            worker = self._spare if self._spare is not None and self._spare.alive() else None
            self._spare = None
            if worker is None:
                worker = _Worker()
            if prefetch and os.environ.get("PELCS_NGSPICE_PREFETCH", "1") != "0":
                self._spare = _Worker()
        return worker

    def give_back(self, worker: _Worker) -> None:
        """Keep an unused (handshaken, idle) worker as the spare, or let it go."""
        with self._lock:
            if self._spare is None and worker.alive():
                self._spare = worker
                return
        worker.close()

    def shutdown(self) -> None:
        with self._lock:
            spare, self._spare = self._spare, None
        if spare is not None:
            spare.kill()


_POOL = _Pool()
atexit.register(_POOL.shutdown)

