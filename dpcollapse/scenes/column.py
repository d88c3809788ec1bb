"""A rectangular granular column against a frictionless symmetry wall (column collapse).

The half column [0, L0] × [0, H0] of a column of width 2 L0 (slope coordinates): the
symmetry plane x = 0 is a frictionless wall (u·n = 0, no tangential stress), the bed
y = 0 has the condition of ``boundary.bed_condition`` (Coulomb friction μ_b or no slip),
the right side and the top are the free surface. Aspect ratio a = H0/L0; the runout
scales as ΔL/L0 ∝ a for a ≲ 3 and a^(2/3) above (seed 003).
"""

from __future__ import annotations

from dataclasses import dataclass

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
    initial_velocity,
    open_box_boundaries,
    top_extent,
)


@dataclass(frozen=True)
class ColumnScene(PolygonScene):
    """Holds ``config.geometry.ColumnGeometry`` (height H0, half-width ``base_length`` L0),
    the boundary and initial sections (``SceneSections``)."""

    shape = "column"

    def rectangle(self) -> np.ndarray:
        """The column [0, L0] × [0, H0], counter-clockwise from the origin."""
        g = self.geometry
        return np.array([[0.0, 0.0], [g.base_length, 0.0], [g.base_length, g.height],
                         [0.0, g.height]])

    def polygon(self):
        """CCW vertices and edge tags: bed, right side and top (free surface), symmetry wall."""
        return self.rectangle(), np.array([BED, SURFACE, SURFACE, WALL], dtype=np.int32)

    def boundaries(self) -> tuple[Boundary, ...]:
        return (self.bed(),
                Boundary(WALL, "symmetry", BoundaryKind.SLIP, (-1.0, 0.0)),
                Boundary(SURFACE, "surface", BoundaryKind.FREE_SURFACE))

    def container(self, box) -> Container:
        """The column [0, L0] × [0, H0] in the box, the symmetry plane x = 0 (slip)."""
        return box_container(*box, open_box_boundaries(
            self.bed(), Boundary(LEFT, "symmetry", BoundaryKind.SLIP, (-1.0, 0.0))),
            (self.rectangle(),))

    def initial_velocity(self):
        return initial_velocity(self.initial.velocity, self.geometry.height,
                                self.initial.surface_speed)

    def extent(self, x):
        return top_extent(x)
