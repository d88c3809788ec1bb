"""One time step of the regularized Drucker–Prager flow: the Picard fixed point of seed 000.

Given uⁿ on the already moved mesh Ω^{n+1} (same dofs: uⁿ∘A⁻¹ for free) and the mesh
velocity w, iterate k = 0, 1, …: assemble the linear Oseen/Stokes problem of
``forms.momentum`` + ``forms.friction`` with coefficients frozen at (uᵏ, pᵏ), solve it by
LU, and stop when the estimated error of the iterate, ‖u^{k+1} − uᵏ‖·max(1, ρ/(1 − ρ)) with ρ
the observed contraction of successive increments, is ≤ rtol ‖u^{k+1}‖ + atol (RMS over
velocity dofs; the absolute part atol only once ρ is measured, k ≥ 2), or, with ``fixed_iterations`` K,
after K iterates whatever the test says
(K = 1: the linearly implicit step, the viscosity and the convecting velocity taken at the
step's start uⁿ — or at its extrapolation — as Basilisk's granular.h does). Optionally the
iterates are Anderson-accelerated (``solvers.anderson``).
The fields and conditions are those of ``models.stokes.state``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem

from dpcollapse import compat
from dpcollapse.forms.picard import picard_terms
from dpcollapse.geometry.mesher import TaggedMesh
from dpcollapse.io.checkpoint import note_not_restored
from dpcollapse.models.stokes.state import (
    FlowParameters,
    StepReport,
    StokesState,
    contraction,
    distance_to_limit,
    load_mixed,
    snapshot_mixed,
)
from dpcollapse.scenes.base import BoundaryKind
from dpcollapse.solvers.anderson import Anderson
from dpcollapse.solvers.assembly import zero_dirichlet
from dpcollapse.solvers.iterative import BlockSolver
from dpcollapse.solvers.linear import DirectSolver


@dataclass(frozen=True)
class PicardSettings:
    epsilon: float
    epsilon_friction: float
    rtol: float
    atol: float
    max_iterations: int
    linear_solver: str = "mumps"   # mumps, superlu_dist (LU) or iterative (solvers.iterative)
    anderson_depth: int = 0    # 0: plain Picard; m > 0: Anderson acceleration of depth m
    reuse_factorization: bool = False  # one LU per step; later iterates: GMRES + stale LU
    quadrature_degree: int | None = None  # of the nonlinear terms; None: UFL's estimate
    extrapolate: bool = False  # first iterate extrapolated linearly from the last two steps
    krylov_rtol: float = 1e-10  # relative residual of FGMRES (iterative) or GMRES (reuse_factorization)
    krylov_max_iterations: int = 500
    time_scheme: str = "bdf1"  # time.scheme: bdf1 or bdf2 (solvers.bdf)
    fixed_iterations: int | None = None  # accept the step after this many iterates (None: converge)
    convection: str = "implicit"  # implicit (lhs) or lagged (rhs at the iterate: symmetric lhs, LDLᵀ)
    error_norm: str = "rms"  # time.error_norm: rms or max of the BDF2 local error estimate


#: checkpoint names of the extrapolation's x_{n−1} (numerics.extrapolate), and the key of its
#: numbers in the checkpoint state
EXTRAPOLATION_FIELDS = ("extrapolation_velocity", "extrapolation_pressure")
EXTRAPOLATION_KEY = "extrapolation"


def picard_settings(cfg) -> PicardSettings:
    """The fixed-point settings of ``numerics`` (``numerics.convection`` is the moving mesh's:
    ``models.two_phase.flow.TwoPhaseFlow`` keeps its skew-symmetric convection in the matrix)."""
    n = cfg.numerics
    return PicardSettings(n.epsilon, n.epsilon_friction, n.nonlinear_rtol, cfg.fixed_point_atol,
                          n.max_iterations, n.linear_solver, n.anderson_depth,
                          n.reuse_factorization, n.quadrature_degree, n.extrapolate,
                          n.krylov_rtol, n.krylov_max_iterations, cfg.time.scheme,
                          n.fixed_iterations, n.convection, cfg.time.error_norm)


class RegularizedFlow(StokesState):
    """The regularized model on one mesh: its forms, its linear solver and the Picard step."""

    #: its ``numerics.method``
    method = "regularized"

    #: its ``numerics.nonlinear_solver`` (``models.stokes.newton.NewtonFlow``: newton)
    nonlinear_solver = "picard"

    @classmethod
    def from_config(cls, tagged: TaggedMesh, cfg, params: FlowParameters) -> RegularizedFlow:
        return cls(tagged, params, picard_settings(cfg))

    def __init__(self, tagged: TaggedMesh, params: FlowParameters, settings: PicardSettings):
        super().__init__(tagged, params)
        self.settings = settings
        self._contraction = 0.0   # last measured contraction of the fixed point (extrapolate)
        self._history = None      # (xₙ₋₁, Δt_prev) of the last accepted step (extrapolate)
        self._pending_history = None
        if settings.time_scheme == "bdf2":
            self._use_bdf2()
            self.error_norm = settings.error_norm
        self._build_forms()
        self.solver = self._make_solver()
        weights = np.zeros(self._size_local)
        weights[self._owned_velocity] = 1.0
        self.anderson = Anderson(self.comm, settings.anderson_depth, self._size_local, weights)

    # ------------------------------------------------------------------ forms
    def _coefficients(self):
        """(f, ε, ε_f, dx, ds, n): the body force, the regularizations (``self.epsilon`` is
        the ε a continuation changes) and the measures with the settings' quadrature."""
        mesh = self.mesh
        f = fem.Constant(mesh, np.array(self.params.body_force, dtype=compat.ScalarType))
        self.epsilon = eps = fem.Constant(mesh, compat.ScalarType(self.settings.epsilon))  # ε
        eps_f = fem.Constant(mesh, compat.ScalarType(self.settings.epsilon_friction))
        # numerics.quadrature_degree q: the nonlinear terms (√, [·]_+, μ(I)) get degree q
        # instead of UFL's estimate (Drucker–Prager: 8 in cells, 17 on friction facets); the
        # polynomial terms keep their exact degree (≤ 4); FFCx merges rules of equal degree.
        degree = self.settings.quadrature_degree
        metadata = {} if degree is None else {"quadrature_degree": degree}
        dx = ufl.Measure("dx", domain=mesh, metadata=metadata)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=self.tagged.facet_tags, metadata=metadata)
        return f, eps, eps_f, dx, ds, ufl.FacetNormal(mesh)

    def _build_forms(self) -> None:
        mesh, p = self.mesh, self.params
        (u, pr), (v, q) = ufl.TrialFunctions(self.W), ufl.TestFunctions(self.W)
        u_k, p_k = ufl.split(self.iterate)
        self._rho = rho = fem.Constant(mesh, compat.ScalarType(p.density))
        f, eps, eps_f, dx, ds, n = self._coefficients()

        walls = [(f"{b.name}_friction", b.friction, b.tag) for b in p.boundaries if b.has_friction]
        self.terms, rhs = picard_terms(
            p.rheology, rho=rho, dt=self.dt, body_force=f, epsilon=eps, epsilon_friction=eps_f,
            u_iter=u_k, p_iter=p_k, u_old=self.previous_velocity_term, mesh_velocity=self.mesh_velocity,
            trial=(u, pr), test=(v, q), n=n, dx=dx, ds=ds,
            friction_walls=[(name, mu, tag) for name, mu, tag in walls if self._has_tag(tag)],
            side_walls=(p.channel_width, p.mu_side) if p.channel_width and p.mu_side > 0 else None,
            weak_walls=self.weak_walls(),
            surface=self._surface_tension(ds), convection=self.settings.convection,
            coordinates=p.coordinates)
        self.rhs_terms = rhs
        a = sum(self.terms.values())
        L = sum(rhs.values())
        self.system = self._make_system(a, L)

    def _make_solver(self):
        """LU kept across solves, or ``iterative_solver()`` (``linear_solver: iterative``)."""
        s = self.settings
        if s.linear_solver == "iterative":
            return self.iterative_solver(s.krylov_rtol, s.krylov_max_iterations)
        return DirectSolver(self.comm, s.linear_solver, prefix="dpc_flow_",
                            krylov=s.reuse_factorization, rtol=s.krylov_rtol,
                            symmetric=s.convection == "lagged")

    def iterative_solver(self, rtol: float, max_iterations: int,
                         prefix: str = "dpc_flow_") -> BlockSolver:
        """FGMRES + Schur fieldsplit (``solvers.iterative``) with its two pressure operators
        on the current iterate: the mass matrix weighted by 1/η (``schur_viscosity``) and
        the Laplacian weighted by Δt/ρ, with p = 0 on the free surface."""
        if self.params.periodic_slave is not None:
            raise ValueError("linear_solver iterative: not available on a periodic layer")
        _, p = ufl.TrialFunctions(self.W)
        _, q = ufl.TestFunctions(self.W)
        dx = ufl.Measure("dx", domain=self.mesh, metadata={"quadrature_degree": 2})
        mass = 1.0 / self.schur_viscosity() * p * q * dx
        laplacian = self.dt / self._rho * ufl.inner(ufl.grad(p), ufl.grad(q)) * ufl.dx
        bcs = [zero_dirichlet(self.W.sub(1), self.tagged.facet_tags, b.tag)
               for b in self.params.of_kind(BoundaryKind.FREE_SURFACE)]
        return BlockSolver(self.comm, self.W, self.velocity_dofs, self.pressure_dofs, mass,
                           laplacian, bcs, prefix=prefix, rtol=rtol, max_it=max_iterations)

    def schur_viscosity(self):
        """η of the Schur approximation −B A⁻¹ Bᵀ ≈ −∫ (1/η) p q where viscosity dominates:
        the Stokes viscosity ν/2 of the secant iterate (stress ν D(u)) [Pa s]."""
        u_k, p_k = ufl.split(self.iterate)
        return 0.5 * self.params.rheology.secant_viscosity(u_k, p_k, self.epsilon)

    def accept_step(self) -> None:
        """uⁿ ← u^{n+1}, and the step's start becomes the extrapolation history."""
        super().accept_step()
        self._history = self._pending_history

    # ------------------------------------------------------------------ checkpoint
    def checkpoint_fields(self) -> dict:
        """Also, with ``numerics.extrapolate``, the last step's start x_{n−1} = (u, p)
        (``EXTRAPOLATION_FIELDS``) that the next step's first iterate reads."""
        fields = super().checkpoint_fields()
        if self.settings.extrapolate and self._history is not None:
            fields.update(snapshot_mixed(self, self._history[0], EXTRAPOLATION_FIELDS))
        return fields

    def checkpoint_state(self) -> dict:
        """Also, with ``numerics.extrapolate``, the extrapolation's numbers: the last step
        Δt_prev (None before the first step on this mesh) and the last measured contraction ρ
        (the first iterate's error estimate)."""
        state = super().checkpoint_state()
        if self.settings.extrapolate:
            dt = self._history[1] if self._history is not None else None
            state[EXTRAPOLATION_KEY] = {"dt": dt, "contraction": self._contraction}
        return state

    def restore_checkpoint(self, fields: dict, state: dict) -> None:
        """Also the extrapolation history (``checkpoint_fields``, ``checkpoint_state``); a
        checkpoint without it (written before 2026-12-07, or without extrapolate) leaves the
        first resumed step unextrapolated."""
        super().restore_checkpoint(fields, state)
        record = state.pop(EXTRAPOLATION_KEY, None)
        if not self.settings.extrapolate:
            return
        stored = record is not None and (record["dt"] is None
                                         or all(name in fields for name in EXTRAPOLATION_FIELDS))
        if not stored:
            note_not_restored(state, "numerics.extrapolate's last step (the first resumed "
                                     "step starts from uⁿ)")
            return
        self._contraction = float(record["contraction"])
        if record["dt"] is not None:
            self._history = (load_mixed(self, fields, EXTRAPOLATION_FIELDS), float(record["dt"]))

    # ------------------------------------------------------------------ the step
    def solve_step(self, dt: float) -> StepReport:
        """Picard iterations for one time step of size ``dt`` on the current mesh."""
        s = self.settings
        self.set_step(dt)
        self.update_surface_tension()
        start = self.iterate.x.array.copy()
        history = self._history
        extrapolated = s.extrapolate and history is not None
        if extrapolated:
            # first iterate x_{n+1}⁰ = xₙ + (Δt/Δt_prev)(xₙ − x_{n−1}): O(Δt²) from the solution
            previous_state, dt_previous = history
            self.iterate.x.array[:] = start + (dt / dt_previous) * (start - previous_state)
        residual = math.inf
        self.anderson.reset()
        n = self._size_local
        previous = 0.0
        for k in range(1, s.max_iterations + 1):
            A = self.system.assemble_matrix()
            b = self.system.assemble_vector()
            stale = s.reuse_factorization and k > 1
            self.solver.set_operator(A, refactor=not stale)
            try:
                try:
                    self.system.solve(self.solver, target=self.solution, b=b)
                except RuntimeError:
                    if not stale:
                        raise
                    self.solver.set_operator(A, refactor=True)  # stale LU too far off
                    self.system.solve(self.solver, target=self.solution, b=b)
            except RuntimeError as exc:
                self.iterate.x.array[:] = start
                return StepReport(False, k, math.nan, str(exc))
            new = self.velocity_values()
            if not np.all(np.isfinite(new)):
                self.iterate.x.array[:] = start
                return StepReport(False, k, math.nan, "non-finite velocity")
            change = self.rms(new - self.velocity_values(self.iterate))
            scale = self.rms(new)
            # error of the iterate, not just its increment: with contraction ρ the distance
            # to the fixed point is about Δ ρ/(1 − ρ) (ρ from successive increments)
            # (first iterate of an extrapolated start: no increment to compare with yet, so
            # the last contraction measured in an earlier step stands in for ρ — otherwise a
            # slowly contracting creep passes the test at k = 1 forever, measured: 3 mm/s)
            if previous > 0:
                rho = measured = contraction(change, previous)
            else:
                rho = self._contraction if extrapolated else 0.0
                measured = None
            error = distance_to_limit(change, rho)
            previous = change
            residual = error / scale if scale > 0 else error
            # numerics.fixed_iterations: the step is accepted after that many iterates even
            # when the test is not met (1: the linearly implicit step, coefficients at the start)
            # the absolute floor atol only once the contraction is known (k ≥ 2, or carried
            # to an extrapolated start): a first iterate that moved little may still be far
            # from the fixed point where the map contracts slowly, as near arrest — accepted
            # on its increment alone, the mass crept on at 1–3 mm/s with one iterate per step
            # (measured with atol 3e-5 m/s, the OpenBLAS Prescott kernel: at rest at 1.79 s
            # instead of 0.94 s)
            floor = s.atol if (measured is not None or extrapolated) else 0.0
            if error <= s.rtol * scale + floor or k == s.fixed_iterations:
                self.iterate.x.array[:] = self.solution.x.array
                self._pending_history = (start, dt)
                if measured is not None:
                    self._contraction = measured
                return StepReport(True, k, residual)
            # next iterate: the Picard image G(x_k), or its Anderson combination
            self.iterate.x.array[:n] = self.anderson.update(self.iterate.x.array[:n],
                                                            self.solution.x.array[:n])
            self.iterate.x.scatter_forward()
        self.iterate.x.array[:] = start
        return StepReport(False, s.max_iterations, residual, "iteration cap reached")
