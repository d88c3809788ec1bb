"""A layer of thickness h on an inclined plane, periodic in x (seed 000, case a).

[0, L] × [0, h] in slope coordinates: the bed y = 0 (no slip or Coulomb friction), the
free surface y = h, and the periodic sides x = 0 (master) and x = L (slave, shifted by
(−L, 0) onto the master). A fixed domain.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from dpcollapse.geometry.layer import layer_mesh, write_layer_msh
from dpcollapse.geometry.mesher import BED, LEFT, RIGHT, SURFACE, TaggedMesh, read_msh
from dpcollapse.scenes.base import (
    Boundary,
    BoundaryKind,
    bed_boundary,
    initial_velocity,
    top_extent,
)


@dataclass(frozen=True)
class LayerScene:
    shape = "layer"

    thickness: float
    length: float
    mesh_size: float
    mesh_file: Path | None
    bed_condition: str
    mu_bed: float
    velocity: str = "rest"
    surface_speed: float = 0.0

    @classmethod
    def from_config(cls, cfg) -> LayerScene:
        g, b = cfg.geometry, cfg.boundary
        return cls(g.height, g.base_length, g.mesh_size, g.mesh_file, b.bed_condition, b.mu_bed,
                   cfg.initial.velocity, cfg.initial.surface_speed)

    def mesh(self, comm) -> TaggedMesh:
        if self.mesh_file:
            return read_msh(comm, self.mesh_file)
        return layer_mesh(comm, self.length, self.thickness, self.mesh_size)

    def boundaries(self) -> tuple[Boundary, ...]:
        return (bed_boundary(BED, self.bed_condition, self.mu_bed),
                Boundary(SURFACE, "surface", BoundaryKind.FREE_SURFACE),
                Boundary(LEFT, "left", BoundaryKind.PERIODIC, (-1.0, 0.0)),
                Boundary(RIGHT, "right", BoundaryKind.PERIODIC, (1.0, 0.0),
                         translation=(-self.length, 0.0)))

    def initial_velocity(self):
        return initial_velocity(self.velocity, self.thickness, self.surface_speed)

    def extent(self, x):
        return top_extent(x)

    def write_msh(self, path: Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_layer_msh(path, self.length, self.thickness, self.mesh_size)
        return path
