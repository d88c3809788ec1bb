"""``diagnostics.csv``: one row per time step, written by rank 0 and flushed every row."""

from __future__ import annotations

import csv
from pathlib import Path

COLUMNS = [
    "step", "t", "dt", "dt_limit", "courant", "iterations", "residual", "front", "max_height", "kinetic_energy",
    "area", "max_speed", "min_angle", "min_detJ", "ill_posed_fraction", "remeshes", "wall_time",
]


class DiagnosticsWriter:
    """Appends rows to ``diagnostics.csv`` on rank 0; other ranks do nothing."""

    def __init__(self, path: Path, comm, resume_after: float | None = None):
        self.path = Path(path)
        self.rank = comm.rank
        if self.rank != 0:
            return
        rows = []
        if resume_after is not None and self.path.exists():
            with self.path.open() as f:
                rows = [r for r in csv.DictReader(f) if float(r["t"]) <= resume_after + 1e-12]
        self._file = self.path.open("w", newline="")
        self._writer = csv.DictWriter(self._file, fieldnames=COLUMNS)
        self._writer.writeheader()
        for r in rows:
            self._writer.writerow(r)
        self._file.flush()

    def write(self, row: dict) -> None:
        if self.rank != 0:
            return
        self._writer.writerow({k: row[k] for k in COLUMNS})
        self._file.flush()

    def close(self) -> None:
        if self.rank == 0:
            self._file.close()


def read_diagnostics(path: Path) -> dict[str, list[float]]:
    """Columns of a diagnostics file as lists of floats."""
    with Path(path).open() as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in COLUMNS if rows and k in rows[0]}
