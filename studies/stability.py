"""Where each method works: ``python -m studies stability SCENE [--quick]``.

Sweeps method (Picard, Picard + Anderson, Newton, augmented Lagrangian) × ε × Δt × ΔX on
a scene with a reference and classifies every run:

* ``accurate``  — converged, error ≤ ``tolerance`` against the reference;
* ``wrong``     — converged, error > ``tolerance`` (regularization error at large ε, the
  fixed-point tolerance floor, a coarse Δt or ΔX);
* ``failed``    — the run ended with an error: its exit code and the reason (3: no
  convergence at time.dt_min; 4: mesh degenerate or energy guard);
* ``too_slow``  — stopped at the cost cap: CPU time of the run > ``cap`` seconds (process
  time, so that the class does not depend on how many other jobs share the machine).

Scenes: ``plug`` (``configs/plug.yaml``; error = RMS over the compare times ≤ end time of
the relative L² error of u_x against the 1D non-smooth reference ``reference.plug1d``) and
``rigid`` (``configs/rigid.yaml``; error = max over the compare times of |x_f − x_f,ref| [m],
the front interpolated between the steps that bracket each compare time, against a
reference run — ``Plan.reference_*``, the finest of the plan — run first and kept in
``reference_rigid.json``). The augmented Lagrangian has no ε: it is run once per (Δt, ΔX)
and its class is drawn in every ε column.

Per run besides the class: iterations, factorizations, Newton's Picard fallbacks, halved
steps, steps shorter than Δt (halving or the mesh-motion limit) and the largest cell and
bulk Courant numbers. Writes ``stability_SCENE.csv`` and ``stability_SCENE.png`` (one panel
per method, Δt against ε, a mark per class, ΔX as marker size, a run that needed Newton
fallbacks drawn open with their number). The runs are in-process (the error needs an
observer of the running simulation), one after another.
"""

from __future__ import annotations

import csv
import json
import math
import time
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from dpcollapse.config import load_config, with_overrides
from dpcollapse.errors import DpcollapseError, Interrupted

#: numerics overrides of each method.
METHODS = {
    "picard": [
        "numerics.method=regularized",
        "numerics.nonlinear_solver=picard",
        "numerics.anderson_depth=0",
    ],
    "picard+anderson": [
        "numerics.method=regularized",
        "numerics.nonlinear_solver=picard",
        "numerics.anderson_depth=5",
    ],
    "newton": ["numerics.method=regularized", "numerics.nonlinear_solver=newton"],
    "augmented_lagrangian": ["numerics.method=augmented_lagrangian"],
}
CLASSES = ("accurate", "wrong", "failed", "too_slow")


@dataclass
class Plan:
    """What one map sweeps, and what counts as accurate and as too slow."""

    methods: list
    epsilons: list
    dts: list
    mesh_sizes: list
    end_time: float
    times: list              # compare times [s] (empty: the end time)
    tolerance: float         # plug: relative L² error; rigid: front difference [m]
    cap: float               # CPU seconds per run
    overrides: list = field(default_factory=list)   # fixed overrides of every run
    # rigid: the reference run; None: the finest Δt / ΔX of the plan
    reference_method: str = "augmented_lagrangian"
    reference_epsilon: float = 1e-6     # ε = ε_f of a regularized reference
    reference_dt: float | None = None
    reference_mesh_size: float | None = None
    reference_overrides: list = field(default_factory=list)


PLANS = {
    # t = 0.8 s: the static layer has grown from the bed (from 0.58 s); at ΔX 1 cm, Δt 4 ms
    # the discretization error there is 1.6e-2 (measured), the regularization error of
    # ε = 1e-1 6e-2
    ("plug", True): Plan(methods=list(METHODS), epsilons=[1e-1, 1e-6], dts=[4e-3], mesh_sizes=[0.01],
                         end_time=0.8, times=[], tolerance=3e-2, cap=15.0,
                         overrides=["time.dt_min=1e-4"]),
    ("plug", False): Plan(methods=list(METHODS), epsilons=[1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8],
                          dts=[2.5e-4, 5e-4, 1e-3, 2e-3, 4e-3, 8e-3], mesh_sizes=[0.02, 0.01, 0.005],
                          end_time=0.8, times=[0.2, 0.4, 0.6, 0.8], tolerance=1e-2, cap=600.0),
    # rigid: error = max over the compare times of |x_f − x_f,ref| [m]; tolerance 1 cm, the
    # reference's own mesh size: a front within one reference cell of the reference's (4 %
    # of the front's travel to 0.4 s, 0.27 m).
    # The reference is the finest run: configs/rigid.yaml as it is (Picard + Anderson,
    # ε = ε_f = 1e-6, ΔX 1 cm, Δt 1 ms, nonlinear_rtol 1e-3). A tighter one did not run at
    # 1 cm: with nonlinear_rtol 1e-4 both Picard + Anderson (residual floor ≈ 5e-3) and the
    # augmented Lagrangian hit the iteration cap on the first step at every Δt from 1 ms
    # down to 63–79 µs (measured 2026-12-02).
    # quick: to 0.2 s on the 4 cm mesh against the augmented Lagrangian at 4 cm, Δt 0.5 ms,
    # rtol 1e-4 (a harness check: ΔX is not resolved, the tolerance is the same 1 cm)
    ("rigid", True): Plan(methods=list(METHODS), epsilons=[1e-2, 1e-6], dts=[1e-3], mesh_sizes=[0.04],
                          end_time=0.2, times=[0.1, 0.2], tolerance=0.01, cap=60.0,
                          reference_dt=5e-4, reference_mesh_size=0.04,
                          reference_overrides=["numerics.nonlinear_rtol=1e-4"]),
    ("rigid", False): Plan(methods=list(METHODS), epsilons=[1e-2, 1e-4, 1e-6],
                           dts=[1e-3, 4e-3], mesh_sizes=[0.04, 0.02],
                           end_time=0.4, times=[0.1, 0.2, 0.4], tolerance=0.01, cap=120.0,
                           reference_method="picard+anderson", reference_dt=1e-3, reference_mesh_size=0.01),
}


@dataclass
class Cell:
    """One run of the map."""

    scene: str
    method: str
    epsilon: float
    dt: float
    mesh_size: float
    cls: str = ""
    exit_code: int = 0
    reason: str = ""
    steps: int = 0
    iterations: int = 0
    factorizations: int = 0
    wall_time: float = math.nan
    error: float = math.nan
    # the three counts: -1 in a row read from a CSV written before they were recorded
    fallbacks: int = 0          # step attempts Newton failed and Picard redid (newton only)
    halvings: int = 0           # step attempts that failed and were retried with Δt/2
    short_steps: int = 0        # accepted steps shorter than Δt (halving, mesh-motion limit)
    max_courant: float = math.nan   # max over the steps of Δt·max_K |uⁿ|/h_K (h_K: shortest edge)
    courant_dx: float = math.nan    # max over the steps of Δt·max |u|/ΔX (ΔX: geometry.mesh_size)


class _Watch:
    """Observer: records the compare quantity at the compare times and stops at the cap."""

    def __init__(self, sim, scene: str, times, cap: float, reference=None):
        self.scene, self.times, self.cap = scene, list(times), cap
        self.t0 = time.process_time()
        self.too_slow = False
        self.max_courant = 0.0
        self.courant_dx = 0.0
        self.mesh_size = sim.cfg.geometry.mesh_size
        self.short_steps = 0
        self.dt = sim.cfg.time.dt
        self.end_time = sim.cfg.time.end_time
        self.values: dict[float, float] = {}
        self.plug = None
        if scene == "plug":
            from dpcollapse.validation.plug import PlugObserver

            self.plug = PlugObserver(sim, reference, times)
        else:
            self.values["front0"] = sim.disc.measures()["front"]
            self._last = (sim.state.t, self.values["front0"])

    def step_accepted(self, sim, row: dict) -> None:
        """``step_accepted`` subscriber: the bulk Courant number of the step, from its row."""
        self.courant_dx = max(self.courant_dx, row["dt"] * row["max_speed"] / self.mesh_size)

    def __call__(self, sim) -> bool:
        self.max_courant = max(self.max_courant, sim.courant)
        dt = sim.step_sizes[-1]
        if dt < self.dt * (1 - 1e-9) and sim.state.t < self.end_time - 1e-12:
            self.short_steps += 1
        if self.plug is not None:
            self.plug(sim)
            self.values = self.plug.errors
        else:
            now = (sim.state.t, sim.disc.measures()["front"])
            for tc in self.times:
                if tc not in self.values and now[0] >= tc - 1e-9:
                    self.values[tc] = interpolate(self._last, now, tc)
            self._last = now
        if time.process_time() - self.t0 > self.cap:
            self.too_slow = True
            return True
        return False


def interpolate(before: tuple, after: tuple, tc: float) -> float:
    """The front at the compare time tc, linear between the steps (t, x_f) that bracket it
    (a step of Δt = 4 ms at 1 m/s would otherwise add up to 4 mm of timing to the error)."""
    (t0, x0), (t1, x1) = before, after
    return x1 if t1 <= t0 else x0 + (x1 - x0) * min(max((tc - t0) / (t1 - t0), 0.0), 1.0)


def fronts_from_diagnostics(path: Path, times, front0: float) -> dict:
    """The rigid compare values of a finished run from its diagnostics.csv (as ``_Watch``)."""
    values, last = {"front0": front0}, (0.0, front0)
    with Path(path).open() as f:
        for row in csv.DictReader(f):
            now = (float(row["t"]), float(row["front"]))
            for tc in times:
                if tc not in values and now[0] >= tc - 1e-9:
                    values[tc] = interpolate(last, now, tc)
            last = now
    return values


def _config(base, scene: str, cell: Cell, plan: Plan, extra=()):
    # a map over fixed steps Δt, with methods that refuse bdf2: BDF1 at the cell's Δt
    # (configs/rigid.yaml's own error-controlled BDF2 step is not one of its cells)
    over = list(METHODS[cell.method]) + ["time.scheme=bdf1", "time.tolerance=null",
        f"numerics.epsilon={cell.epsilon!r}", f"time.dt={cell.dt!r}", f"time.dt_min={min(cell.dt, 1e-6)!r}",
        f"geometry.mesh_size={cell.mesh_size!r}", f"time.end_time={plan.end_time!r}",
        "time.output_every=1000000", "time.checkpoint_every=1000000"] + list(plan.overrides) + list(extra)
    if scene == "rigid":
        over.append(f"numerics.epsilon_friction={cell.epsilon!r}")
    return with_overrides(base, over)


def run_name(cell: Cell) -> str:
    """The run directory of a cell under out/runs (the augmented Lagrangian's ε: 1e-6)."""
    eps = 1e-6 if math.isnan(cell.epsilon) else cell.epsilon
    return f"{cell.method}_eps{eps:g}_dt{cell.dt:g}_dx{cell.mesh_size:g}"


def run_cell(
    base, scene: str, cell: Cell, plan: Plan, out: Path, reference=None, extra=()
) -> tuple[Cell, dict]:
    """Run one cell; fills its counts, class-independent fields and returns the compare values."""
    from dpcollapse.simulation import Simulation

    cfg = _config(base, scene, cell, plan, extra)
    sim = Simulation(cfg, out / "runs" / run_name(cell), quiet=True)
    watch = _Watch(sim, scene, plan.times, plan.cap, reference)
    sim.events.subscribe("step_accepted", watch.step_accepted)
    t0 = time.perf_counter()
    try:
        summary = sim.run(observers=[watch])
        cell.factorizations = int(summary["flow_factorizations"])
        cell.cls = "too_slow" if watch.too_slow else ""
        if watch.too_slow:
            cell.reason = f"CPU time over {plan.cap:g} s at t = {sim.state.t:.3f} s"
    except Interrupted:
        raise                      # Ctrl-C / SIGTERM ends the whole map, not one cell
    except DpcollapseError as exc:
        cell.cls, cell.exit_code = "failed", exc.exit_code
        cell.reason = " ".join(str(exc).split())[:160]
        cell.factorizations = sim.solver_counts()["flow_factorizations"]
    cell.wall_time = time.perf_counter() - t0
    cell.fallbacks = sim.solver_counts()["newton_fallbacks"]
    cell.halvings = sim.halvings
    cell.short_steps = watch.short_steps
    cell.max_courant = watch.max_courant
    cell.courant_dx = watch.courant_dx
    cell.steps = int(sim.state.step)
    cell.iterations = int(np.sum(sim.iteration_counts))
    return cell, dict(watch.values)


def classify(cell: Cell, error: float, tolerance: float) -> Cell:
    """accurate / wrong for a run that finished (failed and too_slow are set by the run)."""
    cell.error = error
    if not cell.cls:
        cell.cls = "accurate" if error <= tolerance else "wrong"
    return cell


def _plug_error(values: dict, times) -> float:
    e = [values[t] for t in times if t in values]
    return float(np.sqrt(np.mean(np.square(e)))) if len(e) == len(times) else math.nan


def _rigid_error(values: dict, reference: dict, times) -> float:
    """max_t |x_f(t) − x_f,ref(t)| [m] over the compare times."""
    if any(t not in values for t in times):
        return math.nan
    return max(abs(values[t] - reference[t]) for t in times)


def rigid_reference(base, config: Path, plan: Plan, out: Path, log=print) -> dict:
    """Front positions of the rigid reference run at the compare times. Kept in
    ``out/reference_rigid.json`` with its settings and reused by a later map into the same
    directory whose reference settings are the same (e.g. a Δt sweep on one mesh)."""
    dt = plan.reference_dt or min(plan.dts)
    dx = plan.reference_mesh_size or min(plan.mesh_sizes)
    settings = {"config": str(Path(config).resolve()), "method": plan.reference_method,
                "epsilon": plan.reference_epsilon, "dt": dt, "mesh_size": dx, "end_time": plan.end_time,
                "overrides": list(plan.overrides) + list(plan.reference_overrides)}
    path = Path(out) / "reference_rigid.json"
    if path.is_file():
        stored = json.loads(path.read_text())
        if stored["settings"] == settings and all(str(t) in stored["front"] for t in plan.times):
            log(f"reference from {path}: front {[round(stored['front'][str(t)], 5) for t in plan.times]} m")
            return {"front0": stored["front"]["front0"], **{t: stored["front"][str(t)] for t in plan.times}}
    ref_cell = Cell("rigid", plan.reference_method, plan.reference_epsilon, dt, dx)
    ref_plan = replace(plan, cap=math.inf)
    ref_cell, values = run_cell(base, "rigid", ref_cell, ref_plan, out, extra=plan.reference_overrides)
    if ref_cell.cls == "failed" or any(t not in values for t in plan.times):
        raise DpcollapseError(f"the rigid reference run failed: {ref_cell.reason}")
    path.write_text(json.dumps({"settings": settings, "front": {str(k): v for k, v in values.items()},
                                "wall_time": ref_cell.wall_time, "steps": ref_cell.steps,
                                "factorizations": ref_cell.factorizations}, indent=1))
    log(
        f"reference ({plan.reference_method}, dt {dt:g} s, dx {dx:g} m, "
        f"{' '.join(plan.reference_overrides)}): "
        f"front {[round(values[t], 5) for t in plan.times]} m, {ref_cell.wall_time:.1f} s"
    )
    return dict(values)


def _key(c: Cell) -> tuple:
    return (c.method, "nan" if math.isnan(c.epsilon) else c.epsilon, c.dt, c.mesh_size)


def rescore_rigid(out: Path, plan: Plan) -> list[Cell]:
    """Recompute the errors, classes and bulk Courant numbers of a rigid map in ``out`` from
    its runs' diagnostics.csv (a new tolerance or compare times without running again; the
    reference's front values are rewritten too). Failed and too-slow cells keep their class."""
    out = Path(out)
    path = out / "reference_rigid.json"
    stored = json.loads(path.read_text())
    ref = stored["settings"]
    ref_cell = Cell("rigid", ref["method"], ref["epsilon"], ref["dt"], ref["mesh_size"])
    front0 = stored["front"]["front0"]
    reference = fronts_from_diagnostics(
        out / "runs" / run_name(ref_cell) / "diagnostics.csv", plan.times, front0
    )
    stored["front"] = {str(k): v for k, v in reference.items()}
    path.write_text(json.dumps(stored, indent=1))
    cells = read_csv(out / "stability_rigid.csv")
    for cell in cells:
        diagnostics = out / "runs" / run_name(cell) / "diagnostics.csv"
        values = fronts_from_diagnostics(diagnostics, plan.times, front0)
        with diagnostics.open() as f:
            cell.courant_dx = max((float(r["dt"]) * float(r["max_speed"]) / cell.mesh_size
                                   for r in csv.DictReader(f)), default=math.nan)
        if cell.cls in ("accurate", "wrong"):
            cell.cls = ""
        classify(cell, _rigid_error(values, reference, plan.times), plan.tolerance)
    write_csv(out / "stability_rigid.csv", cells)
    plot(out / "stability_rigid.png", cells, plan, "rigid")
    return cells


def stability_map(scene: str, config: Path, out: Path, quick: bool = False, plan: Plan | None = None,
                  log=print, append: bool = False) -> list[Cell]:
    """Run the map of ``scene``; write stability_SCENE.csv and .png into ``out``. With
    ``append``, the rows of an existing stability_SCENE.csv there are kept (a cell run again
    replaces its row) and the picture shows them all: a map extended run by run."""
    plan = plan or PLANS[(scene, quick)]
    plan = replace(plan, times=list(plan.times) or [plan.end_time])
    base = load_config(config)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    reference = None
    if scene == "plug":
        from dpcollapse.validation.plug import reference_solution

        reference = reference_solution(base, max(plan.end_time, max(plan.times)), plan.times)
    else:
        reference = rigid_reference(base, config, plan, out, log)
    csv_path = out / f"stability_{scene}.csv"
    cells = read_csv(csv_path) if append and csv_path.is_file() else []
    for method in plan.methods:
        epsilons = [math.nan] if method == "augmented_lagrangian" else plan.epsilons
        for eps in epsilons:
            for dt in plan.dts:
                for dx in plan.mesh_sizes:
                    cell = Cell(scene, method, 1e-6 if math.isnan(eps) else eps, dt, dx)
                    cell, values = run_cell(base, scene, cell, plan, out, reference)
                    if math.isnan(eps):
                        cell.epsilon = math.nan
                    error = (_plug_error(values, plan.times) if scene == "plug"
                             else _rigid_error(values, reference, plan.times))
                    classify(cell, error, plan.tolerance)
                    cells = [c for c in cells if _key(c) != _key(cell)] + [cell]
                    log(_row(cell))
                    write_csv(csv_path, cells)
    plot(out / f"stability_{scene}.png", cells, plan, scene)
    return cells


def _row(c: Cell) -> str:
    eps = "-" if math.isnan(c.epsilon) else f"{c.epsilon:.0e}"
    return (
        f"{c.method:21s} eps {eps:>6s} dt {c.dt:.2e} dx {c.mesh_size:.3g}  {c.cls:9s} "
        f"error {c.error:.2e}  steps {c.steps:5d} its {c.iterations:6d} LU {c.factorizations:6d} "
        f"wall {c.wall_time:7.1f} s  fallbacks {c.fallbacks} halved {c.halvings} short {c.short_steps} "
        f"Courant {c.max_courant:.2g} (bulk {c.courant_dx:.2g})  "
        f"{(f'exit {c.exit_code}: ' + c.reason) if c.exit_code else c.reason}"
    )


COLUMNS = ["scene", "method", "epsilon", "dt", "mesh_size", "cls", "exit_code", "reason", "steps",
           "iterations", "factorizations", "wall_time", "error", "fallbacks", "halvings", "short_steps",
           "max_courant", "courant_dx"]


def write_csv(path: Path, cells: list[Cell]) -> None:
    with Path(path).open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow([("class" if c == "cls" else c) for c in COLUMNS])
        for cell in cells:
            d = asdict(cell)
            w.writerow([f"{d[c]:.4g}" if isinstance(d[c], float) else d[c] for c in COLUMNS])


MARKS = {"accurate": ("o", "tab:green"), "wrong": ("^", "tab:orange"), "failed": ("X", "tab:red"),
         "too_slow": ("D", "tab:gray")}


def read_csv(path: Path) -> list[Cell]:
    """The cells of a ``stability_SCENE.csv`` (e.g. to redraw the map of a partial run)."""
    cells = []
    with Path(path).open() as f:
        for row in csv.DictReader(f):
            cells.append(Cell(row["scene"], row["method"], float(row["epsilon"]), float(row["dt"]),
                              float(row["mesh_size"]), row["class"], int(row["exit_code"]), row["reason"],
                              int(row["steps"]), int(row["iterations"]), int(row["factorizations"]),
                              float(row["wall_time"]), float(row["error"]),
                              # columns added later: a CSV written before them reads as -1
                              # (not recorded) / NaN
                              int(row.get("fallbacks") or -1), int(row.get("halvings") or -1),
                              int(row.get("short_steps") or -1), float(row.get("max_courant") or math.nan),
                              float(row.get("courant_dx") or math.nan)))
    return cells


def plot(path: Path, cells: list[Cell], plan: Plan, scene: str) -> None:
    """One panel per method: Δt (y) against ε (x), a mark per class, ΔX as marker size (and
    a small sideways offset, finest on the left)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker
    from matplotlib.lines import Line2D

    methods = [m for m in dict.fromkeys(list(plan.methods) + [c.method for c in cells])
               if any(c.method == m for c in cells)]
    fig, axes = plt.subplots(
        1, len(methods), figsize=(3.6 * len(methods) + 1, 3.9), sharey=True, squeeze=False
    )
    sizes = sorted(set(plan.mesh_sizes) | {c.mesh_size for c in cells})
    eps_all = sorted(set(plan.epsilons) | {c.epsilon for c in cells if not math.isnan(c.epsilon)})
    dts = sorted(set(plan.dts) | {c.dt for c in cells})
    for ax, method in zip(axes[0], methods):
        for c in (c for c in cells if c.method == method):
            marker, color = MARKS[c.cls]
            k = sizes.index(c.mesh_size)
            offset = 1.8 ** (k - (len(sizes) - 1) / 2)
            xs = eps_all if math.isnan(c.epsilon) else [c.epsilon]
            for x in xs:
                if c.fallbacks > 0:    # Newton alone did not carry the run: open mark + count
                    ax.scatter([x * offset], [c.dt * 1e3], marker=marker, facecolor="none",
                               edgecolor=color, s=25 + 45 * k, linewidth=1.6, zorder=3)
                    ax.annotate(str(c.fallbacks), (x * offset, c.dt * 1e3), xytext=(3, 3),
                                textcoords="offset points", fontsize=6, color="k", zorder=4)
                else:
                    ax.scatter([x * offset], [c.dt * 1e3], marker=marker, color=color,
                               s=25 + 45 * k, edgecolor="k", linewidth=0.4, zorder=3)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlim(min(eps_all) / 3, max(eps_all) * 3)
        ax.set_xticks(eps_all)
        ax.set_xticklabels([f"{e:.0e}" for e in eps_all], fontsize=7)
        ax.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.set_ylim(min(dts) * 1e3 / 1.6, max(dts) * 1e3 * 1.6)
        ax.set_title(method + (" (no ε: same in every column)" if method == "augmented_lagrangian" else ""),
                     fontsize=9)
        ax.set_yticks([d * 1e3 for d in dts])
        ax.set_yticklabels([f"{d * 1e3:g}" for d in dts])
        ax.yaxis.set_minor_locator(matplotlib.ticker.NullLocator())
        ax.set_xlabel("ε [1/s]" if scene == "plug" else "ε [1/s] = ε_f [m/s]")
        ax.grid(alpha=0.3, which="major")
    axes[0, 0].set_ylabel("Δt [ms]")
    handles = [Line2D([], [], marker=m, color=col, linestyle="", markeredgecolor="k", label=name)
               for name, (m, col) in MARKS.items()]
    if any(c.fallbacks > 0 for c in cells):
        handles.append(Line2D([], [], marker="o", color="w", markerfacecolor="none", markeredgecolor="k",
                              markeredgewidth=1.6, label="open: Newton fell back\nto Picard (number)"))
    handles += [Line2D([], [], marker="o", color="w", markeredgecolor="k", markersize=(25 + 45 * k) ** 0.5,
                       label=f"ΔX = {s * 100:g} cm") for k, s in enumerate(sizes)]
    what = ("relative L² error of u_x vs the 1D reference" if scene == "plug"
            else "max |front − reference front| [m]")
    fig.suptitle(f"{scene}: t ≤ {plan.end_time:g} s; accurate = {what} ≤ {plan.tolerance:g}; "
                 f"too slow > {plan.cap:g} CPU s", fontsize=9)
    fig.legend(handles=handles, loc="center right", fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 1 - 1.8 / (3.6 * len(methods) + 1), 0.95))
    fig.savefig(path, dpi=110)
    plt.close(fig)
