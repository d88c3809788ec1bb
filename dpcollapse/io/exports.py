"""What a run writes as it goes, each with ``write`` and a cadence ``every`` (steps).

- ``FieldExport``: the output fields of the current mesh at time t, into the XDMF series
  and/or the ADIOS2 VTX series of ``output.format`` (each time once);
- ``CheckpointExport``: the model's state (2D: the mesh and the snapshot fields) and the
  loop state into ``checkpoint.npz`` (each step once), in its model's format.

The loop writes both every ``every`` steps and at the end of a run (at rest, stopped,
end time), in that order. ``diagnostics.csv`` (every step) is ``io.diagnostics``.
"""

from __future__ import annotations

from pathlib import Path

from dpcollapse.io.presence import DirectoryPresence
from dpcollapse.io.vtx import VTXTimeSeries
from dpcollapse.io.xdmf import XDMFTimeSeries


class FieldExport:
    def __init__(self, run_dir: Path, comm, fmt: str, every: int):
        self.xdmf = XDMFTimeSeries(run_dir, comm) if fmt != "vtx" else None
        self.vtx = VTXTimeSeries(run_dir, comm) if fmt != "xdmf" else None
        self.every = every

    def due(self, step: int) -> bool:
        return step % self.every == 0

    def truncate_after(self, t: float) -> None:
        """Resume: forget the outputs after time t."""
        for series in (self.xdmf, self.vtx):
            if series is not None:
                series.truncate_after(t)

    def written(self, t: float) -> bool:
        """Whether fields at time t (or later) are already written."""
        if self.xdmf is not None and self.xdmf.steps and self.xdmf.steps[-1][1] >= t:
            return True
        return bool(self.vtx is not None and self.vtx.steps and self.vtx.steps[-1] >= t)

    def write(self, t: float, mesh, functions) -> None:
        if self.xdmf is not None:
            self.xdmf.write(t, mesh, functions)
        if self.vtx is not None:
            self.vtx.write(t, mesh, functions)

    def close(self) -> None:
        """End of the run: close the open VTX segment (XDMF files are closed per write)."""
        if self.vtx is not None:
            self.vtx.close()


class CheckpointExport:
    def __init__(self, path: Path, every: int):
        self.path = Path(path)
        self.every = every
        #: the run directory as taken
        self.presence = DirectoryPresence(self.path.parent)

    def due(self, step: int) -> bool:
        return step % self.every == 0

    def write(self, factory, disc, state: dict) -> None:
        """The model's state on ``disc`` in the format of its ``factory``
        (``loop.ModelFactory.save_checkpoint``); ``state``: the loop state as a JSON-able
        dict."""
        factory.save_checkpoint(self.path, disc, state)
        # after the collective write (every rank, so none is left inside it): a checkpoint
        # written into a run directory made again is not the run's
        self.presence.check(self.path.name)
