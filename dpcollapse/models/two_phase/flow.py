"""One time step of the two-phase model: the Picard fixed point of the regularized flow
(``models.stokes.regularized``) with the mixture density ρ(cⁿ) and the mixture law
(``forms.two_phase``), then the advection of c by the converged u^{n+1}
(``fraction.VolumeFraction``, sub-cycled).

    (ρ(cⁿ) u^{n+1} − ½(ρ(cⁿ) + ρ(cⁿ⁻¹)) uⁿ)/Δt + ρ(cⁿ) (u^{n+1,k}·∇) u^{n+1} − ∇·(S(cⁿ, u^{n+1,k}, p^{n+1,k})
    D(u^{n+1}))
        − ∇(γ S ∇·u^{n+1}) + ∇p^{n+1} = ρ(cⁿ) g,   ∇·u^{n+1} = 0;       then  c^{n+1} = A_Δt(cⁿ; u^{n+1})

(``model.inertia: mean``, the default since 2026-12-07; ``energy``, the default from
2026-12-05: √(ρ(cⁿ) ρ(cⁿ⁻¹)) uⁿ/Δt; ``velocity``, the default before: ρ(cⁿ) uⁿ/Δt;
``forms.two_phase.previous_momentum``)

with the grad-div term γ S ∇·u (``forms.two_phase.grad_div``, S the secant viscosity at
the iterate), the convection in skew-symmetric form and the open top's backflow stabilization
(``forms.two_phase.skew_convection``: it creates no kinetic energy at the jumps of ρ(c)).
The mixture coefficients use c clamped to [0, 1] (the advected c may leave it by its overshoot).
Passive tracers (``add_tracer``: the erodible layer's fraction c_L) are advected by the same
u^{n+1} with the same scheme and the same sub-steps as c; they do not enter the flow.

Axisymmetric (``geometry.symmetry``, the flow's ``params.coordinates``; issue 52): every
integral above with the weight 2πr (dx and ds, the convection's, the time derivative's, the
ambient traction's and the grad-div term's too), D(u) with the hoop rate u_r/r and
∇·u = ∂_r u_r + u_r/r + ∂_z u_z (``forms.picard``), and c transported conservatively in
2πr dx (``fraction.VolumeFraction``). The axis x = 0 is the scene's slip side (u_r = 0, no
friction).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import ufl
from dolfinx import fem

from dpcollapse import compat
from dpcollapse.forms.picard import picard_terms
from dpcollapse.forms.two_phase import (
    MixtureRheology,
    ambient_traction,
    cut_cell_pressure,
    grad_div,
    grain_pressure,
    mixture,
    previous_momentum,
    skew_convection,
)
from dpcollapse.geometry.regions import cell_triangles
from dpcollapse.models.stokes.regularized import PicardSettings, RegularizedFlow
from dpcollapse.models.stokes.state import FlowParameters
from dpcollapse.models.two_phase.fraction import VolumeFraction, owned_triangles
from dpcollapse.models.two_phase.remap import remap
from dpcollapse.scenes.base import BoundaryKind
from dpcollapse.transfer import CellwiseField, concatenate


def cell_centroids(mesh):
    """A DG0 vector field of the cells' centroids x_K (the mean of their vertices; the fixed
    box's geometry is affine), owned and ghost cells [m]."""
    V = compat.vector_space(mesh, 0, "DG")
    centroids = fem.Function(V)
    x = cell_triangles(mesh, owned_only=False).mean(axis=1)
    centroids.x.array.reshape(-1, 2)[compat.cell_dofs(V)[:, 0]] = x
    return centroids


def remap_fields(targets: list, mesh) -> None:
    """Each DG0 function of ``targets`` [(function, CellwiseField)] on ``mesh``'s owned cells
    = the exact conservative remap (``remap.remap``) of its field's cell values. The fields
    that share one old mesh (c, cⁿ⁻¹ and the tracers of one snapshot) go in one call, so that
    the candidate pairs and their overlaps |K_i ∩ T_j| — the remap's whole cost — are found
    once for all of them (c_j = Σ_i c_i |K_i ∩ T_j| / |T_j| for each field); ghosts updated."""
    n = compat.num_owned_cells(mesh)
    new = owned_triangles(mesh)
    while targets:
        vertices = targets[0][1].vertices
        group = [t for t in targets if np.array_equal(t[1].vertices, vertices)]
        targets = [t for t in targets if all(t is not g for g in group)]
        values = remap(vertices, np.stack([f.values[:, 0, 0] for _, f in group], axis=1), new)
        for k, (function, _) in enumerate(group):
            function.x.array[compat.cell_dofs(function.function_space)[:n, 0]] = values[:, k]
            function.x.scatter_forward()


@dataclass(frozen=True)
class LightFluid:
    """The passive light fluid and the advection settings of c."""

    density: float        # ρ_a [kg/m³]
    viscosity: float      # η_a [Pa s]
    courant: float        # of the advection sub-steps
    compression: float    # C of the interface compression
    grad_div: float = 0.0  # γ of the grad-div term γ S (∇·u)(∇·v)
    viscosity_average: str = "arithmetic"  # of S_g and 2η_a (forms.two_phase)
    yield_weighting: str = "grains"  # κ_mix = w(c) κ(p) (forms.two_phase.yield_weight)
    grain_pressure: str = "total"  # the p of κ(p), μ(I) and the bed friction (forms.two_phase)
    cut_cell_pressure: str = "pointwise"  # that p in a cut cell: pointwise or at its centroid
    inertia: str = "mean"  # the time derivative's densities (forms.two_phase.previous_momentum)
    compression_direction: str = "normal"  # of the interface compression (forms.two_phase)
    strips: tuple[float, int] | None = None  # (width, count) of the box's strips (layer_normal)
    open_top: str = "hydrostatic"  # the open top's traction: hydrostatic or traction_free
    thin_layer_cells: float = 2.0  # a layer thinner than this many cells: layer_normal's
    compression_speed: str = "facet"  # |u·n| or |u| (forms.two_phase.compression_speed)
    interface_flux: str = "compression"  # or geometric (models.two_phase.geometric_flux)
    interface_normal: str = "gradient"  # geometric's normal: gradient or height_function


#: the snapshot field of cⁿ⁻¹ (``model.inertia: energy``, ``mean``)
PREVIOUS_FRACTION = "volume_fraction_previous"
#: the snapshot entry of what has left the box: (outflow_volume, escaped_volume) [m²]
LEFT_THE_BOX = "fraction_left_the_box"


class TwoPhaseFlow(RegularizedFlow):
    """The regularized flow of the mixture on a fixed mesh, carrying c. (It declares no
    ``method`` of its own: ``models.registry`` does not take it for a ``numerics.method``.)"""

    def __init__(self, tagged, params: FlowParameters, settings: PicardSettings, light: LightFluid):
        self.light = light
        self.tracers: dict[str, VolumeFraction] = {}
        # its convection is the skew-symmetric one, in the matrix: the matrix is not
        # symmetric, so never the lagged convection's LDLᵀ (numerics.convection is the
        # moving mesh's)
        super().__init__(tagged, params, replace(settings, convection="implicit"))
        u = ufl.split(self.solution)[0]
        self.fraction.bind(u)
        outflow = self._tags_of(BoundaryKind.OUTFLOW)
        if outflow:
            self.fraction.watch_outflow(self._over(outflow))

    def highest_point(self, body_force) -> tuple[float, float]:
        """x_ref: the mesh vertex highest against the body force f (least f·x), over all
        ranks; on a box with an open top, a point of the top (p = 0 there)."""
        x = self.mesh.geometry.x[:, :2]
        height = x @ np.asarray(body_force, dtype=float)
        local = (float(height.min()), tuple(float(v) for v in x[int(height.argmin())])) \
            if len(height) else (np.inf, (0.0, 0.0))
        return min(self.comm.allgather(local))[1]

    def _tags_of(self, *kinds) -> list[int]:
        """The facet tags of the scene's sides of these kinds present on this mesh."""
        return [b.tag for b in self.params.of_kind(*kinds) if self._has_tag(b.tag)]

    def _over(self, tags: list[int]):
        """ds over the sides ``tags``."""
        ds = ufl.Measure("ds", domain=self.mesh, subdomain_data=self.tagged.facet_tags)
        return sum((ds(t) for t in tags[1:]), ds(tags[0]))

    def add_tracer(self, name: str) -> VolumeFraction:
        """A DG0 fraction named ``name`` advected with c (same scheme, same sub-steps)."""
        tracer = VolumeFraction(self.mesh, self.light.courant, self.light.compression, name=name,
                                direction=self.light.compression_direction,
                                coordinates=self.params.coordinates, strips=self.light.strips,
                                thin_layer_cells=self.light.thin_layer_cells,
                                speed=self.light.compression_speed,
                                interface_flux=self.light.interface_flux,
                                interface_normal=self.light.interface_normal)
        tracer.bind(ufl.split(self.solution)[0])
        self.tracers[name] = tracer
        return tracer

    # ------------------------------------------------------------------ forms
    def _build_forms(self) -> None:
        mesh, p, light = self.mesh, self.params, self.light
        self.surface_gamma = None   # no surface tension: the surface is not a boundary here
        coords = p.coordinates      # planar, or axisymmetric: the measures weighted by 2πr
        self.fraction = VolumeFraction(mesh, light.courant, light.compression,
                                       direction=light.compression_direction, coordinates=coords,
                                       strips=light.strips, thin_layer_cells=light.thin_layer_cells,
                                       speed=light.compression_speed,
                                       interface_flux=light.interface_flux,
                                       interface_normal=light.interface_normal)
        c = self.fraction.c
        clamped = ufl.min_value(ufl.max_value(c, 0.0), 1.0)
        (u, pr), (v, q) = ufl.TrialFunctions(self.W), ufl.TestFunctions(self.W)
        u_k, p_total = ufl.split(self.iterate)
        self._rho = rho = mixture(clamped, p.density, light.density)
        f, eps, eps_f, dx, ds, n = self._coefficients()
        # the grains' friction sees p, or p − p_a (model.grain_pressure: effective), p_a the
        # light fluid's hydrostatic pressure, zero at the domain's highest point
        self.highest = self.highest_point(self.params.body_force)
        p_walls = p_k = grain_pressure(p_total, light.density, f, self.highest, mesh,
                                       light.grain_pressure)
        # in a cell the interface cuts, the cell's yield stress and μ(I) read it at every point
        # or at the cell's centroid (model.cut_cell_pressure); the walls' friction at the wall
        centroid = cell_centroids(mesh) if light.cut_cell_pressure != "pointwise" else None
        self.grain_pressure = p_k = cut_cell_pressure(p_k, clamped, centroid, mesh,
                                                      light.cut_cell_pressure)
        self.law = law = MixtureRheology(p.rheology, clamped, light.viscosity,
                                         light.viscosity_average, light.yield_weighting)
        walls = [(f"{b.name}_friction", b.friction, b.tag) for b in p.boundaries if b.has_friction]
        self.terms, self.rhs_terms = picard_terms(
            law, rho=rho, dt=self.dt, body_force=f, epsilon=eps, epsilon_friction=eps_f,
            u_iter=u_k, p_iter=p_k, u_old=self.u_old, mesh_velocity=self.mesh_velocity,
            trial=(u, pr), test=(v, q), n=n, dx=dx, ds=ds,
            friction_walls=[(name, mu, tag) for name, mu, tag in walls if self._has_tag(tag)],
            weak_walls=self.weak_walls(), p_walls=p_walls, coordinates=coords)
        dx, ds = coords.measure(dx, mesh), coords.measure(ds, mesh)   # planar: themselves
        # the convection in skew-symmetric form: no kinetic energy from the jumps of ρ(c);
        # backflow stabilization on every open side (the top, an orifice)
        open_tags = self._tags_of(BoundaryKind.FREE_SURFACE, BoundaryKind.OUTFLOW)
        open_ds = sum((ds(t) for t in open_tags[1:]), ds(open_tags[0]))
        self.terms["convection"] = skew_convection(rho, u_k, u, v, n, dx, open_ds)
        # the time derivative's explicit half: ρ(cⁿ) uⁿ/Δt, √(ρ(cⁿ) ρ(cⁿ⁻¹)) uⁿ/Δt or
        # ½(ρ(cⁿ) + ρ(cⁿ⁻¹)) uⁿ/Δt (model.inertia: velocity, energy, mean)
        if light.inertia != "velocity":
            previous = self.fraction.previous
            rho_previous = mixture(ufl.min_value(ufl.max_value(previous, 0.0), 1.0), p.density,
                                   light.density)
            self.rhs_terms["previous_velocity"] = previous_momentum(
                rho, rho_previous, self.dt, self.u_old, v, dx, light.inertia)
        for b in p.of_kind(BoundaryKind.OUTFLOW):
            if self._has_tag(b.tag):   # σ n = −p_a n with the ambient p_a = ρ_a f·(x − x_ref)
                self.rhs_terms[f"{b.name}_ambient"] = ambient_traction(
                    light.density, f, b.reference, v, n, ds(b.tag), mesh)
        if light.open_top == "hydrostatic":
            # the open top borders the light fluid at rest: σ n = −p_a n, p_a zero at the
            # highest point (on a tilted box the top is no isobar: with σ n = 0 there the
            # light fluid cannot rest and circulates over the deposit, model.open_top)
            for b in p.of_kind(BoundaryKind.FREE_SURFACE):
                if self._has_tag(b.tag):
                    self.rhs_terms[f"{b.name}_ambient"] = ambient_traction(
                        light.density, f, self.highest, v, n, ds(b.tag), mesh)
        if light.grad_div > 0:
            # the cellwise divergence the fluxes of c see (c > 1 in converging cells, creep)
            self.terms["grad_div"] = grad_div(light.grad_div, law.secant_viscosity(u_k, p_k, eps),
                                              u, v, dx, coords)
        self.system = self._make_system(sum(self.terms.values()), sum(self.rhs_terms.values()))

    def schur_viscosity(self):
        """η of the Schur approximation (``linear_solver: iterative``): the mixture's Stokes
        viscosity S/2, S its secant viscosity (the stress S D(u)). Measured on the a = 0.5
        box at t = 0.02 s (FGMRES to 1e-8): 39 (1 cm) and 46 (5 mm) iterations; with the
        grad-div term's γS added, (½ + γ) S, 42 and 54; with the granular law alone (the air
        as stiff as the grains) 185 and no convergence in 500."""
        u_k = ufl.split(self.iterate)[0]
        return 0.5 * self.law.secant_viscosity(u_k, self.grain_pressure, self.epsilon)

    # ------------------------------------------------------------------ the step
    def solve_step(self, dt: float):
        """The Picard step of the flow with cⁿ, then c^{n+1} advected by u^{n+1}."""
        report = super().solve_step(dt)
        if report.converged:
            steps = self.fraction.advance(dt)
            for tracer in self.tracers.values():
                tracer.advance(dt, steps)
        return report

    def _fractions(self) -> list:
        return [self.fraction, *self.tracers.values()]

    def accept_step(self) -> None:
        super().accept_step()
        for fraction in self._fractions():
            fraction.accept()

    def reset_iterate(self) -> None:
        super().reset_iterate()
        for fraction in self._fractions():
            fraction.reject()

    def copy_state_from(self, other) -> None:
        super().copy_state_from(other)
        self.fraction.c.x.array[:] = other.fraction.c.x.array
        self.fraction.previous.x.array[:] = other.fraction.previous.x.array
        self.fraction.outflow_volume = other.fraction.outflow_volume
        self.fraction.escaped_volume = other.fraction.escaped_volume
        for name, tracer in self.tracers.items():
            tracer.c.x.array[:] = other.tracers[name].c.x.array

    # ------------------------------------------------------------------ snapshot
    def snapshot(self) -> dict:
        """uⁿ, pⁿ, "volume_fraction" cⁿ and the tracers by name (per cell, as cellwise-constant
        P1 fields)."""
        fields = super().snapshot()
        mesh = self.mesh
        n = compat.num_owned_cells(mesh)
        tri = mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n, :3]]
        cells = compat.cell_dofs(self.fraction.S0)[:n, 0]

        def gathered(function) -> CellwiseField:   # its owned cells' values, on every rank
            local = CellwiseField(vertices=tri, points=tri, degree=1,
                                  values=np.repeat(function.x.array[cells][:, None], 3, axis=1))
            return concatenate(self.comm.allgather(local))

        for fraction in self._fractions():
            fields[fraction.c.name] = gathered(fraction.c)
        if self.light.inertia != "velocity":   # cⁿ⁻¹ of the time derivative's densities
            fields[PREVIOUS_FRACTION] = gathered(self.fraction.previous)
        fields[LEFT_THE_BOX] = (self.fraction.outflow_volume, self.fraction.escaped_volume)
        return fields

    def checkpoint_fields(self) -> dict:
        """``snapshot``'s fields without what has left the box (a number: the checkpoint's
        state carries it, ``adapter.TwoPhaseFactory.save_checkpoint``)."""
        fields = super().checkpoint_fields()
        fields.pop(LEFT_THE_BOX, None)
        return fields

    def transfer(self, fields: dict) -> float:
        """The state of ``snapshot`` fields: u, p interpolated (``RegularizedFlow.transfer``);
        c and the tracers by the exact conservative remap of their cell values
        (``remap_fields``: ∫ c kept to round-off, one overlap search for all); what has left the
        box so far carried over (∫ c + it is the balance across an adaptive remesh)."""
        names = {fraction.c.name for fraction in self._fractions()} | {PREVIOUS_FRACTION, LEFT_THE_BOX}
        if LEFT_THE_BOX in fields:
            self.fraction.outflow_volume, self.fraction.escaped_volume = fields[LEFT_THE_BOX]
        outside = super().transfer({k: v for k, v in fields.items() if k not in names})
        targets = [(fraction.c, fields.get(fraction.c.name)) for fraction in self._fractions()]
        previous = fields.get(PREVIOUS_FRACTION)
        keep_history = previous is not None and self.light.inertia != "velocity"
        if keep_history:
            targets.append((self.fraction.previous, previous))
        remap_fields([(target, field) for target, field in targets if field is not None],
                     self.mesh)
        if not keep_history:        # a state without cⁿ⁻¹: the step starts without ∂ρ/∂t
            self.fraction.forget_history()
        return outside

    def destroy(self) -> None:
        super().destroy()
        for fraction in self._fractions():
            fraction.destroy()
