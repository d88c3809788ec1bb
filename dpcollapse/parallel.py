"""Ending an MPI job together: an error on one rank must never leave another rank spinning.

A rank that fails while the others wait in a collective call (an allreduce, a solve) would
otherwise hang the job until its wall-time limit; and with Open MPI 5 a rank that exits
normally blocks in ``MPI_Finalize`` waiting for the others. So a failing rank first waits
at a *non-blocking* barrier: if every rank arrives there within a grace time (all ranks
failed together, the usual case: a config error, a solver that did not converge), the job
ends normally with the error's exit status; if not, the failing rank aborts the whole job
with ``MPI_Abort``.

Nothing here imports mpi4py unless MPI is already in use, so serial commands that never
touch MPI stay free of it.
"""

from __future__ import annotations

import os
import sys
import time
import traceback

#: Seconds the failing ranks wait for the others before aborting the job.
DEFAULT_GRACE = 20.0
_POLL = 0.01


def _world():
    """MPI.COMM_WORLD if mpi4py has been imported and MPI initialized, else None."""
    if "mpi4py.MPI" not in sys.modules:
        return None
    MPI = sys.modules["mpi4py.MPI"]
    if not MPI.Is_initialized() or MPI.Is_finalized():
        return None
    return MPI.COMM_WORLD


def grace_seconds() -> float:
    """The grace time, from ``DPCOLLAPSE_MPI_GRACE`` (seconds) or the default."""
    try:
        return max(0.0, float(os.environ.get("DPCOLLAPSE_MPI_GRACE", DEFAULT_GRACE)))
    except ValueError:
        return DEFAULT_GRACE


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


def abort_job(comm, exit_code: int, message: str) -> None:
    """Write ``message`` (one line, naming this rank) to stderr and abort every rank."""
    sys.stderr.write(f"dpcollapse: error: [rank {comm.rank}] {message}\n")
    sys.stderr.flush()
    comm.Abort(exit_code if 0 < exit_code < 256 else 1)


def end_together(exit_code: int, message: str) -> bool:
    """Called by a rank that is about to exit with an error.

    Returns True when every rank failed too (or there is no MPI job): the caller reports
    and exits normally. Otherwise this rank aborts the whole job and does not return.
    """
    comm = _world()
    if comm is None or comm.size == 1:
        return True
    if all_arrive(comm, grace_seconds()):
        return True
    abort_job(comm, exit_code, message + " (the other ranks did not stop: aborting the job)")
    return False  # not reached


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
