"""Initial thickness profiles from the 2D scenes' polygons (exact cell averages).

A 2D scene (x along the bed, y normal to it) gives the mass as a simple polygon resting on the bed.
Its thickness at x is the length of the vertical line's intersection with the polygon. With the
vertices ordered counter-clockwise, an edge running towards −x lies on a top side and one running
towards +x on a bottom side, so

    T(x) = Σ_edges −sign(Δx_e) y_e(x) [x in the edge's x-range]

(integrating gives the shoelace area). Each term is linear on its range, so the average over a
cell [x_l, x_r] is exact: Σ −sign(Δx_e) · overlap length · y_e(overlap midpoint) / Δx. The mass
Σ T_i Δx then equals the polygon's area to round-off when the polygon lies inside the grid.
"""

from __future__ import annotations

import numpy as np

from dpcollapse.models.savage_hutter.solver import Grid

__all__ = ["polygon_area", "polygon_cell_averages"]


def polygon_area(vertices) -> float:
    """Signed shoelace area [m²] (> 0 for counter-clockwise vertices)."""
    v = np.asarray(vertices, dtype=float)
    x, y = v[:, 0], v[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def polygon_cell_averages(vertices, grid: Grid) -> np.ndarray:
    """Exact cell averages of the thickness of a simple polygon (any orientation) [m]."""
    v = np.asarray(vertices, dtype=float)
    if polygon_area(v) < 0:
        v = v[::-1]
    a, b = v, np.roll(v, -1, axis=0)
    dx_e = b[:, 0] - a[:, 0]
    keep = dx_e != 0.0                       # vertical edges add nothing
    a, b, dx_e = a[keep], b[keep], dx_e[keep]
    lo = np.minimum(a[:, 0], b[:, 0])[:, None]
    hi = np.maximum(a[:, 0], b[:, 0])[:, None]
    edges = grid.edges
    left = np.maximum(lo, edges[None, :-1])
    right = np.minimum(hi, edges[None, 1:])
    overlap = np.maximum(right - left, 0.0)
    mid = 0.5 * (left + right)
    slope = ((b[:, 1] - a[:, 1]) / dx_e)[:, None]
    y_mid = a[:, 1][:, None] + slope * (mid - a[:, 0][:, None])
    sign = -np.sign(dx_e)[:, None]
    return np.sum(sign * overlap * y_mid, axis=0) / grid.dx
