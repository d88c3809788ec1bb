"""Running the cases: each a ``dpcollapse run`` subprocess, on an existing engine.

* ``local``: :class:`concurrent.futures.ThreadPoolExecutor` threads, each waiting on one
  subprocess; ``--jobs N`` at a time.
* ``mpi``: :class:`mpi4py.futures.MPIPoolExecutor` under
  ``mpirun -n N python -m mpi4py.futures -m dpcollapse.cli sweep ... --executor mpi``:
  rank 0 drives, the N - 1 other ranks each run one case at a time.
* ``slurm``: a job-array script, one array task per case (``dpcollapse sweep --task I``),
  and a collect script; ``sbatch`` is the user's.

A case runs in a subprocess whose environment has no MPI launcher variables (a serial case
starts as its own MPI singleton, not as a member of the sweep's job), one BLAS thread,
and this dpcollapse first on PYTHONPATH. A failure is recorded; the sweep goes on.
"""

from __future__ import annotations

import atexit
import concurrent.futures as cf
import logging
import os
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import dpcollapse
from dpcollapse import parallel
from dpcollapse.errors import ConfigError, Interrupted
from dpcollapse.sweep.collect import (
    case_row,
    case_state,
    collect,
    log_path,
    progress_line,
    read_json,
    record_path,
    run_dir,
    write_atomic,
)
from dpcollapse.sweep.spec import Case, Sweep

__all__ = ["child_env", "decide", "plan", "run_case", "run_one", "run_sweep", "write_slurm"]

log = logging.getLogger("dpcollapse.sweep")

#: Prefixes of the variables an MPI launcher sets (Open MPI, PMIx, MPICH/Hydra, Intel MPI).
LAUNCHER_PREFIXES = ("OMPI_", "PMIX_", "PMI_", "OPAL_", "ORTE_", "PRTE_", "HYDRA_", "I_MPI_",
                     "MPI_LOCALRANKID", "MPI_LOCALNRANKS")
#: Seconds an interrupted case may take to write its checkpoint before it is killed.
STOP_GRACE = 120.0

_live: dict[int, subprocess.Popen] = {}
_live_lock = threading.Lock()
_stop = threading.Event()


def _package_root() -> str | None:
    """The folder holding this dpcollapse package, unless it is an installed site folder."""
    root = Path(dpcollapse.__file__).resolve().parent.parent
    return None if root.name in ("site-packages", "dist-packages") else str(root)


#: Variables only a launcher sets in its ranks' environment: their presence means this
#: process is an MPI rank (an mpi4py.futures worker, a task of srun).
RANK_VARIABLES = ("OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK", "MV2_COMM_WORLD_RANK")
#: The user's Open MPI settings that a case may need (e.g. its own mpirun as root).
KEEP = ("OMPI_ALLOW_RUN_AS_ROOT", "OMPI_ALLOW_RUN_AS_ROOT_CONFIRM")


def child_env(base: dict | None = None) -> dict:
    """The environment of a case: one BLAS/OpenMP thread, this dpcollapse first on
    PYTHONPATH, and, when this process is itself an MPI rank, none of the launcher's
    variables (outside a launcher the user's ``OMPI_MCA_*`` settings are kept)."""
    src = os.environ if base is None else base
    rank = any(v in src for v in RANK_VARIABLES)
    env = {k: v for k, v in src.items()
           if not (rank and k.startswith(LAUNCHER_PREFIXES) and k not in KEEP)}
    env["OPENBLAS_NUM_THREADS"] = env["OMP_NUM_THREADS"] = "1"
    root = _package_root()
    if root:
        paths = [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p and p != root]
        env["PYTHONPATH"] = os.pathsep.join([root, *paths])
    return env


def case_command(sweep: Sweep, case: Case, out: Path, resume: bool, python: str | None = None,
                 launcher: str | None = None) -> list[str]:
    """``[launcher] python -m dpcollapse.cli run BASE --set ... --out DIR --quiet [--resume]``."""
    cmd = [python or sys.executable, "-m", "dpcollapse.cli", "run", str(sweep.base)]
    for item in case.overrides:
        cmd += ["--set", item]
    cmd += ["--out", str(run_dir(out, case).resolve()), "--quiet"] + (["--resume"] if resume else [])
    ranks = sweep.spec.ranks_per_case
    if ranks > 1:
        prefix = (launcher or sweep.spec.launcher).format(ranks=ranks)
        cmd = shlex.split(prefix) + cmd
    return cmd


def decide(out: Path, case: Case, retry_failed: bool = False) -> str:
    """What to do with a case: ``skip``, ``resume`` or ``fresh`` (nothing is changed)."""
    cs = case_state(out, case)
    if cs.state == "done" or (cs.state == "failed" and not retry_failed):
        return "skip"
    if (cs.state in ("interrupted", "running") and cs.resumable) or cs.extendable:
        return "resume"
    return "fresh"


def _in_use(d: Path) -> bool:
    """Whether a live ``dpcollapse run`` holds the run directory's lock."""
    import fcntl

    try:
        fd = os.open(d / ".lock", os.O_RDWR)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fcntl.flock(fd, fcntl.LOCK_UN)
        return False
    except OSError:
        return True
    finally:
        os.close(fd)


def plan(sweep: Sweep, out: Path, case: Case, retry_failed: bool = False) -> str:
    """:func:`decide`, and for a fresh start empty the case's run directory first (a run
    directory holds exactly one run); ``skip`` for a directory another run is using."""
    action = decide(out, case, retry_failed)
    d = run_dir(out, case)
    if d.exists() and _in_use(d):
        log.warning("%s: %s is in use by another run: skipped", case.name, d)
        return "skip"
    if action == "fresh" and d.exists():
        if case_state(out, case).state == "stale":
            log.warning("%s: run directory holds a run of another config: starting again",
                        case.name)
        shutil.rmtree(d)
    elif action == "resume" and case_state(out, case).state == "stale":
        log.info("%s: config changed only in what a resume may change: resuming", case.name)
    return action


def _record_start(task: dict) -> dict:
    record = read_json(Path(task["record"])) or {}
    attempts = record.get("attempts", [])
    if task["action"] == "fresh":
        attempts = []  # the earlier attempts belong to a run directory that is gone
    attempts.append({"action": task["action"], "host": socket.gethostname(),
                     "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                     "command": shlex.join(task["cmd"])})
    record.update(case=task["name"], running=True, exit_code=None, attempts=attempts)
    write_atomic(Path(task["record"]), _dumps(record))
    return record


def _dumps(data: dict) -> str:
    import json

    return json.dumps(data, indent=2) + "\n"


def run_case(task: dict) -> dict:
    """Run one case (a subprocess) and return its record, also written to ``task["record"]``.

    The function the executors call, also on ``mpi4py.futures`` workers (picklable: a dict
    in, a dict out). In the main thread, SIGINT and SIGTERM are forwarded to the case as
    SIGINT, which makes it checkpoint, mark itself interrupted and exit 130.
    """
    if _stop.is_set():
        return {"case": task["name"], "exit_code": None, "skipped": True}
    record = _record_start(task)
    log_file = Path(task["log"])
    log_file.parent.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with log_file.open("a") as fh:
        fh.write(f"# {time.strftime('%Y-%m-%dT%H:%M:%S%z')} {task['action']}: "
                 f"{shlex.join(task['cmd'])}\n")
        fh.flush()
        try:
            proc = subprocess.Popen(task["cmd"], stdout=fh, stderr=subprocess.STDOUT,
                                    stdin=subprocess.DEVNULL, cwd=task["cwd"], env=child_env(),
                                    process_group=0)
        except OSError as exc:  # e.g. the launcher is not installed: the shell's status 127
            fh.write(f"dpcollapse sweep: cannot start the case: {exc}\n")
            return _record_end(task, record, 127, t0)
        with _live_lock:
            _live[proc.pid] = proc
        if _stop.is_set():  # the sweep was stopped while this case was starting
            proc.send_signal(signal.SIGINT)
        handlers = {}
        if threading.current_thread() is threading.main_thread():
            def forward(signum, frame):
                proc.send_signal(signal.SIGINT)
            handlers = {s: signal.signal(s, forward) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            rc = proc.wait()
        finally:
            for s, h in handlers.items():
                signal.signal(s, h)
            with _live_lock:
                _live.pop(proc.pid, None)
    return _record_end(task, record, 128 - rc if rc < 0 else rc, t0)


def _record_end(task: dict, record: dict, rc: int, t0: float) -> dict:
    record["attempts"][-1].update(exit_code=rc, process_time=time.perf_counter() - t0,
                                  finished=time.strftime("%Y-%m-%dT%H:%M:%S%z"))
    record.update(running=False, exit_code=rc)
    write_atomic(Path(task["record"]), _dumps(record))
    return record


def _task(sweep: Sweep, out: Path, case: Case, action: str, **kw) -> dict:
    return {"name": case.name, "action": action, "cwd": os.getcwd(),
            "cmd": case_command(sweep, case, out, resume=action == "resume", **kw),
            "record": str(record_path(out, case).resolve()), "log": str(log_path(out, case).resolve())}


def _stop_children() -> None:
    """Ask every running case to stop (SIGINT: checkpoint, interrupted, exit 130)."""
    with _live_lock:
        procs = list(_live.values())
    for p in procs:
        try:
            p.send_signal(signal.SIGINT)
        except ProcessLookupError:
            pass
    deadline = time.monotonic() + STOP_GRACE
    for p in procs:
        try:
            p.wait(max(0.0, deadline - time.monotonic()))
        except subprocess.TimeoutExpired:
            p.kill()


def _mpi_pool():
    """An MPIPoolExecutor on the shared pool of ``python -m mpi4py.futures``; ConfigError
    when this process is not the driver of such a job."""
    try:
        from mpi4py import MPI
        from mpi4py.futures import MPIPoolExecutor
    except ImportError:
        raise ConfigError("--executor mpi: mpi4py is not installed") from None
    if _futures_lib() is None or MPI.COMM_WORLD.Get_size() < 2:
        raise ConfigError("--executor mpi: start the sweep as 'mpirun -n N python -m "
                          "mpi4py.futures -m dpcollapse.cli sweep ... --executor mpi' (N >= 2: "
                          "rank 0 drives, N - 1 ranks run cases)")
    return MPIPoolExecutor(), MPI.COMM_WORLD.Get_size() - 1


def launched_rank() -> int:
    """This process's rank among those an MPI launcher started (0 when none), from the
    launcher's variables (MPI is not initialized for this)."""
    for var in RANK_VARIABLES:
        try:
            return int(os.environ[var])
        except (KeyError, ValueError):
            continue
    return 0


def launched_ranks() -> int:
    """Number of ranks an MPI launcher started this process among (1 when none)."""
    for var in ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE"):
        try:
            return max(1, int(os.environ[var]))
        except (KeyError, ValueError):
            continue
    return 1


def _futures_lib():
    lib = sys.modules.get("mpi4py.futures._lib") or sys.modules.get("mpi4py.futures._core")
    return lib if getattr(lib, "SharedPool", None) is not None else None


def mpi_exit_status(code: int) -> int:
    """The status to return from the command, given the sweep's ``code``.

    Under ``python -m mpi4py.futures`` a non-zero exit status makes mpi4py call
    ``MPI_Abort`` (and Debian's mpirun 4.1 then crashes in its PMIx clean-up, exit 139).
    So the driver returns 0, lets mpi4py release the worker ranks, and at interpreter exit
    finalizes MPI itself and exits with ``code`` once the workers of its node have exited
    (:func:`dpcollapse.parallel.finalize_and_exit`): mpirun then exits with ``code`` too.
    Elsewhere ``code`` is returned unchanged.
    """
    if code == 0 or _futures_lib() is None:
        return code
    from mpi4py import MPI

    if MPI.COMM_WORLD.Get_size() < 2:
        return code

    def finish() -> None:
        parallel.finalize_and_exit(code)

    atexit.register(finish)
    return 0


def run_sweep(sweep: Sweep, out: Path, executor: str = "local", jobs: int = 1,
              retry_failed: bool = False) -> list[dict]:
    """Run every case not yet done (local or mpi executor); write sweep.csv as cases end.

    Returns the CSV rows. Raises :class:`Interrupted` after Ctrl-C/SIGTERM, once the running
    cases have stopped (their run directories resume on the next run of the sweep).
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    from dpcollapse.io.rundir import take_lock

    # one sweep at a time on a directory (a second one took the first's running cases,
    # locked by their runs, for failures)
    lock = take_lock(out, ".sweep.lock", "sweep")
    try:
        return _run_sweep(sweep, out, executor, jobs, retry_failed)
    finally:
        os.close(lock)


def _run_sweep(sweep: Sweep, out: Path, executor: str, jobs: int, retry_failed: bool) -> list[dict]:
    t0 = time.perf_counter()
    if executor == "mpi":
        pool, workers = _mpi_pool()
    else:
        pool, workers = cf.ThreadPoolExecutor(max_workers=jobs), jobs
    _stop.clear()
    rows: dict[str, dict] = {}
    tasks = []
    for case in sweep.cases:
        action = plan(sweep, out, case, retry_failed)
        if action == "skip":
            log.info("%s: %s, skipped", case.name, case_state(out, case).status or "failed")
        else:
            tasks.append((case, _task(sweep, out, case, action)))
    table = collect(sweep, out)
    log.info("sweep %s: %s; running %d on %d %s", sweep.path.name, progress_line(table),
             len(tasks), workers, "MPI workers" if executor == "mpi" else "processes")
    # SIGTERM stops the sweep as Ctrl-C does; SIGINT may have been ignored (a background
    # job of a script): handled again, and so not ignored either by the cases started now.
    previous = {s: signal.signal(s, h) for s, h in ((signal.SIGTERM, _raise_interrupt),
                                                     (signal.SIGINT, signal.default_int_handler))}
    futures = {}
    try:
        for case, task in tasks:
            futures[pool.submit(run_case, task)] = case
        pending = set(futures)
        while pending:
            finished, pending = cf.wait(pending, timeout=1.0, return_when=cf.FIRST_COMPLETED)
            for fut in finished:
                case = futures[fut]
                try:
                    rec = fut.result()
                except Exception as exc:  # could not start or record the case: say so, go on
                    log.error("%s: not run: %s: %s", case.name, type(exc).__name__, exc)
                    rec = {"exit_code": None}
                rows[case.name] = case_row(sweep, out, case)
                table = collect(sweep, out, rows)
                _report(case, rows[case.name], rec)
                line = progress_line(table, time.perf_counter() - t0)
                write_atomic(out / "progress.txt", line + "\n")
                log.info("sweep: %s", line)
    except KeyboardInterrupt:
        _stop.set()
        for fut in futures:
            fut.cancel()
        log.warning("sweep interrupted: stopping the running cases")
        _stop_children()
        if executor == "mpi":  # the workers pass the signal on; wait for their records
            cf.wait([f for f in futures if not f.done()], timeout=STOP_GRACE)
        pool.shutdown(wait=executor != "mpi", cancel_futures=True)
        table = collect(sweep, out)
        write_atomic(out / "progress.txt", progress_line(table) + "\n")
        raise Interrupted(f"sweep interrupted: {progress_line(table)}; run it again to "
                          "resume") from None
    finally:
        for s, h in previous.items():
            signal.signal(s, h)
    pool.shutdown(wait=True)
    table = collect(sweep, out)
    write_atomic(out / "progress.txt", progress_line(table, time.perf_counter() - t0) + "\n")
    return table


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt


def _report(case: Case, row: dict, rec: dict) -> None:
    code = rec.get("exit_code")
    wall = rec.get("attempts", [{}])[-1].get("process_time", 0.0)
    if row["status"] == "failed" or code not in (0, None):
        log.warning("%s: %s (exit %s) after %.1f s: %s", case.name, row["status"], code, wall,
                    row.get("error", ""))
    else:
        log.info("%s: %s at t = %s s after %.1f s", case.name, row["status"], row.get("t_end"), wall)


def run_one(sweep: Sweep, out: Path, index: int, retry_failed: bool = False) -> int:
    """Run case ``index`` only (a SLURM array task); its exit status (0 when skipped)."""
    if not 0 <= index < len(sweep.cases):
        raise ConfigError(f"--task = {index}: must be in [0, {len(sweep.cases) - 1}] "
                          f"({len(sweep.cases)} cases)")
    case = sweep.cases[index]
    action = plan(sweep, Path(out), case, retry_failed)
    if action == "skip":
        log.info("%s: %s, skipped", case.name, case_state(Path(out), case).status)
        return 0
    task = _task(sweep, Path(out), case, action, python=sweep.spec.slurm.python,
                 launcher=sweep.spec.slurm.launcher)
    rec = run_case(task)
    _report(case, case_row(sweep, Path(out), case), rec)
    return int(rec["exit_code"])


def write_slurm(sweep: Sweep, out: Path, sweep_args: list[str], jobs: int | None) -> tuple[Path, Path]:
    """Write ``out/sweep.sbatch`` (the job array) and ``out/collect.sbatch``; their paths.

    ``sweep_args`` are the ``--set`` items given on the command line (repeated in the tasks).
    """
    out = Path(out).resolve()
    s = sweep.spec.slurm
    n = len(sweep.cases)
    python = s.python or sys.executable
    throttle = f"%{jobs}" if jobs else ""
    for what, text in (("--out", str(out)), ("the sweep file", str(sweep.path.resolve())),
                       ("the working directory", os.getcwd()), ("python", python),
                       ("--set", " ".join(sweep_args))):
        _script_safe(what, text)
    header = [f"#SBATCH --job-name={_sbatch_quote('sweep-' + sweep.path.stem)}",
              f"#SBATCH --ntasks={sweep.spec.ranks_per_case}", "#SBATCH --cpus-per-task=1"]
    for flag, value in (("time", s.time), ("partition", s.partition), ("account", s.account),
                        ("mem-per-cpu", s.memory_per_cpu)):
        if value:
            header.append(f"#SBATCH --{flag}={value}")
    header += [f"#SBATCH {opt}" for opt in s.sbatch]
    root = _package_root()
    env = ["export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1"]
    if root:
        env.append(f"export PYTHONPATH={shlex.quote(root)}${{PYTHONPATH:+:$PYTHONPATH}}")
    common = [python, "-m", "dpcollapse.cli", "sweep", str(sweep.path.resolve()),
              "--out", str(out)] + [a for item in sweep_args for a in ("--set", item)]
    task = shlex.join(common + ["--fingerprint", sweep.fingerprint]) + \
        ' --task "$SLURM_ARRAY_TASK_ID"'
    array = out / "sweep.sbatch"
    write_atomic(array, "\n".join([
        "#!/bin/bash",
        *header,
        f"#SBATCH --array=0-{n - 1}{throttle}",
        f"#SBATCH --output={_sbatch_quote(f'{out}/logs/slurm-%A_%a.out')}",
        f"# {n} cases of {sweep.path} (one array task each), written by dpcollapse sweep.",
        f"# Submit: {submit_hint(array, out / 'collect.sbatch')}",
        "set -eu", *s.setup, *env, f"cd {shlex.quote(os.getcwd())}", f"exec {task}", ""]))
    coll = out / "collect.sbatch"
    write_atomic(
        coll,
        "\n".join(
            [
                "#!/bin/bash",
                f"#SBATCH --job-name={_sbatch_quote('collect-' + sweep.path.stem)}",
                "#SBATCH --ntasks=1",
                *[h for h in header if h.startswith(("#SBATCH --partition", "#SBATCH --account"))],
                f"#SBATCH --output={_sbatch_quote(f'{out}/logs/slurm-collect-%j.out')}",
                "# After the array: writes sweep.csv and the progress line.",
                "set -eu",
                *s.setup,
                *env,
                f"cd {shlex.quote(os.getcwd())}",
                f"exec {shlex.join(common + ['--collect'])}",
                "",
            ]
        ),
    )
    array.chmod(0o755)
    coll.chmod(0o755)
    return array, coll


def submit_hint(array: Path, collect_script: Path) -> str:
    """The shell line that submits the array and, after it, the collect job (paths quoted)."""
    return (f"jid=$(sbatch --parsable {shlex.quote(str(array))}) && "
            f"sbatch --dependency=afterany:$jid {shlex.quote(str(collect_script))}")


def _script_safe(what: str, text: str, quote: str = "") -> None:
    """ConfigError when ``text`` (a path or value written into a job script) holds a
    control character (a newline would start a new script line) or ``quote`` (it would
    end the quoted value)."""
    if any(ord(c) < 32 or ord(c) == 127 for c in text) or (quote and quote in text):
        raise ConfigError(f"{what} = {text[:80]!r}: a job script cannot hold it (a newline, "
                          f"control character{' or ' + quote if quote else ''})")


def _sbatch_quote(value: str) -> str:
    """A value of an ``#SBATCH`` line in double quotes (sbatch reads them; spaces kept)."""
    _script_safe("an #SBATCH value", value, quote='"')
    return f'"{value}"'
