"""ADIOS2 VTX output (``output.format: vtx`` or ``both``), where DOLFINx has ADIOS2.

DOLFINx's ``VTXWriter`` writes the functions given at construction, on their mesh, at
every ``write(t)``; with the mesh policy "update" it rewrites the node coordinates each
time, so it follows the moving (ALE) mesh. A remesh makes new functions on a new mesh, so
the series is cut into *segments*, one ADIOS2 folder per mesh and set of functions (a new
discretization on the same mesh — e.g. after nodes land on the bed — has new functions, which a
writer bound to the old ones would never see: measured, it repeated the segment's first
values):

    vtx/nodes_{k:03d}.bp   P1 fields (velocity, pressure, flowing, ...) on mesh k
    vtx/cells_{k:03d}.bp   DG0 fields (strain_rate, rigid, ...) on mesh k
    vtx/segments.json      for each segment: its files and output times (rank 0)

ParaView opens each ``.bp`` folder with its ADIOS2 VTX reader. VTX requires all functions
of one writer to share their element, hence the two files per segment. On ``--resume``
the segments that begin after the checkpoint time are removed and a new segment starts;
the segment that was open at the interruption keeps its steps after the checkpoint time
(resume recomputes the same states).
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Sequence
from pathlib import Path

from mpi4py import MPI

from dpcollapse import compat, parallel
from dpcollapse.io.presence import DirectoryPresence

SEGMENTS = "segments.json"


class VTXTimeSeries:
    """Time series of P1 and DG0 functions in ADIOS2 VTX format, one segment per set of
    functions (so per mesh)."""

    def __init__(self, directory: str | Path, comm: MPI.Comm):
        self.comm = comm
        self.directory = Path(directory) / "vtx"
        if comm.rank == 0:
            self.directory.mkdir(parents=True, exist_ok=True)
        #: the run directory and vtx/ as taken (checked before each write: ADIOS2 would
        #: make a removed directory again)
        self._presence = [DirectoryPresence(directory), DirectoryPresence(self.directory)]
        comm.barrier()
        self.segments: list[dict] = self._read_index()
        self._segment_functions: list = []
        self._writers: list = []

    # ------------------------------------------------------------------ index
    def _read_index(self) -> list[dict]:
        path = self.directory / SEGMENTS
        data = None
        if self.comm.rank == 0 and path.exists():
            data = json.loads(path.read_text())
        return self.comm.bcast(data, root=0) or []

    def _write_index(self) -> None:
        if self.comm.rank == 0:
            tmp = self.directory / (SEGMENTS + ".tmp")
            tmp.write_text(json.dumps(self.segments, indent=1))
            os.replace(tmp, self.directory / SEGMENTS)

    # ------------------------------------------------------------------ writing
    def _open(self, functions: Sequence) -> None:
        self.close()
        index = len(self.segments)
        nodes = [f for f in functions if compat.element_info(f.function_space).family == "P"]
        cells = [f for f in functions if compat.element_info(f.function_space).family == "DG"]
        files = {}
        for kind, group in (("nodes", nodes), ("cells", cells)):
            if group:
                name = f"{kind}_{index:03d}.bp"
                self._writers.append(compat.vtx_writer(self.comm, str(self.directory / name),
                                                       group, mesh_policy="update"))
                files[kind] = name
        self.segments.append({"files": files, "times": []})
        self._segment_functions = list(functions)

    def write(self, t: float, mesh, functions: Sequence) -> None:
        """Write the functions at time t (collective); new function objects — a new mesh
        always brings them, a landing on the same mesh too; a writer holds the ones it was
        made with — start a new segment. ``mesh`` is that of ``XDMFTimeSeries.write``; the
        functions carry theirs."""
        parallel.on_root(self.comm, lambda: [p.check(f"vtx at t = {float(t):g} s")
                                             for p in self._presence])
        same = (len(functions) == len(self._segment_functions)
                and all(f is g for f, g in zip(functions, self._segment_functions)))
        if not same:
            self._open(functions)
        for writer in self._writers:
            writer.write(float(t))
        self.segments[-1]["times"].append(float(t))
        self._write_index()

    @property
    def steps(self) -> list[float]:
        return [t for seg in self.segments for t in seg["times"]]

    def truncate_after(self, t: float) -> None:
        """Before a resume at time t: drop the segments that begin after t."""
        keep = [s for s in self.segments if s["times"] and s["times"][0] <= t + 1e-12]
        dropped = self.segments[len(keep):]
        if self.comm.rank == 0:
            for seg in dropped:
                for name in seg["files"].values():
                    shutil.rmtree(self.directory / name, ignore_errors=True)
        self.segments = keep
        self._write_index()
        self.comm.barrier()

    def close(self) -> None:
        for writer in self._writers:
            writer.close()
        self._writers = []
        self._segment_functions = []
