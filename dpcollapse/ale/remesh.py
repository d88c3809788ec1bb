"""Remeshing: rebuild the domain from its current boundary and carry (u, p) across.

1. Gather the tagged boundary edges of every rank on rank 0 and chain them into one
   polygon (``geometry.polygon``). Every existing boundary vertex stays where it is or is
   dropped; none is moved or snapped, so the toe (the bed/free-surface corner) and the
   front position are exactly continuous. Long edges are split on the edge (no area
   change); clustered vertices are dropped only while the total area change stays below
   a bound (``max_area_change``).
2. Mesh the polygon with gmsh on rank 0 (``geometry.mesher``), distribute.
3. Snapshot uⁿ (P2) and pⁿ (P1) cell by cell (``transfer.CellwiseField``), all-gather,
   and evaluate them at the new mesh's dof coordinates on every rank.

The same snapshot is what a checkpoint stores, so a restart may use any number of ranks.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.geometry.mesher import SURFACE, TaggedMesh, mesh_polygon
from dpcollapse.geometry.polygon import BoundaryPolygon, chain_boundary, resample
from dpcollapse.transfer import CellwiseField, concatenate


@dataclass
class RemeshReport:
    area_before: float
    area_after: float
    cells_before: int
    cells_after: int
    boundary_vertices: int
    outside_distance: float


def boundary_polygon(tagged: TaggedMesh) -> BoundaryPolygon | None:
    """The tagged boundary polygon of the (distributed) mesh, on rank 0 (None elsewhere)."""
    mesh, ft = tagged.mesh, tagged.facet_tags
    nodes = compat.entities_to_geometry(mesh, 1, ft.indices)
    edges = mesh.geometry.x[:, :2][nodes] if len(ft.indices) else np.zeros((0, 2, 2))
    gathered = mesh.comm.gather((edges, np.asarray(ft.values)), root=0)
    if mesh.comm.rank != 0:
        return None
    all_edges = np.concatenate([e for e, _ in gathered])
    all_tags = np.concatenate([t for _, t in gathered])
    return chain_boundary(all_edges, all_tags)


def _cellwise(V, values: np.ndarray, bs: int, degree: int) -> CellwiseField:
    mesh = V.mesh
    n = compat.num_owned_cells(mesh)
    dofs = compat.cell_dofs(V)[:n]
    coords = V.tabulate_dof_coordinates()[:, :2]
    verts = mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n]]
    return CellwiseField(vertices=verts, points=coords[dofs],
                         values=values.reshape(-1, bs)[dofs], degree=degree)


def snapshot(flow) -> tuple[CellwiseField, CellwiseField]:
    """The accepted state (uⁿ on P2, pⁿ on P1) of ``flow`` gathered on every rank."""
    u = _cellwise(flow.V, flow.u_old.x.array, 2, 2)
    p = _cellwise(flow.Q, flow.iterate.x.array[flow.pressure_dofs], 1, 1)
    comm = flow.comm
    return concatenate(comm.allgather(u)), concatenate(comm.allgather(p))


def load_state(flow, u_field: CellwiseField, p_field: CellwiseField) -> float:
    """Set uⁿ, pⁿ (and the first iterate) of ``flow`` from snapshots; returns the largest
    distance of a new dof outside the old domain (extrapolated there)."""
    xu = flow.V.tabulate_dof_coordinates()[:, :2]
    flow.u_old.x.array[:] = u_field.evaluate(xu).ravel()
    outside = u_field.last_outside_distance
    xp = flow.Q.tabulate_dof_coordinates()[:, :2]
    flow.iterate.x.array[flow.pressure_dofs] = p_field.evaluate(xp)[:, 0]
    flow.iterate.x.array[flow.velocity_dofs] = flow.u_old.x.array
    flow.solution.x.array[:] = flow.iterate.x.array
    return flow.comm.allreduce(float(outside), op=MPI.MAX)


#: Discontinuous fields are evaluated this fraction of the way from each dof towards its
#: cell's centroid, so that a dof on a shared vertex or edge takes its own cell's value
#: (exact on the same mesh: a checkpoint restores the multipliers as they were).
INSIDE_SHIFT = 1e-6


def _evaluation_points(V) -> np.ndarray:
    """Where to evaluate a snapshot for V's dofs: the dof coordinates, pulled slightly into
    their cell for discontinuous spaces (every local dof belongs to one local cell)."""
    x = V.tabulate_dof_coordinates()[:, :2].copy()
    if compat.element_info(V).family != "DG":
        return x
    mesh = V.mesh
    cells = compat.cell_dofs(V)
    centroids = mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:len(cells), :3]].mean(axis=1)
    for j in range(cells.shape[1]):
        x[cells[:, j]] += INSIDE_SHIFT * (centroids - x[cells[:, j]])
    return x


def snapshot_multipliers(flow) -> dict[str, CellwiseField]:
    """The augmented Lagrangian multipliers of ``flow`` (none for other solvers), gathered on
    every rank: DG tensors (σ', γ̇) and P2 vectors (σ_T, δ, σ_w, δ_w), cell by cell."""
    fields = {}
    for name, func in flow.multiplier_functions().items():
        V = func.function_space
        bs = V.dofmap.index_map_bs
        degree = compat.element_info(V).degree
        fields[name] = concatenate(flow.comm.allgather(_cellwise(V, func.x.array, bs, degree)))
    return fields


def load_multipliers(flow, fields: dict[str, CellwiseField]) -> None:
    """Evaluate snapshots of multipliers at ``flow``'s dof coordinates (a warm start for the
    iteration: the converged step does not depend on it). Missing names are left at zero."""
    targets = flow.multiplier_functions()
    for name, field in fields.items():
        if name in targets:
            func = targets[name]
            x = _evaluation_points(func.function_space)
            func.x.array[:] = field.evaluate(x).ravel()
    if targets and fields:
        flow.pressure_known = True


def remesh_domain(tagged: TaggedMesh, mesh_size: float, surface_mesh_size: float | None,
                  max_area_change: float) -> tuple[TaggedMesh, float, int]:
    """A new mesh of the current domain; returns (mesh, polygon area change, #vertices)."""
    comm = tagged.mesh.comm
    poly = boundary_polygon(tagged)
    points = tags = None
    d_area, nverts = 0.0, 0
    if comm.rank == 0:
        hs = surface_mesh_size or mesh_size

        def target(tag: int) -> float:
            return hs if tag == SURFACE else mesh_size

        poly, d_area = resample(poly, target, max_area_change)
        points, tags, nverts = poly.points, poly.edge_tags, len(poly.points)
    d_area, nverts = comm.bcast((d_area, nverts), root=0)
    return mesh_polygon(comm, points, tags, mesh_size, surface_mesh_size), d_area, nverts
