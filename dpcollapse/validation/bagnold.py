"""Validation of the μ(I) rheology: the steady Bagnold flow of a layer down a slope.

A periodic layer (no slip on the bed, stress-free surface, fixed domain) starts from rest and
accelerates (μ_s < tanθ < μ_2) to the steady profile of ``reference.bagnold``::

    u(y) = (2/3)(I_θ/d) √(g cosθ ρ/ρ_s) [h^{3/2} − (h − y)^{3/2}],
    I_θ = I0 (tanθ − μ_s)/(μ_2 − tanθ).

For each mesh (n cells across the layer) the run stops when the flow is steady: the
velocity is compared every ``window`` seconds with the previous comparison; with Δ_k the
relative RMS change over window k and r = Δ_k/Δ_{k−1} its contraction, the remaining
distance to the steady state is Δ_k r/(1 − r) (the tail of a geometric series, the same
estimate as the Picard stopping test); steady when it is ≤ ``steady_tol``. Reported per run:

* the relative L² error ‖u_x − U‖_{L²(Ω)}/‖U‖_{L²(Ω)} of the steady state against the
  analytic profile U (built from ``bagnold_velocity``'s constants and integrated exactly
  enough: quadrature degree 10, U is not interpolated), and the relative error of the
  surface speed;
* the time to steady state and the e-folding time of the approach, −window/ln r;
* wall time, steps and Picard iterations (total);
* the inertial number I of the steady solution per cell (DG0: at the centroid) and the
  area fraction of the cells whose I lies outside the well-posed window (Barker et al. 2015);
  the analytic I is uniform, I_θ, but at the free surface p → 0 while the discrete γ̇ does
  not vanish, so the discrete I = d γ̇/√(p/ρ_s) blows up there: I on the surface and the
  thickness of the ill-posed layer under it (I sampled at points approaching every cell edge,
  barycentric distances 1e-9 ... 0.3) are reported too.

The observed order of convergence is the least-squares slope of log(error) against
log(mesh size) over the runs at the config's ε.
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

from dpcollapse import compat
from dpcollapse.config import Config, load_config, with_overrides
from dpcollapse.errors import ConfigError
from dpcollapse.models.stokes.discretization import rheology
from dpcollapse.reference.bagnold import (
    bagnold_inertial_number,
    bagnold_shear_rate,
    bagnold_surface_velocity,
    bagnold_velocity,
)
from dpcollapse.rheology.mu_i import MuI
from dpcollapse.rheology.wellposedness import criterion, fraction_ill_posed, well_posed_window
from dpcollapse.simulation import Simulation
from dpcollapse.validation.plug import observed_order

#: Quadrature degree of the error integrals (U is not a polynomial).
QUADRATURE_DEGREE = 10


def _law(cfg: Config) -> MuI:
    """The config's μ(I) law; ConfigError unless the config describes a Bagnold flow."""
    if cfg.material.rheology != "mu_i":
        raise ConfigError(f"material.rheology = {cfg.material.rheology}: "
                          "validate bagnold needs mu_i")
    law = rheology(cfg)
    if cfg.geometry.shape != "layer" or cfg.boundary.bed_condition != "no_slip":
        raise ConfigError(f"geometry.shape = {cfg.geometry.shape}, boundary.bed_condition = "
                          f"{cfg.boundary.bed_condition}: validate bagnold needs layer and no_slip")
    try:
        bagnold_inertial_number(law, math.radians(cfg.geometry.bed_angle))
    except ValueError as exc:
        key = ("material.cohesion", cfg.material.cohesion) if cfg.material.cohesion > 0 else \
            ("geometry.bed_angle", cfg.geometry.bed_angle)
        raise ConfigError(f"{key[0]} = {key[1]:g}: {exc}") from None
    return law


def analytic_profile(cfg: Config):
    """(U(y) as UFL of y, u_s, I_θ): the Bagnold profile of ``cfg``'s law, slope, h, ρ, g.

    U(y) = u_s − (2/3) γ̇(0)/√h (h − y)^{3/2}, with u_s and γ̇(0) taken from
    ``reference.bagnold`` (checked against ``bagnold_velocity`` at a few heights)."""
    law, m = _law(cfg), cfg.material
    theta, h = math.radians(cfg.geometry.bed_angle), cfg.geometry.height
    us = bagnold_surface_velocity(law, theta, h, m.density, m.gravity)
    prefactor = bagnold_shear_rate(law, theta, h, 0.0, m.density, m.gravity) / math.sqrt(h)
    ys = np.linspace(0.0, h, 7)
    mine = us - (2.0 / 3.0) * prefactor * (h - ys) ** 1.5
    ref = bagnold_velocity(law, theta, h, ys, m.density, m.gravity)
    if not np.allclose(mine, ref, rtol=1e-12, atol=1e-12 * us):
        raise RuntimeError("the UFL Bagnold profile disagrees with reference.bagnold_velocity")

    def U(y):
        return us - (2.0 / 3.0) * prefactor * ufl.max_value(h - y, 0.0) ** 1.5

    return U, us, bagnold_inertial_number(law, theta)


class SteadyObserver:
    """Stops the run (returns True) when the estimated distance to the steady state is
    ≤ ``tol`` (relative RMS of the velocity dofs); records the history of the approach."""

    def __init__(self, sim: Simulation, window: float, tol: float):
        self.window, self.tol = window, tol
        flow = self.flow = sim.disc.flow
        self.comm = sim.comm
        U, self.us, _ = analytic_profile(sim.cfg)
        y = ufl.SpatialCoordinate(flow.mesh)[1]
        u = ufl.split(flow.solution)[0]
        dx = ufl.dx(metadata={"quadrature_degree": QUADRATURE_DEGREE})
        self._err = fem.form((u[0] - U(y)) ** 2 * dx)
        self._norm = fem.form(U(y) ** 2 * dx)
        n_owned = flow.V.dofmap.index_map.size_local * flow.V.dofmap.index_map_bs
        self._n_owned = n_owned
        self._snapshot = None
        self._next = window
        self._previous_change = math.nan
        self.history: list[tuple[float, float, float, float]] = []  # (t, change, distance, error)
        self.steady_time = math.nan
        self.distance = math.nan
        self.contraction = math.nan
        self.iterations: list[tuple[float, int]] = []  # (t, Picard iterations of the step)

    def _sum(self, values: np.ndarray) -> float:
        return self.comm.allreduce(float(np.dot(values, values)), op=MPI.SUM)

    def error(self) -> float:
        """Relative L² error of u_x against the analytic profile."""
        err = self.comm.allreduce(fem.assemble_scalar(self._err), op=MPI.SUM)
        norm = self.comm.allreduce(fem.assemble_scalar(self._norm), op=MPI.SUM)
        return math.sqrt(err / norm)

    def __call__(self, sim: Simulation) -> bool:
        t = sim.state.t
        self.iterations.append((t, sim.iteration_counts[-1]))
        if t < self._next - 1e-9:
            return False
        self._next = t + self.window
        u = self.flow.u_old.x.array[: self._n_owned].copy()
        scale = math.sqrt(self._sum(u))
        change = distance = math.inf
        if self._snapshot is not None and scale > 0:
            change = math.sqrt(self._sum(u - self._snapshot)) / scale
            r = change / self._previous_change if self._previous_change > 0 else math.inf
            if 0 < r < 1:
                distance = change * r / (1.0 - r)
                self.contraction = r
            elif change == 0:
                distance = 0.0
            self._previous_change = change
        self._snapshot = u
        self.history.append((t, change, distance, self.error()))
        self.distance = distance
        if distance <= self.tol:
            self.steady_time = t
            return True
        return False


@dataclass
class BagnoldCase:
    label: str
    cells: int                # cells across the layer
    mesh_size: float
    epsilon: float
    dt: float
    status: str
    steps: int
    iterations: int
    wall_time: float
    steady_time: float        # nan if the run hit end_time first
    decay_time: float         # e-folding time of the approach to steady state [s]
    time_1pct: float          # first time the relative L² error is ≤ 1 % [s]
    error: float              # relative L² error of u_x
    surface_error: float      # relative error of u_x at y = h (max over the surface dofs)
    ill_posed_cells: float    # fraction of the area whose cell-centroid I is outside the window
    ill_posed_depth: float    # thickness of the ill-posed layer under the surface (sampled) [m]
    I_surface: float          # least I on the free surface itself (p_h ≈ 0 there)
    I_min: float              # min/max of the cell-centroid I
    I_max: float
    profile: tuple = field(repr=False)   # (y levels, u_x) of the steady state
    cell_I: tuple = field(repr=False)    # (cell-centroid y, I) of the steady state
    history: list = field(repr=False)    # SteadyObserver.history
    step_iterations: list = field(repr=False)  # SteadyObserver.iterations


def _gather(comm, values: np.ndarray) -> np.ndarray:
    return np.concatenate(comm.allgather(np.asarray(values)))


def _steady_measures(sim: Simulation, law: MuI, us: float):
    """Surface error, profile, I per cell and the ill-posed fractions of the current state."""
    flow, comm, cfg = sim.disc.flow, sim.comm, sim.cfg
    mesh = flow.mesh
    eps = cfg.numerics.epsilon
    # velocity profile: u_x against y at the owned P2 dofs, one value per level
    n = flow.V.dofmap.index_map.size_local
    y = flow.V.tabulate_dof_coordinates()[:n, 1]
    ux = flow.u_old.x.array.reshape(-1, 2)[:n, 0]
    y, ux = _gather(comm, np.round(y, 12)), _gather(comm, ux)
    levels, inverse = np.unique(y, return_inverse=True)
    profile = np.bincount(inverse, ux) / np.bincount(inverse)
    surface_error = float(abs(profile[-1] - us) / us)
    # I per cell (DG0 interpolation: at the centroid) and cell areas
    u, p = ufl.split(flow.solution)
    I_expr = law.inertial_number(u, p, eps)
    S0 = compat.scalar_space(mesh, 0, "DG")
    I_cell, yc = fem.Function(S0), fem.Function(S0)
    I_cell.interpolate(compat.expression(I_expr, S0))
    yc.interpolate(compat.expression(ufl.SpatialCoordinate(mesh)[1], S0))
    # cell areas: ∫ v dx for the DG0 basis (ffcx 0.5 cannot put CellVolume in an Expression)
    area = fem.assemble_vector(fem.form(ufl.TestFunction(S0) * ufl.dx))
    nc = compat.num_owned_cells(mesh)
    I_all = _gather(comm, I_cell.x.array[:nc])
    w_all = _gather(comm, area.array[:nc])
    yc_all = _gather(comm, yc.x.array[:nc])
    ill_cells = fraction_ill_posed(law, I_all, w_all)
    # near the edges: I at points approaching each edge of every cell (barycentric distance
    # 1e-9 ... 0.3 of the cell, geometric), to find the ill-posed layer under the free surface
    lam = np.geomspace(1e-9, 0.3, 60)
    pts = np.concatenate([np.column_stack([(1 - lam) / 2, (1 - lam) / 2]),    # → edge λ0 = 0
                          np.column_stack([lam, (1 - lam) / 2]),              # → edge ξ = 0
                          np.column_stack([(1 - lam) / 2, lam])])             # → edge η = 0
    cells = np.arange(nc, dtype=np.int32)
    I_pts = compat.eval_expression(fem.Expression(I_expr, pts), mesh, cells).ravel()
    y_pts = compat.eval_expression(fem.Expression(ufl.SpatialCoordinate(mesh)[1], pts), mesh,
                                   cells).ravel()
    ill = criterion(law, I_pts) >= 0
    h = cfg.geometry.height
    depth = comm.allreduce(float((h - y_pts[ill]).max()) if ill.any() else 0.0, op=MPI.MAX)
    # I on the free surface itself (the vertices and midpoints of the surface facets)
    edge = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]])
    I_e = compat.eval_expression(fem.Expression(I_expr, edge), mesh, cells).ravel()
    y_e = compat.eval_expression(fem.Expression(ufl.SpatialCoordinate(mesh)[1], edge), mesh,
                                 cells).ravel()
    on_top = np.abs(y_e - h) < 1e-9 * h
    I_surface = comm.allreduce(float(I_e[on_top].min()) if on_top.any() else math.inf, op=MPI.MIN)
    order = np.argsort(yc_all)
    return (surface_error, (levels, profile), (yc_all[order], I_all[order]), ill_cells,
            depth, I_surface, float(I_all.min()), float(I_all.max()))


def run_case(cfg: Config, run_dir: Path, label: str, cells: int, window: float,
             tol: float) -> BagnoldCase:
    """One run from rest to the steady state (or end_time) and its comparison to Bagnold."""
    law = _law(cfg)
    sim = Simulation(cfg, run_dir, quiet=True)
    obs = SteadyObserver(sim, window, tol)
    t0 = time.perf_counter()
    summary = sim.run(observers=[obs])
    wall = time.perf_counter() - t0
    error = obs.error()
    (surface_error, profile, cell_I, ill_cells, depth, I_surf, I_min,
     I_max) = _steady_measures(sim, law, obs.us)
    r = obs.contraction
    decay = -window / math.log(r) if 0 < r < 1 else math.nan
    within = [t for t, _, _, e in obs.history if e <= 0.01]
    time_1pct = within[0] if within else math.nan
    return BagnoldCase(label, cells, cfg.geometry.mesh_size, cfg.numerics.epsilon, cfg.time.dt,
                       summary["status"], summary["steps"], int(np.sum(sim.iteration_counts)), wall,
                       obs.steady_time, decay, time_1pct, error, surface_error, ill_cells, depth,
                       I_surf, I_min, I_max,
                       profile, cell_I, obs.history, obs.iterations)


@dataclass
class BagnoldPlan:
    """Meshes (cells across the layer), the steady-state test, and extra ε checks."""

    cells: list
    window: float             # [s] between two comparisons of the velocity
    steady_tol: float         # relative distance to the steady state at which a run stops
    extra_epsilons: list      # (cells, ε) runs that show the steady state does not depend on ε


FULL = BagnoldPlan(cells=[5, 10, 20, 40], window=0.2, steady_tol=1e-7, extra_epsilons=[(10, 1e-6)])
QUICK = BagnoldPlan(cells=[5, 10], window=0.2, steady_tol=1e-5, extra_epsilons=[])


def _cfg(base: Config, cells: int, eps: float | None = None) -> Config:
    mesh = base.geometry.height / cells
    extra = [f"numerics.epsilon={eps!r}"] if eps is not None else []
    return with_overrides(base, [f"geometry.mesh_size={mesh!r}", "time.output_every=100000",
                                 "time.checkpoint_every=100000"] + extra)


def validate_bagnold(config: Path, out_dir: Path, quick: bool = False, log=print) -> dict:
    """Run the mesh sweep to steady state; write ``bagnold.csv`` and ``bagnold.png``."""
    plan = QUICK if quick else FULL
    base = load_config(config)
    law = _law(base)
    _, us, I_theta = analytic_profile(base)
    window = well_posed_window(law)
    log(f"Bagnold: h = {base.geometry.height:g} m, θ = {base.geometry.bed_angle:g}°, "
        f"I_θ = {I_theta:.5f}, "
        f"u_s = {us:.5f} m/s; well-posed window {window[0]:.4g} < I < {window[1]:.4g}")
    out_dir = Path(out_dir)
    cases: list[BagnoldCase] = []
    for cells in plan.cells:
        c = run_case(_cfg(base, cells), out_dir / f"cells_{cells}", f"n={cells}", cells,
                     plan.window, plan.steady_tol)
        cases.append(c)
        log(_row(c))
    extra: list[BagnoldCase] = []
    for cells, eps in plan.extra_epsilons:
        c = run_case(_cfg(base, cells, eps), out_dir / f"cells_{cells}_eps_{eps:g}",
                     f"n={cells} ε={eps:g}", cells, plan.window, plan.steady_tol)
        extra.append(c)
        log(_row(c))
    order = observed_order([c.mesh_size for c in cases], [c.error for c in cases])
    log(f"observed order of the L² error in the mesh size: {order:.2f}")
    for c in cases + extra:
        if c.status != "stopped_by_observer":
            log(f"warning: {c.label} did not reach the steady state (tolerance {plan.steady_tol:g}) "
                f"before time.end_time = {base.time.end_time:g} s")
    if MPI.COMM_WORLD.rank == 0:
        _write_csv(out_dir / "bagnold.csv", cases, extra)
        _plot(out_dir / "bagnold.png", cases, extra, base, order, window, I_theta)
    return {"cases": cases, "extra": extra, "order": order, "I_theta": I_theta,
            "surface_velocity": us, "window": window, "plan": plan}


def _row(c: BagnoldCase) -> str:
    return (f"{c.label:>12}  dx={c.mesh_size:.4g} m ε={c.epsilon:.0e} dt={c.dt:.0e} s  {c.status}  "
            f"within 1 % at {c.time_1pct:.2f} s, steady at {c.steady_time:.2f} s "
            f"(e-folding {c.decay_time:.3f} s)  steps {c.steps:4d}  "
            f"iterations {c.iterations:5d}  wall {c.wall_time:6.1f} s  rel. L2 error {c.error:.3e}  "
            f"surface {c.surface_error:.2e}  ill-posed: cells {c.ill_posed_cells:.3f}, "
            f"layer under the surface {c.ill_posed_depth:.2e} m = "
            f"{c.ill_posed_depth / c.mesh_size:.1e} ΔX "
            f"(I on the surface ≥ {c.I_surface:.3g})  cell I in [{c.I_min:.4f}, {c.I_max:.4f}]")


CSV_COLUMNS = ["label", "cells", "mesh_size", "epsilon", "dt", "status", "steps", "iterations",
               "wall_time", "time_1pct", "steady_time", "decay_time", "l2_error", "surface_error",
               "ill_posed_fraction_cells", "ill_posed_depth", "I_surface", "I_min", "I_max"]


def _write_csv(path: Path, cases, extra) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w") as f:
        f.write(",".join(CSV_COLUMNS) + "\n")
        for c in cases + extra:
            f.write(f"{c.label},{c.cells},{c.mesh_size:g},{c.epsilon:g},{c.dt:g},{c.status},{c.steps},"
                    f"{c.iterations},{c.wall_time:.3f},{c.time_1pct:.4f},{c.steady_time:.4f},"
                    f"{c.decay_time:.4f},"
                    f"{c.error:.4e},{c.surface_error:.4e},{c.ill_posed_cells:.4f},"
                    f"{c.ill_posed_depth:.4e},{c.I_surface:.5g},{c.I_min:.5g},{c.I_max:.5g}\n")


def _label(ax, xlabel: str, ylabel: str, title: str, legend: dict | None = None, which: str = "both") -> None:
    """Axis labels, title, legend (font size 8 unless given) and a light grid of one panel."""
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(**(legend or {"fontsize": 8}))
    ax.grid(alpha=0.3, which=which)


def _plot(path: Path, cases, extra, cfg: Config, order: float, window, I_theta: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    law, m, h = _law(cfg), cfg.material, cfg.geometry.height
    theta = math.radians(cfg.geometry.bed_angle)
    yy = np.linspace(0.0, h, 400)
    U = bagnold_velocity(law, theta, h, yy, m.density, m.gravity)
    fig, ax = plt.subplots(2, 3, figsize=(15, 8.5))
    a = ax[0, 0]
    a.plot(U, yy * 1e3, "k-", lw=1.5, label="Bagnold (analytic)")
    for k, c in reversed(list(enumerate(cases))):  # coarsest on top, with the largest markers
        y, ux = c.profile
        a.plot(ux, y * 1e3, "o", ms=2 + 2 * (len(cases) - 1 - k), mfc="none", color=f"C{k}",
               label=f"2D, {c.label}")
    _label(a, "u_x [m/s]", "y [mm]", "Steady velocity profile", which="major")
    a = ax[0, 1]
    for c in cases + extra:
        y, ux = c.profile
        e = np.abs(ux - bagnold_velocity(law, theta, h, np.clip(y, 0, h), m.density, m.gravity))
        a.semilogx(np.maximum(e, 1e-12), y * 1e3, ".-", lw=1, label=f"2D, {c.label}")
    _label(a, "|u_x − U| at the P2 dof levels [m/s]", "y [mm]", "Pointwise error of the steady profile")
    a = ax[0, 2]
    for k, c in enumerate(cases):
        y, I = c.cell_I
        a.semilogx(I, y * 1e3, ".", ms=4, color=f"C{k}", label=f"I at cell centroids, {c.label}")
        a.semilogx([c.I_surface], [h * 1e3], "*", ms=12 - 2 * k, color=f"C{k}")
    a.semilogx([], [], "k*", ms=8, label="I on the surface (p_h ≈ 0)")
    depths = ", ".join(f"{c.ill_posed_depth * 1e6:.2g}" for c in cases)
    a.text(0.03, 0.5, f"ill posed only in a layer under\nthe surface, {depths} µm thick\n"
           f"(≈ {cases[-1].ill_posed_depth / cases[-1].mesh_size:.1e} ΔX)", transform=a.transAxes,
           fontsize=8, va="center")
    a.axvline(I_theta, color="k", lw=1.5, label=f"I_θ = {I_theta:.4f}")
    lo, hi = window
    a.axvspan(lo, hi, color="g", alpha=0.08, label=f"well posed: {lo:.3g} < I < {hi:.3g}")
    _label(a, "I", "y [mm]", "Inertial number at steady state", legend=dict(fontsize=7, loc="lower left"))
    a = ax[1, 0]
    xs = np.array([c.mesh_size for c in cases])
    es = np.array([c.error for c in cases])
    a.loglog(xs * 1e3, es, "o-", label=f"relative L² error (order {order:.2f})")
    a.loglog(xs * 1e3, [c.surface_error for c in cases], "s--", label="surface speed, relative")
    for k, style in ((2, "k:"), (3, "k--")):
        a.loglog(xs * 1e3, es[-1] * (xs / xs[-1]) ** k, style, lw=1, label=f"order {k}")
    for c in extra:
        a.loglog([c.mesh_size * 1e3], [c.error], "x", ms=9, label=f"{c.label}")
    a.axhline(1e-2, color="r", lw=0.8, label="1 % goal")
    a.set_xticks(xs * 1e3, [f"{x * 1e3:g}" for x in xs])
    a.minorticks_off()
    _label(a, "ΔX [mm]", "error", "Convergence in space (steady state)")
    a = ax[1, 1]
    for c in cases + extra:
        t, change, distance, err = np.array(c.history, dtype=float).T
        line, = a.semilogy(t, err, "-", label=f"L² error, {c.label}")
        ok = np.isfinite(distance)
        a.semilogy(t[ok], distance[ok], ":", color=line.get_color(), lw=1)
    _label(a, "t [s]", "relative", "Approach to steady state (dotted: estimated distance)")
    a = ax[1, 2]
    for c in cases + extra:
        t, its = np.array(c.step_iterations, dtype=float).T
        a.plot(t, its, "-", lw=1, label=f"{c.label}: {c.iterations} in {c.steps} steps")
    a.set_yscale("log")
    _label(a, "t [s]", "Picard iterations per step", "Nonlinear iterations")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
