"""Cholesky for symmetric positive definite systems (the mesh velocity, issue 25): PETSc's
own factorization in serial, MUMPS's (SYM = 1) under MPI, with LU's solution."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.ale.motion import MeshMotion
from dpcollapse.config import load_config
from dpcollapse.models.stokes.discretization import make_flow
from dpcollapse.scenes.registry import build_mesh
from dpcollapse.solvers.linear import DirectSolver
from tests.helpers import ROOT, petsc_matrix

RIGID = ROOT / "configs" / "rigid.yaml"


def test_positive_definite_solver_is_cholesky_with_lu_solution():
    n = 12
    rng = np.random.default_rng(5)
    K = rng.normal(size=(n, n))
    dense = K @ K.T + n * np.eye(n)
    A = petsc_matrix(dense)
    b = A.createVecLeft()
    b.array[:] = rng.normal(size=n)
    solutions = []
    for spd in (False, True):
        solver = DirectSolver(MPI.COMM_SELF, "mumps", prefix=f"test_spd{int(spd)}_",
                              positive_definite=spd)
        x = A.createVecRight()
        solver.set_operator(A)
        solver.solve(b, x)
        solutions.append(x.array.copy())
        pc = solver.ksp.getPC()
        assert pc.getType() == ("cholesky" if spd else "lu")
        assert pc.getFactorSolverType() == ("petsc" if spd else "mumps")
        solver.destroy()
    np.testing.assert_allclose(solutions[1], solutions[0], rtol=1e-12)
    np.testing.assert_allclose(dense @ solutions[1], b.array, atol=1e-10)


@pytest.mark.mpi
def test_the_mesh_velocity_by_cholesky_equals_lu():
    """The rigid collapse's mesh velocity after one step: Cholesky (PETSc's in serial, MUMPS's
    under mpirun -n 2) against MUMPS LU on the same assembled system, to 1e-10 of max |w|."""
    comm = MPI.COMM_WORLD
    cfg = load_config(RIGID, ["geometry.mesh_size=0.04", "time.scheme=bdf1", "time.tolerance=null"])
    flow = make_flow(build_mesh(cfg, comm), cfg)
    assert flow.solve_step(1e-2).converged
    flow.accept_step()
    motion = MeshMotion(flow, cfg.numerics.mesh_velocity_penalty)
    pc = motion.solver.ksp.getPC()
    assert pc.getType() == "cholesky"
    assert pc.getFactorSolverType() == ("petsc" if comm.size == 1 else "mumps")
    motion.compute()
    w_cholesky = motion.w.x.array.copy()
    lu = DirectSolver(comm, "mumps", prefix="test_ale_lu_")
    lu.set_operator(motion.system.assemble_matrix())
    lu.solve(motion.system.assemble_vector(), compat.petsc_vec(motion.w))
    motion.w.x.scatter_forward()
    scale = comm.allreduce(float(np.abs(w_cholesky).max()), op=MPI.MAX)
    assert scale > 1e-3          # the mass moves: w is not trivially zero
    diff = comm.allreduce(float(np.abs(motion.w.x.array - w_cholesky).max()), op=MPI.MAX)
    assert diff <= 1e-10 * scale
    lu.destroy()
    motion.destroy()
    flow.destroy()


@pytest.mark.parametrize("where", ["matrix", "right-hand side"])
def test_a_non_finite_system_is_refused_before_the_factorization(where):
    """A NaN in the matrix or an Inf in b (issue 47: MUMPS's symbolic analysis of such a
    matrix never returned) raises NonFiniteSystem, a RuntimeError: the step's attempt fails
    and is retried shorter, as after a failed factorization."""
    from dpcollapse.solvers.linear import NonFiniteSystem

    dense = 4.0 * np.eye(6) + np.diag(np.ones(5), 1) + np.diag(np.ones(5), -1)
    if where == "matrix":
        dense[2, 3] = np.nan
    A = petsc_matrix(dense)
    b = A.createVecLeft()
    b.array[:] = 1.0
    if where != "matrix":
        b.array[4] = np.inf
    solver = DirectSolver(MPI.COMM_SELF, "mumps", prefix=f"test_nan_{where[0]}_")
    solver.set_operator(A)
    with pytest.raises(NonFiniteSystem, match=f"non-finite {where}"):
        solver.solve(b, A.createVecRight())
    assert isinstance(NonFiniteSystem("x"), RuntimeError)
    solver.destroy()
