"""Iterative against direct flow solves: ``python -m studies bench --krylov``.

The rigid collapse (``configs/rigid.yaml``) over its first steps (end time 0.02 s: the
pressure builds up from zero, then the mass starts to flow), on a grid of mesh sizes and
regularizations ε (the viscosity contrast: ν = 2η + κ(p)/√(|D|²+ε²) reaches κ/ε in the
rigid zones), once with ``numerics.linear_solver: iterative`` and once with MUMPS.
Per run: the flow solves (= Picard iterations), the Krylov iterations per solve (mean,
max), and the time per solve, split into set-up (``set_operator`` + ``KSPSetUp``: for
MUMPS the LU factorization, for the iterative solver the assembly of the two pressure
operators and the AMG hierarchies) and solve (MUMPS: triangular solves; iterative: the
FGMRES iterations); assembly of the flow matrix is the same for both and left out. Times
are the maximum over ranks. ``--np N`` reruns the grid under ``mpirun -n N``.

The first steps hide the hard case: at rest |D| ≈ 0 everywhere, so ν ≈ κ/ε is large but
nearly uniform. The contrast appears once part of the mass flows (ν ~ 10–100 Pa s) next to
rigid zones (ν ~ κ/ε). Hence a second table, "developed": the same case run with MUMPS to
``DEVELOPED.end_time`` (0.3 s, fast spreading), then the first Picard system of the next step
assembled with each ε and solved once by each solver (initial guess: the last state;
median of ``REPEATS`` after a warm-up), reporting Krylov iterations or failure.
Writes ``krylov.csv`` (rank 0) and prints the tables.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dpcollapse import compat
from dpcollapse.errors import DpcollapseError, Interrupted
from studies.bench import (
    Instrument,
    _csv_value,
    _fmt,
    _global_dofs,
    default_configs_dir,
    instrumented_simulation,
    load_case_config,
    rerun_under_mpi,
)


@dataclass(frozen=True)
class KrylovPlan:
    mesh_sizes: tuple[float, ...]
    epsilons: tuple[float, ...]
    end_time: float
    solvers: tuple[str, ...] = ("iterative", "mumps")


PLAN = KrylovPlan((0.04, 0.02, 0.01, 0.005), (1e-2, 1e-4, 1e-6), 0.02)
QUICK_PLAN = KrylovPlan((0.04,), (1e-2, 1e-6), 0.003)
DEVELOPED = KrylovPlan((0.04, 0.02, 0.01, 0.005), (1e-2, 1e-4, 1e-6), 0.3)
QUICK_DEVELOPED = KrylovPlan((0.04,), (1e-2, 1e-6), 0.05)

#: Timed repeats (after a warm-up) of each solve of the developed state; the median is used.
REPEATS = 3

COLUMNS = ("kind", "solver", "np", "mesh_size", "dofs", "epsilon", "t", "status", "steps",
           "solves", "krylov_mean", "krylov_max", "setup_s", "solve_s", "time_per_solve_s",
           "lu_over_iterative", "wall_s", "front")


class SolveTimer(Instrument):
    """Set-up and solve time of the flow solves of every discretization it is shown
    (``track``, a subscriber of the run's ``discretization`` event), and the Krylov
    iterations of each solve: the solvers keep these counts (``solvers.linear``,
    ``solvers.iterative``), nothing is wrapped."""

    @property
    def setup(self) -> float:
        return sum(f.solver.seconds["factorization"] for f in self.flows)

    @property
    def solve(self) -> float:
        return sum(f.solver.seconds["solve"] for f in self.flows)

    @property
    def iterations(self) -> list[int]:
        return [its for f in self.flows for its in f.solver.solve_iterations]


def run_krylov_case(cfg, run_dir: Path, comm) -> dict:
    """One run of ``cfg``: its row (the same on every rank)."""
    from mpi4py import MPI

    n = cfg.numerics
    timer = SolveTimer()
    sim = instrumented_simulation(timer, cfg, run_dir, quiet=True, comm=comm)
    dofs = _global_dofs(sim.disc.flow.W)
    status, front = "ok", math.nan
    t0 = time.perf_counter()
    try:
        summary = sim.run()
        status, front = summary["status"], summary["front"]
    except Interrupted:
        raise
    except DpcollapseError as exc:   # a solver that fails is a result, not a crash
        status = f"failed: {type(exc).__name__}"
    finally:
        sim.disc.destroy()
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    solves = len(timer.iterations)
    setup = comm.allreduce(timer.setup, op=MPI.MAX) / max(solves, 1)
    solve = comm.allreduce(timer.solve, op=MPI.MAX) / max(solves, 1)
    its = np.asarray(timer.iterations, dtype=float)
    iterative = n.linear_solver == "iterative"
    return {
        "kind": "first_steps", "solver": n.linear_solver, "np": comm.size,
        "mesh_size": cfg.geometry.mesh_size, "dofs": dofs, "epsilon": n.epsilon,
        "t": float(sim.state.t), "status": status, "steps": int(sim.state.step),
        "solves": solves,
        "krylov_mean": float(its.mean()) if iterative and solves else math.nan,
        "krylov_max": int(its.max()) if iterative and solves else -1,
        "setup_s": setup, "solve_s": solve, "time_per_solve_s": setup + solve,
        "lu_over_iterative": math.nan, "wall_s": wall, "front": front,
    }


def developed_rows(cfg, run_dir: Path, comm, epsilons: Sequence[float]) -> list[dict]:
    """Run ``cfg`` (MUMPS) to its end time; then, for each ε, the next Picard system solved
    once by each solver. Rows of kind "developed"."""
    from mpi4py import MPI

    from dpcollapse.simulation import Simulation
    from dpcollapse.solvers.linear import DirectSolver

    sim = Simulation(cfg, run_dir, quiet=True, comm=comm)
    sim.run()
    flow, rows = sim.disc.flow, []
    flow.dt.value = cfg.time.dt
    start = compat.petsc_vec(flow.solution).copy()
    x = compat.petsc_vec(flow.solution).duplicate()
    n = cfg.numerics
    try:
        for eps in epsilons:
            flow.epsilon.value = eps
            A, b = flow.system.assemble_matrix(), flow.system.assemble_vector()
            lu_time = math.nan
            for solver_name in ("iterative", "mumps"):
                if solver_name == "iterative":
                    solver = flow.iterative_solver(n.krylov_rtol, n.krylov_max_iterations,
                                                   prefix="dpc_bench_it_")
                else:
                    solver = DirectSolver(comm, "mumps", prefix="dpc_bench_lu_")
                setups, solves, status, its = [], [], "ok", -1
                for _ in range(REPEATS + 1):
                    start.copy(x)
                    A = flow.system.assemble_matrix()   # a new matrix state: PETSc sets up anew
                    comm.barrier()
                    t0 = time.perf_counter()
                    solver.set_operator(A)
                    solver.ksp.setUp()
                    t1 = time.perf_counter()
                    try:
                        solver.solve(b, x)
                    except RuntimeError:
                        status = f"failed ({solver.ksp.getIterationNumber()} its)"
                    setups.append(comm.allreduce(t1 - t0, op=MPI.MAX))
                    solves.append(comm.allreduce(time.perf_counter() - t1, op=MPI.MAX))
                if solver_name == "iterative":
                    its = solver.last_iterations
                solver.destroy()
                setup, solve = float(np.median(setups[1:])), float(np.median(solves[1:]))
                row = {
                    "kind": "developed", "solver": solver_name, "np": comm.size,
                    "mesh_size": cfg.geometry.mesh_size, "dofs": _global_dofs(flow.W),
                    "epsilon": eps, "t": float(sim.state.t), "status": status,
                    "steps": int(sim.state.step), "solves": 1,
                    "krylov_mean": float(its) if its >= 0 else math.nan, "krylov_max": its,
                    "setup_s": setup, "solve_s": solve, "time_per_solve_s": setup + solve,
                    "lu_over_iterative": math.nan, "wall_s": math.nan, "front": math.nan,
                }
                rows.append(row)
                if solver_name == "mumps":
                    lu_time = row["time_per_solve_s"]
            if rows[-2]["status"] == "ok":
                rows[-2]["lu_over_iterative"] = lu_time / rows[-2]["time_per_solve_s"]
    finally:
        start.destroy()
        x.destroy()
        sim.disc.destroy()
    return rows


def plan_configs(plan: KrylovPlan, configs: Path):
    """(label, cfg) of every run of the plan, in order."""
    for h in plan.mesh_sizes:
        for eps in plan.epsilons:
            for solver in plan.solvers:
                over = (f"geometry.mesh_size={h!r}", f"numerics.epsilon={eps!r}",
                        f"numerics.linear_solver={solver}", f"time.end_time={plan.end_time!r}",
                        "time.output_every=100000", "time.checkpoint_every=100000")
                yield f"{solver}_{h * 100:g}cm_eps{eps:g}", load_case_config(configs, "rigid.yaml", over)


def _warm_up(configs: Path, out: Path, comm) -> None:
    """Compile every form once (JIT) so that no timed run pays for it."""
    plan = KrylovPlan((0.04,), (1e-6,), 0.001)
    for label, cfg in plan_configs(plan, configs):
        run_krylov_case(cfg, out / "warm_up" / label, comm)


def run_mpi_grid(nprocs: int, quick: bool, out: Path, configs: Path,
                 echo: Callable[[str], None]) -> list[dict]:
    """Rerun the grid under ``mpirun -n nprocs``; its rows."""
    args = ["--krylov", "--out", str(out), "--configs", str(configs)]
    return rerun_under_mpi(nprocs, args + (["--quick"] if quick else []), "the Krylov grid", echo)


def add_ratios(rows: Sequence[dict]) -> None:
    """lu_over_iterative: MUMPS time per solve / iterative time per solve, same np, h, ε."""
    lu = {(r["kind"], r["np"], r["mesh_size"], r["epsilon"]): r["time_per_solve_s"]
          for r in rows if r["solver"] != "iterative"}
    for r in rows:
        key = (r["kind"], r["np"], r["mesh_size"], r["epsilon"])
        if (r["solver"] == "iterative" and key in lu and r["time_per_solve_s"] > 0
                and r["status"] in ("ok", "end_time")):
            r["lu_over_iterative"] = lu[key] / r["time_per_solve_s"]


def run_krylov_bench(out: Path, quick: bool = False, nprocs: int = 2, configs: Path | None = None,
                     result_json: Path | None = None,
                     echo: Callable[[str], None] = print) -> list[dict]:
    """Run the grid (and its rerun on ``nprocs`` ranks); rank 0 prints the table and writes
    krylov.csv. With ``result_json`` (internal: the MPI rerun) only dump the rows."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    say = echo if comm.rank == 0 else (lambda msg: None)
    configs = Path(configs) if configs else default_configs_dir()
    out = Path(out)
    plan = QUICK_PLAN if quick else PLAN
    runs = list(plan_configs(plan, configs))   # a bad configs folder fails before any run
    if comm.size > 1 and nprocs:
        say(f"already running on {comm.size} ranks: no nested mpirun (--np {nprocs} ignored)")
        nprocs = 0
    tag = f"np{comm.size}"
    _warm_up(configs, out / "krylov" / tag, comm)
    rows = []
    for label, cfg in runs:
        row = run_krylov_case(cfg, out / "krylov" / tag / label, comm)
        rows.append(row)
        say(f"[{tag}] {label}: {row['status']}, {row['solves']} solves, Krylov "
            f"{_fmt(row['krylov_mean'], '.1f')} per solve, {1e3 * row['time_per_solve_s']:.1f} ms "
            f"per solve")
    developed = QUICK_DEVELOPED if quick else DEVELOPED
    for h in developed.mesh_sizes:
        cfg = load_case_config(configs, "rigid.yaml", (
            f"geometry.mesh_size={h!r}", f"time.end_time={developed.end_time!r}",
            "time.output_every=100000", "time.checkpoint_every=100000"))
        new = developed_rows(cfg, out / "krylov" / tag / f"developed_{h * 100:g}cm", comm,
                             developed.epsilons)
        rows.extend(new)
        for r in new[::2]:
            say(f"[{tag}] developed {h * 100:g} cm, eps {r['epsilon']:g}: {r['status']}, "
                f"Krylov {r['krylov_max']}, {1e3 * r['time_per_solve_s']:.1f} ms")
    if result_json is not None:
        if comm.rank == 0:
            Path(result_json).write_text(json.dumps({"rows": rows}, default=float))
        return rows
    if nprocs:
        parallel = run_mpi_grid(nprocs, quick, out, configs, say) if comm.rank == 0 else None
        rows.extend(comm.bcast(parallel, root=0))
    add_ratios(rows)
    if comm.rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        echo(format_krylov_table(rows))
        write_krylov_csv(out / "krylov.csv", rows)
        echo(f"wrote {out / 'krylov.csv'}")
    comm.barrier()
    return rows


def format_krylov_table(rows: Sequence[dict]) -> str:
    head = (f"{'kind':<11} {'solver':<10} {'np':>2} {'h cm':>5} {'dofs':>7} {'eps':>6} {'solves':>6} "
            f"{'its':>6} {'max':>4} {'setup ms':>8} {'solve ms':>8} {'ms/solve':>8} "
            f"{'LU/it':>6}  status")
    lines = ["", head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['kind']:<11} {r['solver']:<10} {r['np']:>2} {100 * r['mesh_size']:>5g} {r['dofs']:>7} "
            f"{r['epsilon']:>6.0e} {r['solves']:>6} {_fmt(r['krylov_mean'], '6.1f'):>6} "
            f"{r['krylov_max'] if r['krylov_max'] >= 0 else '-':>4} {1e3 * r['setup_s']:>8.2f} "
            f"{1e3 * r['solve_s']:>8.2f} {1e3 * r['time_per_solve_s']:>8.2f} "
            f"{_fmt(r['lu_over_iterative'], '6.2f'):>6}  {r['status']}")
    lines.append("first_steps: the run to t = end time, per flow solve; developed: one solve "
                 "of the state at t; its/max: Krylov iterations per solve (mean/max); setup: "
                 "factorization or pressure operators + AMG; LU/it: MUMPS time / iterative time")
    return "\n".join(lines)


def write_krylov_csv(path: Path, rows: Sequence[dict]) -> None:
    with Path(path).open("w") as f:
        f.write(",".join(COLUMNS) + "\n")
        f.writelines(",".join(_csv_value(r.get(c, "")) for c in COLUMNS) + "\n" for r in rows)
