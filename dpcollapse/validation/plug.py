"""Validation (a) of seed 000: decelerating plug flow on a periodic inclined plane.

The 2D regularized solver (periodic layer, no slip on the bed, fixed domain) is compared
with the independent 1D non-smooth reference ``reference.plug1d``:

* relative L² error of the longitudinal velocity, ‖u_x − U‖_{L²(Ω)} / ‖U‖_{L²(Ω)}, at
  fixed times, for several ε (regularization vs discretization error);
* total Picard iterations and wall time per run;
* observed orders of convergence in space (three meshes) and in time (three Δt);
* the static/flowing interface b(t) (lowest y where |u| > 1 mm/s) and the stopping time.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse.config import Config, load_config, with_overrides
from dpcollapse.reference.plug1d import PlugFlowProblem, PlugFlowSolution, half_poiseuille, solve_plug_flow
from dpcollapse.simulation import Simulation

#: Flowing threshold of seed 000 [m/s].
THRESHOLD = 1e-3


def plug_problem(cfg: Config) -> PlugFlowProblem:
    m = cfg.material
    return PlugFlowProblem(slope_angle=math.radians(cfg.geometry.bed_angle),
                           friction_coefficient=m.mu_s, viscosity=m.viscosity,
                           density=m.density, thickness=cfg.geometry.height, gravity=m.gravity)


def reference_solution(
    cfg: Config, t_end: float, times, dt: float = 1e-4, nz: int = 2000
) -> PlugFlowSolution:
    """The 1D reference on a fine grid, stored every 5 ms and at ``times``."""
    problem = plug_problem(cfg)
    us = cfg.initial.surface_speed
    grid = np.round(np.arange(0.0, t_end + 1e-12, 5e-3), 10)
    out = np.unique(np.concatenate([grid, np.asarray(times, dtype=float)]))
    return solve_plug_flow(problem, lambda z: half_poiseuille(problem, z, us), t_end, dt, nz,
                           output_times=out, threshold=THRESHOLD)


class PlugObserver:
    """Called after each step: L² error at the compare times, interface b(t), stop time."""

    def __init__(self, sim: Simulation, reference: PlugFlowSolution, times):
        self.reference = reference
        self.times = sorted(times)
        self.errors: dict[float, float] = {}
        self.interface: list[tuple[float, float]] = []
        self.stopping_time = math.nan
        self._bind(sim)

    def _bind(self, sim: Simulation) -> None:
        flow = sim.disc.flow
        self.flow = flow
        self.U = fem.Function(flow.V, name="reference")
        u = ufl.split(flow.solution)[0]
        self._err = fem.form((u[0] - self.U[0]) ** 2 * ufl.dx)
        self._norm = fem.form(self.U[0] ** 2 * ufl.dx)
        self._y = flow.V.tabulate_dof_coordinates()[:, 1]
        self.h = sim.cfg.geometry.height

    def _interface(self, speed: np.ndarray, comm) -> float:
        """b(t): the height where the speed first exceeds the threshold going up from the
        bed, linearly interpolated between dof levels (the solution is x-independent)."""
        levels = np.concatenate(comm.allgather(np.round(self._y, 12)))
        speeds = np.concatenate(comm.allgather(speed))
        y, inverse = np.unique(levels, return_inverse=True)
        level_speed = np.zeros(len(y))
        np.maximum.at(level_speed, inverse, speeds)
        above = np.nonzero(level_speed > THRESHOLD)[0]
        if len(above) == 0:
            return self.h
        i = above[0]
        if i == 0:
            return float(y[0])
        s0, s1 = level_speed[i - 1], level_speed[i]
        return float(y[i - 1] + (THRESHOLD - s0) / (s1 - s0) * (y[i] - y[i - 1]))

    def __call__(self, sim: Simulation) -> None:
        t, dt, comm = sim.state.t, sim.cfg.time.dt, sim.comm
        speed = np.linalg.norm(self.flow.u_old.x.array.reshape(-1, 2), axis=1)
        self.interface.append((t, self._interface(speed, comm)))
        vmax = comm.allreduce(float(speed.max()) if len(speed) else 0.0, op=MPI.MAX)
        if vmax <= THRESHOLD and math.isnan(self.stopping_time):
            self.stopping_time = t
        for tc in self.times:
            if tc not in self.errors and abs(t - tc) < 0.25 * dt:
                profile = self.reference.at(tc)
                z = self.reference.z
                self.U.interpolate(lambda x: np.vstack([np.interp(x[1], z, profile), 0 * x[0]]))
                err = comm.allreduce(fem.assemble_scalar(self._err), op=MPI.SUM)
                norm = comm.allreduce(fem.assemble_scalar(self._norm), op=MPI.SUM)
                self.errors[tc] = math.sqrt(err / norm) if norm > 0 else math.sqrt(err)


@dataclass
class CaseResult:
    label: str
    epsilon: float
    mesh_size: float
    dt: float
    steps: int
    iterations: int
    wall_time: float
    errors: dict
    interface: list = field(repr=False)
    stopping_time: float = math.nan

    @property
    def mean_error(self) -> float:
        """RMS over the compare times of the relative L² errors."""
        e = np.array(list(self.errors.values()))
        return float(np.sqrt(np.mean(e**2))) if len(e) else math.nan


def run_case(cfg: Config, reference: PlugFlowSolution, times, run_dir: Path, label: str) -> CaseResult:
    """One 2D run of the plug case with its comparison to the reference."""
    sim = Simulation(cfg, run_dir, quiet=True)
    obs = PlugObserver(sim, reference, times)
    t0 = time.perf_counter()
    summary = sim.run(observers=[obs])
    wall = time.perf_counter() - t0
    its = int(np.sum(sim.iteration_counts))
    return CaseResult(label, cfg.numerics.epsilon, cfg.geometry.mesh_size, cfg.time.dt,
                      summary["steps"], its, wall, dict(obs.errors), obs.interface,
                      obs.stopping_time)


def observed_order(sizes, errors) -> float:
    """Least-squares slope of log(error) against log(size)."""
    sizes, errors = np.asarray(sizes, float), np.asarray(errors, float)
    return float(np.polyfit(np.log(sizes), np.log(errors), 1)[0])


@dataclass
class PlugPlan:
    """What a validation run sweeps. The ε sweep runs at the config's mesh size and Δt to
    the config's end time; the order studies to ``space_end_time`` and ``time_end_time``."""

    epsilons: list
    mesh_sizes: list          # space order, at Δt = space_dt, to space_end_time
    dts: list                 # time order, on the mesh time_mesh, to time_end_time
    space_dt: float
    time_mesh: float
    space_end_time: float
    time_end_time: float
    times: list
    reference_dt: float
    reference_nz: int


# Orders are measured where the refined parameter dominates the error: P2 resolves the
# smooth profile so well that the space study needs small Δt and coarse meshes.
FULL = PlugPlan(epsilons=[1e-2, 1e-4, 1e-6, 1e-8], mesh_sizes=[0.02, 0.01, 0.005],
                dts=[4e-3, 2e-3, 1e-3], space_dt=2.5e-4, time_mesh=0.005, space_end_time=0.8,
                time_end_time=0.4, times=[0.2, 0.4, 0.6, 0.8], reference_dt=5e-5, reference_nz=4000)
QUICK = PlugPlan(epsilons=[1e-2, 1e-6], mesh_sizes=[0.02, 0.01, 0.005],
                 dts=[8e-3, 4e-3, 2e-3], space_dt=1e-3, time_mesh=0.005, space_end_time=0.8,
                 time_end_time=0.4, times=[0.2, 0.4, 0.6, 0.8], reference_dt=1e-4, reference_nz=2000)


def _cfg(base: Config, eps: float, mesh: float, dt: float, end_time: float | None = None) -> Config:
    extra = [f"time.end_time={end_time!r}"] if end_time else []
    return with_overrides(base, [f"numerics.epsilon={eps!r}", f"geometry.mesh_size={mesh!r}",
                                 f"time.dt={dt!r}", f"time.dt_min={min(dt, 1e-6)!r}",
                                 "time.output_every=100000", "time.checkpoint_every=100000"] + extra)


def validate_plug(config: Path, out_dir: Path, quick: bool = False, log=print) -> dict:
    """Run the ε, space and time sweeps; write ``plug.csv`` and ``plug.png``; return results."""
    plan = QUICK if quick else FULL
    base = load_config(config)
    t_end = base.time.end_time
    t0 = time.perf_counter()
    reference = reference_solution(base, t_end, plan.times, plan.reference_dt, plan.reference_nz)
    ref_time = time.perf_counter() - t0
    log(f"1D reference: nz = {plan.reference_nz}, dt = {plan.reference_dt:g} s, stop at "
        f"{reference.stopping_time:.4f} s, exact arrest {reference.arrest_time:.4f} s ({ref_time:.1f} s)")
    out_dir = Path(out_dir)
    h0, dt0 = base.geometry.mesh_size, base.time.dt
    results = {"epsilon": [], "space": [], "time": []}
    for eps in plan.epsilons:
        mesh, dt = (plan.time_mesh, plan.dts[-1]) if quick else (h0, dt0)
        r = run_case(
            _cfg(base, eps, mesh, dt), reference, plan.times, out_dir / f"eps_{eps:g}", f"eps={eps:g}"
        )
        results["epsilon"].append(r)
        log(_row(r))
    eps_conv = 1e-6
    for mesh in plan.mesh_sizes:
        r = run_case(_cfg(base, eps_conv, mesh, plan.space_dt, plan.space_end_time), reference, plan.times,
                     out_dir / f"mesh_{mesh:g}", f"dx={mesh:g}")
        results["space"].append(r)
        log(_row(r))
    for dt in plan.dts:
        r = run_case(_cfg(base, eps_conv, plan.time_mesh, dt, plan.time_end_time), reference, plan.times,
                     out_dir / f"dt_{dt:g}", f"dt={dt:g}")
        results["time"].append(r)
        log(_row(r))
    orders = {
        "space": observed_order(
            [r.mesh_size for r in results["space"]], [r.mean_error for r in results["space"]]
        ),
        "time": observed_order([r.dt for r in results["time"]], [r.mean_error for r in results["time"]]),
    }
    log(f"observed order: space {orders['space']:.2f}, time {orders['time']:.2f}")
    if MPI.COMM_WORLD.rank == 0:
        _write_csv(out_dir / "plug.csv", results)
        _plot(out_dir / "plug.png", results, reference, plan, orders)
    return {"results": results, "orders": orders, "reference": reference}


def _row(r: CaseResult) -> str:
    errs = "  ".join(f"{e:.2e}" for e in r.errors.values())
    return (f"{r.label:>12}  ε={r.epsilon:.0e} dx={r.mesh_size:.4g} m dt={r.dt:.1e} s  "
            f"steps {r.steps:5d}  iterations {r.iterations:6d}  wall {r.wall_time:6.1f} s  "
            f"stop {r.stopping_time:.4f} s  rel. L2 error at t = {list(r.errors)}: {errs}")


def _write_csv(path: Path, results: dict) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    times = sorted({t for rs in results.values() for r in rs for t in r.errors})
    with path.open("w") as f:
        f.write("sweep,label,epsilon,mesh_size,dt,steps,iterations,wall_time,stopping_time,mean_error,"
                + ",".join(f"error_t{t:g}" for t in times) + "\n")
        for sweep, rs in results.items():
            for r in rs:
                f.write(f"{sweep},{r.label},{r.epsilon:g},{r.mesh_size:g},{r.dt:g},{r.steps},{r.iterations},"
                        f"{r.wall_time:.3f},{r.stopping_time:.5f},{r.mean_error:.4e},"
                        + ",".join(f"{r.errors.get(t, math.nan):.4e}" for t in times) + "\n")


def _plot(path: Path, results: dict, reference: PlugFlowSolution, plan: PlugPlan, orders: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 2, figsize=(11, 8.5))
    rs = results["epsilon"]
    for t in plan.times:
        ax[0, 0].loglog(
            [r.epsilon for r in rs], [r.errors.get(t, math.nan) for r in rs], "o-", label=f"t = {t:g} s"
        )
    ax[0, 0].set_xlabel("ε [1/s]")
    ax[0, 0].set_ylabel("relative L² error of u_x")
    ax[0, 0].set_title("Error against the 1D reference vs ε")
    ax[0, 0].legend(fontsize=8)
    ax[0, 0].grid(alpha=0.3, which="both")
    for key, attr, axis in (("space", "mesh_size", ax[0, 1]), ("time", "dt", ax[1, 0])):
        xs = [getattr(r, attr) for r in results[key]]
        es = [r.mean_error for r in results[key]]
        axis.loglog(xs, es, "o-", label=f"measured (order {orders[key]:.2f})")
        axis.loglog(xs, es[-1] * (np.array(xs) / xs[-1]), "k--", lw=1, label="order 1")
        axis.set_xlabel("ΔX [m]" if key == "space" else "Δt [s]")
        axis.set_ylabel("RMS over times of relative L² error")
        axis.set_title(f"Convergence in {key} (ε = 1e-6)")
        axis.legend(fontsize=8)
        axis.grid(alpha=0.3, which="both")
    a = ax[1, 1]
    a.plot(reference.times, reference.interface, "k-", lw=2, label="1D reference (|U| > 1 mm/s)")
    a.plot(reference.times, reference.static_interface, "k:", lw=1, label="1D exact static layer")
    for r in rs:
        t, b = np.array(r.interface).T
        a.plot(t, b, label=f"2D, {r.label}")
    a.set_xlabel("t [s]")
    a.set_ylabel("b(t) [m]")
    a.set_title("Static/flowing interface")
    a.legend(fontsize=8)
    a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
