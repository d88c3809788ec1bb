"""Time the rigid collapse of two commits (or two settings) back to back, interleaved, and print the ratio.

    benchmarks/compare_speed.sh OLD_REV NEW_REV [--rounds N] [--set KEY=VALUE ...]
    benchmarks/compare_speed.sh HEAD HEAD --old-set KEY=VALUE ... --new-set KEY=VALUE ...

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
import resource
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _env(checkout: Path) -> dict:
    env = dict(os.environ)
    env.update(PYTHONPATH=str(checkout), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
               OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    return env


def _run(python: str, checkout: Path, out: Path, overrides: list[str]) -> dict:
    """One run; wall and CPU time of the child process, and its summary."""
    cmd = [python, "-m", "dpcollapse.cli", "run", str(checkout / "configs" / "rigid.yaml"),
           "--out", str(out), "--quiet"]
    for o in overrides:
        cmd += ["--set", o]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=_env(checkout), cwd=checkout, capture_output=True, text=True,
                          check=False)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"{checkout}: exit {proc.returncode}\n{proc.stderr[-2000:]}")
    summary = json.loads((out / "run.json").read_text())["summary"]
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return {"wall": wall, "cpu": cpu, "steps": summary["steps"], "front": summary["front"],
            "t": summary["t"], "lu": summary.get("flow_factorizations"),
            "rejected": summary.get("rejected_steps", 0)}


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
    args = ap.parse_args(argv)
    # SIGTERM (and SIGINT, which a background job ignores) end the script through its
    # cleanup: the temporary worktrees are removed
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))

    side = {"old": args.old_overrides, "new": args.new_overrides}
    settings = bool(args.old_overrides or args.new_overrides)   # two computations
    tmp = Path(tempfile.mkdtemp(prefix="compare_speed_"))
    checkouts = {}
    try:
        for label, rev in (("old", args.old), ("new", args.new)):
            path = tmp / label
            subprocess.run(["git", "-C", str(REPO), "worktree", "add", "--detach", str(path), rev],
                           check=True, capture_output=True)
            checkouts[label] = path
        config = {label: (path / "configs" / "rigid.yaml").read_bytes() for label, path in checkouts.items()}
        if config["old"] != config["new"]:   # e.g. the headline before and after a new default
            settings = True
            print("configs/rigid.yaml differs between the two revisions: two computations")
        for label, path in checkouts.items():  # warm-up: JIT compile, not timed
            _run(args.python, path, tmp / f"warm_{label}", ["time.end_time=0.003"])
        results = {"old": [], "new": []}
        for k in range(args.rounds):
            order = ("old", "new") if k % 2 == 0 else ("new", "old")
            for label in order:
                r = _run(args.python, checkouts[label], tmp / f"{label}_{k}",
                         args.overrides + side[label])
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
        for path in checkouts.values():
            subprocess.run(["git", "-C", str(REPO), "worktree", "remove", "--force", str(path)],
                           capture_output=True, check=False)
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
