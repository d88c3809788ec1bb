"""A layer of thickness h on an inclined plane, periodic in x (seed 000, case a).

[0, L] × [0, h] in slope coordinates: the bed y = 0 (no slip or Coulomb friction), the
free surface y = h, and the periodic sides x = 0 (master) and x = L (slave, shifted by
(−L, 0) onto the master). A fixed domain, in structured triangles so that the nodes on
x = 0 and x = L match for the periodic constraint.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from mpi4py import MPI

from dpcollapse.geometry.mesher import (
    BED,
    DOMAIN,
    LEFT,
    RIGHT,
    SURFACE,
    TAG_NAMES,
    TaggedMesh,
    gmsh_session,
    read_msh,
)
from dpcollapse.geometry.rectangle import structured_rectangle
from dpcollapse.scenes.base import (
    Boundary,
    BoundaryKind,
    SceneSections,
    initial_velocity,
    top_extent,
)


def layer_mesh(comm: MPI.Comm, length: float, thickness: float, mesh_size: float) -> TaggedMesh:
    """Structured triangles of size ≈ mesh_size on [0, length] × [0, thickness]."""
    nx = max(1, round(length / mesh_size))
    ny = max(1, round(thickness / mesh_size))
    return structured_rectangle(comm, length, thickness, nx, ny)


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


@dataclass(frozen=True)
class LayerScene(SceneSections):
    """Holds ``config.geometry.LayerGeometry`` (thickness ``height`` h, period
    ``base_length`` L), the boundary and initial sections (``SceneSections``)."""

    shape = "layer"

    def mesh(self, comm) -> TaggedMesh:
        g = self.geometry
        if g.mesh_file:
            return read_msh(comm, g.mesh_file)
        return layer_mesh(comm, g.base_length, g.height, g.mesh_size)

    def boundaries(self) -> tuple[Boundary, ...]:
        return (self.bed(),
                Boundary(SURFACE, "surface", BoundaryKind.FREE_SURFACE),
                Boundary(LEFT, "left", BoundaryKind.PERIODIC, (-1.0, 0.0)),
                Boundary(RIGHT, "right", BoundaryKind.PERIODIC, (1.0, 0.0),
                         translation=(-self.geometry.base_length, 0.0)))

    def initial_velocity(self):
        return initial_velocity(self.initial.velocity, self.geometry.height,
                                self.initial.surface_speed)

    def extent(self, x):
        return top_extent(x)

    def write_msh(self, path: Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        g = self.geometry
        write_layer_msh(path, g.base_length, g.height, g.mesh_size)
        return path
