"""A stop request reaches the run wherever its main thread is (issue 47).

SIGINT/SIGTERM during the time loop asks it to stop at the end of the step in progress
(``simulation._StopRequest``: that step is checkpointed, exit 130). A step that never ends
(MUMPS's symbolic analysis on a degenerate mesh of 267 000 cells, a Python loop that does
not return) never gets there, and Python runs a signal handler only in the main thread
between bytecodes: the request was lost and ``timeout`` could not stop the run.

The watchdog: a thread that blocks on the read end of Python's signal wake-up pipe
(``signal.set_wakeup_fd``: the C-level handler writes the signal number at once, whatever
the main thread does). After SIGINT or SIGTERM it first writes, at once, an early run.json
(status ``interrupted``: the request arrived during a step after the last checkpoint; if
the status stays, the process was ended before that step finished). Under Open MPI 4.1,
SIGTERM to ``mpirun`` is forwarded to the ranks and followed 1 s later by SIGKILL: without
this record run.json stayed ``running`` although the last checkpoint is whole. The loop's
own last run.json (:func:`final` first) replaces it. Then the thread waits
:data:`STOP_BOUND` seconds
(``DPCOLLAPSE_STOP_BOUND`` sets it) for the main thread to reach a safe point
(:func:`safe_point`, the end of each time step, where the loop honours the request). If
none comes it writes the prepared run.json (:func:`prepare`: status ``interrupted`` and
the reason; the last checkpoint is untouched — a checkpoint is written to a temporary file
and renamed, so the one in place is whole) and the prepared line, and leaves with
``_exit(130)``. Under mpirun every rank that got the signal does the same (Open MPI
forwards it to every rank); a rank that did not is ended by the launcher when the others
leave.

The thread is native (``watchdog_native.c``, built once with the C compiler that DOLFINx's
JIT needs anyway, cached under ``$XDG_CACHE_HOME/dpcollapse``): petsc4py keeps the GIL
through a factorization, so a Python thread would wait with the main thread (measured: a
Python thread ticking every 0.1 s ran twice during a 3.2 s MUMPS factorization). Without a
compiler a Python thread does the same for hangs in Python code (logged once).
"""

from __future__ import annotations

import ctypes
import hashlib
import json
import logging
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

log = logging.getLogger("dpcollapse")

#: Seconds the main thread has, after SIGINT/SIGTERM, to reach the end of its step.
#: The longest step measured on the 2 cm collapse is under 1 s; 20 s leaves room for a
#: fine mesh and stays well inside a batch system's grace time (SLURM's KillWait: 30 s).
STOP_BOUND = 20.0
#: Exit status of an interrupt (``errors.Interrupted``).
EXIT_INTERRUPTED = 130

_SOURCE = Path(__file__).with_name("watchdog_native.c")
_native = None          # the loaded library, or None (the Python thread is used)
_installed = False
_armed = False
_bound = STOP_BOUND
_python_state = {"safe_points": 0, "record": None, "early": None, "line": None,
                 "final": False}
_python_lock = threading.Lock()


def stop_bound() -> float:
    """The bound [s]: ``DPCOLLAPSE_STOP_BOUND`` or :data:`STOP_BOUND`."""
    try:
        value = float(os.environ.get("DPCOLLAPSE_STOP_BOUND", STOP_BOUND))
    except ValueError:
        return STOP_BOUND
    return value if value > 0 and value == value else STOP_BOUND


def _cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "dpcollapse"


def _build() -> Path | None:
    """The native thread's shared library, compiled once per source (cached by its hash)."""
    source = _SOURCE.read_bytes()
    tag = hashlib.sha256(source).hexdigest()[:16]
    target = _cache_dir() / f"watchdog-{tag}.so"
    if target.exists():
        return target
    compiler = os.environ.get("CC", "cc")
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent) as tmp:
        out = Path(tmp) / target.name
        done = subprocess.run([compiler, "-O2", "-shared", "-fPIC", "-pthread", str(_SOURCE),
                               "-o", str(out)], stdin=subprocess.DEVNULL,
                              capture_output=True, timeout=60)
        if done.returncode != 0:
            return None
        os.replace(out, target)   # atomic: another rank may build it at the same time
    return target


def _load():
    try:
        path = _build()
        if path is None:
            return None
        lib = ctypes.CDLL(str(path))
    except (OSError, subprocess.SubprocessError):
        return None
    lib.dpc_start.argtypes = [ctypes.c_int]
    lib.dpc_arm.argtypes = [ctypes.c_double]
    lib.dpc_prepare.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p,
                                ctypes.c_size_t, ctypes.c_char_p, ctypes.c_size_t,
                                ctypes.c_char_p, ctypes.c_size_t]
    return lib


def install(native: bool = True) -> None:
    """Start the watchdog thread (main thread; once per process). It stays idle until
    :func:`arm`. ``native=False``: the Python thread (tests)."""
    global _installed, _native
    if _installed or threading.current_thread() is not threading.main_thread():
        return
    read_fd, write_fd = os.pipe()
    os.set_blocking(write_fd, False)
    signal.set_wakeup_fd(write_fd, warn_on_full_buffer=False)
    _native = _load() if native else None
    if _native is not None and _native.dpc_start(read_fd) == 0:
        _installed = True
        return
    _native = None
    log.debug("stop watchdog: no C compiler; a Python thread watches (it cannot run while "
              "a C library holds the GIL)")
    threading.Thread(target=_python_watch, args=(read_fd,), daemon=True,
                     name="dpcollapse-stop-watchdog").start()
    _installed = True


def arm() -> None:
    """From now on SIGINT/SIGTERM starts the clock (the run command)."""
    global _armed, _bound
    with _python_lock:
        _python_state["final"] = False
    _armed, _bound = True, stop_bound()
    if _native is not None:
        _native.dpc_arm(_bound)


def final() -> None:
    """The main thread is about to write its own last run.json (the run ends: completed,
    failed, or interrupted at a safe point): from now on the early record is not written;
    one being written is renamed into place before this returns (the same lock), so the
    main thread's write comes after it and wins."""
    if _native is not None:
        _native.dpc_final()
    else:
        with _python_lock:
            _python_state["final"] = True


def safe_point() -> None:
    """The main thread is at the end of a step, where the loop honours a stop request."""
    if _native is not None:
        _native.dpc_safe_point()
    else:
        _python_state["safe_points"] += 1


def prepare(run_json: Path, data: dict, where: str, early_where: str | None = None) -> None:
    """What the watchdog writes: at once on SIGINT/SIGTERM, ``run_json`` as ``data`` with
    status ``interrupted`` and the early reason (the request arrived during a step after
    ``early_where``, default ``where``); if it fires, the same with the reason (``where``:
    the last checkpoint) and the one line."""
    reason = (f"stopped at once: the run did not reach the end of its step within {_bound:g} s "
              f"of the stop request (SIGINT/SIGTERM); {where}")
    early_reason = (
        f"a stop request (SIGINT/SIGTERM) arrived during a step after "
        f"{early_where or where}; if this status stays, the process was ended before that "
        "step finished (e.g. by mpirun after forwarding the signal)")

    def text(why: str) -> str:
        summary = {**data.get("summary", {}), "error": why}
        return json.dumps({**data, "status": "interrupted", "summary": summary}, indent=2,
                          default=float) + "\n"

    record, early = text(reason), text(early_reason)
    rank = _rank_prefix()
    line = (f"dpcollapse: error: {rank}interrupted: {reason}; the run directory is valid, "
            "continue with --resume\n")
    run_json = Path(run_json)
    tmp = run_json.with_name(f"{run_json.name}.{os.getpid()}.watchdog.tmp")
    if _native is not None:
        raw, first, msg = record.encode(), early.encode(), line.encode()
        _native.dpc_prepare(str(run_json).encode(), str(tmp).encode(), raw, len(raw),
                            first, len(first), msg, len(msg))
    else:
        with _python_lock:
            _python_state["record"] = (run_json, tmp, record)
            _python_state["early"] = (run_json, tmp, early)
            _python_state["line"] = line


def prepare_run(info, state, rank: int) -> None:
    """:func:`prepare` for the time loop: ``info`` its RunInfo (run.json), ``state`` its
    LoopState (the last checkpoint's step and time); rank 0 only (it writes run.json and
    the line; another rank leaves silently with the same status)."""
    if rank != 0:
        return
    if state.checkpoint_step is not None:
        where = f"the last checkpoint (step {state.checkpoint_step}, t = {state.t:.4f} s) is whole"
        early = (f"the last checkpoint (step {state.checkpoint_step}, t = {state.t:.4f} s): "
                 "it is whole, continue with --resume")
    else:
        where = "no checkpoint was written yet"
        early = ("the start, before the first checkpoint: nothing to resume, start the run "
                 "again")
    prepare(info.path, info.data, where, early)


def prepare_line(where: str) -> None:
    """Only the line (no run.json yet: the set-up)."""
    line = (f"dpcollapse: error: {_rank_prefix()}interrupted: stopped at once, {_bound:g} s "
            f"after the stop request (SIGINT/SIGTERM); {where}\n")
    if _native is not None:
        msg = line.encode()
        _native.dpc_prepare(b"", b"", None, 0, None, 0, msg, len(msg))
    else:
        with _python_lock:
            _python_state["record"], _python_state["early"] = None, None
            _python_state["line"] = line


def _rank_prefix() -> str:
    mpi = sys.modules.get("mpi4py.MPI")
    if mpi is not None and mpi.Is_initialized() and mpi.COMM_WORLD.size > 1:
        return f"[rank {mpi.COMM_WORLD.rank}] "
    return ""


def _python_watch(read_fd: int) -> None:
    """The Python fallback of the native thread (same logic)."""
    while True:
        try:
            data = os.read(read_fd, 1)
        except InterruptedError:
            continue
        except OSError:
            return
        if not data:
            return
        if data[0] in (signal.SIGINT, signal.SIGTERM) and _armed:
            break
    seen, start = _python_state["safe_points"], time.monotonic()
    # The early record at once, under the lock :func:`final` takes (the race with the main
    # thread's last run.json: see watchdog_native.c); skipped after a safe point.
    early_written = False
    with _python_lock:
        early = _python_state["early"]
        if (not _python_state["final"] and _python_state["safe_points"] == seen
                and early is not None and _still_running(early[0])):
            _write(early)
            early_written = True
    while time.monotonic() - start < _bound:
        time.sleep(0.02)
        if _python_state["safe_points"] != seen:
            return
    with _python_lock:
        record, line = _python_state["record"], _python_state["line"]
        try:
            # not over the main thread's own last run.json, nor another rank's record
            if (not _python_state["final"] and record is not None
                    and (early_written or _still_running(record[0]))):
                _write(record)
            if line:
                os.write(2, line.encode())
        finally:
            os._exit(EXIT_INTERRUPTED)


def _still_running(path) -> bool:
    """run.json still says "running" (or cannot be read); its first key is the status.
    The same test as the native thread's (``still_running``)."""
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError:
        return True
    at = head.find(b'"status"')
    if at < 0:
        return True
    return head[at + 8:].lstrip(b" :\n\t").startswith(b'"running"')


def _write(record) -> None:
    """``(path, tmp, text)``: text to tmp, fsync, rename onto path (the Python thread)."""
    if record is None:
        return
    path, tmp, text = record
    try:
        with open(tmp, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except OSError:
        pass
