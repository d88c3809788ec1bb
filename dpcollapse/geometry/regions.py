"""Material regions (cell tags) carried onto a new mesh of the same domain.

A scene with several regions of the same material (the erodible layer under the mass)
tags its cells; the tags are labels, not physics (one rheology everywhere). On a moving
mesh they move with the cells, i.e. with the mesh velocity w (w·n = u·n on the boundary, a
harmonic extension inside: the region boundary follows the material only as far as w ≈ u).
A remesh or a checkpoint gives a new triangulation: each new cell takes the tag of the old
cell that contains its centroid (the new interface is the staircase of old-cell boundaries
crossed; on the same triangulation, as after a checkpoint, every cell gets its own tag).
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.geometry.mesher import DOMAIN, TaggedMesh
from dpcollapse.transfer import CellwiseField, concatenate


def _local_cell_vertices(mesh, owned_only: bool) -> np.ndarray:
    n = compat.num_owned_cells(mesh) if owned_only else len(compat.geometry_dofmap(mesh))
    return mesh.geometry.x[:, :2][compat.geometry_dofmap(mesh)[:n, :3]]


def region_field(triangles: np.ndarray, tags: np.ndarray) -> CellwiseField:
    """The piecewise-constant field of the cell tags on triangles (n, 3, 2)."""
    values = np.repeat(np.asarray(tags, dtype=float)[:, None], 3, axis=1)
    return CellwiseField(vertices=triangles, points=triangles, values=values, degree=1)


def gather_regions(tagged: TaggedMesh) -> CellwiseField | None:
    """The cell tags of the distributed mesh as a field on every rank (None without tags)."""
    mesh, ct = tagged.mesh, tagged.cell_tags
    if mesh.comm.allreduce(ct is None, op=MPI.LOR):
        return None
    n = compat.num_owned_cells(mesh)
    tags = np.full(n, DOMAIN, dtype=np.int64)
    owned = ct.indices < n
    tags[ct.indices[owned]] = ct.values[owned]
    part = region_field(_local_cell_vertices(mesh, True), tags)
    return concatenate(mesh.comm.allgather(part))


def tag_cells(mesh, field: CellwiseField):
    """Cell tags of every local cell of ``mesh`` (owned and ghost): the tag of the cell of
    ``field`` that contains the cell's centroid."""
    centroids = _local_cell_vertices(mesh, False).mean(axis=1)
    cells, _ = field.locate(centroids)
    tags = np.rint(field.values[cells, 0, 0]).astype(np.int32)
    return compat.meshtags(mesh, mesh.topology.dim, np.arange(len(centroids), dtype=np.int32), tags)


def carry_regions(old: TaggedMesh, new: TaggedMesh) -> TaggedMesh:
    """``new`` with the cell tags of ``old`` located at its cells (unchanged when ``old``
    has none)."""
    field = gather_regions(old)
    if field is None:
        return new
    return TaggedMesh(new.mesh, new.facet_tags, tag_cells(new.mesh, field))

