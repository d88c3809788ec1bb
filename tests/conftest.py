"""Shared fixtures; after each test collect garbage and barrier (as DOLFINx's own tests do)."""

import gc
import logging
import os

# One BLAS/OpenMP thread, as scripts/test.sh and the command line set: threaded BLAS inside
# MUMPS changes the round-off, and the stored regression values are single-threaded.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


#: Seconds a rank waits after a test for the other ranks to finish it too; past that the
#: other rank is stuck (typically in a collective call after an error on this rank) and the
#: whole MPI job is aborted, so that CI fails fast instead of hanging to its time limit.
MPI_TEST_GRACE = float(os.environ.get("DPCOLLAPSE_TEST_MPI_GRACE", "300"))


@pytest.fixture(autouse=True)
def _collect_and_barrier(request):
    yield
    gc.collect()
    try:
        from mpi4py import MPI
    except ImportError:
        return
    from dpcollapse.parallel import abort_job, all_arrive

    comm = MPI.COMM_WORLD
    if not all_arrive(comm, MPI_TEST_GRACE):
        abort_job(comm, 1, f"{request.node.nodeid}: the other ranks did not finish this test "
                           f"within {MPI_TEST_GRACE:g} s (an error on one rank?)")


@pytest.fixture
def comm():
    from mpi4py import MPI

    return MPI.COMM_WORLD


@pytest.fixture
def shared_tmp(tmp_path, comm):
    """A temporary directory agreed on by all ranks (rank 0's)."""
    from pathlib import Path as _P

    return _P(comm.bcast(str(tmp_path), root=0))


#: ``DPCOLLAPSE_TEST_CPU=FILE``: append one JSON line per test with its CPU seconds (this
#: process and the subprocesses it waited for). Unlike wall time, CPU time does not grow
#: when other jobs share the machine, so the suite's budget can be measured on a busy one
#: (docs/development.md, "Time budget").
_CPU_LOG = os.environ.get("DPCOLLAPSE_TEST_CPU")


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    if not _CPU_LOG:
        yield
        return
    import json
    import resource
    import time

    def cpu():
        own = resource.getrusage(resource.RUSAGE_SELF)
        children = resource.getrusage(resource.RUSAGE_CHILDREN)
        return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime

    cpu0, wall0 = cpu(), time.perf_counter()
    yield
    with open(_CPU_LOG, "a") as f:
        f.write(json.dumps({"test": item.nodeid, "cpu": round(cpu() - cpu0, 3),
                            "wall": round(time.perf_counter() - wall0, 3)}) + "\n")


logging.getLogger("UFL").setLevel(logging.WARNING)
logging.getLogger("FFCX").setLevel(logging.WARNING)
