"""Regularization against augmented Lagrangian: accuracy against wall time, same machine, same run.

``python -m studies compare plug``: both methods over their accuracy knobs (ε and the fixed-point
tolerance for regularization; r and the tolerance for the augmented Lagrangian; the mesh
size for both) on the plug-flow case; accuracy = RMS over t = 0.2, 0.4, 0.6, 0.8 s of the
relative L² error of u_x against the 1D non-smooth reference (``reference.plug1d``).

``python -m studies compare collapse``: the rigid-bed collapse; accuracy against the finest
augmented Lagrangian run of the plan (run first): the largest difference of the deposit's
free surface h(x) [m], of the front position history x_f(t) [m] and of the flowing area
fraction (|u| > 1 mm/s, the static/flowing interface) at t = 0.1, 0.2, 0.4 s.

Both write ``compare_CASE.csv`` and ``compare_CASE.png`` (error against wall time, log–log,
one series per method) and print the wall-time ratio regularized/augmented Lagrangian at
matched accuracy: the cheapest run of each method whose error is at most the larger of the
two methods' best errors.
"""

from __future__ import annotations

import csv
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.config import Config, load_config, with_overrides
from dpcollapse.errors import ConvergenceError, MeshError
from dpcollapse.geometry.mesher import SURFACE
from dpcollapse.simulation import Simulation

#: Flowing threshold (seed 000) [m/s].
FLOWING_SPEED = 1e-3


@dataclass
class Run:
    """One run of a comparison: the method, its knobs, cost and accuracy."""

    method: str
    label: str
    overrides: list
    wall_time: float = math.nan
    steps: int = 0
    iterations: int = 0
    factorizations: int = 0
    status: str = ""
    error: float = math.nan          # the accuracy measure of the case
    details: dict = field(default_factory=dict)


# --------------------------------------------------------------------------- plans
PLUG_TIMES = [0.2, 0.4, 0.6, 0.8]

PLUG_FULL = [
    ("regularized", "eps=1e-2", ["numerics.epsilon=1e-2"]),
    ("regularized", "eps=1e-4", ["numerics.epsilon=1e-4"]),
    ("regularized", "eps=1e-6", ["numerics.epsilon=1e-6"]),
    ("regularized", "eps=1e-6 rtol=1e-3", ["numerics.epsilon=1e-6", "numerics.nonlinear_rtol=1e-3"]),
    ("regularized", "eps=1e-6 h=10mm", ["numerics.epsilon=1e-6", "geometry.mesh_size=0.01"]),
    ("augmented_lagrangian", "rtol=1e-3", ["numerics.nonlinear_rtol=1e-3"]),
    ("augmented_lagrangian", "rtol=1e-4", ["numerics.nonlinear_rtol=1e-4"]),
    ("augmented_lagrangian", "rtol=1e-4 r=5", ["numerics.nonlinear_rtol=1e-4", "numerics.augmentation=5"]),
    (
        "augmented_lagrangian",
        "rtol=1e-4 r=500",
        ["numerics.nonlinear_rtol=1e-4", "numerics.augmentation=500"],
    ),
    ("augmented_lagrangian", "rtol=1e-4 h=10mm", ["numerics.nonlinear_rtol=1e-4", "geometry.mesh_size=0.01"]),
]
PLUG_QUICK = [
    (
        "regularized",
        "eps=1e-6 h=10mm",
        ["numerics.epsilon=1e-6", "geometry.mesh_size=0.01", "time.end_time=0.45"],
    ),
    (
        "augmented_lagrangian",
        "rtol=1e-4 h=10mm",
        ["numerics.nonlinear_rtol=1e-4", "geometry.mesh_size=0.01", "time.end_time=0.45"],
    ),
]
#: Augmented Lagrangian absolute tolerance on the plug case [m/s]: the layer comes to rest,
#: where only the absolute part of the stopping test can be met.
PLUG_AL_ATOL = "numerics.nonlinear_atol=1e-6"

COLLAPSE_TIMES = [0.1, 0.2, 0.4]
COLLAPSE_FULL = [   # the first run is the reference (a tolerance of 1e-4 stalls its first steps)
    ("augmented_lagrangian", "h=1.5cm", ["geometry.mesh_size=0.015"]),
    ("augmented_lagrangian", "h=2cm", ["geometry.mesh_size=0.02"]),
    ("augmented_lagrangian", "h=3cm", ["geometry.mesh_size=0.03"]),
    ("regularized", "h=1.5cm eps=1e-6", ["geometry.mesh_size=0.015"]),
    ("regularized", "h=2cm eps=1e-6", ["geometry.mesh_size=0.02"]),
    ("regularized", "h=2cm eps=1e-4", ["geometry.mesh_size=0.02", "numerics.epsilon=1e-4",
                                       "numerics.epsilon_friction=1e-4"]),
    ("regularized", "h=3cm eps=1e-6", ["geometry.mesh_size=0.03"]),
]
COLLAPSE_QUICK = [
    ("augmented_lagrangian", "h=4cm rtol=1e-4", ["geometry.mesh_size=0.04", "numerics.nonlinear_rtol=1e-4",
                                                "time.end_time=0.12"]),
    ("regularized", "h=4cm eps=1e-6", ["geometry.mesh_size=0.04", "time.end_time=0.12"]),
]


def _config(base: Config, method: str, overrides: list) -> Config:
    # both methods at the same fixed step (the augmented Lagrangian refuses bdf2)
    return with_overrides(base, [f"numerics.method={method}", "time.scheme=bdf1",
                                 "time.tolerance=null", "time.output_every=100000",
                                 "time.checkpoint_every=100000"] + list(overrides))


def _run(sim: Simulation, observers=()) -> tuple[dict, float]:
    t0 = time.perf_counter()
    try:
        summary = sim.run(observers=list(observers))
    except (ConvergenceError, MeshError) as exc:  # a failing run is a result too
        summary = {"status": f"failed: {exc}", "steps": sim.state.step,
                   "flow_factorizations": 0}
    return summary, time.perf_counter() - t0


def _fill(run: Run, sim: Simulation, summary: dict, wall: float) -> None:
    run.wall_time = wall
    run.steps = int(sim.state.step)
    run.iterations = int(np.sum(sim.iteration_counts))
    run.factorizations = int(summary.get("flow_factorizations", 0))
    run.status = str(summary["status"])


# --------------------------------------------------------------------------- plug
def compare_plug(config: Path, out_dir: Path, quick: bool = False, log=print) -> list[Run]:
    from dpcollapse.validation.plug import PlugObserver, reference_solution

    base = load_config(config)
    plan = PLUG_QUICK if quick else PLUG_FULL
    reference = reference_solution(base, base.time.end_time, PLUG_TIMES)
    runs = []
    for method, label, overrides in plan:
        extra = [PLUG_AL_ATOL] if method == "augmented_lagrangian" else []
        cfg = _config(base, method, extra + overrides)
        run = Run(method, label, overrides)
        sim = Simulation(cfg, out_dir / "runs" / f"{method}_{len(runs)}", quiet=True)
        observer = PlugObserver(sim, reference, [t for t in PLUG_TIMES if t <= cfg.time.end_time])
        summary, wall = _run(sim, [observer])
        _fill(run, sim, summary, wall)
        errors = np.array(list(observer.errors.values()))
        run.error = float(np.sqrt(np.mean(errors**2))) if len(errors) else math.nan
        run.details = {f"error_t{t:g}": e for t, e in observer.errors.items()}
        run.details["stopping_time"] = observer.stopping_time
        runs.append(run)
        log(_line(run))
    _write(out_dir, "plug", runs, "relative L2 error of u_x vs 1D reference (RMS over t)")
    return runs


# --------------------------------------------------------------------------- collapse
class CollapseObserver:
    """Front history and flowing-area fraction at fixed times (rebinds after remeshes)."""

    def __init__(self, times):
        self.times = list(times)
        self.front: list[tuple[float, float]] = []
        self.flowing: dict[float, float] = {}
        self._disc = None

    def _bind(self, disc) -> None:
        u = ufl.split(disc.flow.solution)[0]
        speed = ufl.sqrt(ufl.inner(u, u))
        self._flowing_area = fem.form(ufl.conditional(ufl.gt(speed, FLOWING_SPEED), 1.0, 0.0) * ufl.dx)
        self._area = fem.form(1.0 * ufl.dx(domain=disc.mesh))
        self._disc = disc

    def __call__(self, sim: Simulation) -> bool:
        if self._disc is not sim.disc:
            self._bind(sim.disc)
        t = sim.state.t
        x = sim.disc.mesh.geometry.x[:, 0]
        front = sim.comm.allreduce(float(x.max()) if len(x) else -np.inf, op=MPI.MAX)
        self.front.append((t, front))
        for tc in self.times:
            if tc not in self.flowing and t >= tc - 1e-9:
                comm = sim.comm
                a = comm.allreduce(fem.assemble_scalar(self._flowing_area), op=MPI.SUM)
                total = comm.allreduce(fem.assemble_scalar(self._area), op=MPI.SUM)
                self.flowing[tc] = a / total
        return False


def surface_profile(sim: Simulation) -> np.ndarray:
    """(n, 2) free-surface vertices (x, y) of the current mesh sorted by x, on every rank."""
    tagged = sim.disc.tagged
    ft = tagged.facet_tags
    facets = ft.indices[ft.values == SURFACE]
    nodes = compat.entities_to_geometry(tagged.mesh, 1, facets)
    pts = tagged.mesh.geometry.x[:, :2][nodes.ravel()] if len(facets) else np.zeros((0, 2))
    pts = np.concatenate(sim.comm.allgather(pts))
    pts = np.unique(np.round(pts, 12), axis=0)
    return pts[np.argsort(pts[:, 0])]


def _profile_difference(a: np.ndarray, b: np.ndarray) -> float:
    """max_x |h_a(x) − h_b(x)| with h = 0 beyond each profile's x-range."""
    x = np.linspace(0.0, max(a[:, 0].max(), b[:, 0].max()), 2000)

    def h(p):
        return np.interp(x, p[:, 0], p[:, 1], left=p[0, 1], right=0.0)

    return float(np.max(np.abs(h(a) - h(b))))


def _history_difference(a, b) -> float:
    """max_t |x_a(t) − x_b(t)| over the common time range (linear interpolation)."""
    a, b = np.asarray(a), np.asarray(b)
    if len(a) == 0 or len(b) == 0:
        return math.nan
    end = min(a[-1, 0], b[-1, 0])
    t = np.linspace(0.0, end, 1000)
    return float(np.max(np.abs(np.interp(t, a[:, 0], a[:, 1]) - np.interp(t, b[:, 0], b[:, 1]))))


def compare_collapse(config: Path, out_dir: Path, quick: bool = False, log=print) -> list[Run]:
    base = load_config(config)
    plan = COLLAPSE_QUICK if quick else COLLAPSE_FULL
    runs, results = [], []
    for method, label, overrides in plan:
        cfg = _config(base, method, overrides)
        run = Run(method, label, overrides)
        sim = Simulation(cfg, out_dir / "runs" / f"{method}_{len(runs)}", quiet=True)
        observer = CollapseObserver(COLLAPSE_TIMES)
        summary, wall = _run(sim, [observer])
        _fill(run, sim, summary, wall)
        results.append((observer, surface_profile(sim)))
        runs.append(run)
    ref_obs, ref_profile = results[0]
    for run, (obs, profile) in zip(runs, results):
        common = [t for t in COLLAPSE_TIMES if t in obs.flowing and t in ref_obs.flowing]
        run.details = {
            "profile_difference_m": _profile_difference(profile, ref_profile),
            "front_difference_m": _history_difference(obs.front, ref_obs.front),
            "flowing_fraction_difference": max((abs(obs.flowing[t] - ref_obs.flowing[t]) for t in common),
                                               default=math.nan),
            "final_front_m": float(profile[:, 0].max()),
            "final_height_m": float(profile[:, 1].max()),
        }
        run.error = run.details["profile_difference_m"] if run is not runs[0] else math.nan
        log(_line(run))
    _write(out_dir, "collapse", runs, "max deposit-profile difference vs finest AL run [m]")
    return runs


# --------------------------------------------------------------------------- output
def matched_ratio(runs: list[Run]) -> dict:
    """Wall-time ratio regularized/AL at matched accuracy E = max(best error of each method):
    the cheapest run of each method with error ≤ E."""
    by = {m: [r for r in runs if r.method == m and np.isfinite(r.error) and r.status != "" and
              not r.status.startswith("failed")] for m in ("regularized", "augmented_lagrangian")}
    if not by["regularized"] or not by["augmented_lagrangian"]:
        return {}
    level = max(min(r.error for r in rs) for rs in by.values())
    cheapest = {m: min((r for r in rs if r.error <= level * (1 + 1e-12)), key=lambda r: r.wall_time)
                for m, rs in by.items()}
    reg, al = cheapest["regularized"], cheapest["augmented_lagrangian"]
    return {"accuracy": level, "regularized": reg.label, "augmented_lagrangian": al.label,
            "regularized_wall": reg.wall_time, "augmented_lagrangian_wall": al.wall_time,
            "ratio_regularized_over_al": reg.wall_time / al.wall_time}


def _line(run: Run) -> str:
    extra = " ".join(f"{k}={v:.3g}" for k, v in run.details.items() if isinstance(v, float))
    return (f"{run.method:21s} {run.label:22s} wall {run.wall_time:7.1f} s  steps {run.steps:5d}  "
            f"iterations {run.iterations:6d}  LU {run.factorizations:5d}  error {run.error:.3e}  "
            f"{run.status}  {extra}")


def _write(out_dir: Path, case: str, runs: list[Run], ylabel: str) -> None:
    if MPI.COMM_WORLD.rank != 0:
        return
    out_dir.mkdir(parents=True, exist_ok=True)
    keys = sorted({k for r in runs for k in r.details})
    with open(out_dir / f"compare_{case}.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["method", "label", "wall_time_s", "steps", "iterations", "factorizations",
                    "status", "error"] + keys)
        for r in runs:
            w.writerow([r.method, r.label, f"{r.wall_time:.3f}", r.steps, r.iterations,
                        r.factorizations, r.status, f"{r.error:.6e}"] + [r.details.get(k, "") for k in keys])
    ratio = matched_ratio(runs)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for method, marker in (("regularized", "o"), ("augmented_lagrangian", "s")):
        rs = [r for r in runs if r.method == method and np.isfinite(r.error) and r.error > 0]
        ax.loglog([r.wall_time for r in rs], [r.error for r in rs], marker, label=method.replace("_", " "))
        for r in rs:
            ax.annotate(
                r.label, (r.wall_time, r.error), fontsize=7, xytext=(3, 3), textcoords="offset points"
            )
    ax.set_xlabel("wall time [s] (this machine, same run)")
    ax.set_ylabel(ylabel)
    title = f"{case}: accuracy against cost"
    if ratio:
        title += f"\nmatched accuracy {ratio['accuracy']:.2e}: regularized/AL wall-time ratio " \
                 f"{ratio['ratio_regularized_over_al']:.2f}"
    ax.set_title(title, fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(out_dir / f"compare_{case}.png", dpi=120)
    plt.close(fig)
