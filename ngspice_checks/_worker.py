"""Child process that runs exactly one ngspice simulation through PySpice's shared library.

Started by :mod:`ngspice_checks.runner` as ``python _worker.py`` (a plain script, so that it
needs neither the package on ``sys.path`` nor an ``if __name__ == "__main__"`` guard in the
user's program). Why a fresh process per simulation is explained in the runner's docstring;
in short, libngspice keeps ``.options`` such as ``cshunt`` from one circuit to the next, a
failed run can leave it unusable, and a crash would take the user's process with it.

Protocol on the original stdin/stdout (each message: 8-byte big-endian length + pickle):

1. the worker sends ``{"ok": bool, "version": str, "error": str, "log": [...]}`` as soon as
   libngspice is initialised (or failed to be);
2. it then reads one request ``{"netlist": str, "vectors": list | None, "workdir": str | None}``
   and answers with the raw outcome (return codes, log, vectors); judging success is the
   parent's job;
3. it exits. EOF instead of a request (the parent has no more work) also ends it.

File descriptors 1 and 2 are pointed at a temporary file before PySpice is imported, so
nothing PySpice or libngspice prints reaches the user's terminal or corrupts the protocol;
that text is returned in the log.
"""

from __future__ import annotations

import os
import pickle
import struct
import sys
import tempfile
import threading
import time

_HEADER = struct.Struct(">Q")


def _send(stream, obj) -> None:
    data = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    stream.write(_HEADER.pack(len(data)))
    stream.write(data)
    stream.flush()


def _recv(stream):
    head = stream.read(_HEADER.size)
    if len(head) < _HEADER.size:
        return None
    (size,) = _HEADER.unpack(head)
    data = stream.read(size)
    if len(data) < size:
        return None
    return pickle.loads(data)


class _Session:
    """PySpice's NgSpiceShared with our own output capture and no error guessing.

    PySpice 1.5 decides that a command failed when the word "error" occurs anywhere in
    ngspice's stdout, e.g. in a title like "Error amplifier ...", and raises; we call the
    library entry points directly and let the parent judge the outcome from the log.
    """

    def __init__(self) -> None:
        import logging
        import warnings

        self.log: list[str] = []
        records = self.log
        self.progress: list[tuple[float, float]] = []  # (wall clock s, simulated time s)
        self.finished = threading.Event()

        class _ToLog(logging.Handler):
            def emit(self, record: logging.LogRecord) -> None:
                records.append(f"pyspice {record.levelname.lower()}: {record.getMessage()}")

        # PySpice logs "Unsupported Ngspice version 39" and echoes ngspice's stderr as
        # errors; keep all of it in our log only.
        logger = logging.getLogger("PySpice")
        logger.handlers[:] = [_ToLog()]
        logger.setLevel(logging.DEBUG if os.environ.get("PELCS_NGSPICE_DEBUG") else logging.INFO)
        logger.propagate = False

        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            from PySpice.Spice.NgSpice import Shared

            self._ffi = Shared.ffi
            base = Shared.NgSpiceShared

            session = self

            class Capture(base):
                def send_char(self, message, ngspice_id):
                    session._on_output(message)
                    return 0

                def send_stat(self, message, ngspice_id):
                    return 0

                # PySpice's own callback returns None, which cffi reports on stderr
                @staticmethod
                def _background_thread_running(no_run, ngspice_id, user_data):
                    if no_run:
                        session.finished.set()
                    return 0

            if "NGSPICE_LIBRARY_PATH" not in os.environ:
                base.LIBRARY_PATH = _library_path(base.LIBRARY_PATH)
            self.ng = Capture.new_instance()
        # from now on send_char records ngspice's own lines; PySpice's echo of them as log
        # records would only duplicate them
        logging.getLogger("PySpice.Spice.NgSpice.Shared").setLevel(logging.CRITICAL)
        for w in caught:
            records.append(f"python warning: {w.category.__name__}: {w.message}")
        self.version = str(getattr(self.ng, "_ngspice_version", "?"))

    def _on_output(self, message: str) -> None:
        # "Reference value : 5.4e-03" is ngspice's progress report (every ~0.3 s of a run):
        # fed to the stall watchdog, kept out of the log
        if "Reference value" in message:
            try:
                value = float(message.split(":", 1)[1].strip())
            except (IndexError, ValueError):
                return
            self.progress.append((time.perf_counter(), value))
            return
        self.log.append(message.rstrip("\r\n"))

    def command(self, cmd: str) -> int:
        return int(self.ng._ngspice_shared.ngSpice_Command(cmd.encode("ascii")))

    def load(self, netlist: str) -> int:
        # one C string per physical line; unlike PySpice we keep blank lines, so that a
        # blank first line stays the title instead of swallowing the first element
        lines = netlist.splitlines() + [""]
        keep = [self._ffi.new("char[]", line.encode("utf-8")) for line in lines]
        keep.append(self._ffi.NULL)
        return int(self.ng._ngspice_shared.ngSpice_Circ(self._ffi.new("char *[]", keep)))

    def running(self) -> bool:
        return bool(self.ng._ngspice_shared.ngSpice_running())

    def current_plot(self) -> str:
        return self._ffi.string(self.ng._ngspice_shared.ngSpice_CurPlot()).decode()

    def vector_names(self, plot: str) -> list[str]:
        lib, ffi = self.ng._ngspice_shared, self._ffi
        names = []
        array = lib.ngSpice_AllVecs(plot.encode())
        i = 0
        while array[i] != ffi.NULL:
            names.append(ffi.string(array[i]).decode())
            i += 1
        return names

    def vectors(self, plot: str, wanted: list[str] | None) -> dict:
        import numpy as np

        lib, ffi = self.ng._ngspice_shared, self._ffi
        names = self.vector_names(plot)
        alias = {n.lower(): n.lower() for n in names}
        if wanted is not None:
            # a node named by a number has the vector "v(1)", not "1"
            alias = {}
            for w in wanted:
                alias.setdefault(f"v({w.lower()})", w.lower())
            for w in wanted:
                alias[w.lower()] = w.lower()
            names = [n for n in names if n.lower() in alias]
        out = {}
        for name in names:
            info = lib.ngGet_Vec_Info(f"{plot}.{name}".encode())
            n = info.v_length
            if info.v_realdata != ffi.NULL:
                buf = ffi.buffer(info.v_realdata, n * 8)
                out[alias[name.lower()]] = np.frombuffer(buf, dtype=np.float64).copy()
            elif info.v_compdata != ffi.NULL:
                buf = ffi.buffer(info.v_compdata, n * 16)
                out[alias[name.lower()]] = np.frombuffer(buf, dtype=np.complex128).copy()
        return out


def _library_path(default: str) -> str:
    """PySpice's 'libngspice.so' needs the -dev symlink; fall back to the versioned name."""
    import ctypes
    import ctypes.util

    try:
        ctypes.CDLL(default.format(""))
        return default
    except OSError:
        found = ctypes.util.find_library("ngspice")
        return found if found else default


def _tstop(listing: list[str]) -> float | None:
    """TSTOP from the ``.tran`` line of ``listing expand`` (numbers, maybe with suffixes)."""
    scale = {
        "t": 1e12,
        "g": 1e9,
        "meg": 1e6,
        "k": 1e3,
        "m": 1e-3,
        "u": 1e-6,
        "n": 1e-9,
        "p": 1e-12,
        "f": 1e-15,
    }
    for line in listing:
        tokens = line.split(":", 1)[-1].split()
        if len(tokens) > 2 and tokens[0].lower() == ".tran":
            text = tokens[2].lower()
            for suffix in sorted(scale, key=len, reverse=True):
                if text.endswith(suffix):
                    try:
                        return float(text[: -len(suffix)]) * scale[suffix]
                    except ValueError:
                        return None
            try:
                return float(text)
            except ValueError:
                return None
    return None


def _stalled(session: _Session, started: float, tstop: float | None, budget: float) -> str:
    """Non-empty reason when the run cannot finish within ``budget`` seconds at its pace.

    Judged after ``min(5 s, budget/2)``: finishing in time must look impossible both at the
    pace of the last few seconds and (with a factor 4 of slack, for runs that slow down for
    a while) at the average pace since the start. The caller halts the run only when this
    verdict has held for another ``min(5 s, budget/4)``.
    """
    now = time.perf_counter()
    elapsed = now - started
    settle = min(5.0, budget / 2.0)
    if tstop is None or elapsed < settle or len(session.progress) < 2:
        return ""
    wall, sim = session.progress[-1]
    remaining = tstop - sim
    if remaining <= 0:
        return ""
    window = [p for p in session.progress if p[0] >= wall - settle]
    w0, s0 = window[0]
    recent = (sim - s0) / (wall - w0) if wall - w0 >= settle / 2.0 else float("inf")
    average = sim / max(wall - started, 1e-9)
    if elapsed + remaining / max(recent, 1e-300) > budget and (
        elapsed + remaining / max(average, 1e-300) > budget / 4.0
    ):
        pace = recent if recent != float("inf") else average
        return (
            f"stalled: at t = {sim:.6g} s of {tstop:.6g} s after {elapsed:.1f} s, advancing "
            f"{pace:.3g} s per second; would not finish within the {budget:g} s timeout"
        )
    return ""


def _simulate(session: _Session, request: dict) -> dict:
    log = session.log
    del log[:]
    if request.get("workdir"):
        os.chdir(request["workdir"])
    t0 = time.perf_counter()
    load_rc = session.load(request["netlist"])
    n_load = len(log)
    # the deck as ngspice expanded it (numparam evaluated): TSTOP for the watchdog and the
    # parent's completeness check
    session.command("listing expand")
    listing = log[n_load:]
    del log[n_load:]
    tstop = _tstop(listing)
    budget = request.get("timeout") or float("inf")
    t1 = time.perf_counter()
    # background run, so that this thread can watch the pace and halt a hopeless run
    session.finished.clear()
    del session.progress[:]
    run_rc = session.command("bg_run")
    stalled = ""
    hopeless_since = None  # the verdict must hold for a while: paces fluctuate
    while not session.finished.wait(0.05):
        now = time.perf_counter()
        # the end-of-thread callback is the signal; ngSpice_running() is False for a moment
        # after bg_run, so it only serves as a fallback (no circuit -> no thread)
        if now - t1 > 1.0 and not session.running():
            break
        verdict = _stalled(session, t1, tstop, budget)
        if not verdict:
            hopeless_since = None
            continue
        hopeless_since = now if hopeless_since is None else hopeless_since
        if now - hopeless_since >= min(5.0, budget / 4.0):
            stalled = verdict
            session.command("bg_halt")
            session.finished.wait(10.0)
            break
    t2 = time.perf_counter()
    plot = session.current_plot()
    is_tran = plot.startswith("tran")
    vectors = session.vectors(plot, request.get("vectors")) if is_tran else {}
    reply = {
        "names": [n.lower() for n in session.vector_names(plot)] if is_tran else [],
        "n_load_lines": n_load,
        "load_rc": load_rc,
        "run_rc": run_rc,
        "plot": plot,
        "vectors": vectors,
        "log": list(log),
        "listing": listing,
        "load_time": t1 - t0,
        "run_time": t2 - t1,
    }
    if stalled:
        reply["failure"] = stalled
    return reply


def main() -> int:
    proto_in = sys.stdin.buffer
    proto_out = os.fdopen(os.dup(1), "wb")
    # from here on, whatever anything prints on fd 1/2 lands in `spill` (read into the log)
    spill = tempfile.TemporaryFile()
    os.dup2(spill.fileno(), 1)
    os.dup2(spill.fileno(), 2)
    sys.stdout = sys.stderr = open(os.devnull, "w")

    def spilled() -> list[str]:
        spill.seek(0)
        text = spill.read().decode("utf-8", "replace")
        spill.seek(0)
        spill.truncate()
        return [f"output: {line}" for line in text.splitlines() if line.strip()]

    try:
        session = _Session()
    except Exception as exc:  # reported to the parent, which raises
        _send(proto_out, {"ok": False, "error": f"{type(exc).__name__}: {exc}", "log": spilled()})
        return 1
    _send(proto_out, {"ok": True, "version": session.version, "log": session.log + spilled()})
    request = _recv(proto_in)
    if request is None:
        return 0
    try:
        reply = _simulate(session, request)
        reply["log"] += spilled()
    except Exception as exc:
        reply = {"error": f"{type(exc).__name__}: {exc}", "log": session.log + spilled()}
    _send(proto_out, reply)
    proto_out.close()
    # skip interpreter teardown: libngspice's atexit handlers have been seen to print or hang
    os._exit(0)


if __name__ == "__main__":
    sys.exit(main())
