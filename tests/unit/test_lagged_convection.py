"""numerics.convection: lagged (issue 25, docs/benchmarks/2026-12-04-lagged-convection.md):
the convection taken at the Picard iterate on the right-hand side leaves a symmetric
matrix, factorized by MUMPS as LDLᵀ, and the same fixed point as the implicit convection."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI

from dpcollapse.cli import main
from dpcollapse.config import load_config
from dpcollapse.forms.picard import picard_terms
from dpcollapse.models.stokes.discretization import make_flow
from dpcollapse.scenes.registry import build_mesh
from dpcollapse.solvers.linear import DirectSolver
from tests.helpers import ROOT, petsc_matrix

RIGID = ROOT / "configs" / "rigid.yaml"
#: a coarse, tightly converged rigid collapse: 5 steps of 5 ms from rest (convection
#: ρ(u·∇)u of order 10 % of the weight by the last step)
TIGHT = ["geometry.mesh_size=0.05", "numerics.epsilon=1e-2", "numerics.epsilon_friction=1e-3",
         "numerics.nonlinear_rtol=1e-11", "numerics.nonlinear_atol=0", "time.scheme=bdf1",
         "time.tolerance=null", "numerics.max_iterations=300"]


def test_the_lagged_terms_move_the_convection_to_the_right_hand_side():
    import ufl
    from dolfinx import fem

    from dpcollapse import compat
    from dpcollapse.rheology.drucker_prager import DruckerPrager

    domain = compat.create_rectangle(MPI.COMM_SELF, (0.0, 0.0), (1.0, 1.0), (2, 2))
    V, Q = compat.vector_space(domain, 1), compat.scalar_space(domain, 1)
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    p, q = ufl.TrialFunction(Q), ufl.TestFunction(Q)
    vector = fem.Function(V)
    kw = dict(rho=1.0, dt=1.0, body_force=vector, epsilon=1e-3, epsilon_friction=1e-3,
              u_iter=vector, p_iter=fem.Function(Q), u_old=vector, mesh_velocity=vector,
              trial=(u, p), test=(v, q), n=ufl.FacetNormal(domain))
    law = DruckerPrager(friction_coefficient=0.5, viscosity=1.0)
    lhs, rhs = picard_terms(law, **kw)
    assert "convection" in lhs and "convection" not in rhs
    lhs, rhs = picard_terms(law, convection="lagged", **kw)
    assert "convection" not in lhs and "convection" in rhs
    with pytest.raises(ValueError, match="convection = 'explicit'"):
        picard_terms(law, convection="explicit", **kw)


def test_lagged_convection_has_the_implicit_fixed_point():
    """Both ways to 1e-11: the same velocities (to 1e-8 of the largest), a symmetric matrix
    and an LDLᵀ factorization only with the lagged convection."""
    velocities = {}
    for convection in ("implicit", "lagged"):
        cfg = load_config(RIGID, TIGHT + [f"numerics.convection={convection}"])
        flow = make_flow(build_mesh(cfg, MPI.COMM_SELF), cfg)
        for _ in range(5):
            report = flow.solve_step(5e-3)
            assert report.converged, (convection, report)
            flow.accept_step()
        A = flow.system.assemble_matrix()
        B = A.duplicate(copy=True)
        B.axpy(-1.0, A.duplicate(copy=True).transpose())
        asymmetry = B.norm() / A.norm()
        lagged = convection == "lagged"
        assert (asymmetry < 1e-14) if lagged else (asymmetry > 1e-12), (convection, asymmetry)
        assert flow.solver.symmetric == lagged
        assert flow.solver.ksp.getPC().getType() == ("cholesky" if lagged else "lu")
        velocities[convection] = flow.velocity_values().copy()
        flow.destroy()
    implicit, lagged = velocities["implicit"], velocities["lagged"]
    scale = np.max(np.abs(implicit))
    assert scale > 0.1       # the mass moves: the convection is not negligible
    assert np.max(np.abs(lagged - implicit)) <= 1e-8 * scale


def test_symmetric_direct_solver_solves_a_saddle_point_as_lu_does():
    """LDLᵀ (MUMPS, symmetric indefinite) on [[K, Bᵀ], [B, 0]] = LU's solution; SuperLU_dist
    has no LDLᵀ and stays LU."""
    n, m = 6, 2
    rng = np.random.default_rng(3)
    K = rng.normal(size=(n, n))
    K = K @ K.T + n * np.eye(n)
    B = rng.normal(size=(m, n))
    dense = np.block([[K, B.T], [B, np.zeros((m, m))]])
    A = petsc_matrix(dense)
    b = A.createVecLeft()
    b.array[:] = rng.normal(size=n + m)
    solutions = []
    for symmetric in (False, True):
        solver = DirectSolver(MPI.COMM_SELF, "mumps", prefix=f"test_sym{int(symmetric)}_",
                              symmetric=symmetric)
        x = A.createVecRight()
        solver.set_operator(A)
        solver.solve(b, x)
        solutions.append(x.array.copy())
        assert solver.ksp.getPC().getType() == ("cholesky" if symmetric else "lu")
        solver.destroy()
    np.testing.assert_allclose(solutions[1], solutions[0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(dense @ solutions[1], b.array, atol=1e-10)
    assert not DirectSolver(MPI.COMM_SELF, "superlu_dist", prefix="test_slu_", symmetric=True).symmetric


def test_bad_convection_one_line(capsys):
    assert main(["check", str(RIGID), "--set", "numerics.convection=upwind"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert (
        len(err) == 1 and "numerics.convection = 'upwind': must be one of 'implicit' or 'lagged'" in err[0]
    ), err


def test_other_methods_keep_their_convection():
    """The key is the regularized Picard iteration's: the augmented Lagrangian keeps LU."""
    cfg = load_config(RIGID, ["geometry.mesh_size=0.05", "numerics.method=augmented_lagrangian",
                              "time.scheme=bdf1", "time.tolerance=null", "numerics.convection=lagged"])
    flow = make_flow(build_mesh(cfg, MPI.COMM_SELF), cfg)
    assert flow.solver.ksp.getPC().getType() == "lu"
    flow.destroy()


def test_the_two_phase_model_keeps_lu_under_rigid_yaml():
    """configs/rigid.yaml (lagged) on the two-phase model: its skew-symmetric convection stays
    in the matrix, which is not symmetric — factorized by LU, never LDLᵀ."""
    from dpcollapse.models.two_phase.adapter import TwoPhaseFactory

    cfg = load_config(RIGID, ["model.name=two_phase", "numerics.ale=false", "time.scheme=bdf1",
                              "time.tolerance=null", "geometry.mesh_size=0.05"])
    assert cfg.numerics.convection == "lagged"
    disc = TwoPhaseFactory.from_config(cfg).start(MPI.COMM_SELF)
    assert disc.flow.settings.convection == "implicit"
    assert disc.flow.solver.ksp.getPC().getType() == "lu" and not disc.flow.solver.symmetric
    disc.destroy()
