"""Shared fixtures; after each test collect garbage and barrier (as DOLFINx's own tests do)."""

import gc
import logging
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(autouse=True)
def _collect_and_barrier():
    yield
    gc.collect()
    try:
        from mpi4py import MPI

        MPI.COMM_WORLD.barrier()
    except ImportError:
        pass


@pytest.fixture
def comm():
    from mpi4py import MPI

    return MPI.COMM_WORLD


@pytest.fixture
def shared_tmp(tmp_path, comm):
    """A temporary directory agreed on by all ranks (rank 0's)."""
    from pathlib import Path as _P

    return _P(comm.bcast(str(tmp_path), root=0))


logging.getLogger("UFL").setLevel(logging.WARNING)
logging.getLogger("FFCX").setLevel(logging.WARNING)
