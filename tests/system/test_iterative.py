"""numerics.linear_solver: iterative (FGMRES + Schur fieldsplit, AMG): the LU answer, the
Krylov counts, failures that the Picard loop can catch, one-line config errors, MPI."""

import json

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.cli import main
from dpcollapse.config import load_config
from dpcollapse.io.diagnostics import read_diagnostics
from dpcollapse.models.stokes.discretization import flow_parameters, initial_velocity, picard_settings
from dpcollapse.models.stokes.regularized import RegularizedFlow
from dpcollapse.scenes.registry import build_mesh
from dpcollapse.simulation import Simulation
from dpcollapse.solvers.iterative import BlockSolver
from dpcollapse.solvers.linear import DirectSolver
from tests.helpers import RIGID_BDF1, ROOT

RIGID = ROOT / "configs" / "rigid.yaml"
TINY = ["geometry.mesh_size=0.04", "time.end_time=0.005", "time.output_every=1000",
        "time.checkpoint_every=1000"]


def _flows(overrides, solvers=("mumps", "iterative"), comm=MPI.COMM_WORLD):
    """Flows with the given linear solvers on the same 4 cm mesh, at rest."""
    cfg = load_config(RIGID, ["geometry.mesh_size=0.04", *RIGID_BDF1] + list(overrides))
    tagged = build_mesh(cfg, comm)
    flows = []
    for solver in solvers:
        c = load_config(RIGID, ["geometry.mesh_size=0.04", *RIGID_BDF1,   # solved w/o set_step
                                f"numerics.linear_solver={solver}"] + list(overrides))
        flow = RegularizedFlow(tagged, flow_parameters(c), picard_settings(c))
        flow.set_velocity(initial_velocity(c))
        flows.append(flow)
    return flows


def test_iterative_solve_equals_lu_solve():
    """Three LU time steps (pressure built from zero, then flow: η from 2 to ~1e9 Pa s), then
    one linear system of the next Picard iterate solved both ways: the same (u, p) to 1e-8
    relative (measured: 8e-11 velocity, 2e-9 pressure)."""
    lu, it = _flows([])
    assert isinstance(lu.solver, DirectSolver) and isinstance(it.solver, BlockSolver)
    for _ in range(3):
        assert lu.solve_step(1e-3).converged
        lu.accept_step()
    it.copy_state_from(lu)
    for flow in (lu, it):
        flow.solver.set_operator(flow.system.assemble_matrix())
        flow.system.solve(flow.solver, target=flow.solution, b=flow.system.assemble_vector())
    a, b = lu.solution.x.array, it.solution.x.array
    for dofs in (lu.velocity_dofs, lu.pressure_dofs):
        assert np.linalg.norm(b[dofs] - a[dofs]) <= 1e-8 * np.linalg.norm(a[dofs])
    assert it.solver.solves == it.solver.factorizations == 1
    assert 0 < it.solver.last_iterations == it.solver.krylov_iterations <= 500
    assert lu.solver.krylov_iterations == 0
    for flow in (lu, it):
        flow.destroy()


def test_failed_krylov_solve_fails_the_step():
    """A Krylov solve that does not converge raises RuntimeError inside the solver; the Picard
    loop reports an unconverged step (the time loop then halves Δt) and restores the state."""
    (it,) = _flows(["numerics.krylov_max_iterations=2"], solvers=("iterative",))
    start = it.iterate.x.array.copy()
    report = it.solve_step(1e-3)
    assert not report.converged and "Krylov solve failed after 2 iterations" in report.message
    assert np.array_equal(it.iterate.x.array, start)
    with pytest.raises(RuntimeError, match="Krylov solve failed"):
        it.solver.set_operator(it.system.assemble_matrix())
        it.system.solve(it.solver, target=it.solution, b=it.system.assemble_vector())
    it.destroy()


def test_run_reports_krylov_iterations(tmp_path):
    """The run's summary (run.json) carries the Krylov iterations; the same run with LU has
    none, the same Picard iterations and the same diagnostics to 1e-5 (measured 2e-6: the
    Krylov tolerance 1e-10 passed through the Picard/Anderson loop)."""
    runs = {}
    for solver in ("mumps", "iterative"):
        cfg = load_config(RIGID, TINY + [f"numerics.linear_solver={solver}"])
        summary = Simulation(cfg, tmp_path / solver, quiet=True).run()
        info = json.loads((tmp_path / solver / "run.json").read_text())
        assert info["summary"]["krylov_iterations"] == summary["krylov_iterations"]
        runs[solver] = summary, read_diagnostics(tmp_path / solver / "diagnostics.csv")
    (s_lu, d_lu), (s_it, d_it) = runs["mumps"], runs["iterative"]
    assert s_lu["krylov_iterations"] == 0
    assert s_it["krylov_iterations"] >= s_it["flow_solves"] == s_lu["flow_solves"] > 0
    assert d_it["iterations"] == d_lu["iterations"]
    for key in ("front", "max_height", "kinetic_energy", "max_speed"):
        np.testing.assert_allclose(d_it[key], d_lu[key], rtol=1e-5, atol=1e-12, err_msg=key)


@pytest.mark.parametrize("overrides, expected", [
    (["numerics.linear_solver=gmres"],
     "numerics.linear_solver = 'gmres': must be one of 'mumps', 'superlu_dist' or 'iterative'"),
    (["numerics.linear_solver=iterative", "numerics.method=augmented_lagrangian"],
     "numerics.linear_solver = 'iterative': only with numerics.method = regularized"),
    (["numerics.linear_solver=iterative", "numerics.reuse_factorization=true"],
     "numerics.reuse_factorization = true: needs a direct numerics.linear_solver"),
    (["numerics.krylov_rtol=0"], "numerics.krylov_rtol = 0: must be in (0, 1)"),
    (["numerics.krylov_max_iterations=0"], "numerics.krylov_max_iterations = 0: must be >= 1"),
])
def test_bad_config_one_line(overrides, expected, capsys):
    argv = ["check", str(RIGID)] + [a for o in overrides for a in ("--set", o)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and expected in err[0], err


def test_periodic_layer_refused(capsys):
    assert main(["check", str(ROOT / "configs" / "plug.yaml"), "--set",
                 "numerics.linear_solver=iterative"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not available on a periodic domain" in err[0], err


@pytest.mark.mpi
def test_iterative_on_all_ranks_matches_serial(shared_tmp, comm):
    """The tiny iterative run on all ranks gives the serial run's Picard iterations and
    diagnostics to 1e-5 (the AMG hierarchy depends on the partition; measured 2e-6)."""
    over = TINY + ["numerics.linear_solver=iterative"]
    cfg = load_config(RIGID, over)
    Simulation(cfg, shared_tmp / "parallel", quiet=True, comm=comm).run()
    comm.barrier()
    if comm.rank == 0:
        Simulation(cfg, shared_tmp / "serial", quiet=True, comm=MPI.COMM_SELF).run()
        d_par = read_diagnostics(shared_tmp / "parallel" / "diagnostics.csv")
        d_ser = read_diagnostics(shared_tmp / "serial" / "diagnostics.csv")
        assert d_par["iterations"] == d_ser["iterations"]
        for key in ("t", "front", "max_height", "kinetic_energy", "max_speed"):
            np.testing.assert_allclose(d_par[key], d_ser[key], rtol=1e-5, atol=1e-12, err_msg=key)
