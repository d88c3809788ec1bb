"""SIGINT/SIGTERM during the time loop (``StopRequest``): stop after the step in progress."""

from __future__ import annotations

import signal

from mpi4py import MPI

from dpcollapse import parallel, signals


class StopRequest:
    """SIGINT/SIGTERM during the loop: the first asks the loop to stop after the step in
    progress (so the checkpoint holds the last accepted step); a second stops at once.
    A signal that came during the set-up and whose KeyboardInterrupt was lost
    (:mod:`dpcollapse.signals`) counts as the first."""

    def __init__(self):
        self.signal: int | None = signal.SIGTERM if signals.received() else None

    def __call__(self, signum, frame):
        if self.signal is not None:
            raise KeyboardInterrupt
        self.signal = signum

    def requested(self, comm) -> bool:
        """Whether any rank was signalled (collective and failure-aware: every rank stops
        at the same step, and a rank that failed alone is noticed here)."""
        return parallel.allreduce(comm, self.signal is not None, op=MPI.LOR)
