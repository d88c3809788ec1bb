"""The two-phase model's linear algebra and step control: the block preconditioner
(``numerics.linear_solver: iterative``, with the mixture's grad-div viscosity in its Schur
approximation) gives the LU answer, MUMPS's symbolic analysis is done once per mesh, and a
step the fixed point fails is halved on the adaptive box too; ``numerics.fixed_iterations``
accepts a step after that many iterates (1: the linearly implicit step)."""

import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

from dpcollapse.config import load_config
from dpcollapse.errors import ConfigError
from dpcollapse.io.diagnostics import read_diagnostics
from dpcollapse.solvers.iterative import BlockSolver
from dpcollapse.solvers.linear import DirectSolver
from tests.helpers import ROOT, simulation

CONFIG = "column_eulerian_a0.5.yaml"
#: a = 0.5 on the 0.3 m × 0.06 m box in 2 cm cells (15 × 3 squares)
TINY = ["model.box_height=0.06", "geometry.mesh_size=0.02", "time.output_every=1000",
        "time.checkpoint_every=1000"]


def _flow(tmp_path, name, overrides, run=True):
    """A two-phase run of TINY (its mesh, c and state after the run, or at the start)."""
    sim = simulation(CONFIG, TINY + list(overrides), tmp_path / name, comm=MPI.COMM_SELF)
    if run:
        sim.run()
    return sim


def test_block_preconditioner_gives_the_lu_solution(tmp_path):
    """Three LU steps of the collapse (the mixture in motion: ρ and S jump by 1e3 and more
    across c = ½), then the next Picard system solved by MUMPS and by FGMRES + Schur
    fieldsplit on the same mesh: the same (u, p) to 1e-7 relative, in fewer than 200
    iterations."""
    lu = _flow(tmp_path, "lu", ["time.end_time=0.003"])
    it = _flow(tmp_path, "it", ["numerics.linear_solver=iterative", "numerics.krylov_rtol=1e-12"],
               run=False)
    a_flow, b_flow = lu.disc.flow, it.disc.flow
    assert isinstance(a_flow.solver, DirectSolver) and isinstance(b_flow.solver, BlockSolver)
    b_flow.copy_state_from(a_flow)
    for flow in (a_flow, b_flow):
        flow.set_step(1e-3)
        flow.solver.set_operator(flow.system.assemble_matrix())
        flow.system.solve(flow.solver, target=flow.solution, b=flow.system.assemble_vector())
    x, y = a_flow.solution.x.array, b_flow.solution.x.array
    for dofs in (a_flow.velocity_dofs, a_flow.pressure_dofs):
        assert np.linalg.norm(y[dofs] - x[dofs]) <= 1e-7 * np.linalg.norm(x[dofs])
    assert 0 < b_flow.solver.last_iterations < 200


def test_lu_symbolic_analysis_once_per_mesh(tmp_path):
    """The matrix is reassembled in place (same nonzero pattern), so PETSc redoes only MUMPS's
    numeric factorization: one symbolic analysis for every numeric one of a run on one mesh."""
    PETSc.Log.begin()
    symbolic, numeric = PETSc.Log.Event("MatLUFactorSym"), PETSc.Log.Event("MatLUFactorNum")
    before = symbolic.getPerfInfo()["count"], numeric.getPerfInfo()["count"]
    sim = _flow(tmp_path, "lu", ["time.end_time=0.004"])
    after = symbolic.getPerfInfo()["count"], numeric.getPerfInfo()["count"]
    factorizations = sim.disc.flow.solver.factorizations
    assert factorizations >= 4
    assert after[1] - before[1] == factorizations
    assert after[0] - before[0] == 1


def test_failed_step_is_halved_on_the_adaptive_box(tmp_path):
    """The first step from rest needs more Picard iterations than allowed: the loop halves
    it and goes on (the adaptive box's domain takes the loop's recompute(disc, dt))."""
    summary = simulation(CONFIG, TINY + ["model.min_cell=0.01", "model.max_cell=0.04",
                                         "time.dt=4e-3", "time.end_time=0.004",
                                         "numerics.max_iterations=4"],
                         tmp_path / "halved", comm=MPI.COMM_SELF).run()
    assert summary["status"] == "end_time" and summary["halved_steps"] >= 1


def test_fixed_iterations_accepts_each_step_after_that_many_iterates(tmp_path):
    """numerics.fixed_iterations = 1: one linear solve (one LU) per step, every step taken;
    the front and height stay within a 2 cm cell of the converged run's at t = 0.05 s."""
    over = ["time.end_time=0.05", "time.dt=2e-3"]
    one = _flow(tmp_path, "one", over + ["numerics.fixed_iterations=1"])
    converged = _flow(tmp_path, "converged", over)
    its = [i for i in read_diagnostics(tmp_path / "one" / "diagnostics.csv")["iterations"]
           if np.isfinite(i)]   # the row of t = 0 has none
    assert set(its) == {1} and one.disc.flow.solver.factorizations == len(its) == 25
    assert converged.disc.flow.solver.factorizations > 25
    a, b = one.disc.measures(), converged.disc.measures()
    for key in ("front", "max_height"):
        assert abs(a[key] - b[key]) <= 0.02, key


def test_fixed_iterations_needs_picard():
    with pytest.raises(ConfigError, match="numerics.fixed_iterations = 1: only with"):
        load_config(ROOT / "configs" / CONFIG, ["numerics.fixed_iterations=1",
                                                "numerics.nonlinear_solver=newton"])
