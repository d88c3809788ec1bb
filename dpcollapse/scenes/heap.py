"""Half of a symmetric triangular heap on the bed (heap spreading).

The right triangle (0, 0), (L0, 0), (0, H0) in slope coordinates: the axis of the heap x = 0
is a frictionless symmetry wall (u·n = 0, no tangential stress), the bed y = 0 has the
condition of ``boundary.bed_condition`` (Coulomb friction μ_b or no slip), the flank is the
free surface, at the angle β = atan(H0/L0) to the bed. A heap steeper than the material's
friction angle φ spreads; one below it stands (Drucker–Prager: the flank at rest holds while
tan β < tan φ, the infinite-slope limit).

The scene holds its config section (``HeapGeometry``) instead of copying its keys.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.scenes.base import (
    Boundary,
    BoundaryKind,
    PolygonScene,
    initial_velocity,
    top_extent,
)


@dataclass(frozen=True)
class HeapScene(PolygonScene):
    """Holds ``config.geometry.HeapGeometry`` (height, base_length, mesh sizes, mesh_file),
    the boundary and initial sections (``SceneSections``); it starts at rest."""

    shape = "heap"

    def polygon(self):
        """CCW vertices and edge tags: bed, flank (free surface), symmetry axis."""
        g = self.geometry
        points = np.array([[0.0, 0.0], [g.base_length, 0.0], [0.0, g.height]])
        return points, np.array([BED, SURFACE, WALL], dtype=np.int32)

    def boundaries(self) -> tuple[Boundary, ...]:
        return (self.bed(),
                Boundary(WALL, "symmetry", BoundaryKind.SLIP, (-1.0, 0.0)),
                Boundary(SURFACE, "surface", BoundaryKind.FREE_SURFACE))

    def initial_velocity(self):
        return initial_velocity("rest", self.geometry.height, 0.0)

    def extent(self, x):
        return top_extent(x)
