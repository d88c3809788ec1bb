"""A rectangular granular column against a frictionless symmetry wall (column collapse).

The half column [0, L0] × [0, H0] of a column of width 2 L0 (slope coordinates): the
symmetry plane x = 0 is a frictionless wall (u·n = 0, no tangential stress), the bed
y = 0 has the condition of ``boundary.bed_condition`` (Coulomb friction μ_b or no slip),
the right side and the top are the free surface. Aspect ratio a = H0/L0; the runout
scales as ΔL/L0 ∝ a for a ≲ 3 and a^(2/3) above (seed 003).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dpcollapse.geometry.mesher import (
    BED,
    LEFT,
    SURFACE,
    WALL,
)
from dpcollapse.scenes.base import (
    Boundary,
    BoundaryKind,
    Container,
    PolygonScene,
    box_container,
    open_box_boundaries,
    bed_boundary,
    initial_velocity,
    top_extent,
)


@dataclass(frozen=True)
class ColumnScene(PolygonScene):
    shape = "column"

    height: float
    half_width: float
    mesh_size: float
    surface_mesh_size: float | None
    mesh_file: Path | None
    bed_condition: str
    mu_bed: float
    velocity: str = "rest"
    surface_speed: float = 0.0

    @classmethod
    def from_config(cls, cfg) -> ColumnScene:
        g, b = cfg.geometry, cfg.boundary
        return cls(g.height, g.base_length, g.mesh_size, g.surface_mesh_size, g.mesh_file,
                   b.bed_condition, b.mu_bed, cfg.initial.velocity, cfg.initial.surface_speed)

    def polygon(self):
        """CCW vertices and edge tags: bed, right side and top (free surface), symmetry wall."""
        points = np.array([[0.0, 0.0], [self.half_width, 0.0], [self.half_width, self.height],
                           [0.0, self.height]])
        return points, np.array([BED, SURFACE, SURFACE, WALL], dtype=np.int32)

    def boundaries(self) -> tuple[Boundary, ...]:
        return (bed_boundary(BED, self.bed_condition, self.mu_bed),
                Boundary(WALL, "symmetry", BoundaryKind.SLIP, (-1.0, 0.0)),
                Boundary(SURFACE, "surface", BoundaryKind.FREE_SURFACE))

    def container(self, box) -> Container:
        """The column [0, L0] × [0, H0] in the box, the symmetry plane x = 0 (slip)."""
        region = np.array([[0.0, 0.0], [self.half_width, 0.0], [self.half_width, self.height],
                           [0.0, self.height]])
        return box_container(*box, open_box_boundaries(
            bed_boundary(BED, self.bed_condition, self.mu_bed),
            Boundary(LEFT, "symmetry", BoundaryKind.SLIP, (-1.0, 0.0))), (region,))

    def initial_velocity(self):
        return initial_velocity(self.velocity, self.height, self.surface_speed)

    def extent(self, x):
        return top_extent(x)
