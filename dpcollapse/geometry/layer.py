"""A layer of thickness h on an inclined plane, periodic in x (seed 000, case a).

Slope coordinates: x along the bed, y normal to it; the rectangle [0, L] × [0, h] with a
structured triangulation, so the nodes on x = 0 and x = L match for the periodic
constraint. Facets: bed (y = 0), free surface (y = h), periodic sides LEFT (x = 0) and
RIGHT (x = L).
"""

from __future__ import annotations

import numpy as np
from dolfinx import mesh as dmesh
from mpi4py import MPI

from dpcollapse import compat
from dpcollapse.geometry.mesher import BED, LEFT, RIGHT, SURFACE, TaggedMesh


def layer_mesh(comm: MPI.Comm, length: float, thickness: float, mesh_size: float) -> TaggedMesh:
    """Structured triangles of size ≈ mesh_size on [0, length] × [0, thickness]."""
    nx = max(1, round(length / mesh_size))
    ny = max(1, round(thickness / mesh_size))
    mesh = compat.create_rectangle(comm, (0.0, 0.0), (length, thickness), (nx, ny))
    fdim = mesh.topology.dim - 1
    tol = 1e-12 * max(length, thickness)
    markers = ((BED, lambda x: np.abs(x[1]) < tol),
               (SURFACE, lambda x: np.abs(x[1] - thickness) < tol),
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
    return TaggedMesh(mesh, compat.meshtags(mesh, fdim, indices, values[first]))
