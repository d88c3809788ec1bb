"""Remeshing: rebuild the domain from its current boundary and carry (u, p) across.

1. Gather the tagged boundary edges of every rank on rank 0 and chain them into one
   polygon (``geometry.polygon``). A free surface folded over itself (a crossing) is
   untangled first: the smaller loop at each crossing is cut off at the crossing point
   (``polygon.untangle``; its area is the area change reported). Every existing boundary vertex stays where it is or is
   dropped; none is moved or snapped, so the toe (the bed/free-surface corner) and the
   front position are exactly continuous. Long edges are split on the edge (no area
   change); clustered vertices are dropped only while the total area change stays below
   a bound (``max_area_change``).
2. Mesh the polygon with gmsh on rank 0 (``geometry.mesher``), distribute.
3. The model carries its fields across (``models.stokes.state``: ``snapshot`` cell by
   cell, ``transfer`` to the new mesh's dofs).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpcollapse import compat
from dpcollapse.geometry.mesher import SURFACE, TaggedMesh, mesh_polygon
from dpcollapse.geometry.polygon import BoundaryPolygon, chain_boundary, resample, untangle


@dataclass
class RemeshReport:
    area_before: float
    area_after: float
    cells_before: int
    cells_after: int
    boundary_vertices: int
    outside_distance: float


def boundary_polygon(tagged: TaggedMesh) -> BoundaryPolygon | None:
    """The tagged boundary polygon of the (distributed) mesh, on rank 0 (None elsewhere),
    untangled where the free surface has folded over itself."""
    mesh, ft = tagged.mesh, tagged.facet_tags
    nodes = compat.entities_to_geometry(mesh, 1, ft.indices)
    edges = mesh.geometry.x[:, :2][nodes] if len(ft.indices) else np.zeros((0, 2, 2))
    gathered = mesh.comm.gather((edges, np.asarray(ft.values)), root=0)
    if mesh.comm.rank != 0:
        return None
    all_edges = np.concatenate([e for e, _ in gathered])
    all_tags = np.concatenate([t for _, t in gathered])
    folded = chain_boundary(all_edges, all_tags, simple=False)
    points, tags, _ = untangle(folded.points, folded.edge_tags, folded.corners)
    return BoundaryPolygon(points, tags)


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
