"""A rectangle [0, L] × [0, H] in structured triangles with its sides tagged (the periodic
layer's mesh, ``scenes.periodic_layer``; the two-phase model's box, ``scenes.base.box_container``).

Slope coordinates: x along the bed, y normal to it; the nodes on x = 0 and x = L match
(a periodic constraint needs them to). Facets: bed (y = 0), SURFACE (y = H), LEFT (x = 0)
and RIGHT (x = L).
"""

from __future__ import annotations

import numpy as np
from dolfinx import mesh as dmesh
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.geometry.mesher import (
    BED,
    DOMAIN,
    LEFT,
    RIGHT,
    SURFACE,
    TaggedMesh,
)


def structured_rectangle(comm: MPI.Comm, length: float, height: float, nx: int, ny: int) -> TaggedMesh:
    """[0, length] × [0, height] in nx × ny squares cut into triangles, its sides tagged BED
    (y = 0), SURFACE (y = height), LEFT (x = 0) and RIGHT (x = length), its cells DOMAIN."""
    mesh = compat.create_rectangle(comm, (0.0, 0.0), (length, height), (nx, ny))
    fdim = mesh.topology.dim - 1
    tol = 1e-12 * max(length, height)
    markers = ((BED, lambda x: np.abs(x[1]) < tol),
               (SURFACE, lambda x: np.abs(x[1] - height) < tol),
               (LEFT, lambda x: np.abs(x[0]) < tol),
               (RIGHT, lambda x: np.abs(x[0] - length) < tol))
    indices, values = [], []
    for tag, where in markers:
        facets = dmesh.locate_entities_boundary(mesh, fdim, where)
        indices.append(facets)
        values.append(np.full(len(facets), tag, dtype=np.int32))
    indices = np.concatenate(indices)
    values = np.concatenate(values)
    indices, first = np.unique(indices, return_index=True)  # corner facets: keep one tag
    mesh.topology.create_connectivity(fdim, mesh.topology.dim)
    cells = np.arange(compat.num_owned_cells(mesh), dtype=np.int32)
    return TaggedMesh(mesh, compat.meshtags(mesh, fdim, indices, values[first]),
                      compat.meshtags(mesh, fdim + 1, cells, np.full(len(cells), DOMAIN)))
