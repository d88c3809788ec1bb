"""Where the time of a two-phase step goes, and what the linear algebra costs (issue 26).

    python benchmarks/two_phase_solver.py profile OUT [KEY=VALUE ...]
    python benchmarks/two_phase_solver.py profile OUT --resume [KEY=VALUE ...]
    python benchmarks/two_phase_solver.py lu OUT [KEY=VALUE ...]
    python benchmarks/two_phase_solver.py window SRC DST [KEY=VALUE ...]
    python benchmarks/two_phase_solver.py schur CELL

``profile``: a run of ``configs/column_eulerian_a6.26.yaml`` with the overrides under
cProfile (CPU time): steps, factorizations, the flow's assembly/factorization/solve times
and PETSc's event counts (``MatLUFactorSym`` against ``MatLUFactorNum``: how often MUMPS's
symbolic analysis runs), then the functions by CPU time. With ``--resume`` OUT is a run
directory to continue (prepared by ``window``, its config and overrides from there).
``lu``: the run to its end time, then the flow matrix of the last state factorized by MUMPS
under several option sets (orderings ICNTL(7), block low-rank ICNTL(35), no scaling):
CPU time of a reassembly + numeric refactorization, solve time, relative residual.
``window``: copy SRC's checkpoint and config into DST with the config keys changed (the
run identity dropped, so that the checkpoint resumes under other numerics); then
``dpcollapse run CONFIG --out DST --resume --set time.end_time=…`` continues it.
``schur``: the a = 0.5 box (0.3 × 0.06 m, cells of CELL m) run by LU to t = 0.02 s, then
its next flow system solved by FGMRES + Schur fieldsplit to 1e-8 with three weights 1/η of
the pressure mass: the mixture's S/2 (``TwoPhaseFlow.schur_viscosity``), (½ + γ) S (with
the grad-div term) and the granular law's S_g/2 (the light fluid as stiff as the grains).
"""

from __future__ import annotations

import cProfile
import io
import json
import pstats
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

CONFIG = Path(__file__).resolve().parents[2] / "configs" / "column_eulerian_a6.26.yaml"
EVENTS = ("MatLUFactorSym", "MatLUFactorNum", "MatSolve", "KSPSolve", "PCSetUp")
#: MUMPS option sets compared by ``lu`` (on top of the solver's ICNTL(14) = 200, ICNTL(24) = 0)
LU_OPTIONS = {
    "as in solvers.linear": {},
    "ICNTL(7)=3 (SCOTCH)": {"mat_mumps_icntl_7": 3},
    "ICNTL(7)=4 (PORD)": {"mat_mumps_icntl_7": 4},
    "ICNTL(7)=5 (METIS)": {"mat_mumps_icntl_7": 5},
    "ICNTL(7)=7 (automatic)": {"mat_mumps_icntl_7": 7},
    "BLR ICNTL(35)=2 CNTL(7)=1e-10": {"mat_mumps_icntl_35": 2, "mat_mumps_cntl_7": 1e-10},
    "BLR ICNTL(35)=2 CNTL(7)=1e-8": {"mat_mumps_icntl_35": 2, "mat_mumps_cntl_7": 1e-8},
    "ICNTL(8)=0 (no scaling)": {"mat_mumps_icntl_8": 0},
}


def _simulation(out: str, overrides: list[str], resume: bool):
    from mpi4py import MPI

    from dpcollapse.config import load_config
    from dpcollapse.simulation import Simulation

    config = Path(out) / "config.yaml" if resume else CONFIG
    return Simulation(load_config(config, overrides), out, quiet=True, resume=resume,
                      comm=MPI.COMM_WORLD)


def profile(out: str, overrides: list[str], resume: bool) -> None:
    from petsc4py import PETSc

    PETSc.Log.begin()
    sim = _simulation(out, overrides, resume)
    prof = cProfile.Profile(time.process_time)
    t0 = time.process_time()
    prof.enable()
    summary = sim.run()
    prof.disable()
    flow = sim.disc.flow
    print(f"run CPU {time.process_time() - t0:.1f} s, steps {summary['steps']}, flow solves "
          f"{summary['flow_solves']}, factorizations {summary['flow_factorizations']}, Krylov "
          f"iterations {summary['krylov_iterations']}, mean Picard {summary['mean_iterations']:.2f}")
    dofs = flow.W.dofmap.index_map.size_local * flow.W.dofmap.index_map_bs
    print(f"cells {flow.mesh.topology.index_map(2).size_local}, dofs {dofs}; seconds (wall) of "
          f"the last mesh: assembly {flow.system.seconds}, solver {flow.solver.seconds}")
    for name in EVENTS:
        info = PETSc.Log.Event(name).getPerfInfo()
        print(f"{name:16s} count {info['count']:5d}  time {info['time']:.2f} s")
    text = io.StringIO()
    pstats.Stats(prof, stream=text).sort_stats("tottime").print_stats(20)
    print(text.getvalue())


def lu_options(out: str, overrides: list[str]) -> None:
    from mpi4py import MPI
    from petsc4py import PETSc

    sim = _simulation(out, overrides, False)
    sim.run()
    system = sim.disc.flow.system
    A, b = system.assemble_matrix(), system.assemble_vector()
    for n, (label, extra) in enumerate(LU_OPTIONS.items()):
        prefix = f"bench_lu{n}_"
        opts = PETSc.Options()
        for key, value in ({"mat_mumps_icntl_14": 200, "mat_mumps_icntl_24": 0} | extra).items():
            opts[prefix + key] = value
        ksp = PETSc.KSP().create(MPI.COMM_WORLD)
        ksp.setOptionsPrefix(prefix)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType("mumps")
        ksp.setFromOptions()
        ksp.setOperators(A)
        t0 = time.process_time()
        ksp.setUp()
        first = time.process_time() - t0
        again = []
        for _ in range(3):   # reassembly bumps the matrix state: a numeric refactorization
            t0 = time.process_time()
            system.assemble_matrix()
            ksp.setUp()
            again.append(time.process_time() - t0)
        x, r = b.duplicate(), b.duplicate()
        t0 = time.process_time()
        ksp.solve(b, x)
        solve = time.process_time() - t0
        A.mult(x, r)
        r.axpy(-1.0, b)
        print(f"{label:32s} first {first:.2f} s, reassembly + refactorization {min(again):.3f} s, "
              f"solve {solve:.3f} s, relative residual {r.norm() / b.norm():.1e}", flush=True)
        ksp.destroy()


def window(src: str, dst: str, overrides: list[str]) -> None:
    src_dir, dst_dir = Path(src), Path(dst)
    dst_dir.mkdir(parents=True, exist_ok=False)
    shutil.copy(src_dir / "checkpoint.npz", dst_dir)
    cfg = yaml.safe_load((src_dir / "config.yaml").read_text())
    for item in overrides:
        key, value = item.split("=", 1)
        section, name = key.split(".")
        cfg.setdefault(section, {})[name] = yaml.safe_load(value)
    (dst_dir / "config.yaml").write_text(yaml.safe_dump(cfg))
    path = dst_dir / "checkpoint.npz"
    data = dict(np.load(path, allow_pickle=False))
    state = json.loads(str(data["state"]))
    state.pop("run", None)     # another run's identity: the resume would refuse it
    data["state"] = np.array(json.dumps(state))
    np.savez(path, **data)


def schur_weights(cell: float) -> None:
    import ufl

    from dpcollapse.models.two_phase.flow import TwoPhaseFlow

    def weight(factor, granular_only):
        def schur_viscosity(self):
            law = self.params.rheology if granular_only else self.law
            return factor(self) * law.secant_viscosity(*ufl.split(self.iterate), self.epsilon)
        return schur_viscosity

    weights = {"mixture S/2": weight(lambda f: 0.5, False),
               "mixture (1/2 + gamma) S": weight(lambda f: 0.5 + f.light.grad_div, False),
               "granular law S_g/2": weight(lambda f: 0.5, True)}
    original = TwoPhaseFlow.schur_viscosity
    try:
        with tempfile.TemporaryDirectory() as tmp:
            for n, (label, method) in enumerate(weights.items()):
                TwoPhaseFlow.schur_viscosity = method
                print(f"{label:26s} {cell} m: {_schur_iterations(cell, Path(tmp) / str(n))}")
    finally:
        TwoPhaseFlow.schur_viscosity = original


def _schur_iterations(cell: float, tmp: Path) -> str:
    """FGMRES iterations of the a = 0.5 box's flow system after 0.02 s of LU steps."""
    from mpi4py import MPI

    from dpcollapse.config import load_config
    from dpcollapse.simulation import Simulation

    box = CONFIG.parent / "column_eulerian_a0.5.yaml"
    base = ["model.box_height=0.06", f"geometry.mesh_size={cell}", "time.output_every=1000",
            "time.checkpoint_every=1000"]
    lu = Simulation(load_config(box, base + ["time.end_time=0.02"]), tmp / "lu", quiet=True,
                    comm=MPI.COMM_SELF)
    lu.run()
    it = Simulation(load_config(box, base + ["numerics.linear_solver=iterative",
                                             "numerics.krylov_rtol=1e-8"]),
                    tmp / "it", quiet=True, comm=MPI.COMM_SELF)
    flow = it.disc.flow
    flow.copy_state_from(lu.disc.flow)
    flow.set_step(1e-3)
    flow.solver.set_operator(flow.system.assemble_matrix())
    try:
        flow.system.solve(flow.solver, target=flow.solution, b=flow.system.assemble_vector())
    except RuntimeError as exc:
        return str(exc)
    return f"{flow.solver.last_iterations} FGMRES iterations"


def main(argv: list[str]) -> None:
    command, *rest = argv
    if command == "profile":
        resume = "--resume" in rest
        out, *overrides = [a for a in rest if a != "--resume"]
        profile(out, overrides, resume)
    elif command == "lu":
        lu_options(rest[0], rest[1:])
    elif command == "window":
        window(rest[0], rest[1], rest[2:])
    elif command == "schur":
        schur_weights(float(rest[0]))
    else:
        raise SystemExit(f"unknown command {command!r}: profile, lu, window or schur")


if __name__ == "__main__":
    main(sys.argv[1:])
