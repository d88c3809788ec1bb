"""The run directory is checked, not assumed: every write verifies it is still there.

A run directory removed during a run (``rm -rf``) went unnoticed: DOLFINx's HDF5 writer
creates the missing parent folders of a step file, so the run went on into a new, empty
directory, ended with exit 0 and a ``run.json`` saying ``end_time`` while
``solution.xdmf`` pointed at datasets that no longer existed (issue 47).

:class:`DirectoryPresence` holds the directory open when the writer takes it (so its inode
cannot be given to a directory made in its place: a file system reuses the numbers of
removed inodes at once) and remembers its identity (``st_dev``, ``st_ino``); :meth:`~DirectoryPresence.check`
raises :class:`~dpcollapse.errors.OutputError` (exit 5, one line) when the path is gone,
no longer a directory, or a *different* directory (removed and made again, by DOLFINx or
by anyone). Each writer of the run (field series, checkpoint, ``diagnostics.csv``,
``run.json``) checks before it writes, so a removal is reported at the next write — the
diagnostics row of the next time step.
"""

from __future__ import annotations

import os
from pathlib import Path

from dpcollapse.errors import OutputError


def _identity(path: Path) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino)


class DirectoryPresence:
    """``path`` (a directory) as it was when this object was made; ``check`` that it is
    still the same directory. Holds one file descriptor (``close`` it, or let it go)."""

    def __init__(self, path: Path | str):
        self.path = Path(path)
        self._fd: int | None = None
        self.identity: tuple[int, int] | None = None
        self._take()

    def _take(self) -> None:
        try:
            self._fd = os.open(self.path, os.O_RDONLY | os.O_DIRECTORY)
        except OSError:
            return
        st = os.fstat(self._fd)
        self.identity = (st.st_dev, st.st_ino)

    def check(self, writing: str) -> None:
        """OutputError (exit 5) naming ``writing`` (what was about to be written) when the
        directory is gone or was replaced since it was taken."""
        if self._fd is None:          # taken before it existed: take it now
            self._take()
            return
        now = _identity(self.path)
        if now is None:
            raise OutputError(f"the run directory {self.path} was removed during the run "
                              f"(writing {writing}); what it held is lost")
        if now != self.identity:
            raise OutputError(f"the run directory {self.path} was removed and made again during "
                              f"the run (writing {writing}); its earlier files are lost")

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def __del__(self) -> None:
        try:
            self.close()
        except OSError:
            pass


def missing_files(paths) -> list[Path]:
    """Those of ``paths`` that do not exist (one ``stat`` each)."""
    return [p for p in paths if not os.path.exists(p)]
