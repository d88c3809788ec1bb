"""The trapezoidal mass of seed 000 against a left wall, on a rigid bed (slope coordinates).

Vertices (0, 0), (l0, 0), (l0 − h0/tan α0, h0), (0, h0). Boundaries: the bed y = 0
(Coulomb friction μ_b or no slip), the free surface (flank and top) and the wall x = 0
(Coulomb friction μ_l; frictionless slip when μ_l = 0). ``geometry.mesh_file`` replaces the
meshed trapezoid by a gmsh file with the same physical tags.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.scenes.base import (
    Boundary,
    Container,
    PolygonScene,
    box_container,
    box_wall,
    initial_velocity,
    open_box_boundaries,
    top_extent,
    walled_boundaries,
)


def trapezoid_polygon(height: float, base_length: float, flank_angle_deg: float):
    """CCW vertices and edge tags of the trapezoid (edge i joins vertex i and i+1): bed, free
    surface (flank and top) and wall. The right flank rises at angle α0 back over the mass
    (our reading of seed 000; see shared/reference/README.md)."""
    top = base_length - height / math.tan(math.radians(flank_angle_deg))
    points = np.array([[0.0, 0.0], [base_length, 0.0], [top, height], [0.0, height]])
    tags = np.array([BED, SURFACE, SURFACE, WALL], dtype=np.int32)
    return points, tags

@dataclass(frozen=True)
class TrapezoidScene(PolygonScene):
    """Holds ``config.geometry.TrapezoidGeometry`` (h0, l0, α0, mesh sizes, mesh_file), the
    boundary and initial sections (``SceneSections``)."""

    shape = "trapezoid"

    def polygon(self):
        g = self.geometry
        return trapezoid_polygon(g.height, g.base_length, g.flank_angle)

    def boundaries(self) -> tuple[Boundary, ...]:
        b = self.boundary
        return walled_boundaries(b.bed_condition, b.mu_bed, b.mu_wall)

    def container(self, box) -> Container:
        """The trapezoid in the box (two-phase model): the bed y = 0, the wall x = 0
        (``box_wall``)."""
        region = np.asarray(self.polygon()[0], dtype=float)   # convex, counter-clockwise
        return box_container(*box, open_box_boundaries(self.bed(), box_wall(self.boundary.mu_wall)),
                             (region,))

    def initial_velocity(self):
        return initial_velocity(self.initial.velocity, self.geometry.height,
                                self.initial.surface_speed)

    def extent(self, x):
        return top_extent(x)
