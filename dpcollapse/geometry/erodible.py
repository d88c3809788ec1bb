"""The trapezoid of seed 000 on an erodible layer of the same material (case II).

Two regions, CCW, edge i from vertex i to i + 1 (slope coordinates, wall x = 0, bed y = 0):

    layer  (0, 0) → (L, 0) → (L, h_e) → (l0, h_e) → (0, h_e)           [cell tag LAYER]
           bed      right end  layer top  interface  wall
    mass   (0, h_e) → (l0, h_e) → (l0 − h0/tan α0, h_e + h0) → (0, h_e + h0)   [DOMAIN]
           interface  flank       top                          wall

L the layer length (our reading of seed 000's l0 = 80 cm of case II: the layer runs from the
wall to x = L), h_e its thickness; the trapezoid is the rigid case's (h0, l0, α0) standing
on the layer. The interface y = h_e, 0 ≤ x ≤ l0, is shared by both regions (interior edges,
tag INTERFACE): one conforming mesh. The layer's right end carries its own tag (RIGHT), a
free surface like the rest, so that the 90° corner at its top is a corner of the tagged
boundary and not a node of the free-surface polyline whose curvature seed 000's local
surface tension looks at.
"""

from __future__ import annotations

import math

import numpy as np

from dpcollapse.geometry.mesher import BED, DOMAIN, INTERFACE, LAYER, RIGHT, SURFACE, WALL


def erodible_regions(height: float, base_length: float, flank_angle_deg: float,
                     layer_thickness: float, layer_length: float):
    """[(points, edge tags, cell tag)] of the layer and the mass (``mesher.mesh_regions``)."""
    he, l0, L = layer_thickness, base_length, layer_length
    top = l0 - height / math.tan(math.radians(flank_angle_deg))
    layer = (np.array([[0.0, 0.0], [L, 0.0], [L, he], [l0, he], [0.0, he]]),
             np.array([BED, RIGHT, SURFACE, INTERFACE, WALL], dtype=np.int32), LAYER)
    mass = (np.array([[0.0, he], [l0, he], [top, he + height], [0.0, he + height]]),
            np.array([INTERFACE, SURFACE, SURFACE, WALL], dtype=np.int32), DOMAIN)
    return [layer, mass]
