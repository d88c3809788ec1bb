"""One time step of the regularized flow by Newton's method (``numerics.nonlinear_solver: newton``).

Same residual as the Picard fixed point of ``models.stokes.regularized`` (``forms.newton``:
the Picard terms with the frozen coefficients put back to the unknowns), solved by PETSc
SNES with the exact Jacobian from ``ufl.derivative`` and LU (``solvers.newton``). Before
Newton, optionally
- ``newton_picard_start`` Picard iterations (the secant-viscosity system, no Anderson),
- ε-continuation: Newton solves at ε_start, ε_start/10, … down to ε, each from the last;
  likewise (``newton_epsilon_friction_start``) for the wall-friction ε_f of
  |u_T|_ε = √(|u_T|² + ε_f²), both lowered together stage by stage.
A step Newton fails (line search, iteration cap, LU) is redone from its start by the
Picard fixed point (``newton_fallback``, the hybrid switch) before the loop halves Δt.
Each step starts from its iterate with the Dirichlet conditions imposed (``_impose_dirichlet``).
The stop is the Picard one applied to the Newton updates: the estimated error
‖Δu‖·max(1, ρ/(1 − ρ)) (ρ = ‖Δu_k‖/‖Δu_{k−1}‖, RMS over velocity dofs) ≤ rtol‖u‖ + atol
(``newton_stop: update``, at least two Jacobians per step), or (``newton_stop: residual``) the
error left after a full Newton step predicted from the residual reduction,
‖Δu_k‖·‖F(U_k)‖/‖F(U_{k−1})‖ ≤ rtol‖u‖ + atol (near the solution the error contracts as the
residual does), which can stop after one Jacobian.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem

from dpcollapse import compat
from dpcollapse.forms.newton import jacobian, residual_terms, with_fixed_quadrature
from dpcollapse.geometry.mesher import TaggedMesh
from dpcollapse.models.stokes.regularized import PicardSettings, RegularizedFlow, picard_settings
from dpcollapse.models.stokes.state import FlowParameters, StepReport, contraction, distance_to_limit
from dpcollapse.solvers.newton import SnesNewton, reason_name


@dataclass(frozen=True)
class NewtonSettings:
    picard: PicardSettings
    line_search: str = "bt"
    max_iterations: int = 25            # per continuation stage
    picard_start: int = 0               # Picard iterations before Newton
    epsilon_start: float | None = None  # ε-continuation from here down to ε (×0.1 per stage)
    fallback: bool = True               # a step Newton fails is redone by Picard (+ Anderson)
    epsilon_friction_start: float | None = None  # ε_f-continuation (×0.1 per stage)
    stop: str = "update"                # "update" (Picard test) or "residual" (predicted error)


def newton_settings(cfg) -> NewtonSettings:
    n = cfg.numerics
    return NewtonSettings(picard_settings(cfg), n.newton_line_search, n.newton_max_iterations,
                          n.newton_picard_start, n.newton_epsilon_start, n.newton_fallback,
                          n.newton_epsilon_friction_start, n.newton_stop)


def continuation(epsilon: float, start: float | None) -> list[float]:
    """ε_start, ε_start/10, … (all > ε), then ε: the regularizations of the Newton stages."""
    stages = []
    if start is not None:
        e = start
        while e > epsilon * (1 + 1e-12):
            stages.append(e)
            e /= 10.0
    return stages + [epsilon]


def regularization_stages(epsilon: float, start: float | None, epsilon_friction: float,
                          friction_start: float | None) -> list[tuple[float, float]]:
    """(ε, ε_f) of the Newton stages: both continuations (``continuation``) run together, the
    shorter one held at its target once reached; the last stage is (ε, ε_f)."""
    bulk = continuation(epsilon, start)
    wall = continuation(epsilon_friction, friction_start)
    n = max(len(bulk), len(wall))
    bulk += [epsilon] * (n - len(bulk))
    wall += [epsilon_friction] * (n - len(wall))
    return list(zip(bulk, wall))


def predicted_error(change: float, history: list[tuple[int, float]]) -> float:
    """Error left after the Newton update Δu_k, predicted from the residual reduction:
    ‖Δu_k‖·‖F_k‖/‖F_{k−1}‖ (history: (iteration, ‖F‖) up to k; ‖Δu_k‖ without a ratio)."""
    if len(history) < 2 or history[-2][1] <= 0:
        return change
    return change * min(1.0, history[-1][1] / history[-2][1])


class NewtonFlow(RegularizedFlow):
    """The regularized model solved by Newton (``numerics.nonlinear_solver: newton``)."""

    method = "regularized"
    nonlinear_solver = "newton"

    @classmethod
    def from_config(cls, tagged: TaggedMesh, cfg, params: FlowParameters) -> NewtonFlow:
        return cls(tagged, params, newton_settings(cfg))

    def __init__(self, tagged: TaggedMesh, params: FlowParameters, settings: NewtonSettings):
        self.newton = settings
        super().__init__(tagged, params, settings.picard)
        self._build_newton()
        self.residual_history: list[tuple[float, int, float]] = []  # (ε, iteration, ‖F‖)

    def _build_newton(self) -> None:
        mesh, p = self.mesh, self.params
        s = self.settings
        degree = s.quadrature_degree
        metadata = {} if degree is None else {"quadrature_degree": degree}
        dx = ufl.Measure("dx", domain=mesh, metadata=metadata)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=self.tagged.facet_tags, metadata=metadata)
        f = fem.Constant(mesh, np.array(p.body_force, dtype=compat.ScalarType))
        eps_f = fem.Constant(mesh, compat.ScalarType(s.epsilon_friction))
        self.newton_epsilon_friction = eps_f
        walls = [(f"{b.name}_friction", b.friction, b.tag) for b in p.boundaries if b.has_friction]
        U = self.iterate
        self.residual_terms = residual_terms(
            p.rheology, state=ufl.split(U), test=ufl.TestFunctions(self.W), rho=self._rho,
            dt=self.dt, body_force=f, epsilon=self.epsilon, epsilon_friction=eps_f,
            u_old=self.previous_velocity_term, mesh_velocity=self.mesh_velocity,
            n=ufl.FacetNormal(mesh),
            dx=dx, ds=ds,
            friction_walls=[(name, mu, tag) for name, mu, tag in walls if self._has_tag(tag)],
            side_walls=(p.channel_width, p.mu_side) if p.channel_width and p.mu_side > 0 else None,
            weak_walls=self.weak_walls(), coordinates=p.coordinates)
        F = with_fixed_quadrature(sum(self.residual_terms.values()))
        self.residual = F
        J = jacobian(F, U, ufl.TrialFunction(self.W))
        self.newton_system = self._make_system(J, -F)
        package = "mumps" if s.linear_solver == "iterative" else s.linear_solver
        self.snes = SnesNewton(self.comm, self.newton_system, U, self._newton_converged, package,
                               self.newton.line_search, self.newton.max_iterations)

    # ------------------------------------------------------------------ the step
    def _picard_iterations(self, count: int) -> None:
        """``count`` plain Picard iterations from the iterate (the last one stays in it)."""
        for _ in range(count):
            A = self.system.assemble_matrix()
            b = self.system.assemble_vector()
            self.solver.set_operator(A)
            self.system.solve(self.solver, target=self.solution, b=b)
            self.iterate.x.array[:] = self.solution.x.array

    def _impose_dirichlet(self, U: fem.Function) -> None:
        """U = 0 on the dofs of the Dirichlet conditions (all zero: u = 0, or u_y = 0 / u_x = 0
        on an axis-parallel side). The residual is zero on their rows and the Jacobian the
        identity, so a Newton update leaves those dofs as the start has them: a start that
        breaks a condition — after a landing the nose's new bed dofs keep the u_y they had as
        free surface — would keep breaking it in the converged step (Picard's linear solve
        sets them)."""
        for bc in self.newton_system.bcs:
            dofs, _ = bc.dof_indices()
            U.x.array[dofs] = 0.0

    def _newton_converged(self, iteration: int) -> bool:
        """The Picard stop applied to the Newton update, and only after a full step: the
        update must be the undamped Newton step δ (λ ≥ 0.9), so that a line search that
        creeps with λ ≪ 1 far from the solution is not taken for convergence."""
        new = self.velocity_values(self.iterate)
        change = self.rms(new - self._previous_velocity)
        full = self.rms(self.snes.direction[self._owned_velocity])
        rho = contraction(change, self._previous_change) if iteration > 1 else 0.0
        error = max(distance_to_limit(change, rho), full)
        if self.newton.stop == "residual":
            error = predicted_error(change, self.snes.history)
        self._previous_velocity = new
        self._previous_change = change
        scale = self.rms(new)
        self._error = error / scale if scale > 0 else error
        s = self.settings
        return bool(change >= 0.9 * full and error <= s.rtol * scale + s.atol)

    def solve_step(self, dt: float) -> StepReport:
        """Newton (after the optional Picard start and ε stages) for one step of size ``dt``;
        on failure, with ``fallback``, the Picard step from the same start."""
        report = self._newton_step(dt)
        if report.converged or not self.newton.fallback:
            return report
        # counted where the loop reads the flow's counters (kept across remeshes)
        self.solver.fallbacks += 1
        picard = super().solve_step(dt)
        picard.iterations += report.iterations
        if not picard.converged:
            picard.message = f"{report.message}; Picard fallback: {picard.message}"
        return picard

    def _newton_step(self, dt: float) -> StepReport:
        """Newton (after the optional Picard start and ε stages) for one step of size ``dt``."""
        s, ns = self.settings, self.newton
        self.set_step(dt)
        start = self.iterate.x.array.copy()
        self._impose_dirichlet(self.iterate)
        iterations = 0
        self._error = math.nan
        try:
            if ns.picard_start:
                self._picard_iterations(ns.picard_start)
                iterations += ns.picard_start
            for eps, eps_f in regularization_stages(s.epsilon, ns.epsilon_start,
                                                    s.epsilon_friction, ns.epsilon_friction_start):
                self.epsilon.value = eps
                self.newton_epsilon_friction.value = eps_f
                self._previous_velocity = self.velocity_values(self.iterate)
                self._previous_change = 0.0
                before = self.snes.factorizations
                reason, its = self.snes.solve()
                iterations += its
                # one set of counters for benchmarks and the run summary: the flow solver's
                self.solver.factorizations += self.snes.factorizations - before
                self.solver.solves += its
                self.residual_history.extend((eps, k, r) for k, r in self.snes.history)
                if reason <= 0:
                    self.iterate.x.array[:] = start
                    return StepReport(False, max(iterations, 1), self._error,
                                      f"Newton: {reason_name(reason)} at epsilon = {eps:g}")
        except RuntimeError as exc:
            self.iterate.x.array[:] = start
            return StepReport(False, max(iterations, 1), math.nan, f"Newton: {exc}")
        finally:
            self.epsilon.value = s.epsilon
            self.newton_epsilon_friction.value = s.epsilon_friction
        if not np.all(np.isfinite(self.iterate.x.array)):
            self.iterate.x.array[:] = start
            return StepReport(False, iterations, math.nan, "non-finite velocity")
        self.solution.x.array[:] = self.iterate.x.array
        self._pending_history = (start, dt)
        return StepReport(True, iterations, self._error)

    def destroy(self) -> None:
        super().destroy()
        self.newton_system.destroy()
        self.snes.destroy()
