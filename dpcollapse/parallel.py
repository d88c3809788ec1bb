"""Ending an MPI job together: an error on one rank must never leave another rank spinning.

A rank that fails while the others wait in a collective call (an allreduce, a solve) would
otherwise hang the job until its wall-time limit. The protocol:

1. **A control communicator** (:func:`start`, a duplicate of ``MPI.COMM_WORLD`` made by
   every rank at the same point of the command line) carries the failure protocol, so its
   messages never mix with a collective call left pending on ``COMM_WORLD`` (that mix
   raised ``MPI_ERR_TRUNCATE`` when SIGTERM hit the ranks at different calls).
2. **A failing rank notifies the others** (:func:`notify_failure`: a message with its
   exit status and its one-line error to every rank), then waits at a non-blocking barrier
   on the control communicator (:func:`end_together`).
3. **Failure-aware collective calls** (:func:`allreduce`, :func:`bcast`, :func:`barrier`,
   :func:`on_root`, :func:`agree`; non-blocking MPI calls polled) watch for that message
   while they wait and raise :class:`PeerFailed` (the failing rank's status and line),
   and let Python's signal handlers run (SIGTERM while waiting is an interrupt). The run's
   own collective points use them: claiming the run directory, the per-step stop check,
   every write that rank 0 does alone (run.json, config.yaml, diagnostics.csv, the XDMF
   master, the checkpoint), whose outcome every rank then shares.
4. When every rank reaches the barrier within the grace time (``DPCOLLAPSE_MPI_GRACE``,
   default :data:`DEFAULT_GRACE` s), the job ends normally with the error's status and
   rank 0 prints the line; when one does not (it is inside a solver's own MPI calls, which
   cannot watch), the failing rank runs the abort hooks (writing run.json as ``failed``)
   and aborts the whole job with ``MPI_Abort`` and the status.

Nothing here imports mpi4py unless MPI is already in use, so serial commands that never
touch MPI stay free of it.
"""

from __future__ import annotations

import os
import pickle
import sys
import time
import traceback
from collections.abc import Callable
from contextlib import contextmanager
from typing import Any

from dpcollapse.errors import DpcollapseError

#: Seconds the failing ranks wait for the others before aborting the job.
DEFAULT_GRACE = 10.0
_POLL = 0.01
#: Tag of the failure notices on the control communicator.
FAILURE_TAG = 4077
#: Busy polls of a request before the wait sleeps between polls (keeps fast calls fast).
_SPINS = 200
_SLEEP = 0.0005
#: Pause between a rank's last line and its MPI_Abort: MPICH's Hydra may end the job before
#: it has forwarded the line (CI, pip path: 1 run in 14 under load came out without it).
_LINE_PAUSE = 0.5

_control = None                 # the control communicator (start())
_failure: tuple | None = None   # (rank, exit status, message) once this rank knows of a failure
_sent: list = []                # pending notices (kept alive until the end)
_abandoned = False              # a failure-aware wait was left by an exception
_abort_hooks: list[Callable[[], None]] = []


class NotArrived(Exception):
    """The other ranks did not reach a failure-aware call within its time bound."""


class PeerFailed(DpcollapseError):
    """Another rank failed: its exit status and one-line message, raised on this rank while
    it waited in a failure-aware collective call."""

    def __init__(self, rank: int, exit_code: int, message: str):
        super().__init__(message)
        self.rank = rank
        self.exit_code = exit_code


def _mpi():
    return sys.modules["mpi4py.MPI"]


def _world():
    """MPI.COMM_WORLD if mpi4py has been imported and MPI initialized, else None."""
    if "mpi4py.MPI" not in sys.modules:
        return None
    MPI = _mpi()
    if not MPI.Is_initialized() or MPI.Is_finalized():
        return None
    return MPI.COMM_WORLD


def several_ranks() -> bool:
    """Whether this process is one rank of an MPI job of several."""
    world = _world()
    return world is not None and world.size > 1


def start() -> None:
    """Create the control communicator (collective over COMM_WORLD: every rank must call
    it at the same point). A no-op without MPI, on one rank, when already done, and under
    ``python -m mpi4py.futures`` (the sweep's driver: the other ranks are workers)."""
    global _control
    world = _world()
    if "mpi4py.futures" in sys.modules:   # only the driver (rank 0) runs the command line
        return
    if _control is None and world is not None and world.size > 1:
        _control = world.Dup()


def grace_seconds() -> float:
    """The grace time, from ``DPCOLLAPSE_MPI_GRACE`` (seconds) or the default."""
    try:
        return max(0.0, float(os.environ.get("DPCOLLAPSE_MPI_GRACE", DEFAULT_GRACE)))
    except ValueError:
        return DEFAULT_GRACE


# ----------------------------------------------------------------------------- notices
def notify_failure(exit_code: int, message: str) -> None:
    """Tell every other rank that this one is failing (once; not when this rank only
    learned of another's failure)."""
    global _failure
    if _failure is not None or _control is None:
        return
    _failure = (_control.rank, exit_code, message)
    for rank in range(_control.size):
        if rank != _control.rank:
            _sent.append(_control.isend((exit_code, message), dest=rank, tag=FAILURE_TAG))


def check_peers() -> None:
    """Raise :class:`PeerFailed` when another rank has reported a failure."""
    global _failure
    if _control is None:
        return
    MPI = _mpi()
    status = MPI.Status()
    if not _control.Iprobe(source=MPI.ANY_SOURCE, tag=FAILURE_TAG, status=status):
        return
    rank = status.Get_source()
    exit_code, message = _control.recv(source=rank, tag=FAILURE_TAG)
    if _failure is None:
        _failure = (rank, exit_code, message)
    raise PeerFailed(rank, exit_code, message)


def _drain() -> None:
    """Receive the notices still queued (the job is ending together)."""
    if _control is None:
        return
    MPI = _mpi()
    while _control.Iprobe(source=MPI.ANY_SOURCE, tag=FAILURE_TAG):
        _control.recv(source=MPI.ANY_SOURCE, tag=FAILURE_TAG)


def wait(request, timeout: float | None = None) -> None:
    """Complete a non-blocking MPI request, watching for other ranks' failures (raises
    :class:`PeerFailed`) and letting signal handlers run (an interrupt while waiting).
    With ``timeout`` (seconds), raise :class:`NotArrived` when the request has not
    completed by then (the request is left pending)."""
    global _abandoned
    spins = 0
    deadline = None if timeout is None else time.monotonic() + timeout
    try:
        while not request.Test():
            check_peers()
            spins += 1
            if spins > _SPINS:
                time.sleep(_SLEEP)
                if deadline is not None and time.monotonic() >= deadline:
                    raise NotArrived(f"the other ranks did not arrive within {timeout:g} s")
    except BaseException:
        _abandoned = True     # a collective call left pending: the ranks are out of step
        raise


def out_of_step() -> bool:
    """Whether this rank learned of another's failure or left a collective call pending:
    then the ranks stopped at different calls, and no collective terminator (PETSc's) may
    run at exit."""
    return _abandoned or (_failure is not None and several_ranks())


# ----------------------------------------------------------------------------- collectives
def barrier(comm) -> None:
    """A failure-aware barrier."""
    if comm.size > 1:
        wait(comm.Ibarrier())


def allreduce(comm, value, op=None, timeout: float | None = None):
    """A failure-aware allreduce of one number or bool (``op``: MPI.SUM by default, MAX,
    MIN, LOR, LAND); returns the same type. ``timeout``: see :func:`wait`."""
    import numpy as np

    MPI = _mpi()
    op = MPI.SUM if op is None else op
    if comm.size == 1:
        return value
    kind = type(value)
    if isinstance(value, (bool, np.bool_)):
        send, kind = np.array([int(value)], dtype=np.int64), bool
    elif isinstance(value, (int, np.integer)):
        send = np.array([value], dtype=np.int64)
    else:
        send = np.array([value], dtype=np.float64)
    recv = np.empty_like(send)
    wait(comm.Iallreduce(send, recv, op=op), timeout)
    return kind(recv[0]) if kind in (bool, int, float) else recv[0]


def bcast(comm, obj: Any = None, root: int = 0) -> Any:
    """A failure-aware broadcast of a picklable object."""
    import numpy as np

    if comm.size == 1:
        return obj
    MPI = _mpi()
    data = pickle.dumps(obj) if comm.rank == root else b""
    size = np.array([len(data)], dtype=np.int64)
    wait(comm.Ibcast(size, root=root))
    buf = bytearray(data) if comm.rank == root else bytearray(int(size[0]))
    wait(comm.Ibcast([buf, MPI.BYTE], root=root))
    return obj if comm.rank == root else pickle.loads(bytes(buf))


def on_root(comm, fn: Callable[[], Any]) -> Any:
    """Run ``fn`` on rank 0 of ``comm`` and share its outcome: every rank returns its
    result, or raises its exception (an I/O failure of a file rank 0 writes alone ends
    every rank at the same point)."""
    result, error = None, None
    if comm.rank == 0:
        try:
            result = fn()
        except Exception as exc:
            error = exc
    if comm.size > 1:
        result, error = bcast(comm, (result, _picklable(error)), root=0)
    if error is not None:
        raise error
    return result


def agree(comm, fn: Callable[[], Any]) -> Any:
    """Run ``fn`` on every rank; if it raises on any, every rank raises the exception of
    the lowest failing rank (a failure-aware point of agreement).

    A rank whose ``fn`` failed waits for the others at most the grace time and then
    raises its own exception (the caller ends the job, :func:`end_together`): a C
    library's collective call may have failed on this rank alone and left the others
    inside it (a parallel HDF5 write on a full disk under MPICH: one rank's write fails,
    the other waits in HDF5's MPI-IO for it, never reaching this point)."""
    error = None
    try:
        result = fn()
    except Exception as exc:
        result, error = None, exc
    if comm.size == 1:
        if error is not None:
            raise error
        return result
    try:
        first = allreduce(comm, comm.rank if error is not None else comm.size, op=_mpi().MIN,
                          timeout=grace_seconds() if error is not None else None)
    except NotArrived:
        raise error from None
    if first == comm.size:
        return result
    shared = bcast(comm, _picklable(error) if comm.rank == first else None, root=first)
    raise (error if error is not None else shared)


def _picklable(error: BaseException | None) -> BaseException | None:
    if error is None:
        return None
    try:
        pickle.loads(pickle.dumps(error))
        return error
    except Exception:
        return RuntimeError(f"{type(error).__name__}: {error}")


# ----------------------------------------------------------------------------- the end
def meeting_comm():
    """The communicator on which ending ranks meet: the control communicator (no collective
    call left pending on COMM_WORLD by the error can mix with the meeting: a failed parallel
    HDF5 write's did, MPI_ERR_TRUNCATE), else COMM_WORLD; None without MPI."""
    return _control if _control is not None else _world()


def all_arrive(comm, timeout: float) -> bool:
    """True when every rank of ``comm`` reaches this call within ``timeout`` seconds.

    A non-blocking barrier polled until it completes or the time is up; on time-out the
    request is left pending (the caller is about to abort the job).
    """
    if comm.size == 1:
        return True
    request = comm.Ibarrier()
    deadline = time.monotonic() + timeout
    while True:
        if request.Test():
            return True
        if time.monotonic() >= deadline:
            return False
        time.sleep(_POLL)


def on_abort(hook: Callable[[int, str], None]) -> Callable[[int, str], None]:
    """Call ``hook(exit_code, message)`` on this rank just before it ends the job at once
    (e.g. write run.json as failed when rank 0, which normally writes it, is stuck).
    Remove it with :func:`remove_abort_hook`."""
    _abort_hooks.append(hook)
    return hook


def remove_abort_hook(hook) -> None:
    if hook in _abort_hooks:
        _abort_hooks.remove(hook)


def _run_abort_hooks(exit_code: int, message: str) -> None:
    for hook in list(_abort_hooks):
        try:
            hook(exit_code, message)
        except Exception:
            pass


def abort_job(comm, exit_code: int, message: str) -> None:
    """Run the abort hooks, write ``message`` (one line, naming this rank) to stderr and
    abort every rank."""
    _run_abort_hooks(exit_code, message)
    sys.stderr.write(f"dpcollapse: error: [rank {comm.rank}] {message}\n")
    sys.stderr.flush()
    time.sleep(_LINE_PAUSE)
    # On COMM_WORLD whatever ``comm`` is: MPICH passes the status on only then (on the
    # control communicator its mpiexec exited 1 instead of 5: 3 runs in 40)
    world = _world()
    try:
        (world if world is not None else comm).Abort(exit_code if 0 < exit_code < 256 else 1)
    finally:   # MPI_Abort does not return; should it (MPICH's did, then the caller printed
        os._exit(exit_code)   # the error a second time), leave without a second line


def fail_now(exit_code: int, message: str) -> None:
    """End the whole job from any thread, at once: the abort hooks, one line, then
    ``MPI_Abort`` (several ranks) or ``os._exit`` (one process). For a main thread stuck
    in a C library that never returns (see :func:`time_limit`)."""
    world = _world()
    if world is not None and world.size > 1:
        abort_job(world, exit_code, message)   # does not return
    _run_abort_hooks(exit_code, message)
    sys.stderr.write(f"dpcollapse: error: {message}\n")
    sys.stderr.flush()
    sys.stdout.flush()
    os._exit(exit_code)


@contextmanager
def time_limit(seconds: float, exit_code: int, message: Callable[[float], str]):
    """Bound a call into a C library that may never return (gmsh looping on a degenerate
    boundary): past ``seconds`` a watchdog thread ends the job (:func:`fail_now`) with
    ``exit_code`` and ``message(seconds)``."""
    import threading

    timer = threading.Timer(seconds, lambda: fail_now(exit_code, message(seconds)))
    timer.daemon = True
    timer.start()
    try:
        yield
    finally:
        timer.cancel()


def end_together(exit_code: int, message: str, peer: bool = False) -> bool:
    """Called by a rank that is about to exit with an error (``peer``: the error is
    another rank's, learned in a failure-aware call).

    Notifies the other ranks, then returns True when every rank reaches the end within
    the grace time (or there is no MPI job): the caller reports (rank 0) and exits
    normally. Otherwise this rank aborts the whole job and does not return.
    """
    world = _world()
    if world is None or world.size == 1:
        return True
    _ignore_signals()    # a further SIGTERM (mpirun forwards it) must not break the ending
    if not peer:
        notify_failure(exit_code, message)
    comm = meeting_comm()
    if all_arrive(comm, grace_seconds()):
        _drain()
        return True
    abort_job(comm, exit_code, message + " (the other ranks did not stop: aborting the job)")
    return False  # not reached


def _ignore_signals() -> None:
    import signal
    import threading

    if threading.current_thread() is threading.main_thread():
        for s in (signal.SIGINT, signal.SIGTERM):
            signal.signal(s, signal.SIG_IGN)


def install_excepthook() -> None:
    """Under MPI with several ranks, an uncaught exception prints its traceback and aborts
    the whole job instead of leaving the other ranks waiting (mpi4py's ``-m mpi4py`` does
    the same for scripts)."""
    previous = sys.excepthook

    def hook(kind, value, tb):
        comm = _world()
        if comm is None or comm.size == 1:
            previous(kind, value, tb)
            return
        traceback.print_exception(kind, value, tb)
        abort_job(comm, 1, f"uncaught {kind.__name__}: {value}")

    sys.excepthook = hook


#: How long rank 0 waits, after ``MPI_Finalize``, for the other ranks on its node to exit.
SIBLING_WAIT = 10.0


def _stat(pid: int) -> list[bytes] | None:
    """The fields of ``/proc/PID/stat`` after the command name (state, ppid, …); None for a
    process that has exited."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read()
    except OSError:
        return None
    return stat[stat.rfind(b")") + 2:].split()


def _alive(pid: int) -> bool:
    """Whether ``pid`` is still running (a zombie counts as exited)."""
    fields = _stat(pid)
    return bool(fields) and fields[0] != b"Z"


def _sibling_pids() -> set[int] | None:
    """The other running processes with this process's parent (under mpirun, Hydra's proxy
    or Open MPI's daemon: the other ranks on this node); ``None`` where ``/proc`` is not
    readable."""
    me, parent = os.getpid(), os.getppid()
    try:
        pids = [int(e) for e in os.listdir("/proc") if e.isdigit() and int(e) != me]
    except OSError:
        return None
    return {p for p in pids
            if (f := _stat(p)) and len(f) > 1 and f[0] != b"Z" and int(f[1]) == parent}


def finalize_and_exit(code: int) -> None:
    """Finalize MPI and exit with ``code``, rank 0 after the other ranks of its node.

    A launcher that sees a rank exit with a non-zero status kills the ranks still running
    (MPICH's Hydra does) and then reports *their* signal: ``mpiexec`` exited 9 instead of 2
    in one run of twelve when rank 0 exited right after ``MPI_Finalize``, while a worker
    rank was still between its ``MPI_Finalize`` and its exit. So rank 0 leaves last: after
    ``MPI_Finalize`` (which the ranks pass together) it waits until its sibling processes
    have exited (at most :data:`SIBLING_WAIT` s; a fixed 0.5 s where ``/proc`` is not
    readable). Ranks on other nodes are not seen; they are past ``MPI_Finalize`` too.
    Used by the sweep's driver under ``mpi4py.futures`` (its workers exit 0).
    """
    sys.stdout.flush()
    sys.stderr.flush()
    _ignore_signals()   # no KeyboardInterrupt once MPI is finalized: leave with ``code``
    MPI = sys.modules.get("mpi4py.MPI")
    rank = 0
    if MPI is not None and MPI.Is_initialized() and not MPI.Is_finalized():
        rank = MPI.COMM_WORLD.rank
        several = MPI.COMM_WORLD.size > 1
        MPI.Finalize()
        if rank == 0 and several and code != 0:
            deadline = time.monotonic() + SIBLING_WAIT
            pids = _sibling_pids()
            if pids is None:
                time.sleep(0.5)
            while pids and time.monotonic() < deadline:
                time.sleep(0.02)
                pids = {p for p in pids if _alive(p)}
    os._exit(code)
