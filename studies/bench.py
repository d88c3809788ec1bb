"""Benchmark suite: ``python -m studies bench``.

Fixed cases (rigid collapse at two mesh sizes, plug flow, Bagnold), each run through the
ordinary :class:`~dpcollapse.simulation.Simulation` with the solver left untouched. For each
case the table reports: steps, simulated time, the smallest/mean/largest Δt, wall time (the time loop,
initial output
included: ``Simulation.timings["total"]``) and wall time per simulated second, mean/max
nonlinear iterations per step, linear solves per step (flow + mesh velocity), the split of
the wall time between assembly, LU factorization, LU solve (forward/back substitution),
the rest of the Picard loop, mesh motion, remeshing, output and everything else, the peak
memory, and the overhead ratio

    total wall time / (steps × time of one linear solve on the initial mesh),

where "one linear solve" is one assembly (matrix + vector) + numeric factorization + solve of
the flow system, the median of ``REPEATS`` after a warm-up, on a separate discretization of
the case's initial mesh. 1.0 is the floor (one Picard iteration per step and nothing else).

How the split is measured: the flow systems and solvers keep their own times and counts
(``solvers.assembly``: assembly; ``solvers.linear``: factorization and solve). PETSc
factorizes inside the first ``KSPSolve`` after ``KSPSetOperators``; ``DirectSolver`` calls
``ksp.setUp()`` itself before the first solve after a new operator (PCSetUp: the numeric
factorization, and the symbolic one on a new pattern) and times it apart from the triangular
solves. :class:`Instrument` subscribes to the run's ``discretization`` event (every flow
discretization the run creates: the initial one, after each remesh, after a nose lands on
the bed) and sums their counters; nothing is wrapped, and a tracked run gives the
diagnostics of an untracked one bit for bit (``tests/system/test_bench.py`` checks it).

Peak memory: ``ru_maxrss`` after resetting the high-water mark (``/proc/self/clear_refs``,
Linux ≥ 4.0) before each case, max over ranks; where the reset is refused it is the peak of
the whole process so far (``peak_reset`` column false).

``--np N`` reruns the chosen cases under ``mpirun -n N`` (a subprocess running this same
command with a hidden ``--result-json`` flag) and reports the speed-up, serial over parallel
wall time per simulated second, measured in the same invocation.

Cost growth: the rigid collapse over a short end time on four mesh sizes; time per step
against the number of unknowns (dofs of the Taylor–Hood space W), and the least-squares
exponent in log-log; the same for the time of one linear solve.
"""

from __future__ import annotations

import ctypes
import gc
import json
import logging
import math
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from dpcollapse.errors import ConfigError, DpcollapseError, Interrupted

log = logging.getLogger("studies.bench")

#: Timed repeats (after one warm-up) of the reference linear solve; the median is used.
REPEATS = 5


@dataclass(frozen=True)
class CaseSpec:
    """A benchmark case: a config file (in the configs folder) and overrides."""

    name: str
    config: str
    overrides: tuple[str, ...] = ()
    quick_overrides: tuple[str, ...] = ()   # applied after ``overrides`` with --quick
    description: str = ""


CASES: dict[str, CaseSpec] = {c.name: c for c in (
    CaseSpec("rigid_4cm", "rigid.yaml", ("geometry.mesh_size=0.04",),
             ("time.end_time=0.02",), "rigid collapse, 4 cm mesh, to rest"),
    CaseSpec("rigid_2cm", "rigid.yaml", ("geometry.mesh_size=0.02",),
             ("time.end_time=0.02",), "rigid collapse, 2 cm mesh, to rest"),
    CaseSpec("rigid_1cm", "rigid.yaml", ("geometry.mesh_size=0.01",),
             ("time.end_time=0.02",), "rigid collapse, 1 cm mesh, to rest"),
    CaseSpec("plug", "plug.yaml", (), ("time.end_time=0.05",),
             "decelerating plug flow (configs/plug.yaml), to rest"),
    CaseSpec("bagnold", "bagnold.yaml", ("geometry.mesh_size=0.002", "time.end_time=2.0"),
             ("time.end_time=0.1",),
             "mu(I) layer from rest (configs/bagnold.yaml), 2 mm mesh, 2 s"),
)}
DEFAULT_CASES = ("rigid_2cm", "rigid_1cm", "plug", "bagnold")
QUICK_CASES = ("rigid_4cm", "plug")


@dataclass(frozen=True)
class GrowthPlan:
    config: str
    mesh_sizes: tuple[float, ...]
    end_time: float


GROWTH = GrowthPlan("rigid.yaml", (0.02, 0.01, 0.005, 0.0025), 0.05)
QUICK_GROWTH = GrowthPlan("rigid.yaml", (0.04, 0.02), 0.01)

#: Columns of bench.csv, in order.
COLUMNS = (
    "kind", "case", "np", "mesh_size", "dofs", "status", "steps", "sim_time", "wall_s",
    "setup_s", "wall_per_sim_s", "time_per_step_s", "mean_iterations", "max_iterations",
    "linear_solves_per_step", "flow_solves_per_step", "ale_solves_per_step", "remeshes",
    "dt_min_s", "dt_mean_s", "dt_max_s",
    "pct_assembly", "pct_factorization", "pct_solve", "pct_picard_other", "pct_mesh_motion",
    "pct_remesh", "pct_output", "pct_other", "peak_mb", "peak_reset", "linear_solve_s",
    "overhead_ratio", "speedup", "growth_exponent", "linear_solve_exponent",
)
#: The parts of the wall time, in the order of the pct_* columns.
PARTS = ("assembly", "factorization", "solve", "picard_other", "mesh_motion", "remesh",
         "output", "other")


def default_configs_dir() -> Path:
    """The repository's configs/ (next to the package), else ./configs."""
    here = Path(__file__).resolve().parents[1] / "configs"
    return here if here.is_dir() else Path("configs")


def parse_cases(text: str | None, quick: bool) -> list[str]:
    if not text:
        return list(QUICK_CASES if quick else DEFAULT_CASES)
    names = [s.strip() for s in text.split(",") if s.strip()]
    bad = [n for n in names if n not in CASES]
    if bad or not names:
        raise ConfigError(f"--cases = {text!r}: unknown case {', '.join(bad) or '(none)'}; "
                          f"allowed: {', '.join(CASES)} (comma-separated)")
    return list(dict.fromkeys(names))


# ---------------------------------------------------------------------- instrumentation
class Instrument:
    """Assembly / factorization / solve time and counts of the flow systems of a run, summed
    over every discretization it is shown (``track``, a subscriber of the run's
    ``discretization`` event): the systems and solvers keep these counts themselves
    (``solvers.assembly``, ``solvers.linear``), nothing is wrapped."""

    def __init__(self):
        self.flows: list = []

    def track(self, sim, disc) -> None:
        """Event ``discretization``: count the flow of a new discretization (once)."""
        if all(flow is not disc.flow for flow in self.flows):
            self.flows.append(disc.flow)

    def subscribe(self, events) -> Instrument:
        events.subscribe("discretization", self.track)
        return self

    @property
    def wrapped(self) -> int:
        """Discretizations tracked."""
        return len(self.flows)

    @property
    def times(self) -> dict[str, float]:
        return {
            "assembly": sum(f.system.seconds["assembly"] for f in self.flows),
            "factorization": sum(f.solver.seconds["factorization"] for f in self.flows),
            "solve": sum(f.solver.seconds["solve"] for f in self.flows),
        }

    @property
    def linear_solves(self) -> int:
        return sum(f.solver.solves for f in self.flows)

    @property
    def factorizations(self) -> int:
        return sum(f.solver.factorizations for f in self.flows)


def instrumented_simulation(instrument, cfg, run_dir, **kwargs):
    """A Simulation whose discretizations ``instrument`` tracks from the first one on."""
    from dpcollapse.loop import Events
    from dpcollapse.simulation import Simulation

    events = Events()
    instrument.subscribe(events)
    return Simulation(cfg, run_dir, events=events, **kwargs)


# ---------------------------------------------------------------------- memory
_LIBC = None


def reset_peak_memory() -> bool:
    """Give freed heap back to the OS and reset the RSS high-water mark; False if refused."""
    global _LIBC
    gc.collect()
    try:
        if _LIBC is None:
            _LIBC = ctypes.CDLL("libc.so.6")
        _LIBC.malloc_trim(0)
    except (OSError, AttributeError):
        pass
    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")
        return True
    except OSError:
        return False


def peak_memory_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0   # kB on Linux


# ---------------------------------------------------------------------- measurements
def load_case_config(configs: Path, config: str, overrides: Sequence[str]):
    from dpcollapse.config import load_config

    path = Path(configs) / config
    if not path.is_file():
        raise ConfigError(f"--configs = {configs}: {config} not found there")
    return load_config(path, list(overrides))


def _global_dofs(V) -> int:
    im = V.dofmap.index_map
    return int(im.size_global * V.dofmap.index_map_bs)


def linear_solve_time(cfg, comm, repeats: int = REPEATS) -> tuple[float, int]:
    """Median time of one flow assembly (matrix + vector) + factorization + solve on the
    initial mesh of ``cfg`` (a separate discretization, after one warm-up), max over ranks;
    and the number of unknowns of W."""
    from dolfinx import fem
    from mpi4py import MPI

    from dpcollapse.models.stokes.discretization import StokesDiscretization, initial_velocity
    from dpcollapse.scenes.registry import build_mesh

    disc = StokesDiscretization(build_mesh(cfg, comm), cfg)
    try:
        flow = disc.flow
        flow.set_velocity(initial_velocity(cfg))
        flow.dt.value = cfg.time.dt
        scratch = fem.Function(flow.W)

        def once() -> float:
            comm.barrier()
            t0 = time.perf_counter()
            A = flow.system.assemble_matrix()
            b = flow.system.assemble_vector()
            flow.solver.set_operator(A)
            flow.system.solve(flow.solver, target=scratch, b=b)
            return comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)

        once()   # warm-up: symbolic analysis, first-touch allocations
        t = statistics.median(once() for _ in range(repeats))
        return float(t), _global_dofs(flow.W)
    finally:
        disc.destroy()


def _mean_over_ranks(comm, values: dict) -> dict:
    from mpi4py import MPI

    keys = sorted(values)
    arr = np.array([values[k] for k in keys], dtype=float)
    total = comm.allreduce(arr, op=MPI.SUM) / comm.size
    return dict(zip(keys, map(float, total)))


def run_case(name: str, cfg, run_dir: Path, comm, kind: str = "case",
             calibrate: bool = True) -> dict:
    """Run one case and return its row (every rank gets the same row)."""
    from mpi4py import MPI

    row: dict = {"kind": kind, "case": name, "np": comm.size,
                 "mesh_size": cfg.geometry.mesh_size}
    t_lin, dofs = linear_solve_time(cfg, comm) if calibrate else (math.nan, -1)
    peak_reset = comm.allreduce(reset_peak_memory(), op=MPI.LAND)
    instrument = Instrument()
    t0 = time.perf_counter()
    sim = instrumented_simulation(instrument, cfg, run_dir, quiet=True, comm=comm)
    setup = time.perf_counter() - t0
    if dofs < 0:
        dofs = _global_dofs(sim.disc.flow.W)
    status = "ok"
    try:
        summary = sim.run()
        status = summary["status"]
    except Interrupted:
        raise
    except DpcollapseError as exc:   # a failed case is reported, the suite goes on
        status = f"failed: {type(exc).__name__}"
        log.warning("%s: %s", name, exc)
    finally:
        sim.disc.destroy()
    peak = comm.allreduce(peak_memory_mb(), op=MPI.MAX)
    tm = dict(sim.timings)
    steps, t_sim = int(sim.state.step), float(sim.state.t)
    its = np.asarray(sim.iteration_counts, dtype=float)
    local = {
        "total": tm.get("total", time.perf_counter() - sim.wall0),
        "assembly": instrument.times["assembly"],
        "factorization": instrument.times["factorization"],
        "solve": instrument.times["solve"],
        "picard_other": tm["solve"] - sum(instrument.times.values()),
        "mesh_motion": tm["mesh_motion"], "remesh": tm["remesh"], "output": tm["output"],
        "setup": setup,
    }
    local["other"] = local["total"] - sum(local[p] for p in PARTS if p != "other")
    pct_local = {p: 100.0 * local[p] / local["total"] if local["total"] > 0 else 0.0 for p in PARTS}
    pct = _mean_over_ranks(comm, pct_local)   # mean of the per-rank splits: sums to 100
    wall = comm.allreduce(local["total"], op=MPI.MAX)
    flow_solves = comm.allreduce(instrument.linear_solves, op=MPI.MAX)
    per_step = 1.0 / steps if steps else math.nan
    row.update({
        "dofs": dofs, "status": status, "steps": steps, "sim_time": t_sim, "wall_s": wall,
        "setup_s": comm.allreduce(setup, op=MPI.MAX),
        "wall_per_sim_s": wall / t_sim if t_sim > 0 else math.nan,
        "time_per_step_s": wall * per_step,
        "mean_iterations": float(its.mean()) if len(its) else math.nan,
        "max_iterations": int(its.max()) if len(its) else 0,
        "linear_solves_per_step": (flow_solves + sim.domain.solves) * per_step,
        "flow_solves_per_step": flow_solves * per_step,
        "ale_solves_per_step": sim.domain.solves * per_step,
        "remeshes": int(sim.state.remeshes),
        "dt_min_s": min(sim.step_sizes, default=math.nan),
        "dt_mean_s": t_sim * per_step if steps else math.nan,
        "dt_max_s": max(sim.step_sizes, default=math.nan),
        **{f"pct_{p}": pct[p] for p in PARTS},
        "peak_mb": peak, "peak_reset": bool(peak_reset), "linear_solve_s": t_lin,
        "overhead_ratio": wall / (steps * t_lin) if steps and t_lin > 0 else math.nan,
        "speedup": math.nan, "growth_exponent": math.nan, "linear_solve_exponent": math.nan,
    })
    del sim
    gc.collect()
    return row


def fitted_exponent(x: Sequence[float], y: Sequence[float]) -> float:
    """Least-squares slope of log y against log x (NaN with fewer than two points)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    if ok.sum() < 2:
        return math.nan
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


# ---------------------------------------------------------------------- MPI rerun
_LAUNCHER_PREFIXES = ("OMPI_COMM_WORLD", "OMPI_UNIVERSE", "OMPI_FILE_LOCATION", "OMPI_APP_CTX",
                      "OMPI_NUM_APP_CTX", "OMPI_FIRST_RANKS", "OMPI_ARGV", "OMPI_COMMAND",
                      "OMPI_MCA_ess", "OMPI_MCA_orte", "OMPI_MCA_pmix", "OMPI_MCA_initial_wdir",
                      "PMIX_", "PMI_", "OPAL_", "ORTE_", "PRTE_", "HYDRA_", "I_MPI_")


def _mpi_env(nprocs: int) -> dict:
    """Our environment without a launcher's job variables (if we were started by one),
    one thread per rank, the checkout on the path, and (as root) Open MPI's permission to run."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(_LAUNCHER_PREFIXES)}
    env["OPENBLAS_NUM_THREADS"] = env["OMP_NUM_THREADS"] = "1"
    checkout = str(Path(__file__).resolve().parents[1])   # studies/ is not installed
    env["PYTHONPATH"] = os.pathsep.join(p for p in (checkout, env.get("PYTHONPATH")) if p)
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    if nprocs > (os.cpu_count() or 1):   # Open MPI 4, and 5 (PRRTE)
        env.setdefault("OMPI_MCA_rmaps_base_oversubscribe", "1")
        env.setdefault("PRTE_MCA_rmaps_default_mapping_policy", ":oversubscribe")
    return env


def rerun_under_mpi(nprocs: int, bench_args: Sequence[str], what: str,
                    echo: Callable[[str], None]) -> list[dict]:
    """Run ``python -m studies bench <bench_args> --np 0 --result-json …`` under
    ``mpirun -n nprocs`` and return the rows it wrote; a failed rerun is an error."""
    launcher = shutil.which("mpirun") or shutil.which("mpiexec")
    if launcher is None:
        raise DpcollapseError("--np: neither mpirun nor mpiexec is on PATH")
    with tempfile.TemporaryDirectory(prefix="dpcollapse-bench-") as tmp:
        result = Path(tmp) / "result.json"
        cmd = [launcher, "-n", str(nprocs), sys.executable, "-m", "studies", "bench",
               *bench_args, "--np", "0", "--result-json", str(result)]
        echo(f"rerunning {what} under mpirun -n {nprocs}")
        proc = subprocess.run(cmd, env=_mpi_env(nprocs), check=False)
        if proc.returncode != 0 or not result.is_file():
            raise DpcollapseError(f"the mpirun -n {nprocs} rerun failed (exit {proc.returncode}): "
                                  + " ".join(cmd))
        return json.loads(result.read_text())["rows"]


def run_mpi(nprocs: int, cases: Sequence[str], quick: bool, out: Path, configs: Path,
            echo: Callable[[str], None]) -> list[dict]:
    """Rerun ``cases`` under ``mpirun -n nprocs`` and return their rows."""
    args = ["--cases", ",".join(cases), "--out", str(out), "--configs", str(configs), "--no-growth"]
    return rerun_under_mpi(nprocs, args + (["--quick"] if quick else []), ", ".join(cases), echo)


# ---------------------------------------------------------------------- driver
@dataclass
class BenchResult:
    rows: list = field(default_factory=list)
    growth: list = field(default_factory=list)
    exponents: dict = field(default_factory=dict)


def run_bench(out: Path, cases: str | None = None, quick: bool = False, nprocs: int = 2,
              growth: bool = True, configs: Path | None = None, result_json: Path | None = None,
              echo: Callable[[str], None] = print) -> BenchResult:
    """Run the suite; on rank 0 print the table and write bench.csv, bench.json, bench.png.
    With ``result_json`` (internal: the MPI rerun) only run the cases and dump their rows."""
    from mpi4py import MPI

    comm = MPI.COMM_WORLD
    rank0 = comm.rank == 0
    say = echo if rank0 else (lambda msg: None)
    names = parse_cases(cases, quick)
    configs = Path(configs) if configs else default_configs_dir()
    out = Path(out)
    for n in names:   # fail early on a bad config dir, before any run
        load_case_config(configs, CASES[n].config, CASES[n].overrides)
    if comm.size > 1 and nprocs:
        say(f"already running on {comm.size} ranks: no nested mpirun (--np {nprocs} ignored)")
        nprocs = 0
    result = BenchResult()
    tag = f"np{comm.size}"
    for n in names:
        spec = CASES[n]
        cfg = load_case_config(configs, spec.config,
                               spec.overrides + (spec.quick_overrides if quick else ()))
        row = run_case(n, cfg, out / tag / n, comm)
        result.rows.append(row)
        say(f"[{tag}] {n}: {row['status']}, {row['steps']} steps to t = {row['sim_time']:.3f} s, "
            f"{row['wall_s']:.1f} s wall, {row['dofs']} dofs, overhead ratio "
            f"{row['overhead_ratio']:.2f}")
    if result_json is not None:
        if rank0:
            Path(result_json).write_text(json.dumps({"rows": result.rows}, default=float))
        return result
    if nprocs:
        parallel = run_mpi(nprocs, names, quick, out, configs, say) if rank0 else None
        parallel = comm.bcast(parallel, root=0)
        serial = {r["case"]: r for r in result.rows}
        for r in parallel:
            s = serial.get(r["case"])
            if s and r["wall_per_sim_s"] > 0:
                r["speedup"] = s["wall_per_sim_s"] / r["wall_per_sim_s"]
        result.rows.extend(parallel)
    if growth:
        plan = QUICK_GROWTH if quick else GROWTH
        for h in plan.mesh_sizes:
            cfg = load_case_config(configs, plan.config, (f"geometry.mesh_size={h!r}",
                                                          f"time.end_time={plan.end_time!r}"))
            label = f"rigid_{h * 100:g}cm"
            row = run_case(label, cfg, out / "growth" / label, comm, kind="growth")
            result.growth.append(row)
            say(f"[growth] {label}: {row['dofs']} dofs, {row['steps']} steps, "
                f"{row['time_per_step_s']:.3f} s/step, "
                f"one linear solve {row['linear_solve_s']:.4f} s")
        dofs = [r["dofs"] for r in result.growth]
        result.exponents = {
            "time_per_step": fitted_exponent(dofs, [r["time_per_step_s"] for r in result.growth]),
            "linear_solve": fitted_exponent(dofs, [r["linear_solve_s"] for r in result.growth]),
        }
        for r in result.growth:
            r["growth_exponent"] = result.exponents["time_per_step"]
            r["linear_solve_exponent"] = result.exponents["linear_solve"]
    if rank0:
        out.mkdir(parents=True, exist_ok=True)
        echo(format_table(result))
        write_csv(out / "bench.csv", result.rows + result.growth)
        write_json(out / "bench.json", result, quick, comm.size)
        plot_bench(out / "bench.png", result)
        echo(f"wrote {out / 'bench.csv'}, {out / 'bench.json'} and {out / 'bench.png'}")
    comm.barrier()
    return result


# ---------------------------------------------------------------------- outputs
def _fmt(value, spec: str) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    return format(value, spec)


def format_table(result: BenchResult) -> str:
    head = (f"{'case':<10} {'np':>2} {'dofs':>7} {'steps':>5} {'t_sim':>6} {'dt ms':>5} {'wall':>7} "
            f"{'wall/s':>7} "
            f"{'it':>5} {'max':>4} {'lin/st':>6} {'asm%':>5} {'fact%':>5} {'sol%':>5} "
            f"{'pic%':>5} {'ale%':>5} {'rem%':>5} {'out%':>5} {'oth%':>5} {'MB':>6} "
            f"{'ovh':>5} {'speedup':>7}")
    lines = ["", head, "-" * len(head)]
    for r in result.rows:
        lines.append(
            f"{r['case']:<10} {r['np']:>2} {r['dofs']:>7} {r['steps']:>5} {r['sim_time']:>6.3f} "
            f"{_fmt(1e3 * r['dt_mean_s'], '5.2f'):>5} {r['wall_s']:>7.1f} "
            f"{_fmt(r['wall_per_sim_s'], '7.1f'):>7} "
            f"{_fmt(r['mean_iterations'], '5.2f'):>5} {r['max_iterations']:>4} "
            f"{_fmt(r['linear_solves_per_step'], '6.2f'):>6} "
            + " ".join(f"{r['pct_' + p]:>5.1f}" for p in PARTS)
            + f" {r['peak_mb']:>6.0f} {_fmt(r['overhead_ratio'], '5.2f'):>5} "
            f"{_fmt(r['speedup'], '7.2f'):>7}"
        )
        if not str(r["status"]).startswith(("at_rest", "end_time")):
            lines[-1] += f"  [{r['status']}]"
    lines.append(
        "dt ms: mean time step [ms]; wall: time loop [s]; wall/s: per simulated second; "
        "it/max: nonlinear iterations per step; lin/st: linear solves per step (flow + mesh "
        "velocity); %: share of the wall time (asm assembly, fact LU factorization, sol LU "
        "solve, pic rest of the Picard loop, ale mesh motion, rem remesh, out output, oth "
        "other); MB: peak RSS; "
        "ovh: wall / (steps x one assembly+factorization+solve); speedup: serial/parallel "
        "wall per simulated second"
    )
    if result.growth:
        lines += ["", f"{'growth':<10} {'dofs':>7} {'steps':>5} {'it':>5} {'s/step':>8} "
                      f"{'1 solve [s]':>11} {'ovh':>5} {'MB':>6}"]
        for r in result.growth:
            lines.append(f"{r['case']:<10} {r['dofs']:>7} {r['steps']:>5} "
                         f"{_fmt(r['mean_iterations'], '5.2f'):>5} {r['time_per_step_s']:>8.4f} "
                         f"{r['linear_solve_s']:>11.4f} {_fmt(r['overhead_ratio'], '5.2f'):>5} "
                         f"{r['peak_mb']:>6.0f}")
        e = result.exponents
        lines.append(f"fitted exponent (least squares, log-log): time per step ~ dofs^"
                     f"{_fmt(e['time_per_step'], '.2f')}, one linear solve ~ dofs^"
                     f"{_fmt(e['linear_solve'], '.2f')}")
    return "\n".join(lines)


def _csv_value(v) -> str:
    if isinstance(v, bool):
        return str(v).lower()
    if isinstance(v, float):
        return "" if not math.isfinite(v) else f"{v:.6g}"
    return str(v)


def write_csv(path: Path, rows: list[dict]) -> None:
    with Path(path).open("w") as f:
        f.write(",".join(COLUMNS) + "\n")
        for r in rows:
            f.write(",".join(_csv_value(r.get(c, "")) for c in COLUMNS) + "\n")


def write_json(path: Path, result: BenchResult, quick: bool, size: int) -> None:
    import platform

    from dpcollapse.io.runinfo import versions, write_json_atomic

    write_json_atomic(path, {
        "versions": versions(), "host": platform.node(), "cpus": os.cpu_count(),
        "date": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "quick": quick, "mpi_size": size,
        "rows": result.rows, "growth": result.growth, "exponents": result.exponents,
    })


def plot_bench(path: Path, result: BenchResult) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colors = {"assembly": "tab:blue", "factorization": "tab:red", "solve": "tab:orange",
              "picard_other": "tab:purple", "mesh_motion": "tab:green", "remesh": "tab:olive",
              "output": "tab:cyan", "other": "tab:gray"}
    labels = {"assembly": "assembly", "factorization": "LU factorization", "solve": "LU solve",
              "picard_other": "rest of Picard", "mesh_motion": "mesh motion", "remesh": "remesh",
              "output": "output", "other": "other"}
    ncols = 2 if result.growth else 1
    fig, axes = plt.subplots(1, ncols, figsize=(6.5 * ncols + 1, 4.8), squeeze=False)
    ax = axes[0, 0]
    rows = result.rows
    names = [f"{r['case']} (np {r['np']})" for r in rows]
    y = np.arange(len(rows))[::-1]
    left = np.zeros(len(rows))
    for p in PARTS:
        w = np.array([r[f"pct_{p}"] for r in rows])
        ax.barh(y, w, left=left, color=colors[p], label=labels[p], height=0.6)
        left += w
    for yi, r in zip(y, rows):
        wall = f"{r['wall_s']:.0f}" if r["wall_s"] >= 10 else f"{r['wall_s']:.2g}"
        ax.text(101, yi, f"{wall} s\n×{_fmt(r['overhead_ratio'], '.1f')}",
                va="center", fontsize=7)
    ax.set_yticks(y, names, fontsize=8)
    ax.set_xlim(0, 115)
    ax.set_xlabel("share of the wall time [%]  (right: wall time, overhead ratio)")
    ax.set_title("Where the time goes")
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=4, frameon=False)
    if result.growth:
        ax = axes[0, 1]
        g = result.growth
        n = np.array([r["dofs"] for r in g], float)
        e = result.exponents
        for key, col, label in (("time_per_step_s", "tab:blue", "time per step"),
                                ("linear_solve_s", "tab:red", "one linear solve")):
            t = np.array([r[key] for r in g], float)
            expo = e["time_per_step" if key == "time_per_step_s" else "linear_solve"]
            ax.loglog(n, t, "o", color=col)
            if math.isfinite(expo):
                ok = t > 0
                c = np.exp(np.mean(np.log(t[ok]) - expo * np.log(n[ok])))
                nn = np.geomspace(n.min(), n.max(), 20)
                ax.loglog(nn, c * nn**expo, "-", color=col, lw=1, label=f"{label} ∝ N^{expo:.2f}")
            for ni, ti, r in zip(n, t, g):
                if key == "time_per_step_s":
                    ax.annotate(f"{r['mesh_size'] * 100:g} cm", (ni, ti),
                                textcoords="offset points", xytext=(4, 4), fontsize=7)
        ax.set_xlabel("unknowns N (dofs of W)")
        ax.set_ylabel("wall time [s]")
        ax.set_title("Cost growth (rigid collapse, short run)")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
