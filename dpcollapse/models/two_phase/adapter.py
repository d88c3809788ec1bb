"""The Eulerian two-phase model in the time loop (``simulation``): the loop's protocols
(``loop``) for a fixed box mesh carrying the granular volume fraction c.

* ``box_mesh``: the structured triangle mesh of [0, box_length] × [0, box_height], cells of
  ``geometry.mesh_size``, sides tagged bed (y = 0), symmetry (x = 0), right, top;
* ``TwoPhaseDiscretization``: the flow (``flow.TwoPhaseFlow``), its measures from c (mass
  front, thickness front and heights from h(x) = ∫ c dy, kinetic energy and area of the
  granular phase), its outputs (c, u, p and the law's fields such as the inertial number);
* ``TwoPhaseFactory``: ``model.name = two_phase``: a fixed domain, the column, or the
  trapezoid on its erodible layer (``layer``: c and the layer's own fraction c_L), as the
  initial c (exact cell overlap), checkpoints of u, p, c (and c_L).

On the erodible layer the fronts leave the layer out, as the moving-mesh scene does: the mass
front is the furthest x of the granular cells whose centroid lies above 2 h_e, the thickness
front the right edge of the furthest column with h ≥ max(film threshold, 2 h_e).

The vessel, its sides and the initial material are the scene's (``scenes.base.Container``,
the one owner of geometry): the column's and the erodible layer's box has the bed of
``boundary.bed_condition``, the symmetry plane or wall x = 0, the slip right side and the open
top (σ·n = 0: the light fluid leaves and enters freely, and the pressure needs no gauge); the
silo (``scenes.silo``) its bin, walls and orifice (outflow).

Axisymmetric (``geometry.symmetry: axisymmetric``, issue 52): the mesh is the (r, z)
half-plane, x = r; the flow and c's transport carry the measure 2πr (``flow``), the initial c
is the exact overlap in r dA, and the measures are the body of revolution's: ``area`` its
granular volume 2π∫ r c dx [m³] (as on the moving mesh), the kinetic energy [J], the
outflow and escaped volumes [m³], a bin's discharge rate ρ_b (volume through the orifice)/Δt
[kg/s] and its mass [kg]; h(x) = ∫ c dz stays a height, front and heights radii and heights.
"""

from __future__ import annotations

import math

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.domain.adaptive_box import AdaptiveBox, SizeField, equivalent_size
from dpcollapse.domain.fixed import FixedDomain
from dpcollapse.fronts import profile_front
from dpcollapse.geometry.mesher import TaggedMesh
from dpcollapse.geometry.rectangle import structured_rectangle
from dpcollapse.io.checkpoint import load_model_checkpoint, save_model_checkpoint
from dpcollapse.io.law_fields import LawFields
from dpcollapse.models.base import DiscretizationDefaults
from dpcollapse.models.stokes.regularized import picard_settings
from dpcollapse.models.stokes.state import FlowParameters
from dpcollapse.models.two_phase.erodible_layer import MEASURES as LAYER_MEASURES
from dpcollapse.models.two_phase.erodible_layer import LayerTracer
from dpcollapse.models.two_phase.flow import LightFluid, TwoPhaseFlow
from dpcollapse.models.two_phase.fraction import owned_triangles
from dpcollapse.models.two_phase.overlap import union_fraction
from dpcollapse.models.two_phase.remap import strip_overlaps
from dpcollapse.rheology.choice import law_from_material
from dpcollapse.rheology.coordinates import PLANAR, coordinates
from dpcollapse.scenes.base import Container, film_threshold
from dpcollapse.scenes.registry import scene


def box_mesh(comm, length: float, height: float, mesh_size: float) -> TaggedMesh:
    """[0, length] × [0, height] in triangles of about ``mesh_size``, sides tagged BED,
    LEFT (the symmetry wall), RIGHT and SURFACE (the open top)."""
    nx, ny = max(2, round(length / mesh_size)), max(2, round(height / mesh_size))
    return structured_rectangle(comm, length, height, nx, ny)


def container(cfg) -> Container:
    """The scene's vessel (``scenes.base.Container``): its mesh, sides and initial material;
    the box of ``model.box_length`` × ``model.box_height`` for the scenes that stand in one."""
    m = cfg.model
    return scene(cfg).container((m.box_length, m.box_height))


def cell_sizes(cfg) -> tuple[float, float]:
    """(fine, coarse) cell sizes: ``model.min_cell``, ``model.max_cell`` (null:
    ``geometry.mesh_size``)."""
    m, h = cfg.model, cfg.geometry.mesh_size
    return (m.min_cell if m.min_cell is not None else h,
            m.max_cell if m.max_cell is not None else h)


def is_adaptive(cfg) -> bool:
    """The mesh follows the granular phase: ``model.min_cell`` below the coarse size."""
    fine, coarse = cell_sizes(cfg)
    return cfg.model.min_cell is not None and fine < coarse


def adaptive_domain(cfg, box: tuple[float, float]) -> AdaptiveBox:
    m = cfg.model
    fine, coarse = cell_sizes(cfg)
    size = SizeField(fine, coarse, m.refine_band * fine, m.refine_grading,
                     layer_cell=m.layer_cell, thin_cells=m.thin_layer_cells)
    return AdaptiveBox(*box, size, m.refine_fraction, m.remesh_every)


def make_flow(tagged: TaggedMesh, cfg, vessel: Container) -> TwoPhaseFlow:
    m, model = cfg.material, cfg.model
    coords = coordinates(cfg.geometry.coordinates)     # geometry.symmetry
    params = FlowParameters(density=m.density, gravity=m.gravity,
                            bed_angle=math.radians(cfg.geometry.bed_angle),
                            rheology=law_from_material(cfg.material, coords),
                            boundaries=vessel.boundaries, coordinates=coords)
    light = LightFluid(model.air_density, model.air_viscosity, model.courant, model.compression,
                       model.grad_div, model.viscosity_average, model.yield_weighting,
                       model.grain_pressure, model.cut_cell_pressure, model.inertia,
                       model.compression_direction, strips(cfg, vessel), model.open_top,
                       model.thin_layer_cells, model.compression_speed,
                       interface_flux=model.interface_flux,
                       interface_normal=model.interface_normal)
    return TwoPhaseFlow(tagged, params, picard_settings(cfg), light)


def strips(cfg, vessel: Container) -> tuple[float, int]:
    """(width, count): the columns of h(x) = ∫ c dy, the vessel's length in strips of the fine
    cell size (the measures' and the thin layers' height function, ``layer_normal``)."""
    count = max(2, round(vessel.length / cell_sizes(cfg)[0]))
    return vessel.length / count, count


def _triangle_areas(triangles: np.ndarray) -> np.ndarray:
    """|K| of each triangle (n, 3, 2) [m²]."""
    a, b = triangles[:, 1] - triangles[:, 0], triangles[:, 2] - triangles[:, 0]
    return 0.5 * np.abs(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0])


def _shortest_edges(triangles: np.ndarray) -> np.ndarray:
    """The shortest edge of each triangle (n, 3, 2) [m]."""
    return np.linalg.norm(triangles - np.roll(triangles, 1, axis=1), axis=2).min(axis=1)


#: a bin's measures (the half vessel; Q for the whole symmetric silo): the discharge rate Q
#: [kg/(m s)] = 2 ρ_s (volume through the orifice in the step)/Δt, the granular area that has
#: left [m²], the fill height floor(x_w) + ∫ c dy at the side wall's strip x_w [m], the
#: granular mass in the whole bin 2 ρ_s ∫ c dx [kg/m]. Axisymmetric: the volumes are the
#: whole body's, Q = ρ_s (volume)/Δt [kg/s], the outflow volume [m³], the mass ρ_s ∫ 2πr c [kg]
BIN_MEASURES = ("discharge_rate", "outflow_area", "fill_height", "bin_mass")


class TwoPhaseDiscretization(DiscretizationDefaults):
    """The two-phase flow on the box, its measures and output fields (``loop``)."""

    #: h(x = 0) [m]; min and max of c; advection sub-steps of the last step
    #: and the kinetic energy ∫ c ρ |u|²/2 over every cell (the haze of c the light fluid
    #: carries included) [J/m]; Σ_K min(c_K, 1) |∫_K ∇·u| [m²/s]; the material that left
    #: through the sides other than an outflow (the open top) [m²]
    extra_measures = ("wall_height", "fraction_min", "fraction_max", "substeps",
                      "mixture_kinetic_energy", "divergence_rate", "escaped_area")

    def __init__(self, tagged: TaggedMesh, cfg, vessel: Container | None = None):
        self.cfg, self.tagged = cfg, tagged
        self.vessel = vessel = vessel or container(cfg)
        self.mesh = mesh = tagged.mesh
        self.comm = mesh.comm
        self.flow = flow = make_flow(tagged, cfg, vessel)
        self.fraction = flow.fraction
        coords = flow.params.coordinates
        self.radial = coords != PLANAR
        # planar: the half vessel's measures doubled for the whole symmetric bin; axisymmetric:
        # the body of revolution's volumes are already the whole silo's
        self.whole = 1.0 if self.radial else 2.0
        model = cfg.model
        fine = cell_sizes(cfg)[0]
        self.film_threshold = film_threshold(law_from_material(cfg.material).grain_scale, fine)
        self.threshold = model.fraction_threshold
        # a scene with an erodible layer: c_L, and the fronts above the scene's floor
        self.layer = LayerTracer(flow, vessel.bed_layer) if vessel.bed_layer is not None else None
        self.thick_floor = max(self.film_threshold, vessel.front_floor)
        if self.layer:
            self.extra_measures = type(self).extra_measures + LAYER_MEASURES
        self.bin = vessel.floor is not None
        self._discharge, self._last_outflow = [], None   # (Δt, Q) of the accepted steps
        if self.bin:
            self.extra_measures = type(self).extra_measures + BIN_MEASURES
            self.history_plot = "discharge"   # Q, −dm/dt and the fill height over time
        # columns for h(x) = ∫ c dy: strips of the structured mesh's width along x (on the
        # adaptive mesh: of min_cell)
        self.dx_bin, self.nx = strips(cfg, vessel)
        n = compat.num_owned_cells(mesh)
        tri = owned_triangles(mesh)
        self._cells = compat.cell_dofs(self.fraction.S0)[:n, 0]
        self._xmax = tri[:, :, 0].max(axis=1)
        self._above = tri[:, :, 1].mean(axis=1) > vessel.front_floor    # cells counted by the mass front
        # the planar cell areas |K| (the strips' h(x) = ∫ c dy is a height in either coordinates)
        self._volume = (_triangle_areas(tri) if self.radial else
                        self.fraction.volume[self._cells] if len(self._cells) else np.zeros(0))
        if is_adaptive(cfg) or vessel.box is None:   # |K ∩ strip_j| (exact: the cells straddle
            # the strips of an unstructured mesh)
            self._strip_cell, self._bin, self._strip_area = strip_overlaps(tri, self.dx_bin, self.nx)
        else:                  # each structured cell lies in the strip of its centroid
            self._strip_cell, self._strip_area = np.arange(len(tri)), self._volume
            self._bin = np.clip((tri[:, :, 0].mean(axis=1) / self.dx_bin).astype(int), 0, self.nx - 1)
        self._size = equivalent_size(tri)                    # h_K of the owned cells
        self._min_edge = self.comm.allreduce(
            float(_shortest_edges(tri).min()) if len(tri) else math.inf, op=MPI.MIN)
        rho = cfg.material.density
        u, p = ufl.split(flow.solution)
        c = self.fraction.c
        dx = coords.measure(ufl.dx(domain=mesh), mesh)    # axisymmetric: 2πr dx
        # the granular cells (c > fraction_threshold): 1 there, 0 elsewhere (set in measures)
        self._granular = fem.Function(self.fraction.S0)
        energy = 0.5 * rho * c * ufl.inner(flow.u_old, flow.u_old)
        self._kinetic = fem.form(self._granular * energy * dx)
        self._kinetic_mixture = fem.form(energy * dx)
        f = fem.Constant(mesh, np.array(flow.params.body_force, dtype=compat.ScalarType))
        self._gravity_moment = fem.form(rho * c * ufl.inner(f, ufl.SpatialCoordinate(mesh)) * dx)
        V1, S1, S0 = (compat.vector_space(mesh, 1), compat.scalar_space(mesh, 1),
                      compat.scalar_space(mesh, 0, "DG"))
        self.out_velocity = fem.Function(V1, name="velocity")
        self.out_pressure = fem.Function(S1, name="pressure")
        self._speed = fem.Function(S0)
        self._speed_expr = compat.expression(ufl.sqrt(ufl.inner(flow.u_old, flow.u_old)), S0)
        eps = cfg.numerics.epsilon
        self.out_extra = LawFields(flow.params.rheology, u, p, eps, S0)

    def set_initial(self) -> None:
        """c = |K ∩ ∪P| / |K| in each cell for the scene's initial region ∪P (exact); on the
        erodible layer c_L = |K ∩ layer| / |K| too."""
        values = union_fraction(owned_triangles(self.mesh), self.vessel.fraction_region,
                                radial=self.radial)
        c = self.fraction.c
        c.x.array[self._cells] = values
        c.x.scatter_forward()
        self.fraction.forget_history()
        if self.layer:
            self.layer.set_initial()

    # ------------------------------------------------------------------ measures
    def area(self) -> float:
        """∫ c dx [m²] (axisymmetric: the granular volume 2π∫ r c dx [m³])."""
        return self.fraction.integral()

    def thickness(self) -> np.ndarray:
        """h_j = ∫ c dy of each column j of cells (width ``dx_bin``) [m], on every rank."""
        own = self.fraction.c.x.array[self._cells]
        local = np.bincount(self._bin, weights=own[self._strip_cell] * self._strip_area,
                            minlength=self.nx)
        return self.comm.allreduce(local, op=MPI.SUM) / self.dx_bin

    def max_step(self) -> float:
        """With ``model.adaptive_dt``: Co min_K h_K / |uⁿ_K| over the cells with c >
        ``model.step_fraction`` (Co = ``model.step_courant``, h_K the equilateral side of
        |K|, |uⁿ_K| at the midpoint); inf at rest and without it (the advection of c
        sub-cycles inside the step)."""
        model = self.cfg.model
        if not model.adaptive_dt:
            return math.inf
        self._speed.interpolate(self._speed_expr)
        speed = self._speed.x.array[self._cells]
        moving = (self.fraction.c.x.array[self._cells] > model.step_fraction) & (speed > 0)
        local = float((self._size[moving] / speed[moving]).min()) if moving.any() else math.inf
        return model.step_courant * self.comm.allreduce(local, op=MPI.MIN)

    def _granular_speed(self) -> np.ndarray:
        self._speed.interpolate(self._speed_expr)
        own = self.fraction.c.x.array[self._cells] > self.threshold
        return self._speed.x.array[self._cells][own]

    def courant_rate(self) -> float:
        """max |uⁿ| at the granular cells' midpoints / the shortest cell edge [1/s]."""
        speed = self._granular_speed()
        top = float(speed.max()) if len(speed) else 0.0
        return self.comm.allreduce(top, op=MPI.MAX) / self._min_edge

    def measures(self) -> dict:
        """Mass front (furthest x of a cell with c > model.fraction_threshold; on the erodible
        layer of those above 2 h_e), thickness front (right edge of the furthest column with
        h ≥ film_threshold, ``fronts.profile_front`` through the columns' centres; on the
        layer ≥ max(film_threshold, 2 h_e)), max height
        max_j h_j, kinetic energy ∫ c ρ |u|²/2 over the granular cells (c > the threshold:
        the haze of c that the light fluid's circulation carries is left out, measured to
        hold 97 % of the mixture's energy once the deposit stops), gravity's moment
        ∫ c ρ f·x, area ∫ c, max speed of the granular cells, bounds of c; on the erodible
        layer the layer's measures (``erodible_layer.LayerTracer.measures``)."""
        c = self.fraction.c.x.array[self._cells]
        granular = c > self.threshold
        self._granular.x.array[:] = (self.fraction.c.x.array > self.threshold).astype(float)
        ahead = granular & self._above
        front = float(self._xmax[ahead].max()) if ahead.any() else 0.0
        h = self.thickness()
        thick = np.nonzero(h >= self.thick_floor)[0]
        speed = self._granular_speed()
        lo, hi = self.fraction.bounds()
        out = self.layer.measures() if self.layer else {}
        if self.bin:
            out = out | self._bin_measures(h)
        return out | {
            "front": self.comm.allreduce(front, op=MPI.MAX),
            "thick_front": profile_front((np.arange(self.nx) + 0.5) * self.dx_bin, h, self.thick_floor)
            if len(thick) else -math.inf,
            "max_height": float(h.max()),
            "kinetic_energy": self.comm.allreduce(fem.assemble_scalar(self._kinetic), op=MPI.SUM),
            "gravity_moment": self.comm.allreduce(fem.assemble_scalar(self._gravity_moment), op=MPI.SUM),
            "area": self.area(),
            "max_speed": self.comm.allreduce(float(speed.max()) if len(speed) else 0.0, op=MPI.MAX),
            "wall_height": float(h[0]),
            "escaped_area": self.fraction.escaped_volume,
            "fraction_min": lo, "fraction_max": hi,
            "substeps": self.fraction.substeps,
            "divergence_rate": self.fraction.divergence_rate(),
            "mixture_kinetic_energy": self.comm.allreduce(
                fem.assemble_scalar(self._kinetic_mixture), op=MPI.SUM),
        }

    def _bin_measures(self, h: np.ndarray) -> dict:
        """The bin's measures (``BIN_MEASURES``) and ``emptied``: less than
        ``geometry.empty_fraction`` of the initial material left in the bin."""
        rho = self.cfg.material.density
        volume, dt = self.fraction.step_outflow
        area = self.area()
        whole = self.whole
        if dt > 0 and volume != self._last_outflow:
            self._discharge.append((dt, whole * rho * volume / dt))
        self._last_outflow = volume
        left = self.fraction.outflow_volume
        wall_x = (self.nx - 0.5) * self.dx_bin
        initial = area + left
        return {"discharge_rate": whole * rho * volume / dt if dt > 0 else 0.0,
                "outflow_area": left,
                "fill_height": float(self.vessel.floor(wall_x)) + float(h[-1]),
                "bin_mass": whole * rho * area,
                "emptied": initial > 0 and area < self.cfg.geometry.empty_fraction * initial}

    def stop_reason(self, measures: dict) -> str | None:
        """A bin that has discharged (``emptied``: less than ``geometry.empty_fraction`` of
        its material left) ends the run."""
        return "emptied" if self.bin and measures["emptied"] else None

    def mass_area(self, measures: dict) -> float:
        """The area in the vessel plus what left through an outflow side and through the
        other sides (``escaped_area``: the open top) [m²]: what left is not a loss."""
        return measures["area"] + measures["escaped_area"] + (measures["outflow_area"] if self.bin else 0.0)

    def summary_measures(self) -> dict:
        """run.json's steady discharge (a bin): the mean and relative standard deviation of Q
        over the window from the first step where Q reaches 95 % of its largest value (the
        discharge set up) to the end (or the last step with Q > 0); NaN without outflow."""
        if not self.bin or not self._discharge:
            return {}
        dt, q = np.array(self._discharge).T
        t = np.cumsum(dt)
        start = int(np.argmax(q >= 0.95 * q.max()))
        stop = int(np.nonzero(q > 0)[0][-1]) + 1
        window = q[start:stop]
        mean = float(window.mean()) if len(window) else math.nan
        return {"discharge_steady": mean,
                "discharge_spread": float(window.std() / mean) if len(window) and mean else math.nan,
                "discharge_window": [float(t[start] - dt[start]), float(t[stop - 1])]}

    def output_functions(self) -> list:
        """c (DG0), u and p (P1), c_L ("layer_fraction", DG0) on the erodible layer, and the
        law's fields (μ(I): the inertial number, DG0)."""
        sol = self.flow.solution
        self.out_velocity.interpolate(sol.sub(0))
        self.out_pressure.interpolate(sol.sub(1))
        fields = [self.fraction.c, self.out_velocity, self.out_pressure]
        if self.layer:
            fields.append(self.layer.fraction.c)
        fields.extend(self.out_extra.interpolated())
        return fields

    def solver_counts(self) -> dict[str, int]:
        return self.flow.solver_counts()

    def destroy(self) -> None:
        self.flow.destroy()


class TwoPhaseFactory:
    """The two-phase model (``model.name = two_phase``) for the loop."""

    model_name = "two_phase"
    #: whether its mesh is the scene's own (``dpcollapse mesh`` writes it)
    meshes_the_scene = False

    def __init__(self, cfg):
        self.cfg = cfg
        self.vessel = container(cfg)
        self._domain = (adaptive_domain(cfg, self.vessel.box) if is_adaptive(cfg)
                        else FixedDomain())

    @classmethod
    def from_config(cls, cfg) -> TwoPhaseFactory:
        return cls(cfg)

    @staticmethod
    def describe(cfg) -> list[str]:
        """The lines of ``dpcollapse check``: the 2D model's, with the box's cell estimate."""
        from dpcollapse.config.sizes import first_mesh
        from dpcollapse.models.describe import lines_2d

        vessel = container(cfg)
        est = first_mesh(cfg)     # from the finest size used (model.min_cell, the orifice's)
        return lines_2d(cfg, [f"two-phase vessel {vessel.length:g} x {vessel.height:g} m: about "
                              f"{est.cells:.3g} cells of {est.finest:.3g} m and coarser (about "
                              f"{est.memory / 1e6:.3g} MB)"])

    def domain(self) -> FixedDomain | AdaptiveBox:
        """The box: nothing moves; the adaptive mesh (``adaptive.AdaptiveBox``) is rebuilt
        around the granular phase, the uniform one never."""
        return self._domain

    def _box(self, comm) -> TaggedMesh:
        """The scene's vessel meshed uniformly: cells of ``model.min_cell`` (= ``max_cell``),
        else of ``geometry.mesh_size`` (the box: structured)."""
        return self.vessel.mesh(comm, cell_sizes(self.cfg)[0])

    def _initial(self, tagged) -> TwoPhaseDiscretization:
        """c of the scene's initial region on ``tagged``, at rest."""
        disc = TwoPhaseDiscretization(tagged, self.cfg, self.vessel)
        disc.set_initial()
        return disc

    def start(self, comm) -> TwoPhaseDiscretization:
        """The box with the initial c (exact overlaps). Adaptive: the uniform box of
        ``max_cell`` refined twice around its granular cells (the second from the first's
        finer cells), the exact overlaps set anew on each."""
        if not is_adaptive(self.cfg):
            return self._initial(self._box(comm))
        disc = self._initial(self.vessel.mesh(comm, cell_sizes(self.cfg)[1]))
        for _ in range(2):
            tagged = self._domain.mesh_for(comm, disc.fraction)
            disc.destroy()
            disc = self._initial(tagged)
        return disc

    def rebuild(self, tagged) -> TwoPhaseDiscretization:
        """A discretization on a new mesh of the box (the adaptive remesh); the loop transfers
        the state (``flow.TwoPhaseFlow.transfer``)."""
        return TwoPhaseDiscretization(tagged, self.cfg, self.vessel)

    def save_checkpoint(self, path, disc: TwoPhaseDiscretization, state: dict) -> None:
        """The mesh, uⁿ, pⁿ, cⁿ and the loop state (collective; rank 0 writes); a bin's
        outflow so far and its (Δt, Q) history with the loop state."""
        state = state | {"escaped_area": disc.fraction.escaped_volume}
        if disc.bin:
            state = state | {"outflow_area": disc.fraction.outflow_volume,
                             "discharge_history": [list(x) for x in disc._discharge]}
        # the flow's numbers besides the fields (numerics.extrapolate's x_{n−1}, Δt, ρ)
        state = state | disc.flow.checkpoint_state()
        save_model_checkpoint(path, disc.tagged, disc.flow.checkpoint_fields(), state)

    def load_checkpoint(self, path, comm) -> tuple[TwoPhaseDiscretization, dict]:
        """The box of the config with the checkpoint's fields."""
        tagged, fields, state = load_model_checkpoint(path, comm)
        # the adaptive mesh is the checkpoint's own; the uniform box that of the config
        disc = TwoPhaseDiscretization(tagged if is_adaptive(self.cfg) else self._box(comm), self.cfg,
                                      self.vessel)
        disc.flow.transfer(fields)
        disc.flow.restore_checkpoint(fields, state)
        disc.fraction.escaped_volume = float(state.get("escaped_area", 0.0))
        if disc.bin:
            disc.fraction.outflow_volume = float(state.get("outflow_area", 0.0))
            disc._discharge = [tuple(x) for x in state.get("discharge_history", [])]
        return disc, state
