"""The trapezoid of the rigid-bed collapse released on an erodible layer (seed 000, case II).

The layer [0, L] × [0, h_e] of the same material (its right end a slope at
``geometry.layer_end_angle``) lies on the rigid bed; the trapezoid of
``scenes.trapezoid`` stands on it (``erodible_regions``). Two material regions as cell tags
(DOMAIN the mass, LAYER the layer) in one conforming mesh. Boundaries: the bed y = 0 under
the layer (``boundary.bed_condition``: Coulomb μ_b or no slip), the wall x = 0 along both
(Coulomb μ_l), the free surface (flank, top, and the layer's top where the mass does not
cover it, and the layer's right end x = L). Seed 000 adds its local surface tension on the
free surface (``boundary.surface_tension``).

Front: the furthest x of the nodes more than 2 h_e above the bed, i.e. where the mass stands
at least h_e above the initial layer top (the layer's own end stays at x = L).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dpcollapse.geometry.mesher import (
    BED,
    DOMAIN,
    INTERFACE,
    LAYER,
    SURFACE,
    WALL,
    TaggedMesh,
    mesh_regions,
    read_msh,
    write_regions_msh,
)
from dpcollapse.scenes.base import (
    Boundary,
    Container,
    SceneSections,
    box_container,
    box_wall,
    initial_velocity,
    open_box_boundaries,
    walled_boundaries,
)

#: fronts count the nodes (cells) more than FRONT_FLOOR h_e above the bed
FRONT_FLOOR = 2.0


def erodible_regions(height: float, base_length: float, flank_angle_deg: float,
                     layer_thickness: float, layer_length: float, layer_end_angle_deg: float):
    """[(points, edge tags, cell tag)] of the layer and the mass (``mesher.mesh_regions``).

    Two regions, CCW, edge i from vertex i to i + 1 (slope coordinates, wall x = 0, bed y = 0):

        layer  (0, 0) → (L, 0) → (L − h_e/tan φ_e, h_e) → (l0, h_e) → (0, h_e)   [cell tag LAYER]
               bed      right end         layer top     interface  wall  (end, top: free surface)
        mass   (0, h_e) → (l0, h_e) → (l0 − h0/tan α0, h_e + h0) → (0, h_e + h0)   [DOMAIN]
               interface  flank       top                          wall

    L the layer length (our reading of seed 000's l0 = 80 cm of case II: the layer runs from the
    wall to x = L along the bed), h_e its thickness, φ_e the slope of its end (a cohesionless
    layer cannot end in a vertical face: it ends at its angle of repose, the material's friction
    angle by default — a vertical end slumps at once, and its 90° corner was the free surface's
    largest curvature, where seed 000's surface tension then stayed instead of at the fold); the
    trapezoid is the rigid case's (h0, l0, α0) standing on the layer. The interface y = h_e,
    0 ≤ x ≤ l0, is shared by both regions (interior edges, tag INTERFACE): one conforming mesh.
    The layer's right end is free surface like its top (tag SURFACE): the mesh motion keeps
    SURFACE nodes from crossing the bed and lands them on it (``ale.motion``), and no other
    tag's — with a tag of its own the slumping end of the layer went through the bed
    (measured: y = −5.8 mm at t = 0.30 s).
    """
    he, l0, L = layer_thickness, base_length, layer_length
    top = l0 - height / math.tan(math.radians(flank_angle_deg))
    end = L - he / math.tan(math.radians(layer_end_angle_deg))
    layer = (np.array([[0.0, 0.0], [L, 0.0], [end, he], [l0, he], [0.0, he]]),
             np.array([BED, SURFACE, SURFACE, INTERFACE, WALL], dtype=np.int32), LAYER)
    mass = (np.array([[0.0, he], [l0, he], [top, he + height], [0.0, he + height]]),
            np.array([INTERFACE, SURFACE, SURFACE, WALL], dtype=np.int32), DOMAIN)
    return [layer, mass]

@dataclass(frozen=True)
class ErodibleScene(SceneSections):
    """Holds ``config.geometry.ErodibleGeometry`` (the trapezoid's h0, l0, α0 and the layer's
    h_e, L, φ_e), the boundary and initial sections (``SceneSections``)."""

    shape = "erodible"

    def regions(self):
        g = self.geometry
        return erodible_regions(g.height, g.base_length, g.flank_angle, g.layer_thickness,
                                g.layer_length, g.layer_end_angle)

    def mesh(self, comm) -> TaggedMesh:
        g = self.geometry
        if g.mesh_file:
            return read_msh(comm, g.mesh_file)
        regions = self.regions() if comm.rank == 0 else None
        return mesh_regions(comm, regions, g.mesh_size, g.surface_mesh_size)

    def write_msh(self, path: Path) -> Path:
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        write_regions_msh(path, self.regions(), self.geometry.mesh_size,
                          self.geometry.surface_mesh_size)
        return path

    def boundaries(self) -> tuple[Boundary, ...]:
        b = self.boundary
        return walled_boundaries(b.bed_condition, b.mu_bed, b.mu_wall)

    def container(self, box) -> Container:
        """The layer and the mass on it in the box; the wall x = 0 (``box_wall``)."""
        (layer, _, _), (mass, _, _) = self.regions()
        return box_container(*box, open_box_boundaries(self.bed(), box_wall(self.boundary.mu_wall)),
                             (layer, mass), bed_layer=layer,
                             front_floor=FRONT_FLOOR * self.geometry.layer_thickness)

    def initial_velocity(self):
        return initial_velocity(self.initial.velocity,
                                self.geometry.height + self.geometry.layer_thickness,
                                self.initial.surface_speed)

    def extent(self, x):
        """(front, maximum height): the furthest x of the nodes above 2 h_e, the highest y."""
        if not len(x):
            return -np.inf, -np.inf
        above = x[x[:, 1] > FRONT_FLOOR * self.geometry.layer_thickness]
        front = float(above[:, 0].max()) if len(above) else -np.inf
        return front, float(x[:, 1].max())
