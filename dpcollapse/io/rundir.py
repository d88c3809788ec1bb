"""A run directory holds exactly one run: claiming it for a new run, a resume or an overwrite.

Rules (``dpcollapse run``):

* **new run** (default): the directory must not hold a run yet; one that does is refused
  with exit 2, naming ``--resume`` and ``--overwrite``;
* ``--overwrite``: the old run's files are removed whole before the new run starts (only
  the files a run writes: anything else in the directory is left alone);
* ``--resume``: there must be a checkpoint, and the config may differ from the run's own
  ``config.yaml`` only in :data:`RESUMABLE_KEYS` (end time, output cadence, rest criteria);
  any other difference is exit 2 naming the keys.

A lock (``.lock``, an exclusive ``flock`` held by rank 0 for the run's whole life) refuses
a second writer; the kernel drops it when the process ends however it ends, so a crashed
run never leaves a stale lock on the same machine (the file itself, with the holder's
host and pid, stays as a note). On file systems without working ``flock`` (some NFS
mounts) the lock is advisory only.

Bad output locations (an empty path, a path under a file, a name too long for the file
system, a directory that cannot be written) are exit 2 with one line.
"""

from __future__ import annotations

import errno
import fcntl
import os
import platform
import re
import shutil
from pathlib import Path
from typing import Any

import yaml

from dpcollapse.config import config_to_dict, from_saved, validate_config
from dpcollapse.errors import ConfigError

#: Files and folders a run writes (removed whole by --overwrite).
RUN_FILES = ("run.json", "config.yaml", "diagnostics.csv", "solution.xdmf", "checkpoint.npz",
             "checkpoint.prev.npz", "collapse.png", "error.log")
RUN_DIRS = ("fields", "vtx")
#: Config keys that may change on --resume: when to stop and how often to write.
RESUMABLE_KEYS = ("time.end_time", "time.max_steps", "time.output_every",
                  "time.checkpoint_every", "time.rest_speed", "time.rest_duration",
                  "output.directory")
LOCK_NAME = ".lock"
#: The names a run writes inside RUN_DIRS (XDMF steps, VTX series and their temporaries).
_RUN_STEP = re.compile(r"^(step_\d{6,}\.(xdmf|h5)(\.tmp)?|[\w.-]*\.bp(\.tmp)?)$")


def holds_run(run_dir: Path) -> bool:
    """Whether ``run_dir`` holds (part of) a run."""
    return any((run_dir / name).exists() for name in RUN_FILES + RUN_DIRS)


def check_location(run_dir: Path | str) -> Path:
    """The run directory as a usable path, or ConfigError naming what is wrong with it."""
    text = str(run_dir)
    if not text.strip():
        raise ConfigError("--out = '': the run directory must be a non-empty path")
    path = Path(run_dir)
    try:
        max_name = os.pathconf(_existing_ancestor(path), "PC_NAME_MAX")
    except (OSError, ValueError):
        max_name = 255
    try:
        max_path = os.pathconf(_existing_ancestor(path), "PC_PATH_MAX")
    except (OSError, ValueError):
        max_path = 4096
    if len(os.fsencode(str(path.absolute()))) >= max_path:
        raise ConfigError(f"--out = {text[:60]}...: the path has {len(os.fsencode(text))} bytes, "
                          f"more than the file system allows ({max_path})")
    for part in path.parts:
        if len(part.encode()) > max_name:
            raise ConfigError(f"--out = {text[:60]}...: a path component has {len(part.encode())} "
                              f"bytes, more than the file system allows ({max_name})")
    for parent in [path, *path.parents]:
        if parent.exists() and not parent.is_dir():
            raise ConfigError(f"--out = {text}: {parent} is a file, not a directory")
    _refuse_shared_folder(path, text)
    return path


def _refuse_shared_folder(path: Path, text: str) -> None:
    """A run directory of its own: never the root, the home directory or the working
    directory itself (a run writes fields/, and --overwrite removes what a run wrote)."""
    try:
        resolved = path.expanduser().resolve()
    except (OSError, RuntimeError):
        return
    shared = {Path("/"): "the root directory", Path.cwd().resolve(): "the working directory"}
    home = os.environ.get("HOME")
    if home:
        shared[Path(home).resolve()] = "the home directory"
    if resolved in shared:
        raise ConfigError(f"--out = {text}: is {shared[resolved]}; a run needs a directory of "
                          "its own (e.g. runs/NAME)")


def _existing_ancestor(path: Path) -> Path:
    for p in [path.absolute(), *path.absolute().parents]:
        try:
            if p.exists():
                return p
        except OSError:      # a component too long to stat
            continue
    return Path("/")


class RunDirectory:
    """The claim of one process (rank 0) on a run directory; release it with ``release()``
    or use it as a context manager."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self._lock_fd: int | None = None

    # ------------------------------------------------------------------ claim
    def claim(self, config: dict[str, Any], mode: str = "new") -> None:
        """Create/lock the directory and apply the rule of ``mode`` (new, resume, overwrite)."""
        path = check_location(self.path)
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise ConfigError(f"--out = {path}: cannot create the run directory "
                              f"({exc.strerror})") from None
        if not os.access(path, os.W_OK | os.X_OK):
            raise ConfigError(f"--out = {path}: the run directory is not writable")
        self._lock()
        try:
            if mode == "new":
                if holds_run(path):
                    raise ConfigError(
                        f"--out = {path} already holds a run{_status_note(path)}: continue it "
                        "with --resume, or replace it with --overwrite")
            elif mode == "overwrite":
                self._remove_run()
            elif mode == "resume":
                self._check_resume(config)
            else:
                raise ValueError(f"unknown mode {mode!r}")
        except BaseException:
            self.release()
            raise

    def _lock(self) -> None:
        self._lock_fd = take_lock(self.path, LOCK_NAME, "run")

    def _remove_run(self) -> None:
        remove_run_files(self.path)

    def _check_resume(self, config: dict[str, Any]) -> None:
        has_checkpoint = any((self.path / n).exists()
                             for n in ("checkpoint.npz", "checkpoint.prev.npz"))
        if not has_checkpoint:
            raise ConfigError(f"--resume: {self.path} has no checkpoint to resume from; "
                              "start the run without --resume")
        saved_path = self.path / "config.yaml"
        try:
            # through the schema, so that keys added since the run was made take their defaults
            saved = config_to_dict(validate_config(from_saved(yaml.safe_load(saved_path.read_text()))))
        except (OSError, yaml.YAMLError, ConfigError):
            raise ConfigError(f"--resume: {saved_path} is missing or unreadable; the run cannot "
                              "be checked against its config (start it again with --overwrite)"
                              ) from None
        differ = changed_keys(saved, config)
        blocked = [k for k in differ if k not in RESUMABLE_KEYS]
        if blocked:
            raise ConfigError(
                f"--resume: the config differs from the run's in {', '.join(blocked)}; only "
                f"{', '.join(RESUMABLE_KEYS)} may change on resume (use --overwrite to start over)")

    def release(self) -> None:
        if self._lock_fd is not None:
            try:
                fcntl.flock(self._lock_fd, fcntl.LOCK_UN)
            finally:
                os.close(self._lock_fd)
                self._lock_fd = None

    def __enter__(self) -> RunDirectory:
        return self

    def __exit__(self, *exc) -> None:
        self.release()


def remove_run_files(path: Path) -> None:
    """Remove the files a run writes in ``path``, and only those: RUN_FILES, in fields/ and
    vtx/ the step files (``step_NNNNNN.xdmf/.h5``, ``*.bp``), ``*.tmp``; a folder is removed
    only once empty (``--overwrite``; the ladder's run directories)."""
    path = Path(path)
    for name in RUN_FILES:
        (path / name).unlink(missing_ok=True)
    for name in RUN_DIRS:
        folder = path / name
        if not folder.is_dir() or folder.is_symlink():
            continue
        for item in folder.iterdir():
            if _RUN_STEP.match(item.name):
                if item.is_dir() and not item.is_symlink():
                    shutil.rmtree(item, ignore_errors=True)
                else:
                    item.unlink(missing_ok=True)
        try:
            folder.rmdir()
        except OSError:          # something the run did not write is left in it
            pass
    for tmp in path.glob("*.tmp"):
        tmp.unlink(missing_ok=True)


def take_lock(folder: Path, name: str, holder_kind: str) -> int:
    """An exclusive ``flock`` on ``folder/name`` (the file notes this host and pid); the
    descriptor (close it to release). ConfigError naming the holder when another process
    (a ``holder_kind``: run, sweep) has it."""
    lock_path = Path(folder) / name
    try:
        fd = os.open(lock_path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise ConfigError(f"--out = {folder}: cannot create {name} ({exc.strerror})") from None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError as exc:
        holder = _read_holder(fd)
        os.close(fd)
        if exc.errno in (errno.EWOULDBLOCK, errno.EACCES, errno.EAGAIN):
            raise ConfigError(f"--out = {folder} is in use by another {holder_kind} ({holder}): "
                              "wait for it to end, or choose another --out") from None
        raise
    os.ftruncate(fd, 0)
    os.write(fd, f"{platform.node()} pid {os.getpid()}\n".encode())
    return fd


def claim_on_root(comm, run_dir, config: dict[str, Any], mode: str) -> RunDirectory:
    """Claim ``run_dir`` on rank 0 of ``comm`` (collective); every rank raises the same
    ConfigError when the claim is refused. Use the result as a context manager."""
    claim = RunDirectory(Path(str(run_dir)))
    error = None
    if comm.rank == 0:
        try:
            check_location(str(run_dir))   # before Path(""), which means "."
            claim.claim(config, mode)
        except ConfigError as exc:
            error = str(exc)
    from dpcollapse import parallel

    error = parallel.bcast(comm, error, root=0)
    if error is not None:
        raise ConfigError(error)
    return claim


def changed_keys(old: dict, new: dict, prefix: str = "") -> list[str]:
    """Dotted keys whose values differ between two nested config dicts."""
    keys = []
    for k in sorted(set(old) | set(new)):
        a, b = old.get(k), new.get(k)
        name = f"{prefix}{k}"
        if isinstance(a, dict) and isinstance(b, dict):
            keys += changed_keys(a, b, name + ".")
        elif a != b:
            keys.append(name)
    return keys


def _read_holder(fd: int) -> str:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        text = os.read(fd, 200).decode(errors="replace").strip()
        return text or "unknown process"
    except OSError:
        return "unknown process"


def _status_note(path: Path) -> str:
    import json

    try:
        info = json.loads((path / "run.json").read_text())
        t = info.get("summary", {}).get("t")
        return f" (status {info.get('status')}" + (f", t = {t:.4g} s)" if t is not None else ")")
    except (OSError, ValueError, AttributeError):
        return ""
