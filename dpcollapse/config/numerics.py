"""``boundary`` and ``numerics``: the bed and wall conditions, the 2D model's solvers."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import (
    Field,
    model_validator,
)

from dpcollapse.config.fields import Count, Number, _f, _Section
from dpcollapse.errors import ConfigError


class BoundaryConfig(_Section):
    """The bed (Coulomb friction or no slip) and the left wall (Coulomb friction)."""

    bed_condition: Literal["coulomb", "no_slip"] = _f(
        "coulomb", "", "Bed: no penetration + Coulomb friction, or no slip (u = 0)")
    bed_friction_angle: Number = _f(25.5, "deg", "Bed friction angle; mu_b = tan", ge=0, lt=90)
    wall_friction_angle: Number = _f(
        10.2, "deg", "Left-wall friction angle; mu_l = tan", ge=0, lt=90
    )
    channel_width: Number | None = _f(
        None, "m", "Width w of the channel: adds the side-wall friction (2/w) mu_w p u/|u| "
        "(null: no side walls)", gt=0)
    side_wall_friction_angle: Number = _f(
        10.2, "deg", "Side-wall friction angle; mu_w = tan (used with channel_width)", ge=0, lt=90)
    surface_tension: Number = _f(
        0.0, "N/m", "Local surface tension of seed 000 on the free surface: the height gamma0_bar "
        "of gamma0_i = gamma0_bar (max{0, 1 - ((i - i_c)/delta)^2})^2 around the node i_c of "
        "largest curvature, traction sigma.N = -gamma0_i C_i N (0: off; it must vanish with the "
        "mesh size, gamma0_bar = o(h))", ge=0)
    surface_tension_extent: Number = _f(
        3.0, "nodes", "Extent delta of the local surface tension around i_c, in free-surface "
        "nodes (used when surface_tension > 0)", gt=0)

    @property
    def mu_side(self) -> float:
        """Side-wall friction coefficient mu_w = tan(side_wall_friction_angle) [-]."""
        return math.tan(math.radians(self.side_wall_friction_angle))

    @property
    def mu_bed(self) -> float:
        """Bed friction coefficient mu_b = tan(bed_friction_angle) [-]."""
        return math.tan(math.radians(self.bed_friction_angle))

    @property
    def mu_wall(self) -> float:
        """Wall friction coefficient mu_l = tan(wall_friction_angle) [-]."""
        return math.tan(math.radians(self.wall_friction_angle))


class NumericsConfig(_Section):
    """Regularization, the fixed-point iteration, the linear solver and the moving mesh."""

    method: Literal["regularized", "augmented_lagrangian"] = _f(
        "regularized", "", "Treatment of the yield stress and wall friction: regularization "
        "(Picard) or augmented Lagrangian (exact rigid zones)")
    augmentation: Number | None = _f(
        None, "Pa s", "Augmented Lagrangian: penalty r (null: 2*rho*sqrt(g)*h0^1.5)", gt=0)
    augmentation_friction: Number | None = _f(
        None, "Pa s/m", "Augmented Lagrangian: friction penalty r_f (null: 10*r/h0)", gt=0)
    augmented_max_iterations: Count = _f(
        5000, "", "Augmented Lagrangian: most iterations per time step (each is one "
        "back-substitution, no factorization)", ge=1)
    epsilon: Number = _f(1.0e-6, "1/s", "Regularization of |D|", gt=0)
    epsilon_friction: Number = _f(1.0e-6, "m/s", "Regularization of |u_T| in wall friction", gt=0)
    nonlinear_rtol: Number = _f(
        1.0e-3, "", "Fixed-point stop: ||du|| <= rtol*||u|| + atol (relative part)", gt=0, lt=1
    )
    nonlinear_atol: Number | None = _f(
        None, "m/s", "Fixed-point stop, absolute part (null: min(0.3*time.tolerance, "
        "0.03*time.rest_speed) with the error-controlled step, 1e-7 with a fixed step)", ge=0)
    max_iterations: Count = _f(100, "", "Most fixed-point iterations per time step", ge=1)
    nonlinear_solver: Literal["picard", "newton"] = _f(
        "picard", "", "Regularized method: Picard fixed point (secant viscosity, Anderson) or "
        "Newton (PETSc SNES, exact Jacobian, LU; same stop test on the velocity updates)")
    newton_line_search: Literal["bt", "basic", "l2", "cp", "nleqerr"] = _f(
        "bt", "", "Newton: SNES line search (bt backtracking, basic = full steps)")
    newton_max_iterations: Count = _f(
        25, "", "Newton: most iterations per time step (per continuation stage)", ge=1)
    newton_picard_start: Count = _f(
        0, "", "Newton: Picard iterations before the first Newton iteration of a step", ge=0, le=100)
    newton_fallback: bool = Field(
        True, strict=True, description="Newton: a time step Newton fails is redone by the "
        "Picard fixed point (with Anderson) before the step is halved")
    newton_epsilon_start: Number | None = _f(
        None, "1/s", "Newton: epsilon-continuation within a step, from this down to "
        "numerics.epsilon by factors of 10 (null: none)", gt=0)
    newton_epsilon_friction_start: Number | None = _f(
        None, "m/s", "Newton: continuation of the wall-friction regularization within a step, "
        "from this down to numerics.epsilon_friction by factors of 10 (null: none)", gt=0)
    newton_stop: Literal["update", "residual"] = _f(
        "update", "", "Newton: stop test. update: the Picard test on the velocity updates "
        "(>= 2 Jacobians per step); residual: predicted error ||du_k||*||F_k||/||F_k-1|| "
        "<= rtol*||u|| + atol after a full step (can stop after one Jacobian)")
    reuse_factorization: bool = _f(
        False, "", "Factorize once per time step; later fixed-point iterates solve with GMRES "
        "preconditioned by that LU (experimental)")
    extrapolate: bool = Field(
        False, strict=True, description="Start each step's fixed point from the linear "
        "extrapolation of the last two steps instead of the last state")
    fixed_iterations: Count | None = _f(
        None, "", "Regularized Picard: accept each step after this many fixed-point iterates "
        "even when nonlinear_rtol is not met (earlier when it is); 1: the linearly implicit "
        "step, viscosity and convection at the step's start (as Basilisk's granular.h); null: iterate "
        "to nonlinear_rtol", ge=1)
    convection: Literal["implicit", "lagged"] = _f(
        "implicit", "", "Picard fixed point of the regularized method (model stokes): the "
        "convection in the matrix, linearized at the iterate (implicit), or wholly at the iterate "
        "on the right-hand side (lagged: the same fixed point, a symmetric matrix that MUMPS "
        "factorizes as LDL^T at about half the cost of LU); the augmented Lagrangian, Newton's "
        "own iterations and the two-phase model keep their convection")
    anderson_depth: Count = _f(
        5, "", "Anderson acceleration of the fixed point: history length m (0 = plain Picard)",
        ge=0, le=50)
    linear_solver: Literal["mumps", "superlu_dist", "iterative"] = _f(
        "mumps", "", "Flow solver: direct LU (mumps, superlu_dist) or iterative (FGMRES, Schur "
        "fieldsplit, AMG velocity block; regularized method, not on a periodic layer)")
    krylov_rtol: Number = _f(
        1.0e-10, "", "linear_solver iterative: relative residual of the FGMRES solve; with "
        "reuse_factorization, of the GMRES solve on the stale factorization", gt=0, lt=1)
    krylov_max_iterations: Count = _f(
        500, "", "linear_solver iterative: most FGMRES iterations per solve (more: the step "
        "is retried with half the time step)", ge=1)
    quadrature_degree: Count | None = _f(
        None, "", "Quadrature degree of the nonlinear terms (secant viscosity, convection, "
        "friction); null: UFL's estimate (8 in cells, 17 on friction facets)", ge=1, le=20)
    mesh_velocity_penalty: Number = _f(
        1.0e3, "", "Penalty xi-hat on (w-u).n on the free surface (dimensionless, applied as xi-hat/h)", gt=0
    )
    remesh_min_angle: Number = _f(
        12.0, "deg", "Remesh when the smallest cell angle falls below this", gt=0, lt=60
    )
    remesh_film_trim: Number = _f(
        0.0, "", "Remeshing cuts off the front film thinner than this fraction of "
        "geometry.mesh_size (vertical cut where the mass is last that thick; 0: off)", ge=0, lt=1)
    remesh_film_trim_grains: Number = _f(
        0.0, "", "mu(I): remeshing also cuts off the front film thinner than this many grain "
        "diameters material.grain_diameter (the larger of the two trims; 0: off)", ge=0, le=10)
    remesh_film_trim_face: Literal["repose", "vertical"] = _f(
        "repose", "", "The film trim's cut face: at the angle of repose, slope min(mu_s, mu_b) "
        "(the material's and, on a Coulomb bed, the bed's friction) from the trim's thickness "
        "delta down to the bed, where the front is slower than sqrt(g delta) (a deposit; a "
        "faster front is cut vertically), or vertical always (before 2026-12-07)")
    remesh_conserve_area: bool = Field(
        False, strict=True, description="Remeshing puts back the area that untangling a fold, "
        "trimming the film and resampling changed, by moving the free surface along its normal")
    step_conserve_area: bool = Field(
        False, strict=True, description="Every mesh move puts back its own area change (the "
        "dt^2 term of the explicit node update) by moving the free surface along its normal; "
        "geometry.symmetry axisymmetric: the body's volume 2 pi r dA")
    remesh_surgery: bool = Field(
        True, strict=True, description="Remeshing rebuilds a free surface that touches the bed "
        "or the mass itself (closer than 0.25 geometry.mesh_size, or crossing) as the union of "
        "the mass; enclosed pockets of 4 cells or more are kept as holes, smaller ones closed")
    ale: bool = Field(True, strict=True, description="Move the mesh (false: fixed domain)")
    mesh_tolerance: Number | None = _f(
        None, "m/s", "Moving mesh: the accuracy asked of the mesh instead of a size: every "
        "remesh sizes the cells inside so that the Zienkiewicz-Zhu indicator of the velocity, "
        "eta_K = ||G* - grad u_h||_L2(K) (about the velocity error on the cell), comes to this "
        "(h_new = h (tol/eta_K)^(1/3), within mesh_size_min..mesh_size_max; the free surface "
        "keeps geometry.surface_mesh_size or mesh_size, the first mesh geometry.mesh_size); "
        "null: uniform geometry.mesh_size", gt=0, le=1)
    mesh_size_min: Number | None = _f(
        None, "m", "With mesh_tolerance: the smallest cell size (null: geometry.mesh_size / 4)",
        gt=0, le=1)
    mesh_size_max: Number | None = _f(
        None, "m", "With mesh_tolerance: the largest cell size (null: 4 x geometry.mesh_size)",
        gt=0, le=1)

    @model_validator(mode="after")
    def _iterative(self) -> NumericsConfig:
        if self.linear_solver == "iterative" and self.method != "regularized":
            raise ConfigError(f"numerics.linear_solver = 'iterative': only with numerics.method "
                              f"= regularized (not {self.method}); use mumps or superlu_dist")
        if self.nonlinear_solver == "newton" and self.method != "regularized":
            raise ConfigError(f"numerics.nonlinear_solver = 'newton': only with numerics.method "
                              f"= regularized (not {self.method})")
        if self.nonlinear_solver == "newton" and self.linear_solver == "iterative":
            raise ConfigError("numerics.nonlinear_solver = 'newton': needs a direct "
                              "numerics.linear_solver (mumps or superlu_dist), not iterative")
        if self.fixed_iterations is not None and (self.method != "regularized"
                                                  or self.nonlinear_solver != "picard"):
            raise ConfigError(f"numerics.fixed_iterations = {self.fixed_iterations}: only with "
                              f"numerics.method = regularized and nonlinear_solver = picard")
        if self.linear_solver == "iterative" and self.reuse_factorization:
            raise ConfigError("numerics.reuse_factorization = true: needs a direct "
                              "numerics.linear_solver (mumps or superlu_dist), not iterative")
        return self


# model: one class per model (dpcollapse/models/), told apart by ``name``
