"""A dam break on a step: a rectangular column released on a plateau that ends in a step down.

Slope coordinates, the lower bed y = 0. The plateau y = s runs from the wall x = 0 to its
edge x = x_e (``geometry.plateau_length``), where the bed drops by the step's height s
(``geometry.step_height``) to the lower bed; the column [0, L] × [s, s + H] (L
``geometry.base_length`` ≤ x_e, H ``geometry.height``) stands on the plateau against the
wall. Released at rest, the mass spreads along the plateau, falls over the edge and lands on
the lower bed. Boundaries: the bed (``boundary.bed_condition``: Coulomb μ_b or no slip, the
plateau and, after landing, the lower bed), the wall x = 0 (Coulomb μ_l; frictionless slip
when μ_l = 0), the free surface. The rigid bed under the mass is

    b(x) = s  for x ≤ x_e,   b(x) = 0  for x > x_e          (``bed_height``)

on which the moving mesh lands a falling nose and from which a bed node sliding past the edge
takes off (``ale.motion``). The step's face x = x_e, 0 < y < s, is not a side of the mesh:
no node may enter the step (the system test measures it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dpcollapse.geometry.mesher import BED, SURFACE, WALL
from dpcollapse.scenes.base import Boundary, PolygonScene, initial_velocity, top_extent, walled_boundaries


@dataclass(frozen=True)
class DamBreakStepScene(PolygonScene):
    """Holds ``config.geometry.DamBreakStepGeometry`` (H, L, x_e, s, mesh sizes), the
    boundary and initial sections (``SceneSections``); it starts at rest."""

    shape = "dambreak_step"

    def polygon(self):
        """CCW vertices and edge tags of the column on the plateau: bed, right side and top
        (free surface), wall."""
        g = self.geometry
        s, top = g.step_height, g.step_height + g.height
        points = np.array([[0.0, s], [g.base_length, s], [g.base_length, top], [0.0, top]])
        return points, np.array([BED, SURFACE, SURFACE, WALL], dtype=np.int32)

    def bed_height(self, x):
        """b(x) = s on the plateau x ≤ x_e, 0 beyond the step."""
        g = self.geometry
        return np.where(np.asarray(x, dtype=float) <= g.plateau_length, float(g.step_height), 0.0)

    def boundaries(self) -> tuple[Boundary, ...]:
        b = self.boundary
        return walled_boundaries(b.bed_condition, b.mu_bed, b.mu_wall)

    def initial_velocity(self):
        return initial_velocity("rest", self.geometry.height, 0.0)

    def extent(self, x):
        return top_extent(x)
