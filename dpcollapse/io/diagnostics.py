"""``diagnostics.csv``: one row per time step, written by rank 0 and flushed every row."""

from __future__ import annotations

import csv
import logging
import os
from pathlib import Path

from dpcollapse.errors import OutputError
from dpcollapse.io.presence import DirectoryPresence

COLUMNS = [
    "step",
    "t",
    "dt",
    "dt_limit",
    "courant",
    "iterations",
    "residual",
    "front",
    "max_height",
    "kinetic_energy",
    "area",
    "max_speed",
    "remeshes",
    "wall_time",
    "thick_front",
]


class DiagnosticsWriter:
    """Appends rows to ``diagnostics.csv`` on rank 0; other ranks do nothing."""

    def __init__(self, path: Path, comm, resume_after: float | None = None,
                 extra_columns: tuple[str, ...] = ()):
        self.path = Path(path)
        self.rank = comm.rank
        #: COLUMNS, then the counts of the domain's and the model's named events (the moving
        #: domain: landings) and the model's own measures (the depth-averaged model:
        #: wet_front, outflow), as the loop gives them
        self.columns = COLUMNS + [c for c in extra_columns if c not in COLUMNS]
        from dpcollapse import parallel

        parallel.on_root(comm, lambda: self._start(resume_after))   # its failure is every rank's

    def _start(self, resume_after: float | None) -> None:
        """Rank 0: the file with the rows kept on resume, open for appending."""
        #: the run directory as taken (checked before each row)
        self._presence = DirectoryPresence(self.path.parent)
        rows = []
        if resume_after is not None and self.path.exists():
            rows = [r for r in complete_rows(self.path) if float(r["t"]) <= resume_after + 1e-12]
        #: time of the last row kept on resume (None: none kept)
        self.last_kept_t = float(rows[-1]["t"]) if rows else None
        # the kept rows go to a new file that replaces the old one whole
        tmp = self.path.with_name(self.path.name + ".tmp")
        with tmp.open("w", newline="") as f:
            # rows of an older file lack the newer columns: nan
            writer = csv.DictWriter(f, fieldnames=self.columns, extrasaction="ignore", restval="nan")
            writer.writeheader()
            writer.writerows(rows)
        os.replace(tmp, self.path)
        self._file = self.path.open("a", newline="")
        self._writer = csv.DictWriter(self._file, fieldnames=self.columns)

    def _check_present(self) -> None:
        """OutputError (exit 5) when the run directory or the file was removed: rows
        appended to an unlinked file are lost in silence."""
        self._presence.check(self.path.name)
        if os.fstat(self._file.fileno()).st_nlink == 0 or not self.path.exists():
            raise OutputError(f"{self.path} was removed during the run; its rows are lost")

    def write(self, row: dict) -> None:
        if self.rank != 0:
            return
        self._check_present()
        self._writer.writerow({k: row[k] for k in self.columns})
        self._file.flush()

    def restore(self, row: dict) -> bool:
        """Resume: write ``row`` (the checkpoint's step; missing columns nan) when the kept
        rows end before it (the file was cut after the checkpoint was written). Whether it
        was written (rank 0; False elsewhere)."""
        if self.rank != 0:
            return False
        t = float(row["t"])
        if self.last_kept_t is not None and self.last_kept_t >= t - 1e-12 * max(1.0, abs(t)):
            return False
        self._check_present()
        self._writer.writerow({k: row.get(k, float("nan")) for k in self.columns})
        self._file.flush()
        logging.getLogger("dpcollapse").warning(
            "diagnostics.csv ended before the checkpoint (t = %.4f s): its row was rebuilt from "
            "the checkpoint (dt, iterations: nan); rows between them, if any, are lost", t)
        return True

    def close(self) -> None:
        if self.rank == 0:
            self._file.close()


def complete_rows(path: Path) -> list[dict[str, str]]:
    """The rows of a diagnostics file that were written whole: a last line cut short by a
    crash or a full disk (no newline, missing or unparsable fields) is left out, and so is
    any row after it."""
    text = Path(path).read_text(errors="replace")
    lines = text.split("\n")
    header = lines[0].split(",")
    if "t" not in header or len(lines) < 2:
        return []
    rows = []
    for line in lines[1:-1]:            # the piece after the last newline is incomplete
        cells = line.split(",")
        if len(cells) != len(header):
            break
        try:
            [float(c) for c in cells]
        except ValueError:
            break
        rows.append(dict(zip(header, cells)))
    return rows


def read_diagnostics(path: Path) -> dict[str, list[float]]:
    """Columns of a diagnostics file as lists of floats."""
    with Path(path).open() as f:
        rows = list(csv.DictReader(f))
    return {k: [float(r[k]) for r in rows] for k in (rows[0] if rows else ())}
