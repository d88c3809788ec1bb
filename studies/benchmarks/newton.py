"""Newton against Picard, same machine, one process, back to back (docs/benchmarks/2026-12-01-newton.md).

    python benchmarks/newton.py plug  [--end 0.8] [--set KEY=VALUE ...] VARIANT ...
    python benchmarks/newton.py rigid [--end T]   [--set KEY=VALUE ...] VARIANT ...

A VARIANT is a name and its overrides, e.g. ``newton:numerics.nonlinear_solver=newton``
(commas separate several overrides). plug: relative L² error of u_x against the 1D
reference at t = 0.2 … 0.8 s (``validation.plug``); rigid: front and height at the end.
Prints steps, iterations, LU factorizations, wall and CPU time, Newton's Picard fallbacks per
variant and the wall-time, LU and CPU ratios of each variant to the first.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from dpcollapse.config import load_config, with_overrides
from dpcollapse.errors import ConvergenceError, MeshError
from dpcollapse.simulation import Simulation

TIMES = [0.2, 0.4, 0.6, 0.8]


def run(case: str, overrides: list[str], end: float | None, out: Path) -> dict:
    config = Path("configs/plug.yaml" if case == "plug" else "configs/rigid.yaml")
    extra = ["time.output_every=100000", "time.checkpoint_every=100000"]
    if end:
        extra.append(f"time.end_time={end!r}")
    cfg = with_overrides(load_config(config), extra + overrides)
    sim = Simulation(cfg, out, quiet=True)
    observers = []
    if case == "plug":
        from dpcollapse.validation.plug import PlugObserver, reference_solution

        times = [t for t in TIMES if t <= cfg.time.end_time + 1e-9] + [cfg.time.end_time]
        reference = reference_solution(cfg, cfg.time.end_time, times)
        observers.append(PlugObserver(sim, reference, times))
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        summary = sim.run(observers=observers)
        status = summary["status"]
        factorizations = summary["flow_factorizations"]
        fallbacks = summary.get("newton_fallbacks", 0)
    except (ConvergenceError, MeshError) as exc:
        status, factorizations = f"failed: {exc}", sim.factorizations + sim.disc.flow.solver.factorizations
        fallbacks = sim.fallbacks + sim.disc.flow.solver.fallbacks
    row = {"status": status, "steps": sim.state.step, "iterations": int(np.sum(sim.iteration_counts)),
           "factorizations": factorizations, "wall": time.perf_counter() - t0,
           "cpu": time.process_time() - c0, "fallbacks": fallbacks}
    if case == "plug":
        row["errors"] = dict(observers[0].errors)
    else:
        m = sim.disc.measures()
        row["front"], row["height"] = m["front"], m["max_height"]
    flow = sim.disc.flow
    row["history"] = list(getattr(flow, "residual_history", []))
    return row


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("case", choices=["plug", "rigid"])
    parser.add_argument("variants", nargs="+")
    parser.add_argument("--end", type=float, default=None)
    parser.add_argument("--set", action="append", default=[])
    parser.add_argument("--history", action="store_true", help="print the last Newton residuals")
    args = parser.parse_args()
    rows = []
    for variant in args.variants:
        name, _, spec = variant.partition(":")
        overrides = list(args.set) + [o for o in spec.split(",") if o]
        row = run(args.case, overrides, args.end, Path(f"/tmp/bench_newton/{name}"))
        rows.append((name, row))
        ratio = row["wall"] / rows[0][1]["wall"]
        lu_ratio = row["factorizations"] / max(rows[0][1]["factorizations"], 1)
        cpu_ratio = row["cpu"] / rows[0][1]["cpu"]
        extra = (" errors " + " ".join(f"t={t:g}:{e:.2e}" for t, e in row["errors"].items())
                 if "errors" in row else f" front {row['front']:.5f} m height {row['height']:.5f} m")
        print(f"{name:28s} {row['status'][:60]:20s} steps {row['steps']:5d} its {row['iterations']:6d} "
              f"LU {row['factorizations']:6d} wall {row['wall']:7.1f} s cpu {row['cpu']:7.1f} s "
              f"fallbacks {row['fallbacks']:4d} ratio wall {ratio:5.2f} LU {lu_ratio:5.2f} "
              f"cpu {cpu_ratio:5.2f}{extra}", flush=True)
        if args.history and row["history"]:
            print("   last Newton residual history (ε, iteration, ‖F‖):",
                  ", ".join(f"({e:g}, {k}, {r:.2e})" for e, k, r in row["history"][-12:]), flush=True)


if __name__ == "__main__":
    main()
