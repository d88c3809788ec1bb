"""The model ladder, measured (issue 15): the 2D solver and the depth-averaged model on one scene.

    python -m studies ladder [--quick] [--out docs/figures] [--work runs/ladder]
                                           [--only CASE]... [--redo] [--plot-only]

For each case (a config of ``configs/`` plus ``--set`` overrides) both rungs run on the same
problem, one after the other in this process:

* 2D: ``Simulation`` (what ``dpcollapse run`` runs) to rest or to ``time.end_time``, run
  directory ``WORK/CASE``; its front history is the mesh's largest x (diagnostics.csv);
* Savage–Hutter (``models.savage_hutter``), order 2, Δx = ``SH_DX`` (1 mm; 4 mm with --quick),
  from the exact cell averages of the 2D scene's initial polygon; to the 2D run's end time when
  the 2D run ended there, else to its own rest (at most ``SH_MAX_TIME``); its front history is
  the 1 mm front.

Compared, on the Savage–Hutter grid:

* the deposit thickness h(x) of each rung: for the 2D run, the exact cell averages of the final
  domain's boundary polygon (``initial.polygon_cell_averages``: the length of the cut normal to
  the bed at x — the thickness from the free surface, normal to the bed);
* front x_f = the largest x where h = 1 mm (``solver.front_position``, the same function and
  threshold for both rungs), runout ΔL = x_f − L0 (L0 = ``geometry.base_length``), deposit height
  H_f = max h; relative differences (SH − 2D)/2D; "within 5 %" when both |ΔL| and |H_f|
  differences are ≤ 5 %;
* the L1 difference of the profiles Σ|h_SH − h_2D| Δx [m²] and the same over the area;
* the cost ratio: 2D time (mesh, forms and loop) / Savage–Hutter time (``simulate``), in the
  same process, one run at a time: process (CPU) time — what a shared machine does not inflate —
  and wall time (``time.perf_counter``);
* the dam break on a slope also against the exact solution of Mangeney et al. (2000), on the part
  of the domain the left wall has not reached (x ≥ m t²/2 + c0 t, valid while t < L0/(2 c0)).

Results go to ``OUT/ladder.csv`` (one row per case) and ``OUT/ladder_series.csv`` (front
histories and final profiles); a case already in the CSV with the same config is not run again
(``--redo`` runs it again; ``--plot-only`` only redraws ``OUT/ladder.png`` from the CSVs).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dpcollapse.config import Config, NumericsConfig, load_config, with_overrides
from dpcollapse.errors import ConfigError
from dpcollapse.models.savage_hutter import Grid, SavageHutter, simulate
from dpcollapse.models.savage_hutter.exact import mangeney_dam_break
from dpcollapse.models.savage_hutter.initial import polygon_area, polygon_cell_averages
from dpcollapse.models.savage_hutter.setup import setup_from_config
from dpcollapse.models.savage_hutter.solver import front_position

#: Repository root (the configs are named relative to it).
ROOT = Path(__file__).resolve().parents[1]
#: Thickness that defines the front of both rungs [m].
FRONT_THRESHOLD = 1e-3
#: Savage–Hutter cell size [m] (full run, --quick).
SH_DX = 1e-3
SH_DX_QUICK = 4e-3
#: Savage–Hutter: longest run to rest [s].
SH_MAX_TIME = 5.0
#: Tolerance of "within" [-].
WITHIN = 0.05
#: The 2D runs write no fields and no checkpoints (only diagnostics.csv and run.json).
QUIET_OUTPUT = ("time.output_every=1000000", "time.checkpoint_every=1000000")
#: every case at its config's fixed step, first order, as the ladder was measured (the 1D
#: model refuses bdf2; configs/rigid.yaml's own default is BDF2 with error control)
FIXED_STEP = ("time.scheme=bdf1", "time.tolerance=null")

COLUMNS = [
    "case", "group", "param", "config", "overrides", "mesh_size_2d", "sh_dx", "sh_order", "sh_friction",
    "status_2d", "t_end_2d", "steps_2d", "remeshes_2d", "wall_2d_s", "cpu_2d_s", "front_2d_mesh", "front_2d",
    "runout_2d", "height_2d", "area_drift_2d",
    "status_sh", "t_end_sh", "steps_sh", "wall_sh_s", "cpu_sh_s", "front_sh", "runout_sh", "height_sh",
    "mass_error_sh",
    "runout_diff", "height_diff", "l1_diff_m2", "l1_rel", "cost_ratio", "cost_ratio_cpu", "within_5pct",
    "l1_sh_exact_m2", "l1_2d_exact_m2", "front_exact",
    # the depth-averaged rung again with Savage–Hutter's K_act/pass ("k") and with a constant
    # Rankine active K = (1 − sin φ)/(1 + sin φ) ("ka", the ladder's K hypothesis)
    "k_act", "k_pass", "status_sh_k", "cpu_sh_k", "runout_sh_k", "height_sh_k", "runout_diff_k",
    "height_diff_k", "k_rankine", "status_sh_ka", "runout_sh_ka", "height_sh_ka",
    "runout_diff_ka", "height_diff_ka",
    # the two-phase rung (``python -m studies ladder --two-phase``): the same scene in a fixed box
    "status_tp", "t_end_tp", "steps_tp", "cell_tp", "cpu_tp_s", "wall_tp_s", "front_stop_tp",
    "runout_tp", "height_tp", "runout_diff_tp", "height_diff_tp", "max_speed_tp", "ritter_speed",
    "runout_tp_profile",
]


@dataclass(frozen=True)
class Case:
    """One scene both rungs run: a config of ``configs/`` and its ``--set`` overrides."""

    name: str
    group: str                       # rigid | column | slope | dam_break | resolution
    param: float                     # the swept value (aspect ratio a, bed angle θ [deg], ...)
    config: str                      # relative to the repository root
    overrides: tuple[str, ...] = ()
    sh_x_max: float | None = None    # end of the Savage–Hutter domain [m] (None: L0 + 6 H0 + 0.2)

    def load(self) -> Config:
        return load_config(ROOT / self.config, list(QUIET_OUTPUT) + list(FIXED_STEP)
                           + list(self.overrides))


L0_COLUMN = 0.07
ASPECT_RATIOS = (0.5, 1.0, 2.0, 3.0, 4.0, 6.0)
RIGID_SLOPES = (10.0, 20.0)
#: At 20° the mass still moves at the 2 s cap, 2.9 m from the wall (measured): a longer SH domain.
RIGID_SLOPE_X_MAX = {20.0: 5.0}
#: Dam break on a slope: a 1 m long, 10 cm deep reservoir released at once on a 22° bed with a
#: 21° bed friction (the angles of Mangeney et al. 2000); the material keeps configs/rigid.yaml's
#: internal friction angle 25.5° (> θ: the reservoir slides as a block, as the depth-averaged
#: model assumes) and its left-wall friction. 0.5 s < L0/(2 c0) = 0.52 s.
DAM_BREAK = ("geometry.flank_angle=90", "geometry.height=0.1", "geometry.base_length=1.0",
             "geometry.bed_angle=22", "boundary.bed_friction_angle=21", "time.end_time=0.5")


#: The a = 2 column with seed 004's μ(I) fit (μ_s = 0.32 = tan 17.74°, μ_2 = 0.60 = tan 30.96°,
#: I0 = 0.4; d = 0.7 mm, the config default) in the 2D material, the bed at μ_s: the SH side then
#: takes μ(Ī) as its basal law (``model.basal_friction: auto`` → rheology).
MU_I = ("material.rheology=mu_i", "material.friction_angle=17.74", "material.friction_angle_2=30.96",
        "material.inertial_number_I0=0.4", "boundary.bed_friction_angle=17.74")
MU_I_ASPECT_RATIOS = (1.0, 2.0, 4.0)


def full_plan() -> list[Case]:
    cases = [Case("rigid", "rigid", 0.0, "configs/rigid.yaml")]
    cases += [Case(f"rigid_slope{theta:g}", "slope", theta, "configs/rigid.yaml",
                   (f"geometry.bed_angle={theta:g}",), sh_x_max=RIGID_SLOPE_X_MAX.get(theta))
              for theta in RIGID_SLOPES]
    for a in ASPECT_RATIOS:
        height = round(a * L0_COLUMN, 6)
        over = () if a == 2.0 else (f"geometry.height={height:g}",)
        cases.append(Case(f"column_a{a:g}", "column", a, "configs/column.yaml", over))
    cases.append(Case("dam_break_slope22", "dam_break", 22.0, "configs/rigid.yaml",
                      DAM_BREAK + ("geometry.mesh_size=0.02",), sh_x_max=2.5))
    for a in MU_I_ASPECT_RATIOS:
        height = () if a == 2.0 else (f"geometry.height={round(a * L0_COLUMN, 6):g}",)
        cases.append(Case(f"column_a{a:g}_mui", "mu_i", a, "configs/column.yaml", MU_I + height))
    cases.append(Case("column_a2_mesh5mm", "resolution", 2.0, "configs/column.yaml",
                      ("geometry.mesh_size=0.005",)))
    cases.append(Case("column_a2_mesh2cm", "resolution", 2.0, "configs/column.yaml",
                      ("geometry.mesh_size=0.02",)))
    return cases


#: The shallow limit (issue 29): columns of thickness H = SHALLOW_H and half-length L0 = H/ε
#: against the wall at x = 0, ε = SHALLOW_EPS, on a flat bed and on SHALLOW_SLOPES° slopes, bed
#: friction SHALLOW_BED_FRICTION° (< φ = 25.5°: the layer slides on the bed in both rungs;
#: tan 20° − tan θ = 0.15 at 12°, 0.039 at 18°: the mass flows, then stops — at 12° only its
#: front when it is thin, at 18° the whole of it). 2D cells H/5: five across the initial
#: thickness. Coulomb/Drucker–Prager (configs/column.yaml's material), and μ(I) (MU_I: seed
#: 004's fit, bed at μ_s). The Coulomb model has no length scale of its own, so a family of
#: fixed H and varying L0 is a family of fixed L0 and varying H scaled.
SHALLOW_H = 0.03
SHALLOW_EPS = (0.5, 0.3, 0.2, 0.1, 0.05)
SHALLOW_SLOPES = (12.0, 18.0)
SHALLOW_BED_FRICTION = 20.0
SHALLOW_END_TIME = 5.0


def shallow_plan(laws=("dp", "mui")) -> list[Case]:
    """The ε family on the flat bed and on the slope, per law (``dp``: Drucker–Prager with the
    Coulomb bed at SHALLOW_BED_FRICTION; ``mui``: μ(I) with the bed at μ_s)."""
    cases = []
    for law in laws:
        for bed, theta in [("flat", 0.0)] + [(f"slope{t:g}", t) for t in SHALLOW_SLOPES]:
            if law == "mui" and theta >= 17.74:    # tan θ ≥ μ_s: a μ(I) layer does not stop
                continue
            for eps in SHALLOW_EPS:
                l0 = round(SHALLOW_H / eps, 6)
                over = (f"geometry.height={SHALLOW_H:g}", f"geometry.base_length={l0:g}",
                        f"geometry.bed_angle={theta:g}", f"geometry.mesh_size={SHALLOW_H / 5:g}",
                        f"time.end_time={SHALLOW_END_TIME:g}")
                over += (MU_I if law == "mui" else (f"boundary.bed_friction_angle={SHALLOW_BED_FRICTION:g}",))
                suffix = "_mui" if law == "mui" else ""
                cases.append(Case(f"shallow_{bed}{suffix}_eps{eps:g}", f"shallow_{bed}{suffix}", eps,
                                  "configs/column.yaml", over, sh_x_max=l0 + 40 * SHALLOW_H + 0.1))
    return cases


def quick_plan() -> list[Case]:
    """For the test suite: two tiny 2D runs (3 cm cells) and their Savage–Hutter twins — the
    Coulomb column to 0.1 s, and the μ(I) column to rest (measured 9 s CPU)."""
    return [Case("column_a2_quick", "column", 2.0, "configs/column.yaml",
                 ("geometry.mesh_size=0.03", "time.end_time=0.1")),
            Case("column_a2_mui_quick", "mu_i", 2.0, "configs/column.yaml",
                 MU_I + ("geometry.mesh_size=0.03",))]


# ----------------------------------------------------------------------------- config → SH
def sh_config(cfg: Config, dx: float, x_max: float | None = None, order: int = 2) -> Config:
    """The same config with ``model.name = savage_hutter``: order 2, cells of ``dx`` on
    [0, x_max] (default L0 + 6 H0 + 0.2 m, rounded up to whole cells), a wall at x = 0 (the
    trapezoid's wall or the column's symmetry plane; the 2D wall friction has no 1D
    counterpart), open downslope, the 1 mm front. What the scene, bed and material mean for
    the 1D model is ``models.savage_hutter.setup`` (the one mapping)."""
    geo = cfg.geometry
    x_max = x_max if x_max is not None else geo.base_length + 6.0 * geo.height + 0.2
    n = max(2, math.ceil(x_max / dx - 1e-9))
    # the 1D model reads no numerics (it refuses the 2D config's that differ from the defaults)
    two_d_free = cfg.model_copy(update={"numerics": NumericsConfig()})
    return with_overrides(two_d_free, ["model.name=savage_hutter", f"model.order={order}",
                                f"model.n_cells={n}", "model.x_min=0", f"model.x_max={n * dx!r}",
                                "model.left=wall", "model.right=open", "model.shape_factor=1",
                                f"model.front_threshold={FRONT_THRESHOLD!r}"])


def sh_problem(cfg: Config, dx: float, x_max: float | None = None, order: int = 2):
    """(SavageHutter, Grid, initial polygon, μ_b source) of a trapezoid or column config."""
    setup = setup_from_config(sh_config(cfg, dx, x_max, order))
    return setup.model, setup.grid, setup.vertices, setup.friction


# ----------------------------------------------------------------------------- config → two-phase
#: The two-phase rung's cells in and around the grains: at most the 2D rung's mesh size and at
#: least this many across L0 (the column: L0/16 = 4.4 mm; the trapezoid: the 2D 1 cm).
TWO_PHASE_CELLS_ACROSS_L0 = 16
#: … and in the --quick ladder (the test)
TWO_PHASE_CELLS_ACROSS_L0_QUICK = 4
#: Its cells far out in the light fluid (the adaptive box grades between) [m].
TWO_PHASE_MAX_CELL = 0.05
#: The light fluid's circulation keeps the two-phase deposits from meeting the rest rule
#: (issue 27): the run goes on to max(TWO_PHASE_MIN_END, TWO_PHASE_END_FACTOR × the 2D rung's
#: time at rest), at most TWO_PHASE_MAX_END, and the front's stopping time is read from it.
TWO_PHASE_MIN_END, TWO_PHASE_END_FACTOR, TWO_PHASE_MAX_END = 1.0, 2.0, 3.0
#: The front counts as stopped from the time after which it stays within this of its end [m].
TWO_PHASE_FRONT_STILL = 1e-3


def two_phase_config(cfg: Config, grid: Grid, end_time: float,
                     cells_across: int = TWO_PHASE_CELLS_ACROSS_L0) -> Config:
    """The same scene and material on the two-phase model (``model.name: two_phase``): the
    box [0, x_max of the depth-averaged grid] × [0, H0 + max(H0/4, 8 cells)], an adaptive mesh
    of cells ``min(mesh_size, L0/cells_across)`` around the grains and ``TWO_PHASE_MAX_CELL`` far away,
    the Courant step of the grains (``model.adaptive_dt``, Δt ≤ 5 ms), the converged Picard
    fixed point of every step (the 2D rung's ``numerics``)."""
    g = cfg.geometry
    cell = min(g.mesh_size, g.base_length / cells_across)
    height = g.height + max(0.25 * g.height, 8.0 * cell)
    return with_overrides(cfg, [
        "model.name=two_phase", "numerics.ale=false", f"model.box_length={grid.x_max!r}",
        f"model.box_height={height!r}", f"model.min_cell={cell!r}",
        f"model.max_cell={TWO_PHASE_MAX_CELL!r}", "model.adaptive_dt=true", "time.dt=5e-3",
        f"time.end_time={end_time!r}"])


def two_phase_end(row: dict) -> float:
    """The two-phase rung's end time from the 2D rung's row: the 2D end time where the 2D run
    stopped there (compared at the same time), else from its time at rest."""
    if str(row["status_2d"]).startswith("end_time"):
        return float(row["t_end_2d"])
    return min(TWO_PHASE_MAX_END, max(TWO_PHASE_MIN_END, TWO_PHASE_END_FACTOR * float(row["t_end_2d"])))


def front_stop_time(t: np.ndarray, front: np.ndarray, still: float = TWO_PHASE_FRONT_STILL) -> float:
    """The first time after which |front − front(end)| ≤ ``still`` for good (NaN: no rows)."""
    if not len(t):
        return math.nan
    moving = np.nonzero(np.abs(front - front[-1]) > still)[0]   # never the last row
    return float(t[moving[-1] + 1]) if len(moving) else float(t[0])


# ----------------------------------------------------------------------------- runs
@dataclass
class Rung:
    """What one rung gives: status, cost, final profile on the SH grid, front history."""

    status: str
    t_end: float
    steps: int
    wall: float
    cpu: float
    h: np.ndarray
    front_history: np.ndarray          # (n, 2): t, x_f
    extra: dict = field(default_factory=dict)


#: The file the ladder writes into each run directory it makes under --work: only a folder
#: that holds it is the ladder's to clear (a user's folder of a case's name is never touched).
WORK_MARK = ".dpcollapse-ladder"


class NotTheLaddersError(ConfigError):
    """A folder under --work of a case's name that the ladder did not make (exit 2)."""


def check_work_dir(run_dir: Path) -> None:
    """ConfigError (exit 2) when ``run_dir`` exists and is not the ladder's (no WORK_MARK):
    a file, a link, or a folder with anything in it."""
    if not (run_dir.exists() or run_dir.is_symlink()):
        return
    ours = run_dir.is_dir() and not run_dir.is_symlink() and (run_dir / WORK_MARK).is_file()
    if ours or (run_dir.is_dir() and not run_dir.is_symlink() and not any(run_dir.iterdir())):
        return
    raise NotTheLaddersError(f"--work = {run_dir.parent}: {run_dir.name} exists and was not made by the "
                      f"ladder (no {WORK_MARK} in it); move it, or choose another --work")


def claim_work_dir(run_dir: Path) -> None:
    """Make ``run_dir`` ready for a rung: a folder the ladder made before loses the files a run
    writes (``io.rundir.remove_run_files``, as ``run --overwrite``: nothing else); a folder it
    did not make is refused (``check_work_dir``); the marker is written into it."""
    from dpcollapse.io.rundir import remove_run_files

    check_work_dir(run_dir)
    if run_dir.is_dir():
        remove_run_files(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / WORK_MARK).write_text("made by dpcollapse ladder: its run files are replaced when "
                                     "the case runs again\n")


def run_2d(cfg: Config, run_dir: Path, grid: Grid) -> Rung:
    """The 2D run (``Simulation``, as ``dpcollapse run``); a failure is a result."""
    from dpcollapse.ale.remesh import boundary_polygon
    from dpcollapse.errors import ConvergenceError, MeshError
    from dpcollapse.io.diagnostics import read_diagnostics
    from dpcollapse.simulation import Simulation

    claim_work_dir(run_dir)
    t0, c0 = time.perf_counter(), time.process_time()
    sim = Simulation(cfg, run_dir, quiet=True)
    try:
        summary = sim.run()
        status = summary["status"]
    except (ConvergenceError, MeshError) as exc:
        summary = {"remeshes": sim.state.remeshes, "area_drift": math.nan, "front": math.nan}
        status = f"failed: {exc}"
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    poly = boundary_polygon(sim.disc.tagged).polygon.points
    diag = read_diagnostics(run_dir / "diagnostics.csv")
    history = np.column_stack([[0.0] + diag.get("t", []),
                               [cfg.geometry.base_length] + diag.get("front", [])])
    return Rung(status=status, t_end=float(sim.state.t), steps=int(sim.state.step), wall=wall, cpu=cpu,
                h=polygon_cell_averages(poly, grid), front_history=history,
                extra={"remeshes": summary.get("remeshes", 0), "area_drift": summary["area_drift"],
                       "front_mesh": float(np.max(poly[:, 0]))})


def run_two_phase(cfg: Config, run_dir: Path, grid: Grid) -> Rung:
    """The two-phase run of a ``two_phase_config``; its deposit h(x) = ∫ c dy of the box's
    columns of cells, interpolated to the depth-averaged grid, and its mass front (the
    furthest cell with c > ``model.fraction_threshold``); a failure is a result."""
    from dpcollapse.errors import ConvergenceError, MeshError
    from dpcollapse.io.diagnostics import read_diagnostics
    from dpcollapse.simulation import Simulation

    claim_work_dir(run_dir)
    t0, c0 = time.perf_counter(), time.process_time()
    sim = Simulation(cfg, run_dir, quiet=True)
    try:
        status = sim.run()["status"]
    except (ConvergenceError, MeshError) as exc:
        status = f"failed: {exc}"
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    columns = sim.disc.thickness()
    centers = (np.arange(len(columns)) + 0.5) * sim.disc.dx_bin
    diag = read_diagnostics(run_dir / "diagnostics.csv")
    t, front = np.asarray(diag.get("t", [])), np.asarray(diag.get("front", []))
    history = np.column_stack([np.r_[0.0, t], np.r_[cfg.geometry.base_length, front]])
    return Rung(status=status, t_end=float(sim.state.t), steps=int(sim.state.step), wall=wall,
                cpu=cpu, h=np.interp(grid.centers, centers, columns, right=0.0),
                front_history=history,
                extra={"front": float(sim.disc.measures()["front"]),
                       "front_stop": front_stop_time(t, front),
                       "max_speed": float(np.max(diag["max_speed"])) if len(t) else math.nan,
                       "cell": cfg.model.min_cell})


def two_phase_rung(case: Case, row: dict, work: Path, dx: float,
                   cells_across: int = TWO_PHASE_CELLS_ACROSS_L0) -> tuple[dict, list[tuple]]:
    """The two-phase rung of a case whose 2D and depth-averaged rungs are in ``row``:
    (CSV columns, series rows). Its runout is that of the mass front (cells with c > ½, the
    interface of Lagrée et al. 2011): the light fluid spreads a haze of c ahead of it that
    the 2D rung's 1 mm profile threshold would count (``runout_tp_profile``: that threshold on
    the two-phase profile, for reference). The peak speed of the granular cells is set
    against Ritter's inviscid front speed 2 √(g H0) (an upper bound for a frictional collapse)."""
    cfg = case.load()
    _, grid, _, _ = sh_problem(cfg, dx, case.sh_x_max)
    tp = run_two_phase(two_phase_config(cfg, grid, two_phase_end(row), cells_across),
                       work / f"{case.name}_tp", grid)
    l0 = cfg.geometry.base_length
    runout = tp.extra["front"] - l0
    height = float(tp.h.max())
    status = tp.status
    if tp.h[-1] > 1e-6:
        status += f" (reached x_max = {grid.x_max:g} m: not comparable)"
    g = cfg.geometry
    cols = {"status_tp": status, "t_end_tp": tp.t_end, "steps_tp": tp.steps,
            "cell_tp": tp.extra["cell"], "cpu_tp_s": tp.cpu, "wall_tp_s": tp.wall,
            "front_stop_tp": tp.extra["front_stop"], "runout_tp": runout, "height_tp": height,
            "runout_diff_tp": _rel(runout, row["runout_2d"]),
            "height_diff_tp": _rel(height, row["height_2d"]), "max_speed_tp": tp.extra["max_speed"],
            "runout_tp_profile": front_position(tp.h, grid, FRONT_THRESHOLD) - l0,
            "ritter_speed": 2.0 * math.sqrt(cfg.material.gravity * math.cos(math.radians(g.bed_angle))
                                            * g.height)}
    series = [(case.name, "tp", "front", t, x) for t, x in tp.front_history]
    series += [(case.name, "tp", "profile", x, h) for x, h in zip(grid.centers, tp.h)]
    return cols, series


def run_sh(model: SavageHutter, grid: Grid, poly, end_time: float) -> Rung:
    """The Savage–Hutter run from the exact cell averages of the 2D initial polygon."""
    h0 = polygon_cell_averages(poly, grid)
    t0, c0 = time.perf_counter(), time.process_time()
    res = simulate(model, grid, h0, [end_time])
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    s = res.series
    mass_error = abs(res.mass[-1] + s["outflow"][-1] - polygon_area(poly)) / polygon_area(poly)
    status = "at_rest" if res.rest_time is not None else "end_time"
    return Rung(status=status, t_end=res.rest_time if res.rest_time is not None else end_time,
                steps=res.steps, wall=wall, cpu=cpu, h=res.h[-1],
                front_history=np.column_stack([s["t"], s["front"]]),
                extra={"mass_error": float(mass_error), "outflow": float(s["outflow"][-1])})


def k_variants(cfg: Config, case: Case, dx: float, end_time: float, runout_2d: float,
               height_2d: float) -> tuple[dict, list[tuple]]:
    """The depth-averaged rung with Savage–Hutter's K (``model.earth_pressure: savage_hutter``)
    and with a constant Rankine active K (the K hypothesis), compared with the 2D runout and
    deposit height: (CSV columns, profile series). A run whose mass reaches the end of the
    domain is run again on a domain twice as long (at most twice)."""
    import dataclasses

    from dpcollapse.models.savage_hutter import EarthPressure
    from dpcollapse.models.savage_hutter.earth_pressure import savage_hutter_coefficients

    geo = cfg.geometry
    x_max = case.sh_x_max if case.sh_x_max is not None else geo.base_length + 6.0 * geo.height + 0.2
    k_rankine = savage_hutter_coefficients(cfg.material.friction_angle, 0.0)[0]
    l0 = geo.base_length
    cols = {"k_rankine": k_rankine}
    series = []
    for tag in ("k", "ka"):
        for longer in (1, 2, 4):
            sh_cfg = with_overrides(
                sh_config(cfg, dx, longer * x_max), ["model.earth_pressure=savage_hutter"]
            )
            setup = setup_from_config(sh_cfg)
            ep = setup.model.earth_pressure
            earth = ep if tag == "k" else EarthPressure(k_rankine, k_rankine)
            sh = run_sh(dataclasses.replace(setup.model, earth_pressure=earth), setup.grid,
                        setup.vertices, end_time)
            reached = sh.h[-1] > 1e-6 or sh.extra["outflow"] > 1e-9
            if not reached:
                break
        cols.update({"k_act": ep.k_active, "k_pass": ep.k_passive})
        runout = front_position(sh.h, setup.grid, FRONT_THRESHOLD) - l0
        height = float(sh.h.max())
        status = sh.status
        if reached:
            status += f" (reached x_max = {setup.grid.x_max:g} m: not comparable)"
        cols.update({f"status_sh_{tag}": status, f"runout_sh_{tag}": runout,
                     f"height_sh_{tag}": height, f"runout_diff_{tag}": _rel(runout, runout_2d),
                     f"height_diff_{tag}": _rel(height, height_2d)})
        if tag == "k":
            cols["cpu_sh_k"] = sh.cpu
        series += [(case.name, f"sh_{tag}", "profile", x, h) for x, h in zip(setup.grid.centers, sh.h)]
    return cols, series


def _rel(a: float, b: float) -> float:
    return (a - b) / abs(b) if b else math.nan


def compare(case: Case, work: Path, dx: float) -> tuple[dict, list[tuple]]:
    """Run both rungs of one case; (CSV row, series rows)."""
    cfg = case.load()
    model, grid, poly, friction = sh_problem(cfg, dx, case.sh_x_max)
    two = run_2d(cfg, work / case.name, grid)
    sh_end = two.t_end if two.status == "end_time" else SH_MAX_TIME
    sh = run_sh(model, grid, poly, sh_end)
    l0 = cfg.geometry.base_length
    front_2d = front_position(two.h, grid, FRONT_THRESHOLD)
    front_sh = front_position(sh.h, grid, FRONT_THRESHOLD)
    runout_2d, runout_sh = front_2d - l0, front_sh - l0
    height_2d, height_sh = float(two.h.max()), float(sh.h.max())
    l1 = float(np.sum(np.abs(sh.h - two.h)) * grid.dx)
    area = polygon_area(poly)
    rd, hd = _rel(runout_sh, runout_2d), _rel(height_sh, height_2d)
    for rung, h in ((two, two.h), (sh, sh.h)):
        if h[-1] > 1e-6 or rung.extra.get("outflow", 0.0) > 1e-9:   # the mass reached x_max
            rung.status += f" (reached x_max = {grid.x_max:g} m: not comparable)"
    row = {
        "case": case.name, "group": case.group, "param": case.param, "config": case.config,
        "overrides": " ".join(case.overrides), "mesh_size_2d": cfg.geometry.mesh_size,
        "sh_dx": grid.dx, "sh_order": model.order, "sh_friction": f"{friction} {model.basal}",
        "status_2d": two.status, "t_end_2d": two.t_end, "steps_2d": two.steps,
        "remeshes_2d": two.extra["remeshes"], "wall_2d_s": two.wall, "cpu_2d_s": two.cpu,
        "front_2d_mesh": two.extra["front_mesh"], "front_2d": front_2d, "runout_2d": runout_2d,
        "height_2d": height_2d, "area_drift_2d": two.extra["area_drift"],
        "status_sh": sh.status, "t_end_sh": sh.t_end, "steps_sh": sh.steps, "wall_sh_s": sh.wall,
        "cpu_sh_s": sh.cpu,
        "front_sh": front_sh, "runout_sh": runout_sh, "height_sh": height_sh,
        "mass_error_sh": sh.extra["mass_error"],
        "runout_diff": rd, "height_diff": hd, "l1_diff_m2": l1, "l1_rel": l1 / area,
        "cost_ratio": two.wall / sh.wall, "cost_ratio_cpu": two.cpu / sh.cpu,
        "within_5pct": bool(abs(rd) <= WITHIN and abs(hd) <= WITHIN),
        "l1_sh_exact_m2": math.nan, "l1_2d_exact_m2": math.nan, "front_exact": math.nan,
    }
    series = [(case.name, "2d", "front", t, x) for t, x in two.front_history]
    series += [(case.name, "sh", "front", t, x) for t, x in _thin(sh.front_history, 400)]
    series += [(case.name, "2d", "profile", x, h) for x, h in zip(grid.centers, two.h)]
    series += [(case.name, "sh", "profile", x, h) for x, h in zip(grid.centers, sh.h)]
    if case.group == "dam_break":
        row.update(_against_mangeney(cfg, grid, two, sh, series, case.name))
    cols, more = k_variants(cfg, case, dx, sh_end, runout_2d, height_2d)
    row.update(cols)
    return row, series + more


def _against_mangeney(cfg: Config, grid: Grid, two: Rung, sh: Rung, series: list, name: str) -> dict:
    """L1 errors of both rungs against Mangeney et al. (2000) where the wall has not reached."""
    geo = cfg.geometry
    t = sh.t_end
    theta = math.radians(geo.bed_angle)
    g_cos = cfg.material.gravity * math.cos(theta)
    c0 = math.sqrt(g_cos * geo.height)
    m = cfg.material.gravity * math.sin(theta) - g_cos * cfg.boundary.mu_bed
    x = grid.centers
    h_exact, _ = mangeney_dam_break(x - geo.base_length, t, geo.height, geo.bed_angle,
                                    cfg.boundary.bed_friction_angle, cfg.material.gravity)
    valid = x >= m * t * t / 2 + c0 * t       # not reached by the wall's rarefaction
    series += [(name, "exact", "profile", xi, hi) for xi, hi in zip(x[valid], h_exact[valid])]
    ts = np.linspace(1e-6, t, 100)      # the 1 mm front: h = 1 mm in the fan
    tip_1mm = geo.base_length + m * ts**2 / 2 + 2 * c0 * ts - 3 * ts * math.sqrt(g_cos * FRONT_THRESHOLD)
    series += [(name, "exact", "front", ti, xi) for ti, xi in zip(ts, tip_1mm)]
    return {"l1_sh_exact_m2": float(np.sum(np.abs(sh.h - h_exact)[valid]) * grid.dx),
            "l1_2d_exact_m2": float(np.sum(np.abs(two.h - h_exact)[valid]) * grid.dx),
            "front_exact": float(tip_1mm[-1])} if t < geo.base_length / (2 * c0) else {}


def _thin(a: np.ndarray, n: int) -> np.ndarray:
    """At most about n rows of a (first and last kept)."""
    if len(a) <= n:
        return a
    idx = np.unique(np.r_[np.linspace(0, len(a) - 1, n).astype(int), len(a) - 1])
    return a[idx]


# ----------------------------------------------------------------------------- files
SERIES_COLUMNS = ["case", "rung", "kind", "x", "y"]


def _csv_rows(path: Path, required: list[str]) -> list[dict]:
    """The rows of one of the ladder's CSV files; one that is not (no header with the
    ``required`` columns, unreadable text) is ConfigError naming it (exit 2)."""
    try:
        with path.open(newline="") as fh:
            reader = csv.DictReader(fh)
            missing = [c for c in required if c not in (reader.fieldnames or [])]
            rows = [] if missing else list(reader)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ConfigError(f"{path}: cannot be read ({exc}); delete it to run the cases "
                          "again") from None
    if missing:
        more = f" and {len(missing) - 3} more" if len(missing) > 3 else ""
        raise ConfigError(f"{path}: not a ladder table (no column {', '.join(missing[:3])}{more}); "
                          "delete it to run the cases again")
    return rows


#: The columns of ladder.csv that hold text; the others hold numbers (nan for a failed rung).
TEXT_COLUMNS = ("case", "group", "param", "config", "overrides", "sh_friction", "status_2d",
                "status_sh", "within_5pct", "status_sh_k", "status_sh_ka", "status_tp")
#: Every row has the 2D and depth-averaged rungs' columns; the K variants' and the two-phase
#: rung's are all empty (not run yet) or all filled.
CORE_COLUMNS = COLUMNS[:COLUMNS.index("k_act")]
OPTIONAL_GROUPS = (COLUMNS[COLUMNS.index("k_act"):COLUMNS.index("status_tp")],
                   COLUMNS[COLUMNS.index("status_tp"):])


def read_rows(path: Path) -> list[dict]:
    """The rows of ladder.csv (numbers as floats), in the order of the file; columns a user
    added are kept as read. A table that is not the ladder's (a missing column, a number
    column that does not parse) is ConfigError naming the file, the row and the column."""
    if not path.exists():
        return []
    rows = _csv_rows(path, CORE_COLUMNS)
    for i, r in enumerate(rows):
        for k, v in r.items():
            try:
                r[k] = float(v)
            except (TypeError, ValueError):
                pass
        _check_row(path, i, r)
    return rows


def _check_row(path: Path, i: int, row: dict) -> None:
    """ConfigError unless ``row`` (numbers already parsed) has numbers where the ladder
    writes them: in every core column, and in a K or two-phase group that is filled."""
    def bad(column: str) -> ConfigError:
        return ConfigError(f"{path}: not a ladder table (row {i + 2}, column {column} = "
                           f"{str(row.get(column))[:30]!r} is not a number); delete it to run the "
                           "cases again")

    for column in CORE_COLUMNS:
        if column not in TEXT_COLUMNS and not isinstance(row.get(column), float):
            raise bad(column)
    for group in OPTIONAL_GROUPS:
        numbers = [c for c in group if c not in TEXT_COLUMNS]
        if all(row.get(c) in ("", None) for c in numbers):
            continue
        for column in numbers:
            if not isinstance(row.get(column), float):
                raise bad(column)


def read_series(path: Path) -> dict:
    """{(case, rung, kind): (n, 2) array} from ladder_series.csv."""
    out: dict = {}
    if not path.exists():
        return out
    for i, r in enumerate(_csv_rows(path, SERIES_COLUMNS)):
        try:
            point = (float(r["x"]), float(r["y"]))
        except (TypeError, ValueError):
            raise ConfigError(f"{path}: row {i + 2}: x, y must be numbers; delete the file to "
                              "run the cases again") from None
        out.setdefault((r["case"], r["rung"], r["kind"]), []).append(point)
    return {k: np.asarray(v) for k, v in out.items()}


def write_results(out: Path, rows: list[dict], series: list[tuple], stem: str = "ladder") -> None:
    """Rewrite STEM.csv and STEM_series.csv whole (rows in plan order; the columns a user
    added to STEM.csv kept, after the ladder's)."""
    out.mkdir(parents=True, exist_ok=True)
    extra = list(dict.fromkeys(k for r in rows for k in r if k not in COLUMNS))
    with (out / f"{stem}.csv").open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=COLUMNS + extra)
        w.writeheader()
        for r in rows:
            w.writerow({k: _fmt(r.get(k, "")) for k in COLUMNS + extra})
    with (out / f"{stem}_series.csv").open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(SERIES_COLUMNS)
        w.writerows((c, rung, kind, f"{x:.6g}", f"{y:.6g}") for c, rung, kind, x, y in _trim(series))


def _trim(series: list[tuple]) -> list[tuple]:
    """The series as stored (for the chart): each front history thinned to about 200 points,
    each profile to about 300, cut one cell after its last h > 1 µm (beyond: dry bed, or the
    precursor film of the SH model)."""
    groups: dict = {}
    for row in series:
        groups.setdefault(row[:3], []).append(row)
    out = []
    for (_, _, kind), rows in groups.items():
        if kind == "front":
            out += [rows[i] for i in _thin(np.arange(len(rows)), 200)]
        else:
            wet = [i for i, r in enumerate(rows) if r[4] > 1e-6]
            rows = rows[:(wet[-1] + 2) if wet else 1]
            out += [rows[i] for i in _thin(np.arange(len(rows)), 300)]
    return out


def _fmt(v):
    if isinstance(v, bool):
        return str(v)
    if isinstance(v, float):
        return f"{v:.6g}"
    return v


def _same_case(row: dict, case: Case, dx: float) -> bool:
    return (row.get("case") == case.name and str(row.get("overrides", "")) == " ".join(case.overrides)
            and row.get("config") == case.config and abs(float(row.get("sh_dx", 0)) - dx) < 1e-6 * dx)


# ----------------------------------------------------------------------------- table
def table(rows: list[dict]) -> str:
    """The Markdown table of ladder.csv."""
    head = ("| case | 2D mesh [m] | 2D status | SH status | runout ΔL 2D / SH [m] | Δ runout | "
            "H_f 2D / SH [m] | Δ H_f | L1 [m²] (/area) | CPU 2D / SH [s] | cost ratio CPU (wall) | "
            "within 5 % |")
    lines = [head, "| " + " | ".join(["---"] * 12) + " |"]
    for r in rows:
        lines.append(
            f"| {r['case']} | {r['mesh_size_2d']:g} | {str(r['status_2d'])[:40]} | {r['status_sh']} | "
            f"{r['runout_2d']:.4f} / {r['runout_sh']:.4f} | {100 * r['runout_diff']:+.1f} % | "
            f"{r['height_2d']:.4f} / {r['height_sh']:.4f} | {100 * r['height_diff']:+.1f} % | "
            f"{r['l1_diff_m2']:.2e} ({r['l1_rel']:.2f}) | {r['cpu_2d_s']:.1f} / {r['cpu_sh_s']:.2f} | "
            f"{r['cost_ratio_cpu']:.0f} ({r['cost_ratio']:.0f}) | "
            f"{'yes' if str(r['within_5pct']) == 'True' else 'no'} |"
        )
    return "\n".join(lines)


def k_table(rows: list[dict]) -> str:
    """Markdown: every row's depth-averaged runout and deposit height with K = 1, Savage–Hutter's
    K_act/pass and a constant Rankine K against the 2D ones."""
    lines = [
        "| case | K_act / K_pass (K_R) | ΔL 2D [m] | ΔL SH: K = 1 / SH K / K_R [m] | "
        "Δ runout: K = 1 / SH K / K_R | "
        "Δ H_f: K = 1 / SH K / K_R | SH K status | CPU SH K [s] |",
        "| " + " | ".join(["---"] * 8) + " |",
    ]
    for r in rows:
        if not isinstance(r.get("runout_diff_k"), float):
            continue
        lines.append(
            f"| {r['case']} | {r['k_act']:.3f} / {r['k_pass']:.3f} ({r['k_rankine']:.3f}) | "
            f"{r['runout_2d']:.4f} | "
            f"{r['runout_sh']:.4f} / {r['runout_sh_k']:.4f} / {r['runout_sh_ka']:.4f} | "
            f"{100 * r['runout_diff']:+.1f} / {100 * r['runout_diff_k']:+.1f} / "
            f"{100 * r['runout_diff_ka']:+.1f} % | "
            f"{100 * r['height_diff']:+.1f} / {100 * r['height_diff_k']:+.1f} / "
            f"{100 * r['height_diff_ka']:+.1f} % | "
            f"{str(r['status_sh_k'])[:40]} | {r['cpu_sh_k']:.2f} |"
        )
    return "\n".join(lines)


def tp_table(rows: list[dict]) -> str:
    """Markdown: the two-phase rung against the 2D one (and the depth-averaged, K = 1)."""
    lines = ["| case | cells [mm] | ΔL 2D / two-phase (c > ½) / SH [m] | Δ runout two-phase | "
             "two-phase ΔL at h = 1 mm [m] | H_f 2D / two-phase [m] | Δ H_f | front stops at [s] "
             "(2D at rest) | peak speed / 2√(gH0) | CPU 2D / two-phase [s] | two-phase status |",
             "| " + " | ".join(["---"] * 11) + " |"]
    for r in rows:
        if not isinstance(r.get("runout_tp"), float):
            if str(r.get("status_tp", "")).startswith("refused"):
                lines.append(f"| {r['case']} | – | – | – | – | – | – | – | – | – | {r['status_tp']} |")
            continue
        lines.append(
            f"| {r['case']} | {1e3 * r['cell_tp']:.1f} | {r['runout_2d']:.4f} / {r['runout_tp']:.4f} / "
            f"{r['runout_sh']:.4f} | {100 * r['runout_diff_tp']:+.1f} % | "
            f"{r['runout_tp_profile']:.4f} | {r['height_2d']:.4f} / "
            f"{r['height_tp']:.4f} | {100 * r['height_diff_tp']:+.1f} % | {r['front_stop_tp']:.2f} "
            f"({r['t_end_2d']:.2f}) | {r['max_speed_tp']:.2f} / {r['ritter_speed']:.2f} m/s | "
            f"{r['cpu_2d_s']:.0f} / {r['cpu_tp_s']:.0f} | {str(r['status_tp'])[:40]} |")
    return "\n".join(lines)


def _save(fig, axes, path: Path) -> None:
    """Grid every panel, write the figure to ``path`` and close it."""
    import matplotlib.pyplot as plt

    for ax in axes.flat:
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_two_phase(rows: list[dict], series: dict, path: Path) -> None:
    """ladder_two_phase.png: runout and deposit height of the two-phase rung against the 2D
    one (columns: against a), fronts against time, and the deposits of three columns."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    ax = axes[0]
    for group, marker, label in (("column", "o", "Drucker–Prager, Coulomb bed"),
                                 ("mu_i", "s", "μ(I)")):
        sel = sorted((r for r in rows if r["group"] == group and isinstance(r.get("runout_tp"), float)),
                     key=lambda r: r["param"])
        if not sel:
            continue
        a = [r["param"] for r in sel]
        ax.plot(a, [100 * r["runout_diff_tp"] for r in sel], marker + "-", color=colors[0],
                label=f"runout, {label}")
        ax.plot(a, [100 * r["height_diff_tp"] for r in sel], marker + "--", color=colors[1],
                label=f"H_f, {label}")
        ax.plot(a, [100 * r["runout_diff"] for r in sel], marker + ":", color=colors[2],
                label=f"runout SH (K = 1), {label}")
    ax.axhspan(-100 * WITHIN, 100 * WITHIN, color="0.85", zorder=0)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlabel("column aspect ratio a = H0/L0")
    ax.set_ylabel("(rung − 2D)/2D [%]")
    ax.set_title("two-phase (and depth-averaged) against the 2D moving mesh", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[1]
    names = [n for n in ("column_a2", "column_a2_mui", "rigid", "column_a6") if n in
             {r["case"] for r in rows if isinstance(r.get("runout_tp"), float)}]
    by = {r["case"]: r for r in rows}
    for i, name in enumerate(names):
        for rung, style, label in (("2d", "-", "2D"), ("tp", "--", "two-phase")):
            s = series.get((name, rung, "front"))
            if s is not None:
                ax.plot(s[:, 0], s[:, 1] - _l0(by[name]), style, color=colors[i], label=f"{name} {label}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("front − L0 [m]")
    ax.set_title("fronts (2D: mesh tip; two-phase: cells with c > ½)", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[2]
    for i, name in enumerate(names):
        for rung, style, label in (("2d", "-", "2D"), ("tp", "--", "two-phase"), ("sh", ":", "SH")):
            s = series.get((name, rung, "profile"))
            if s is not None:
                ax.plot(s[:, 0], s[:, 1], style, color=colors[i], label=f"{name} {label}")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("final thickness h [m]")
    ax.set_xlim(left=0)
    ax.set_title("deposits", fontsize=9)
    ax.legend(fontsize=6)
    _save(fig, axes, path)


# ----------------------------------------------------------------------------- shallow limit
#: The depth-averaged variants of a row: (label, runout-difference column, height column).
VARIANTS = (("K = 1", "runout_diff", "height_diff"), ("SH K", "runout_diff_k", "height_diff_k"),
            ("K = K_Rankine", "runout_diff_ka", "height_diff_ka"))
TOLERANCES = (0.05, 0.10)
#: The two-phase rung of a row (``ladder --shallow --two-phase``), as a variant.
TP_VARIANT = ("two-phase", "runout_diff_tp", "height_diff_tp")


def _variants(rows: list[dict]) -> tuple:
    """The depth-averaged variants, and the two-phase rung where any row has it."""
    has_tp = any(isinstance(r.get("runout_diff_tp"), float) for r in rows)
    return VARIANTS + ((TP_VARIANT,) if has_tp else ())


def eps_threshold(rows: list[dict], column: str, tol: float) -> str:
    """The largest ε of the family below which (at every ε' ≤ ε measured) |column| ≤ tol:
    "all (≤ 0.5)" when every ε passes, "none" (with the smallest ε's difference) when the
    thinnest fails. Rows whose 2D run failed break the chain."""
    rows = sorted(rows, key=lambda r: r["param"])
    best = None
    for r in rows:
        v = r.get(column)
        if not isinstance(v, float) or math.isnan(v) or abs(v) > tol or "failed" in str(r["status_2d"]):
            break
        best = r["param"]
    if best is None:
        v = rows[0].get(column) if rows else math.nan
        return f"none ({100 * v:+.0f} % at ε = {rows[0]['param']:g})" if rows else "—"
    return f"all (≤ {best:g})" if best == rows[-1]["param"] else f"≤ {best:g}"


def _groups(rows: list[dict]) -> dict:
    out: dict = {}
    for r in rows:
        out.setdefault(r["group"], []).append(r)
    return out


def threshold_table(rows: list[dict]) -> str:
    """Markdown: per family (bed and law) and depth-averaged variant (and the two-phase rung
    where it ran), the ε below which its runout is within 5 % and 10 % of the 2D one."""
    lines = ["| family | depth-averaged K (or two-phase) | runout within 5 % for ε | "
             "within 10 % for ε | Δ runout (ε: rung vs 2D) |",
             "| --- | --- | --- | --- | --- |"]
    for group, members in _groups(rows).items():
        members = sorted(members, key=lambda r: r["param"])
        for label, col, _ in _variants(members):
            diffs = ", ".join(f"{r['param']:g}: {100 * r[col]:+.0f} %" if isinstance(r.get(col), float)
                              else f"{r['param']:g}: —" for r in members)
            lines.append(f"| {group} | {label} | {eps_threshold(members, col, 0.05)} | "
                         f"{eps_threshold(members, col, 0.10)} | {diffs} |")
    return "\n".join(lines)


def shallow_table(rows: list[dict]) -> str:
    """Markdown: every ε row — runouts, deposit heights, differences with K = 1, Savage–Hutter
    K and Rankine K, CPU times."""
    lines = ["| case | ε | 2D cells across H | 2D status | ΔL 2D [m] | ΔL SH K=1 / SH K / K_R [m] | "
             "Δ runout K=1 / SH K / K_R | H_f 2D [m] | Δ H_f K=1 / SH K / K_R | CPU 2D / SH [s] |",
             "| " + " | ".join(["---"] * 10) + " |"]
    for r in rows:
        cells = SHALLOW_H / r["mesh_size_2d"] if "shallow" in str(r["group"]) else math.nan
        lines.append(
            f"| {r['case']} | {r['param']:g} | {cells:.0f} | {str(r['status_2d'])[:30]} | "
            f"{r['runout_2d']:.4f} | {r['runout_sh']:.4f} / {r['runout_sh_k']:.4f} / "
            f"{r['runout_sh_ka']:.4f} | {100 * r['runout_diff']:+.1f} / {100 * r['runout_diff_k']:+.1f} / "
            f"{100 * r['runout_diff_ka']:+.1f} % | {r['height_2d']:.4f} | {100 * r['height_diff']:+.1f} / "
            f"{100 * r['height_diff_k']:+.1f} / {100 * r['height_diff_ka']:+.1f} % | "
            f"{r['cpu_2d_s']:.1f} / {r['cpu_sh_s']:.2f} |")
    return "\n".join(lines)


def _eps_axis(ax) -> None:
    """A log ε axis with the family's ε as ticks."""
    ax.set_xscale("log")
    ax.set_xticks(sorted(SHALLOW_EPS))
    ax.set_xticklabels([f"{e:g}" for e in sorted(SHALLOW_EPS)])
    ax.minorticks_off()
    ax.set_xlabel("aspect ratio ε = H/L0")


def plot_shallow(rows: list[dict], series: dict, path: Path) -> None:
    """ladder_shallow.png: runout and deposit-height differences against ε per family and K
    (grey bands ±5 %, ±10 %), ΔL/H against ε, and the thinnest deposits."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = _groups(rows)
    fig, axes = plt.subplots(2, 2, figsize=(13, 9))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles = {"K = 1": "o-", "SH K": "s--", "K = K_Rankine": "^:", "two-phase": "x-."}
    for ax, which, title in ((axes[0, 0], 1, "runout: (rung − 2D)/2D, rung = SH or two-phase"),
                             (axes[0, 1], 2, "deposit height H_f: (rung − 2D)/2D")):
        for i, (group, members) in enumerate(groups.items()):
            members = sorted(members, key=lambda r: r["param"])
            for variant in _variants(members):
                vals = [100 * r[variant[which]] if isinstance(r.get(variant[which]), float) else np.nan
                        for r in members]
                ax.plot([r["param"] for r in members], vals, styles[variant[0]],
                        color=colors[i % len(colors)], label=f"{group}, {variant[0]}")
        ax.axhspan(-10, 10, color="0.92", zorder=0)
        ax.axhspan(-5, 5, color="0.82", zorder=0)
        ax.axhline(0, color="k", lw=0.5)
        _eps_axis(ax)
        ax.set_ylabel("[%]")
        ax.set_title(title + " (bands ±5 %, ±10 %)", fontsize=9)
        ax.legend(fontsize=6, ncol=2)
    ax = axes[1, 0]
    for i, (group, members) in enumerate(groups.items()):
        members = sorted(members, key=lambda r: r["param"])
        eps = [r["param"] for r in members]
        ax.plot(eps, [r["runout_2d"] / SHALLOW_H for r in members], "o-", color=colors[i % len(colors)],
                label=f"{group} 2D")
        ax.plot(eps, [r["runout_sh"] / SHALLOW_H for r in members], "o--", color=colors[i % len(colors)],
                label=f"{group} SH K=1")
        ax.plot(eps, [r["runout_sh_k"] / SHALLOW_H for r in members], "s:", color=colors[i % len(colors)],
                label=f"{group} SH K")
        if TP_VARIANT in _variants(members):
            ax.plot(eps, [r["runout_tp"] / SHALLOW_H if isinstance(r.get("runout_tp"), float)
                               else np.nan for r in members], "x-.",
                    color=colors[i % len(colors)], label=f"{group} two-phase")
    ax.set_yscale("log")
    _eps_axis(ax)
    ax.set_ylabel("runout ΔL / H")
    ax.set_title(f"runout (H = {SHALLOW_H:g} m, L0 = H/ε)", fontsize=9)
    ax.legend(fontsize=6, ncol=2)
    ax = axes[1, 1]
    thinnest = [min(m, key=lambda r: r["param"]) for m in groups.values()]
    for i, r in enumerate(thinnest):
        for rung, style, label in (("2d", "-", "2D"), ("sh", "--", "SH K=1"), ("sh_k", ":", "SH K"),
                                   ("tp", "-.", "two-phase")):
            s = series.get((r["case"], rung, "profile"))
            if s is not None:
                ax.plot(s[:, 0] - _l0(r), s[:, 1], style, color=colors[i % len(colors)],
                        label=f"{r['case']} {label}")
    ax.set_xlabel("x − L0 [m]")
    ax.set_ylabel("final thickness h [m]")
    ax.set_xlim(-0.3, None)
    ax.set_title("deposits of the thinnest masses near the front", fontsize=9)
    ax.legend(fontsize=6)
    _save(fig, axes, path)


# ----------------------------------------------------------------------------- chart
def plot(rows: list[dict], series: dict, path: Path) -> None:
    """ladder.png: fronts against time, deposits, the aspect-ratio and slope sweeps, cost."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    by = {r["case"]: r for r in rows}
    fig, axes = plt.subplots(2, 3, figsize=(15, 8.5))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]

    ax = axes[0, 0]
    for i, name in enumerate(n for n in ("rigid", "rigid_slope10", "rigid_slope20", "column_a1",
                                         "column_a2", "column_a6", "column_a2_quick") if n in by):
        for rung, style in (("2d", "-"), ("sh", "--")):
            s = series.get((name, rung, "front"))
            if s is not None:
                ax.plot(s[:, 0], s[:, 1] - _l0(by[name]),
                        style, color=colors[i % len(colors)],
                        label=f"{name} {'2D' if rung == '2d' else 'SH'}")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("front − L0 [m]")
    ax.set_title("front against time (2D: mesh tip; SH: 1 mm)", fontsize=9)
    ax.legend(fontsize=6, ncol=2)

    ax = axes[0, 1]
    for i, name in enumerate(n for n in ("dam_break_slope22",) if n in by):
        for rung, style, label in (("2d", "-", "2D"), ("sh", "--", "SH"), ("exact", ":", "exact (1 mm)")):
            s = series.get((name, rung, "front"))
            if s is not None:
                ax.plot(s[:, 0], s[:, 1], style, color="k" if rung == "exact" else colors[i], label=label)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("front [m]")
    ax.set_title("dam break on a 22° slope (δ = 21°): front", fontsize=9)
    if ax.get_legend_handles_labels()[0]:       # no dam break in a --quick ladder
        ax.legend(fontsize=7)

    ax = axes[0, 2]
    for i, name in enumerate(n for n in ("rigid", "column_a2", "column_a6", "dam_break_slope22",
                                         "column_a2_quick") if n in by):
        for rung, style in (("2d", "-"), ("sh", "--"), ("exact", ":")):
            s = series.get((name, rung, "profile"))
            if s is not None:
                ax.plot(s[:, 0], s[:, 1], style, color="k" if rung == "exact" else colors[i % len(colors)],
                        label=f"{name} {dict(sh='SH', exact='exact').get(rung, '2D')}")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("final thickness h [m]")
    ax.set_xlim(left=0)
    ax.set_title("deposits (dam break: at t = 0.5 s)", fontsize=9)
    ax.legend(fontsize=6)

    ax = axes[1, 0]
    col = sorted((r for r in rows if r["group"] == "column"), key=lambda r: r["param"])
    if col:
        a = [r["param"] for r in col]
        l0 = [r["front_2d"] - r["runout_2d"] for r in col]
        ax.plot(a, [r["runout_2d"] / x for r, x in zip(col, l0)], "o-", color=colors[0], label="ΔL/L0 2D")
        ax.plot(a, [r["runout_sh"] / x for r, x in zip(col, l0)], "o--", color=colors[0], label="ΔL/L0 SH")
        ax.plot(a, [r["height_2d"] / x for r, x in zip(col, l0)], "s-", color=colors[1], label="H_f/L0 2D")
        ax.plot(a, [r["height_sh"] / x for r, x in zip(col, l0)], "s--", color=colors[1], label="H_f/L0 SH")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xticks(a)
        ax.set_xticklabels([f"{v:g}" for v in a])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("aspect ratio a = H0/L0")
    ax.set_title("column collapse, Coulomb bed μ = tan 25.5°", fontsize=9)
    ax.legend(fontsize=7)

    ax = axes[1, 1]
    col = sorted((r for r in rows if r["group"] == "column"), key=lambda r: r["param"])
    ax.plot([r["param"] for r in col], [100 * r["runout_diff"] for r in col], "o-", color=colors[0],
            label="runout ΔL, column (bottom axis: a)")
    ax.plot([r["param"] for r in col], [100 * r["height_diff"] for r in col], "s-", color=colors[1],
            label="H_f, column (bottom axis: a)")
    for col_name, style, label in (("runout_diff_k", "o-.", "runout ΔL, column, SH K = 1.455"),
                                   ("runout_diff_ka", "o-.", "runout ΔL, column, K = K_Rankine 0.398")):
        pts = [(r["param"], 100 * r[col_name]) for r in col if isinstance(r.get(col_name), float)]
        if pts:
            ax.plot(*zip(*pts), style, color=colors[6] if col_name.endswith("_k") else colors[7],
                    label=label)
    mui = sorted((r for r in rows if r["group"] == "mu_i"), key=lambda r: r["param"])
    ax.plot([r["param"] for r in mui], [100 * r["runout_diff"] for r in mui], "o:", color=colors[4],
            label="runout ΔL, column μ(I) (bottom axis: a)")
    ax.plot([r["param"] for r in mui], [100 * r["height_diff"] for r in mui], "s:", color=colors[5],
            label="H_f, column μ(I) (bottom axis: a)")
    ax.set_xlabel("column aspect ratio a = H0/L0")
    top = ax.twiny()
    slope = sorted((r for r in rows if r["group"] in ("rigid", "slope")), key=lambda r: r["param"])
    top.plot([r["param"] for r in slope], [100 * r["runout_diff"] for r in slope], "o--",
             color=colors[2], label="runout ΔL, trapezoid (top axis: θ)")
    top.plot([r["param"] for r in slope], [100 * r["height_diff"] for r in slope], "s--",
             color=colors[3], label="H_f, trapezoid (top axis: θ)")
    top.set_xlabel("bed angle θ of the rigid-bed trapezoid [deg]", fontsize=8)
    ax.axhspan(-100 * WITHIN, 100 * WITHIN, color="0.85", zorder=0)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_ylabel("(SH − 2D)/2D [%]")
    ax.set_title("depth-averaged against 2D (grey band: within 5 %)", fontsize=9, pad=22)
    lines = ax.get_legend_handles_labels()
    more = top.get_legend_handles_labels()
    ax.legend(lines[0] + more[0], lines[1] + more[1], fontsize=7)

    ax = axes[1, 2]
    names = [r["case"] for r in rows]
    pos = np.arange(len(rows))
    ax.bar(pos - 0.2, [r["cost_ratio_cpu"] for r in rows], 0.4, color=colors[2], label="CPU time")
    ax.bar(pos + 0.2, [r["cost_ratio"] for r in rows], 0.4, color=colors[4], label="wall time")
    ax.legend(fontsize=7)
    ax.set_yscale("log")
    ax.set_xticks(range(len(rows)))
    ax.set_xticklabels(names, rotation=60, ha="right", fontsize=7)
    ax.set_ylabel("time 2D / time SH")
    ax.set_title("cost ratio (same process, one run at a time)", fontsize=9)
    _save(fig, axes, path)


def _l0(row: dict) -> float:
    """L0 of a row: front − runout [m]."""
    return row["front_2d"] - row["runout_2d"]


# ----------------------------------------------------------------------------- SH resolution
SH_RESOLUTION_DX = (4e-3, 2e-3, 1e-3, 5e-4)


def sh_resolution(case: Case, end_time: float | None = None) -> list[dict]:
    """The Savage–Hutter side of one case alone at Δx = 4, 2, 1, 0.5 mm: how much of its
    runout and deposit height is resolution (to rest, or to ``end_time``)."""
    cfg = case.load()
    out = []
    for dx in SH_RESOLUTION_DX:
        model, grid, poly, _ = sh_problem(cfg, dx, case.sh_x_max)
        sh = run_sh(model, grid, poly, end_time or SH_MAX_TIME)
        front = front_position(sh.h, grid, FRONT_THRESHOLD)
        out.append({"dx": dx, "status": sh.status, "t_end": sh.t_end, "steps": sh.steps,
                    "wall": sh.wall, "runout": front - cfg.geometry.base_length,
                    "height": float(sh.h.max())})
    return out


# ----------------------------------------------------------------------------- main
def run(quick=False, out="runs/ladder", work="runs/ladder", only=None, redo=False, plot_only=False,
        sh_case=None, echo=print, shallow=False, two_phase=False, cells_across=None) -> int:
    """Run the plan (skipping cases already in the CSV), write the CSVs, the chart, the table.

    ``two_phase``: add the two-phase rung (``two_phase_rung``) to every case of the plan
    whose 2D rung is in the CSV and that has none yet (``redo``: again), except the 2D
    resolution variants; then ladder_two_phase.png and its table. ``cells_across``: its
    cells across L0 (default TWO_PHASE_CELLS_ACROSS_L0; the resolution check).

    ``sh_case``: only the Savage–Hutter side of that case at Δx = 4, 2, 1, 0.5 mm.
    ``shallow``: the ε family (``shallow_plan``) into OUT/ladder_shallow.csv, …_series.csv and
    ladder_shallow.png, and the ε-threshold table.
    A case in the CSV without the K columns gets them (the depth-averaged runs only).
    An unknown case name is a :class:`~dpcollapse.errors.ConfigError` (one line, exit 2)."""
    known = [c.name for c in full_plan() + quick_plan() + shallow_plan()]
    for name in ([sh_case] if sh_case else []) + list(only or []):
        if name not in known:
            raise ConfigError(f"case {name!r}: must be one of {', '.join(dict.fromkeys(known))}")
    if sh_case:
        case = next(c for c in full_plan() + quick_plan() + shallow_plan() if c.name == sh_case)
        end = 0.5 if case.group == "dam_break" else None
        echo("dx [m]   status   t_end [s]  steps  wall [s]  runout [m]  H_f [m]")
        for r in sh_resolution(case, end):
            echo(f"{r['dx']:.4f}  {r['status']:8s} {r['t_end']:8.3f} {r['steps']:6d} {r['wall']:8.2f} "
                 f"{r['runout']:10.4f} {r['height']:8.4f}")
        return 0
    out, work = Path(out), Path(work)
    plan = shallow_plan() if shallow else quick_plan() if quick else full_plan()
    stem = "ladder_shallow" if shallow else "ladder"
    dx = SH_DX_QUICK if quick else SH_DX
    done = {r["case"]: r for r in read_rows(out / f"{stem}.csv")}
    curves: dict = {}
    for (c, rung, kind), arr in read_series(out / f"{stem}_series.csv").items():
        curves.setdefault(c, []).extend((c, rung, kind, x, y) for x, y in arr)

    changed = False

    def save():
        nonlocal changed
        changed = True
        names = [c.name for c in plan if c.name in done]
        names += [n for n in done if n not in names]        # other plans' cases are kept
        write_results(out, [done[n] for n in names], [s for n in names for s in curves.get(n, [])],
                      stem)

    if not plot_only:     # before any run: a user's folder of a case's name is refused
        for case in plan:
            if not only or case.name in only:
                check_work_dir(work / (f"{case.name}_tp" if two_phase else case.name))
    for case in plan:
        old = done.get(case.name)
        fresh = old is not None and _same_case(old, case, dx)
        wanted = not only or case.name in only
        if plot_only or not wanted:
            continue
        if two_phase:
            if case.group == "resolution":
                continue
            if not fresh:
                echo(f"{case.name}: no 2D rung in {out / (stem + '.csv')}: run the ladder first")
                continue
            if isinstance(old.get("runout_tp"), float) and not redo:
                continue
            echo(f"{case.name}: two-phase rung ({case.config} {' '.join(case.overrides)})")
            try:
                cols, more = two_phase_rung(case, old, work, dx, cells_across or (
                    TWO_PHASE_CELLS_ACROSS_L0_QUICK if quick else TWO_PHASE_CELLS_ACROSS_L0))
            except NotTheLaddersError:
                raise
            except ConfigError as exc:      # a scene the two-phase model cannot carry
                cols, more = {"status_tp": f"refused: {exc}"}, []
            old.update(cols)
            curves[case.name] = [r for r in curves.get(case.name, []) if r[1] != "tp"] + more
            save()
            echo(f"  {old['status_tp']}" + (f", {cols['cpu_tp_s']:.0f} s CPU: runout "
                                            f"{cols['runout_tp']:.4f} m (2D {old['runout_2d']:.4f}), "
                                            f"H_f {cols['height_tp']:.4f} m" if "cpu_tp_s" in cols else ""))
            continue
        if fresh and not redo and not isinstance(old.get("runout_diff_k"), float):
            echo(f"{case.name}: Savage–Hutter K runs only (2D from the CSV)")
            sh_end = old["t_end_2d"] if old["status_2d"] == "end_time" else SH_MAX_TIME
            cols, more = k_variants(case.load(), case, dx, sh_end, old["runout_2d"], old["height_2d"])
            old.update(cols)
            curves[case.name] = [r for r in curves.get(case.name, []) if not r[1].startswith("sh_k")] + more
            save()
            continue
        if fresh and not redo:
            continue
        echo(f"{case.name}: running ({case.config} {' '.join(case.overrides)})")
        row, series = compare(case, work, dx)
        done[case.name], curves[case.name] = row, series
        save()
        echo(f"  2D {row['status_2d']} {row['wall_2d_s']:.1f} s, SH {row['status_sh']} "
             f"{row['wall_sh_s']:.2f} s: runout {row['runout_2d']:.4f} / {row['runout_sh']:.4f} m, "
             f"H_f {row['height_2d']:.4f} / {row['height_sh']:.4f} m")
    if not changed and not (out / f"{stem}.csv").exists():
        save()          # an empty table (nothing run): the files exist for the chart
    rows = read_rows(out / f"{stem}.csv")
    if shallow:
        rows = [r for r in rows if str(r["group"]).startswith("shallow")]
        plot_shallow(rows, read_series(out / f"{stem}_series.csv"), out / f"{stem}.png")
        echo(threshold_table(rows))
        echo(shallow_table(rows))
        if any(isinstance(r.get("runout_tp"), float) for r in rows):
            echo(tp_table(rows))
        return 0
    plot(rows, read_series(out / "ladder_series.csv"), out / "ladder.png")
    echo(table(rows))
    echo(k_table(rows))
    if any(isinstance(r.get("runout_tp"), float) for r in rows):
        plot_two_phase(rows, read_series(out / "ladder_series.csv"), out / "ladder_two_phase.png")
        echo(tp_table(rows))
    return 0


def main(argv=None) -> int:
    """``python -m studies.ladder``: the same as ``python -m studies ladder``."""
    parser = argparse.ArgumentParser(prog="python -m studies.ladder")
    parser.add_argument("--quick", action="store_true",
                        help="two tiny cases (3 cm 2D cells; SH Δx 4 mm): the test")
    parser.add_argument(
        "--out", default="runs/ladder", help="folder of ladder.csv, ladder_series.csv, ladder.png"
    )
    parser.add_argument("--work", default="runs/ladder", help="folder of the 2D run directories")
    parser.add_argument("--only", nargs="*", default=None, help="run only these cases")
    parser.add_argument("--redo", action="store_true", help="run cases already in the CSV again")
    parser.add_argument("--plot-only", action="store_true", help="only redraw from the CSVs")
    parser.add_argument("--sh-resolution", metavar="CASE",
                        help="only the Savage–Hutter side of CASE at Δx = 4, 2, 1, 0.5 mm")
    parser.add_argument("--shallow", action="store_true",
                        help="the shallow limit: the ε family, ladder_shallow.csv/.png")
    parser.add_argument("--two-phase", action="store_true",
                        help="add the two-phase rung to the cases in the CSV")
    parser.add_argument("--cells-across", type=int, default=None, metavar="N",
                        help="the two-phase rung's cells across L0 (default 16)")
    args = parser.parse_args(argv)
    if args.cells_across is not None and not (2 <= args.cells_across <= 256):
        print(f"ladder: error: --cells-across = {args.cells_across}: must be in [2, 256]",
              file=sys.stderr)
        return 2
    try:
        return run(args.quick, args.out, args.work, args.only, args.redo, args.plot_only,
                   args.sh_resolution, echo=lambda m: print(m, flush=True), shallow=args.shallow,
                   two_phase=args.two_phase, cells_across=args.cells_across)
    except ConfigError as exc:
        print(f"ladder: error: {exc}", file=sys.stderr)
        return exc.exit_code


if __name__ == "__main__":
    sys.exit(main())
