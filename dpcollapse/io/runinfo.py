"""``run.json``: versions, MPI size, the resolved config, timings and the outcome."""

from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

from dpcollapse.io.presence import DirectoryPresence


def versions() -> dict:
    import dolfinx
    import petsc4py
    from petsc4py import PETSc

    import dpcollapse

    v = PETSc.Sys.getVersion()
    return {
        "dpcollapse": dpcollapse.__version__,
        "dolfinx": dolfinx.__version__,
        "petsc": ".".join(str(i) for i in v),
        "petsc4py": petsc4py.__version__,
        "python": platform.python_version(),
    }


def write_json_atomic(path: Path, data: dict) -> None:
    """Write JSON to ``path`` via a temporary file and a rename (never half-written)."""
    path = Path(path)
    tmp = path.with_suffix(path.suffix + ".tmp")
    try:
        tmp.write_text(json.dumps(data, indent=2, default=float) + "\n")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def read_history_plot(path: Path) -> str:
    """run.json's ``history_plot`` (the panel its model declared for its diagnostics over
    time); "front" for a run.json without it (older) or unreadable."""
    try:
        return str(json.loads(Path(path).read_text()).get("history_plot") or "front")
    except (OSError, ValueError, AttributeError):
        return "front"


class RunInfo:
    """Collects what a run did and rewrites ``run.json`` atomically on rank 0."""

    def __init__(self, path: Path, comm, config: dict, run_id: str | None = None, **entries):
        self.path = Path(path)
        self.rank = comm.rank
        #: the run directory as taken: the status is never written into another one
        self.presence = DirectoryPresence(self.path.parent)
        self.started = time.time()
        self.data = {
            "status": "running",
            "run_id": run_id,
            "versions": versions(),
            "mpi_size": comm.size,
            "host": platform.node(),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "config": config,
            "timings": {},
            "summary": {},
            # what the model declares for the run's readers (history_plot), the time scheme a
            # method chose (None: not set)
            **{k: v for k, v in entries.items() if v is not None},
        }
        if self.path.exists():  # resumed: keep the history of earlier segments
            try:
                old = json.loads(self.path.read_text())
                self.data["segments"] = old.get("segments", []) + [
                    {k: old.get(k) for k in ("status", "started", "summary", "timings")}]
            except (json.JSONDecodeError, OSError):
                pass
        from dpcollapse import parallel

        parallel.on_root(comm, self.write)   # a failure to write it ends every rank

    def update(self, **kwargs) -> None:
        self.data.update(kwargs)

    def record_abort(self, exit_code: int, message: str) -> None:
        """The job is ended at once (``parallel.on_abort``): run.json from this rank, status
        interrupted (exit 130) or failed, the message as the summary's error."""
        self.update(status="interrupted" if exit_code == 130 else "failed",
                    summary={**self.data.get("summary", {}), "error": message})
        write_json_atomic(self.path, self.data)

    def write(self) -> None:
        """Rewrite run.json (rank 0; not collective)."""
        if self.rank == 0:
            self.presence.check(f"{self.path.name} (status {self.data.get('status')})")
            self.data["wall_time"] = time.time() - self.started
            write_json_atomic(self.path, self.data)
