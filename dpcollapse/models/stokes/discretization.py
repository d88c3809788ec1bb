"""Everything that lives on one mesh, and the physics built from the config.

``StokesDiscretization`` bundles the regularized flow, the ALE mesh motion, the output functions
and the integrals (area, kinetic energy, gravity's moment) of one mesh; the time loop in
``simulation`` replaces it on every remesh or landing. ``StokesFactory`` is the 2D model of
``model.name = stokes`` as the loop sees it (``loop.ModelFactory``): its domain, its initial
discretization, a new one per remesh, its checkpoints.
"""

from __future__ import annotations

import math

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.ale.motion import MeshMotion, cell_orientation, quality
from dpcollapse.ale.quality import courant_rate
from dpcollapse.config import Config
from dpcollapse.domain.base import make_domain
from dpcollapse.geometry.boundary_loops import BoundaryLoops
from dpcollapse.geometry.mesher import DOMAIN, TaggedMesh
from dpcollapse.io.checkpoint import load_model_checkpoint, save_model_checkpoint
from dpcollapse.io.law_fields import LawFields
from dpcollapse.models.base import DiscretizationDefaults
from dpcollapse.models.registry import model_class
from dpcollapse.models.stokes.augmented import augmented_settings  # noqa: F401  (callers import it here)
from dpcollapse.models.stokes.regularized import picard_settings  # noqa: F401  (callers import it here)
from dpcollapse.models.stokes.state import FlowParameters
from dpcollapse.rheology.base import Rheology
from dpcollapse.rheology.choice import law_from_material
from dpcollapse.rheology.coordinates import coordinates
from dpcollapse.scenes.base import film_threshold, thickness_front
from dpcollapse.scenes.registry import build_mesh
from dpcollapse.scenes.registry import scene as make_scene

#: Speed above which a point counts as flowing (seed 000) [m/s].
FLOWING_SPEED = 1e-3


def rheology(cfg: Config) -> Rheology:
    """The constitutive law of ``material`` (a :class:`~dpcollapse.rheology.base.Rheology`):
    DruckerPrager or MuI, in the coordinates of ``geometry.symmetry``."""
    return law_from_material(cfg.material, flow_coordinates(cfg))


def flow_coordinates(cfg: Config):
    """``rheology.coordinates`` of ``geometry.symmetry`` (planar, or axisymmetric: x = r)."""
    return coordinates(cfg.geometry.coordinates)


def flow_parameters(cfg: Config, scene=None) -> FlowParameters:
    """Physical parameters of the flow: the material and the boundaries of the scene (of the
    config when not given)."""
    m, b = cfg.material, cfg.boundary
    scene = scene or make_scene(cfg)
    return FlowParameters(
        density=m.density, gravity=m.gravity, bed_angle=math.radians(cfg.geometry.bed_angle),
        rheology=rheology(cfg), boundaries=scene.boundaries(), channel_width=b.channel_width,
        mu_side=b.mu_side, surface_tension=b.surface_tension,
        surface_tension_extent=b.surface_tension_extent, coordinates=flow_coordinates(cfg))


def initial_velocity(cfg: Config):
    """The initial velocity u(x, y) of the config's scene, for ``Function.interpolate``."""
    return make_scene(cfg).initial_velocity()


def direct_solver(cfg: Config) -> str:
    """The LU package of the small mesh-motion solves: mumps when the flow is iterative."""
    n = cfg.numerics
    return "mumps" if n.linear_solver == "iterative" else n.linear_solver


def make_flow(tagged: TaggedMesh, cfg: Config, scene=None):
    """The model of ``numerics.method`` and ``numerics.nonlinear_solver`` on one mesh
    (``models.registry``)."""
    n = cfg.numerics
    return model_class(n.method, n.nonlinear_solver).from_config(tagged, cfg,
                                                                 flow_parameters(cfg, scene))


class StokesDiscretization(DiscretizationDefaults):
    """Everything that lives on one mesh: the flow, the mesh motion, outputs, integrals."""

    #: measures beyond the shared ones (``loop``): none
    #: the smallest cell angle [deg] and Jacobian determinant of the moving mesh, and μ(I)'s
    #: ill-posed fraction (NaN for rate-independent laws)
    extra_measures = ("min_angle", "min_detJ", "ill_posed_fraction")

    def __init__(self, tagged: TaggedMesh, cfg: Config):
        self.tagged = tagged
        self.mesh = mesh = tagged.mesh
        self.comm = mesh.comm
        self.scene = make_scene(cfg)
        self.flow = make_flow(tagged, cfg, self.scene)
        self.orientation = cell_orientation(mesh)
        # the thickness front: max(3 d, h/4); d only where the law has grains (mu_i)
        self.film_threshold = film_threshold(self.flow.params.rheology.grain_scale,
                                             cfg.geometry.mesh_size)
        self.motion = MeshMotion(self.flow, cfg.numerics.mesh_velocity_penalty,
                                 direct_solver(cfg), bed_height=self.scene.bed_height,
                                 conserve_area=cfg.numerics.step_conserve_area) \
            if cfg.numerics.ale else None
        # the boundary's chaining for the thickness front, done once per mesh (rank 0)
        self._boundary_loops = BoundaryLoops()
        u, p = ufl.split(self.flow.solution)
        # axisymmetric: the body of revolution's volume [m³], energy [J] and moment (2πr dx);
        # planar: per unit depth (dx)
        coords = self.flow.params.coordinates
        dx = coords.measure(ufl.dx, mesh)
        self._area = fem.form(1.0 * coords.measure(ufl.dx(domain=mesh)))
        self._kinetic = fem.form(0.5 * cfg.material.density * ufl.inner(u, u) * dx)
        f = fem.Constant(mesh, np.array(self.flow.params.body_force, dtype=compat.ScalarType))
        self._gravity_moment = fem.form(cfg.material.density * ufl.inner(f, ufl.SpatialCoordinate(mesh)) * dx)
        # output functions on spaces XDMF writes faithfully (P1, DG0)
        V1, S1, S0 = (
            compat.vector_space(mesh, 1),
            compat.scalar_space(mesh, 1),
            compat.scalar_space(mesh, 0, "DG"),
        )
        self.out_velocity = fem.Function(V1, name="velocity")
        self.out_pressure = fem.Function(S1, name="pressure")
        self.out_strain_rate = fem.Function(S0, name="strain_rate")
        self.out_flowing = fem.Function(S1, name="flowing")
        # material region of each cell (cell tag: granular_mass 10, erodible_layer 11)
        self.out_region = fem.Function(S0, name="material_region")
        self._set_regions(tagged)
        # per-cell fields of the model (AL: the exact rigid zone γ̇ = 0)
        self.out_cells = [fem.Function(S0, name=name) for name in self.flow.exported_cell_fields]
        D = coords.strain_rate(u)    # planar: sym ∇u; axisymmetric: with the hoop rate u_r/r
        self._strain_expr = compat.expression(ufl.sqrt(ufl.inner(D, D)), S0)
        self.law = law = self.flow.params.rheology
        # fields only some laws have (μ(I): the inertial number), and the well-posed window
        eps = cfg.numerics.epsilon
        self.out_extra = LawFields(law, u, p, eps, S0)
        self.window = law.well_posed_window()
        if self.window is not None:
            self._speed = fem.Function(S0)
            self._speed_expr = compat.expression(ufl.sqrt(ufl.inner(u, u)), S0)

    def _set_regions(self, tagged: TaggedMesh) -> None:
        """``material_region`` = the cell tag of each cell (DOMAIN where there are none)."""
        self.out_region.x.array[:] = DOMAIN
        ct = tagged.cell_tags
        if ct is not None:
            cells = compat.cell_dofs(self.out_region.function_space)[:, 0]
            self.out_region.x.array[cells[ct.indices]] = ct.values

    def region_area(self, tag: int, speed_above: float | None = None) -> float:
        """Area of the cells of region ``tag`` [m²]; with ``speed_above``, only of those whose
        mean vertex speed |uⁿ| exceeds it (the part of the region set in motion)."""
        ct = self.tagged.cell_tags
        n = compat.num_owned_cells(self.mesh)
        tri = self.mesh.geometry.x[:, :2][compat.geometry_dofmap(self.mesh)[:n, :3]]
        d1, d2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        areas = 0.5 * np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
        tags = np.full(n, DOMAIN)
        if ct is not None:
            owned = ct.indices < n
            tags[ct.indices[owned]] = ct.values[owned]
        mask = tags == tag
        if speed_above is not None:
            p1 = fem.Function(self.flow.Vw)
            p1.interpolate(self.flow.u_old)
            speed = np.linalg.norm(p1.x.array.reshape(-1, 2), axis=1)
            dofs = compat.cell_dofs(self.flow.Vw)[:n]
            mask &= speed[dofs].mean(axis=1) > speed_above
        return self.comm.allreduce(float(areas[mask].sum()), op=MPI.SUM)

    def area(self) -> float:
        return self.comm.allreduce(fem.assemble_scalar(self._area), op=MPI.SUM)

    def max_step(self) -> float:
        """The model's own step limit: none (the domain and the Courant bound limit it)."""
        return math.inf

    def courant_rate(self) -> float:
        """max_K max_{vertices of K} |uⁿ|/h_K on the current mesh (global) [1/s]: uⁿ
        interpolated to P1 (its vertex values), h_K the shortest edge of K."""
        cached = getattr(self, "_courant_p1", None)
        if cached is None:
            V1 = self.flow.Vw
            cached = self._courant_p1 = (fem.Function(V1), compat.cell_dofs(V1))
        p1, dofs = cached
        p1.interpolate(self.flow.u_old)
        n = compat.num_owned_cells(self.mesh)
        tri = self.mesh.geometry.x[:, :2][compat.geometry_dofmap(self.mesh)[:n]]
        vel = p1.x.array.reshape(-1, 2)[dofs[:n]]
        return self.comm.allreduce(courant_rate(tri, vel), op=MPI.MAX)

    def measures(self) -> dict:
        """Front position (furthest x of the mass: the toe, or the nose of an overturning
        front), maximum height, kinetic energy, area, max speed, mesh quality."""
        x = self.mesh.geometry.x
        front, height = self.scene.extent(x)
        speed = np.linalg.norm(self.flow.u_old.x.array.reshape(-1, 2), axis=1)
        out = {
            "front": self.comm.allreduce(float(front), op=MPI.MAX),
            "max_height": self.comm.allreduce(float(height), op=MPI.MAX),
            "kinetic_energy": self.comm.allreduce(fem.assemble_scalar(self._kinetic), op=MPI.SUM),
            "gravity_moment": self.comm.allreduce(fem.assemble_scalar(self._gravity_moment), op=MPI.SUM),
            "area": self.area(),
            "max_speed": self.comm.allreduce(float(speed.max()) if len(speed) else 0.0, op=MPI.MAX),
        }
        out.update(quality(self.mesh, self.orientation))
        out["ill_posed_fraction"] = self.ill_posed_fraction()
        out["thick_front"] = self.thick_front()
        return out

    def thick_front(self) -> float:
        """The furthest x where the mass is at least ``film_threshold`` thick
        (``scenes.base.thickness_front`` on the boundary polygon, gathered on rank 0):
        the front of a deposit that ends in a thin film; −inf on a boundary that does not
        chain into one loop."""
        from dpcollapse.geometry.mesher import boundary_edges

        edges, tags = boundary_edges(self.tagged)
        front = None
        if self.comm.rank == 0:
            try:
                # the outer loop (holes: pockets); chained once per mesh (geometry.boundary_loops)
                key = (self.tagged.mesh, self.tagged.facet_tags)
                poly = self._boundary_loops.loops(edges, tags, key)[0]
                front = thickness_front(poly.points, self.film_threshold)
            except ValueError:
                front = -math.inf
        return float(self.comm.bcast(front, root=0))

    def ill_posed_fraction(self) -> float:
        """μ(I): fraction of the flowing cells (|u| > 1 mm/s) whose I lies outside the
        well-posed window of Barker et al. (2015); NaN for other laws."""
        if self.window is None:
            return math.nan
        n = compat.num_owned_cells(self.mesh)
        inertial, expr = self.out_extra["inertial_number"]
        inertial.interpolate(expr)
        self._speed.interpolate(self._speed_expr)
        I = inertial.x.array[:n]
        flowing = self._speed.x.array[:n] > FLOWING_SPEED
        lo, hi = self.window
        bad = flowing & ((I < lo) | (I > hi)) if lo == lo else flowing
        counts = self.comm.allreduce(np.array([bad.sum(), flowing.sum()], dtype=float), op=MPI.SUM)
        return float(counts[0] / counts[1]) if counts[1] > 0 else 0.0

    def output_functions(self) -> list:
        sol = self.flow.solution
        self.out_velocity.interpolate(sol.sub(0))
        self.out_pressure.interpolate(sol.sub(1))
        self.out_strain_rate.interpolate(self._strain_expr)
        speed = np.linalg.norm(self.out_velocity.x.array.reshape(-1, 2), axis=1)
        self.out_flowing.x.array[:] = (speed > FLOWING_SPEED).astype(float)
        fields = [self.out_velocity, self.out_pressure, self.out_strain_rate, self.out_flowing]
        fields.append(self.out_region)
        if self.flow.surface_gamma is not None:   # seed 000's local surface tension γ = γ0 C [Pa]
            fields.append(self.flow.surface_gamma)
        for function in self.out_cells:
            cells = compat.cell_dofs(function.function_space)[:, 0]
            function.x.array[cells] = self.flow.cell_field(function.name)
            fields.append(function)
        fields.extend(self.out_extra.interpolated())
        return fields


    def solver_counts(self) -> dict[str, int]:
        return self.flow.solver_counts()

    def destroy(self) -> None:
        self.flow.destroy()
        if self.motion is not None:
            self.motion.destroy()


class StokesFactory:
    """The 2D model (``model.name = stokes``, ``numerics.method``) for the loop."""

    model_name = "stokes"
    #: whether its mesh is the scene's own (``dpcollapse mesh`` writes it)
    meshes_the_scene = True

    @staticmethod
    def describe(cfg) -> list[str]:
        """The lines of ``dpcollapse check``: the mesh's cell estimate (and memory), the
        augmented Lagrangian's parameters when it is the method."""
        from dpcollapse.config.sizes import first_mesh
        from dpcollapse.models.describe import lines_2d

        est = first_mesh(cfg)     # from the finest size used (the free surface's too)
        own = [f"mesh: about {est.cells:.3g} cells at {cfg.geometry.mesh_size:g} m "
               f"(about {est.memory / 1e6:.3g} MB)"]
        flow = model_class(cfg.numerics.method, cfg.numerics.nonlinear_solver)
        own += flow.describe(cfg)
        return lines_2d(cfg, own)

    def __init__(self, cfg: Config):
        self.cfg = cfg

    @classmethod
    def from_config(cls, cfg: Config) -> StokesFactory:
        return cls(cfg)

    def domain(self):
        """Moving with ``numerics.ale``, else fixed (``domain.make_domain``)."""
        return make_domain(self.cfg)

    def start(self, comm) -> StokesDiscretization:
        """The scene's mesh with the initial velocity."""
        disc = StokesDiscretization(build_mesh(self.cfg, comm), self.cfg)
        disc.flow.set_velocity(initial_velocity(self.cfg))
        return disc

    def rebuild(self, tagged: TaggedMesh) -> StokesDiscretization:
        """A discretization of a new mesh (remesh) or new facet tags (landing)."""
        return StokesDiscretization(tagged, self.cfg)

    def save_checkpoint(self, path, disc: StokesDiscretization, state: dict) -> None:
        """The mesh, the model's snapshot and the loop state (collective; rank 0 writes)."""
        # the model's numbers besides the fields (BDF2's past steps, the extrapolation's)
        state = {**state, **disc.flow.checkpoint_state()}
        save_model_checkpoint(path, disc.tagged, disc.flow.checkpoint_fields(), state)

    def load_checkpoint(self, path, comm) -> tuple[StokesDiscretization, dict]:
        tagged, fields, state = load_model_checkpoint(path, comm)
        disc = StokesDiscretization(tagged, self.cfg)
        disc.flow.transfer(fields)
        disc.flow.restore_checkpoint(fields, state)
        return disc, state
