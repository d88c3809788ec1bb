"""The two-phase column's step: fixed Δt against the Courant-limited step (issue 25).

    python benchmarks/two_phase_step.py OUT_DIR [--config configs/column_eulerian_a1.42.yaml]
                                        [--mesh-size 0.01]

Runs the config at ``geometry.mesh_size`` with Δt = 0.25 ms (the reference), Δt = 1 ms, and
``model.adaptive_dt`` (Δt ≤ 5 ms) at Courant numbers 0.5 and 0.25, each into OUT_DIR/NAME
(a run already finished there is reused), then prints per run: steps, LU factorizations,
CPU time (this process's children, serial), the front at the end and the largest and mean
|x_f(t) − x_f,ref(t)| over the reference's times, and the ratios to the 1 ms run; draws
OUT_DIR/front_and_step.png (front and Δt against t).

The front is the last cell column holding grains, so it moves in steps of one cell: errors
below one cell are not resolved.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import numpy as np

from dpcollapse.io.diagnostics import read_diagnostics

ROOT = Path(__file__).resolve().parents[2]
RUNS = {
    "dt_0.25ms": ["time.dt=2.5e-4"],
    "dt_1ms": ["time.dt=1e-3"],
    "adaptive_co0.5": ["time.dt=5e-3", "model.adaptive_dt=true", "model.step_courant=0.5"],
    "adaptive_co0.25": ["time.dt=5e-3", "model.adaptive_dt=true", "model.step_courant=0.25"],
}
REFERENCE = "dt_0.25ms"


def _run(config: str, mesh_size: float, out: Path, sets: list[str]) -> float:
    """Run (or reuse) one case; its CPU seconds (nan when reused)."""
    done = out / "run.json"
    if done.exists() and json.loads(done.read_text()).get("status") in ("at_rest", "end_time"):
        return float("nan")
    exe = Path(sys.executable).parent / "dpcollapse"
    cmd = [str(exe), "run", config, "--out", str(out), "--quiet", "--overwrite",
           "--set", f"geometry.mesh_size={mesh_size}"]
    for kv in sets:
        cmd += ["--set", kv]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(cmd, check=True, cwd=ROOT,
                   env={**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"})
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def _history(run: Path):
    d = read_diagnostics(run / "diagnostics.csv")
    return np.array(d["t"]), np.array(d["front"]), np.array(d["dt"])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--config", default="configs/column_eulerian_a1.42.yaml")
    ap.add_argument("--mesh-size", type=float, default=0.01)
    args = ap.parse_args()
    cpu = {name: _run(args.config, args.mesh_size, args.out / name, sets)
           for name, sets in RUNS.items()}
    tr, xr, _ = _history(args.out / REFERENCE)
    rows = {}
    for name in RUNS:
        t, x, _ = _history(args.out / name)
        s = json.loads((args.out / name / "run.json").read_text())["summary"]
        m = t <= tr[-1]
        ref = xr[np.searchsorted(tr, t[m], side="right") - 1]
        err = np.abs(x[m] - ref)
        rows[name] = dict(steps=s["steps"], lu=s.get("flow_factorizations"), cpu=cpu[name],
                          front=s["front"], max_err=err.max(), mean_err=err.mean())
    base = rows["dt_1ms"]
    print(f"{'run':16} {'steps':>6} {'LU':>6} {'CPU s':>7} {'front m':>8} {'max|dx| m':>10} "
          f"{'mean|dx| m':>10} {'steps/1ms':>9} {'LU/1ms':>7} {'CPU/1ms':>7}")
    for name, r in rows.items():
        print(f"{name:16} {r['steps']:6d} {r['lu']:6d} {r['cpu']:7.1f} {r['front']:8.3f} "
              f"{r['max_err']:10.4f} {r['mean_err']:10.4f} {r['steps'] / base['steps']:9.2f} "
              f"{r['lu'] / base['lu']:7.2f} {r['cpu'] / base['cpu']:7.2f}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for name in RUNS:
        t, x, dt = _history(args.out / name)
        ax[0].plot(t, x, label=name)
        ax[1].semilogy(t[1:], dt[1:], label=name)
    ax[0].set_xlabel("t [s]")
    ax[0].set_ylabel("front [m]")
    ax[0].legend()
    ax[1].set_xlabel("t [s]")
    ax[1].set_ylabel("Δt [s]")
    fig.suptitle(f"{Path(args.config).stem}, cells {args.mesh_size:g} m")
    fig.tight_layout()
    fig.savefig(args.out / "front_and_step.png", dpi=90)
    return 0


if __name__ == "__main__":
    sys.exit(main())
