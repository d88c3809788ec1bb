"""Time the rigid collapse (or another config) of two commits or settings, interleaved; print the ratio.

    benchmarks/compare_speed.sh OLD_REV NEW_REV [--rounds N] [--set KEY=VALUE ...]
    benchmarks/compare_speed.sh HEAD HEAD --old-set KEY=VALUE ... --new-set KEY=VALUE ...
    benchmarks/compare_speed.sh OLD_REV NEW_REV --config configs/column_eulerian_a6.26_adaptive.yaml \
        --rounds 1 --concurrent

``--config`` times another config of the checkouts (default ``configs/rigid.yaml``; the
a = 6.26 adaptive two-phase column: issue 51's other headline). ``--concurrent`` runs the
old and the new run of each round at the same time instead of one after the other (on a
shared 2-core machine: the same load for both, in half the wall time of a long run); the
CPU times are each child's own. ``--keep DIR`` keeps the timed runs' directories
(``DIR/old_0``, ``DIR/new_0``, …: their diagnostics.csv to compare row by row).

Both revisions are checked out into temporary git worktrees (the repository of this file);
each round runs ``dpcollapse run configs/rigid.yaml`` once with the old and once with the new
checkout (the order alternates between rounds, so a slow drift of the machine's load hits
both alike). Before the rounds, each checkout runs a short warm-up (JIT compilation into the
shared ``$XDG_CACHE_HOME``), which is not timed. Reported per run: wall time, CPU time of the
child (user + system) and the number of steps; then the medians, the new/old ratio of
each round and its median over rounds (robust to a load that drifts between rounds). The
runs must agree in steps and final front, or the comparison is refused.

The headline before and after a change of ``configs/rigid.yaml`` itself (each revision runs
its own file): ``benchmarks/compare_speed.sh OLD_REV NEW_REV`` (issue 51); when the two files
differ the sides are two computations, as with ``--old-set`` / ``--new-set`` below.

``--old-set`` / ``--new-set`` add overrides to one side only (e.g. the old and the new time
settings of ``configs/rigid.yaml`` on one commit): the two sides are then different
computations, so each side's runs must agree among themselves, and the steps, LU
factorizations of the flow, rejected steps, final time and front of both sides are printed
next to the ratios (the accuracy is judged against a reference, not here).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
#: the runs started and not yet waited for (ended with the script: SIGINT, SIGTERM, an error)
_RUNNING: set = set()


def _env(checkout: Path) -> dict:
    env = dict(os.environ)
    env.update(PYTHONPATH=str(checkout), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    return env


def _start(python: str, checkout: Path, out: Path, overrides: list[str],
           config: str = "configs/rigid.yaml") -> tuple:
    """Start one run of ``config`` (relative to the checkout): (process, start time)."""
    cmd = [python, "-m", "dpcollapse.cli", "run", str(checkout / config),
           "--out", str(out), "--quiet"]
    for o in overrides:
        cmd += ["--set", o]
    with open(f"{out}.err", "w") as err:    # a file, not a pipe: a concurrent run never blocks
        proc = subprocess.Popen(cmd, env=_env(checkout), cwd=checkout, stdout=subprocess.DEVNULL,
                                stderr=err)
    _RUNNING.add(proc)
    return proc, time.perf_counter()


def _finish(started: tuple, checkout: Path, out: Path, ended: tuple | None = None) -> dict:
    """Wait for a run of ``_start`` (``ended``: its (status, rusage, end time) if already
    reaped); wall and CPU time of the child process (its own rusage), and its summary."""
    proc, t0 = started
    if ended is None:
        _, status, usage = os.wait4(proc.pid, 0)
        ended = (status, usage, time.perf_counter())
    status, usage, t1 = ended
    _RUNNING.discard(proc)
    wall = t1 - t0
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        stderr = Path(f"{out}.err").read_text()
        raise SystemExit(f"{checkout}: exit {proc.returncode}\n{stderr[-2000:]}")
    summary = json.loads((out / "run.json").read_text())["summary"]
    return {"wall": wall, "cpu": usage.ru_utime + usage.ru_stime, "steps": summary["steps"],
            "front": summary["front"], "t": summary["t"],
            "lu": summary.get("flow_factorizations"), "rejected": summary.get("rejected_steps", 0)}


def _run(python: str, checkout: Path, out: Path, overrides: list[str],
         config: str = "configs/rigid.yaml") -> dict:
    """One run; wall and CPU time of the child process, and its summary."""
    return _finish(_start(python, checkout, out, overrides, config), checkout, out)


def _same_computation(runs: list[dict]) -> bool:
    """Whether runs did the same steps to the same front (1 µm)."""
    ref = runs[0]
    return all(r["steps"] == ref["steps"] and abs(r["front"] - ref["front"]) <= 1e-6 for r in runs)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--set", dest="overrides", action="append", default=[],
                    help="config override for every timed run (e.g. time.end_time=0.3)")
    ap.add_argument("--old-set", dest="old_overrides", action="append", default=[],
                    help="config override for the old side only")
    ap.add_argument("--new-set", dest="new_overrides", action="append", default=[],
                    help="config override for the new side only")
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--config", default="configs/rigid.yaml",
                    help="the config to time, relative to the checkouts (default configs/rigid.yaml)")
    ap.add_argument("--concurrent", action="store_true",
                    help="run each round's old and new run at the same time")
    ap.add_argument("--keep", type=Path, default=None,
                    help="keep the timed runs' directories in this directory")
    args = ap.parse_args(argv)
    # SIGTERM and SIGINT (which a background job would ignore: e.g. ``timeout -s INT``) end
    # the script through its cleanup: the runs ended, the temporary worktrees removed
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    signal.signal(signal.SIGINT, lambda *_: sys.exit(130))

    side = {"old": args.old_overrides, "new": args.new_overrides}
    settings = bool(args.old_overrides or args.new_overrides)   # two computations
    tmp = Path(tempfile.mkdtemp(prefix="compare_speed_"))
    if args.keep:
        args.keep.mkdir(parents=True, exist_ok=True)
    checkouts = {}
    try:
        for label, rev in (("old", args.old), ("new", args.new)):
            path = tmp / label
            subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(path), rev],
                           check=True, capture_output=True)
            checkouts[label] = path
        config = {label: (path / args.config).read_bytes() for label, path in checkouts.items()}
        if config["old"] != config["new"]:   # e.g. the headline before and after a new default
            settings = True
            print(f"{args.config} differs between the two revisions: two computations")
        for label, path in checkouts.items():  # warm-up: JIT compile, not timed
            _run(args.python, path, tmp / f"warm_{label}", ["time.end_time=0.003"], args.config)
        results = {"old": [], "new": []}
        print(f"load average at the start: {os.getloadavg()}", flush=True)
        for k in range(args.rounds):
            order = ("old", "new") if k % 2 == 0 else ("new", "old")
            started = {}
            for label in order:
                out = (args.keep or tmp) / f"{label}_{k}"
                started[label] = _start(args.python, checkouts[label], out,
                                        args.overrides + side[label], args.config)
                if not args.concurrent:
                    started[label] = _finish(started[label], checkouts[label], out)
            if args.concurrent:    # each run's wall time ends when it ends, whichever first
                pids = {started[label][0].pid: label for label in order}
                while pids:
                    pid, status, usage = os.wait4(-1, 0)
                    if pid in pids:
                        label = pids.pop(pid)
                        started[label] = _finish(started[label], checkouts[label],
                                                 (args.keep or tmp) / f"{label}_{k}",
                                                 (status, usage, time.perf_counter()))
            for label in order:
                r = started[label]
                results[label].append(r)
                print(f"round {k + 1} {label}: wall {r['wall']:.2f} s, cpu {r['cpu']:.2f} s, "
                      f"{r['steps']} steps, {r['lu']} LU, {r['rejected']} rejected, "
                      f"t {r['t']:.4f} s, front {r['front']:.9f} m", flush=True)
        groups = ([results["old"], results["new"]] if settings
                  else [results["old"] + results["new"]])
        if not all(_same_computation(g) for g in groups):
            print("the runs differ (steps or front): not the same computation", file=sys.stderr)
            return 1
        med = {label: {key: statistics.median(r[key] for r in rs) for key in ("wall", "cpu")}
               for label, rs in results.items()}
        print(f"load average at the end: {os.getloadavg()}")
        if settings:
            for label in ("old", "new"):
                r = results[label][0]
                print(f"{label} ({' '.join(side[label]) or 'as configured'}): {r['steps']} steps, "
                      f"{r['lu']} LU, {r['rejected']} rejected, at t = {r['t']:.4f} s, "
                      f"front {r['front']:.6f} m")
        for key in ("wall", "cpu"):
            # the ratio of the two runs of each round (back to back, so under about the same
            # load), then its median over rounds: robust to a load that drifts between rounds
            paired = [n[key] / o[key] for o, n in zip(results["old"], results["new"])]
            print(f"{key}: median old {med['old'][key]:.2f} s, new {med['new'][key]:.2f} s; "
                  f"new/old per round {', '.join(f'{r:.3f}' for r in paired)}, "
                  f"median {statistics.median(paired):.3f}")
        return 0
    finally:
        for proc in list(_RUNNING):     # interrupted: no run outlives the script
            proc.terminate()
            proc.wait()
        for path in checkouts.values():
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(path)],
                           capture_output=True, check=False)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
