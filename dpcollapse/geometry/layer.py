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
from dpcollapse.geometry.mesher import (
    BED,
    DOMAIN,
    LEFT,
    RIGHT,
    SURFACE,
    TAG_NAMES,
    TaggedMesh,
    gmsh_session,
)


def layer_mesh(comm: MPI.Comm, length: float, thickness: float, mesh_size: float) -> TaggedMesh:
    """Structured triangles of size ≈ mesh_size on [0, length] × [0, thickness]."""
    nx = max(1, round(length / mesh_size))
    ny = max(1, round(thickness / mesh_size))
    return structured_rectangle(comm, length, thickness, nx, ny)


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


def write_layer_msh(path, length: float, thickness: float, mesh_size: float) -> None:
    """Write the layer as a structured gmsh mesh (the divisions of ``layer_mesh``; matching
    nodes on x = 0 and x = L) with the physical tags BED, RIGHT, SURFACE, LEFT, DOMAIN."""
    nx = max(1, round(length / mesh_size))
    ny = max(1, round(thickness / mesh_size))
    corners = [(0.0, 0.0), (length, 0.0), (length, thickness), (0.0, thickness)]
    sides = [(BED, nx), (RIGHT, ny), (SURFACE, nx), (LEFT, ny)]   # side i: corner i -> i + 1
    with gmsh_session() as gmsh:
        gmsh.model.add("layer")
        geo = gmsh.model.geo
        points = [geo.addPoint(x, y, 0.0, mesh_size) for x, y in corners]
        lines = [geo.addLine(points[i], points[(i + 1) % 4]) for i in range(4)]
        for line, (_, n) in zip(lines, sides):
            geo.mesh.setTransfiniteCurve(line, n + 1)
        surface = geo.addPlaneSurface([geo.addCurveLoop(lines)])
        geo.mesh.setTransfiniteSurface(surface)
        geo.synchronize()
        for line, (tag, _) in zip(lines, sides):
            gmsh.model.addPhysicalGroup(1, [line], tag)
            gmsh.model.setPhysicalName(1, tag, TAG_NAMES[tag])
        gmsh.model.addPhysicalGroup(2, [surface], DOMAIN)
        gmsh.model.setPhysicalName(2, DOMAIN, "granular_mass")
        gmsh.model.mesh.generate(2)
        gmsh.write(str(path))
