"""The trapezoid of seed 000 on an erodible layer of the same material (case II).

Two regions, CCW, edge i from vertex i to i + 1 (slope coordinates, wall x = 0, bed y = 0):

    layer  (0, 0) → (L, 0) → (L − h_e/tan φ_e, h_e) → (l0, h_e) → (0, h_e)   [cell tag LAYER]
           bed      right end         layer top     interface  wall  (end, top: free surface)
    mass   (0, h_e) → (l0, h_e) → (l0 − h0/tan α0, h_e + h0) → (0, h_e + h0)   [DOMAIN]
           interface  flank       top                          wall

L the layer length (our reading of seed 000's l0 = 80 cm of case II: the layer runs from the
wall to x = L along the bed), h_e its thickness, φ_e the slope of its end (a cohesionless
layer cannot end in a vertical face: it ends at its angle of repose, the material's friction
angle by default — a vertical end slumps at once, and its 90° corner was the free surface's
largest curvature, where seed 000's surface tension then stayed instead of at the fold); the trapezoid is the rigid case's (h0, l0, α0) standing
on the layer. The interface y = h_e, 0 ≤ x ≤ l0, is shared by both regions (interior edges,
tag INTERFACE): one conforming mesh. The layer's right end is free surface like its top (tag
SURFACE): the mesh motion keeps SURFACE nodes from crossing the bed and lands them on it
(``ale.motion``), and no other tag's — with a tag of its own the slumping end of the layer
went through the bed (measured: y = −5.8 mm at t = 0.30 s).
"""

from __future__ import annotations

import math

import numpy as np

from dpcollapse.geometry.mesher import BED, DOMAIN, INTERFACE, LAYER, SURFACE, WALL


def erodible_regions(height: float, base_length: float, flank_angle_deg: float,
                     layer_thickness: float, layer_length: float, layer_end_angle_deg: float):
    """[(points, edge tags, cell tag)] of the layer and the mass (``mesher.mesh_regions``)."""
    he, l0, L = layer_thickness, base_length, layer_length
    top = l0 - height / math.tan(math.radians(flank_angle_deg))
    end = L - he / math.tan(math.radians(layer_end_angle_deg))
    layer = (np.array([[0.0, 0.0], [L, 0.0], [end, he], [l0, he], [0.0, he]]),
             np.array([BED, SURFACE, SURFACE, INTERFACE, WALL], dtype=np.int32), LAYER)
    mass = (np.array([[0.0, he], [l0, he], [top, he + height], [0.0, he + height]]),
            np.array([INTERFACE, SURFACE, SURFACE, WALL], dtype=np.int32), DOMAIN)
    return [layer, mass]
