"""The trapezoid of the rigid-bed collapse released on an erodible layer (seed 000, case II).

The layer [0, L] × [0, h_e] of the same material (its right end a slope at
``geometry.layer_end_angle``) lies on the rigid bed; the trapezoid of
``scenes.trapezoid`` stands on it (``geometry.erodible``). Two material regions as cell tags
(DOMAIN the mass, LAYER the layer) in one conforming mesh. Boundaries: the bed y = 0 under
the layer (``boundary.bed_condition``: Coulomb μ_b or no slip), the wall x = 0 along both
(Coulomb μ_l), the free surface (flank, top, and the layer's top where the mass does not
cover it, and the layer's right end x = L). Seed 000 adds its local surface tension on the
free surface (``boundary.surface_tension``).

Front: the furthest x of the nodes more than 2 h_e above the bed, i.e. where the mass stands
at least h_e above the initial layer top (the layer's own end stays at x = L).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dpcollapse.geometry.erodible import erodible_regions
from dpcollapse.geometry.mesher import (
    TaggedMesh,
    mesh_regions,
    read_msh,
    write_regions_msh,
)
from dpcollapse.geometry.mesher import BED
from dpcollapse.scenes.base import (
    Boundary,
    Container,
    bed_boundary,
    box_container,
    box_wall,
    initial_velocity,
    open_box_boundaries,
    walled_boundaries,
)

#: fronts count the nodes (cells) more than FRONT_FLOOR h_e above the bed
FRONT_FLOOR = 2.0


@dataclass(frozen=True)
class ErodibleScene:
    shape = "erodible"

    height: float
    base_length: float
    flank_angle: float
    layer_thickness: float
    layer_length: float
    layer_end_angle: float
    mesh_size: float
    surface_mesh_size: float | None
    mesh_file: Path | None
    bed_condition: str
    mu_bed: float
    mu_wall: float
    velocity: str = "rest"
    surface_speed: float = 0.0

    @classmethod
    def from_config(cls, cfg) -> ErodibleScene:
        g, b = cfg.geometry, cfg.boundary
        return cls(g.height, g.base_length, g.flank_angle, g.layer_thickness, g.layer_length,
                   g.layer_end_angle, g.mesh_size, g.surface_mesh_size, g.mesh_file, b.bed_condition, b.mu_bed,
                   b.mu_wall, cfg.initial.velocity, cfg.initial.surface_speed)

    def regions(self):
        return erodible_regions(self.height, self.base_length, self.flank_angle,
                                self.layer_thickness, self.layer_length, self.layer_end_angle)

    def mesh(self, comm) -> TaggedMesh:
        if self.mesh_file:
            return read_msh(comm, self.mesh_file)
        regions = self.regions() if comm.rank == 0 else None
        return mesh_regions(comm, regions, self.mesh_size, self.surface_mesh_size)

    def write_msh(self, path: Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_regions_msh(path, self.regions(), self.mesh_size, self.surface_mesh_size)
        return path

    def boundaries(self) -> tuple[Boundary, ...]:
        return walled_boundaries(self.bed_condition, self.mu_bed, self.mu_wall)

    def container(self, box) -> Container:
        """The layer and the mass on it in the box; the wall x = 0 (``box_wall``)."""
        (layer, _, _), (mass, _, _) = self.regions()
        return box_container(*box, open_box_boundaries(
            bed_boundary(BED, self.bed_condition, self.mu_bed), box_wall(self.mu_wall)), (layer, mass),
            bed_layer=layer, front_floor=FRONT_FLOOR * self.layer_thickness)

    def initial_velocity(self):
        return initial_velocity(self.velocity, self.height + self.layer_thickness,
                                self.surface_speed)

    def extent(self, x):
        """(front, maximum height): the furthest x of the nodes above 2 h_e, the highest y."""
        if not len(x):
            return -np.inf, -np.inf
        above = x[x[:, 1] > FRONT_FLOOR * self.layer_thickness]
        front = float(above[:, 0].max()) if len(above) else -np.inf
        return front, float(x[:, 1].max())
