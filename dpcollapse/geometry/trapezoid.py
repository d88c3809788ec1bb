"""The trapezoidal granular mass of seed 000 over a rigid bed, in slope coordinates.

Vertices (0, 0), (l0, 0), (l0 − h0 / tan α0, h0), (0, h0): left wall x = 0, bed y = 0,
base length l0 from the wall to the toe, and the right flank rising at angle α0 back
over the mass (our reading of seed 000; see shared/reference/README.md). Edges are tagged
bed, free surface (flank and top) and wall.
"""

from __future__ import annotations

import math

import numpy as np

from dpcollapse.geometry.mesher import BED, SURFACE, WALL


def trapezoid_polygon(height: float, base_length: float, flank_angle_deg: float):
    """CCW vertices and edge tags of the trapezoid (edge i joins vertex i and i+1)."""
    top = base_length - height / math.tan(math.radians(flank_angle_deg))
    points = np.array([[0.0, 0.0], [base_length, 0.0], [top, height], [0.0, height]])
    tags = np.array([BED, SURFACE, SURFACE, WALL], dtype=np.int32)
    return points, tags
