r"""Numerical ill-posedness test of the μ(I) law (Barker, Schaeffer, Bohórquez & Gray 2015).

The steady uniform (Bagnold) flow of a periodic layer down a slope θ has the uniform inertial
number I_θ = I0 (tanθ − μ_s)/(μ_2 − tanθ) (``reference.bagnold``). The linear criterion
C(I_θ) of ``rheology.wellposedness`` says whether the equations linearized about it are well
posed (C < 0) or not (C ≥ 0: short waves grow at σ = G k² η/ρ, G > 0 from
``high_wavenumber_growth``, without bound in k). This module measures that on the discrete
problem (P2/P1, backward Euler, Picard to ``rtol``: 1e-8, 1e-7 in --quick):

* two runs of ``n_steps`` steps on the same mesh, both started from the Bagnold profile U(y)
  (with the lithostatic pressure ρ g cosθ (h − y) as the first iterate): the reference run
  from U, the perturbed run from U + δu₀, with δu₀ random nodal noise (seeded; independent
  normal components of standard deviation ``noise`` × u_s at every P2 velocity node off the
  bed, the same value at the two periodic images of a node and on any number of ranks);
* the perturbation δu(t) = u_pert(t) − u_ref(t) and its norm a(t) = ‖δu(t)‖_{L²(Ω)};
* the growth rate σ = least-squares slope of ln a against t over the last ``fit_steps``
  steps (the first steps project the noise onto the discretely divergence-free fields and
  damp the decaying waves; what is left is the slowest-decaying or fastest-growing part).

Time step of each mesh: Δt = β min(ΔX²/ν_mid, ΔX/u_s) (β = ``diffusion_number``, ν_mid =
μ p/(ρ γ̇) at mid-depth, u_s the surface speed). Backward Euler turns a growth rate σ into
the factor 1/(1 − σΔt) per step and is singular at σΔt = 1: with a Δt fixed across meshes the
fastest short waves of a fine mesh would be damped, not seen. With Δt ∝ ΔX², σΔt of the
grid-scale waves is mesh independent, so an ill-posed σ grows as ΔX⁻² and a well-posed one
stays bounded or negative. The period L (``period``) must be long: the unstable wave vectors
lie within a few degrees of the bed-parallel or bed-normal direction (``docs/model.md``), so a
wave resolved across the layer needs a wavelength along x of ~10× its wavelength across.

Classification of one (θ, ε) over the meshes, coarse to fine:

* ``ill_posed``: σ increases at every refinement, is > 0 on the finest mesh and at least
  ``GROWTH_FACTOR`` (1.5×) the previous mesh's (positive part);
* ``well_posed``: σ ≤ 0 on every mesh (the perturbation decays), or σ converges: the change
  between the two finest meshes is ≤ ``CONVERGED`` (25 %) of the finest |σ|;
* ``failed``: a run did not finish its steps (no convergence at time.dt_min = Δt/4; exit
  code and message kept);
* ``inconclusive``: anything else.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse.config import Config, load_config, with_overrides
from dpcollapse.errors import ConfigError, DpcollapseError
from dpcollapse.reference.bagnold import (
    bagnold_inertial_number,
    bagnold_shear_rate,
    bagnold_surface_velocity,
    bagnold_velocity,
)
from dpcollapse.rheology.choice import law_from_material
from dpcollapse.rheology.wellposedness import criterion, high_wavenumber_growth, well_posed_window
from dpcollapse.simulation import Simulation

__all__ = ["WellposedCase", "WellposedPlan", "FULL", "QUICK", "wellposedness_map", "classify",
           "growth_rate", "periodic_noise"]

#: σ must grow by this factor per refinement for ``ill_posed``
GROWTH_FACTOR = 1.5
#: relative change of σ between the two finest meshes below which σ has converged
CONVERGED = 0.25
CLASSES = ("well_posed", "ill_posed", "inconclusive", "failed")


@dataclass(frozen=True)
class WellposedCase:
    """One slope and regularization: a name, θ [deg], ε [1/s]."""

    name: str
    bed_angle: float
    epsilon: float = 1e-2


@dataclass
class WellposedPlan:
    """Cases (θ, ε) × meshes (cells across the layer); Δt, steps, noise and fit window."""

    cases: list
    cells: list
    dt: float
    n_steps: int
    noise: float = 1e-3
    #: the fit of σ uses the last ``fit_steps`` steps (after the decaying modes have gone)
    fit_steps: int = 10
    #: period L of the layer [m] (None: the config's); see the module docstring
    period: float | None = None
    #: numerics.nonlinear_rtol of every run (the Picard error must stay far below δu)
    rtol: float = 1e-8
    #: β: when set, Δt = β min(ΔX²/ν_mid, ΔX/u_s) per mesh (``time_step``), instead of ``dt``
    diffusion_number: float | None = None
    seed: int = 16


# Law of configs/bagnold.yaml: μ_s = 0.32, μ_2 = 0.60, I0 = 0.4; window 0.01363 < I < 1.810.
# θ = 17.9° ⇒ I_θ = 0.00432 (below), 22° ⇒ 0.1715 (inside), 30° ⇒ 4.545 (above; μ_2 >
# tan 30°, so the steady state exists).
# ε = 1 1/s exceeds the bulk shear rate of the slow flow (γ̇ ≈ 0.66 1/s at mid-depth).
CASES = [WellposedCase("below", 17.9), WellposedCase("inside", 22.0),
         WellposedCase("above", 30.0), WellposedCase("below", 17.9, 1.0)]
FULL = WellposedPlan(cases=CASES, cells=[5, 10, 20], dt=1e-3, n_steps=40, diffusion_number=1.0,
                     period=0.1)
QUICK = WellposedPlan(cases=CASES[:2], cells=[5, 10], dt=1e-3, n_steps=16, diffusion_number=2.0,
                      period=0.1, fit_steps=6, rtol=1e-7)


@dataclass
class GrowthRun:
    case: str
    bed_angle: float
    I_bulk: float
    C: float
    inside: bool
    epsilon: float
    cells: int
    mesh_size: float
    dt: float
    status: str
    growth_rate: float        # σ [1/s]
    amplification: float      # a(T)/a(T − fit_steps Δt)
    wall_time: float
    iterations: int
    message: str = ""
    history: list = field(default_factory=list, repr=False)   # (t, a)
    klass: str = ""


def periodic_noise(coords: np.ndarray, period: float, seed: int, tol: float = 1e-9) -> np.ndarray:
    """Standard normal pairs (n, 2) keyed on (x mod L, y) rounded to ``tol``: the two periodic
    images of a node and every MPI rank get the same value (no dependence on the partition)."""
    out = np.empty((len(coords), 2))
    for k, (x, y) in enumerate(coords[:, :2]):
        xm = x % period
        if abs(xm - period) < tol:
            xm = 0.0
        key = [seed, int(round(xm / tol)), int(round(y / tol))]
        out[k] = np.random.default_rng(key).standard_normal(2)
    return out


def growth_rate(times, norms, last: int) -> float:
    """Least-squares slope of ln a against t over the last ``last`` steps (last + 1 samples)."""
    t = np.asarray(times, dtype=float)[-(last + 1):]
    a = np.asarray(norms, dtype=float)[-(last + 1):]
    if len(t) < 2 or np.any(~np.isfinite(a)) or np.any(a <= 0):
        return math.nan
    return float(np.polyfit(t, np.log(a), 1)[0])


def classify(rates: list[float], failed: bool) -> str:
    """The class of one (θ, ε) from its growth rates, coarse to fine (module docstring)."""
    if failed:
        return "failed"
    r = np.asarray(rates, dtype=float)
    if len(r) < 2 or not np.all(np.isfinite(r)):
        return "inconclusive"
    if np.all(r <= 0):
        return "well_posed"
    if r[-1] > 0 and r[-1] >= GROWTH_FACTOR * max(r[-2], 0.0) and np.all(np.diff(r) > 0):
        return "ill_posed"
    if abs(r[-1] - r[-2]) <= CONVERGED * abs(r[-1]):
        return "well_posed"
    return "inconclusive"


def _base(config: Path) -> Config:
    cfg = load_config(config)
    if cfg.material.rheology != "mu_i" or cfg.geometry.shape != "layer" \
            or cfg.boundary.bed_condition != "no_slip":
        raise ConfigError(f"material.rheology = {cfg.material.rheology}, geometry.shape = "
                          f"{cfg.geometry.shape}, boundary.bed_condition = "
                          f"{cfg.boundary.bed_condition}: wellposed needs mu_i, layer and no_slip")
    if cfg.material.cohesion > 0:
        raise ConfigError(f"material.cohesion = {cfg.material.cohesion:g}: the Bagnold flow "
                          "needs cohesion = 0")
    return cfg


def kinematic_viscosity(law, theta: float, h: float, density: float, gravity: float) -> float:
    """ν_mid = μ(I_θ) p/(ρ γ̇) [m²/s] of the Bagnold flow at mid-depth y = h/2
    (p = ρ g cosθ h/2, γ̇ = ``bagnold_shear_rate``): the effective viscosity σ'_xy/γ̇ over ρ."""
    p = density * gravity * math.cos(theta) * h / 2
    rate = bagnold_shear_rate(law, theta, h, h / 2, density, gravity)
    return math.tan(theta) * p / (density * rate)


def time_step(base: Config, case: WellposedCase, cells: int, plan: WellposedPlan) -> float:
    """Δt of one mesh: ``plan.dt``, or β min(ΔX²/ν_mid, ΔX/u_s) with β =
    ``plan.diffusion_number``: the viscous and the advective time of one cell (u_s the
    surface speed; the advective time is the shorter one only in fast flow)."""
    if plan.diffusion_number is None:
        return plan.dt
    law, m, h = law_from_material(base.material), base.material, base.geometry.height
    theta = math.radians(case.bed_angle)
    nu = kinematic_viscosity(law, theta, h, m.density, m.gravity)
    us = bagnold_surface_velocity(law, theta, h, m.density, m.gravity)
    dx = h / cells
    return plan.diffusion_number * min(dx**2 / nu, dx / us)


def _cfg(base: Config, case: WellposedCase, cells: int, eps: float, plan: WellposedPlan) -> Config:
    h = base.geometry.height
    dt = time_step(base, case, cells, plan)
    period = [f"geometry.base_length={plan.period!r}"] if plan.period is not None else []
    return with_overrides(base, period + [
        f"geometry.bed_angle={case.bed_angle!r}", f"geometry.mesh_size={h / cells!r}",
        f"numerics.epsilon={eps!r}", f"numerics.nonlinear_rtol={plan.rtol!r}",
        "numerics.nonlinear_atol=1e-13",
        f"time.dt={dt!r}", f"time.dt_min={dt / 4!r}", f"time.end_time={dt * plan.n_steps!r}",
        "time.adaptive=false", "time.output_every=100000", "time.checkpoint_every=100000",
        "time.rest_speed=1e-12", "time.rest_duration=1e9"])


class _Recorder:
    """Observer: keeps (t, owned velocity dofs of uⁿ) after every accepted step."""

    def __init__(self, sim: Simulation):
        self.flow = sim.disc.flow
        self.states: list[tuple[float, np.ndarray]] = []
        self.sim = sim

    def __call__(self, sim: Simulation) -> bool:
        self.states.append((sim.state.t, self.flow.u_old.x.array.copy()))
        return False


def _start(sim: Simulation, cfg: Config, law, plan: WellposedPlan, perturbed: bool) -> float:
    """uⁿ = U (+ noise), first pressure iterate ρ g cosθ (h − y); returns u_s."""
    flow, g, m = sim.disc.flow, cfg.geometry, cfg.material
    theta, h = math.radians(g.bed_angle), g.height
    us = bagnold_surface_velocity(law, theta, h, m.density, m.gravity)

    def profile(x):
        y = np.clip(x[1], 0.0, h)
        return np.vstack([bagnold_velocity(law, theta, h, y, m.density, m.gravity), 0.0 * y])

    flow.set_velocity(profile)
    if perturbed:
        xy = flow.V.tabulate_dof_coordinates()
        noise = periodic_noise(xy, g.base_length, plan.seed) * plan.noise * us
        noise[xy[:, 1] < 1e-9 * h] = 0.0      # no slip on the bed
        flow.u_old.x.array[:] += noise.ravel()
        flow.iterate.x.array[flow.velocity_dofs] = flow.u_old.x.array
        flow.solution.x.array[:] = flow.iterate.x.array
    yq = flow.Q.tabulate_dof_coordinates()[:, 1]
    p = m.density * m.gravity * math.cos(theta) * np.clip(h - yq, 0.0, None)
    flow.iterate.x.array[flow.pressure_dofs] = p
    flow.solution.x.array[:] = flow.iterate.x.array
    return us


def _run(cfg: Config, run_dir: Path, law, plan: WellposedPlan, perturbed: bool):
    sim = Simulation(cfg, run_dir, quiet=True)
    _start(sim, cfg, law, plan, perturbed)
    rec = _Recorder(sim)
    x0 = sim.disc.flow.u_old.x.array.copy()
    try:
        summary = sim.run(observers=[rec])
        status, message = summary["status"], summary.get("error") or ""
    except DpcollapseError as exc:
        status, message = f"failed (exit {exc.exit_code})", " ".join(str(exc).split())
    return sim, [(0.0, x0)] + rec.states, status, message, int(np.sum(sim.iteration_counts))


def run_cell(base: Config, case: WellposedCase, cells: int, eps: float, plan: WellposedPlan,
             out_dir: Path) -> GrowthRun:
    """Reference and perturbed runs of one (θ, ΔX, ε); σ from their difference."""
    cfg = _cfg(base, case, cells, eps, plan)
    law = law_from_material(cfg.material)
    theta = math.radians(case.bed_angle)
    lo, hi = well_posed_window(law)
    try:
        I_bulk = bagnold_inertial_number(law, theta)
    except ValueError as exc:
        return GrowthRun(case.name, case.bed_angle, math.nan, math.nan, False, eps, cells,
                         cfg.geometry.mesh_size, cfg.time.dt, "failed (no steady state)", math.nan,
                         math.nan, 0.0, 0, str(exc), klass="failed")
    C = criterion(law, I_bulk)
    tag = f"{case.name}_eps{eps:g}_n{cells}"
    t0 = time.perf_counter()
    sim_ref, ref, st_ref, msg_ref, it_ref = _run(cfg, out_dir / tag / "reference", law, plan, False)
    sim, per, st_per, msg_per, it_per = _run(cfg, out_dir / tag / "perturbed", law, plan, True)
    wall = time.perf_counter() - t0
    flow = sim.disc.flow
    delta = fem.Function(flow.V)
    norm = fem.form(ufl.inner(delta, delta) * ufl.dx)
    history = []
    for (t_r, u_r), (t_p, u_p) in zip(ref, per):
        if abs(t_r - t_p) > 1e-6 * cfg.time.dt:
            break
        delta.x.array[:] = u_p - u_r
        a2 = sim.comm.allreduce(fem.assemble_scalar(norm), op=MPI.SUM)
        history.append((t_r, math.sqrt(max(a2, 0.0))))
    ok = [s for s in (st_ref, st_per) if s.startswith("failed") or s == "error"]
    status = ok[0] if ok else "ok"
    if not ok and len(history) < plan.n_steps + 1:
        status = "failed (steps)"
    t, a = (np.array(v) for v in zip(*history)) if history else (np.zeros(0), np.zeros(0))
    k = len(a) - 1 - plan.fit_steps
    sigma = growth_rate(t, a, plan.fit_steps) if not ok and k >= 0 else math.nan
    amp = float(a[-1] / a[k]) if not ok and k >= 0 else math.nan
    return GrowthRun(case.name, case.bed_angle, I_bulk, C, bool(lo < I_bulk < hi), eps, cells,
                     cfg.geometry.mesh_size, cfg.time.dt, status, sigma, amp, wall, it_ref + it_per,
                     msg_ref or msg_per, history)


def wellposedness_map(config: Path, out_dir: Path, plan: WellposedPlan, log=print) -> list:
    """Every (θ, ε, ΔX) of ``plan``; writes ``stability_mui.csv`` and ``stability_mui.png``."""
    base = _base(Path(config))
    law = law_from_material(base.material)
    lo, hi = well_posed_window(law)
    log(f"μ(I) law μ_s = {law.mu_s:.4g}, μ_2 = {law.mu_2:.4g}, I0 = {law.I0:g}: well posed for "
        f"{lo:.4g} < I < {hi:.4g}; Δt = {plan.diffusion_number} min(ΔX²/ν_mid, ΔX/u_s), "
        f"{plan.n_steps} steps, "
        f"period {plan.period or base.geometry.base_length:g} m, noise {plan.noise:g} u_s")
    out_dir = Path(out_dir)
    runs: list[GrowthRun] = []
    for case in plan.cases:
        group = []
        for n in plan.cells:
            group.append(run_cell(base, case, n, case.epsilon, plan, out_dir))
            log(_row(group[-1]))
        klass = classify([r.growth_rate for r in group], any(r.status != "ok" for r in group))
        for r in group:
            r.klass = klass
        log(f"  → {case.name} θ = {case.bed_angle:g}°, ε = {case.epsilon:g}: {klass}")
        runs += group
    if MPI.COMM_WORLD.rank == 0:
        write_csv(out_dir / "stability_mui.csv", runs)
        write_history(out_dir / "stability_mui_history.csv", runs)
        plot(out_dir / "stability_mui.png", runs, (lo, hi), plan, law, base)
    return runs


def _row(r: GrowthRun) -> str:
    return (f"{r.case:>7} θ={r.bed_angle:5.2f}° I={r.I_bulk:.4g} C={r.C:+.3f} ε={r.epsilon:g} "
            f"n={r.cells:3d} ΔX={r.mesh_size:.3g} m  {r.status}  σ={r.growth_rate:+.4g} 1/s "
            f"Δt={r.dt:.3g} s σΔt={r.growth_rate * r.dt:+.3g} a(T)/a(T−fit)={r.amplification:.3g}  "
            f"iterations {r.iterations}  "
            f"wall {r.wall_time:.1f} s" + (f"  [{r.message}]" if r.message else ""))


CSV_COLUMNS = ["case", "slope", "I_bulk", "C", "inside_window", "epsilon", "cells", "mesh_size",
               "dt", "status", "growth_rate", "amplification", "iterations", "wall_time", "class"]


def write_csv(path: Path, runs) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w") as f:
        f.write(",".join(CSV_COLUMNS) + "\n")
        for r in runs:
            f.write(f"{r.case},{r.bed_angle:g},{r.I_bulk:.5g},{r.C:.4f},{int(r.inside)},"
                    f"{r.epsilon:g},{r.cells},{r.mesh_size:.5g},{r.dt:g},{r.status},"
                    f"{r.growth_rate:.5g},{r.amplification:.5g},{r.iterations},"
                    f"{r.wall_time:.2f},{r.klass}\n")


def write_history(path: Path, runs) -> None:
    """a(t) of every run: case, ε, cells, step, t [s], a = ‖δu‖_L² [m²/s]."""
    with path.open("w") as f:
        f.write("case,epsilon,cells,step,t,a\n")
        for r in runs:
            for k, (t, a) in enumerate(r.history):
                f.write(f"{r.case},{r.epsilon:g},{r.cells},{k},{t:.6e},{a:.6e}\n")


def read_runs(csv_path: Path, history_path: Path) -> list:
    """The runs of a written map (``write_csv`` + ``write_history``), for ``plot``."""
    import csv

    hist: dict = {}
    with Path(history_path).open() as f:
        for row in csv.DictReader(f):
            key = (row["case"], float(row["epsilon"]), int(row["cells"]))
            hist.setdefault(key, []).append((float(row["t"]), float(row["a"])))
    runs = []
    with Path(csv_path).open() as f:
        for row in csv.DictReader(f):
            r = GrowthRun(row["case"], float(row["slope"]), float(row["I_bulk"]), float(row["C"]),
                          row["inside_window"] == "1", float(row["epsilon"]), int(row["cells"]),
                          float(row["mesh_size"]), float(row["dt"]), row["status"],
                          float(row["growth_rate"]), float(row["amplification"]),
                          float(row["wall_time"]), int(row["iterations"]), klass=row["class"])
            r.history = hist.get((r.case, r.epsilon, r.cells), [])
            runs.append(r)
    return runs


def plot(path: Path, runs, window, plan: WellposedPlan, law=None,
         base: Config | None = None) -> None:
    """Left: σ against 1/ΔX per (θ, ε), the class in the legend, and (dotted, where C > 0) the
    frozen-coefficient rate G ν_mid (π/ΔX)². Right: a(t)/a(0) of each run against the step."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(14, 6.4))
    groups: dict = {}
    for r in runs:
        groups.setdefault((r.case, r.epsilon), []).append(r)
    markers = {"well_posed": "o", "ill_posed": "^", "inconclusive": "s", "failed": "x"}
    for k, ((case, eps), rs) in enumerate(groups.items()):
        color = f"C{k}"
        r0 = rs[0]
        where = "inside" if r0.inside else ("below" if r0.I_bulk < window[0] else "above")
        label = (f"θ={r0.bed_angle:g}°, I={r0.I_bulk:.3g} ({where} the window, C={r0.C:+.2f}), "
                 f"ε={eps:g}: {r0.klass.upper()}")
        x = np.array([1.0 / r.mesh_size for r in rs])
        y = [r.growth_rate for r in rs]
        ax[0].plot(x, y, "-", color=color, marker=markers.get(r0.klass, "o"), ms=9, lw=1.5,
                   label=label)
        first_eps = min(e for c, e in groups if c == case)
        if law is not None and base is not None and r0.C > 0 and eps == first_eps:
            theta, m = math.radians(r0.bed_angle), base.material
            G = high_wavenumber_growth(law, r0.I_bulk)
            nu = kinematic_viscosity(law, theta, base.geometry.height, m.density, m.gravity)
            ax[0].plot(x, G * nu * (math.pi * x) ** 2, ":", color=color, lw=1.2,
                       label=f"θ={r0.bed_angle:g}°: frozen-coefficient G ν_mid (π/ΔX)², "
                             f"G = {G:.3f}")
        for r in rs:
            if r.history:
                t, a = np.array(r.history).T
                width = 0.6 + 0.8 * plan.cells.index(r.cells) if r.cells in plan.cells else 1.0
                ax[1].semilogy(np.arange(len(a)), a / a[0], "-", color=color, lw=width)
    ax[0].axhline(0.0, color="k", lw=0.8)
    ax[0].set_xscale("log")
    ax[0].set_yscale("symlog", linthresh=1.0)
    ax[0].set_xlabel("1/ΔX [1/m]")
    ax[0].set_ylabel("growth rate σ of ‖u_pert − u_ref‖_L² [1/s]")
    ax[0].set_title(f"Grid-scale noise on the Bagnold flow (well posed for {window[0]:.3g} < I < "
                    f"{window[1]:.3g})", fontsize=10)
    ax[0].legend(fontsize=7.5, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=1)
    ax[0].grid(alpha=0.3, which="both")
    ax[1].set_xlabel("step (Δt = β min(ΔX²/ν_mid, ΔX/u_s): finer meshes take shorter steps)")
    ax[1].set_ylabel("a(t)/a(0), a = ‖δu‖_L²  (thicker: finer mesh)")
    ax[1].set_title(f"Perturbation norm, β = {plan.diffusion_number}, noise {plan.noise:g} u_s; "
                    f"σ fitted over the last {plan.fit_steps} steps", fontsize=10)
    ax[1].grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plan_with(plan: WellposedPlan, **changes) -> WellposedPlan:
    """A copy of ``plan`` with the given fields replaced (the command line's options)."""
    return replace(plan, **{k: v for k, v in changes.items() if v is not None})
