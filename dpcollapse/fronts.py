"""The front of a deposit: one definition for every model and every report (issue 50).

The runout is read at a stated thickness h_f from the deposit's thickness profile h(x),
piecewise linear through the points (x_i, h_i) (the depth-averaged cells' centres, the
two-phase model's columns of cells, the stored profiles of the ladder)::

    x_f = x_i + (h_i − h_f) / (h_i − h_{i+1}) (x_{i+1} − x_i),   i the last point with h_i ≥ h_f

(x_f = x_i when i is the last point). The moving mesh reads the same definition on its
boundary polygon, whose h(x) is exactly piecewise linear (``scenes.base.thickness_front``).
The stated thickness (``front_thickness``) is max(3 d, ΔX/4): a few grains (μ(I), d the grain
diameter; a thinner layer is not a continuum) or a quarter of the cell (Drucker–Prager,
d = 0; a thinner layer is not resolved). A comparison of two models states one h_f for
both (the coarser model's, or a fixed one such as the ladder's 1 mm). Beside it each model
keeps its own extent: the two-phase mass front (cells with c > ½), the moving mesh's largest x.
"""

from __future__ import annotations

import math

import numpy as np

#: h_f = max(FILM_GRAINS · d, FILM_MESH_FRACTION · ΔX)
FILM_GRAINS = 3.0
FILM_MESH_FRACTION = 0.25


def front_thickness(grain_diameter: float, cell: float) -> float:
    """The stated thickness h_f [m] at which a runout is read: max(3 d, ΔX/4)."""
    return max(FILM_GRAINS * grain_diameter, FILM_MESH_FRACTION * cell)


def profile_front(x, h, thickness: float) -> float:
    """x_f [m]: the largest x where the profile through (x_i, h_i) (x increasing) reaches
    ``thickness``, linear to the next point; NaN where h < thickness everywhere."""
    x, h = np.asarray(x, dtype=float), np.asarray(h, dtype=float)
    above = np.flatnonzero(h >= thickness)
    if not above.size:
        return math.nan
    i = int(above[-1])
    if i + 1 >= h.size:
        return float(x[i])
    return float(x[i] + (h[i] - thickness) / (h[i] - h[i + 1]) * (x[i + 1] - x[i]))
