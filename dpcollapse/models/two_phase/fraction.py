"""The granular volume fraction c (DG0) of the two-phase model and its explicit, sub-cycled,
conservative advection (``forms.two_phase``); its initial value is an exact cell overlap
(``overlap``). The layer's fraction c_L of the erodible scene is a second ``VolumeFraction``
advected with the sub-step count of c.

* ``VolumeFraction``: c, and ``advance(dt)``: N sub-steps of
  c_K ← c_K − (Δt/N)/|K| ∫_∂K (F_upwind + F_compression) ds, with N the smallest count such
  that (Δt/N) max_K ∫_∂K ((u·n)⁺ + C|u·n|) ds / |K| ≤ the Courant number. The fluxes' matrices
  are assembled once per step and each sub-step is a sparse product (``fluxes``); with
  ``direction`` "normal" the compression's facet weights carry |n̂·n|, n̂ from the gradient of
  c averaged to the vertices at the start of the step (``_VertexAverage``); with "layer_normal"
  ("skip_layers") a layer thinner than two cells takes the normal of its height function
  (no compression) instead (``layer_normal``, on the box's ``strips``). Under MPI
  the ghost values of c are updated by a forward scatter after every sub-step.
* ``interface_flux`` "geometric" (``model.interface_flux``): the sub-step's fluxes are the
  PLIC fluxes of ``geometric_flux`` instead (a straight interface per mixed cell, normal from
  ∇c̄ of cⁿ or, ``interface_normal`` "height_function", the thin layers' (−h', 1); the donor
  strip's granular share; Zalesak-limited to [0, 1]); the boundary keeps the upwind outflow.
* What leaves: the upwind flux takes (u·n)⁺ c out through every side of the box, so
  ∫ c dx + ``outflow_volume`` (the watched outflow sides, a silo's orifice) +
  ``escaped_volume`` (every other side: the open top a haze of c rises through) is
  conserved to round-off; both counted per sub-step with the fluxes' own values.
* Axisymmetric (``coordinates`` = ``rheology.coordinates.AXISYMMETRIC``, issue 52): the cell
  "volumes" |K| = ∫_K 2πr dx and every flux ∫_f … 2πr ds carry the weight 2πr, so the same
  single-valued facet fluxes conserve Σ_K |K| c_K = ∫ 2πr c dx (the body's granular volume
  [m³]) to round-off, with ``outflow_volume`` and ``escaped_volume`` in m³; the cellwise
  divergence is the axisymmetric ∂_r u_r + u_r/r + ∂_z u_z.
"""

from __future__ import annotations

import math

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from dpcollapse import compat
from dpcollapse.forms.two_phase import (
    INTERFACE_FLUXES,
    compression_weights,
    facet_volume_flux,
    fraction_flux,
    outflow_rate,
    outflow_volume_rate,
)
from dpcollapse.geometry.regions import cell_triangles
from dpcollapse.models.two_phase.fluxes import StepFluxes
from dpcollapse.models.two_phase.geometric_flux import GeometricFluxes
from dpcollapse.models.two_phase.layer_normal import LayerNormal
from dpcollapse.models.two_phase.remap import remap
from dpcollapse.rheology.coordinates import PLANAR


def owned_triangles(mesh) -> np.ndarray:
    """(n_owned, 3, 2) vertex coordinates of the owned cells."""
    return cell_triangles(mesh, owned_only=True)


class VolumeFraction:
    """c on DG0 and its advection by a velocity given by ``bind(u)`` (a UFL vector on the same
    mesh; the flow's forms need c before its velocity exists)."""

    def __init__(self, mesh, courant: float, compression: float, name: str = "volume_fraction",
                 direction: str = "normal", coordinates=PLANAR, strips: tuple[float, int] | None = None,
                 thin_layer_cells: float = 2.0, speed: str = "facet",
                 interface_flux: str = "compression", interface_normal: str = "gradient"):
        self.mesh, self.comm = mesh, mesh.comm
        if interface_flux not in INTERFACE_FLUXES:
            raise ValueError(f"interface flux {interface_flux!r}: one of {', '.join(INTERFACE_FLUXES)}")
        #: "compression" (upwind + algebraic compression) or "geometric" (``geometric_flux``)
        self.interface_flux = interface_flux
        #: the geometric flux's normal: "gradient" (−∇c̄) or "height_function" (in a layer
        #: thinner than ``thin_layer_cells``, the layer's own (−h', 1), ``layer_normal``)
        self.interface_normal = interface_normal
        self._geometric = None
        #: planar (|K| the area, per unit depth) or axisymmetric (|K| = ∫_K 2πr dx)
        self.coordinates = coordinates
        self.courant, self.compression = courant, compression
        self.direction = direction   # of the compression: "facet" or "normal" (to the interface)
        self._vertex = None          # c̄: c averaged to the vertices (P1), for "normal"
        #: (width, count) of the box's strips from x = 0: the thin layers' height function
        #: (``layer_normal``) of the directions "layer_normal" and "skip_layers"
        self.strips, self.thin_layer_cells = strips, thin_layer_cells
        self.speed = speed           # of the compression: |u·n| ("facet") or |u| ("full")
        self._layer = None
        self.S0 = S0 = compat.scalar_space(mesh, 0, "DG")
        self.c = fem.Function(S0, name=name)                 # cⁿ (accepted)
        self.previous = fem.Function(S0)                     # cⁿ⁻¹ (``forget_history``)
        self.work = fem.Function(S0)                         # c during the sub-steps
        self.pending = None                                  # c^{n+1} of a converged step
        self.substeps = 0                                    # of the last advance
        self._n = S0.dofmap.index_map.size_local
        v = ufl.TestFunction(S0)
        dx = self._measure(ufl.dx)
        cell = fem.form(v * dx)
        volume = compat.create_vector(cell)
        fem_petsc.assemble_vector(volume, cell)
        volume.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.volume = volume.array_r[:self._n].copy()       # |K| of the owned cells
        volume.destroy()
        self._integral = fem.form(self.c * dx)
        self._b = None
        self._fluxes = None           # the sub-steps' flux matrices (``bind``)
        self._outflow = None          # ∫_out (u·n)⁺ v ds: the outflow sides' weights (``watch_outflow``)
        self.outflow_volume = 0.0     # material that left through the outflow sides [m², axi m³]
        self.escaped_volume = 0.0     # material that left through the other sides [m², axi m³]
        self._boundary = None         # ∫_∂Ω (u·n)⁺ v ds: every side's weights (``bind``)
        self.pending_outflow = 0.0    # of the step not yet accepted
        self.pending_escaped = 0.0
        self.step_outflow = (0.0, 0.0)  # (volume, Δt) of the last accepted step
        self._pending_dt = 0.0

    def _measure(self, measure):
        """``measure`` on this mesh, weighted by 2πr when axisymmetric."""
        return self.coordinates.measure(measure(domain=self.mesh), self.mesh)

    def bind(self, u) -> None:
        """Build the flux and rate forms for the velocity ``u``."""
        if self.interface_flux == "geometric":
            self._bind_geometric(u)
            return
        mesh, C = self.mesh, self.compression
        v, trial = ufl.TestFunction(self.S0), ufl.TrialFunction(self.S0)
        n = ufl.FacetNormal(mesh)
        dS, ds = self._measure(ufl.dS), self._measure(ufl.ds)
        gradient = layer = None
        if self.direction != "facet" and C > 0:
            if self._vertex is None:
                self._vertex = _VertexAverage(self.c)
            gradient = ufl.grad(self._vertex.function)
        if self.direction in ("layer_normal", "skip_layers") and C > 0:
            if self.strips is None:
                raise ValueError(f"compression direction {self.direction!r} needs the box's strips")
            if self._layer is None:
                self._layer = LayerNormal(self.c, *self.strips, self.thin_layer_cells)
            layer = (self._layer.normal, self._layer.thin, self.direction)
        self._fluxes = StepFluxes(fem.form(fraction_flux(trial, u, v, n, dS, ds)),
                                  fem.form(compression_weights(trial, u, v, n, dS, gradient, layer,
                                                               self.speed)),
                                  self.S0.dofmap.index_map, C)
        self._rate = fem.form(outflow_rate(u, v, n, dS, ds, C, self.speed))
        self._divergence = fem.form(self.coordinates.divergence(u) * v * self._measure(ufl.dx))
        self._boundary = fem.form(outflow_volume_rate(v, u, n, ds))
        self._b = compat.create_vector(self._rate)
        self._u = u

    def _bind_geometric(self, u) -> None:
        """The geometric interface flux (``geometric_flux``): the net facet fluxes' matrix,
        the local cells' geometry in dof order, the vertex average c̄ for the normals."""
        mesh = self.mesh
        v, trial = ufl.TestFunction(self.S0), ufl.TrialFunction(self.S0)
        n = ufl.FacetNormal(mesh)
        dS, ds = self._measure(ufl.dS), self._measure(ufl.ds)
        if self._vertex is None:
            self._vertex = _VertexAverage(self.c)
        dofs = compat.cell_dofs(self.S0)[:, 0]
        n_local = len(dofs)
        triangles = np.empty((n_local, 3, 2))
        triangles[dofs] = cell_triangles(mesh, owned_only=False)
        nodes = np.empty((n_local, 3), dtype=np.int64)
        nodes[dofs] = compat.geometry_dofmap(mesh)[:n_local, :3]
        P1 = self._vertex.function.function_space
        p1 = np.empty((n_local, 3), dtype=np.int64)
        p1[dofs] = compat.cell_dofs(P1)[:n_local, :3]
        self._vertex_dofs = p1
        self._vertex_points = P1.tabulate_dof_coordinates()[:, :2][p1]
        self._ratios = (fem.Function(self.S0), fem.Function(self.S0))
        volume = fem.Function(self.S0)
        volume.x.array[:self._n] = self.volume
        volume.x.scatter_forward()
        if self.interface_normal == "height_function":
            if self.strips is None:
                raise ValueError("interface normal 'height_function' needs the box's strips")
            if self._layer is None:
                self._layer = LayerNormal(self.c, *self.strips, self.thin_layer_cells)
        self._geometric = GeometricFluxes(fem.form(facet_volume_flux(trial, u, v, n, dS)),
                                          self.S0.dofmap.index_map, triangles, nodes,
                                          volume.x.array.copy(), self._scatter_ratios)
        self._rate = fem.form(outflow_rate(u, v, n, dS, ds, 0.0))
        self._divergence = fem.form(self.coordinates.divergence(u) * v * self._measure(ufl.dx))
        self._boundary = fem.form(outflow_volume_rate(v, u, n, ds))
        self._b = compat.create_vector(self._rate)
        self._u = u

    def _layer_normals(self, geometric) -> None:
        """In the thin layers' cells (owned and ghosts) the height function's normal (−h', 1)
        (out of the grains of a layer on the bed) in place of −∇c̄'s."""
        layer = self._layer
        cells = layer._scalar_dofs
        thin = layer.thin.x.array[cells] > 0.5
        normal = layer.normal.x.array.reshape(-1, 2)[layer._vector_dofs]
        geometric.normal[cells[thin]] = normal[thin]
        geometric.has_normal[cells[thin]] = True

    def _scatter_ratios(self, r_plus: np.ndarray, r_minus: np.ndarray):
        """The limiter's R± of the owned cells onto every local cell (ghosts updated)."""
        out = []
        for f, values in zip(self._ratios, (r_plus, r_minus)):
            f.x.array[:self._n] = values
            f.x.scatter_forward()
            out.append(f.x.array.copy())
        return out

    def watch_outflow(self, ds_out) -> None:
        """Count the material leaving through the sides of the measure ``ds_out`` (after
        ``bind``): each sub-step adds (Δt/N) ∫_out (u·n)⁺ c ds, exactly what the upwind
        fluxes take out there, so ∫ c dx + ``outflow_volume`` is conserved to round-off."""
        n = ufl.FacetNormal(self.mesh)
        v = ufl.TestFunction(self.S0)
        self._outflow = fem.form(outflow_volume_rate(v, self._u, n,
                                                     self.coordinates.measure(ds_out, self.mesh)))

    def set_values(self, owned_values: np.ndarray) -> None:
        """cⁿ of the owned cells (in dof order); ghosts updated."""
        self.c.x.array[:self._n] = owned_values
        self.c.x.scatter_forward()

    def owned_values(self) -> np.ndarray:
        """cⁿ of the owned cells in the order of ``owned_triangles``."""
        n = compat.num_owned_cells(self.mesh)
        return self.c.x.array[compat.cell_dofs(self.S0)[:n, 0]]

    def gathered(self) -> tuple[np.ndarray, np.ndarray]:
        """(triangles (N, 3, 2), cⁿ (N,)) of the owned cells of every rank, on every rank."""
        parts = self.comm.allgather((owned_triangles(self.mesh), self.owned_values()))
        return (np.concatenate([t for t, _ in parts]), np.concatenate([v for _, v in parts]))

    def remap_from(self, triangles: np.ndarray, values: np.ndarray, previous: bool = False) -> None:
        """cⁿ (``previous``: cⁿ⁻¹) = the exact conservative remap (``remap``) of the cellwise
        ``values`` on the ``triangles`` of another mesh of the same region (all of it, on every
        rank) onto the owned cells; ghosts updated."""
        n = compat.num_owned_cells(self.mesh)
        target = self.previous if previous else self.c
        target.x.array[compat.cell_dofs(self.S0)[:n, 0]] = remap(triangles, values,
                                                                 owned_triangles(self.mesh))
        target.x.scatter_forward()

    def forget_history(self) -> None:
        """cⁿ⁻¹ = cⁿ: no change of c before this step (the start, or a state without it)."""
        self.previous.x.array[:] = self.c.x.array

    def _assemble(self, form) -> np.ndarray:
        b = self._b
        with b.localForm() as loc:
            loc.set(0.0)
        fem_petsc.assemble_vector(b, form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return b.array_r[:self._n]

    def max_rate(self) -> float:
        """max_K ∫_∂K ((u·n)⁺ + C|u·n|) ds / |K| [1/s] for the current u."""
        local = self._assemble(self._rate) / self.volume
        top = float(local.max()) if len(local) else 0.0
        return self.comm.allreduce(top, op=MPI.MAX)

    def divergence_rate(self) -> float:
        """Σ_K min(c_K, 1) |∫_K ∇·u dx| [m²/s]: the rate at which the cellwise divergence of
        the velocity makes or unmakes granular volume in the upwind fluxes (zero for an
        exactly divergence-free u; the light fluid's cells do not count)."""
        weight = np.clip(self.c.x.array[:self._n], 0.0, 1.0)
        local = float((weight * np.abs(self._assemble(self._divergence))).sum())
        return self.comm.allreduce(local, op=MPI.SUM)

    def advance(self, dt: float, steps: int | None = None) -> int:
        """c^{n+1} from cⁿ with the current u (kept as ``pending``) in ``steps`` sub-steps
        (None: the fewest the Courant number allows); the number of sub-steps."""
        if steps is None:
            rate = self.max_rate()
            steps = max(1, math.ceil(dt * rate / self.courant - 1e-12)) if rate > 0 else 1
        h = dt / steps
        self.work.x.array[:] = self.c.x.array
        geometric = self._geometric
        if self._vertex is not None:
            self._vertex.update()       # the interface normal of cⁿ, fixed over the sub-steps
        if self._layer is not None:
            self._layer.update()        # the thin layers' normals of cⁿ, likewise
        if geometric is not None:
            vertex = self._vertex.function.x.array
            geometric.set_normals(self._vertex_points, vertex[self._vertex_dofs])
            if self._layer is not None:
                self._layer_normals(geometric)
            geometric.assemble()
        else:
            self._fluxes.assemble()
        weights = None if self._outflow is None else self._assemble(self._outflow).copy()
        others = self._assemble(self._boundary).copy()     # every side, less the outflow's
        boundary = others.copy()                             # every side (geometric's upwind)
        if weights is not None:
            others -= weights
        out = escaped = 0.0
        for _ in range(steps):
            own = self.work.x.array[:self._n]
            if weights is not None:
                local = float(weights @ own)
                out += h * self.comm.allreduce(local, op=MPI.SUM)
            escaped += h * self.comm.allreduce(float(others @ own), op=MPI.SUM)
            if geometric is not None:
                residual = geometric.residual(self.work.x.array, h, boundary)
            else:
                residual = self._fluxes.residual(self.work.x.array)
            self.work.x.array[:self._n] -= h * residual / self.volume
            self.work.x.scatter_forward()
        self.pending = self.work.x.array.copy()
        self.pending_outflow, self.pending_escaped, self._pending_dt = out, escaped, dt
        self.substeps = steps
        return steps

    def accept(self) -> None:
        if self.pending is not None:
            self.previous.x.array[:] = self.c.x.array
            self.c.x.array[:] = self.pending
            self.outflow_volume += self.pending_outflow
            self.escaped_volume += self.pending_escaped
            self.step_outflow = (self.pending_outflow, self._pending_dt)
        self.pending = None

    def reject(self) -> None:
        self.pending = None

    def integral(self) -> float:
        """∫ c dx [m²] (axisymmetric: ∫ 2πr c dx [m³])."""
        return self.comm.allreduce(fem.assemble_scalar(self._integral), op=MPI.SUM)

    def bounds(self) -> tuple[float, float]:
        """(min c, max c) over all cells."""
        own = self.c.x.array[:self._n]
        lo = float(own.min()) if len(own) else math.inf
        hi = float(own.max()) if len(own) else -math.inf
        return self.comm.allreduce(lo, op=MPI.MIN), self.comm.allreduce(hi, op=MPI.MAX)

    def destroy(self) -> None:
        if self._b is not None:
            self._b.destroy()
        if self._fluxes is not None:
            self._fluxes.destroy()
        if self._geometric is not None:
            self._geometric.destroy()


class _VertexAverage:
    """c̄ ∈ P1 with c̄_i = ∫ c φ_i dx / ∫ φ_i dx (the lumped L2 projection of the DG0 ``fraction``):
    the vertex values whose gradient gives the interface normal of ``compression_direction:
    normal``."""

    def __init__(self, fraction):
        mesh = fraction.function_space.mesh
        self.function = fem.Function(compat.scalar_space(mesh, 1))
        phi = ufl.TestFunction(self.function.function_space)
        self._n = self.function.function_space.dofmap.index_map.size_local
        self._form = fem.form(phi * ufl.dx(domain=mesh))
        self._assemble()
        self._weight = self.function.x.array[:self._n].copy()     # ∫ φ_i dx
        self._form = fem.form(fraction * phi * ufl.dx(domain=mesh))

    def _assemble(self) -> None:
        """The form into the function's owned values (contributions of other ranks added)."""
        vec = compat.petsc_vec(self.function)
        with vec.localForm() as loc:
            loc.set(0.0)
        fem_petsc.assemble_vector(vec, self._form)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)

    def update(self) -> None:
        self._assemble()
        self.function.x.array[:self._n] /= self._weight
        self.function.x.scatter_forward()
