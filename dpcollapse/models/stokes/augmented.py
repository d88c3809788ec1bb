"""One time step by the augmented Lagrangian (decomposition–coordination) method, seed 002.

The yield term is not regularized: the strain rate is split as D(u) = γ̇ with the multiplier
σ' (the deviatoric stress), and Coulomb friction as u_T = δ with the multiplier σ_T (the
tangential traction). Iterations k = 1, 2, … of a time step:

1. the linear Stokes/Oseen problem of ``forms.augmented`` for (u, p) given (σ', γ̇, σ_T, δ);
   its matrix (ρ/Δt, convection by uⁿ − w, penalties r, r_f) is the same for every k, so it
   is factorized once per step;
2. the closed-form local steps of ``solvers.al_projection`` at the nodes of the DG2 tensor
   space (γ̇ from σ' + r dev D(u) with κ(p) and η(|D|, p) of the current iterate) and at the
   boundary nodes of the P2 velocity space (δ from σ_T − r_f u_T with the Coulomb limit
   μ [p − σ'_nn]_+, lumped onto the wall's nodes);
3. σ' ← σ' + r (D(u) − γ̇), σ_T ← σ_T − r_f (u_T − δ).

Stop when the multiplier residuals and the velocity change are all small::

    ‖D(u) − γ̇‖ ≤ rtol ‖D(u)‖ + atol/ℓ,   ‖u_T − δ‖_Γ ≤ rtol ‖u_T‖_Γ + atol,
    ‖u^k − u^{k−1}‖ max(1, ρ/(1 − ρ)) ≤ rtol ‖u^k‖ + atol

(ρ the observed contraction of successive velocity increments: the distance to the limit
of a linearly converging iteration, as in ``models.stokes.regularized``)
(root mean squares over Ω, Γ and the velocity dofs; ℓ = √|Ω|). The rigid zone is where
γ̇ = 0 exactly. Multipliers are carried from step to step (warm start); on the moving mesh
their nodal values move with the nodes, like uⁿ.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from dpcollapse import compat
from dpcollapse.forms import augmented
from dpcollapse.models.stokes.regularized import PicardSettings, RegularizedFlow
from dpcollapse.models.stokes.state import (
    FlowParameters,
    StepReport,
    StokesState,
    contraction,
    distance_to_limit,
)
from dpcollapse.rheology.kinematics import strain_rate
from dpcollapse.scenes.base import BoundaryKind
from dpcollapse.solvers import al_projection as local
from dpcollapse.solvers.anderson import Anderson
from dpcollapse.solvers.linear import DirectSolver

#: Polynomial degree of the discontinuous multiplier space (γ̇, σ') and of the nodes where
#: the local steps are taken.
MULTIPLIER_DEGREE = 2


@dataclass(frozen=True)
class AugmentedSettings:
    """Parameters of the augmented Lagrangian iteration."""

    augmentation: float            # r [Pa s]
    augmentation_friction: float   # r_f [Pa s/m] on bed and wall
    augmentation_side: float       # r_w [Pa s/m²] for side-wall friction
    rtol: float
    atol: float                    # [m/s]
    max_iterations: int
    epsilon: float = 1e-6          # μ(I): |D|_ε in η(|D|, p); and the first step's regularized start [1/s]
    epsilon_friction: float = 1e-6  # the first step's regularized start [m/s]
    linear_solver: str = "mumps"
    anderson_depth: int = 0        # Anderson acceleration of the multiplier iteration
    reuse_factorization: bool = False  # GMRES on the LU (the operator is fixed within a step anyway)


def default_augmentation(density: float, gravity: float, height: float) -> tuple[float, float, float]:
    """r = 2 ρ √g H^{3/2} [Pa s] (twice the stress ρgH over the rate √(g/H)), r_f = 10 r/H,
    r_w = r/H². Measured: 1214 Pa s on the 25 cm collapse (r = 300 stalls the first steps,
    1000 runs), 108 on the 5 cm plug layer (5 to 500 all converge there); on the collapse's
    first step (4 cm mesh) r_f = r/H stalls on the sticking bed, 10 r/H converges in 2151
    iterations, 100 r/H in 2538."""
    r = 2.0 * density * math.sqrt(gravity) * height ** 1.5
    return r, 10.0 * r / height, r / height**2


def augmented_settings(cfg) -> AugmentedSettings:
    """Settings of the augmented Lagrangian; r, r_f default to 2ρ√g h0^{3/2} and 10 r/h0."""
    n, m, h = cfg.numerics, cfg.material, cfg.geometry.height
    r, r_f, r_w = default_augmentation(m.density, m.gravity, h)
    if n.augmentation is not None:
        r, r_w = n.augmentation, n.augmentation / h**2
        r_f = 10.0 * n.augmentation / h
    if n.augmentation_friction is not None:
        r_f = n.augmentation_friction
    return AugmentedSettings(r, r_f, r_w, n.nonlinear_rtol, cfg.fixed_point_atol, n.augmented_max_iterations,
                             n.epsilon, n.epsilon_friction, n.linear_solver, n.anderson_depth)


class AugmentedLagrangianFlow(StokesState):
    """Spaces, state, multipliers and solvers of the augmented Lagrangian flow on one mesh.

    The fields of ``models.stokes.state`` (solution, iterate, u_old, mesh_velocity), plus
    the multipliers ``sigma`` (σ'), ``gamma`` (γ̇) on DG2 tensors and ``traction`` (σ_T),
    ``slip`` (δ) on the P2 velocity space.
    """

    #: its ``numerics.method``
    method = "augmented_lagrangian"

    @staticmethod
    def describe(cfg) -> list[str]:
        """Its line of ``dpcollapse check``: the augmentation parameters."""
        a = augmented_settings(cfg)
        return [f"augmented Lagrangian: r = {a.augmentation:.4g} Pa s, r_f = "
                f"{a.augmentation_friction:.4g} Pa s/m, at most {a.max_iterations} iterations per step"]
    #: an iteration is one back-substitution, not a factorization (measured 3 ms against
    #: 15 ms per Picard iteration on the 2 cm collapse): the adaptive step's thresholds on
    #: the iteration count are this many times those of the regularized model
    iteration_scale = 5

    @classmethod
    def from_config(cls, tagged, cfg, params: FlowParameters) -> AugmentedLagrangianFlow:
        return cls(tagged, params, augmented_settings(cfg))

    def __init__(self, tagged, params: FlowParameters, settings: AugmentedSettings):
        super().__init__(tagged, params)
        self.settings = settings
        self._build_forms()
        self.solver = DirectSolver(self.comm, settings.linear_solver, prefix="dpc_flow_",
                                   krylov=settings.reuse_factorization)
        #: False until a pressure field exists (initial state): the first step then iterates
        #: the yield limit κ(p) to convergence instead of lagging it
        self.pressure_known = False
        nT = self.T.dofmap.index_map.size_local * 4
        nV = self.V.dofmap.index_map.size_local * 2
        # Anderson mixes the active multipliers (owned entries), in the iteration's natural
        # norm ‖σ‖²/r + r‖γ̇‖² (Pa²/(Pa s) either way), the same for the walls
        r, r_f, r_w = settings.augmentation, settings.augmentation_friction, settings.augmentation_side
        active = [(self.sigma, nT, 1.0 / r), (self.gamma, nT, r)]
        if self.has_friction:
            active += [(self.traction, nV, 1.0 / r_f), (self.slip, nV, r_f)]
        if self.has_side_walls:
            active += [(self.side_traction, nV, 1.0 / r_w), (self.side_slip, nV, r_w)]
        self._mixed = [(f, n) for f, n, _ in active]
        weights = np.concatenate([np.full(n, w) for _, n, w in active])
        self.anderson = Anderson(self.comm, settings.anderson_depth, len(weights), weights)

    # ------------------------------------------------------------------ forms
    def _build_forms(self) -> None:
        mesh, p, s = self.mesh, self.params, self.settings
        (u, pr), (v, q) = ufl.TrialFunctions(self.W), ufl.TestFunctions(self.W)
        u_h, p_h = ufl.split(self.solution)
        rho = fem.Constant(mesh, compat.ScalarType(p.density))
        f = fem.Constant(mesh, np.array(p.body_force, dtype=compat.ScalarType))
        self.r = r = fem.Constant(mesh, compat.ScalarType(s.augmentation))
        self.r_f = r_f = fem.Constant(mesh, compat.ScalarType(s.augmentation_friction))
        self.r_w = r_w = fem.Constant(mesh, compat.ScalarType(s.augmentation_side))
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=self.tagged.facet_tags)
        n = ufl.FacetNormal(mesh)

        # multipliers: DG2 tensors hold D(u) of P2 velocities exactly (affine cells); the local steps
        # at their six nodes per cell resolve the yield surface better than DG1 (measured)
        self.T = compat.tensor_space(mesh, MULTIPLIER_DEGREE, "DG")
        self.S = compat.scalar_space(mesh, MULTIPLIER_DEGREE, "DG")
        self.sigma = fem.Function(self.T, name="deviatoric_stress")      # σ'
        self.gamma = fem.Function(self.T, name="yield_multiplier")       # γ̇
        self.rate = fem.Function(self.T, name="strain_rate_tensor")      # D(u^k)
        self.kappa = fem.Function(self.S, name="yield_stress")           # κ(p^k)
        self.eta = fem.Function(self.S, name="viscosity")                # η(|D(u^k)|, p^k)
        self.traction = fem.Function(self.V, name="tangential_traction")  # σ_T
        self.slip = fem.Function(self.V, name="slip_multiplier")         # δ
        self.side_traction = fem.Function(self.V, name="side_wall_traction")  # σ_w
        self.side_slip = fem.Function(self.V, name="side_wall_slip")     # δ_w
        rheo = p.rheology
        # the deviatoric part: Taylor–Hood velocities are divergence-free only weakly, and a
        # trace in γ̇, σ' would trade off against p (and so κ(p)) and stall the iteration
        self._rate_expr = compat.expression(ufl.dev(strain_rate(u_h)), self.T)
        self._kappa_expr = compat.expression(rheo.yield_stress(p_h), self.S)
        eta = rheo.capped_rate_viscosity(u_h, p_h, s.epsilon)  # η(|D|_ε, p), capped at η_max
        if rheo.rate_dependent:
            self._eta_expr = compat.expression(eta, self.S)
        else:  # a constant: set once
            self._eta_expr = None
            self.eta.x.array[:] = eta

        # Coulomb walls of the scene (μ > 0) present on this mesh
        walls = [b for b in p.boundaries if b.has_friction and self._has_tag(b.tag)]
        self.has_friction = bool(walls)
        self.has_side_walls = bool(p.channel_width and p.mu_side > 0)
        ds_f = sum((ds(b.tag) for b in walls[1:]), ds(walls[0].tag)) if walls else None
        self.terms, rhs = augmented.augmented_terms(
            rho=rho, dt=self.dt, body_force=f, r=r, u_old=self.u_old,
            mesh_velocity=self.mesh_velocity, sigma=self.sigma, gamma=self.gamma,
            trial=(u, pr), test=(v, q), n=n, ds_friction=ds_f, r_f=r_f, traction=self.traction,
            slip=self.slip, r_w=r_w if self.has_side_walls else None,
            side_traction=self.side_traction, side_slip=self.side_slip,
            weak_walls=[(name, ds(tag)) for name, tag in self.weak_walls()],
            surface=self._surface_tension(ds))
        self.rhs_terms = rhs
        L = sum(rhs.values())
        if walls:
            self._setup_friction_nodes(walls)
            vV = ufl.TestFunction(self.V)
            ones = vV[0] + vV[1]
            sigma_nn = ufl.dot(n, ufl.dot(self.sigma, n))
            self._normal_form = fem.form((p_h - sigma_nn) * ones * ds_f)   # ∫ (p − σ'_nn) φ_i
            self._weight_form = fem.form(ones * ds_f)                       # ∫ φ_i
            self._normal = fem.Function(self.V)
            self._weight = fem.Function(self.V)
        if self.has_side_walls:
            self._side_threshold_expr = compat.expression(
                2.0 / p.channel_width * p.mu_side * ufl.as_vector((p_h, p_h)), self.V)
            self._side_threshold = fem.Function(self.V)

        a = sum(self.terms.values())
        self.system = self._make_system(a, L)

    def _setup_friction_nodes(self, walls) -> None:
        """Velocity nodes (blocks of V) on the friction walls, their unit tangent (from the
        wall's normal) and μ. Nodes on two walls (a corner, where u = 0) are left out."""
        fdim = self.mesh.topology.dim - 1
        ft = self.tagged.facet_tags
        found = [(b, np.asarray(fem.locate_dofs_topological(self.V, fdim, ft.indices[ft.values == b.tag]),
                                dtype=np.int64)) for b in walls]
        counts: dict[int, int] = {}
        for _, nodes in found:
            for i in nodes:
                counts[int(i)] = counts.get(int(i), 0) + 1
        blocks, tangents, mus = [], [], []
        for wall, nodes in found:
            b = np.array([i for i in nodes if counts[int(i)] == 1], dtype=np.int64)
            blocks.append(b)
            tangents.append(np.tile(wall.tangent, (len(b), 1)))
            mus.append(np.full(len(b), wall.friction))
        self._f_blocks = np.concatenate(blocks)
        self._f_tangent = np.concatenate(tangents)
        self._f_mu = np.concatenate(mus)
        self._threshold = np.zeros(len(self._f_blocks))

    # ------------------------------------------------------------------ helpers
    def _assemble_nodal(self, form, target: fem.Function) -> None:
        vec = compat.petsc_vec(target)
        with vec.localForm() as loc:
            loc.set(0.0)
        fem_petsc.assemble_vector(vec, form)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        target.x.scatter_forward()

    def _multipliers(self) -> tuple:
        return (self.sigma, self.gamma, self.traction, self.slip, self.side_traction, self.side_slip)

    def multiplier_functions(self) -> dict[str, fem.Function]:
        """The multipliers by name, for transfer across remeshes and checkpoints."""
        return {f.name: f for f in self._multipliers()}

    def copy_state_from(self, other: AugmentedLagrangianFlow) -> None:
        """Also the multipliers (same mesh, same dofs) and whether a pressure is known."""
        super().copy_state_from(other)
        for mine, theirs in zip(self._multipliers(), other._multipliers()):
            mine.x.array[:] = theirs.x.array
        self.pressure_known = other.pressure_known

    def transfer(self, fields) -> float:
        """Also the multipliers; with them, the pressure counts as known (κ(p) is lagged
        from it, as in later steps)."""
        outside = super().transfer(fields)
        if any(name in fields for name in self.multiplier_functions()):
            self.pressure_known = True
        return outside

    def _state(self) -> list[np.ndarray]:
        return [f.x.array for f in self._multipliers()]

    def multiplier_arrays(self) -> list[np.ndarray]:
        """Copies of (σ', γ̇, σ_T, δ, σ_w, δ_w) dof arrays (local incl. ghosts)."""
        return [a.copy() for a in self._state()]

    def set_multiplier_arrays(self, arrays) -> None:
        for target, values in zip(self._state(), arrays):
            target[:] = values

    exported_cell_fields = ("rigid",)

    def cell_field(self, name: str) -> np.ndarray:
        """"rigid": 1 in the cells where γ̇ = 0 exactly, else 0."""
        if name != "rigid":
            return super().cell_field(name)
        return self.rigid_cells().astype(float)

    def rigid_cells(self) -> np.ndarray:
        """Per local cell: True where γ̇ = 0 exactly at all its nodes (rigid zone)."""
        dofs = compat.cell_dofs(self.T)          # (cells, nodes) block indices
        g = self.gamma.x.array.reshape(-1, 4)
        return np.all(g[dofs] == 0.0, axis=(1, 2))

    def _wall_slip(self, u: np.ndarray) -> np.ndarray:
        """u_T = (u·t) t at the wall nodes, from nodal velocities u (n_nodes, 2)."""
        t = self._f_tangent
        return np.sum(u[self._f_blocks] * t, axis=1)[:, None] * t

    # ------------------------------------------------------------------ coefficients
    def _update_coefficients(self) -> float:
        """κ(p), η(|D|, p) and the Coulomb limits μ[p − σ'_nn]_+ (walls), (2/w)μ_w[p]_+ (side
        walls) from the current (u, p, σ'); returns their largest relative RMS change.

        They are held fixed while the multipliers iterate: each inner problem is then convex
        and the iteration converges, whereas updating κ(p) at every iteration (seed 002,
        step 2) stalls it on the collapse (measured: the residual stops decreasing)."""
        changes = []

        def refresh(values: np.ndarray, compute) -> None:
            old = values.copy()
            compute()
            diff = self.comm.allreduce(float(np.dot(values - old, values - old)), op=MPI.SUM)
            norm = self.comm.allreduce(float(np.dot(values, values)), op=MPI.SUM)
            changes.append(math.sqrt(diff) / max(math.sqrt(norm), 1e-300))

        refresh(self.kappa.x.array, lambda: self.kappa.interpolate(self._kappa_expr))
        if self._eta_expr is not None:
            refresh(self.eta.x.array, lambda: self.eta.interpolate(self._eta_expr))
        if self.has_friction:
            refresh(self._threshold, self._compute_wall_threshold)
        if self.has_side_walls:
            refresh(
                self._side_threshold.x.array,
                lambda: self._side_threshold.interpolate(self._side_threshold_expr),
            )
        return max(changes)

    def _compute_wall_threshold(self) -> None:
        """μ [p − σ'_nn]_+ at the wall nodes, p − σ'_nn averaged along the wall with the
        nodal weights ∫_Γ φ_i ds."""
        self._assemble_nodal(self._normal_form, self._normal)
        b = self._f_blocks
        weight = self._weight.x.array.reshape(-1, 2)[b, 0]
        normal = self._normal.x.array.reshape(-1, 2)[b, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            pressure = np.where(weight > 0, normal / weight, 0.0)
        self._threshold[:] = self._f_mu * np.maximum(pressure, 0.0)

    def _regularized_start(self, dt: float) -> int:
        """First step (no pressure, no multipliers yet): start from the regularized step.

        Building the static stress field of a mass at rest from σ' = 0 takes the iteration
        thousands of iterations (measured: > 5000 on the 1.5 cm collapse, at every Δt down to
        1/8 ms). Instead one regularized Picard step (ε of the config) gives (u, p), the
        multiplier σ' = dev σ'_ε(u, p) and the wall traction σ_T = −μ[p − σ'_nn]_+ u_T/|u_T|_ε;
        the augmented Lagrangian iteration then removes the regularization, with κ from that
        p (iterating κ(p) here diverges slowly on the 1.5 cm mesh: the stress of the rigid
        part is not unique). If the regularized step fails, the lithostatic pressure
        ρ g cos θ (s − y) is the start and κ(p) is iterated.
        Returns the Picard iterations spent (counted in the step's iterations)."""
        s = self.settings
        settings = PicardSettings(s.epsilon, s.epsilon_friction, s.rtol, s.atol, 200,
                                  s.linear_solver, 5)
        regularized = RegularizedFlow(self.tagged, self.params, settings)
        try:
            regularized.u_old.x.array[:] = self.u_old.x.array
            regularized.mesh_velocity.x.array[:] = self.mesh_velocity.x.array
            regularized.iterate.x.array[:] = self.iterate.x.array
            report = regularized.solve_step(dt)
            self.solver.factorizations += regularized.solver.factorizations
            if not report.converged:
                self._lithostatic_pressure()
                return report.iterations
            for f in (self.solution, self.iterate):
                f.x.array[:] = regularized.solution.x.array
            self.pressure_known = True   # κ(p) from the regularized p, lagged as in later steps
            u_r, p_r = ufl.split(regularized.solution)
            stress = ufl.dev(self.params.rheology.deviatoric_stress(u_r, p_r, s.epsilon))
            self.sigma.interpolate(compat.expression(stress, self.T))
            self.gamma.x.array[:] = 0.0
            if self.has_friction:
                self._compute_wall_threshold()
                u_t = self._wall_slip(self.solution.x.array[self.velocity_dofs].reshape(-1, 2))
                size = np.sqrt(np.sum(u_t * u_t, axis=1) + s.epsilon_friction**2)
                traction = self.traction.x.array.reshape(-1, 2)
                traction[self._f_blocks] = -(self._threshold / size)[:, None] * u_t
                self.traction.x.scatter_forward()
            return report.iterations
        finally:
            regularized.destroy()

    def _lithostatic_pressure(self) -> None:
        """First guess of p where none exists yet (the initial state):
        p = ρ g cos θ [s(x) − y]_+ with s(x) the free-surface height above x. The first step
        then starts from the yield limit of a mass at rest, not from κ = 0."""
        ft = self.tagged.facet_tags
        surface_tags = [b.tag for b in self.params.of_kind(BoundaryKind.FREE_SURFACE)]
        facets = ft.indices[np.isin(ft.values, surface_tags)]
        nodes = compat.entities_to_geometry(self.mesh, 1, facets)
        pts = self.mesh.geometry.x[:, :2][nodes.ravel()] if len(facets) else np.zeros((0, 2))
        pts = np.concatenate(self.comm.allgather(pts))
        if len(pts) == 0:
            return
        xs, inverse = np.unique(np.round(pts[:, 0], 12), return_inverse=True)
        top = np.full(len(xs), -np.inf)
        np.maximum.at(top, inverse, pts[:, 1])
        xq = self.Q.tabulate_dof_coordinates()[:, :2]
        surface = np.interp(xq[:, 0], xs, top)
        weight = self.params.density * self.params.gravity * math.cos(self.params.bed_angle)
        pressure = weight * np.maximum(surface - xq[:, 1], 0.0)
        for f in (self.solution, self.iterate):
            f.x.array[self.pressure_dofs] = pressure

    # ------------------------------------------------------------------ local steps
    def _local_yield(self) -> None:
        """Steps 2–3 for the yield term at the nodes of the multiplier space."""
        r = float(self.r.value)
        self.rate.interpolate(self._rate_expr)
        D = self.rate.x.array.reshape(-1, 2, 2)
        sigma = self.sigma.x.array.reshape(-1, 2, 2)
        gamma = local.yield_multiplier(sigma, D, self.kappa.x.array, self.eta.x.array, r)
        self.sigma.x.array[:] = local.update_stress(sigma, D, gamma, r).ravel()
        self.gamma.x.array[:] = gamma.ravel()

    def _local_friction(self, u: np.ndarray) -> None:
        """Steps 2–3 for Coulomb friction at the wall nodes: δ and σ_T."""
        r_f = float(self.r_f.value)
        b, u_t = self._f_blocks, self._wall_slip(u)
        traction = self.traction.x.array.reshape(-1, 2)
        slip = self.slip.x.array.reshape(-1, 2)
        delta = local.slip_multiplier(traction[b], u_t, self._threshold, 0.0, r_f)
        traction[b] = local.update_traction(traction[b], u_t, delta, r_f)
        slip[b] = delta

    def _local_side_walls(self, u: np.ndarray) -> None:
        """Steps 2–3 for the width-averaged side-wall friction at every velocity node."""
        r_w = float(self.r_w.value)
        threshold = np.maximum(self._side_threshold.x.array.reshape(-1, 2)[:, 0], 0.0)
        traction = self.side_traction.x.array.reshape(-1, 2)
        delta = local.slip_multiplier(traction, u, threshold, 0.0, r_w)
        traction[:] = local.update_traction(traction, u, delta, r_w)
        self.side_slip.x.array[:] = delta.ravel()

    # ------------------------------------------------------------------ norms
    def _cell_areas(self) -> np.ndarray:
        """|K| of the owned cells (the mesh moves every step)."""
        x = self.mesh.geometry.x[:, :2]
        cells = compat.geometry_dofmap(self.mesh)[:compat.num_owned_cells(self.mesh), :3]
        a, b, c = x[cells[:, 0]], x[cells[:, 1]], x[cells[:, 2]]
        return 0.5 * np.abs(
            (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        )

    def _dg_norm(self, values: np.ndarray) -> float:
        """RMS over Ω of a DG tensor field given by its dof array, with the lumped (nodal)
        quadrature ∫_K |f|² ≈ |K| mean_i |f_i|² (an equivalent norm; exact for constants)."""
        local = float(np.dot(self._dof_weights, values * values))
        return math.sqrt(max(self.comm.allreduce(local, op=MPI.SUM), 0.0) / self._area_total)

    def _wall_norm(self, vectors: np.ndarray) -> float:
        """RMS over the friction walls of nodal vectors at ``_f_blocks`` (lumped: Σ wᵢ|fᵢ|²/Σ wᵢ)."""
        w = self._f_weights
        local = float(np.sum(w * np.sum(vectors * vectors, axis=1)))
        return math.sqrt(max(self.comm.allreduce(local, op=MPI.SUM), 0.0) / self._wall_total)

    def _node_rms(self, vectors: np.ndarray) -> float:
        """RMS over the owned velocity nodes of nodal vectors (n_nodes, 2)."""
        n = self.V.dofmap.index_map.size_local
        local = float(np.sum(vectors[:n] * vectors[:n]))
        count = self.comm.allreduce(n, op=MPI.SUM)
        return math.sqrt(self.comm.allreduce(local, op=MPI.SUM) / max(count, 1))

    def _prepare_norms(self) -> None:
        """Cell areas, per-dof weights of the DG norm and the wall nodes' lumped weights."""
        self._areas = self._cell_areas()
        blocks = compat.cell_dofs(self.T)[:len(self._areas)]        # (owned cells, nodes)
        weights = np.zeros(self.sigma.x.array.size // 4)
        weights[blocks] = (self._areas / blocks.shape[1])[:, None]
        self._dof_weights = np.repeat(weights, 4)                     # per tensor component
        self._area_total = self.comm.allreduce(float(self._areas.sum()), op=MPI.SUM)
        if self.has_friction:
            self._assemble_nodal(self._weight_form, self._weight)
            owned = self._f_blocks < self.V.dofmap.index_map.size_local
            self._f_weights = np.where(owned, self._weight.x.array.reshape(-1, 2)[self._f_blocks, 0], 0.0)
            self._wall_total = max(self.comm.allreduce(float(self._f_weights.sum()), op=MPI.SUM), 1e-300)

    # ------------------------------------------------------------------ the step
    def _checks(self, u: np.ndarray, gamma_old: np.ndarray, slip_old: np.ndarray,
                side_slip_old: np.ndarray, speed: float) -> list[tuple[float, float]]:
        """(value, tolerance) pairs of the stopping test after the local steps.

        Yield term: the constraint D(u) = γ̇ and the changes of both multipliers,
        ‖D − γ̇‖ ≤ rtol max(‖D‖, ‖γ̇‖) + atol/ℓ, r‖D − γ̇‖ and r‖γ̇ − γ̇_old‖ ≤ rtol‖σ'‖ + r atol/ℓ;
        friction the same with u_T, δ, σ_T, r_f, the slip constraint relative to the RMS
        velocity ``speed`` of the flow (a sticking wall has no slip scale of its own);
        side walls with u, δ_w, σ_w, r_w.
        """
        s = self.settings
        r, r_f, r_w = float(self.r.value), float(self.r_f.value), float(self.r_w.value)
        tol = s.atol / self._length_scale
        D, gamma = self.rate.x.array, self.gamma.x.array
        primal = self._dg_norm(D - gamma)
        dual = self._dg_norm(gamma - gamma_old)
        stress = self._dg_norm(self.sigma.x.array)
        checks = [(primal, s.rtol * max(self._dg_norm(D), self._dg_norm(gamma)) + tol),
                  (r * primal, s.rtol * stress + r * tol),
                  (r * dual, s.rtol * stress + r * tol)]
        if self.has_friction:
            b, u_t = self._f_blocks, self._wall_slip(u)
            slip = self.slip.x.array.reshape(-1, 2)[b]
            primal = self._wall_norm(u_t - slip)
            dual = self._wall_norm(slip - slip_old.reshape(-1, 2)[b])
            traction = self._wall_norm(self.traction.x.array.reshape(-1, 2)[b])
            checks += [(primal, s.rtol * speed + s.atol),
                       (r_f * primal, s.rtol * traction + r_f * s.atol),
                       (r_f * dual, s.rtol * traction + r_f * s.atol)]
        if self.has_side_walls:
            slip = self.side_slip.x.array.reshape(-1, 2)
            primal = self._node_rms(u - slip)
            dual = self._node_rms(slip - side_slip_old.reshape(-1, 2))
            traction = self._node_rms(self.side_traction.x.array.reshape(-1, 2))
            checks += [(primal, s.rtol * speed + s.atol),
                       (r_w * primal, s.rtol * traction + r_w * s.atol),
                       (r_w * dual, s.rtol * traction + r_w * s.atol)]
        return checks

    def solve_step(self, dt: float) -> StepReport:
        """Augmented Lagrangian iterations for one time step of size ``dt``."""
        s = self.settings
        self.dt.value = dt
        self.update_surface_tension()
        start = self.iterate.x.array.copy()
        start_multipliers = self.multiplier_arrays()
        A = self.system.assemble_matrix()
        self.solver.set_operator(A)
        self._prepare_norms()
        self._length_scale = math.sqrt(self._area_total)
        start_iterations = 0
        if not self.pressure_known:
            start_iterations = self._regularized_start(dt)
        self._update_coefficients()   # from the last accepted state (uⁿ, pⁿ, σ'ⁿ)
        self.anderson.reset()
        residual = math.inf
        previous = 0.0

        def fail(k: int, message: str) -> StepReport:
            self.iterate.x.array[:] = start
            self.solution.x.array[:] = start
            self.set_multiplier_arrays(start_multipliers)
            return StepReport(False, start_iterations + k, residual, message)

        for k in range(1, s.max_iterations + 1):
            b = self.system.assemble_vector()
            try:
                self.system.solve(self.solver, target=self.solution, b=b)
            except RuntimeError as exc:
                return fail(k, str(exc))
            new = self.velocity_values()
            if not np.all(np.isfinite(new)):
                return fail(k, "non-finite velocity")
            before = np.concatenate([f.x.array[:n] for f, n in self._mixed]) if s.anderson_depth else None
            gamma_old = self.gamma.x.array.copy()
            slip_old = self.slip.x.array.copy() if self.has_friction else None
            side_old = self.side_slip.x.array.copy() if self.has_side_walls else None
            u_nodes = self.solution.x.array[self.velocity_dofs].reshape(-1, 2)
            self._local_yield()
            if self.has_friction:
                self._local_friction(u_nodes)
            if self.has_side_walls:
                self._local_side_walls(u_nodes)

            change = self.rms(new - self.velocity_values(self.iterate))
            scale = self.rms(new)
            checks = self._checks(u_nodes, gamma_old, slip_old, side_old, scale)
            # distance to the limit, not the bare increment: the iteration converges
            # linearly, slowly for large r, so with contraction ρ it is about Δ ρ/(1 − ρ)
            rho = contraction(change, previous)
            previous = change
            checks.append((distance_to_limit(change, rho), s.rtol * scale + s.atol))
            residual = max(value / tol for value, tol in checks) * s.rtol
            self.iterate.x.array[:] = self.solution.x.array
            if all(value <= tol for value, tol in checks):
                # inner problem converged: update κ, η, Coulomb limits; done if they held
                if self.pressure_known:
                    return StepReport(True, start_iterations + k, residual)
                if self._update_coefficients() <= s.rtol:
                    self.pressure_known = True
                    return StepReport(True, start_iterations + k, residual)
                self.anderson.reset()
            if s.anderson_depth > 0:
                after = np.concatenate([f.x.array[:n] for f, n in self._mixed])
                mixed = self.anderson.update(before, after)
                offset = 0
                for func, n in self._mixed:
                    func.x.array[:n] = mixed[offset:offset + n]
                    offset += n
            for func, _ in self._mixed:
                func.x.scatter_forward()
        return fail(s.max_iterations, "iteration cap reached")
